//! Flips toward lower tac: Lawson's LOP and simulated annealing, with annealing's
//! parameters exposed as the core declares them (`scanmesh_core` optimize/).

use crate::convert::{
    edges, faces, faces_out, points2_view, points3_view, trace_out, vector3, Ints2,
};
use crate::progress::{counter, ProgressCounter};
use crate::results::AnnealOutcome;
use crate::{detached, to_py, ParameterError, ScanmeshError};
use numpy::{PyReadonlyArray1, PyReadonlyArray2};
use pyo3::exceptions::PyTypeError;
use pyo3::prelude::*;
use pyo3::types::PyDict;
use scanmesh_core::mesh::Relabel;
use scanmesh_core::optimize::{
    curtain_facing, run_lop, Ensemble, FixedEdges, LopCriterion, TacOrder, TacState,
};

/// Lists `scanmesh_core::optimize::AnnealParams`'s fields once, for reading them from keywords and
/// writing them to a dict. The destructuring in `fields_dict` names every field with no
/// `..`, so a field added to the core does not compile until it is listed here too.
macro_rules! anneal_fields {
    ($($field:ident),+ $(,)?) => {
        /// Sets the field `name` of `params` to `value`; false when there is no such field.
        fn set_field(
            params: &mut scanmesh_core::optimize::AnnealParams,
            name: &str,
            value: &Bound<'_, PyAny>,
        ) -> PyResult<bool> {
            match name {
                $(stringify!($field) => params.$field = extract_field(name, value)?,)+
                _ => return Ok(false),
            }
            Ok(true)
        }

        /// Every field of `params` by name, in the struct's order.
        fn fields_dict<'py>(
            py: Python<'py>,
            params: &scanmesh_core::optimize::AnnealParams,
        ) -> PyResult<Bound<'py, PyDict>> {
            let scanmesh_core::optimize::AnnealParams { $($field),+ } = params;
            let dict = PyDict::new(py);
            $(dict.set_item(stringify!($field), $field)?;)+
            Ok(dict)
        }
    };
}

anneal_fields!(
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
    descend,
    sliver_angle,
    curtain_angle,
    calibration_samples,
    chains,
    tiles,
);

/// `value` as a field's type; a TypeError names the field, as for a keyword argument.
fn extract_field<'py, T: FromPyObjectOwned<'py>>(
    name: &str,
    value: &Bound<'py, PyAny>,
) -> PyResult<T> {
    value.extract::<T>().map_err(|e| {
        let e: PyErr = e.into();
        if e.is_instance_of::<PyTypeError>(value.py()) {
            PyTypeError::new_err(format!("argument '{name}': {}", e.value(value.py())))
        } else {
            e
        }
    })
}

/// The parameters of an annealing run (`scanmesh_core::optimize::AnnealParams`): the core's defaults
/// with the given keywords replaced, range-checked by the core (`AnnealParams::check`).
/// The one declaration of annealing's fields and defaults: Python reads them from
/// `as_dict()`.
#[pyclass(name = "AnnealParams", frozen, module = "scanmesh._core")]
pub(crate) struct AnnealParams(scanmesh_core::optimize::AnnealParams);

#[pymethods]
impl AnnealParams {
    #[new]
    #[pyo3(signature = (**params))]
    fn new(params: Option<&Bound<'_, PyDict>>) -> PyResult<Self> {
        let mut out = scanmesh_core::optimize::AnnealParams::default();
        for (name, value) in params.into_iter().flatten() {
            let name: String = name.extract()?;
            if !set_field(&mut out, &name, &value)? {
                return Err(PyTypeError::new_err(format!(
                    "AnnealParams() got an unexpected keyword argument '{name}'"
                )));
            }
        }
        out.check().map_err(to_py)?;
        Ok(AnnealParams(out))
    }

    /// Sweeps of the automatic schedule for `n_points` points and `interior_edges` interior
    /// edges (`scanmesh_core::optimize::AnnealParams::auto_sweeps`).
    fn auto_sweeps(&self, n_points: usize, interior_edges: usize) -> usize {
        self.0.auto_sweeps(n_points, interior_edges)
    }

    /// Every field by name, in the core's order.
    fn as_dict<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        fields_dict(py, &self.0)
    }

    fn __repr__(&self, py: Python<'_>) -> PyResult<String> {
        let fields = fields_dict(py, &self.0)?
            .iter()
            .map(|(k, v)| Ok(format!("{k}={}", v.repr()?)))
            .collect::<PyResult<Vec<_>>>()?;
        Ok(format!("AnnealParams({})", fields.join(", ")))
    }
}

/// The incremental tac state of `faces` over 3-D `points` with planar `uv`, both normalized
/// (scale-free), checked to be a valid planar triangulation, with the (3,) line of sight
/// `sight` when given and the (K, 2) point index pairs `fixed`, edges no flip may remove.
/// Built without the GIL (0.4 s on 200,000 points: Ctrl-C waited).
pub(crate) fn tac_state(
    py: Python<'_>,
    points: &PyReadonlyArray2<'_, f64>,
    uv: &PyReadonlyArray2<'_, f64>,
    faces_: &PyReadonlyArray2<'_, i64>,
    p: f64,
    sight: Option<PyReadonlyArray1<'_, f64>>,
    fixed: Option<PyReadonlyArray2<'_, i64>>,
) -> PyResult<(TacState, Relabel)> {
    let sight = sight.map(|s| vector3("sight", &s)).transpose()?;
    // Borrowed from numpy where it lays them out as rows: no copy at the boundary.
    let xyz = points3_view(points)?;
    let plane = points2_view(uv)?;
    let t = faces(faces_, xyz.len())?;
    let fixed = fixed.map(|f| edges("fixed", &f, xyz.len())).transpose()?;
    let (state, relabel) =
        detached(py, || TacState::from_input(&xyz, &plane, t, p))?.map_err(to_py)?;
    let fixed = fixed
        .map(|f| FixedEdges::new(xyz.len(), &f)?.renamed(&relabel.to_local))
        .transpose()
        .map_err(to_py)?;
    let state = state.with_sight(sight).and_then(|s| s.with_fixed(fixed));
    Ok((state.map_err(to_py)?, relabel))
}

/// Lawson's LOP from `faces`. `criterion` is "tac" (energy Σ tac^p, ties broken toward the
/// larger smallest angle when `sliver_guard`, no flip bringing a face within
/// `curtain_angle` degrees of the (3,) line of sight `sight` when one is given) or
/// "max-min" (smallest angle in the plane; converges to Delaunay); the options after it are
/// keywords, and `p`, `sliver_guard`, `tie_tolerance` and `curtain_angle` default to
/// annealing's; no flip removes an edge of the (K, 2) point index pairs `fixed`. Returns
/// (faces, flips).
#[pyfunction]
#[pyo3(signature = (
    points, uv, faces_, criterion, *,
    p=scanmesh_core::optimize::AnnealParams::default().p,
    sliver_guard=scanmesh_core::optimize::AnnealParams::default().sliver_guard,
    tie_tolerance=scanmesh_core::optimize::AnnealParams::default().tie_tolerance,
    sight=None,
    curtain_angle=scanmesh_core::optimize::AnnealParams::default().curtain_angle,
    fixed=None,
))]
#[allow(clippy::too_many_arguments)]
pub(crate) fn lop<'py>(
    py: Python<'py>,
    points: PyReadonlyArray2<'py, f64>,
    uv: PyReadonlyArray2<'py, f64>,
    faces_: PyReadonlyArray2<'py, i64>,
    criterion: &str,
    p: f64,
    sliver_guard: bool,
    tie_tolerance: f64,
    sight: Option<PyReadonlyArray1<'py, f64>>,
    curtain_angle: f64,
    fixed: Option<PyReadonlyArray2<'py, i64>>,
) -> PyResult<(Ints2<'py>, usize)> {
    let criterion = match criterion {
        "tac" => LopCriterion::Tac(TacOrder {
            min_facing: curtain_facing(curtain_angle).map_err(to_py)?,
            ..TacOrder::new(tie_tolerance, sliver_guard).map_err(to_py)?
        }),
        "max-min" => LopCriterion::PlanarMaxMin,
        other => {
            return Err(ParameterError::new_err(format!(
                "unknown LOP criterion {other:?}: use 'tac' or 'max-min'"
            )))
        }
    };
    let (state, relabel) = tac_state(py, &points, &uv, &faces_, p, sight, fixed)?;
    let (faces, flips) = detached(py, || {
        let (mesh, flips) = run_lop(state, criterion)?;
        Ok((relabel.triangles_to_input(&mesh.triangles()?)?, flips))
    })?
    .map_err(to_py)?;
    Ok((faces_out(py, &faces)?, flips))
}

/// A resumable simulated-annealing run: the chains of `scanmesh_core` optimize::ensemble::Ensemble
/// (one on large inputs). Python drives it in chunks with `advance`, so progress is
/// reported and Ctrl-C honoured between chunks.
#[pyclass(module = "scanmesh._core")]
pub(crate) struct Annealer {
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
    /// A run from `faces` over 3-D `points` with planar `uv`, with `params` (the core
    /// checks them against this triangulation and refuses runs that would cost too much)
    /// and the (3,) line of sight `sight` its curtain rule judges by (None: no rule); no
    /// flip removes an edge of the (K, 2) point index pairs `fixed` (None: none kept). The
    /// descent and the chains' set-up are counted on `progress` (None: not counted).
    #[new]
    #[pyo3(signature = (points, uv, faces, params, sight=None, fixed=None, progress=None))]
    #[allow(clippy::too_many_arguments)]
    fn new(
        py: Python<'_>,
        points: PyReadonlyArray2<'_, f64>,
        uv: PyReadonlyArray2<'_, f64>,
        faces: PyReadonlyArray2<'_, i64>,
        params: PyRef<'_, AnnealParams>,
        sight: Option<PyReadonlyArray1<'_, f64>>,
        fixed: Option<PyReadonlyArray2<'_, i64>>,
        progress: Option<PyRef<'_, ProgressCounter>>,
    ) -> PyResult<Self> {
        let params = params.0.clone();
        let progress = counter(progress);
        let (state, relabel) = tac_state(py, &points, &uv, &faces, params.p, sight, fixed)?;
        let inner =
            detached(py, || Ensemble::new_counted(state, params, &progress))?.map_err(to_py)?;
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
        detached(py, || inner.advance_until(max_proposals, deadline))?.map_err(to_py)
    }

    /// Plans `sweeps` sweeps per chain instead of the parameters' (the cooling follows),
    /// before the first `advance`: a budget of proposals spread over the live edges
    /// (`sweep_len`). Refused for 0, for tiled chains and once a chain has proposed.
    fn replan(&mut self, sweeps: usize) -> PyResult<()> {
        let inner = self
            .inner
            .as_mut()
            .ok_or_else(|| ScanmeshError::new_err("this annealing run has finished"))?;
        inner.replan(sweeps).map_err(to_py)
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

    /// Ends the run: every chain's best state, polished; the lowest energy wins. The
    /// polish is counted on `progress` (None: not counted).
    #[pyo3(signature = (progress=None))]
    fn finish(
        &mut self,
        py: Python<'_>,
        progress: Option<PyRef<'_, ProgressCounter>>,
    ) -> PyResult<AnnealOutcome> {
        let progress = counter(progress);
        let inner = self
            .inner
            .take()
            .ok_or_else(|| ScanmeshError::new_err("this annealing run has finished"))?;
        let relabel = &self.relabel;
        let (r, chains, faces) = detached(py, || {
            let (r, chains) = inner.finish_counted(&progress)?;
            let faces = relabel.triangles_to_input(&r.mesh.triangles()?)?;
            Ok((r, chains, faces))
        })?
        .map_err(to_py)?;
        Ok(AnnealOutcome {
            faces: faces_out(py, &faces)?.unbind(),
            trace: trace_out(py, &r.trace).unbind(),
            initial_energy: r.initial_energy,
            energy: r.energy,
            initial_temperature: r.initial_temperature,
            polish_flips: r.polish_flips,
            proposals: r.trace.iter().map(|s| s.proposals as u64).sum(),
            stopped: r.stopped.name(),
            chains: chains.energies.len(),
            best_chain: chains.best_chain,
            chain_energies: chains.energies,
        })
    }
}
