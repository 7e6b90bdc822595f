//! Thin PyO3 bindings of `scanmesh-core`: check shapes, convert numpy, release the GIL for
//! the work, map `scanmesh_core::Error` to the exception classes declared here. One file
//! per topic of the core (`triangulate`, `criteria`, `strips`, `optimize`, `exact`, `io`,
//! `fusion`, `progress`), numpy conversions in `convert`, the result classes in `results`.
#![deny(rustdoc::broken_intra_doc_links)]

use numpy::PyArray1;
use pyo3::create_exception;
use pyo3::exceptions::{PyKeyboardInterrupt, PyMemoryError, PyValueError};
use pyo3::prelude::*;
use pyo3::sync::PyOnceLock;
use pyo3::types::{PyDict, PyTuple, PyType};
use scanmesh_core::Error;

mod arena;
mod convert;
mod criteria;
mod exact;
mod fusion;
mod io;
mod optimize;
mod progress;
mod results;
mod simplify;
mod strips;
mod triangulate;

create_exception!(
    _core,
    ScanmeshError,
    PyValueError,
    "Base of every scanmesh input error (a ValueError)."
);
create_exception!(
    _core,
    DegenerateInputError,
    ScanmeshError,
    "Points that span no surface: too few, identical, collinear or non-finite."
);
create_exception!(
    _core,
    ParameterError,
    ScanmeshError,
    "An option outside its valid range."
);
create_exception!(
    _core,
    InvalidMeshError,
    ScanmeshError,
    "Faces that do not form a valid triangulation."
);

/// `MemoryLimitError`: a stage that needs more memory than the process may have, refused
/// before it runs or failed in an allocation. Both a `ScanmeshError` and a `MemoryError`
/// (two bases, which `create_exception!` cannot declare, so it is made once by `type`).
static MEMORY_LIMIT_ERROR: PyOnceLock<Py<PyType>> = PyOnceLock::new();

fn memory_limit_error(py: Python<'_>) -> PyResult<&Bound<'_, PyType>> {
    let class = MEMORY_LIMIT_ERROR.get_or_try_init(py, || -> PyResult<Py<PyType>> {
        let bases = PyTuple::new(
            py,
            [
                py.get_type::<ScanmeshError>(),
                py.get_type::<PyMemoryError>(),
            ],
        )?;
        let body = PyDict::new(py);
        body.set_item("__module__", "scanmesh._core")?;
        body.set_item(
            "__doc__",
            "A stage needs more memory than this process may have (its estimate, or an \
             allocation that failed); the message names the need and the limit. Also a \
             MemoryError.",
        )?;
        let made = py
            .get_type::<PyType>()
            .call1(("MemoryLimitError", bases, body))?;
        Ok(made.cast_into::<PyType>()?.unbind())
    })?;
    Ok(class.bind(py))
}

/// The one place where core errors become Python exceptions.
pub(crate) fn to_py(e: Error) -> PyErr {
    let msg = e.to_string();
    match e {
        Error::NonFinite { .. } | Error::TooFewPoints { .. } | Error::Collinear { .. } => {
            DegenerateInputError::new_err(msg)
        }
        Error::InvalidParameter { .. } | Error::TooCostly { .. } => ParameterError::new_err(msg),
        Error::InvalidFace { .. } | Error::Invariant(_) => InvalidMeshError::new_err(msg),
        Error::Interrupted => PyKeyboardInterrupt::new_err(msg),
        Error::OutOfMemory { .. } => Python::attach(|py| match memory_limit_error(py) {
            Ok(class) => PyErr::from_type(class.clone(), msg),
            Err(e) => e,
        }),
    }
}

/// `f()` with the GIL released, once the core's thread pool runs: it starts at the first
/// such call, with fewer workers where their stacks do not all fit, and a
/// `MemoryLimitError` naming the threads and the limit where none does (rayon's own start
/// panicked there, and the process hung). Every call into parallel work of the core goes
/// through here. O(1) after the first call.
pub(crate) fn detached<T: Send>(py: Python<'_>, f: impl FnOnce() -> T + Send) -> PyResult<T> {
    arena::share_arena_under_address_limit();
    scanmesh_core::pool::start_pool().map_err(to_py)?;
    Ok(py.detach(f))
}

/// The native core of scanmesh.
#[pymodule]
fn _core(m: &Bound<'_, PyModule>) -> PyResult<()> {
    let py = m.py();
    // rust-numpy imports NumPy's C API on its first use and panics when that import fails,
    // as it does when a Ctrl-C lands in the Python code it runs (seen in the first parse
    // of a read interrupted early): used here, at import, so no later call meets it.
    drop(PyArray1::<f64>::zeros(py, 0, false));
    m.add("ScanmeshError", py.get_type::<ScanmeshError>())?;
    m.add(
        "DegenerateInputError",
        py.get_type::<DegenerateInputError>(),
    )?;
    m.add("ParameterError", py.get_type::<ParameterError>())?;
    m.add("InvalidMeshError", py.get_type::<InvalidMeshError>())?;
    m.add("MemoryLimitError", memory_limit_error(py)?)?;
    m.add(
        "SLIVER_ANGLE_DEG",
        scanmesh_core::criteria::SLIVER_ANGLE_DEG,
    )?;
    m.add(
        "DEFAULT_MAX_EDGE_FACTOR",
        scanmesh_core::triangulate::DEFAULT_MAX_EDGE_FACTOR,
    )?;
    m.add(
        "DEFAULT_JUMP_FACTOR",
        scanmesh_core::triangulate::DEFAULT_JUMP_FACTOR,
    )?;
    m.add(
        "DEFAULT_BRIDGE_FACTOR",
        scanmesh_core::triangulate::DEFAULT_BRIDGE_FACTOR,
    )?;
    m.add(
        "DEFAULT_HOLE_FACTOR",
        scanmesh_core::triangulate::DEFAULT_HOLE_FACTOR,
    )?;
    m.add(
        "DEFAULT_GRID_TURN_DEG",
        scanmesh_core::triangulate::DEFAULT_GRID_TURN_DEG,
    )?;
    m.add(
        "DEFAULT_GRID_EDGE_FACTOR",
        scanmesh_core::triangulate::DEFAULT_GRID_EDGE_FACTOR,
    )?;
    m.add("JUMP_STEPS", scanmesh_core::fusion::JUMP_STEPS)?;
    m.add("BEHIND_VOXELS", scanmesh_core::fusion::BEHIND_VOXELS)?;
    m.add("MAX_MARGIN", scanmesh_core::fusion::MAX_MARGIN)?;
    m.add("MAX_TILES", scanmesh_core::optimize::MAX_TILES)?;
    m.add_function(wrap_pyfunction!(triangulate::project, m)?)?;
    m.add_function(wrap_pyfunction!(triangulate::delaunay, m)?)?;
    m.add_function(wrap_pyfunction!(triangulate::median_spacing, m)?)?;
    m.add_function(wrap_pyfunction!(triangulate::trim_long_edges, m)?)?;
    m.add_function(wrap_pyfunction!(triangulate::delaunay_trimmed, m)?)?;
    m.add_function(wrap_pyfunction!(triangulate::grid_triangulate, m)?)?;
    m.add_function(wrap_pyfunction!(triangulate::validate, m)?)?;
    m.add_function(wrap_pyfunction!(criteria::mesh_quality, m)?)?;
    m.add_function(wrap_pyfunction!(criteria::tac_norm, m)?)?;
    m.add_function(wrap_pyfunction!(criteria::steep_count, m)?)?;
    m.add(
        "DEFAULT_GAP_FACTOR",
        scanmesh_core::strips::DEFAULT_GAP_FACTOR,
    )?;
    m.add("DEFAULT_BAND", scanmesh_core::strips::fuchs::DEFAULT_BAND)?;
    m.add_function(wrap_pyfunction!(strips::detect_lines, m)?)?;
    m.add_function(wrap_pyfunction!(strips::scan_segments, m)?)?;
    m.add_function(wrap_pyfunction!(strips::strip_mesh, m)?)?;
    m.add_function(wrap_pyfunction!(strips::set_strip_filter, m)?)?;
    m.add_function(wrap_pyfunction!(strips::strip_filter_counts, m)?)?;
    m.add_function(wrap_pyfunction!(exact::empty_triangles, m)?)?;
    m.add_function(wrap_pyfunction!(exact::triangulations, m)?)?;
    m.add_function(wrap_pyfunction!(exact::cheapest_fans, m)?)?;
    m.add_function(wrap_pyfunction!(optimize::lop, m)?)?;
    m.add_function(wrap_pyfunction!(io::parse_text_table, m)?)?;
    m.add_function(wrap_pyfunction!(io::stl_records, m)?)?;
    m.add_function(wrap_pyfunction!(simplify::simplify, m)?)?;
    m.add_class::<optimize::AnnealParams>()?;
    m.add_class::<optimize::Annealer>()?;
    m.add_class::<fusion::DepthView>()?;
    m.add_class::<fusion::FusionVolume>()?;
    m.add_class::<progress::ProgressCounter>()?;
    m.add_class::<strips::StripParams>()?;
    m.add_class::<strips::ScanContext>()?;
    m.add_class::<results::ScanSegments>()?;
    m.add_class::<results::StripResult>()?;
    m.add_class::<results::AnnealOutcome>()?;
    m.add_class::<results::TrimmedDelaunay>()?;
    m.add_class::<results::GridTriangles>()?;
    m.add_class::<results::CheapestFans>()?;
    m.add_class::<results::TextTable>()?;
    m.add_class::<results::TextProblem>()?;
    Ok(())
}
