//! Binding of the core's `simplify`: fewer faces within a distance of the mesh.

use crate::convert::{faces, faces_out, points3_view, Floats2, Ints2};
use crate::to_py;
use numpy::ndarray::{Array1, Array2};
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
    let out = py
        .detach(|| scanmesh_core::simplify::simplify(&v, &t, &l, tolerance))
        .map_err(to_py)?;
    let flat: Vec<f64> = out.vertices.iter().flat_map(|p| p.to_array()).collect();
    let vertices = Array2::from_shape_vec((out.vertices.len(), 3), flat)
        .expect("3 per vertex")
        .into_pyarray(py);
    Ok((
        vertices,
        faces_out(py, &out.faces)?,
        Array1::from_vec(out.labels).into_pyarray(py),
    ))
}
