//! Fusion of aligned range views (`scanmesh_core` fusion/): a view's depth image, the voxel
//! grid that views are integrated and carved into, the labelled closed mesh it gives.

use crate::convert::{faces_out, points3_out, points3_view, shape_error, Floats2, Ints2};
use crate::progress::{counter, ProgressCounter};
use crate::{detached, to_py};
use numpy::ndarray::Array1;
use numpy::{IntoPyArray, PyArray1, PyReadonlyArray2};
use pyo3::prelude::*;
use std::collections::HashMap;

/// One range view: a depth image seen along the scanner's -z, with its scanner-to-world
/// pose. `pose` (4, 4) rigid; `depth` and `cos` (H, W) float64, row j and column i being
/// the ray through scanner (x, y) = `origin + (i, j) * step`; depth NaN where the ray had
/// no return; `cos` the |cosine| between ray and surface normal; `weight` (H, W), optional,
/// the trust in each return in [0, 1] (default 1); `margin`, the rays around a return
/// within which a nearer surface keeps it from showing space empty (the view's alignment
/// residual, default 0). Raises ParameterError for a pose that is not rigid and finite, a
/// bad step, a weight outside [0, 1], a margin over 16 or mismatched shapes.
/// O(H · W · (1 + margin)).
#[pyclass(frozen, module = "scanmesh._core")]
pub(crate) struct DepthView {
    inner: scanmesh_core::fusion::DepthView,
}

#[pymethods]
impl DepthView {
    #[new]
    #[pyo3(signature = (pose, origin, step, depth, cos, weight=None, margin=0))]
    fn new(
        pose: PyReadonlyArray2<'_, f64>,
        origin: (f64, f64),
        step: f64,
        depth: PyReadonlyArray2<'_, f64>,
        cos: PyReadonlyArray2<'_, f64>,
        weight: Option<PyReadonlyArray2<'_, f64>>,
        margin: usize,
    ) -> PyResult<Self> {
        let pose = pose.as_array();
        if pose.shape() != [4, 4] {
            return Err(shape_error("pose", "(4, 4)", pose.shape()));
        }
        let (d, c) = (depth.as_array(), cos.as_array());
        if d.shape() != c.shape() {
            return Err(shape_error("cos", "the depth image's shape", c.shape()));
        }
        let (height, width) = d.dim();
        let flat: [f64; 16] = std::array::from_fn(|k| pose[[k / 4, k % 4]]);
        let mut inner = scanmesh_core::fusion::DepthView::new(
            flat,
            [origin.0, origin.1],
            step,
            width,
            height,
            d.iter().copied().collect(),
            c.iter().copied().collect(),
        )
        .map_err(to_py)?;
        if let Some(w) = weight {
            let w = w.as_array();
            if w.shape() != d.shape() {
                return Err(shape_error("weight", "the depth image's shape", w.shape()));
            }
            inner = inner
                .with_weight(w.iter().copied().collect())
                .map_err(to_py)?;
        }
        if margin > 0 {
            inner = inner.with_margin(margin).map_err(to_py)?;
        }
        Ok(Self { inner })
    }
}

/// The voxel grid: `dims` (nx, ny, nz) nodes `voxel` apart from `origin` (world units),
/// signed distances truncated at `truncation`, stored by blocks of 8³ nodes allocated
/// where the evidence varies, at most `max_voxels` nodes allocated. Raises ParameterError
/// for bad sizes and MemoryLimitError when its block index (4 bytes per block) does not
/// fit.
#[pyclass(module = "scanmesh._core")]
pub(crate) struct FusionVolume {
    inner: scanmesh_core::fusion::Volume,
}

#[pymethods]
impl FusionVolume {
    #[new]
    fn new(
        origin: (f64, f64, f64),
        voxel: f64,
        dims: (usize, usize, usize),
        truncation: f64,
        max_voxels: usize,
    ) -> PyResult<Self> {
        let inner = scanmesh_core::fusion::Volume::new(
            [origin.0, origin.1, origin.2],
            voxel,
            [dims.0, dims.1, dims.2],
            truncation,
        )
        .map_err(to_py)?
        .with_max_voxels(max_voxels);
        Ok(Self { inner })
    }

    /// Nodes allocated so far (whole blocks of 8³): with distances (9 bytes each), and
    /// with flags alone (1 byte each: near silhouettes and carving edges).
    #[getter]
    fn allocated(&self) -> (usize, usize) {
        let [distances, flags] = self.inner.allocated();
        (distances, flags)
    }

    /// Adds a view's returns (distance near its surfaces, empty space in front of them).
    /// O(blocks + pixels + nodes of the blocks its surfaces cross), GIL released. Raises
    /// ParameterError beyond `max_voxels`, MemoryLimitError when the blocks do not fit.
    fn integrate(&mut self, py: Python<'_>, view: &DepthView) -> PyResult<()> {
        detached(py, || self.inner.integrate(&view.inner))?.map_err(to_py)
    }

    /// Marks empty the space along the view's rays without return that crossed no measured
    /// surface; call after every `integrate`. O(rays · blocks per ray + blocks + nodes of
    /// the blocks the carving's edge crosses), GIL released. Raises as `integrate`.
    fn carve(&mut self, py: Python<'_>, view: &DepthView) -> PyResult<()> {
        detached(py, || self.inner.carve(&view.inner))?.map_err(to_py)
    }

    /// (nx, ny, nz) uint8 per node: 0 measured, 1 seen empty, 2 unseen (a byte per node of
    /// the whole grid: for small grids and tests).
    fn evidence<'py>(&self, py: Python<'py>) -> Bound<'py, numpy::PyArray3<u8>> {
        let [nx, ny, nz] = self.inner.dims();
        let codes: Vec<u8> = (0..nx * ny * nz)
            .map(|n| match self.inner.evidence(n) {
                scanmesh_core::fusion::Evidence::Measured => 0,
                scanmesh_core::fusion::Evidence::Empty => 1,
                scanmesh_core::fusion::Evidence::Unseen => 2,
            })
            .collect();
        // stored x fastest: (nz, ny, nx) in C order, transposed to (nx, ny, nz)
        numpy::ndarray::Array3::from_shape_vec((nz, ny, nx), codes)
            .expect("one per node")
            .reversed_axes()
            .into_pyarray(py)
    }

    /// The closed mesh of the zero set: (vertices (V, 3) float64, faces (M, 3) int64
    /// counter-clockwise from outside, labels (M,) uint8 (0 measured, 1 inferred, 2
    /// filled), nodes moved by the manifold repair, and the thin handles taken off before
    /// it: a dict of "handles", "closed" nodes, "largest" group of nodes).
    /// Vertices are placed on `samples`
    /// (S, 3) with outward unit `normals` (S, 3); `views`, the list integrated and carved
    /// in the order carved, place the surface between nodes where their rays' evidence
    /// jumps. `progress`, a `ProgressCounter`, counts the grid's slices pass by pass.
    /// O(nodes + S log S), GIL released.
    #[allow(clippy::type_complexity)]
    #[pyo3(signature = (samples, normals, views, progress=None))]
    fn extract<'py>(
        &self,
        py: Python<'py>,
        samples: PyReadonlyArray2<'py, f64>,
        normals: PyReadonlyArray2<'py, f64>,
        views: Vec<PyRef<'py, DepthView>>,
        progress: Option<PyRef<'py, ProgressCounter>>,
    ) -> PyResult<(
        Floats2<'py>,
        Ints2<'py>,
        Bound<'py, PyArray1<u8>>,
        usize,
        HashMap<&'static str, usize>,
    )> {
        let s = points3_view(&samples)?;
        let n = points3_view(&normals)?;
        let inner: Vec<&scanmesh_core::fusion::DepthView> =
            views.iter().map(|v| &v.inner).collect();
        let progress = counter(progress);
        let fused = detached(py, || {
            scanmesh_core::fusion::extract_counted(&self.inner, &s, &n, &inner, &progress)
        })?
        .map_err(to_py)?;
        Ok((
            points3_out(py, &fused.vertices)?,
            faces_out(py, &fused.faces)?,
            Array1::from_vec(fused.labels).into_pyarray(py),
            fused.repaired,
            HashMap::from([
                ("handles", fused.settled.handles),
                ("closed", fused.settled.closed),
                ("largest", fused.settled.largest),
            ]),
        ))
    }
}
