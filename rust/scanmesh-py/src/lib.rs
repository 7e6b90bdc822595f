//! Thin PyO3 bindings of `scanmesh-core`: check shapes, convert numpy, release the GIL for
//! the work, map `scanmesh_core::Error` to the exception classes declared here.

use numpy::ndarray::{Array1, Array2};
use numpy::{IntoPyArray, PyArray1, PyArray2, PyReadonlyArray1, PyReadonlyArray2};
use pyo3::create_exception;
use pyo3::exceptions::{PyKeyboardInterrupt, PyValueError};
use pyo3::prelude::*;
use rayon::prelude::*;
use scanmesh_core::glam::DVec3;
use scanmesh_core::{
    check_finite, parse_table, run_lop, stitch_part, tac_and_min_angles, AnnealParams, Ensemble,
    Error, HalfEdgeMesh, LopCriterion, Method, Norm, Plane, Relabel, ScanContext, Solver,
    StripMesh, StripParams, SweepRecord, Table, TacOrder, TacState, TextErrorKind, Weight, NONE,
};
use std::borrow::Cow;

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

/// numpy arrays handed to Python: (rows, cols) float64, (n,) float64, (rows, cols) int64, (n,) int64.
type Floats2<'py> = Bound<'py, PyArray2<f64>>;
type Floats1<'py> = Bound<'py, PyArray1<f64>>;
type Ints2<'py> = Bound<'py, PyArray2<i64>>;
type Ints1<'py> = Bound<'py, PyArray1<i64>>;

/// The one place where core errors become Python exceptions.
fn to_py(e: Error) -> PyErr {
    let msg = e.to_string();
    match e {
        Error::NonFinite { .. } | Error::TooFewPoints { .. } | Error::Collinear { .. } => {
            DegenerateInputError::new_err(msg)
        }
        Error::InvalidParameter { .. } | Error::TooCostly { .. } => ParameterError::new_err(msg),
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
    Ok(v.rows()
        .into_iter()
        .map(|r| DVec3::new(r[0], r[1], r[2]))
        .collect())
}

fn points2(a: &PyReadonlyArray2<'_, f64>) -> PyResult<Vec<[f64; 2]>> {
    let v = a.as_array();
    if v.ncols() != 2 {
        return Err(shape_error("uv", "(N, 2)", v.shape()));
    }
    Ok(v.rows().into_iter().map(|r| [r[0], r[1]]).collect())
}

/// `flat`, C-order rows of `size_of::<R>() / size_of::<T>()` values each, as a slice of
/// rows, without a copy (`slice::as_chunks` is newer than our MSRV). None when `R` is not a
/// whole number of `T`s, is more strictly aligned, or `flat` is not whole rows.
///
/// # Safety
/// `R` must consist of exactly those `T` values in order, no padding, every bit pattern
/// valid: `[T; K]`, or `DVec3` (`#[repr(C)]` x, y, z) for `T` = f64.
unsafe fn as_rows<T, R>(flat: &[T]) -> Option<&[R]> {
    let (row, value) = (std::mem::size_of::<R>(), std::mem::size_of::<T>());
    if value == 0 || row % value != 0 || std::mem::align_of::<R>() > std::mem::align_of::<T>() {
        return None;
    }
    let k = row / value;
    if k == 0 || flat.len() % k != 0 {
        return None;
    }
    // SAFETY: the caller guarantees R's layout is K values of T; `flat` is aligned for T
    // and so for R (checked), and holds len / K whole rows, borrowed for the same lifetime.
    Some(unsafe { std::slice::from_raw_parts(flat.as_ptr().cast::<R>(), flat.len() / k) })
}

/// (N, 3) float64 points borrowed as `DVec3`s when numpy holds them C-contiguous (as
/// `as_points` makes them): no copy, 240 MB fewer at 10M points; copied otherwise.
fn points3_view<'a>(a: &'a PyReadonlyArray2<'_, f64>) -> PyResult<Cow<'a, [DVec3]>> {
    let v = a.as_array();
    if v.ncols() != 3 {
        return Err(shape_error("points", "(N, 3)", v.shape()));
    }
    // SAFETY: `DVec3` is `#[repr(C)] struct { x, y, z: f64 }`.
    match v
        .to_slice()
        .and_then(|flat| unsafe { as_rows::<f64, DVec3>(flat) })
    {
        Some(points) => Ok(Cow::Borrowed(points)),
        None => points3(a).map(Cow::Owned),
    }
}

/// (N, 2) float64 planar points borrowed when C-contiguous, copied otherwise.
fn points2_view<'a>(a: &'a PyReadonlyArray2<'_, f64>) -> PyResult<Cow<'a, [[f64; 2]]>> {
    let v = a.as_array();
    // SAFETY: `[f64; 2]` is two f64.
    match v
        .to_slice()
        .filter(|_| v.ncols() == 2)
        .and_then(|flat| unsafe { as_rows(flat) })
    {
        Some(uv) => Ok(Cow::Borrowed(uv)),
        None => points2(a).map(Cow::Owned),
    }
}

/// (M, 3) int64 faces borrowed as rows when C-contiguous, copied otherwise; the indices are
/// not checked (the callee checks them where it reads them).
fn face_rows<'a>(a: &'a PyReadonlyArray2<'_, i64>) -> PyResult<Cow<'a, [[i64; 3]]>> {
    let v = a.as_array();
    if v.ncols() != 3 {
        return Err(shape_error("faces", "(M, 3)", v.shape()));
    }
    // SAFETY: `[i64; 3]` is three i64.
    Ok(
        match v.to_slice().and_then(|flat| unsafe { as_rows(flat) }) {
            Some(rows) => Cow::Borrowed(rows),
            None => Cow::Owned(v.rows().into_iter().map(|r| [r[0], r[1], r[2]]).collect()),
        },
    )
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

/// (M, 3) int64 faces for numpy, widened on every core without the GIL: 20M faces are
/// 480 MB to write, a third of a second on one core.
fn faces_out<'py>(py: Python<'py>, t: &[[u32; 3]]) -> Ints2<'py> {
    let flat = py.detach(|| {
        let mut flat = vec![0i64; 3 * t.len()];
        flat.par_chunks_mut(3 * 4096)
            .zip(t.par_chunks(4096))
            .for_each(|(out, faces)| {
                for (o, f) in out.chunks_exact_mut(3).zip(faces) {
                    o.copy_from_slice(&f.map(i64::from));
                }
            });
        flat
    });
    Array2::from_shape_vec((t.len(), 3), flat)
        .expect("3 per face")
        .into_pyarray(py)
}

/// (N, 2) float64 planar points for numpy, taking over `uv`'s buffer (no copy).
fn uv_into<'py>(py: Python<'py>, uv: Vec<[f64; 2]>) -> Floats2<'py> {
    let n = uv.len();
    let mut uv = std::mem::ManuallyDrop::new(uv);
    // SAFETY: `[f64; 2]` is two f64 without padding, with f64's alignment; the buffer's
    // length and capacity in f64s are twice those in pairs, and it is no longer owned by
    // `uv` (ManuallyDrop), so it is freed once, by the new Vec.
    let flat =
        unsafe { Vec::from_raw_parts(uv.as_mut_ptr().cast::<f64>(), 2 * n, 2 * uv.capacity()) };
    Array2::from_shape_vec((n, 2), flat)
        .expect("2 per point")
        .into_pyarray(py)
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
) -> PyResult<(Floats2<'py>, Floats2<'py>)> {
    let pts = points3_view(&points)?;
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
    let p = py
        .detach(|| scanmesh_core::project(&pts, plane))
        .map_err(to_py)?;
    let f = p.frame;
    let frame: Vec<f64> = [f.origin, f.u, f.v, f.normal]
        .iter()
        .flat_map(|v| v.to_array())
        .collect();
    Ok((
        uv_into(py, p.uv),
        Array2::from_shape_vec((4, 3), frame)
            .expect("4x3")
            .into_pyarray(py),
    ))
}

/// Delaunay triangulation of (N, 2) points. Returns (faces (M, 3) int64 counter-clockwise,
/// duplicate_of (N,) int64: -1, or the index of the earlier identical point standing in).
#[pyfunction]
fn delaunay<'py>(
    py: Python<'py>,
    uv: PyReadonlyArray2<'py, f64>,
) -> PyResult<(Ints2<'py>, Ints1<'py>)> {
    let pts = points2(&uv)?;
    let d = py.detach(|| scanmesh_core::delaunay(&pts)).map_err(to_py)?;
    let dup: Vec<i64> = d
        .duplicate_of
        .iter()
        .map(|&k| if k == NONE { -1 } else { i64::from(k) })
        .collect();
    Ok((
        faces_out(py, &d.triangles),
        Array1::from_vec(dup).into_pyarray(py),
    ))
}

/// Refuses a trimming length or depth-jump factor that is NaN or not positive (the core's
/// check, run before the arrays are converted).
fn check_trim_lengths(max_edge: f64, jump_factor: f64) -> PyResult<()> {
    scanmesh_core::check_trim_lengths(max_edge, jump_factor).map_err(to_py)
}

/// Delaunay triangulation of (N, 2) `uv` trimmed in the same call (`delaunay_trimmed` in
/// the core): at `max_edge`, or None for DEFAULT_MAX_EDGE_FACTOR x the median spacing, and
/// when that is finite, depth jumps on the (N, 3) `points` at `jump_factor`. Returns (faces,
/// duplicate_of as in `delaunay`, trimmed (K,) int64, max_edge used, (triangulate, trim)
/// seconds).
#[pyfunction]
#[pyo3(signature = (uv, points, max_edge=None, jump_factor=scanmesh_core::DEFAULT_JUMP_FACTOR))]
#[allow(clippy::type_complexity)]
fn delaunay_trimmed<'py>(
    py: Python<'py>,
    uv: PyReadonlyArray2<'py, f64>,
    points: PyReadonlyArray2<'py, f64>,
    max_edge: Option<f64>,
    jump_factor: f64,
) -> PyResult<(Ints2<'py>, Ints1<'py>, Ints1<'py>, f64, (f64, f64))> {
    check_trim_lengths(max_edge.unwrap_or(1.0), jump_factor)?;
    let pts = points2_view(&uv)?;
    let xyz = points3_view(&points)?;
    if xyz.len() != pts.len() {
        return Err(ParameterError::new_err(format!(
            "{} points for {} planar points",
            xyz.len(),
            pts.len()
        )));
    }
    check_finite(&xyz).map_err(to_py)?;
    let t = py
        .detach(|| scanmesh_core::delaunay_trimmed(&pts, &xyz, max_edge, jump_factor))
        .map_err(to_py)?;
    let dup: Vec<i64> = t
        .duplicate_of
        .iter()
        .map(|&k| if k == NONE { -1 } else { i64::from(k) })
        .collect();
    let trimmed: Vec<i64> = t.trimmed.iter().map(|&v| i64::from(v)).collect();
    Ok((
        faces_out(py, &t.triangles),
        Array1::from_vec(dup).into_pyarray(py),
        Array1::from_vec(trimmed).into_pyarray(py),
        t.max_edge,
        (t.seconds[0], t.seconds[1]),
    ))
}

/// Median nearest-neighbour spacing of (N, 2) points along the edges of `faces`.
#[pyfunction]
fn median_spacing(
    uv: PyReadonlyArray2<'_, f64>,
    faces_: PyReadonlyArray2<'_, i64>,
) -> PyResult<f64> {
    let pts = points2(&uv)?;
    let t = faces(&faces_, pts.len())?;
    Ok(scanmesh_core::median_spacing(&pts, &t))
}

/// Drops faces whose longest planar edge exceeds `max_edge` and, given the (N, 3) `points`,
/// faces that bridge a depth jump (longest 3-D edge above `jump_factor` times the local
/// spacing; `inf` turns it off), a gap or a hole; then peels collinear hull slivers and
/// resolves pinches.
#[pyfunction]
#[pyo3(signature = (uv, faces_, max_edge, points=None, jump_factor=f64::INFINITY))]
fn trim_long_edges<'py>(
    py: Python<'py>,
    uv: PyReadonlyArray2<'py, f64>,
    faces_: PyReadonlyArray2<'py, i64>,
    max_edge: f64,
    points: Option<PyReadonlyArray2<'py, f64>>,
    jump_factor: f64,
) -> PyResult<Ints2<'py>> {
    check_trim_lengths(max_edge, jump_factor)?;
    let pts = points2(&uv)?;
    let t = faces(&faces_, pts.len())?;
    let xyz = points.as_ref().map(points3_view).transpose()?;
    if let Some(p) = &xyz {
        if p.len() != pts.len() {
            return Err(ParameterError::new_err(format!(
                "{} points for {} planar points",
                p.len(),
                pts.len()
            )));
        }
        check_finite(p).map_err(to_py)?;
    }
    let jumps = xyz.as_deref().map(|p| scanmesh_core::DepthJumps {
        points: p,
        factor: jump_factor,
        gaps: true,
    });
    let kept = py
        .detach(|| scanmesh_core::trim_long_edges(&pts, &t, max_edge, jumps))
        .map_err(to_py)?;
    Ok(faces_out(py, &kept))
}

/// Checks that `faces` form a valid planar triangulation of (N, 2) points; raises
/// InvalidMeshError naming the broken invariant.
#[pyfunction]
fn validate(
    py: Python<'_>,
    uv: PyReadonlyArray2<'_, f64>,
    faces_: PyReadonlyArray2<'_, i64>,
) -> PyResult<()> {
    let pts = scanmesh_core::unit_square(&points2(&uv)?);
    let t = faces(&faces_, pts.len())?;
    py.detach(|| HalfEdgeMesh::from_triangles(pts.len(), &t).and_then(|m| m.validate(&pts)))
        .map_err(to_py)
}

/// 3-D quality of a mesh. Returns (tac (N,) with NaN off the interior, smallest angle per
/// face (M,) in radians).
#[pyfunction]
fn mesh_quality<'py>(
    py: Python<'py>,
    points: PyReadonlyArray2<'py, f64>,
    faces_: PyReadonlyArray2<'py, i64>,
) -> PyResult<(Floats1<'py>, Floats1<'py>)> {
    let pts = points3_view(&points)?;
    let t = faces(&faces_, pts.len())?;
    check_finite(&pts).map_err(to_py)?;
    // tac and angles only: Python takes the norms it reports from the tac vector.
    let (tac, min_angle) = py.detach(|| tac_and_min_angles(&pts, &t)).map_err(to_py)?;
    Ok((
        Array1::from_vec(tac).into_pyarray(py),
        Array1::from_vec(min_angle).into_pyarray(py),
    ))
}

/// Number of faces (M, 3) int64 over (N, 3) points whose right-hand normal is tilted more
/// than `max_tilt` radians from `normal` (3,) (folds count, degenerate faces do not);
/// scale-free. Raises InvalidMeshError for an index out of range. O(M), GIL released.
#[pyfunction]
fn steep_count(
    py: Python<'_>,
    points: PyReadonlyArray2<'_, f64>,
    faces_: PyReadonlyArray2<'_, i64>,
    normal: PyReadonlyArray1<'_, f64>,
    max_tilt: f64,
) -> PyResult<usize> {
    let pts = points3_view(&points)?;
    let t = face_rows(&faces_)?;
    let n = normal.as_array();
    if n.len() != 3 {
        return Err(shape_error("normal", "(3,)", n.shape()));
    }
    let n = DVec3::new(n[0], n[1], n[2]);
    py.detach(|| scanmesh_core::steep_count(&pts, &t, n, max_tilt))
        .map_err(to_py)
}

/// p-norm (p ≥ 1, or inf for the maximum) of the non-NaN entries of a vector.
#[pyfunction]
fn tac_norm(values: PyReadonlyArray1<'_, f64>, p: f64) -> PyResult<f64> {
    let norm = Norm::new(p).map_err(to_py)?;
    Ok(norm.of(values.as_slice()?))
}

/// The incremental tac state of `faces` over 3-D `points` with planar `uv`, both normalized
/// (scale-free), checked to be a valid planar triangulation.
fn tac_state(
    points: &PyReadonlyArray2<'_, f64>,
    uv: &PyReadonlyArray2<'_, f64>,
    faces_: &PyReadonlyArray2<'_, i64>,
    p: f64,
) -> PyResult<(TacState, Relabel)> {
    // Borrowed from numpy where it lays them out as rows: no copy at the boundary.
    let xyz = points3_view(points)?;
    let plane = points2_view(uv)?;
    let t = faces(faces_, xyz.len())?;
    TacState::from_input(&xyz, &plane, t, p).map_err(to_py)
}

/// Lawson's LOP from `faces`. `criterion` is "tac" (energy Σ tac^p, ties broken toward the
/// larger smallest angle when `sliver_guard`) or "max-min" (smallest angle in the plane;
/// converges to Delaunay). Returns (faces, flips).
#[pyfunction]
#[pyo3(signature = (points, uv, faces_, criterion, p=1.0, sliver_guard=true, tie_tolerance=1e-10))]
#[allow(clippy::too_many_arguments)]
fn lop<'py>(
    py: Python<'py>,
    points: PyReadonlyArray2<'py, f64>,
    uv: PyReadonlyArray2<'py, f64>,
    faces_: PyReadonlyArray2<'py, i64>,
    criterion: &str,
    p: f64,
    sliver_guard: bool,
    tie_tolerance: f64,
) -> PyResult<(Ints2<'py>, usize)> {
    let criterion = match criterion {
        "tac" => LopCriterion::Tac(TacOrder::new(tie_tolerance, sliver_guard).map_err(to_py)?),
        "max-min" => LopCriterion::PlanarMaxMin,
        other => {
            return Err(ParameterError::new_err(format!(
                "unknown LOP criterion {other:?}: use 'tac' or 'max-min'"
            )))
        }
    };
    let (state, relabel) = tac_state(&points, &uv, &faces_, p)?;
    let (mesh, flips) = py.detach(|| run_lop(state, criterion));
    Ok((
        faces_out(py, &relabel.triangles_to_input(&mesh.triangles())),
        flips,
    ))
}

/// A resumable simulated-annealing run: the chains of `scanmesh_core::ensemble::Ensemble`
/// (one on large inputs). Python drives it in chunks with `advance`, so progress is
/// reported and Ctrl-C honoured between chunks.
#[pyclass(module = "scanmesh._core")]
struct Annealer {
    inner: Option<Ensemble>,
    /// Maps the run's Z-ordered vertex labels back to the caller's indices.
    relabel: Relabel,
}

impl Annealer {
    fn running(&self) -> PyResult<&Ensemble> {
        self.inner
            .as_ref()
            .ok_or_else(|| ScanmeshError::new_err("this annealing run has finished"))
    }
}

#[pymethods]
impl Annealer {
    #[new]
    #[pyo3(signature = (points, uv, faces, *, sweeps, p, seed, initial_acceptance, final_temperature_ratio, patience, sliver_guard, tie_tolerance, planar_ties, polish, calibration_samples, chains, tiles))]
    #[allow(clippy::too_many_arguments)]
    fn new(
        py: Python<'_>,
        points: PyReadonlyArray2<'_, f64>,
        uv: PyReadonlyArray2<'_, f64>,
        faces: PyReadonlyArray2<'_, i64>,
        sweeps: usize,
        p: f64,
        seed: u64,
        initial_acceptance: f64,
        final_temperature_ratio: f64,
        patience: usize,
        sliver_guard: bool,
        tie_tolerance: f64,
        planar_ties: bool,
        polish: bool,
        calibration_samples: usize,
        chains: usize,
        tiles: usize,
    ) -> PyResult<Self> {
        let params = AnnealParams {
            sweeps,
            p,
            seed,
            initial_acceptance,
            final_temperature_ratio,
            patience,
            sliver_guard,
            tie_tolerance,
            planar_ties,
            polish,
            calibration_samples,
            chains,
            tiles,
        };
        params.check().map_err(to_py)?;
        let (state, relabel) = tac_state(&points, &uv, &faces, p)?;
        let inner = py.detach(|| Ensemble::new(state, params)).map_err(to_py)?;
        Ok(Annealer {
            inner: Some(inner),
            relabel,
        })
    }

    /// Runs at most `max_proposals` proposals per chain, and for about `max_seconds` at
    /// most, without the GIL; returns how many ran in all.
    fn advance(
        &mut self,
        py: Python<'_>,
        max_proposals: usize,
        max_seconds: f64,
    ) -> PyResult<usize> {
        let inner = self
            .inner
            .as_mut()
            .ok_or_else(|| ScanmeshError::new_err("this annealing run has finished"))?;
        let budget = std::time::Duration::try_from_secs_f64(max_seconds.max(0.0))
            .unwrap_or(std::time::Duration::MAX);
        let deadline = std::time::Instant::now().checked_add(budget);
        Ok(py.detach(|| inner.advance_until(max_proposals, deadline)))
    }

    /// True when every chain ran all its sweeps or froze and stopped early.
    #[getter]
    fn done(&self) -> PyResult<bool> {
        Ok(self.running()?.is_done())
    }

    /// Number of chains (`AnnealParams::chain_count` on this triangulation).
    #[getter]
    fn chains(&self) -> PyResult<usize> {
        Ok(self.running()?.len())
    }

    /// Proposals in the current sweep of the first chain (its live edges at the sweep's
    /// start).
    #[getter]
    fn sweep_len(&self) -> PyResult<usize> {
        Ok(self.running()?.sweep_len())
    }

    /// Sweeps completed so far, summed over the chains.
    #[getter]
    fn sweeps_done(&self) -> PyResult<usize> {
        Ok(self.running()?.sweeps_done())
    }

    /// The lowest current energy among the chains.
    #[getter]
    fn energy(&self) -> PyResult<f64> {
        Ok(self.running()?.energy())
    }

    /// Ends the run: every chain's best state, polished; the lowest energy wins. Returns
    /// (faces, the winner's trace (S, 4), summary dict).
    fn finish<'py>(
        &mut self,
        py: Python<'py>,
    ) -> PyResult<(Ints2<'py>, Floats2<'py>, Bound<'py, pyo3::types::PyDict>)> {
        let inner = self
            .inner
            .take()
            .ok_or_else(|| ScanmeshError::new_err("this annealing run has finished"))?;
        let (r, chains) = py.detach(|| inner.finish()).map_err(to_py)?;
        let summary = pyo3::types::PyDict::new(py);
        summary.set_item("initial_energy", r.initial_energy)?;
        summary.set_item("energy", r.energy)?;
        summary.set_item("initial_temperature", r.initial_temperature)?;
        summary.set_item("polish_flips", r.polish_flips)?;
        summary.set_item(
            "proposals",
            r.trace.iter().map(|s| s.proposals as u64).sum::<u64>(),
        )?;
        summary.set_item("stopped", r.stopped.name())?;
        summary.set_item("chains", chains.energies.len())?;
        summary.set_item("best_chain", chains.best_chain)?;
        summary.set_item("chain_energies", chains.energies)?;
        Ok((
            faces_out(py, &self.relabel.triangles_to_input(&r.mesh.triangles())),
            trace_out(py, &r.trace),
            summary,
        ))
    }
}

fn trace_out<'py>(py: Python<'py>, trace: &[SweepRecord]) -> Floats2<'py> {
    let flat: Vec<f64> = trace
        .iter()
        .flat_map(|r| [r.temperature, r.energy, r.best, r.acceptance])
        .collect();
    Array2::from_shape_vec((trace.len(), 4), flat)
        .expect("4 per sweep")
        .into_pyarray(py)
}

/// Every empty triangle of (N, 2) pairwise distinct points: no other point in the closed
/// triangle, corners not collinear (exact predicates). Returns (T, 3) int64, counter-clockwise.
#[pyfunction]
fn empty_triangles<'py>(py: Python<'py>, uv: PyReadonlyArray2<'py, f64>) -> PyResult<Ints2<'py>> {
    let pts = points2(&uv)?;
    let t = py
        .detach(|| scanmesh_core::empty_triangles(&pts))
        .map_err(to_py)?;
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
    let all = py
        .detach(|| scanmesh_core::triangulations(&pts, &t, max_count))
        .map_err(to_py)?;
    let flat: Vec<i64> = all
        .iter()
        .flatten()
        .flat_map(|f| f.map(i64::from))
        .collect();
    let shape = (all.len(), t.len(), 3);
    Ok(numpy::ndarray::Array3::from_shape_vec(shape, flat)
        .expect("M per triangulation")
        .into_pyarray(py))
}

/// Scan-line id per point, (N,) int64 numbered 0..L-1 in scan order, detected from the
/// order of the planar points `uv` (N, 2) with gap factor k (scanmesh_core::lines).
#[pyfunction]
fn detect_lines<'py>(
    py: Python<'py>,
    uv: PyReadonlyArray2<'py, f64>,
    gap_factor: f64,
) -> PyResult<Bound<'py, PyArray1<i64>>> {
    let pts = points2(&uv)?;
    let ids = py
        .detach(|| scanmesh_core::detect_lines(&pts, gap_factor))
        .map_err(to_py)?;
    Ok(Array1::from_iter(ids.into_iter().map(i64::from)).into_pyarray(py))
}

fn line_ids_in(a: &PyReadonlyArray1<'_, i64>, n: usize) -> PyResult<Vec<i64>> {
    let v = a.as_array();
    if v.len() != n {
        return Err(shape_error("line_ids", &format!("({n},)"), v.shape()));
    }
    Ok(v.iter().copied().collect())
}

fn pairs_out<'py>(py: Python<'py>, pairs: &[(u32, u32)]) -> Bound<'py, PyArray2<i64>> {
    let flat: Vec<i64> = pairs
        .iter()
        .flat_map(|&(a, b)| [i64::from(a), i64::from(b)])
        .collect();
    Array2::from_shape_vec((pairs.len(), 2), flat)
        .expect("2 per pair")
        .into_pyarray(py)
}

/// Scan lines from a line id per point: returns (lines: list of lines, each a list of
/// segments, each a (K,) int64 array of point indices; median step; gap length;
/// duplicates (D, 2) int64 pairs (dropped point, the point it coincides with)).
#[pyfunction]
fn scan_segments<'py>(
    py: Python<'py>,
    uv: PyReadonlyArray2<'py, f64>,
    line_ids: PyReadonlyArray1<'py, i64>,
    gap_factor: f64,
) -> PyResult<(Vec<Vec<Ints1<'py>>>, f64, f64, Ints2<'py>)> {
    let pts = points2(&uv)?;
    let ids = line_ids_in(&line_ids, pts.len())?;
    let scan = py
        .detach(|| scanmesh_core::segment_lines(&pts, &ids, gap_factor))
        .map_err(to_py)?;
    let out = scan
        .lines
        .iter()
        .map(|line| {
            line.iter()
                .map(|s| Array1::from_iter(s.iter().map(|&k| i64::from(k))).into_pyarray(py))
                .collect()
        })
        .collect();
    Ok((
        out,
        scan.median_step,
        scan.gap,
        pairs_out(py, &scan.duplicates),
    ))
}

/// Strips between consecutive scan lines as one mesh over `points` (N, 3), with planar
/// positions `uv` (N, 2) and a line id per point. `weight` = (length, area, angle,
/// dihedral) coefficients; `method` "shortest-path" (with `solver` "banded", "dp" or
/// "dijkstra" and initial half width `band`) or "lookahead" (with `alpha`); lines cut and
/// triangles dropped at depth jumps of `jump_factor` (inf: none). `context`: these points
/// are some consecutive lines of a larger scan, to be solved as that scan solves them
/// (`scanmesh_core::ScanContext`: (lo, hi) its 3-D bounding box, its largest |planar
/// coordinate|, its median planar step, whether the first line with two points runs
/// against the scan). Returns (faces (M, 3) int64 counter-clockwise in the plane, unused
/// (K,) int64, duplicates (D, 2) int64, number of strips, total path cost, planar error
/// message or None, triangles dropped at depth jumps, triangles dropped to make the mesh
/// planar-valid, trimmed (T,) int64: the unused points that lost every triangle to those
/// drops, twice the planar signed area before the faces were turned counter-clockwise).
#[pyfunction]
#[pyo3(signature = (points, uv, line_ids, weight, method, alpha, solver, band, gap_factor, check=true, jump_factor=f64::INFINITY, context=None))]
#[allow(clippy::too_many_arguments, clippy::type_complexity)]
fn strip_mesh<'py>(
    py: Python<'py>,
    points: PyReadonlyArray2<'py, f64>,
    uv: PyReadonlyArray2<'py, f64>,
    line_ids: PyReadonlyArray1<'py, i64>,
    weight: (f64, f64, f64, f64),
    method: &str,
    alpha: usize,
    solver: &str,
    band: usize,
    gap_factor: f64,
    check: bool,
    jump_factor: f64,
    context: Option<([f64; 3], [f64; 3], f64, f64, bool)>,
) -> PyResult<(
    Ints2<'py>,
    Ints1<'py>,
    Ints2<'py>,
    usize,
    f64,
    Option<String>,
    usize,
    usize,
    Ints1<'py>,
    f64,
)> {
    let params = strip_params(weight, method, alpha, solver, band, check, jump_factor)?;
    let context = context.map(|(lo, hi, largest, median_step, first_turned)| ScanContext {
        bounds: [DVec3::from_array(lo), DVec3::from_array(hi)],
        largest_planar: largest,
        median_step,
        first_turned,
    });
    let (faces, unused, duplicates, mesh) = run_strips(
        py,
        &points,
        &uv,
        &line_ids,
        gap_factor,
        &params,
        context.as_ref(),
    )?;
    let error = mesh.planar_error.map(|e| e.to_string());
    let trimmed = Array1::from_iter(mesh.trimmed.iter().map(|&k| i64::from(k))).into_pyarray(py);
    Ok((
        faces,
        unused,
        duplicates,
        mesh.n_strips,
        mesh.cost,
        error,
        mesh.dropped_jumps,
        mesh.dropped_overlaps,
        trimmed,
        mesh.signed_area,
    ))
}

/// The strip method's options as the core takes them.
fn strip_params(
    weight: (f64, f64, f64, f64),
    method: &str,
    alpha: usize,
    solver: &str,
    band: usize,
    check: bool,
    jump_factor: f64,
) -> PyResult<StripParams> {
    let solver = match solver {
        "banded" => Solver::Banded(band),
        "dp" => Solver::Dp,
        "dijkstra" => Solver::Dijkstra,
        other => {
            return Err(ParameterError::new_err(format!(
                "solver must be 'banded', 'dp' or 'dijkstra', got {other:?}"
            )))
        }
    };
    let method = match method {
        "shortest-path" => Method::ShortestPath(solver),
        "lookahead" => Method::Lookahead(alpha),
        other => {
            return Err(ParameterError::new_err(format!(
                "method must be 'shortest-path' or 'lookahead', got {other:?}"
            )))
        }
    };
    let (length, area, angle, dihedral) = weight;
    Ok(StripParams {
        weight: Weight {
            length,
            area,
            angle,
            dihedral,
        },
        method,
        check,
        jump_factor,
    })
}

/// Checks the arrays and runs `stitch_part` without the GIL: faces, unused points and
/// duplicates as numpy arrays, and the mesh for its scalars.
#[allow(clippy::type_complexity)]
fn run_strips<'py>(
    py: Python<'py>,
    points: &PyReadonlyArray2<'py, f64>,
    uv: &PyReadonlyArray2<'py, f64>,
    line_ids: &PyReadonlyArray1<'py, i64>,
    gap_factor: f64,
    params: &StripParams,
    context: Option<&ScanContext>,
) -> PyResult<(Ints2<'py>, Ints1<'py>, Ints2<'py>, StripMesh)> {
    // Borrowed, not copied, when numpy holds them contiguous (as `strip_surface` passes
    // them): 480 MB fewer at 10M points while the strips' planar check is at its peak.
    let pts = points3_view(points)?;
    let plane = points2_view(uv)?;
    if plane.len() != pts.len() || uv.as_array().ncols() != 2 {
        return Err(shape_error(
            "uv",
            &format!("({}, 2)", pts.len()),
            uv.as_array().shape(),
        ));
    }
    let ids = match line_ids.as_slice() {
        Ok(ids) if ids.len() == pts.len() => Cow::Borrowed(ids),
        _ => Cow::Owned(line_ids_in(line_ids, pts.len())?),
    };
    let (mut mesh, duplicates) = py
        .detach(|| stitch_part(&pts, &plane, &ids, gap_factor, params, context))
        .map_err(to_py)?;
    let unused = Array1::from_iter(mesh.unused.iter().map(|&k| i64::from(k))).into_pyarray(py);
    let faces = faces_out(py, &std::mem::take(&mut mesh.triangles));
    Ok((faces, unused, pairs_out(py, &duplicates), mesh))
}

/// Binary STL records of faces (M, 3) int64 over (N, 3) points: (M * 50,) uint8, normal and
/// corners as little-endian float32, attribute 0 (`scanmesh_core::stl`). Raises
/// InvalidMeshError for an index out of range. O(M), GIL released.
#[pyfunction]
fn stl_records<'py>(
    py: Python<'py>,
    points: PyReadonlyArray2<'py, f64>,
    faces_: PyReadonlyArray2<'py, i64>,
) -> PyResult<Bound<'py, PyArray1<u8>>> {
    let pts = points3_view(&points)?;
    let t = face_rows(&faces_)?;
    let bytes = py
        .detach(|| scanmesh_core::stl_records(&pts, &t))
        .map_err(to_py)?;
    Ok(Array1::from_vec(bytes).into_pyarray(py))
}

/// Parses bytes `data[start:stop]` (whole lines) as rows of `ncols` numbers (`ncols` 0: any
/// number per row) separated by whitespace and, when given, the one-character `delimiter`
/// (rules in scanmesh-core's `parse_table`), without the GIL. Returns (values (R, ncols) float64,
/// or (V, 1) holding every value with `ncols` 0, row_lines (R,) int64 and blank_lines (B,) int64, both 0-based line indices
/// within the range, number of lines, problem): problem is None, or for a refused range
/// (line index, byte offset within the range, "number" | "count") of its first bad line,
/// the other fields then empty.
#[pyfunction]
#[pyo3(signature = (data, start, stop, ncols, delimiter=None))]
#[allow(clippy::type_complexity)]
fn parse_text_table<'py>(
    py: Python<'py>,
    data: &[u8],
    start: usize,
    stop: usize,
    ncols: usize,
    delimiter: Option<char>,
) -> PyResult<(
    Floats2<'py>,
    Ints1<'py>,
    Ints1<'py>,
    usize,
    Option<(usize, usize, &'static str)>,
)> {
    if start > stop || stop > data.len() {
        return Err(ParameterError::new_err(format!(
            "need 0 <= start <= stop <= {}, got start {start}, stop {stop}",
            data.len()
        )));
    }
    let delimiter = match delimiter {
        None => None,
        Some(c) if c.is_ascii_punctuation() && c != '#' && c != '.' && c != '-' && c != '+' => {
            Some(c as u8)
        }
        Some(c) => {
            return Err(ParameterError::new_err(format!(
                "delimiter must be one ASCII punctuation character other than # . + -, got {c:?}"
            )))
        }
    };
    let chunk = &data[start..stop];
    let width = ncols.max(1);
    let (table, problem) = match py.detach(|| parse_table(chunk, ncols, delimiter)) {
        Ok(table) => (table, None),
        Err(e) => {
            let kind = match e.kind {
                TextErrorKind::NotANumber => "number",
                TextErrorKind::WrongCount => "count",
            };
            (Table::default(), Some((e.line, e.offset, kind)))
        }
    };
    let rows = table.values.len() / width;
    let values = Array2::from_shape_vec((rows, width), table.values).expect("width per row");
    Ok((
        values.into_pyarray(py),
        Array1::from_vec(table.row_lines).into_pyarray(py),
        Array1::from_vec(table.blank_lines).into_pyarray(py),
        table.n_lines,
        problem,
    ))
}

/// The cheapest fan (star in some triangulation) around each of `vertices`: the minimum of
/// `w·|Σ d| + Σ c` over fans of the candidate `triangles` (T, 3), with `d`, `c` (T, 3) per
/// corner and `w` (I,) per vertex. Returns (lower bounds (I,), then for K fans found, the
/// cheapest of each vertex first: their vertex positions (K,) int64, values (K,), triangles
/// (F,) int64 and offsets (K + 1,) int64: fan k is `fans[offsets[k]:offsets[k + 1]]`).
#[pyfunction]
#[allow(clippy::type_complexity)]
fn cheapest_fans<'py>(
    py: Python<'py>,
    uv: PyReadonlyArray2<'py, f64>,
    triangles: PyReadonlyArray2<'py, i64>,
    d: PyReadonlyArray2<'py, f64>,
    c: PyReadonlyArray2<'py, f64>,
    vertices: PyReadonlyArray1<'py, i64>,
    w: PyReadonlyArray1<'py, f64>,
) -> PyResult<(
    Bound<'py, PyArray1<f64>>,
    Bound<'py, PyArray1<i64>>,
    Bound<'py, PyArray1<f64>>,
    Bound<'py, PyArray1<i64>>,
    Bound<'py, PyArray1<i64>>,
)> {
    let pts = points2(&uv)?;
    let t = faces(&triangles, pts.len())?;
    let per_corner = |a: &PyReadonlyArray2<'py, f64>, name: &str| -> PyResult<Vec<[f64; 3]>> {
        let v = a.as_array();
        if v.ncols() != 3 || v.nrows() != t.len() {
            return Err(shape_error(name, "(T, 3) like triangles", v.shape()));
        }
        Ok(v.rows().into_iter().map(|r| [r[0], r[1], r[2]]).collect())
    };
    let (d, c) = (per_corner(&d, "d")?, per_corner(&c, "c")?);
    let mut vs = Vec::with_capacity(vertices.len()?);
    for &v in vertices.as_array().iter() {
        if v < 0 || v as u64 >= pts.len() as u64 {
            return Err(ParameterError::new_err(format!("vertex {v} out of range")));
        }
        vs.push(v as u32);
    }
    let w = w.as_array().to_vec();
    let fans = py
        .detach(|| scanmesh_core::cheapest_fans(&pts, &t, &d, &c, &vs, &w))
        .map_err(to_py)?;
    let bounds: Vec<f64> = fans.iter().map(|f| f.lower_bound).collect();
    let (mut owner, mut values, mut flat, mut offsets) =
        (Vec::new(), Vec::new(), Vec::new(), vec![0i64]);
    for (i, f) in fans.iter().enumerate() {
        let best = (!f.fan.is_empty()).then_some((f.value, &f.fan));
        for (value, fan) in best
            .into_iter()
            .chain(f.others.iter().map(|(v, t)| (*v, t)))
        {
            owner.push(i as i64);
            values.push(value);
            flat.extend(fan.iter().map(|&x| i64::from(x)));
            offsets.push(flat.len() as i64);
        }
    }
    Ok((
        Array1::from_vec(bounds).into_pyarray(py),
        Array1::from_vec(owner).into_pyarray(py),
        Array1::from_vec(values).into_pyarray(py),
        Array1::from_vec(flat).into_pyarray(py),
        Array1::from_vec(offsets).into_pyarray(py),
    ))
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
    m.add("SLIVER_ANGLE_DEG", scanmesh_core::SLIVER_ANGLE_DEG)?;
    m.add(
        "DEFAULT_MAX_EDGE_FACTOR",
        scanmesh_core::DEFAULT_MAX_EDGE_FACTOR,
    )?;
    m.add("DEFAULT_JUMP_FACTOR", scanmesh_core::DEFAULT_JUMP_FACTOR)?;
    m.add(
        "DEFAULT_BRIDGE_FACTOR",
        scanmesh_core::DEFAULT_BRIDGE_FACTOR,
    )?;
    m.add("DEFAULT_HOLE_FACTOR", scanmesh_core::DEFAULT_HOLE_FACTOR)?;
    let d = AnnealParams::default();
    let defaults = pyo3::types::PyDict::new(py);
    defaults.set_item("sweeps", d.sweeps)?;
    defaults.set_item("p", d.p)?;
    defaults.set_item("initial_acceptance", d.initial_acceptance)?;
    defaults.set_item("final_temperature_ratio", d.final_temperature_ratio)?;
    defaults.set_item("patience", d.patience)?;
    defaults.set_item("sliver_guard", d.sliver_guard)?;
    defaults.set_item("tie_tolerance", d.tie_tolerance)?;
    defaults.set_item("planar_ties", d.planar_ties)?;
    defaults.set_item("polish", d.polish)?;
    defaults.set_item("calibration_samples", d.calibration_samples)?;
    defaults.set_item("chains", d.chains)?;
    defaults.set_item("tiles", d.tiles)?;
    m.add("ANNEAL_DEFAULTS", defaults)?;
    m.add_function(wrap_pyfunction!(project, m)?)?;
    m.add_function(wrap_pyfunction!(delaunay, m)?)?;
    m.add_function(wrap_pyfunction!(median_spacing, m)?)?;
    m.add_function(wrap_pyfunction!(trim_long_edges, m)?)?;
    m.add_function(wrap_pyfunction!(delaunay_trimmed, m)?)?;
    m.add_function(wrap_pyfunction!(validate, m)?)?;
    m.add_function(wrap_pyfunction!(mesh_quality, m)?)?;
    m.add_function(wrap_pyfunction!(tac_norm, m)?)?;
    m.add_function(wrap_pyfunction!(steep_count, m)?)?;
    m.add("DEFAULT_GAP_FACTOR", scanmesh_core::DEFAULT_GAP_FACTOR)?;
    m.add("DEFAULT_BAND", scanmesh_core::DEFAULT_BAND)?;
    m.add_function(wrap_pyfunction!(detect_lines, m)?)?;
    m.add_function(wrap_pyfunction!(scan_segments, m)?)?;
    m.add_function(wrap_pyfunction!(strip_mesh, m)?)?;
    m.add_function(wrap_pyfunction!(empty_triangles, m)?)?;
    m.add_function(wrap_pyfunction!(triangulations, m)?)?;
    m.add_function(wrap_pyfunction!(cheapest_fans, m)?)?;
    m.add_function(wrap_pyfunction!(lop, m)?)?;
    m.add_function(wrap_pyfunction!(parse_text_table, m)?)?;
    m.add_function(wrap_pyfunction!(stl_records, m)?)?;
    m.add_class::<Annealer>()?;
    Ok(())
}
