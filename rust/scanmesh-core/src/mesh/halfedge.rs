//! A flat half-edge triangulation that supports edge flips; positions are kept apart.
//!
//! Layout (as delaunator): triangle `t` owns half-edges `3t`, `3t + 1`, `3t + 2` in
//! counter-clockwise order, so `next` and `prev` are arithmetic and only two arrays are
//! stored: `start[h]` (the vertex the half-edge leaves) and `twin[h]` (the opposite
//! half-edge, `NONE` on the boundary). A flip rewrites the six slots of its two triangles
//! in place; nothing is allocated.

use crate::budget::{try_collect, try_filled, try_vec};
use crate::geometry::orient2d;
use crate::mesh::locality::prefetch;
use crate::{Error, Result};
use rayon::prelude::*;
use std::sync::atomic::{AtomicU64, Ordering};

/// Marks "no such index" in index arrays (boundary twins, unique points).
pub const NONE: u32 = u32::MAX;

/// Items per rayon task in the mesh's parallel passes (half-edges, triangles or
/// vertices): large enough that splitting costs nothing next to the work.
pub(super) const BLOCK: usize = 1 << 14;

/// Triples whose triangle has a smallest angle with sine below about this count as collinear
/// for flips. Scan grids put many points on lines (grid diagonals) that are straight in the
/// reals but not in floating point; exact predicates call those triangles valid, and a
/// flip into one (angles near 1e-13 degrees) cannot be undone by any convex flip later.
pub const COLLINEAR_SINE: f64 = 1e-10;

/// True when planar triangle (a, b, c) is counter-clockwise and not numerically collinear:
/// twice its area exceeds `COLLINEAR_SINE` times its longest edge squared, which bounds the
/// sine of its smallest angle from below. O(1).
#[inline]
pub fn well_formed(a: [f64; 2], b: [f64; 2], c: [f64; 2]) -> bool {
    let area2 = orient2d(a, b, c);
    if area2 <= 0.0 {
        return false;
    }
    let sq = |p: [f64; 2], q: [f64; 2]| (p[0] - q[0]).powi(2) + (p[1] - q[1]).powi(2);
    area2 > COLLINEAR_SINE * sq(a, b).max(sq(b, c)).max(sq(c, a))
}

/// True when the quadrilateral (a, d, b, c) around diagonal a→b (triangles (a, b, c) and
/// (b, a, d), counter-clockwise) may flip to diagonal c→d: both new triangles (d, c, a) and
/// (c, d, b) are [`well_formed`]. The test of [`HalfEdgeMesh::can_flip`], for callers that
/// hold the positions elsewhere. O(1).
#[inline]
pub fn convex_quad(a: [f64; 2], b: [f64; 2], c: [f64; 2], d: [f64; 2]) -> bool {
    well_formed(d, c, a) && well_formed(c, d, b)
}

/// The three entries of triangle `t` in a per-slot array, with one bounds check (the
/// range's) instead of three. O(1).
#[inline(always)]
fn slots3(v: &[u32], t: usize) -> [u32; 3] {
    let s = &v[3 * t..3 * t + 3];
    [s[0], s[1], s[2]]
}

/// Connectivity of a triangulation of `n_vertices` points.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct HalfEdgeMesh {
    pub(super) start: Vec<u32>,
    pub(super) twin: Vec<u32>,
    /// For each vertex, one half-edge leaving it: on a boundary vertex, the one without a
    /// twin (the most clockwise), so that a counter-clockwise walk covers the whole fan.
    pub(super) vertex_edge: Vec<u32>,
    pub(super) on_boundary: Vec<bool>,
    /// False after [`flip_unanchored`](Self::flip_unanchored): `vertex_edge` may name
    /// half-edges that no longer leave their vertex until [`reanchor`](Self::reanchor).
    pub(super) anchored: bool,
}

/// The next half-edge in the same triangle (counter-clockwise). O(1).
#[inline]
pub fn next(h: u32) -> u32 {
    if h % 3 == 2 {
        h - 2
    } else {
        h + 1
    }
}

/// The previous half-edge in the same triangle. O(1).
#[inline]
pub fn prev(h: u32) -> u32 {
    if h % 3 == 0 {
        h + 2
    } else {
        h - 1
    }
}

impl HalfEdgeMesh {
    /// Builds the mesh from consistently oriented triangles over vertices `0..n_vertices`.
    ///
    /// Errors: an index out of range, a repeated vertex in a triangle, or a directed edge
    /// used twice (two triangles on the same side of an edge: inconsistent orientation or
    /// a non-manifold edge). O(m + n) work for m triangles and n vertices (a counting sort
    /// of the half-edges by start vertex, then per-vertex passes), in parallel on the
    /// rayon pool; the result and the error do not depend on the thread count.
    pub fn from_triangles(n_vertices: usize, triangles: &[[u32; 3]]) -> Result<Self> {
        let m = triangles.len();
        if 3 * m >= NONE as usize {
            return Err(Error::InvalidParameter {
                name: "faces",
                value: m.to_string(),
                expected: "fewer than 2^32 / 3 triangles",
            });
        }
        // The lowest bad face, as a serial scan would report it.
        let bad_face = triangles
            .par_iter()
            .with_min_len(BLOCK)
            .enumerate()
            .find_map_first(|(f, t)| {
                if let Some(&v) = t.iter().find(|&&v| v as usize >= n_vertices) {
                    return Some(Error::InvalidFace {
                        face: f,
                        reason: format!(
                            "vertex index {v} out of range (there are {n_vertices} vertices)"
                        ),
                    });
                }
                (t[0] == t[1] || t[1] == t[2] || t[0] == t[2]).then(|| Error::InvalidFace {
                    face: f,
                    reason: format!("repeats a vertex: {t:?}"),
                })
            });
        if let Some(e) = bad_face {
            return Err(e);
        }
        // Input-sized buffers whose allocation may fail: an Error, never an abort.
        let start = try_collect("half-edges", triangles.as_flattened().iter().copied())?;
        let out = Outgoing::new(n_vertices, &start)?;
        if out.repeats_a_directed_edge() {
            // Rare (a bad input): the sort names the same edge and faces as always.
            return Err(Self::repeated_edge_by_sort(&start));
        }
        // Twins: the twin of a→b is the one half-edge b→a in b's list, if any.
        let mut twin = try_filled("half-edge twins", NONE, 3 * m)?;
        twin.par_chunks_mut(BLOCK)
            .enumerate()
            .for_each(|(c, chunk)| {
                for (k, tw) in chunk.iter_mut().enumerate() {
                    let h = (c * BLOCK + k) as u32;
                    let (a, b) = (start[h as usize], start[next(h) as usize]);
                    if let Some(g) = out.find(b, a) {
                        *tw = g;
                    }
                }
            });
        // Each vertex from its own list: vertex_edge is its highest twin-less outgoing
        // half-edge, else its lowest (what a serial pass over h that lets twin-less
        // half-edges overwrite would leave); it is on the boundary when a twin-less
        // half-edge leaves or enters it, and every half-edge entering v is prev(h) of a
        // half-edge h leaving v (the same triangle's corner).
        let mut vertex_edge = try_filled("vertex half-edges", NONE, n_vertices)?;
        let mut on_boundary = try_filled("boundary flags", false, n_vertices)?;
        vertex_edge
            .par_chunks_mut(BLOCK)
            .zip(on_boundary.par_chunks_mut(BLOCK))
            .enumerate()
            .for_each(|(c, (edges, flags))| {
                for (k, (e, flag)) in edges.iter_mut().zip(flags.iter_mut()).enumerate() {
                    let (mut lowest, mut twinless) = (NONE, None);
                    for &h in out.half_edges(c * BLOCK + k) {
                        lowest = lowest.min(h);
                        if twin[h as usize] == NONE {
                            twinless = twinless.max(Some(h));
                            *flag = true;
                        } else if twin[prev(h) as usize] == NONE {
                            *flag = true;
                        }
                    }
                    *e = twinless.unwrap_or(lowest);
                }
            });
        Ok(HalfEdgeMesh {
            start,
            twin,
            vertex_edge,
            on_boundary,
            anchored: true,
        })
    }

    /// The error for half-edges `start` (three per triangle) with a repeated directed
    /// edge: the lowest undirected edge (min << 32 | max) whose half-edges do not form
    /// one opposite pair, naming the faces of its two lowest half-edges. O(m log m); only
    /// called once [`Outgoing::repeats_a_directed_edge`] has found one, so that the error
    /// is the one this check has always named.
    fn repeated_edge_by_sort(start: &[u32]) -> Error {
        let undirected = |h: u32| {
            let (a, b) = (start[h as usize], start[next(h) as usize]);
            ((a.min(b) as u64) << 32) | a.max(b) as u64
        };
        let mut keyed: Vec<(u64, u32)> = (0..start.len() as u32)
            .map(|h| (undirected(h), h))
            .collect();
        keyed.par_sort_unstable(); // (key, half-edge) pairs are distinct: deterministic
        let mut k = 0;
        while k < keyed.len() {
            let run = keyed[k..].iter().take_while(|e| e.0 == keyed[k].0).count();
            if run >= 2 {
                let (h, g) = (keyed[k].1, keyed[k + 1].1);
                let (a, b) = (start[h as usize], start[next(h) as usize]);
                if run > 2 || start[g as usize] == a {
                    return Error::InvalidFace {
                        face: (g / 3) as usize,
                        reason: format!(
                            "edge {a}->{b} is also used by face {}: faces must be consistently oriented and each edge shared by at most two faces",
                            h / 3
                        ),
                    };
                }
            }
            k += run;
        }
        unreachable!("repeated_edge_by_sort called on half-edges without a repeated edge")
    }

    /// A copy whose allocations may fail instead of aborting: for copies an option
    /// multiplies (annealing chains). O(m + n).
    pub fn try_clone(&self) -> std::result::Result<Self, std::collections::TryReserveError> {
        use crate::budget::try_copy;
        Ok(HalfEdgeMesh {
            start: try_copy(&self.start)?,
            twin: try_copy(&self.twin)?,
            vertex_edge: try_copy(&self.vertex_edge)?,
            on_boundary: try_copy(&self.on_boundary)?,
            anchored: self.anchored,
        })
    }

    /// Bytes its arrays take (for memory estimates). O(1).
    pub fn heap_bytes(&self) -> u64 {
        (4 * (self.start.len() + self.twin.len() + self.vertex_edge.len()) + self.on_boundary.len())
            as u64
    }

    /// Number of vertices (used or not). O(1).
    pub fn n_vertices(&self) -> usize {
        self.vertex_edge.len()
    }

    /// Number of triangles. O(1).
    pub fn n_triangles(&self) -> usize {
        self.start.len() / 3
    }

    /// Number of half-edges (three per triangle). O(1).
    pub fn n_half_edges(&self) -> usize {
        self.start.len()
    }

    /// The vertex half-edge `h` leaves. O(1).
    #[inline]
    pub fn start(&self, h: u32) -> u32 {
        self.start[h as usize]
    }

    /// The vertex half-edge `h` arrives at. O(1).
    #[inline]
    pub fn end(&self, h: u32) -> u32 {
        self.start[next(h) as usize]
    }

    /// The opposite half-edge, or `NONE` on the boundary. O(1).
    #[inline]
    pub fn twin(&self, h: u32) -> u32 {
        self.twin[h as usize]
    }

    /// The three vertices of triangle `t`, counter-clockwise. O(1).
    #[inline]
    pub fn triangle(&self, t: usize) -> [u32; 3] {
        [
            self.start[3 * t],
            self.start[3 * t + 1],
            self.start[3 * t + 2],
        ]
    }

    /// All triangles, counter-clockwise. Errors: an [`Error::OutOfMemory`] for the list.
    /// O(m).
    pub fn triangles(&self) -> Result<Vec<[u32; 3]>> {
        let all = (0..self.n_triangles()).map(|t| self.triangle(t));
        try_collect("the mesh's triangles", all)
    }

    /// One half-edge per undirected edge (the lower of a twin pair; every boundary half-edge).
    /// O(m).
    pub fn edges(&self) -> impl Iterator<Item = u32> + '_ {
        (0..self.start.len() as u32).filter(move |&h| {
            let t = self.twin[h as usize];
            t == NONE || h < t
        })
    }

    /// One half-edge per interior edge (both sides have a triangle). Errors: an
    /// [`Error::OutOfMemory`] for the list. O(m).
    pub fn interior_edges(&self) -> Result<Vec<u32>> {
        let mut edges = try_vec("the interior edges", self.interior_edge_slots().count())?;
        edges.extend(self.interior_edge_slots());
        Ok(edges)
    }

    /// The slots of [`interior_edges`](Self::interior_edges), in increasing order, without
    /// a vector: for callers that allocate it themselves (fallibly). O(m) to walk.
    pub fn interior_edge_slots(&self) -> impl DoubleEndedIterator<Item = u32> + '_ {
        (0..self.start.len() as u32).filter(|&h| {
            let t = self.twin[h as usize];
            t != NONE && h < t
        })
    }

    /// True when `v` is used and no boundary edge touches it: its triangles form a closed fan.
    /// O(1).
    #[inline]
    pub fn is_interior(&self, v: u32) -> bool {
        self.vertex_edge[v as usize] != NONE && !self.on_boundary[v as usize]
    }

    /// True when `v` belongs to at least one triangle. O(1).
    #[inline]
    pub fn is_used(&self, v: u32) -> bool {
        self.vertex_edge[v as usize] != NONE
    }

    /// The half-edges leaving `v`, counter-clockwise, starting from the most clockwise one on
    /// a boundary vertex. Needs an anchored mesh (see [`reanchor`](Self::reanchor)).
    /// O(degree).
    pub fn fan(&self, v: u32) -> Fan<'_> {
        debug_assert!(self.anchored, "fan walk on a mesh that needs reanchor()");
        let first = self.vertex_edge[v as usize];
        Fan {
            mesh: self,
            first,
            current: first,
        }
    }

    /// True when flipping `h` is allowed: it is interior and its two triangles form a
    /// strictly convex quadrilateral in the plane, with no three of its corners collinear.
    ///
    /// With the quadrilateral (a, d, b, c) around diagonal a→b, the old triangles are strictly
    /// counter-clockwise by invariant, so strict convexity is exactly that both new triangles
    /// (d, c, a) and (c, d, b) are strictly counter-clockwise (exact predicate). "Collinear"
    /// includes numerically collinear: see `COLLINEAR_SINE`. O(1).
    pub fn can_flip(&self, h: u32, uv: &[[f64; 2]]) -> bool {
        let t = self.twin[h as usize];
        if t == NONE {
            return false;
        }
        let [a, b, c, d] = self.quad(h, t).map(|v| uv[v as usize]);
        convex_quad(a, b, c, d)
    }

    /// The four corners (a, b, c, d) around interior half-edge `h` = a→b with twin `t`:
    /// c is opposite h, d opposite t. O(1).
    #[inline]
    pub fn quad(&self, h: u32, t: u32) -> [u32; 4] {
        [
            self.start(h),
            self.start(t),
            self.start(prev(h)),
            self.start(prev(t)),
        ]
    }

    /// Prefetch hint for the `start` and `twin` entries of triangle `t` (see
    /// `crate::mesh::locality::prefetch`; no effect on results). O(1).
    #[inline(always)]
    pub fn prefetch_triangle(&self, t: u32) {
        // A triangle's three u32 entries straddle two cache lines in 2 of 16 positions:
        // hint both ends.
        let first = 3 * t as usize;
        for s in [&self.start, &self.twin] {
            prefetch(s, first);
            prefetch(s, first + 2);
        }
    }

    /// Prefetch hint for what [`flip`](Self::flip)`(h)` writes outside the two triangles of
    /// `h`: the twins of the four outer edges and the corners' `vertex_edge` (`t` and `quad`
    /// from [`twin_and_quad`](Self::twin_and_quad), which has read the twin already). Reads
    /// the two triangles, so call it once they are cached. No effect on results. O(1).
    #[inline(always)]
    pub fn prefetch_flip_writes(&self, h: u32, t: u32, quad: [u32; 4]) {
        for e in [h, t] {
            let (th, k) = (e as usize / 3, e as usize % 3);
            let twins = slots3(&self.twin, th);
            for o in [twins[(k + 1) % 3], twins[(k + 2) % 3]] {
                if o != NONE {
                    prefetch(&self.twin, o as usize);
                }
            }
        }
        for v in quad {
            prefetch(&self.vertex_edge, v as usize);
        }
    }

    /// The twin `t` of `h` and the corners (a, b, c, d) of [`quad`](Self::quad)`(h, t)`,
    /// reading each triangle's slots as one block; `None` when `h` is on the boundary. O(1).
    #[inline(always)]
    pub fn twin_and_quad(&self, h: u32) -> Option<(u32, [u32; 4])> {
        let t = self.twin[h as usize];
        if t == NONE {
            return None;
        }
        let (th, kh) = (h as usize / 3, h as usize % 3);
        let (tt, kt) = (t as usize / 3, t as usize % 3);
        let (sh, st) = (slots3(&self.start, th), slots3(&self.start, tt));
        Some((
            t,
            [sh[kh], sh[(kh + 1) % 3], sh[(kh + 2) % 3], st[(kt + 2) % 3]],
        ))
    }

    /// Flips interior half-edge `h` (a→b) to the other diagonal (c→d) without checking
    /// convexity (see [`can_flip`](Self::can_flip)). O(1).
    ///
    /// ```text
    ///        c                      c
    ///      / ^ \                  / | \
    ///   h2/  |h0\h1    flip     h1/  |  \t2
    ///    v   |   \    ----->    v  h0|t0 \
    ///   a    |    b            a     |    b
    ///    \ t0|   ^              \    |   ^
    ///   t1\  v  /t2           h2 \   v  / t1
    ///      v   /                  v  /
    ///        d                      d
    /// ```
    /// Before: triangle h = (a, b, c) in slots h0 = a→b, h1 = b→c, h2 = c→a and twin
    /// triangle (b, a, d) in t0 = b→a, t1 = a→d, t2 = d→b. After: (d, c, a) in h0 = d→c,
    /// h1 = c→a, h2 = a→d and (c, d, b) in t0 = c→d, t1 = d→b, t2 = b→c. Returns the new
    /// diagonal's half-edge (still `h`). Flipping it again restores the connectivity up to
    /// slot rotation; the caller's caches indexed by slot must follow the same rewrite.
    pub fn flip(&mut self, h: u32) -> u32 {
        for (v, old0, old1, new) in self.rewrite_flip(h) {
            let e = &mut self.vertex_edge[v as usize];
            if *e == old0 || *e == old1 {
                *e = new;
            }
        }
        h
    }

    /// [`flip`](Self::flip) without keeping `vertex_edge`: for loops that walk no fan while
    /// they flip (the annealer's exact ties, a third of its proposals on scans of machined
    /// parts). Why: those four scattered read-modify-writes cost about a tenth of the
    /// annealing loop on the rod. Fan walks ([`fan`](Self::fan)) need
    /// [`reanchor`](Self::reanchor) first; [`validate`](Self::validate) does it on a copy.
    /// O(1).
    #[inline]
    pub fn flip_unanchored(&mut self, h: u32) -> u32 {
        self.rewrite_flip(h);
        self.anchored = false;
        h
    }

    /// Whether every vertex's `vertex_edge` leaves it (false after
    /// [`flip_unanchored`](Self::flip_unanchored) until [`reanchor`](Self::reanchor)). O(1).
    pub fn is_anchored(&self) -> bool {
        self.anchored
    }

    /// Recomputes every vertex's `vertex_edge` from the slots, by the rule of
    /// [`from_triangles`](Self::from_triangles) (the highest twin-less half-edge leaving
    /// the vertex, else the lowest), so that anchors, and the order of every fan walk, are
    /// a function of the connectivity alone, not of the flips that led to it. A no-op on
    /// an anchored mesh. O(m), serial.
    pub fn reanchor(&mut self) {
        if self.anchored {
            return;
        }
        self.vertex_edge.fill(NONE);
        for (h, (&v, &t)) in self.start.iter().zip(&self.twin).enumerate() {
            // Out-of-range starts are left for `validate` to report.
            // Ascending slots: a twin-less half-edge overwrites (the highest wins), any
            // other only fills an empty anchor (the lowest wins).
            if let Some(e) = self.vertex_edge.get_mut(v as usize) {
                if t == NONE || *e == NONE {
                    *e = h as u32;
                }
            }
        }
        self.anchored = true;
    }

    /// The slot rewrite of [`flip`](Self::flip); returns, per corner, the vertex, the two
    /// slots that may hold its anchor before the flip and its slot after. O(1).
    #[inline(always)]
    fn rewrite_flip(&mut self, h: u32) -> [(u32, u32, u32, u32); 4] {
        let t = self.twin[h as usize];
        debug_assert!(t != NONE, "flip of boundary half-edge {h}");
        // Each triangle's slots are taken as a block of three (one bounds check per block);
        // positions k and step(k) are below 3, so indexing a block needs no other check.
        // Written out slot by slot: the loop's flips are its largest instruction cost.
        let (kh, kt) = ((h % 3) as usize, (t % 3) as usize);
        let (th, tt) = (h as usize - kh, t as usize - kt);
        let step = |k: usize| if k == 2 { 0 } else { k + 1 };
        let (kh1, kh2, kt1, kt2) = (step(kh), step(step(kh)), step(kt), step(step(kt)));
        let (h0, h1, h2) = (h, (th + kh1) as u32, (th + kh2) as u32);
        let (t0, t1, t2) = (t, (tt + kt1) as u32, (tt + kt2) as u32);
        let sh: &mut [u32; 3] = (&mut self.start[th..th + 3]).try_into().unwrap();
        let [a, b, c] = [sh[kh], sh[kh1], sh[kh2]];
        // New triangles: h0 = d→c, h1 = c→a, h2 = a→d and t0 = c→d, t1 = d→b, t2 = b→c.
        let st: &mut [u32; 3] = (&mut self.start[tt..tt + 3]).try_into().unwrap();
        let d = st[kt2];
        st[kt] = c;
        st[kt1] = d;
        st[kt2] = b;
        let sh: &mut [u32; 3] = (&mut self.start[th..th + 3]).try_into().unwrap();
        sh[kh] = d;
        sh[kh1] = c;
        sh[kh2] = a;
        let wh: &mut [u32; 3] = (&mut self.twin[th..th + 3]).try_into().unwrap();
        let (tw_bc, tw_ca) = (wh[kh1], wh[kh2]);
        let wt: &mut [u32; 3] = (&mut self.twin[tt..tt + 3]).try_into().unwrap();
        let (tw_ad, tw_db) = (wt[kt1], wt[kt2]);
        wt[kt1] = tw_db;
        wt[kt2] = tw_bc;
        let wh: &mut [u32; 3] = (&mut self.twin[th..th + 3]).try_into().unwrap();
        wh[kh1] = tw_ca;
        wh[kh2] = tw_ad;
        for (outer, inner) in [(tw_ca, h1), (tw_ad, h2), (tw_db, t1), (tw_bc, t2)] {
            if outer != NONE {
                self.twin[outer as usize] = inner;
            }
        }
        // Boundary vertices must keep their twin-less outgoing half-edge, which may have
        // moved slot; an interior vertex may point anywhere it still leaves from. A corner
        // pointing into the two triangles gets its one new slot there: a's a→b (h0, gone)
        // and a→d (t1) become h2 = a→d; b's b→a (t0, gone) and b→c (h1) become t2 = b→c;
        // c's c→a (h2) becomes h1; d's d→b (t2) becomes t1. Two compares per corner.
        [
            (a, h0, t1, h2),
            (b, t0, h1, t2),
            (c, h2, h2, h1),
            (d, t2, t2, t1),
        ]
    }
}

/// The half-edges of a triangle list grouped by start vertex (a counting sort): the
/// half-edges leaving v are `half_edge[first[v]..first[v + 1]]`, in increasing order,
/// and `end[k]` is where `half_edge[k]` arrives. Used by
/// [`HalfEdgeMesh::from_triangles`] to pair twins without sorting edge keys.
struct Outgoing {
    first: Vec<u32>,
    half_edge: Vec<u32>,
    end: Vec<u32>,
}

impl Outgoing {
    /// Groups half-edges `start` (three per triangle, vertices below `n`). Each of c
    /// chunks of the half-edges counts its own starts, so the chunks scatter without
    /// atomic counters and every list comes out in increasing order whatever c is.
    /// O(m + c n) work for m half-edges, c = the rayon pool's thread count (at most one
    /// chunk per 2^16 half-edges); c arrays of n counts, allocations that may fail (an
    /// [`Error::OutOfMemory`]).
    fn new(n: usize, start: &[u32]) -> Result<Self> {
        let m = start.len();
        let chunks = rayon::current_num_threads().min(m >> 16).max(1);
        let len = m.div_ceil(chunks).max(1);
        let mut cursor: Vec<Vec<u32>> = start
            .par_chunks(len)
            .map(|s| {
                let mut count = try_filled("vertex counts", 0u32, n)?;
                for &v in s {
                    count[v as usize] += 1;
                }
                Ok(count)
            })
            .collect::<Result<_>>()?;
        // Exclusive prefix sums in (vertex, chunk) order: chunk c's first slot for v.
        let mut first = try_vec("vertex offsets", n.saturating_add(1))?;
        let mut total = 0u32;
        for v in 0..n {
            first.push(total);
            for count in cursor.iter_mut() {
                let k = count[v];
                count[v] = total;
                total += k;
            }
        }
        first.push(total);
        // The slots are disjoint across chunks but interleaved, so the scatter writes
        // through relaxed atomics (plain stores on x86): (end << 32) | half-edge.
        let slots = try_collect("half-edge slots", (0..m).map(|_| AtomicU64::new(0)))?;
        start
            .par_chunks(len)
            .zip(cursor.par_iter_mut())
            .enumerate()
            .for_each(|(c, (s, cursor))| {
                for (k, &v) in s.iter().enumerate() {
                    let h = (c * len + k) as u32;
                    let slot = &mut cursor[v as usize];
                    let packed = (u64::from(start[next(h) as usize]) << 32) | u64::from(h);
                    slots[*slot as usize].store(packed, Ordering::Relaxed);
                    *slot += 1;
                }
            });
        let (end, half_edge) = slots
            .into_par_iter()
            .map(|s| {
                let p = s.into_inner();
                ((p >> 32) as u32, p as u32)
            })
            .unzip();
        Ok(Outgoing {
            first,
            half_edge,
            end,
        })
    }

    /// The slots of vertex `v`'s half-edges. O(1).
    #[inline]
    fn range(&self, v: usize) -> std::ops::Range<usize> {
        self.first[v] as usize..self.first[v + 1] as usize
    }

    /// The half-edges leaving `v`, in increasing order. O(1).
    #[inline]
    fn half_edges(&self, v: usize) -> &[u32] {
        &self.half_edge[self.range(v)]
    }

    /// The first half-edge a→b, if any. O(degree of a).
    #[inline]
    fn find(&self, a: u32, b: u32) -> Option<u32> {
        let r = self.range(a as usize);
        let k = self.end[r.clone()].iter().position(|&w| w == b)?;
        Some(self.half_edge[r.start + k])
    }

    /// True when some vertex has two half-edges to the same vertex. O(Σ d²) over vertex
    /// degrees d up to 32 (about 15 compares at the usual 6), O(d log d) above; parallel.
    fn repeats_a_directed_edge(&self) -> bool {
        (0..self.first.len() - 1)
            .into_par_iter()
            .with_min_len(BLOCK)
            .any(|v| {
                let ends = &self.end[self.range(v)];
                if ends.len() <= 32 {
                    (1..ends.len()).any(|k| ends[..k].contains(&ends[k]))
                } else {
                    let mut sorted = ends.to_vec();
                    sorted.sort_unstable();
                    sorted.windows(2).any(|w| w[0] == w[1])
                }
            })
    }
}

/// Iterator over the half-edges leaving one vertex, counter-clockwise. See [`HalfEdgeMesh::fan`].
pub struct Fan<'a> {
    mesh: &'a HalfEdgeMesh,
    first: u32,
    current: u32,
}

impl Iterator for Fan<'_> {
    type Item = u32;
    fn next(&mut self) -> Option<u32> {
        let h = self.current;
        if h == NONE {
            return None;
        }
        let following = self.mesh.twin(prev(h));
        self.current = if following == self.first {
            NONE
        } else {
            following
        };
        Some(h)
    }
}

#[cfg(test)]
mod tests;
