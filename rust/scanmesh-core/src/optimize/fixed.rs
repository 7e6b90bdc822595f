//! Fixed edges: edges of a triangulation that flip optimizers must keep, such as the walls
//! and steps the strips bridge along the scan lines, so that annealing on tac smooths the
//! rest of the surface without re-bridging them.
//!
//! Why a set keyed by the two vertices and not a mask of half-edge slots: a flip moves the
//! five edges of its quadrilateral to other slots, so a slot does not name an edge for long;
//! its two vertices do, and a kept edge keeps them. A bit per vertex (it ends a fixed edge)
//! answers most queries with one load; only an edge both of whose vertices end fixed edges
//! is looked up in the sorted keys.

use crate::budget::{try_collect, try_filled};
use crate::error::Error;
use crate::Result;

/// A set of undirected edges between vertices `0..n_vertices`, each named by its two ends.
/// Memory: one bit per vertex and 8 bytes per edge.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct FixedEdges {
    n_vertices: usize,
    // One bit per vertex: it ends at least one fixed edge.
    ends: Vec<u64>,
    // `key(a, b)` of every fixed edge, sorted, without repeats.
    keys: Vec<u64>,
}

/// The key of the undirected edge {a, b}: the smaller end in the high half. O(1).
#[inline(always)]
fn key(a: u32, b: u32) -> u64 {
    let (lo, hi) = if a < b { (a, b) } else { (b, a) };
    (u64::from(lo) << 32) | u64::from(hi)
}

impl FixedEdges {
    /// The set of `edges` (pairs of vertex indices, either order, repeats allowed) over
    /// `n_vertices` vertices. Errors: [`Error::InvalidParameter`] naming "fixed edges" for
    /// an index out of range or an edge from a vertex to itself; an
    /// [`Error::OutOfMemory`] for the set. O(k log k) for k edges.
    pub fn new(n_vertices: usize, edges: &[[u32; 2]]) -> Result<Self> {
        if let Some(bad) = edges
            .iter()
            .find(|[a, b]| a == b || *a as usize >= n_vertices || *b as usize >= n_vertices)
        {
            return Err(Error::InvalidParameter {
                name: "fixed edges",
                value: format!("{bad:?} over {n_vertices} vertices"),
                expected: "pairs of two different vertex indices below the vertex count",
            });
        }
        let mut keys = try_collect("the fixed edges", edges.iter().map(|&[a, b]| key(a, b)))?;
        keys.sort_unstable();
        keys.dedup();
        let mut ends = try_filled("the fixed edges", 0u64, n_vertices.div_ceil(64))?;
        for &[a, b] in edges {
            for v in [a, b] {
                ends[v as usize / 64] |= 1 << (v % 64);
            }
        }
        Ok(FixedEdges {
            n_vertices,
            ends,
            keys,
        })
    }

    /// The same edges with every vertex `v` renamed `to_new[v]` (a permutation of
    /// `0..n_vertices`, as a relabelling's `to_local`). O(k log k).
    pub fn renamed(&self, to_new: &[u32]) -> Result<Self> {
        let edges = try_collect(
            "the fixed edges",
            self.edges()
                .map(|[a, b]| [to_new[a as usize], to_new[b as usize]]),
        )?;
        FixedEdges::new(self.n_vertices, &edges)
    }

    /// The edges, each once, smaller end first, in increasing order. O(k).
    pub fn edges(&self) -> impl ExactSizeIterator<Item = [u32; 2]> + '_ {
        self.keys.iter().map(|&k| [(k >> 32) as u32, k as u32])
    }

    /// Number of distinct edges. O(1).
    pub fn len(&self) -> usize {
        self.keys.len()
    }

    /// True when there is no edge. O(1).
    pub fn is_empty(&self) -> bool {
        self.keys.is_empty()
    }

    /// Number of vertices the edges are over. O(1).
    pub fn n_vertices(&self) -> usize {
        self.n_vertices
    }

    /// True when the edge {a, b} is fixed. O(1) unless both ends end fixed edges, then
    /// O(log k).
    #[inline]
    pub fn contains(&self, a: u32, b: u32) -> bool {
        let ends = |v: u32| self.ends[v as usize / 64] & (1 << (v % 64)) != 0;
        ends(a) && ends(b) && self.keys.binary_search(&key(a, b)).is_ok()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn contains_the_given_edges_in_either_order_and_no_other() {
        let f = FixedEdges::new(5, &[[0, 1], [3, 1], [1, 0]]).unwrap();
        assert_eq!(f.len(), 2);
        assert!(f.contains(0, 1) && f.contains(1, 0) && f.contains(1, 3) && f.contains(3, 1));
        // Both ends of 0-3 end fixed edges, the edge itself is not fixed.
        assert!(!f.contains(0, 3) && !f.contains(2, 4) && !f.contains(1, 2));
        assert_eq!(f.edges().collect::<Vec<_>>(), vec![[0, 1], [1, 3]]);
    }

    #[test]
    fn bad_edges_are_refused_by_name() {
        for bad in [[0u32, 5], [2, 2], [7, 1]] {
            let e = FixedEdges::new(5, &[[0, 1], bad]).unwrap_err();
            assert!(e.to_string().contains("fixed edges"), "{e}");
        }
    }

    /// Sorted undirected edges of `mesh`.
    fn edge_set(mesh: &crate::mesh::HalfEdgeMesh) -> std::collections::BTreeSet<[u32; 2]> {
        let key = |a: u32, b: u32| [a.min(b), a.max(b)];
        let tris = mesh.triangles().unwrap();
        tris.iter()
            .flat_map(|t| [key(t[0], t[1]), key(t[1], t[2]), key(t[2], t[0])])
            .collect()
    }

    #[test]
    fn lop_and_annealing_keep_fixed_edges_they_would_flip() {
        use crate::optimize::anneal::AnnealParams;
        use crate::optimize::ensemble::Ensemble;
        use crate::optimize::lop::{tac_lop, TacOrder};
        use crate::optimize::tac_state::tests::bumpy_state;
        let start = bumpy_state(300, 4, 1.0);
        let before = edge_set(start.mesh());
        let mut free = start.clone();
        tac_lop(&mut free, TacOrder::new(1e-10, true).unwrap()).unwrap();
        let flipped: Vec<[u32; 2]> = before.difference(&edge_set(free.mesh())).copied().collect();
        assert!(
            flipped.len() > 10,
            "LOP should flip edges here: {}",
            flipped.len()
        );
        let n = start.mesh().n_vertices();
        let fixed = FixedEdges::new(n, &flipped).unwrap();
        let mut kept = start.clone().with_fixed(Some(fixed.clone())).unwrap();
        tac_lop(&mut kept, TacOrder::new(1e-10, true).unwrap()).unwrap();
        let after = edge_set(kept.mesh());
        assert!(flipped.iter().all(|e| after.contains(e)));
        let params = AnnealParams {
            sweeps: 40,
            chains: 2,
            ..AnnealParams::default()
        };
        let state = start.clone().with_fixed(Some(fixed)).unwrap();
        let (r, _) = Ensemble::new(state, params.clone()).unwrap().run().unwrap();
        let after = edge_set(&r.mesh);
        assert!(flipped.iter().all(|e| after.contains(e)));
        // Tiled chains rebuild their pieces and could not keep them: refused by name.
        let tiled = AnnealParams { tiles: 2, ..params };
        let state = start
            .with_fixed(Some(FixedEdges::new(n, &flipped).unwrap()))
            .unwrap();
        let e = Ensemble::new(state, tiled).err().unwrap();
        assert!(e.to_string().contains("tiles"), "{e}");
    }

    #[test]
    fn renaming_follows_the_permutation() {
        let f = FixedEdges::new(4, &[[0, 1], [2, 3]]).unwrap();
        let g = f.renamed(&[3, 2, 1, 0]).unwrap();
        assert!(g.contains(3, 2) && g.contains(1, 0) && !g.contains(0, 2));
    }
}
