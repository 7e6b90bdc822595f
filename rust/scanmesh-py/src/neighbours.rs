//! The k nearest planar neighbours of points (`scanmesh_core` neighbours).

use crate::convert::{points2_view, Ints2};
use crate::{detached, to_py, ParameterError};
use numpy::ndarray::Array2;
use numpy::{IntoPyArray, PyReadonlyArray1, PyReadonlyArray2};
use pyo3::prelude::*;

/// For each index in `queries` (Q,) int64, the indices of its `k` nearest points of `uv`
/// (N, 2) itself included, nearest first, ties by the smaller index: (Q, k) int64.
#[pyfunction]
pub(crate) fn k_nearest<'py>(
    py: Python<'py>,
    uv: PyReadonlyArray2<'py, f64>,
    queries: PyReadonlyArray1<'py, i64>,
    k: usize,
) -> PyResult<Ints2<'py>> {
    let pts = points2_view(&uv)?;
    let asked: Vec<usize> = queries
        .as_array()
        .iter()
        .map(|&q| {
            usize::try_from(q).map_err(|_| {
                ParameterError::new_err(format!("queries must be point indices, got {q}"))
            })
        })
        .collect::<PyResult<_>>()?;
    let found =
        detached(py, || scanmesh_core::neighbours::k_nearest(&pts, &asked, k))?.map_err(to_py)?;
    let rows = Array2::from_shape_vec((asked.len(), k), found.into_iter().map(i64::from).collect())
        .expect("k indices per query");
    Ok(rows.into_pyarray(py))
}
