//! Thin PyO3 bindings of `scanmesh-core`: check shapes, convert numpy, release the GIL for
//! the work, map `scanmesh_core::Error` to the exception classes declared here.

use numpy::ndarray::{Array1, Array2};
use numpy::{IntoPyArray, PyArray1, PyArray2, PyReadonlyArray1, PyReadonlyArray2};
use pyo3::create_exception;
use pyo3::exceptions::{PyKeyboardInterrupt, PyValueError};
use pyo3::prelude::*;
use scanmesh_core::criteria::{self, Norm};
use scanmesh_core::delaunay::NONE;
use scanmesh_core::glam::DVec3;
use scanmesh_core::mesh::HalfEdgeMesh;
use scanmesh_core::projection::{self, Plane};
use scanmesh_core::{trim, Error};

create_exception!(_core, ScanmeshError, PyValueError, "Base of every scanmesh input error (a ValueError).");
create_exception!(_core, DegenerateInputError, ScanmeshError, "Points that span no surface: too few, identical, collinear or non-finite.");
create_exception!(_core, ParameterError, ScanmeshError, "An option outside its valid range.");
create_exception!(_core, InvalidMeshError, ScanmeshError, "Faces that do not form a valid triangulation.");

/// The one place where core errors become Python exceptions.
fn to_py(e: Error) -> PyErr {
    let msg = e.to_string();
    match e {
        Error::NonFinite { .. } | Error::TooFewPoints { .. } | Error::Collinear { .. } => DegenerateInputError::new_err(msg),
        Error::InvalidParameter { .. } => ParameterError::new_err(msg),
        Error::InvalidFace { .. } | Error::Invariant(_) => InvalidMeshError::new_err(msg),
        Error::Interrupted => PyKeyboardInterrupt::new_err(msg),
    }
}

fn shape_error(name: &str, expected: &str, shape: &[usize]) -> PyErr {
    ScanmeshError::new_err(format!("{name} must have shape {expected}, got {shape:?}"))
}

fn points3(a: &PyReadonlyArray2<'_, f64>) -> PyResult<Vec<DVec3>> {
    let v = a.as_array();
    if v.ncols() != 3 {
        return Err(shape_error("points", "(N, 3)", v.shape()));
    }
    Ok(v.rows().into_iter().map(|r| DVec3::new(r[0], r[1], r[2])).collect())
}

fn points2(a: &PyReadonlyArray2<'_, f64>) -> PyResult<Vec<[f64; 2]>> {
    let v = a.as_array();
    if v.ncols() != 2 {
        return Err(shape_error("uv", "(N, 2)", v.shape()));
    }
    Ok(v.rows().into_iter().map(|r| [r[0], r[1]]).collect())
}

fn faces(a: &PyReadonlyArray2<'_, i64>, n_vertices: usize) -> PyResult<Vec<[u32; 3]>> {
    let v = a.as_array();
    if v.ncols() != 3 {
        return Err(shape_error("faces", "(M, 3)", v.shape()));
    }
    let mut out = Vec::with_capacity(v.nrows());
    for (f, r) in v.rows().into_iter().enumerate() {
        let mut t = [0u32; 3];
        for k in 0..3 {
            let x = r[k];
            if x < 0 || x as u64 >= n_vertices as u64 {
                return Err(InvalidMeshError::new_err(format!(
                    "face {f}: vertex index {x} out of range (there are {n_vertices} vertices)"
                )));
            }
            t[k] = x as u32;
        }
        out.push(t);
    }
    Ok(out)
}

fn faces_out<'py>(py: Python<'py>, t: &[[u32; 3]]) -> Bound<'py, PyArray2<i64>> {
    let flat: Vec<i64> = t.iter().flat_map(|f| f.map(i64::from)).collect();
    Array2::from_shape_vec((t.len(), 3), flat).expect("3 per face").into_pyarray(py)
}

fn uv_out<'py>(py: Python<'py>, uv: &[[f64; 2]]) -> Bound<'py, PyArray2<f64>> {
    let flat: Vec<f64> = uv.iter().flatten().copied().collect();
    Array2::from_shape_vec((uv.len(), 2), flat).expect("2 per point").into_pyarray(py)
}

/// Projects (N, 3) points onto a plane. `plane` is "best-fit", "x", "y" or "z", or None
/// with `normal` a 3-vector. Returns (uv (N, 2), frame (4, 3): origin, u, v, normal).
#[pyfunction]
#[pyo3(signature = (points, plane, normal=None))]
fn project<'py>(
    py: Python<'py>,
    points: PyReadonlyArray2<'py, f64>,
    plane: Option<&str>,
    normal: Option<PyReadonlyArray1<'py, f64>>,
) -> PyResult<(Bound<'py, PyArray2<f64>>, Bound<'py, PyArray2<f64>>)> {
    let pts = points3(&points)?;
    let plane = match (plane, normal) {
        (Some("best-fit"), None) => Plane::BestFit,
        (Some("x"), None) => Plane::Axis(0),
        (Some("y"), None) => Plane::Axis(1),
        (Some("z"), None) => Plane::Axis(2),
        (None, Some(n)) => {
            let n = n.as_array();
            if n.len() != 3 {
                return Err(shape_error("normal", "(3,)", n.shape()));
            }
            Plane::Normal(DVec3::new(n[0], n[1], n[2]))
        }
        (p, _) => {
            return Err(ParameterError::new_err(format!(
                "plane must be 'best-fit', 'x', 'y', 'z' or a normal vector, got {p:?}"
            )))
        }
    };
    let p = py.detach(|| projection::project(&pts, plane)).map_err(to_py)?;
    let f = p.frame;
    let frame: Vec<f64> = [f.origin, f.u, f.v, f.normal].iter().flat_map(|v| v.to_array()).collect();
    Ok((uv_out(py, &p.uv), Array2::from_shape_vec((4, 3), frame).expect("4x3").into_pyarray(py)))
}

/// Delaunay triangulation of (N, 2) points. Returns (faces (M, 3) int64 counter-clockwise,
/// duplicate_of (N,) int64: -1, or the index of the earlier identical point standing in).
#[pyfunction]
fn delaunay<'py>(
    py: Python<'py>,
    uv: PyReadonlyArray2<'py, f64>,
) -> PyResult<(Bound<'py, PyArray2<i64>>, Bound<'py, PyArray1<i64>>)> {
    let pts = points2(&uv)?;
    let d = py.detach(|| scanmesh_core::delaunay::delaunay(&pts)).map_err(to_py)?;
    let dup: Vec<i64> = d.duplicate_of.iter().map(|&k| if k == NONE { -1 } else { i64::from(k) }).collect();
    Ok((faces_out(py, &d.triangles), Array1::from_vec(dup).into_pyarray(py)))
}

/// Median nearest-neighbour spacing of (N, 2) points along the edges of `faces`.
#[pyfunction]
fn median_spacing(uv: PyReadonlyArray2<'_, f64>, faces_: PyReadonlyArray2<'_, i64>) -> PyResult<f64> {
    let pts = points2(&uv)?;
    let t = faces(&faces_, pts.len())?;
    Ok(trim::median_spacing(&pts, &t))
}

/// Drops faces whose longest planar edge exceeds `max_edge`, then resolves pinches.
#[pyfunction]
fn trim_long_edges<'py>(
    py: Python<'py>,
    uv: PyReadonlyArray2<'py, f64>,
    faces_: PyReadonlyArray2<'py, i64>,
    max_edge: f64,
) -> PyResult<Bound<'py, PyArray2<i64>>> {
    if max_edge.is_nan() || max_edge <= 0.0 {
        return Err(ParameterError::new_err(format!("max_edge must be positive, got {max_edge}")));
    }
    let pts = points2(&uv)?;
    let t = faces(&faces_, pts.len())?;
    let kept = py.detach(|| trim::trim_long_edges(&pts, &t, max_edge)).map_err(to_py)?;
    Ok(faces_out(py, &kept))
}

/// Checks that `faces` form a valid planar triangulation of (N, 2) points; raises
/// InvalidMeshError naming the broken invariant.
#[pyfunction]
fn validate(py: Python<'_>, uv: PyReadonlyArray2<'_, f64>, faces_: PyReadonlyArray2<'_, i64>) -> PyResult<()> {
    let pts = points2(&uv)?;
    let t = faces(&faces_, pts.len())?;
    py.detach(|| HalfEdgeMesh::from_triangles(pts.len(), &t).and_then(|m| m.validate(&pts))).map_err(to_py)
}

/// 3-D quality of a mesh. Returns (tac (N,) with NaN off the interior, smallest angle per
/// face (M,) in radians).
#[pyfunction]
fn mesh_quality<'py>(
    py: Python<'py>,
    points: PyReadonlyArray2<'py, f64>,
    faces_: PyReadonlyArray2<'py, i64>,
) -> PyResult<(Bound<'py, PyArray1<f64>>, Bound<'py, PyArray1<f64>>)> {
    let pts = points3(&points)?;
    let t = faces(&faces_, pts.len())?;
    scanmesh_core::geometry::check_finite(&pts).map_err(to_py)?;
    let q = py.detach(|| criteria::quality(&pts, &t)).map_err(to_py)?;
    Ok((Array1::from_vec(q.tac).into_pyarray(py), Array1::from_vec(q.min_angle).into_pyarray(py)))
}

/// p-norm (p ≥ 1, or inf for the maximum) of the non-NaN entries of a vector.
#[pyfunction]
fn tac_norm(values: PyReadonlyArray1<'_, f64>, p: f64) -> PyResult<f64> {
    let norm = Norm::new(p).map_err(to_py)?;
    Ok(norm.of(values.as_slice()?))
}

/// Every empty triangle of (N, 2) pairwise distinct points: no other point in the closed
/// triangle, corners not collinear (exact predicates). Returns (T, 3) int64, counter-clockwise.
#[pyfunction]
fn empty_triangles<'py>(py: Python<'py>, uv: PyReadonlyArray2<'py, f64>) -> PyResult<Bound<'py, PyArray2<i64>>> {
    let pts = points2(&uv)?;
    let t = py.detach(|| scanmesh_core::enumerate::empty_triangles(&pts)).map_err(to_py)?;
    Ok(faces_out(py, &t))
}

/// Every triangulation of the convex hull of (N, 2) distinct points, by flips from `faces_`
/// (a triangulation using every point). Returns (K, M, 3) int64, each canonical; raises
/// ParameterError when there are more than `max_count`.
#[pyfunction]
fn triangulations<'py>(
    py: Python<'py>,
    uv: PyReadonlyArray2<'py, f64>,
    faces_: PyReadonlyArray2<'py, i64>,
    max_count: usize,
) -> PyResult<Bound<'py, numpy::PyArray3<i64>>> {
    let pts = points2(&uv)?;
    let t = faces(&faces_, pts.len())?;
    let all = py.detach(|| scanmesh_core::enumerate::triangulations(&pts, &t, max_count)).map_err(to_py)?;
    let flat: Vec<i64> = all.iter().flatten().flat_map(|f| f.map(i64::from)).collect();
    let shape = (all.len(), t.len(), 3);
    Ok(numpy::ndarray::Array3::from_shape_vec(shape, flat).expect("M per triangulation").into_pyarray(py))
}

/// The native core of scanmesh.
#[pymodule]
fn _core(m: &Bound<'_, PyModule>) -> PyResult<()> {
    let py = m.py();
    m.add("ScanmeshError", py.get_type::<ScanmeshError>())?;
    m.add("DegenerateInputError", py.get_type::<DegenerateInputError>())?;
    m.add("ParameterError", py.get_type::<ParameterError>())?;
    m.add("InvalidMeshError", py.get_type::<InvalidMeshError>())?;
    m.add("SLIVER_ANGLE_DEG", criteria::SLIVER_ANGLE_DEG)?;
    m.add("DEFAULT_MAX_EDGE_FACTOR", trim::DEFAULT_MAX_EDGE_FACTOR)?;
    m.add_function(wrap_pyfunction!(project, m)?)?;
    m.add_function(wrap_pyfunction!(delaunay, m)?)?;
    m.add_function(wrap_pyfunction!(median_spacing, m)?)?;
    m.add_function(wrap_pyfunction!(trim_long_edges, m)?)?;
    m.add_function(wrap_pyfunction!(validate, m)?)?;
    m.add_function(wrap_pyfunction!(mesh_quality, m)?)?;
    m.add_function(wrap_pyfunction!(tac_norm, m)?)?;
    m.add_function(wrap_pyfunction!(empty_triangles, m)?)?;
    m.add_function(wrap_pyfunction!(triangulations, m)?)?;
    Ok(())
}
