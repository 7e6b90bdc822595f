//! Binding of the core's `simplify`: fewer faces within a distance of the mesh.

use crate::convert::{faces, faces_out, points3_out, points3_view, Floats2, Ints2};
use crate::{detached, to_py};
use numpy::ndarray::Array1;
use numpy::{IntoPyArray, PyArray1, PyReadonlyArray1, PyReadonlyArray2};
use pyo3::prelude::*;

/// The mesh (`vertices` (V, 3), `faces` (M, 3), `labels` (M,) uint8) with edges collapsed
/// while every input vertex stays within `tolerance` (world units) of it, quadric error
/// first; a closed 2-manifold stays one, labels' borders stay. Returns (vertices, faces,
/// labels). O(E log E), GIL released.
#[pyfunction]
pub(crate) fn simplify<'py>(
    py: Python<'py>,
    vertices: PyReadonlyArray2<'py, f64>,
    faces_: PyReadonlyArray2<'py, i64>,
    labels: PyReadonlyArray1<'py, u8>,
    tolerance: f64,
) -> PyResult<(Floats2<'py>, Ints2<'py>, Bound<'py, PyArray1<u8>>)> {
    let v = points3_view(&vertices)?;
    let t = faces(&faces_, v.len())?;
    let l = labels.as_array().to_vec();
    let out = detached(py, || {
        scanmesh_core::simplify::simplify(&v, &t, &l, tolerance)
    })?
    .map_err(to_py)?;
    Ok((
        points3_out(py, &out.vertices)?,
        faces_out(py, &out.faces)?,
        Array1::from_vec(out.labels).into_pyarray(py),
    ))
}
