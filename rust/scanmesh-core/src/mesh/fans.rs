//! The faces around every vertex of a face list, as compressed rows.

use crate::budget::{try_collect, try_filled};
use crate::Result;

/// The faces around every vertex as compressed rows: the faces of vertex `v` are
/// `faces[offsets[v]..offsets[v + 1]]`, in increasing face order (so that sums over a fan
/// add in the same order as a pass over the faces would). O(n + m) time and memory.
pub(crate) struct Fans {
    offsets: Vec<usize>,
    faces: Vec<u32>,
}

impl Fans {
    /// Counting sort of the 3m corners by vertex; `faces` must be checked already. Its
    /// arrays are allocated fallibly (an [`crate::Error::OutOfMemory`]).
    pub(crate) fn new(n_vertices: usize, faces: &[[u32; 3]]) -> Result<Fans> {
        const WHAT: &str = "the faces around each vertex";
        let mut offsets = try_filled(WHAT, 0usize, n_vertices + 1)?;
        for t in faces {
            for &v in t {
                offsets[v as usize + 1] += 1;
            }
        }
        for v in 0..n_vertices {
            offsets[v + 1] += offsets[v];
        }
        let mut fill = try_collect(WHAT, offsets[..n_vertices].iter().copied())?;
        let mut around = try_filled(WHAT, 0u32, offsets[n_vertices])?;
        for (f, t) in faces.iter().enumerate() {
            for &v in t {
                around[fill[v as usize]] = f as u32;
                fill[v as usize] += 1;
            }
        }
        Ok(Fans {
            offsets,
            faces: around,
        })
    }

    /// The faces around vertex `v`, in increasing order.
    #[inline]
    pub(crate) fn of(&self, v: usize) -> &[u32] {
        &self.faces[self.offsets[v]..self.offsets[v + 1]]
    }
}
