//! Bytes in and out: binary STL records and numeric text tables (`scanmesh_core` io/).

use crate::convert::{face_rows, points3_view};
use crate::results::{TextProblem, TextTable};
use crate::{detached, to_py, ParameterError};
use numpy::ndarray::{Array1, Array2};
use numpy::{IntoPyArray, PyArray1, PyReadonlyArray2};
use pyo3::prelude::*;
use scanmesh_core::io::{parse_table, Table, TextErrorKind};

/// Binary STL records of faces (M, 3) int64 over (N, 3) points: (M * 50,) uint8, normal and
/// corners as little-endian float32, attribute 0 (`scanmesh_core` io::stl). Raises
/// InvalidMeshError for an index out of range. O(M), GIL released.
#[pyfunction]
pub(crate) fn stl_records<'py>(
    py: Python<'py>,
    points: PyReadonlyArray2<'py, f64>,
    faces_: PyReadonlyArray2<'py, i64>,
) -> PyResult<Bound<'py, PyArray1<u8>>> {
    let pts = points3_view(&points)?;
    let t = face_rows(&faces_)?;
    let bytes = detached(py, || scanmesh_core::io::stl_records(&pts, &t))?.map_err(to_py)?;
    Ok(Array1::from_vec(bytes).into_pyarray(py))
}

/// Parses bytes `data[start:stop]` (whole lines) as rows of `ncols` numbers (`ncols` 0: any
/// number per row) separated by whitespace and, when given, the one-character `delimiter`
/// (rules in scanmesh-core's `parse_table`), without the GIL. Returns a `TextTable`: values
/// (R, ncols) float64, or (V, 1) holding every value with `ncols` 0, row_lines (R,) int64
/// and blank_lines (B,) int64, both 0-based line indices within the range, the number of
/// lines, and problem: None, or for a refused range a `TextProblem` naming its first bad
/// line (index, byte offset within the range, "number" | "count"), the other fields then
/// empty.
#[pyfunction]
#[pyo3(signature = (data, start, stop, ncols, delimiter=None))]
pub(crate) fn parse_text_table<'py>(
    py: Python<'py>,
    data: &[u8],
    start: usize,
    stop: usize,
    ncols: usize,
    delimiter: Option<char>,
) -> PyResult<TextTable> {
    if start > stop || stop > data.len() {
        return Err(ParameterError::new_err(format!(
            "need 0 <= start <= stop <= {}, got start {start}, stop {stop}",
            data.len()
        )));
    }
    let delimiter = match delimiter {
        None => None,
        Some(c) if c.is_ascii_punctuation() && c != '#' && c != '.' && c != '-' && c != '+' => {
            Some(c as u8)
        }
        Some(c) => {
            return Err(ParameterError::new_err(format!(
                "delimiter must be one ASCII punctuation character other than # . + -, got {c:?}"
            )))
        }
    };
    let chunk = &data[start..stop];
    let width = ncols.max(1);
    let (table, problem) = match detached(py, || parse_table(chunk, ncols, delimiter))? {
        Ok(table) => (table, None),
        Err(e) => {
            let kind = match e.kind {
                TextErrorKind::NotANumber => "number",
                TextErrorKind::WrongCount => "count",
                TextErrorKind::OutOfMemory => {
                    return Err(to_py(scanmesh_core::Error::OutOfMemory {
                        what: format!("the numbers of {} bytes of text", chunk.len()),
                        needs: (chunk.len() as u64 / 4).saturating_mul(8),
                        limit: "what the allocator could give".into(),
                    }))
                }
            };
            let problem = TextProblem {
                line: e.line,
                offset: e.offset,
                kind,
            };
            (Table::default(), Some(Py::new(py, problem)?))
        }
    };
    let rows = table.values.len() / width;
    let values = Array2::from_shape_vec((rows, width), table.values).expect("width per row");
    Ok(TextTable {
        values: values.into_pyarray(py).unbind(),
        row_lines: Array1::from_vec(table.row_lines).into_pyarray(py).unbind(),
        blank_lines: Array1::from_vec(table.blank_lines)
            .into_pyarray(py)
            .unbind(),
        n_lines: table.n_lines,
        problem,
    })
}
