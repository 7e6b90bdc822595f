//! Planar triangulation: projection, Delaunay, its trimming, the median spacing, the
//! triangulation along a range grid, and the check that faces form a valid triangulation (`scanmesh_core` triangulate/, projection).

use crate::convert::{
    duplicates_out, faces, faces_out, indices_out, points2, points2_view, points3_view, uv_into,
    vector3, Floats2, Ints1, Ints2,
};
use crate::progress::{counter, ProgressCounter};
use crate::results::{GridTriangles, TrimmedDelaunay};
use crate::{detached, to_py, ParameterError};
use numpy::ndarray::Array2;
use numpy::{IntoPyArray, PyReadonlyArray1, PyReadonlyArray2};
use pyo3::prelude::*;
use scanmesh_core::geometry::check_finite;
use scanmesh_core::glam::DVec3;
use scanmesh_core::mesh::HalfEdgeMesh;
use scanmesh_core::projection::Plane;
use std::borrow::Cow;

/// Projects (N, 3) points onto a plane. `plane` is "best-fit", "x", "y" or "z", or None
/// with `normal` a 3-vector. Returns (uv (N, 2), frame (4, 3): origin, u, v, normal).
#[pyfunction]
#[pyo3(signature = (points, plane, normal=None))]
pub(crate) fn project<'py>(
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
        (None, Some(n)) => Plane::Normal(vector3("normal", &n)?),
        (p, _) => {
            return Err(ParameterError::new_err(format!(
                "plane must be 'best-fit', 'x', 'y', 'z' or a normal vector, got {p:?}"
            )))
        }
    };
    let p = detached(py, || scanmesh_core::projection::project(&pts, plane))?.map_err(to_py)?;
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
pub(crate) fn delaunay<'py>(
    py: Python<'py>,
    uv: PyReadonlyArray2<'py, f64>,
) -> PyResult<(Ints2<'py>, Ints1<'py>)> {
    let pts = points2(&uv)?;
    let d = detached(py, || scanmesh_core::triangulate::delaunay(&pts))?.map_err(to_py)?;
    Ok((
        faces_out(py, &d.triangles)?,
        duplicates_out(py, &d.duplicate_of),
    ))
}

/// Refuses a trimming length or depth-jump factor that is NaN or not positive (the core's
/// check, run before the arrays are converted).
pub(crate) fn check_trim_lengths(max_edge: f64, jump_factor: f64) -> PyResult<()> {
    scanmesh_core::triangulate::check_trim_lengths(max_edge, jump_factor).map_err(to_py)
}

/// Delaunay triangulation of (N, 2) `uv` trimmed in the same call (`delaunay_trimmed` in
/// the core): at `max_edge`, or None for DEFAULT_MAX_EDGE_FACTOR x the median spacing, and
/// when that is finite, depth jumps on the (N, 3) `points` at `jump_factor`. Returns a
/// `TrimmedDelaunay`: faces, duplicate_of as in `delaunay`, trimmed (K,) int64, the
/// max_edge used, (triangulate, trim) seconds. `progress`, a `ProgressCounter`, counts its
/// passes over the points while it runs.
#[pyfunction]
#[pyo3(signature = (uv, points, max_edge=None, jump_factor=scanmesh_core::triangulate::DEFAULT_JUMP_FACTOR, progress=None))]
pub(crate) fn delaunay_trimmed<'py>(
    py: Python<'py>,
    uv: PyReadonlyArray2<'py, f64>,
    points: PyReadonlyArray2<'py, f64>,
    max_edge: Option<f64>,
    jump_factor: f64,
    progress: Option<PyRef<'py, ProgressCounter>>,
) -> PyResult<TrimmedDelaunay> {
    check_trim_lengths(max_edge.unwrap_or(1.0), jump_factor)?;
    let pts = points2_view(&uv)?;
    let xyz = matching_points(&points, pts.len())?;
    let progress = counter(progress);
    let t = detached(py, || {
        scanmesh_core::triangulate::delaunay_trimmed(&pts, &xyz, max_edge, jump_factor, &progress)
    })?
    .map_err(to_py)?;
    Ok(TrimmedDelaunay {
        faces: faces_out(py, &t.triangles)?.unbind(),
        duplicate_of: duplicates_out(py, &t.duplicate_of).unbind(),
        trimmed: indices_out(py, &t.trimmed).unbind(),
        max_edge: t.max_edge,
        seconds: (t.seconds[0], t.seconds[1]),
    })
}

/// Triangulates a range grid (`grid_triangulate` in the core): (R, C) int64 `grid` of
/// point indices (-1: no sample) over (N, 2) `uv` and (N, 3) `points`, seen along the
/// (3,) `sight`; drops faces turned more than `max_turn_deg` from it or with an edge over
/// `edge_factor` local grid spacings. Returns a `GridTriangles`.
#[pyfunction]
#[pyo3(signature = (
    grid, uv, points, sight,
    max_turn_deg=scanmesh_core::triangulate::DEFAULT_GRID_TURN_DEG,
    edge_factor=scanmesh_core::triangulate::DEFAULT_GRID_EDGE_FACTOR,
))]
pub(crate) fn grid_triangulate<'py>(
    py: Python<'py>,
    grid: PyReadonlyArray2<'py, i64>,
    uv: PyReadonlyArray2<'py, f64>,
    points: PyReadonlyArray2<'py, f64>,
    sight: PyReadonlyArray1<'py, f64>,
    max_turn_deg: f64,
    edge_factor: f64,
) -> PyResult<GridTriangles> {
    let pts = points2_view(&uv)?;
    let xyz = matching_points(&points, pts.len())?;
    let sight = vector3("sight", &sight)?;
    let g = grid.as_array();
    let (rows, cols) = (g.nrows(), g.ncols());
    // C-ordered grids (every scanmesh reader's) are read in place
    let cells: Cow<'_, [i64]> = match g.as_slice() {
        Some(flat) => Cow::Borrowed(flat),
        None => Cow::Owned(g.iter().copied().collect()),
    };
    let params = scanmesh_core::triangulate::GridParams {
        sight,
        max_turn_deg,
        edge_factor,
    };
    let t = detached(py, || {
        scanmesh_core::triangulate::grid_triangulate(&cells, rows, cols, &pts, &xyz, params)
    })?
    .map_err(to_py)?;
    Ok(GridTriangles {
        faces: faces_out(py, &t.triangles)?.unbind(),
        candidates: t.candidates,
        turned: t.turned,
        long: t.long,
        folded: t.folded,
        peeled: t.peeled,
        spacing: t.spacing,
        unused: indices_out(py, &t.unused).unbind(),
    })
}

/// Median nearest-neighbour spacing of (N, 2) points along the edges of `faces`.
#[pyfunction]
pub(crate) fn median_spacing(
    py: Python<'_>,
    uv: PyReadonlyArray2<'_, f64>,
    faces_: PyReadonlyArray2<'_, i64>,
) -> PyResult<f64> {
    let pts = points2(&uv)?;
    let t = faces(&faces_, pts.len())?;
    detached(py, || scanmesh_core::triangulate::median_spacing(&pts, &t))?.map_err(to_py)
}

/// Drops faces whose longest planar edge exceeds `max_edge` and, given the (N, 3) `points`,
/// faces that bridge a depth jump (longest 3-D edge above `jump_factor` times the local
/// spacing; `inf` turns it off), a gap or a hole; then peels collinear hull slivers and
/// resolves pinches.
#[pyfunction]
#[pyo3(signature = (uv, faces_, max_edge, points=None, jump_factor=f64::INFINITY))]
pub(crate) fn trim_long_edges<'py>(
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
    let xyz = points
        .as_ref()
        .map(|p| matching_points(p, pts.len()))
        .transpose()?;
    let jumps = xyz
        .as_deref()
        .map(|p| scanmesh_core::triangulate::DepthJumps {
            points: p,
            factor: jump_factor,
            gaps: true,
        });
    let kept = detached(py, || {
        scanmesh_core::triangulate::trim_long_edges(&pts, &t, max_edge, jumps)
    })?
    .map_err(to_py)?;
    faces_out(py, &kept)
}

/// Checks that `faces` form a valid planar triangulation of (N, 2) points; raises
/// InvalidMeshError naming the broken invariant.
#[pyfunction]
pub(crate) fn validate(
    py: Python<'_>,
    uv: PyReadonlyArray2<'_, f64>,
    faces_: PyReadonlyArray2<'_, i64>,
) -> PyResult<()> {
    let pts = scanmesh_core::geometry::unit_square(&points2(&uv)?);
    let t = faces(&faces_, pts.len())?;
    detached(py, || {
        HalfEdgeMesh::from_triangles(pts.len(), &t).and_then(|m| m.validate(&pts))
    })?
    .map_err(to_py)
}

/// (N, 3) `points` borrowed as `DVec3`s, checked to be as many as the `planar` points a
/// triangulation is built on and finite: the 3-D positions it is measured on. O(N).
fn matching_points<'a>(
    points: &'a PyReadonlyArray2<'_, f64>,
    planar: usize,
) -> PyResult<Cow<'a, [DVec3]>> {
    let xyz = points3_view(points)?;
    if xyz.len() != planar {
        return Err(ParameterError::new_err(format!(
            "{} points for {planar} planar points",
            xyz.len()
        )));
    }
    check_finite(&xyz).map_err(to_py)?;
    Ok(xyz)
}
