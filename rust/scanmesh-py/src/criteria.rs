//! Mesh quality: tac and smallest angles, steep faces, p-norms (`scanmesh_core` criteria).

use crate::convert::{face_rows, faces, points3_view, shape_error, Floats1};
use crate::{detached, to_py};
use numpy::ndarray::Array1;
use numpy::{IntoPyArray, PyReadonlyArray1, PyReadonlyArray2};
use pyo3::prelude::*;
use scanmesh_core::criteria::{tac_and_min_angles, Norm};
use scanmesh_core::geometry::check_finite;
use scanmesh_core::glam::DVec3;

/// 3-D quality of a mesh. Returns (tac (N,) with NaN off the interior, smallest angle per
/// face (M,) in radians).
#[pyfunction]
pub(crate) fn mesh_quality<'py>(
    py: Python<'py>,
    points: PyReadonlyArray2<'py, f64>,
    faces_: PyReadonlyArray2<'py, i64>,
) -> PyResult<(Floats1<'py>, Floats1<'py>)> {
    let pts = points3_view(&points)?;
    let t = faces(&faces_, pts.len())?;
    check_finite(&pts).map_err(to_py)?;
    // tac and angles only: Python takes the norms it reports from the tac vector.
    let (tac, min_angle) = detached(py, || tac_and_min_angles(&pts, &t))?.map_err(to_py)?;
    Ok((
        Array1::from_vec(tac).into_pyarray(py),
        Array1::from_vec(min_angle).into_pyarray(py),
    ))
}

/// Number of faces (M, 3) int64 over (N, 3) points whose right-hand normal is tilted more
/// than `max_tilt` radians from `normal` (3,) (folds count, degenerate faces do not);
/// scale-free. Raises InvalidMeshError for an index out of range. O(M), GIL released.
#[pyfunction]
pub(crate) fn steep_count(
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
    detached(py, || {
        scanmesh_core::criteria::steep_count(&pts, &t, n, max_tilt)
    })?
    .map_err(to_py)
}

/// p-norm (p ≥ 1, or inf for the maximum) of the non-NaN entries of a vector.
#[pyfunction]
pub(crate) fn tac_norm(values: PyReadonlyArray1<'_, f64>, p: f64) -> PyResult<f64> {
    let norm = Norm::new(p).map_err(to_py)?;
    Ok(norm.of(values.as_slice()?))
}
