//! Scan lines and the strips between them (`scanmesh_core` strips/).

use crate::convert::{
    faces_out, indices_out, line_ids_in, pairs_out, points2, points2_view, points3_view,
    shape_error, Ints1, Ints2,
};
use crate::results::StripResult;
use crate::{to_py, ParameterError};
use numpy::ndarray::Array1;
use numpy::{IntoPyArray, PyArray1, PyReadonlyArray1, PyReadonlyArray2};
use pyo3::prelude::*;
use scanmesh_core::glam::DVec3;
use scanmesh_core::strips::fuchs::{Solver, Weight};
use scanmesh_core::strips::{stitch_part, Method, ScanContext, StripMesh, StripParams};
use std::borrow::Cow;

/// Scan-line id per point, (N,) int64 numbered 0..L-1 in scan order, detected from the
/// order of the planar points `uv` (N, 2) with gap factor k (`scanmesh_core` strips::lines).
#[pyfunction]
pub(crate) fn detect_lines<'py>(
    py: Python<'py>,
    uv: PyReadonlyArray2<'py, f64>,
    gap_factor: f64,
) -> PyResult<Bound<'py, PyArray1<i64>>> {
    let pts = points2(&uv)?;
    let ids = py
        .detach(|| scanmesh_core::strips::detect_lines(&pts, gap_factor))
        .map_err(to_py)?;
    Ok(Array1::from_iter(ids.into_iter().map(i64::from)).into_pyarray(py))
}

/// Scan lines from a line id per point: returns (lines: list of lines, each a list of
/// segments, each a (K,) int64 array of point indices; median step; gap length;
/// duplicates (D, 2) int64 pairs (dropped point, the point it coincides with)).
#[pyfunction]
pub(crate) fn scan_segments<'py>(
    py: Python<'py>,
    uv: PyReadonlyArray2<'py, f64>,
    line_ids: PyReadonlyArray1<'py, i64>,
    gap_factor: f64,
) -> PyResult<(Vec<Vec<Ints1<'py>>>, f64, f64, Ints2<'py>)> {
    let pts = points2(&uv)?;
    let ids = line_ids_in(&line_ids, pts.len())?;
    let scan = py
        .detach(|| scanmesh_core::strips::segment_lines(&pts, &ids, gap_factor))
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

/// A scan's context as Python passes it: (lo, hi) its 3-D bounding box, its largest
/// |planar coordinate|, its median planar step, whether its first line runs against it,
/// and the rows (start, end) whose strips are returned (None: all).
type Context = ([f64; 3], [f64; 3], f64, f64, bool, Option<(usize, usize)>);

/// Strips between consecutive scan lines as one mesh over `points` (N, 3), with planar
/// positions `uv` (N, 2) and a line id per point. `weight` = (length, area, angle,
/// dihedral) coefficients; `method` "shortest-path" (with `solver` "banded", "dp" or
/// "dijkstra" and initial half width `band`) or "lookahead" (with `alpha`); lines cut and
/// triangles dropped at depth jumps of `jump_factor` (inf: none). `context`: these points
/// are some consecutive lines of a larger scan, to be solved as that scan solves them
/// (`scanmesh_core::strips::ScanContext`: (lo, hi) its 3-D bounding box, its largest |planar
/// coordinate|, its median planar step, whether the first line with two points runs
/// against the scan, the rows (start, end) whose strips are returned, the lines around them
/// only informing the drops at depth jumps and overlaps, or None). Returns a `StripResult` (faces counter-clockwise in the plane, unused
/// and trimmed points, duplicates, the strips' count and cost, the planar error, the
/// triangles dropped, the signed area).
#[pyfunction]
#[pyo3(signature = (points, uv, line_ids, weight, method, alpha, solver, band, gap_factor, check=true, jump_factor=f64::INFINITY, context=None))]
#[allow(clippy::too_many_arguments)]
pub(crate) fn strip_mesh<'py>(
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
    context: Option<Context>,
) -> PyResult<StripResult> {
    let params = strip_params(weight, method, alpha, solver, band, check, jump_factor)?;
    let context =
        context.map(
            |(lo, hi, largest, median_step, first_turned, own_rows)| ScanContext {
                bounds: [DVec3::from_array(lo), DVec3::from_array(hi)],
                largest_planar: largest,
                median_step,
                first_turned,
                own_rows,
            },
        );
    let (faces, unused, duplicates, mesh) = run_strips(
        py,
        &points,
        &uv,
        &line_ids,
        gap_factor,
        &params,
        context.as_ref(),
    )?;
    Ok(StripResult {
        faces: faces.unbind(),
        unused: unused.unbind(),
        duplicates: duplicates.unbind(),
        n_strips: mesh.n_strips,
        cost: mesh.cost,
        planar_error: mesh.planar_error.map(|e| e.to_string()),
        dropped_jumps: mesh.dropped_jumps,
        dropped_overlaps: mesh.dropped_overlaps,
        trimmed: indices_out(py, &mesh.trimmed).unbind(),
        signed_area: mesh.signed_area,
    })
}

/// The strip method's options as the core takes them.
pub(crate) fn strip_params(
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
pub(crate) fn run_strips<'py>(
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
    let unused = indices_out(py, &mesh.unused);
    let faces = faces_out(py, &std::mem::take(&mut mesh.triangles))?;
    Ok((faces, unused, pairs_out(py, &duplicates), mesh))
}

/// Turns the strips' filtered decisions on (the default) or off, process-wide
/// (`scanmesh_core::strips::fuchs::set_strip_filter`); the faces are the same either way. For benchmarks.
#[pyfunction]
pub(crate) fn set_strip_filter(on: bool) {
    scanmesh_core::strips::fuchs::set_strip_filter(on);
}

/// The filtered decisions' counters since the last reset, as (decisions, fallbacks)
/// (`scanmesh_core::strips::fuchs::strip_filter_counts`); `reset` sets them to zero. For benchmarks.
#[pyfunction]
#[pyo3(signature = (reset=false))]
pub(crate) fn strip_filter_counts(reset: bool) -> (u64, u64) {
    let c = scanmesh_core::strips::fuchs::strip_filter_counts(reset);
    (c.decisions, c.fallbacks)
}
