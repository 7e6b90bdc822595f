//! numpy in and out: shape checks, zero-copy row views of C-contiguous arrays, and the
//! output arrays (faces widened to int64 on every core without the GIL).

use crate::{detached, to_py, InvalidMeshError, ParameterError, ScanmeshError};
use numpy::ndarray::{Array1, Array2};
use numpy::{IntoPyArray, PyArray1, PyArray2, PyReadonlyArray1, PyReadonlyArray2};
use pyo3::prelude::*;
use rayon::prelude::*;
use scanmesh_core::budget::{try_filled, try_vec};
use scanmesh_core::glam::DVec3;
use scanmesh_core::mesh::NONE;
use scanmesh_core::optimize::SweepRecord;
use std::borrow::Cow;

/// numpy arrays handed to Python: (rows, cols) float64, (n,) float64, (rows, cols) int64, (n,) int64.
pub(crate) type Floats2<'py> = Bound<'py, PyArray2<f64>>;
pub(crate) type Floats1<'py> = Bound<'py, PyArray1<f64>>;
pub(crate) type Ints2<'py> = Bound<'py, PyArray2<i64>>;
pub(crate) type Ints1<'py> = Bound<'py, PyArray1<i64>>;

pub(crate) fn shape_error(name: &str, expected: &str, shape: &[usize]) -> PyErr {
    ScanmeshError::new_err(format!("{name} must have shape {expected}, got {shape:?}"))
}

/// The (3,) vector `a` as a `DVec3`; a shape error naming `name` otherwise.
pub(crate) fn vector3(name: &str, a: &PyReadonlyArray1<'_, f64>) -> PyResult<DVec3> {
    let s = a.as_array();
    if s.len() != 3 {
        return Err(shape_error(name, "(3,)", s.shape()));
    }
    Ok(DVec3::new(s[0], s[1], s[2]))
}

pub(crate) fn points3(a: &PyReadonlyArray2<'_, f64>) -> PyResult<Vec<DVec3>> {
    let v = a.as_array();
    if v.ncols() != 3 {
        return Err(shape_error("points", "(N, 3)", v.shape()));
    }
    // A copy whose allocation may fail: a MemoryLimitError, not an abort.
    let mut out = try_vec("the points", v.nrows()).map_err(to_py)?;
    out.extend(v.rows().into_iter().map(|r| DVec3::new(r[0], r[1], r[2])));
    Ok(out)
}

pub(crate) fn points2(a: &PyReadonlyArray2<'_, f64>) -> PyResult<Vec<[f64; 2]>> {
    let v = a.as_array();
    if v.ncols() != 2 {
        return Err(shape_error("uv", "(N, 2)", v.shape()));
    }
    let mut out = try_vec("the planar points", v.nrows()).map_err(to_py)?;
    out.extend(v.rows().into_iter().map(|r| [r[0], r[1]]));
    Ok(out)
}

/// `flat`, C-order rows of `size_of::<R>() / size_of::<T>()` values each, as a slice of
/// rows, without a copy (`slice::as_chunks` is newer than our MSRV). None when `R` is not a
/// whole number of `T`s, is more strictly aligned, or `flat` is not whole rows.
///
/// # Safety
/// `R` must consist of exactly those `T` values in order, no padding, every bit pattern
/// valid: `[T; K]`, or `DVec3` (`#[repr(C)]` x, y, z) for `T` = f64.
unsafe fn as_rows<T, R>(flat: &[T]) -> Option<&[R]> {
    let (row, value) = (std::mem::size_of::<R>(), std::mem::size_of::<T>());
    if value == 0 || row % value != 0 || std::mem::align_of::<R>() > std::mem::align_of::<T>() {
        return None;
    }
    let k = row / value;
    if k == 0 || flat.len() % k != 0 {
        return None;
    }
    // SAFETY: the caller guarantees R's layout is K values of T; `flat` is aligned for T
    // and so for R (checked), and holds len / K whole rows, borrowed for the same lifetime.
    Some(unsafe { std::slice::from_raw_parts(flat.as_ptr().cast::<R>(), flat.len() / k) })
}

/// (N, 3) float64 points borrowed as `DVec3`s when numpy holds them C-contiguous (as
/// `as_points` makes them): no copy, 240 MB fewer at 10M points; copied otherwise.
pub(crate) fn points3_view<'a>(a: &'a PyReadonlyArray2<'_, f64>) -> PyResult<Cow<'a, [DVec3]>> {
    let v = a.as_array();
    if v.ncols() != 3 {
        return Err(shape_error("points", "(N, 3)", v.shape()));
    }
    // SAFETY: `DVec3` is `#[repr(C)] struct { x, y, z: f64 }`.
    match v
        .to_slice()
        .and_then(|flat| unsafe { as_rows::<f64, DVec3>(flat) })
    {
        Some(points) => Ok(Cow::Borrowed(points)),
        None => points3(a).map(Cow::Owned),
    }
}

/// (N, 2) float64 planar points borrowed when C-contiguous, copied otherwise.
pub(crate) fn points2_view<'a>(a: &'a PyReadonlyArray2<'_, f64>) -> PyResult<Cow<'a, [[f64; 2]]>> {
    let v = a.as_array();
    // SAFETY: `[f64; 2]` is two f64.
    match v
        .to_slice()
        .filter(|_| v.ncols() == 2)
        .and_then(|flat| unsafe { as_rows(flat) })
    {
        Some(uv) => Ok(Cow::Borrowed(uv)),
        None => points2(a).map(Cow::Owned),
    }
}

/// (M, 3) int64 faces borrowed as rows when C-contiguous, copied otherwise; the indices are
/// not checked (the callee checks them where it reads them).
pub(crate) fn face_rows<'a>(a: &'a PyReadonlyArray2<'_, i64>) -> PyResult<Cow<'a, [[i64; 3]]>> {
    let v = a.as_array();
    if v.ncols() != 3 {
        return Err(shape_error("faces", "(M, 3)", v.shape()));
    }
    // SAFETY: `[i64; 3]` is three i64.
    Ok(
        match v.to_slice().and_then(|flat| unsafe { as_rows(flat) }) {
            Some(rows) => Cow::Borrowed(rows),
            None => Cow::Owned(v.rows().into_iter().map(|r| [r[0], r[1], r[2]]).collect()),
        },
    )
}

pub(crate) fn faces(a: &PyReadonlyArray2<'_, i64>, n_vertices: usize) -> PyResult<Vec<[u32; 3]>> {
    let v = a.as_array();
    if v.ncols() != 3 {
        return Err(shape_error("faces", "(M, 3)", v.shape()));
    }
    let mut out = try_vec("the faces", v.nrows()).map_err(to_py)?;
    for (f, r) in v.rows().into_iter().enumerate() {
        let mut t = [0u32; 3];
        for k in 0..3 {
            let x = r[k];
            if x < 0 || x as u64 >= n_vertices as u64 {
                return Err(InvalidMeshError::new_err(format!(
                    "face {f}: vertex index {x} out of range (there are {n_vertices} vertices)"
                )));
            }
            t[k] = x as u32;
        }
        out.push(t);
    }
    Ok(out)
}

/// (M, 3) int64 faces for numpy, widened on every core without the GIL: 24 bytes a face to
/// write. Allocated fallibly: memory refused is a `MemoryLimitError`, not an abort.
pub(crate) fn faces_out<'py>(py: Python<'py>, t: &[[u32; 3]]) -> PyResult<Ints2<'py>> {
    let flat = detached(py, || {
        let mut flat = try_filled("the faces for numpy", 0i64, 3 * t.len())?;
        flat.par_chunks_mut(3 * 4096)
            .zip(t.par_chunks(4096))
            .for_each(|(out, faces)| {
                for (o, f) in out.chunks_exact_mut(3).zip(faces) {
                    o.copy_from_slice(&f.map(i64::from));
                }
            });
        Ok(flat)
    })?;
    Ok(Array2::from_shape_vec((t.len(), 3), flat.map_err(to_py)?)
        .expect("3 per face")
        .into_pyarray(py))
}

/// (N, 3) float64 points for numpy (a fused or simplified mesh's vertices: the only
/// points the core makes). Allocated fallibly: memory refused is a `MemoryLimitError`. O(N).
pub(crate) fn points3_out<'py>(py: Python<'py>, points: &[DVec3]) -> PyResult<Floats2<'py>> {
    let mut flat = try_vec("the vertices for numpy", 3 * points.len()).map_err(to_py)?;
    flat.extend(points.iter().flat_map(|p| p.to_array()));
    Ok(Array2::from_shape_vec((points.len(), 3), flat)
        .expect("3 per point")
        .into_pyarray(py))
}

/// (N, 2) float64 planar points for numpy, taking over `uv`'s buffer (no copy).
pub(crate) fn uv_into<'py>(py: Python<'py>, uv: Vec<[f64; 2]>) -> Floats2<'py> {
    let n = uv.len();
    let mut uv = std::mem::ManuallyDrop::new(uv);
    // SAFETY: `[f64; 2]` is two f64 without padding, with f64's alignment; the buffer's
    // length and capacity in f64s are twice those in pairs, and it is no longer owned by
    // `uv` (ManuallyDrop), so it is freed once, by the new Vec.
    let flat =
        unsafe { Vec::from_raw_parts(uv.as_mut_ptr().cast::<f64>(), 2 * n, 2 * uv.capacity()) };
    Array2::from_shape_vec((n, 2), flat)
        .expect("2 per point")
        .into_pyarray(py)
}

pub(crate) fn trace_out<'py>(py: Python<'py>, trace: &[SweepRecord]) -> Floats2<'py> {
    let flat: Vec<f64> = trace
        .iter()
        .flat_map(|r| [r.temperature, r.energy, r.best, r.acceptance])
        .collect();
    Array2::from_shape_vec((trace.len(), 4), flat)
        .expect("4 per sweep")
        .into_pyarray(py)
}

pub(crate) fn line_ids_in(a: &PyReadonlyArray1<'_, i64>, n: usize) -> PyResult<Vec<i64>> {
    let v = a.as_array();
    if v.len() != n {
        return Err(shape_error("line_ids", &format!("({n},)"), v.shape()));
    }
    Ok(v.iter().copied().collect())
}

pub(crate) fn pairs_out<'py>(py: Python<'py>, pairs: &[(u32, u32)]) -> Bound<'py, PyArray2<i64>> {
    let flat: Vec<i64> = pairs
        .iter()
        .flat_map(|&(a, b)| [i64::from(a), i64::from(b)])
        .collect();
    Array2::from_shape_vec((pairs.len(), 2), flat)
        .expect("2 per pair")
        .into_pyarray(py)
}

/// (K,) int64 point indices for numpy.
pub(crate) fn indices_out<'py>(py: Python<'py>, indices: &[u32]) -> Ints1<'py> {
    Array1::from_iter(indices.iter().map(|&k| i64::from(k))).into_pyarray(py)
}

/// (N,) int64 for numpy: -1 where the core has `NONE`, else the index of the earlier
/// identical point standing in.
pub(crate) fn duplicates_out<'py>(py: Python<'py>, duplicate_of: &[u32]) -> Ints1<'py> {
    Array1::from_iter(
        duplicate_of
            .iter()
            .map(|&k| if k == NONE { -1 } else { i64::from(k) }),
    )
    .into_pyarray(py)
}

/// (K, 2) int64 vertex index pairs `a` (named `name` in errors) as `[u32; 2]`, each index
/// below `n_vertices`; a `ParameterError` names the first pair out of range. O(K).
pub(crate) fn edges(
    name: &str,
    a: &PyReadonlyArray2<'_, i64>,
    n_vertices: usize,
) -> PyResult<Vec<[u32; 2]>> {
    let v = a.as_array();
    if v.ncols() != 2 {
        return Err(shape_error(name, "(K, 2)", v.shape()));
    }
    let mut out = try_vec("the edges", v.nrows()).map_err(to_py)?;
    for (k, r) in v.rows().into_iter().enumerate() {
        let pair = [r[0], r[1]];
        if pair.iter().any(|&x| x < 0 || x as u64 >= n_vertices as u64) {
            return Err(ParameterError::new_err(format!(
                "{name} edge {k}: vertex indices {pair:?} out of range (there are {n_vertices} vertices)"
            )));
        }
        out.push(pair.map(|x| x as u32));
    }
    Ok(out)
}
