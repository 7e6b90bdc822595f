//! How far a long native call has got (`scanmesh_core::progress`): a counter the caller
//! passes in and reads from another thread while the call runs with the GIL released.

use pyo3::prelude::*;
use scanmesh_core::progress::Progress;
use std::sync::Arc;

/// Items done of items planned by the long call it is passed to (`progress=`): Delaunay,
/// the strips, fusion's integration and extraction, annealing's start and polish. Read `done` and `total` from another
/// thread while the call runs; both only grow. O(1) each.
#[pyclass(frozen, module = "scanmesh._core")]
#[derive(Default)]
pub(crate) struct ProgressCounter(Arc<Progress>);

#[pymethods]
impl ProgressCounter {
    #[new]
    fn new() -> Self {
        Self::default()
    }

    /// Items done so far.
    #[getter]
    fn done(&self) -> u64 {
        self.0.done()
    }

    /// Items the call has planned so far (0 before it starts).
    #[getter]
    fn total(&self) -> u64 {
        self.0.total()
    }
}

/// The core's counter behind an optional `progress=` argument (a fresh one, read by nobody,
/// for None), shared so that it can cross into the GIL-free closure.
pub(crate) fn counter(progress: Option<PyRef<'_, ProgressCounter>>) -> Arc<Progress> {
    progress.map(|p| Arc::clone(&p.0)).unwrap_or_default()
}
