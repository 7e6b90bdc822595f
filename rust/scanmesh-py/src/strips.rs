//! Scan lines and the strips between them (`scanmesh_core` strips/).

use crate::convert::{
    faces_out, indices_out, line_ids_in, pairs_out, points2, points2_view, points3_view,
    shape_error,
};
use crate::progress::{counter, ProgressCounter};
use crate::results::{ScanSegments, StripResult};
use crate::{detached, to_py, ParameterError};
use numpy::ndarray::Array1;
use numpy::{IntoPyArray, PyArray1, PyReadonlyArray1, PyReadonlyArray2};
use pyo3::prelude::*;
use scanmesh_core::glam::DVec3;
use scanmesh_core::strips::fuchs::{Solver, Weight, DEFAULT_BAND};
use scanmesh_core::strips::{segment_lines, stitch_part, Method};
use std::borrow::Cow;
use std::collections::HashMap;

/// Scan-line id per point, (N,) int64 numbered 0..L-1 in scan order, detected from the
/// order of the planar points `uv` (N, 2) with gap factor k (`scanmesh_core` strips::lines).
#[pyfunction]
pub(crate) fn detect_lines<'py>(
    py: Python<'py>,
    uv: PyReadonlyArray2<'py, f64>,
    gap_factor: f64,
) -> PyResult<Bound<'py, PyArray1<i64>>> {
    let pts = points2(&uv)?;
    let ids =
        detached(py, || scanmesh_core::strips::detect_lines(&pts, gap_factor))?.map_err(to_py)?;
    Ok(Array1::from_iter(ids.into_iter().map(i64::from)).into_pyarray(py))
}

/// Scan lines from a line id per point (`scanmesh_core::strips::segment_lines`): the lines
/// of segments of point indices, the median step, the gap length and the duplicates, as a
/// `ScanSegments`.
#[pyfunction]
pub(crate) fn scan_segments<'py>(
    py: Python<'py>,
    uv: PyReadonlyArray2<'py, f64>,
    line_ids: PyReadonlyArray1<'py, i64>,
    gap_factor: f64,
) -> PyResult<ScanSegments> {
    let pts = points2(&uv)?;
    let ids = line_ids_in(&line_ids, pts.len())?;
    let scan = detached(py, || segment_lines(&pts, &ids, gap_factor))?.map_err(to_py)?;
    let lines = scan
        .lines
        .iter()
        .map(|line| {
            line.iter()
                .map(|s| {
                    Array1::from_iter(s.iter().map(|&k| i64::from(k)))
                        .into_pyarray(py)
                        .unbind()
                })
                .collect()
        })
        .collect();
    Ok(ScanSegments {
        lines,
        median_step: scan.median_step,
        gap: scan.gap,
        duplicates: pairs_out(py, &scan.duplicates).unbind(),
    })
}

/// The strip method's options (`scanmesh_core::strips::StripParams`): `method`
/// "shortest-path" (with `solver` "banded", "dp" or "dijkstra", default "banded", and the
/// banded solver's initial half width `band`, default DEFAULT_BAND) or "lookahead" (with its
/// depth `alpha`, required); `weight` the coefficients of the criteria "length", "area",
/// "angle" and "dihedral" by name (those not named are 0); whether to `check` the mesh in
/// the plane; the depth-jump factor (inf: none). An option the method (or solver) does not
/// use is refused, not ignored, and so are weights the core would refuse.
#[pyclass(name = "StripParams", frozen, module = "scanmesh._core")]
pub(crate) struct StripParams(scanmesh_core::strips::StripParams);

#[pymethods]
impl StripParams {
    #[new]
    #[pyo3(signature = (
        method, *, weight, alpha=None, solver=None, band=None, check=true,
        jump_factor=f64::INFINITY,
    ))]
    fn new(
        method: &str,
        weight: HashMap<String, f64>,
        alpha: Option<usize>,
        solver: Option<&str>,
        band: Option<usize>,
        check: bool,
        jump_factor: f64,
    ) -> PyResult<Self> {
        let unused = |name: &str, by: &str| {
            ParameterError::new_err(format!("{name} is not an option of {by}"))
        };
        let method = match method {
            "shortest-path" => {
                if alpha.is_some() {
                    return Err(unused("alpha", "method 'shortest-path'"));
                }
                Method::ShortestPath(match solver.unwrap_or("banded") {
                    "banded" => Solver::Banded(band.unwrap_or(DEFAULT_BAND)),
                    other @ ("dp" | "dijkstra") if band.is_some() => {
                        return Err(unused("band", &format!("solver {other:?}")))
                    }
                    "dp" => Solver::Dp,
                    "dijkstra" => Solver::Dijkstra,
                    other => {
                        return Err(ParameterError::new_err(format!(
                            "solver must be 'banded', 'dp' or 'dijkstra', got {other:?}"
                        )))
                    }
                })
            }
            "lookahead" => {
                if let Some(name) = [("solver", solver.is_some()), ("band", band.is_some())]
                    .into_iter()
                    .find_map(|(name, given)| given.then_some(name))
                {
                    return Err(unused(name, "method 'lookahead'"));
                }
                Method::Lookahead(alpha.ok_or_else(|| {
                    ParameterError::new_err("method 'lookahead' needs its depth alpha")
                })?)
            }
            other => {
                return Err(ParameterError::new_err(format!(
                    "method must be 'shortest-path' or 'lookahead', got {other:?}"
                )))
            }
        };
        let mut w = Weight {
            length: 0.0,
            area: 0.0,
            angle: 0.0,
            dihedral: 0.0,
        };
        for (name, value) in weight {
            *match name.as_str() {
                "length" => &mut w.length,
                "area" => &mut w.area,
                "angle" => &mut w.angle,
                "dihedral" => &mut w.dihedral,
                _ => {
                    return Err(ParameterError::new_err(format!(
                        "unknown weight criterion {name:?}: use 'length', 'area', 'angle' or \
                         'dihedral'"
                    )))
                }
            } = value;
        }
        w.check().map_err(to_py)?;
        Ok(StripParams(scanmesh_core::strips::StripParams {
            weight: w,
            method,
            check,
            jump_factor,
        }))
    }

    fn __repr__(&self) -> String {
        format!("{:?}", self.0)
    }
}

/// What a run over some consecutive lines of a larger scan shares with that scan, so that
/// its strips are the whole scan's (`scanmesh_core::strips::ScanContext`): the scan's 3-D
/// bounding box (`lo`, `hi`), its largest |planar coordinate|, its median planar step,
/// whether its first line with two points runs against it, and the rows (start, end) of
/// these points whose strips are returned (None: all), the lines around them only
/// informing the drops at depth jumps and overlaps.
#[pyclass(name = "ScanContext", frozen, module = "scanmesh._core")]
pub(crate) struct ScanContext(scanmesh_core::strips::ScanContext);

#[pymethods]
impl ScanContext {
    #[new]
    #[pyo3(signature = (*, lo, hi, largest_planar, median_step, first_turned, own_rows=None))]
    fn new(
        lo: [f64; 3],
        hi: [f64; 3],
        largest_planar: f64,
        median_step: f64,
        first_turned: bool,
        own_rows: Option<(usize, usize)>,
    ) -> Self {
        ScanContext(scanmesh_core::strips::ScanContext {
            bounds: [DVec3::from_array(lo), DVec3::from_array(hi)],
            largest_planar,
            median_step,
            first_turned,
            own_rows,
        })
    }

    fn __repr__(&self) -> String {
        format!("{:?}", self.0)
    }
}

/// Strips between consecutive scan lines as one mesh over `points` (N, 3), with planar
/// positions `uv` (N, 2) and a line id per point, with the options `params`; lines split at
/// gaps of `gap_factor` median steps. `context`: these points are some consecutive lines of
/// a larger scan, to be solved as that scan solves them. Returns a `StripResult` (faces
/// counter-clockwise in the plane, unused and trimmed points, duplicates, the strips' count
/// and cost, the planar error, the triangles dropped, the signed area). `progress`, a
/// `ProgressCounter`, counts the strips' triangles as they are solved.
#[pyfunction]
#[pyo3(signature = (points, uv, line_ids, params, gap_factor, context=None, progress=None))]
#[allow(clippy::too_many_arguments)] // the Python signature: arrays, options, context, progress
pub(crate) fn strip_mesh<'py>(
    py: Python<'py>,
    points: PyReadonlyArray2<'py, f64>,
    uv: PyReadonlyArray2<'py, f64>,
    line_ids: PyReadonlyArray1<'py, i64>,
    params: PyRef<'py, StripParams>,
    gap_factor: f64,
    context: Option<PyRef<'py, ScanContext>>,
    progress: Option<PyRef<'py, ProgressCounter>>,
) -> PyResult<StripResult> {
    let (points, uv, line_ids) = (&points, &uv, &line_ids);
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
    // Copies (a few words each): a PyRef may not cross into the GIL-free closure.
    let (params, context, progress) = (params.0, context.map(|c| c.0), counter(progress));
    let (mut mesh, duplicates) = detached(py, || {
        let context = context.as_ref();
        stitch_part(&pts, &plane, &ids, gap_factor, &params, context, &progress)
    })?
    .map_err(to_py)?;
    Ok(StripResult {
        faces: faces_out(py, &std::mem::take(&mut mesh.triangles))?.unbind(),
        unused: indices_out(py, &mesh.unused).unbind(),
        duplicates: pairs_out(py, &duplicates).unbind(),
        n_strips: mesh.n_strips,
        cost: mesh.cost,
        planar_error: mesh.planar_error.map(|e| e.to_string()),
        dropped_jumps: mesh.dropped_jumps,
        dropped_overlaps: mesh.dropped_overlaps,
        trimmed: indices_out(py, &mesh.trimmed).unbind(),
        signed_area: mesh.signed_area,
    })
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
