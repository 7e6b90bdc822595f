//! A flat half-edge triangulation that supports edge flips; positions are kept apart.
//!
//! Layout (as delaunator): triangle `t` owns half-edges `3t`, `3t + 1`, `3t + 2` in
//! counter-clockwise order, so `next` and `prev` are arithmetic and only two arrays are
//! stored: `start[h]` (the vertex the half-edge leaves) and `twin[h]` (the opposite
//! half-edge, `NONE` on the boundary). A flip rewrites the six slots of its two triangles
//! in place; nothing is allocated.

use crate::geometry::orient2d;
use crate::mesh::locality::prefetch;
use crate::{Error, Result};
use rayon::prelude::*;
use std::sync::atomic::{AtomicU32, AtomicU64, Ordering};

/// Marks "no such index" in index arrays (boundary twins, unique points).
pub const NONE: u32 = u32::MAX;

/// Items per rayon task in the mesh's parallel passes (half-edges, triangles or
/// vertices): large enough that splitting costs nothing next to the work.
const BLOCK: usize = 1 << 14;

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
    start: Vec<u32>,
    twin: Vec<u32>,
    /// For each vertex, one half-edge leaving it: on a boundary vertex, the one without a
    /// twin (the most clockwise), so that a counter-clockwise walk covers the whole fan.
    vertex_edge: Vec<u32>,
    on_boundary: Vec<bool>,
    /// False after [`flip_unanchored`](Self::flip_unanchored): `vertex_edge` may name
    /// half-edges that no longer leave their vertex until [`reanchor`](Self::reanchor).
    anchored: bool,
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
        let start = triangles.as_flattened().to_vec();
        let out = Outgoing::new(n_vertices, &start);
        if out.repeats_a_directed_edge() {
            // Rare (a bad input): the sort names the same edge and faces as always.
            return Err(Self::repeated_edge_by_sort(&start));
        }
        // Twins: the twin of a→b is the one half-edge b→a in b's list, if any.
        let mut twin = vec![NONE; 3 * m];
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
        let mut vertex_edge = vec![NONE; n_vertices];
        let mut on_boundary = vec![false; n_vertices];
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

    /// All triangles, counter-clockwise. O(m).
    pub fn triangles(&self) -> Vec<[u32; 3]> {
        (0..self.n_triangles()).map(|t| self.triangle(t)).collect()
    }

    /// One half-edge per undirected edge (the lower of a twin pair; every boundary half-edge). O(m).
    pub fn edges(&self) -> impl Iterator<Item = u32> + '_ {
        (0..self.start.len() as u32).filter(move |&h| {
            let t = self.twin[h as usize];
            t == NONE || h < t
        })
    }

    /// One half-edge per interior edge (both sides have a triangle). O(m).
    pub fn interior_edges(&self) -> Vec<u32> {
        (0..self.start.len() as u32)
            .filter(|&h| {
                let t = self.twin[h as usize];
                t != NONE && h < t
            })
            .collect()
    }

    /// True when `v` is used and no boundary edge touches it: its triangles form a closed fan. O(1).
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
    /// includes numerically collinear: see [`COLLINEAR_SINE`]. O(1).
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
    /// [`crate::mesh::locality::prefetch`]; no effect on results). O(1).
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

    /// Checks every invariant against the planar positions `uv`; the error says which failed.
    /// A mesh left unanchored by [`flip_unanchored`](Self::flip_unanchored) is checked on a
    /// reanchored copy.
    ///
    /// Twins are mutual and reversed; each triangle is strictly counter-clockwise (exact
    /// predicate); no directed edge repeats; every used vertex has a single fan (at most one
    /// boundary half-edge leaves it, and the walk from `vertex_edge` visits all its
    /// half-edges); the fan of each interior vertex winds once around it (its planar angles
    /// sum to 2π: no fold); and the Euler characteristic V − E + F equals 2C − B for C
    /// components and B boundary loops (each component a disc with holes).
    ///
    /// O(m α(m)) time (the components' union-find), no sort and no floating-point angle:
    /// repeated directed edges and folds are found by the fan walks (see
    /// [`fan_winding`]), exactly. The half-edge, triangle and vertex checks run in
    /// parallel on the rayon pool; the error named is that of the lowest failing
    /// half-edge, else triangle, else vertex (in that order of checks), so it does not
    /// depend on the thread count.
    pub fn validate(&self, uv: &[[f64; 2]]) -> Result<()> {
        if !self.anchored {
            let mut anchored = self.clone();
            anchored.reanchor();
            return anchored.validate(uv);
        }
        let fail = |s: String| Err(Error::Invariant(s));
        if uv.len() != self.n_vertices() {
            return fail(format!(
                "{} positions for {} vertices",
                uv.len(),
                self.n_vertices()
            ));
        }
        if self.start.len() % 3 != 0 || self.twin.len() != self.start.len() {
            return fail("half-edge arrays of inconsistent length".into());
        }
        let n_he = self.start.len() as u32;
        let half_edge_fault = (0..n_he)
            .into_par_iter()
            .with_min_len(BLOCK)
            .find_map_first(|h| {
                if self.start(h) as usize >= self.n_vertices() {
                    return Some(format!(
                        "half-edge {h} starts at vertex {} out of range",
                        self.start(h)
                    ));
                }
                let t = self.twin(h);
                if t != NONE {
                    if t >= n_he || self.twin(t) != h {
                        return Some(format!("twin of half-edge {h} is not mutual"));
                    }
                    if self.start(t) != self.end(h) || self.end(t) != self.start(h) {
                        return Some(format!(
                            "half-edge {h} and its twin {t} do not join the same vertices"
                        ));
                    }
                }
                None
            });
        if let Some(s) = half_edge_fault {
            return fail(s);
        }
        let triangle_fault = (0..self.n_triangles())
            .into_par_iter()
            .with_min_len(BLOCK)
            .find_map_first(|tri| {
                let [a, b, c] = self.triangle(tri);
                (orient2d(uv[a as usize], uv[b as usize], uv[c as usize]) <= 0.0).then(|| {
                    format!(
                        "triangle {tri} ({a}, {b}, {c}) is not strictly counter-clockwise in the plane"
                    )
                })
            });
        if let Some(s) = triangle_fault {
            return fail(s);
        }
        // The vertex checks need each vertex's out-degree and count of boundary half-edges
        // leaving it, a scattered count over all half-edges. A valid mesh does not: the
        // fan walks leave from different vertices, so they reach disjoint sets of
        // half-edges, and when they reach all of them together every walk reached its
        // vertex's degree and at most one boundary half-edge (the first) leaves each
        // vertex (see `vertex_fault`). So the counts are only taken when that pass fails,
        // to name the fault as a full check would.
        let n = self.n_vertices();
        let walks = (0..n as u32)
            .into_par_iter()
            .with_min_len(BLOCK)
            .map_init(Vec::new, |ends, v| {
                self.vertex_fault(v, uv, None, ends).ok().map(u64::from)
            })
            .sum::<Option<u64>>();
        let v_used = if walks == Some(u64::from(n_he)) {
            self.vertex_edge.par_iter().filter(|&&e| e != NONE).count()
        } else {
            let mut degree = vec![0u32; n];
            let mut boundary_out = vec![0u32; n];
            for h in 0..n_he {
                degree[self.start(h) as usize] += 1;
                if self.twin(h) == NONE {
                    boundary_out[self.start(h) as usize] += 1;
                }
            }
            let counts = Some((&degree[..], &boundary_out[..]));
            let vertex_fault = (0..n as u32)
                .into_par_iter()
                .with_min_len(BLOCK)
                .map_init(Vec::new, |ends, v| {
                    self.vertex_fault(v, uv, counts, ends).err()
                })
                .find_map_first(|fault| fault);
            if let Some(s) = vertex_fault {
                return fail(s);
            }
            degree.iter().filter(|&&d| d > 0).count()
        };
        let (components, loops) = self.count_components_and_loops();
        let v_used = v_used as i64;
        let e = (0..n_he)
            .into_par_iter()
            .filter(|&h| {
                let t = self.twin(h);
                t == NONE || h < t
            })
            .count() as i64;
        let f = self.n_triangles() as i64;
        if v_used - e + f != 2 * components - loops {
            return fail(format!(
                "Euler characteristic V - E + F = {} but {components} components with {loops} boundary loops need {}",
                v_used - e + f,
                2 * components - loops
            ));
        }
        Ok(())
    }

    /// The first fault of vertex `v` in the order [`validate`](Self::validate) checks
    /// them, or the number of half-edges its fan walk reached. Assumes twins are mutual
    /// and reversed (checked first), so the walk only meets half-edges leaving `v`, never
    /// one twice (the fan map h → twin(prev(h)) is injective), and ends.
    ///
    /// `counts` = (out-degree, boundary half-edges leaving) per vertex gives the full
    /// check. Without it (the fast pass), a vertex without `vertex_edge` passes and the
    /// boundary flag is compared with the first half-edge of the walk: when the walks of
    /// all vertices together reach every half-edge, that is the same check (a second
    /// boundary half-edge leaving v, or one not first in its fan, would not be reached);
    /// otherwise the caller reruns with counts. `ends` is scratch space (the fan's far
    /// ends, to find a repeated directed edge). O(degree), O(degree log degree) above 32.
    fn vertex_fault(
        &self,
        v: u32,
        uv: &[[f64; 2]],
        counts: Option<(&[u32], &[u32])>,
        ends: &mut Vec<u32>,
    ) -> std::result::Result<u32, String> {
        let vi = v as usize;
        let e = self.vertex_edge[vi];
        match counts {
            Some((degree, boundary_out)) => {
                if degree[vi] == 0 {
                    if e != NONE {
                        return Err(format!("unused vertex {v} has an outgoing half-edge"));
                    }
                    return Ok(0);
                }
                if e == NONE || self.start(e) != v {
                    return Err(format!(
                        "vertex {v} does not point at a half-edge leaving it"
                    ));
                }
                if boundary_out[vi] > 1 {
                    return Err(format!(
                        "vertex {v} joins {} separate fans (a pinch)",
                        boundary_out[vi]
                    ));
                }
                if self.on_boundary[vi] != (boundary_out[vi] == 1) {
                    return Err(format!("boundary flag of vertex {v} is stale"));
                }
                if boundary_out[vi] == 1 && self.twin(e) != NONE {
                    return Err(format!(
                        "boundary vertex {v} does not point at its boundary half-edge"
                    ));
                }
            }
            None => {
                if e == NONE {
                    return Ok(0);
                }
                if self.start(e) != v {
                    return Err(format!(
                        "vertex {v} does not point at a half-edge leaving it"
                    ));
                }
                if self.on_boundary[vi] != (self.twin(e) == NONE) {
                    return Err(format!("boundary flag of vertex {v} is stale"));
                }
            }
        }
        // A repeated directed edge v→w shows as w met twice in the walk: a scan of the
        // ends so far (about 6) beats a shared per-vertex stamp array's scattered writes;
        // a long fan switches to a set, so a star of degree d costs O(d log d), not d².
        ends.clear();
        let mut seen = std::collections::BTreeSet::new();
        let mut reached = 0u32;
        for h in self.fan(v) {
            reached += 1;
            let w = self.end(h);
            let repeat = if ends.len() < 32 {
                let r = ends.contains(&w);
                ends.push(w);
                if ends.len() == 32 {
                    seen.extend(ends.iter().copied());
                }
                r
            } else {
                !seen.insert(w)
            };
            if repeat {
                return Err(format!("directed edge {v}->{w} appears twice"));
            }
        }
        if let Some((degree, _)) = counts {
            if reached != degree[vi] {
                return Err(format!(
                    "the fan of vertex {v} reaches {reached} of its {} half-edges",
                    degree[vi]
                ));
            }
        }
        if self.is_interior(v) {
            let winding = self.fan_winding(v, uv);
            if winding != 1 {
                return Err(format!(
                    "the fan of interior vertex {v} winds {winding} times around it (planar angles sum to {winding} × 2π, not 2π: a fold)"
                ));
            }
        }
        Ok(reached)
    }

    /// How many times the closed fan of `v` winds around it in the plane, when every
    /// triangle is strictly counter-clockwise (checked first by [`validate`](Self::validate)).
    ///
    /// Why this is the angle-sum test without angles: going round the fan, the direction
    /// from v to the far end of each half-edge turns counter-clockwise by the triangle's
    /// corner angle at v, which lies strictly between 0 and π because the triangle is
    /// strictly counter-clockwise. The directions return to the first, so the corner
    /// angles sum to 2πk, k ≥ 1 the winding number, and k = 1 exactly when the sum is 2π
    /// (k ≥ 2 is a fold: the fan covers its neighbourhood k times). Split the directions
    /// into the half-open upper half [0, π) (y > 0, or y = 0 and x > 0) and lower half
    /// [π, 2π). A turn by less than π passes the direction 0 (≡ 2π) exactly when it goes
    /// from the lower half into the upper half, and the lifted direction passes 0 exactly
    /// k times in the whole walk; so k = the number of lower-to-upper steps. Each half is
    /// decided by comparing coordinates with v's (exact, no subtraction), and the
    /// orientation was decided by an exact predicate, so the count is exact: no atan2,
    /// and no tolerance where the sum of corner angles needed 1e-6. O(degree).
    fn fan_winding(&self, v: u32, uv: &[[f64; 2]]) -> u32 {
        let p = uv[v as usize];
        let lower = |q: [f64; 2]| q[1] < p[1] || (q[1] == p[1] && q[0] < p[0]);
        self.fan(v)
            .map(|h| {
                let (from, to) = (uv[self.end(h) as usize], uv[self.start(prev(h)) as usize]);
                u32::from(lower(from) && !lower(to))
            })
            .sum()
    }

    /// Connected components of triangles (through twins) and boundary loops.
    ///
    /// Components: a concurrent union-find over the interior edges on the rayon pool
    /// (compare-and-swap links, the higher root under the lower, path halving); the count
    /// of roots does not depend on the order of the unions. Loops: the cycles of
    /// h → vertex_edge[end(h)] on the boundary half-edges, walked serially over the
    /// (usually few) boundary half-edges. O(m α(m)) work.
    fn count_components_and_loops(&self) -> (i64, i64) {
        let m = self.n_triangles();
        let parent: Vec<AtomicU32> = (0..m as u32).into_par_iter().map(AtomicU32::new).collect();
        fn find(p: &[AtomicU32], mut x: u32) -> u32 {
            loop {
                let up = p[x as usize].load(Ordering::Relaxed);
                if up == x {
                    return x;
                }
                let grand = p[up as usize].load(Ordering::Relaxed);
                if grand != up {
                    // Halving; losing the race only leaves a longer path.
                    let _ = p[x as usize].compare_exchange(
                        up,
                        grand,
                        Ordering::Relaxed,
                        Ordering::Relaxed,
                    );
                }
                x = grand;
            }
        }
        (0..self.start.len() as u32)
            .into_par_iter()
            .with_min_len(BLOCK)
            .for_each(|h| {
                let t = self.twin(h);
                // Each interior edge once (from its lower half-edge).
                if t == NONE || h > t {
                    return;
                }
                let (mut x, mut y) = (h / 3, t / 3);
                loop {
                    x = find(&parent, x);
                    y = find(&parent, y);
                    if x == y {
                        return;
                    }
                    let (lo, hi) = (x.min(y), x.max(y));
                    // Only a root is relinked: if hi stopped being one, retry.
                    if parent[hi as usize]
                        .compare_exchange(hi, lo, Ordering::Relaxed, Ordering::Relaxed)
                        .is_ok()
                    {
                        return;
                    }
                }
            });
        let components = (0..m)
            .into_par_iter()
            .filter(|&x| parent[x].load(Ordering::Relaxed) == x as u32)
            .count() as i64;
        let boundary: Vec<u32> = (0..self.start.len() as u32)
            .into_par_iter()
            .filter(|&h| self.twin(h) == NONE)
            .collect();
        // The boundary half-edge leaving end(h) is that vertex's vertex_edge (one fan each);
        // validate has checked that it is a boundary half-edge, so this is a permutation.
        let loops = count_cycles(boundary.len(), |k| {
            let h = self.vertex_edge[self.end(boundary[k]) as usize];
            boundary.binary_search(&h).ok()
        })
        .expect("boundary vertex_edge checked");
        (components, loops as i64)
    }
}

/// Number of cycles of the map `successor` on `0..n`, or `None` when it is not a
/// permutation (`successor` returns `None`, or a walk joins a cycle part-way). Counts
/// boundary loops, of a mesh (`validate`) and of strips before they are built
/// (`strips::check`). O(n) calls of `successor`.
pub(crate) fn count_cycles(
    n: usize,
    mut successor: impl FnMut(usize) -> Option<usize>,
) -> Option<usize> {
    let mut seen = vec![false; n];
    let mut cycles = 0;
    for k0 in 0..n {
        if seen[k0] {
            continue;
        }
        cycles += 1;
        let mut k = k0;
        while !seen[k] {
            seen[k] = true;
            k = successor(k)?;
        }
        if k != k0 {
            return None;
        }
    }
    Some(cycles)
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
    /// chunk per 2^16 half-edges); c arrays of n counts.
    fn new(n: usize, start: &[u32]) -> Self {
        let m = start.len();
        let chunks = rayon::current_num_threads().min(m >> 16).max(1);
        let len = m.div_ceil(chunks).max(1);
        let mut cursor: Vec<Vec<u32>> = start
            .par_chunks(len)
            .map(|s| {
                let mut count = vec![0u32; n];
                for &v in s {
                    count[v as usize] += 1;
                }
                count
            })
            .collect();
        // Exclusive prefix sums in (vertex, chunk) order: chunk c's first slot for v.
        let mut first = Vec::with_capacity(n + 1);
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
        let slots: Vec<AtomicU64> = (0..m).map(|_| AtomicU64::new(0)).collect();
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
        Outgoing {
            first,
            half_edge,
            end,
        }
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
mod tests {
    use super::*;
    use crate::testing::random_points;
    use crate::triangulate::delaunay::delaunay;

    fn canonical(mut t: Vec<[u32; 3]>) -> Vec<[u32; 3]> {
        for tri in t.iter_mut() {
            let k = (0..3).min_by_key(|&k| tri[k]).unwrap();
            tri.rotate_left(k);
        }
        t.sort();
        t
    }

    fn delaunay_mesh(n: usize, seed: u64) -> (Vec<[f64; 2]>, HalfEdgeMesh) {
        let uv = random_points(n, seed);
        let d = delaunay(&uv).unwrap();
        (
            uv.clone(),
            HalfEdgeMesh::from_triangles(uv.len(), &d.triangles).unwrap(),
        )
    }

    #[test]
    fn delaunay_mesh_is_valid() {
        let (uv, mesh) = delaunay_mesh(300, 1);
        mesh.validate(&uv).unwrap();
        let interior = mesh.interior_edges();
        assert!(interior.iter().all(|&h| mesh.twin(h) != NONE));
        let boundary = mesh.edges().filter(|&h| mesh.twin(h) == NONE).count();
        assert_eq!(interior.len() + boundary, mesh.edges().count());
        let interior = (0..300).filter(|&v| mesh.is_interior(v)).count();
        assert!(interior > 200 && interior < 300);
    }

    #[test]
    fn flipping_twice_restores_the_mesh() {
        let (uv, mut mesh) = delaunay_mesh(100, 2);
        let before = canonical(mesh.triangles());
        for h in mesh.interior_edges() {
            if mesh.can_flip(h, &uv) {
                let copy = mesh.clone();
                mesh.flip(h);
                mesh.validate(&uv).unwrap();
                assert_ne!(canonical(mesh.triangles()), before);
                assert!(mesh.can_flip(h, &uv), "the flipped quad is still convex");
                mesh.flip(h);
                assert_eq!(canonical(mesh.triangles()), before);
                mesh.validate(&uv).unwrap();
                mesh = copy;
            }
        }
    }

    #[test]
    fn ten_thousand_random_flips_keep_every_invariant() {
        let (uv, mut mesh) = delaunay_mesh(400, 3);
        let edges = mesh.interior_edges();
        let mut s = 99u64;
        let mut flips = 0;
        for step in 0..10_000 {
            s = s.wrapping_mul(6364136223846793005).wrapping_add(1);
            let h = edges[((s >> 33) as usize) % edges.len()];
            if mesh.can_flip(h, &uv) {
                mesh.flip(h);
                flips += 1;
            }
            if step % 2_500 == 0 {
                mesh.validate(&uv).unwrap();
            }
        }
        mesh.validate(&uv).unwrap();
        assert!(flips > 3_000, "only {flips} flips were legal");
    }

    #[test]
    fn unanchored_flips_then_reanchor_equal_a_fresh_build() {
        // Mixed full and unanchored flips: reanchoring gives exactly the anchors that
        // `from_triangles` gives the same slots (so fan sums cannot depend on history),
        // and `validate` accepts the mesh before and after.
        let (uv, mut mesh) = delaunay_mesh(400, 4);
        let edges = mesh.interior_edges();
        let mut s = 7u64;
        let mut unanchored = 0;
        for step in 0..6_000 {
            s = s.wrapping_mul(6364136223846793005).wrapping_add(1);
            let h = edges[((s >> 33) as usize) % edges.len()];
            if !mesh.can_flip(h, &uv) {
                continue;
            }
            if step % 3 == 0 {
                mesh.flip(h);
            } else {
                mesh.flip_unanchored(h);
                unanchored += 1;
            }
            if step % 1_500 == 0 {
                mesh.validate(&uv).unwrap();
            }
        }
        assert!(unanchored > 1_000, "only {unanchored} unanchored flips");
        assert!(!mesh.is_anchored());
        mesh.validate(&uv).unwrap();
        let fresh = HalfEdgeMesh::from_triangles(uv.len(), &mesh.triangles()).unwrap();
        assert_ne!(
            mesh.vertex_edge, fresh.vertex_edge,
            "the flips left anchors stale"
        );
        mesh.reanchor();
        assert_eq!(mesh, fresh);
        mesh.validate(&uv).unwrap();
        // A fresh build is already anchored by the same rule.
        let mut rebuilt = fresh.clone();
        rebuilt.anchored = false;
        rebuilt.reanchor();
        assert_eq!(rebuilt, fresh);
    }

    #[test]
    fn nonconvex_quads_are_refused() {
        // A convex kite (a, d, b, c) = (0, 3, 1, 2): flippable.
        let uv = vec![[0.0, 0.0], [2.0, 0.0], [1.0, 3.0], [1.0, -0.2]];
        let mesh = HalfEdgeMesh::from_triangles(4, &[[0, 1, 2], [1, 0, 3]]).unwrap();
        assert!(mesh.can_flip(0, &uv));
        // Move c so that the turn d -> b -> c is clockwise: a reflex corner at b.
        let uv2 = vec![[0.0, 0.0], [2.0, 0.0], [3.0, 0.5], [1.0, -1.0]];
        assert!(!mesh.can_flip(0, &uv2));
        // Collinear: c, b, d in a line makes the quad degenerate at b.
        let uv3 = vec![[0.0, 0.0], [2.0, 0.0], [3.0, 1.0], [1.0, -1.0]];
        let mesh3 = HalfEdgeMesh::from_triangles(4, &[[0, 1, 2], [1, 0, 3]]).unwrap();
        assert!(!mesh3.can_flip(0, &uv3));
        // Numerically collinear: d, b, c lie on x + y = 0.4 in the reals, but the rounded
        // coordinates make (c, d, b) counter-clockwise by 5.6e-18: still not a legal flip.
        let uv4 = vec![[0.0, 0.0], [0.2, 0.2], [0.1, 0.3], [0.3, 0.1]];
        assert!(orient2d(uv4[2], uv4[3], uv4[1]) > 0.0);
        assert!(!mesh3.can_flip(0, &uv4));
        assert!(!mesh3.can_flip(1, &uv3), "boundary edge");
    }

    #[test]
    fn bad_triangles_are_rejected() {
        assert!(HalfEdgeMesh::from_triangles(3, &[[0, 1, 3]]).is_err());
        assert!(HalfEdgeMesh::from_triangles(3, &[[0, 1, 1]]).is_err());
        // Same orientation of a shared edge: inconsistent.
        assert!(HalfEdgeMesh::from_triangles(4, &[[0, 1, 2], [0, 1, 3]]).is_err());
    }

    #[test]
    fn validate_catches_clockwise_and_pinches() {
        let uv = vec![[0.0, 0.0], [1.0, 0.0], [0.0, 1.0]];
        let cw = HalfEdgeMesh::from_triangles(3, &[[0, 2, 1]]).unwrap();
        assert!(cw.validate(&uv).is_err());
        // Two triangles sharing only vertex 0: a pinch.
        let uv = vec![
            [0.0, 0.0],
            [1.0, 0.0],
            [1.0, 1.0],
            [-1.0, 0.0],
            [-1.0, -1.0],
        ];
        let bow = HalfEdgeMesh::from_triangles(5, &[[0, 1, 2], [0, 3, 4]]).unwrap();
        let err = bow.validate(&uv).unwrap_err();
        assert!(format!("{err}").contains("pinch"), "{err}");
    }

    #[test]
    fn validate_catches_a_fan_that_winds_twice() {
        // Centre 0 and five points at 0°, 144°, 288°, 72°, 216°: every triangle
        // (0, k, k + 1) is counter-clockwise and the fan closes, but it covers the plane
        // around 0 twice (corner angles 5 × 144° = 720°); V − E + F = 6 − 10 + 5 = 1 with
        // one boundary loop, so only the fold check can see it.
        let mut uv = vec![[0.0, 0.0]];
        for k in 0..5 {
            let a = (144.0 * k as f64).to_radians();
            uv.push([a.cos(), a.sin()]);
        }
        let tris: Vec<[u32; 3]> = (0..5).map(|k| [0, k + 1, (k + 1) % 5 + 1]).collect();
        let mesh = HalfEdgeMesh::from_triangles(6, &tris).unwrap();
        assert!(mesh.is_interior(0));
        assert_eq!(mesh.fan_winding(0, &uv), 2);
        let err = mesh.validate(&uv).unwrap_err();
        assert!(format!("{err}").contains("fold"), "{err}");
        // The same fan with the points in angular order winds once and is valid.
        let mut once = vec![[0.0, 0.0]];
        for k in 0..5 {
            let a = (72.0 * k as f64).to_radians();
            once.push([a.cos(), a.sin()]);
        }
        assert_eq!(mesh.fan_winding(0, &once), 1);
        mesh.validate(&once).unwrap();
    }

    #[test]
    fn winding_counts_agree_with_angle_sums_on_random_meshes() {
        // Every interior fan whose triangles are counter-clockwise, on Delaunay meshes with
        // one vertex moved: the exact count against the corner angles summed with atan2
        // (mostly k = 1; the test above builds k = 2).
        for seed in 0..20 {
            let (mut uv, mesh) = delaunay_mesh(60, 100 + seed);
            // Fans with a clockwise triangle are skipped: validate rejects those first.
            uv[(seed % 60) as usize] = [0.5, 0.5];
            for v in 0..60u32 {
                if !mesh.is_interior(v) {
                    continue;
                }
                let ccw = mesh.fan(v).all(|h| {
                    let t = (h / 3) as usize;
                    let [a, b, c] = mesh.triangle(t).map(|k| uv[k as usize]);
                    orient2d(a, b, c) > 0.0
                });
                if !ccw {
                    continue;
                }
                let sum: f64 = mesh
                    .fan(v)
                    .map(|h| {
                        crate::geometry::planar_corner_angle(
                            uv[v as usize],
                            uv[mesh.end(h) as usize],
                            uv[mesh.start(prev(h)) as usize],
                        )
                    })
                    .sum();
                let k = (sum / std::f64::consts::TAU).round() as u32;
                assert!((sum - k as f64 * std::f64::consts::TAU).abs() < 1e-9);
                assert_eq!(mesh.fan_winding(v, &uv), k, "seed {seed} vertex {v}");
            }
        }
    }

    #[test]
    fn count_cycles_counts_permutation_cycles_and_refuses_other_maps() {
        let perm = [1, 2, 0, 4, 3, 5];
        assert_eq!(count_cycles(6, |k| Some(perm[k])), Some(3));
        assert_eq!(count_cycles(0, |_| None), Some(0));
        // 0 -> 1 -> 2 -> 1: the walk from 0 joins a cycle part-way.
        let tail = [1, 2, 1];
        assert_eq!(count_cycles(3, |k| Some(tail[k])), None);
        assert_eq!(count_cycles(2, |k| (k == 0).then_some(1)), None);
    }

    #[test]
    fn validate_catches_a_repeated_directed_edge() {
        // Built by hand (from_triangles refuses it): triangles (0, 1, 2) and (0, 1, 3) both
        // use 0→1, both counter-clockwise.
        let uv = vec![[0.0, 0.0], [1.0, 0.0], [0.0, 1.0], [1.0, 1.0]];
        let mesh = HalfEdgeMesh {
            start: vec![0, 1, 2, 0, 1, 3],
            twin: vec![NONE; 6],
            vertex_edge: vec![0, 1, 2, 5],
            on_boundary: vec![true; 4],
            anchored: true,
        };
        assert!(mesh.validate(&uv).is_err());
    }

    /// `f` on a rayon pool of `threads` threads.
    fn on_pool<T: Send>(threads: usize, f: impl FnOnce() -> T + Send) -> T {
        rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .unwrap()
            .install(f)
    }

    #[test]
    fn errors_name_the_lowest_fault_on_any_thread_count() {
        // 60,000 points: every parallel pass splits into several blocks of BLOCK items.
        let (uv, mesh) = delaunay_mesh(60_000, 7);
        let tris = mesh.triangles();
        let both = |f: &(dyn Fn() -> String + Sync)| {
            let (one, two) = (on_pool(1, f), on_pool(2, f));
            assert_eq!(one, two);
            one
        };
        // from_triangles: the same mesh, and the lowest bad face, on 1 and 2 threads.
        let build = |t: &[[u32; 3]]| match HalfEdgeMesh::from_triangles(uv.len(), t) {
            Ok(m) => format!("{m:?}"),
            Err(e) => format!("{e}"),
        };
        assert_eq!(both(&|| build(&tris)), format!("{mesh:?}"));
        let mut bad = tris.clone();
        bad[100_000][1] = 70_000; // out of range
        bad[90_000][2] = bad[90_000][0]; // repeated vertex: the lowest fault
        let err = both(&|| build(&bad));
        assert!(
            err.contains("face 90000") && err.contains("repeats"),
            "{err}"
        );
        // Repeated directed edges (a face copied over another twice): the lowest edge key.
        let mut bad = tris.clone();
        bad[110_000] = bad[3];
        bad[5] = bad[100_000];
        let sorted_error = format!(
            "{}",
            HalfEdgeMesh::repeated_edge_by_sort(bad.as_flattened())
        );
        assert_eq!(both(&|| build(&bad)), sorted_error);
        // validate: several stale flags, a vertex pointing elsewhere and a fold; the
        // lowest faulty vertex is named whatever the split.
        let mut broken = mesh.clone();
        let interior: Vec<u32> = (0..60_000).filter(|&v| mesh.is_interior(v)).collect();
        let [v1, v2, v3] = [interior[20_000], interior[35_000], interior[50_000]];
        broken.on_boundary[v3 as usize] = true;
        broken.on_boundary[v2 as usize] = true;
        broken.vertex_edge[v1 as usize] = broken.vertex_edge[v3 as usize];
        let err = both(&|| format!("{}", broken.validate(&uv).unwrap_err()));
        assert_eq!(
            err,
            format!(
                "mesh invariant violated: vertex {v1} does not point at a half-edge leaving it"
            )
        );
        // Clockwise triangles at both ends: the lowest triangle is named.
        let mut flipped = uv.clone();
        let [a, b, _] = mesh.triangle(110_000);
        flipped.swap(a as usize, b as usize);
        let [a, b, _] = mesh.triangle(40_000);
        flipped.swap(a as usize, b as usize);
        let one = on_pool(1, || broken.validate(&flipped).unwrap_err());
        assert_eq!(
            format!("{one}"),
            format!("{}", on_pool(2, || broken.validate(&flipped).unwrap_err()))
        );
        assert!(format!("{one}").contains("triangle"), "{one}");
    }

    #[test]
    fn fans_go_counter_clockwise() {
        let (uv, mesh) = delaunay_mesh(200, 5);
        for v in 0..200u32 {
            if !mesh.is_interior(v) {
                continue;
            }
            let ends: Vec<[f64; 2]> = mesh.fan(v).map(|h| uv[mesh.end(h) as usize]).collect();
            let p = uv[v as usize];
            for k in 0..ends.len() {
                let (a, b) = (ends[k], ends[(k + 1) % ends.len()]);
                assert!(orient2d(p, a, b) > 0.0);
            }
        }
    }
}
