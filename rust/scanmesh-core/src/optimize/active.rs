//! Live edges: the interior edges whose flip could lower the energy by more than a tie,
//! kept as a list the annealer draws its proposals from.
//!
//! An edge is live when its quadrilateral is strictly convex in the plane (it can flip)
//! and at least one of its four corners is an interior vertex whose tac exceeds the
//! defect floor `f = (tie_tolerance / 4)^(1/p)`. A flip changes the energy of its four
//! corners only, so a flip none of whose corners is above the floor lowers the energy by
//! at most `4 f^p = tie_tolerance`: a tie or an uphill move. Those are left out: on scans
//! of machined parts they are the flat regions (most edges), where every flip is an exact
//! tie that the final polish settles once. Where every vertex is curved (or noisy above
//! the floor), live edges are the flippable ones: the same chain as drawing among all
//! edges and rejecting the unflippable, with no draw wasted.
//!
//! Why a list with stale entries: a flip moves the five edges of its quadrilateral to
//! other slots, and a vertex's tac crossing the floor makes the edges around it live.
//! Every edge that may have become live is (re)listed under its canonical slot (the lower
//! of its two half-edges) right after the flip; an entry no longer canonical or with no
//! corner above the floor is dropped when a draw hits it, one that cannot flip when its
//! proposal finds so. So every live edge is listed exactly once (tested), each step is
//! O(1) amortized, and the draws depend on the seed and the flips alone.

use crate::budget::{try_filled, try_vec};
use crate::mesh::NONE;
use crate::mesh::{next, prev};
use crate::optimize::tac_state::{PrefetchHints, TacState};
use crate::Result;
use rand_core::RngCore;
use rand_pcg::Pcg64Mcg;

/// Proposals between the prefetch stages of a drawn edge (see [`TacState::prefetch`]):
/// stage 0 right after the draw, stage 1 `STAGE_GAP` proposals later, stage 2 after another
/// `STAGE_GAP`, and the proposal itself `STAGE_GAP` after that. On the rod and on 1M
/// points 2 to 6 all help about alike (docs/benchmarks/speed.md, "Annealing throughput").
const STAGE_GAP: usize = 4;

/// From this many half-edges up, the lines a flip writes outside its two triangles are
/// hinted too: about 175,000 points, where the state (some 100 bytes per half-edge)
/// outgrows a last-level cache and those stores go to memory, fill the store buffer and
/// stall the loop. Below, the stores hit the cache and the hints only crowd the useful ones
/// (both measured: docs/benchmarks/speed.md, "Figures behind the core's constants").
const FLIP_HINT_HALF_EDGES: u64 = 1 << 20;

/// Random numbers drawn this many proposals ahead of their use.
const AHEAD: usize = 3 * STAGE_GAP;

/// Ring size: the smallest power of two above `AHEAD`.
const RING: usize = (AHEAD + 1).next_power_of_two();

/// The live edges of a state and the stream that draws among them.
#[derive(Debug, Clone)]
pub(crate) struct LiveEdges {
    // Canonical slots of the listed edges; some may be stale (see the module doc).
    list: Vec<u32>,
    // One bit per half-edge slot: the slot is in `list`.
    listed: Vec<u64>,
    // The defect floor in radians of tac (not tac^p).
    floor: f64,
    rng: Pcg64Mcg,
    // The next AHEAD raw draws, positions `head .. head + AHEAD`, each at its position mod
    // RING. Raw 64-bit values, mapped to a list index when used (the list changes length):
    // drawn early so that the lines of the edges they will probably pick can be hinted.
    ring: [u64; RING],
    head: usize,
    // List index of the entry drawn last.
    drawn: usize,
    /// What to hint besides the triangles and corners' records (see [`TacState::prefetch`]).
    pub(crate) hints: PrefetchHints,
}

impl LiveEdges {
    /// Lists the live edges of `state` for a run with `tie_tolerance`, drawing with `rng`.
    /// The list has room for every slot once (it never holds more), allocated fallibly with
    /// its bits: an [`crate::Error::OutOfMemory`] instead of an abort. O(m).
    pub(crate) fn new(state: &TacState, tie_tolerance: f64, mut rng: Pcg64Mcg) -> Result<Self> {
        let n = state.mesh().n_half_edges();
        let floor = (tie_tolerance / 4.0).powf(1.0 / state.p());
        let mut ring = [0; RING];
        for r in &mut ring[..AHEAD] {
            *r = rng.next_u64();
        }
        let mut live = LiveEdges {
            list: try_vec("the live edge list", n)?,
            listed: try_filled("the live edge list", 0, n.div_ceil(64))?,
            floor,
            rng,
            ring,
            head: 0,
            drawn: 0,
            hints: PrefetchHints {
                corners: true,
                flip_writes: n as u64 >= FLIP_HINT_HALF_EDGES,
            },
        };
        for h in 0..n as u32 {
            if live.is_current(state, h) {
                live.push(h);
            }
        }
        Ok(live)
    }

    /// The defect floor (radians of tac): corners at or below it cannot make a flip
    /// lower the energy by more than a tie. O(1).
    pub(crate) fn floor(&self) -> f64 {
        self.floor
    }

    /// Entries listed: every live edge once, and entries gone stale since they were
    /// listed and not drawn since. O(1).
    pub(crate) fn len(&self) -> usize {
        self.list.len()
    }

    /// True when slot `h` is its edge's canonical slot and the edge is live. O(1).
    #[inline]
    fn is_current(&self, state: &TacState, h: u32) -> bool {
        let t = state.mesh().twin(h);
        t != NONE && h < t && state.is_live(h, self.floor)
    }

    #[inline]
    fn push(&mut self, h: u32) {
        let (w, bit) = (h as usize / 64, 1u64 << (h % 64));
        if self.listed[w] & bit == 0 {
            self.listed[w] |= bit;
            self.list.push(h);
        }
    }

    /// Lists the edge at slot `h` (under its canonical slot) if it is live. O(1).
    #[inline]
    fn relist(&mut self, state: &TacState, h: u32) {
        let t = state.mesh().twin(h);
        if t == NONE {
            return;
        }
        let c = h.min(t);
        if state.is_live(c, self.floor) {
            self.push(c);
        }
    }

    /// An edge drawn uniformly from the list, or `None` when the list is empty. Entries
    /// that no longer name an edge by its canonical slot, or whose corners all fell to the
    /// floor, are dropped and drawn again; an entry whose edge cannot flip any more is
    /// returned, and the caller drops it with [`drop_drawn`](Self::drop_drawn) when its
    /// proposal finds so (the test it makes anyway). O(1) amortized.
    #[inline]
    pub(crate) fn next(&mut self, state: &TacState) -> Option<u32> {
        loop {
            if self.list.is_empty() {
                return None;
            }
            let raw = self.advance_ring(state);
            let i = self.index(raw);
            let h = self.list[i];
            let t = state.mesh().twin(h);
            self.drawn = i;
            if t != NONE && h < t && state.has_corner_above(h, self.floor) {
                return Some(h);
            }
            self.drop_drawn();
        }
    }

    /// Removes the entry [`next`](Self::next) returned last (the list is unchanged since,
    /// or only appended to). O(1).
    #[inline]
    pub(crate) fn drop_drawn(&mut self) {
        let h = self.list.swap_remove(self.drawn);
        self.listed[h as usize / 64] &= !(1u64 << (h % 64));
    }

    /// Maps a raw draw to a list index by Lemire's multiply-shift (bias below 2^-32 for
    /// lists under 2^32 entries), written out so results never depend on a library's
    /// sampling algorithm. O(1).
    #[inline]
    fn index(&self, raw: u64) -> usize {
        ((raw as u128 * self.list.len() as u128) >> 64) as usize
    }

    /// The next raw draw; draws its replacement and hints the lines of the edges the draws
    /// ahead would pick in today's list. Hints never change results. O(1).
    #[inline]
    fn advance_ring(&mut self, state: &TacState) -> u64 {
        const MASK: usize = RING - 1;
        let raw = self.ring[self.head & MASK];
        let fresh = self.rng.next_u64();
        self.ring[(self.head + AHEAD) & MASK] = fresh;
        self.head = self.head.wrapping_add(1);
        let at = |d: usize| self.list[self.index(self.ring[(self.head + d) & MASK])];
        state.prefetch(at(AHEAD - 1), 0, self.hints);
        state.prefetch(at(AHEAD - 1 - STAGE_GAP), 1, self.hints);
        state.prefetch(at(AHEAD - 1 - 2 * STAGE_GAP), 2, self.hints);
        raw
    }

    /// After flipping `h` (twin `t`): relists the five edges of its quadrilateral (they
    /// moved slots, and their quadrilaterals changed), and every edge around a corner in
    /// `risen` (a corner whose tac rose above the floor with this flip). O(1 + their
    /// degrees).
    pub(crate) fn after_flip(&mut self, state: &TacState, h: u32, t: u32, risen: [bool; 4]) {
        let slots = [h, next(h), prev(h), next(t), prev(t)];
        for s in slots {
            self.relist(state, s);
        }
        if risen.iter().any(|&r| r) {
            // After the flip (see `HalfEdgeMesh::flip`), the corners (a, b, c, d) leave
            // slots prev(h), prev(t), next(h) and h (the order `TacState::apply` uses).
            for (&r, s) in risen.iter().zip([prev(h), prev(t), next(h), h]) {
                if r {
                    self.relist_around(state, s);
                }
            }
        }
    }

    /// Relists every edge of every triangle around the start vertex of `s`: all edges
    /// whose quadrilateral has that vertex as a corner. O(degree).
    fn relist_around(&mut self, state: &TacState, s: u32) {
        let mesh = state.mesh();
        // Counter-clockwise until the boundary or back at `s`, then clockwise from `s`.
        let mut e = s;
        loop {
            let tri = e - e % 3;
            for k in tri..tri + 3 {
                self.relist(state, k);
            }
            e = mesh.twin(prev(e));
            if e == NONE || e == s {
                break;
            }
        }
        if e == NONE {
            let mut e = s;
            loop {
                let t = mesh.twin(e);
                if t == NONE {
                    break;
                }
                e = next(t);
                let tri = e - e % 3;
                for k in tri..tri + 3 {
                    self.relist(state, k);
                }
            }
        }
    }

    /// Bytes per half-edge the list and its bits take at most (for memory estimates): a
    /// u32 per slot (the room reserved: a slot is listed at most once), a bit per slot.
    pub(crate) const BYTES_PER_HALF_EDGE: u64 = 5;
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::optimize::tac_state::tests::{bumpy_state, plateau_state};
    use crate::optimize::tac_state::Detail;
    use rand_core::SeedableRng;

    impl LiveEdges {
        /// Drops every entry that does not name a live edge by its canonical slot.
        fn compact(&mut self, state: &TacState) {
            let mut list = std::mem::take(&mut self.list);
            list.retain(|&h| {
                let keep = self.is_current(state, h);
                if !keep {
                    self.listed[h as usize / 64] &= !(1u64 << (h % 64));
                }
                keep
            });
            self.list = list;
        }
    }

    /// The live edges by definition, each once.
    fn live_by_definition(state: &TacState, floor: f64) -> Vec<u32> {
        state
            .mesh()
            .interior_edges()
            .unwrap()
            .into_iter()
            .filter(|&h| state.is_live(h, floor))
            .collect()
    }

    #[test]
    fn every_live_edge_stays_listed_once_under_random_flips() {
        for (state, tol) in [
            (bumpy_state(300, 5, 1.0), 1e-10),
            (plateau_state(300, 5, 1.0), 1e-10),
            (bumpy_state(300, 6, 1.5), 1e-3),
        ] {
            let mut st = state;
            let mut live = LiveEdges::new(&st, tol, Pcg64Mcg::seed_from_u64(1)).unwrap();
            let mut rng = Pcg64Mcg::seed_from_u64(2);
            let mut flips = 0;
            for step in 0..3000 {
                let Some(h) = live.next(&st) else { break };
                if !st.is_live(h, live.floor()) {
                    live.drop_drawn();
                } else if rng.next_u64() % 2 == 0 {
                    let Some(mv) = st.evaluate(h, Detail::Energy) else {
                        panic!("a live edge can flip")
                    };
                    let (t, quad) = st.mesh().twin_and_quad(h).unwrap();
                    let low = quad.map(|v| !st.is_above_floor(v, live.floor()));
                    st.apply(&mv);
                    let risen =
                        [0, 1, 2, 3].map(|k| low[k] && st.is_above_floor(quad[k], live.floor()));
                    live.after_flip(&st, h, t, risen);
                    flips += 1;
                }
                if step % 500 == 0 {
                    let mut want = live_by_definition(&st, live.floor());
                    live.compact(&st);
                    let mut got = live.list.clone();
                    want.sort_unstable();
                    got.sort_unstable();
                    assert_eq!(got, want);
                }
            }
            assert!(flips > 100, "{flips}");
        }
    }

    /// (live edges listed, flippable edges) of `state` with exact ties.
    fn live_and_flippable(state: &TacState) -> (usize, usize) {
        let live = LiveEdges::new(state, 1e-10, Pcg64Mcg::seed_from_u64(0)).unwrap();
        let uv = state.uv().unwrap();
        let flippable = state
            .mesh()
            .interior_edges()
            .unwrap()
            .into_iter()
            .filter(|&h| state.mesh().can_flip(h, &uv))
            .count();
        (live.len(), flippable)
    }

    #[test]
    fn a_plateau_has_fewer_live_edges_than_flippable_ones() {
        // Flat regions are ties only: their edges are not live, curved ones are.
        let (live, flippable) = live_and_flippable(&plateau_state(400, 3, 1.0));
        assert!(live > 0);
        assert!(live < flippable, "{live} of {flippable}");
        // On a curved state every flippable edge is live.
        let (live, flippable) = live_and_flippable(&bumpy_state(400, 3, 1.0));
        assert_eq!(live, flippable);
    }
}
