//! Exact small problems: empty triangles, every triangulation, cheapest fans
//! (`scanmesh_core` exact/).

use crate::convert::{faces, faces_out, points2, shape_error, Ints2};
use crate::results::CheapestFans;
use crate::{detached, to_py, ParameterError};
use numpy::ndarray::Array1;
use numpy::{IntoPyArray, PyReadonlyArray1, PyReadonlyArray2};
use pyo3::prelude::*;

/// Every empty triangle of (N, 2) pairwise distinct points: no other point in the closed
/// triangle, corners not collinear (exact predicates). Returns (T, 3) int64, counter-clockwise.
#[pyfunction]
pub(crate) fn empty_triangles<'py>(
    py: Python<'py>,
    uv: PyReadonlyArray2<'py, f64>,
) -> PyResult<Ints2<'py>> {
    let pts = points2(&uv)?;
    let t = detached(py, || scanmesh_core::exact::empty_triangles(&pts))?.map_err(to_py)?;
    faces_out(py, &t)
}

/// Every triangulation of the convex hull of (N, 2) distinct points, by flips from `faces_`
/// (a triangulation using every point). Returns (K, M, 3) int64, each canonical; raises
/// ParameterError when there are more than `max_count`.
#[pyfunction]
pub(crate) fn triangulations<'py>(
    py: Python<'py>,
    uv: PyReadonlyArray2<'py, f64>,
    faces_: PyReadonlyArray2<'py, i64>,
    max_count: usize,
) -> PyResult<Bound<'py, numpy::PyArray3<i64>>> {
    let pts = points2(&uv)?;
    let t = faces(&faces_, pts.len())?;
    let all = detached(py, || {
        scanmesh_core::exact::triangulations(&pts, &t, max_count)
    })?
    .map_err(to_py)?;
    let flat: Vec<i64> = all
        .iter()
        .flatten()
        .flat_map(|f| f.map(i64::from))
        .collect();
    let shape = (all.len(), t.len(), 3);
    Ok(numpy::ndarray::Array3::from_shape_vec(shape, flat)
        .expect("M per triangulation")
        .into_pyarray(py))
}

/// The cheapest fan (star in some triangulation) around each of `vertices`: the minimum of
/// `w·|Σ d| + Σ c` over fans of the candidate `triangles` (T, 3), with `d`, `c` (T, 3) per
/// corner and `w` (I,) per vertex. Returns `CheapestFans`: lower bounds (I,), then for K
/// fans found, the cheapest of each vertex first: their vertex positions (K,) int64,
/// values (K,), triangles (F,) int64 and offsets (K + 1,) int64.
#[pyfunction]
pub(crate) fn cheapest_fans<'py>(
    py: Python<'py>,
    uv: PyReadonlyArray2<'py, f64>,
    triangles: PyReadonlyArray2<'py, i64>,
    d: PyReadonlyArray2<'py, f64>,
    c: PyReadonlyArray2<'py, f64>,
    vertices: PyReadonlyArray1<'py, i64>,
    w: PyReadonlyArray1<'py, f64>,
) -> PyResult<CheapestFans> {
    let pts = points2(&uv)?;
    let t = faces(&triangles, pts.len())?;
    let per_corner = |a: &PyReadonlyArray2<'py, f64>, name: &str| -> PyResult<Vec<[f64; 3]>> {
        let v = a.as_array();
        if v.ncols() != 3 || v.nrows() != t.len() {
            return Err(shape_error(name, "(T, 3) like triangles", v.shape()));
        }
        Ok(v.rows().into_iter().map(|r| [r[0], r[1], r[2]]).collect())
    };
    let (d, c) = (per_corner(&d, "d")?, per_corner(&c, "c")?);
    let mut vs = Vec::with_capacity(vertices.len()?);
    for &v in vertices.as_array().iter() {
        if v < 0 || v as u64 >= pts.len() as u64 {
            return Err(ParameterError::new_err(format!("vertex {v} out of range")));
        }
        vs.push(v as u32);
    }
    let w = w.as_array().to_vec();
    let fans = detached(py, || {
        scanmesh_core::exact::cheapest_fans(&pts, &t, &d, &c, &vs, &w)
    })?
    .map_err(to_py)?;
    let bounds: Vec<f64> = fans.iter().map(|f| f.lower_bound).collect();
    let (mut owner, mut values, mut flat, mut offsets) =
        (Vec::new(), Vec::new(), Vec::new(), vec![0i64]);
    for (i, f) in fans.iter().enumerate() {
        let best = (!f.fan.is_empty()).then_some((f.value, &f.fan));
        for (value, fan) in best
            .into_iter()
            .chain(f.others.iter().map(|(v, t)| (*v, t)))
        {
            owner.push(i as i64);
            values.push(value);
            flat.extend(fan.iter().map(|&x| i64::from(x)));
            offsets.push(flat.len() as i64);
        }
    }
    Ok(CheapestFans {
        lower_bounds: Array1::from_vec(bounds).into_pyarray(py).unbind(),
        owner: Array1::from_vec(owner).into_pyarray(py).unbind(),
        values: Array1::from_vec(values).into_pyarray(py).unbind(),
        fans: Array1::from_vec(flat).into_pyarray(py).unbind(),
        offsets: Array1::from_vec(offsets).into_pyarray(py).unbind(),
    })
}
