//! Binary STL records, encoded in parallel: the writer's per-face work (gather, normal,
//! float32 rounding) outweighs the file I/O (docs/benchmarks/speed.md, "Figures behind the
//! core's constants").

use crate::{Error, Result};
use glam::DVec3;
use rayon::prelude::*;

/// Bytes of one binary STL record: unit normal and three corners (12 little-endian
/// float32), then a u16 attribute count (0).
pub const RECORD_BYTES: usize = 50;

/// Faces encoded per parallel task.
const GROUP: usize = 4096;

/// The binary STL records of `faces` over `points`, `RECORD_BYTES` per face in face order:
/// the unit normal of the float64 triangle by the right-hand rule (zero when degenerate),
/// then the corners rounded to float32, attribute 0, as trimesh writes them.
///
/// Faces are taken in the caller's index type (the binding reads numpy's int64 rows in
/// place). Errors: a face with an index out of range (the first one is named). O(m) time,
/// in parallel over the faces; `RECORD_BYTES` per face of output.
pub fn records<I>(points: &[DVec3], faces: &[[I; 3]]) -> Result<Vec<u8>>
where
    I: Copy + Sync + TryInto<usize>,
{
    let index = |i: I| i.try_into().ok().filter(|&k| k < points.len());
    if let Some(f) = faces
        .par_iter()
        .position_first(|t| t.iter().any(|&i| index(i).is_none()))
    {
        return Err(Error::InvalidFace {
            face: f,
            reason: format!(
                "vertex index out of range (there are {} vertices)",
                points.len()
            ),
        });
    }
    let mut out = crate::budget::try_vec("STL records", faces.len() * RECORD_BYTES)?;
    out.resize(faces.len() * RECORD_BYTES, 0u8);
    // Faces in groups (one rayon task each), every record assembled on the stack and
    // copied once: per-face tasks and per-value slice checks cost more than the arithmetic.
    out.par_chunks_mut(GROUP * RECORD_BYTES)
        .zip(faces.par_chunks(GROUP))
        .for_each(|(records, group)| {
            for (record, t) in records.chunks_exact_mut(RECORD_BYTES).zip(group) {
                // `index` cannot fail here: every face was checked above.
                let [a, b, c] = t.map(|i| points[index(i).unwrap_or(0)]);
                let normal = (b - a).cross(c - a);
                let length = normal.length();
                let normal = if length > 0.0 {
                    normal / length
                } else {
                    normal
                };
                let mut bytes = [0u8; RECORD_BYTES]; // bytes 48..50, the attribute count, stay 0
                for (k, v) in [normal, a, b, c].iter().enumerate() {
                    for (j, x) in v.to_array().iter().enumerate() {
                        let at = 12 * k + 4 * j;
                        bytes[at..at + 4].copy_from_slice(&(*x as f32).to_le_bytes());
                    }
                }
                record.copy_from_slice(&bytes);
            }
        });
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn one_record_and_a_degenerate_one() {
        let pts = [DVec3::ZERO, DVec3::X * 2.0, DVec3::new(0.0, 0.1, 0.0)];
        let out = records(&pts, &[[0u32, 1, 2], [0, 1, 1]]).unwrap();
        assert_eq!(out.len(), 2 * RECORD_BYTES);
        let f = |r: usize, k: usize| {
            let at = r * RECORD_BYTES + 4 * k;
            f32::from_le_bytes(out[at..at + 4].try_into().unwrap())
        };
        assert_eq!([f(0, 0), f(0, 1), f(0, 2)], [0.0, 0.0, 1.0]);
        assert_eq!([f(0, 6), f(0, 10)], [2.0, 0.1f64 as f32]);
        assert_eq!([f(1, 0), f(1, 1), f(1, 2)], [0.0, 0.0, 0.0]);
        assert_eq!(&out[48..50], &[0, 0]);
        assert!(matches!(
            records(&pts, &[[0i64, 1, 2], [0, -1, 2]]),
            Err(Error::InvalidFace { face: 1, .. })
        ));
        assert!(matches!(
            records(&pts, &[[0i64, 1, 3]]),
            Err(Error::InvalidFace { face: 0, .. })
        ));
    }
}
