//! Lawson's local optimization procedure (LOP): flip while a flip improves the criterion.
//!
//! The deterministic baseline of the paper's annealing (annealing at T = 0). One queue
//! loop serves every criterion; a criterion only says whether flipping an edge improves.

use crate::budget::{try_filled, try_grow, try_vec};
use crate::geometry::planar_smallest_angle;
use crate::mesh::NONE;
use crate::mesh::{next, prev, HalfEdgeMesh};
use crate::optimize::tac_state::{Detail, FlipMove, TacState};
use crate::progress::{Progress, Share};
use crate::{Error, Result};

/// Smallest improvement in a smallest angle (radians) that counts: below it, rounding could
/// make both diagonals of a cocircular quadrilateral look better than the other, and loop.
pub const ANGLE_EPSILON: f64 = 1e-12;

/// How a tac move is judged: a lower energy wins; within `tie_tolerance` of no change,
/// the larger smallest 3-D angle wins when `sliver_guard` is on (the lexicographic order
/// "tac energy first, then smallest angle"). With `planar_ties`, a move whose four
/// corners are all flat up to the noise (tac at most
/// `NOISE_TAC` tie tolerances, see
/// [`TacState::flat_quad_uv`]) is judged by the smallest planar angle alone, Delaunay's
/// criterion.
///
/// Why: on a noisy scan the tac of such corners and the 3-D angles of their triangles are
/// the noise's, so judging their flips by either picks triangles by the noise, which on
/// a flat noisy part can only raise the height error above Delaunay's (the noisy rod:
/// docs/benchmarks/noise.md). The planar angle is blind to the heights:
/// such parts keep (or return to) the Delaunay triangulation. Corners curved beyond the
/// noise (creases, real relief) keep the tac order.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TacOrder {
    /// Energy changes of at most this size count as ties.
    pub tie_tolerance: f64,
    /// Break ties toward the larger smallest angle (else ties are not improvements).
    pub sliver_guard: bool,
    /// Measure the smallest angle of ties in the plane instead of in 3-D.
    pub planar_ties: bool,
    /// A move that makes the smallest 3-D angle of its two triangles fall below this
    /// (radians) and below what it was never improves (0: no such rule).
    pub sliver_angle: f64,
    /// A move that makes one of its two triangles face the line of sight less squarely
    /// than this ([`FlipMove::new_facing`]: the sine of the angle between the plane and
    /// the sight) and less squarely than before never improves: no new curtain (0: no
    /// such rule; measured only on a state with a sight, [`TacState::with_sight`]). Set it
    /// from an angle with [`curtain_facing`].
    pub min_facing: f64,
}

/// The [`TacOrder::min_facing`] that refuses moves bringing a triangle's plane within
/// `degrees` of the line of sight (0: off); an error naming `curtain_angle` unless
/// 0 ≤ degrees < 90. O(1).
pub fn curtain_facing(degrees: f64) -> Result<f64> {
    if !(0.0..90.0).contains(&degrees) {
        return Err(Error::InvalidParameter {
            name: "curtain_angle",
            value: degrees.to_string(),
            expected: "an angle in degrees from 0 (off) up to, not including, 90",
        });
    }
    Ok(degrees.to_radians().sin())
}

/// The one rule behind both of [`TacOrder::refuses`]'s guards: a shape measure where
/// larger is better (a smallest angle, a facing) falls below its `floor` with a move and
/// below what it `was`. NaN (not measured) never falls. O(1).
#[inline(always)]
fn falls_below(now: f64, was: f64, floor: f64) -> bool {
    now < floor && now < was
}

impl TacOrder {
    /// The order with `tie_tolerance` (radians^p, finite and ≥ 0, else an error naming it)
    /// and `sliver_guard`, ties measured in 3-D. O(1).
    pub fn new(tie_tolerance: f64, sliver_guard: bool) -> Result<Self> {
        if !(tie_tolerance >= 0.0 && tie_tolerance.is_finite()) {
            return Err(Error::InvalidParameter {
                name: "tie_tolerance",
                value: tie_tolerance.to_string(),
                expected: "a finite value >= 0",
            });
        }
        Ok(TacOrder {
            tie_tolerance,
            sliver_guard,
            planar_ties: false,
            sliver_angle: 0.0,
            min_facing: 0.0,
        })
    }

    /// True when `mv` is refused whatever its energy: it would make a sliver (its new
    /// smallest 3-D angle below `sliver_angle` and below the old one) or a curtain (a new
    /// triangle facing the sight less than `min_facing` and less than the old ones did).
    /// Moves whose shapes were not measured (NaN: coplanar ties evaluated for their energy
    /// only, which change neither a plane nor, by the polish's order, an angle for the
    /// worse; no sight) are not judged. O(1).
    #[inline]
    pub fn refuses(&self, mv: &FlipMove) -> bool {
        falls_below(mv.new_min_angle, mv.old_min_angle, self.sliver_angle)
            || falls_below(mv.new_facing, mv.old_facing, self.min_facing)
    }

    /// True when `mv` is a tie under this order. O(1).
    #[inline]
    pub fn is_tie(&self, mv: &FlipMove) -> bool {
        mv.delta_energy.abs() <= self.tie_tolerance
    }

    /// True when applying `mv` strictly improves the order. `flat(tie_tolerance)` gives
    /// the planar positions of its quadrilateral (a, b, c, d) of [`HalfEdgeMesh::quad`]
    /// when every corner's tac is within the noise ([`TacState::flat_quad_uv`]), else
    /// `None`; asked for only with `planar_ties`. O(1).
    #[inline]
    pub fn improves(&self, mv: &FlipMove, flat: impl FnOnce(f64) -> Option<[[f64; 2]; 4]>) -> bool {
        if self.refuses(mv) {
            return false;
        }
        if let Some(quad) = self.planar_ties.then(|| flat(self.tie_tolerance)).flatten() {
            return planar_flip_improves(quad);
        }
        if self.is_tie(mv) {
            self.sliver_guard && mv.new_min_angle > mv.old_min_angle + ANGLE_EPSILON
        } else {
            mv.delta_energy < 0.0
        }
    }
}

/// Whether flipping the diagonal ab of the convex quadrilateral (a, b, c, d) of
/// [`HalfEdgeMesh::quad`] to cd raises the smallest planar angle of its two triangles by
/// more than [`ANGLE_EPSILON`]: Delaunay's criterion (Lawson's max-min flip). O(1).
pub fn planar_flip_improves([a, b, c, d]: [[f64; 2]; 4]) -> bool {
    let old = planar_smallest_angle(a, b, c).min(planar_smallest_angle(b, a, d));
    let new = planar_smallest_angle(d, c, a).min(planar_smallest_angle(c, d, b));
    new > old + ANGLE_EPSILON
}

/// Something LOP can drive: a triangulation and a rule that flips an edge when that improves.
pub trait FlipSearch {
    /// The current triangulation.
    fn mesh(&self) -> &HalfEdgeMesh;
    /// Flips `h` if that strictly improves the criterion; returns whether it flipped.
    fn flip_if_better(&mut self, h: u32) -> bool;
    /// After `h` was flipped (its twin is `t`), pushes every edge whose verdict may have
    /// changed. Default: the four outer edges of the quadrilateral, right for criteria
    /// that look only at an edge's two triangles.
    fn push_affected(&self, h: u32, t: u32, stack: &mut Vec<u32>) {
        stack.extend([next(h), prev(h), next(t), prev(t)]);
    }
    /// For orders with a tolerance: the primary value (lower is better) and the least
    /// decrease that counts, so that [`lop`] can stop a cycle (see [`max_flips`]).
    /// Default `None`: a strict order, which cannot cycle.
    fn progress(&self) -> Option<(f64, f64)> {
        None
    }
}

/// Flips LOP may make per half-edge before it gives up (see [`max_flips`]): polishing an
/// annealed rod makes about 0.25, LOP from Delaunay well under 1.
pub const MAX_FLIPS_PER_HALF_EDGE: usize = 50;

/// The flip budget for a mesh of `n_half_edges` half-edges: finite, because an order with
/// a tie tolerance (tac within `tie_tolerance`, then angle) is not strict, and flips that
/// each raise tac by less than the tolerance can close a cycle with one that lowers it by
/// more. O(1).
pub fn max_flips(n_half_edges: usize) -> usize {
    MAX_FLIPS_PER_HALF_EDGE * n_half_edges.max(1)
}

/// What [`run_lop`] improves.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum LopCriterion {
    /// The tac energy of the state (Σ tac^p) under this order.
    Tac(TacOrder),
    /// The smallest angle in the plane; converges to a Delaunay triangulation.
    PlanarMaxMin,
}

/// LOP from `state`'s triangulation under `criterion`, within the flip budget
/// `max_flips`: the final triangulation and the flips made. Errors: an
/// [`Error::OutOfMemory`] when the edge stack cannot be allocated (see `lop`).
/// O(flips + m).
pub fn run_lop(mut state: TacState, criterion: LopCriterion) -> Result<(HalfEdgeMesh, usize)> {
    match criterion {
        LopCriterion::Tac(order) => {
            let flips = tac_lop(&mut state, order)?;
            Ok((state.into_mesh(), flips))
        }
        LopCriterion::PlanarMaxMin => {
            let uv = state.uv()?;
            let mut mesh = state.into_mesh();
            let budget = max_flips(mesh.n_half_edges());
            let flips = lop(
                &mut PlanarMaxMinLop {
                    mesh: &mut mesh,
                    uv: &uv,
                },
                budget,
            )?;
            Ok((mesh, flips))
        }
    }
}

/// LOP of `state`'s tac energy under `order` within the flip budget `max_flips`;
/// returns the flips made, or an [`Error::OutOfMemory`] (see `lop`). O(flips + m).
pub fn tac_lop(state: &mut TacState, order: TacOrder) -> Result<usize> {
    tac_lop_counted(state, order, None)
}

/// [`tac_lop`], counted as `weight` items of `progress` (see [`lop_counted`]).
/// O(flips + m).
pub fn tac_lop_counted(
    state: &mut TacState,
    order: TacOrder,
    counted: Option<(&Progress, u64)>,
) -> Result<usize> {
    let budget = max_flips(state.mesh().n_half_edges());
    lop_counted(&mut TacLop { state, order }, budget, counted)
}

/// Runs LOP to a local optimum: every interior edge is examined; after a flip the edges
/// the criterion names as affected are examined again. Returns the number of flips.
///
/// Terminates for criteria that strictly improve a bounded potential (Delaunay's max-min
/// angle vector, tac energy); `max_flips` guards against cycles (see [`max_flips`]), and
/// for a search that reports [`FlipSearch::progress`], so does this: every m flips the
/// primary value must have dropped by more than its tolerance since the last check, or the
/// search stops (flips that only trade ties then are a cycle or a creep within the
/// tolerance; polishing an annealed rod makes a quarter of m flips in all).
/// The stack holds at most about 4m entries: when it grows past that, each edge keeps only
/// its topmost entry, which changes no flip (the entries below would be examined after an
/// examination of the same edge with nothing in between that `push_affected` did not
/// push again above them). The stack and the compaction's buffers grow with the input and
/// are allocated fallibly: an allocation refused is an [`Error::OutOfMemory`], not an
/// abort. O(flips + m) time, O(m) memory.
pub fn lop<S: FlipSearch>(search: &mut S, max_flips: usize) -> Result<usize> {
    lop_counted(search, max_flips, None)
}

/// Edges [`lop_counted`] examines between two counts: a relaxed atomic add per batch.
const COUNT_BATCH: usize = 4096;

/// [`lop`], counted as `weight` items of `progress` when `counted` is `(progress, weight)`:
/// the share of the interior edges whose first examination has come (the stack's bottom,
/// below every edge a flip pushed, is the edges not yet reached), in batches of
/// [`COUNT_BATCH`] examinations. The weight is all counted when it returns. O(flips + m).
pub fn lop_counted<S: FlipSearch>(
    search: &mut S,
    max_flips: usize,
    counted: Option<(&Progress, u64)>,
) -> Result<usize> {
    let n_half_edges = search.mesh().n_half_edges();
    let mut stack: Vec<u32> = try_vec(EDGE_STACK, n_half_edges / 2)?;
    stack.extend(search.mesh().interior_edge_slots().rev());
    // What a flip pushes (the edges around a few vertices), moved onto the stack once its
    // room is reserved fallibly.
    let mut affected: Vec<u32> = Vec::new();
    let compact_above = 4 * n_half_edges + 1024;
    let check_every = n_half_edges.max(1);
    let mut next_check = check_every;
    let mut checkpoint = search.progress();
    let mut flips = 0;
    let share = counted.map(|(progress, weight)| Share::new(progress, weight, stack.len() as u64));
    // The stack's lowest length so far (the edges never reached) and the last one counted.
    let (mut unreached, mut counted_at, mut examined) = (stack.len(), stack.len(), 0);
    while let Some(h) = stack.pop() {
        unreached = unreached.min(stack.len());
        examined += 1;
        if examined == COUNT_BATCH {
            examined = 0;
            if let Some(share) = &share {
                share.add((counted_at - unreached) as u64);
                counted_at = unreached;
            }
        }
        if flips >= max_flips {
            break;
        }
        if flips >= next_check {
            next_check += check_every;
            if let (Some((before, tolerance)), Some((now, _))) = (checkpoint, search.progress()) {
                if now >= before - tolerance {
                    break;
                }
                checkpoint = Some((now, tolerance));
            }
        }
        let t = search.mesh().twin(h);
        if t == NONE || !search.flip_if_better(h) {
            continue;
        }
        flips += 1;
        affected.clear();
        search.push_affected(h, t, &mut affected);
        try_grow(EDGE_STACK, &mut stack, affected.len())?;
        stack.extend_from_slice(&affected);
        if stack.len() > compact_above {
            keep_topmost(&mut stack, n_half_edges)?;
        }
    }
    if let Some(share) = share {
        share.finish();
    }
    Ok(flips)
}

/// What [`lop`]'s failed allocations name.
const EDGE_STACK: &str = "LOP's edge stack";

/// Removes every entry of `stack` that has a copy nearer the top, keeping order; an
/// [`Error::OutOfMemory`] when its buffers cannot be allocated. O(len + m).
fn keep_topmost(stack: &mut Vec<u32>, n_half_edges: usize) -> Result<()> {
    let mut seen = try_filled(EDGE_STACK, false, n_half_edges)?;
    let mut kept: Vec<u32> = try_vec(EDGE_STACK, n_half_edges)?;
    for &e in stack.iter().rev() {
        if !std::mem::replace(&mut seen[e as usize], true) {
            kept.push(e);
        }
    }
    kept.reverse();
    *stack = kept;
    Ok(())
}

/// LOP for the tac energy of a [`TacState`] under a [`TacOrder`].
pub struct TacLop<'a> {
    /// The state flipped in place.
    pub state: &'a mut TacState,
    /// The order judged by.
    pub order: TacOrder,
}

impl FlipSearch for TacLop<'_> {
    fn mesh(&self) -> &HalfEdgeMesh {
        self.state.mesh()
    }
    fn flip_if_better(&mut self, h: u32) -> bool {
        // `push_affected` walks fans: a state left unanchored by annealing ties is
        // reanchored once, here (a flag test on every later call).
        self.state.reanchor();
        match self.state.evaluate(h, Detail::Shape) {
            Some(mv)
                if self
                    .order
                    .improves(&mv, |tol| self.state.flat_quad_uv(h, tol)) =>
            {
                self.state.apply(&mv);
                true
            }
            _ => false,
        }
    }
    /// A flip changes the angle sums of its four corners, and with them the energy change
    /// of every edge in their fans (incident or opposite): those are re-examined.
    fn push_affected(&self, h: u32, t: u32, stack: &mut Vec<u32>) {
        let mesh = self.state.mesh();
        for v in mesh.quad(h, t) {
            for e in mesh.fan(v) {
                stack.extend([e, next(e)]);
            }
        }
    }
    fn progress(&self) -> Option<(f64, f64)> {
        Some((self.state.energy(), self.order.tie_tolerance))
    }
}

/// LOP for the max-min angle measured in the plane: a flip improves when the smallest
/// planar angle of the two triangles grows. Its optimum is the Delaunay triangulation.
pub struct PlanarMaxMinLop<'a> {
    /// The triangulation flipped in place.
    pub mesh: &'a mut HalfEdgeMesh,
    /// Planar positions.
    pub uv: &'a [[f64; 2]],
}

impl FlipSearch for PlanarMaxMinLop<'_> {
    fn mesh(&self) -> &HalfEdgeMesh {
        self.mesh
    }
    fn flip_if_better(&mut self, h: u32) -> bool {
        if !self.mesh.can_flip(h, self.uv) {
            return false;
        }
        let t = self.mesh.twin(h);
        if planar_flip_improves(self.mesh.quad(h, t).map(|v| self.uv[v as usize])) {
            self.mesh.flip(h);
            true
        } else {
            false
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::optimize::tac_state::tests::bumpy_state;
    use crate::optimize::tac_state::NOISE_TAC;
    use crate::triangulate::delaunay::delaunay;
    use std::f64::consts::TAU;

    /// A search that flips every convex edge it is shown and pushes a flood of edges: it
    /// never reaches an optimum (flipping twice restores a quadrilateral), the worst case
    /// for the cycle guards.
    struct Restless {
        mesh: HalfEdgeMesh,
        uv: Vec<[f64; 2]>,
        primary: Option<(f64, f64)>,
    }

    impl FlipSearch for Restless {
        fn mesh(&self) -> &HalfEdgeMesh {
            &self.mesh
        }
        fn flip_if_better(&mut self, h: u32) -> bool {
            let ok = self.mesh.can_flip(h, &self.uv);
            if ok {
                self.mesh.flip(h);
            }
            ok
        }
        fn push_affected(&self, h: u32, t: u32, stack: &mut Vec<u32>) {
            for _ in 0..8 {
                stack.extend([h, next(h), prev(h), next(t), prev(t)]);
            }
        }
        fn progress(&self) -> Option<(f64, f64)> {
            self.primary
        }
    }

    #[test]
    fn cycles_stop_with_bounded_memory() {
        let uv = crate::testing::random_points(200, 3);
        let d = delaunay(&uv).unwrap();
        let mesh = HalfEdgeMesh::from_triangles(uv.len(), &d.triangles).unwrap();
        let m = mesh.n_half_edges();
        // No progress reported: only the flip budget stops it (the stack compacted, not
        // growing by 40 entries per flip).
        let mut blind = Restless {
            mesh: mesh.clone(),
            uv: uv.clone(),
            primary: None,
        };
        assert_eq!(lop(&mut blind, 20 * m).unwrap(), 20 * m);
        blind.mesh.validate(&uv).unwrap();
        // A primary value that never drops: stopped after m flips, long before the budget.
        let mut flat = Restless {
            mesh,
            uv: uv.clone(),
            primary: Some((1.0, 1e-10)),
        };
        assert_eq!(lop(&mut flat, max_flips(m)).unwrap(), m);
    }

    #[test]
    fn a_stack_beyond_memory_is_an_error_not_an_abort() {
        // Compacting for more half-edges than any allocator gives, and growing past them.
        for e in [
            keep_topmost(&mut vec![0], usize::MAX / 2).unwrap_err(),
            try_grow(EDGE_STACK, &mut vec![0u32], usize::MAX / 4).unwrap_err(),
        ] {
            assert!(
                matches!(&e, Error::OutOfMemory { what, .. } if what.starts_with(EDGE_STACK)),
                "{e}"
            );
        }
    }

    #[test]
    fn compaction_keeps_each_entrys_topmost_copy_in_order() {
        let mut stack = vec![1, 2, 1, 3, 2, 0];
        keep_topmost(&mut stack, 4).unwrap();
        assert_eq!(stack, vec![1, 3, 2, 0]);
    }

    fn canonical(mut t: Vec<[u32; 3]>) -> Vec<[u32; 3]> {
        for tri in t.iter_mut() {
            let k = (0..3).min_by_key(|&k| tri[k]).unwrap();
            tri.rotate_left(k);
        }
        t.sort();
        t
    }

    #[test]
    fn planar_max_min_lop_reproduces_delaunay() {
        let st = bumpy_state(400, 8, 1.0);
        let uv = st.uv().unwrap();
        let dt = canonical(delaunay(&uv).unwrap().triangles);
        let mut mesh = st.mesh().clone();
        scramble(&mut mesh, &uv, 5000);
        assert_ne!(canonical(mesh.triangles().unwrap()), dt);
        let flips = lop(
            &mut PlanarMaxMinLop {
                mesh: &mut mesh,
                uv: &uv,
            },
            usize::MAX,
        )
        .unwrap();
        assert!(flips > 0);
        mesh.validate(&uv).unwrap();
        assert_eq!(canonical(mesh.triangles().unwrap()), dt);
    }

    /// Tries `tries` random legal flips of `mesh` (a fixed sequence): a triangulation away
    /// from Delaunay's.
    fn scramble(mesh: &mut HalfEdgeMesh, uv: &[[f64; 2]], tries: usize) {
        let edges = mesh.interior_edges().unwrap();
        let mut s = 5u64;
        for _ in 0..tries {
            s = s.wrapping_mul(6364136223846793005).wrapping_add(1);
            let h = edges[(s >> 33) as usize % edges.len()];
            if mesh.can_flip(h, uv) {
                mesh.flip(h);
            }
        }
    }

    #[test]
    fn planar_ties_return_a_noisy_plane_to_delaunay() {
        // A plane with height noise: every corner's tac is the noise's, within the
        // tolerance, so with planar ties tac LOP is Delaunay's LOP (from a scrambled
        // start, back to Delaunay); judged by tac and 3-D angles it ends elsewhere.
        let noisy = crate::optimize::tac_state::tests::height_state(400, 12, 1.0, |x, y| {
            let bits =
                (x.to_bits() ^ y.to_bits().rotate_left(29)).wrapping_mul(0x9E37_79B9_7F4A_7C15);
            let unit = (bits >> 11) as f64 / (1u64 << 53) as f64;
            0.2 * x + 0.1 * y + 2e-3 * (unit - 0.5)
        });
        let uv = noisy.uv().unwrap();
        let dt = canonical(delaunay(&uv).unwrap().triangles);
        let mut mesh = noisy.mesh().clone();
        // A few flips away: LOP's progress guard (the energy must drop every m flips) stops
        // the long planar walks back from a thoroughly scrambled start.
        scramble(&mut mesh, &uv, 100);
        assert_ne!(canonical(mesh.triangles().unwrap()), dt);
        let start = noisy.with_mesh(mesh).unwrap();
        let max_tac = (0..start.mesh().n_vertices() as u32)
            .filter(|&v| start.mesh().is_interior(v))
            .map(|v| (TAU - start.angle_sum(v)).abs())
            .fold(0.0, f64::max);
        let tie_tolerance = max_tac / NOISE_TAC;
        for planar_ties in [true, false] {
            let mut st = start.clone();
            let order = TacOrder {
                tie_tolerance,
                sliver_guard: true,
                planar_ties,
                sliver_angle: 0.0,
                min_facing: 0.0,
            };
            assert!(tac_lop(&mut st, order).unwrap() > 0);
            st.mesh().validate(&uv).unwrap();
            assert_eq!(canonical(st.mesh().triangles().unwrap()) == dt, planar_ties);
        }
    }

    #[test]
    fn no_single_flip_of_delaunay_raises_its_planar_smallest_angle() {
        let st = bumpy_state(300, 9, 1.0);
        let uv = st.uv().unwrap();
        let mut mesh = st.mesh().clone();
        let flips = lop(
            &mut PlanarMaxMinLop {
                mesh: &mut mesh,
                uv: &uv,
            },
            usize::MAX,
        )
        .unwrap();
        assert_eq!(flips, 0, "Delaunay is already max-min optimal");
    }

    #[test]
    fn tac_lop_descends_to_a_local_optimum() {
        let mut st = bumpy_state(500, 10, 1.0);
        let e0 = st.energy();
        let order = TacOrder {
            tie_tolerance: 1e-12,
            sliver_guard: true,
            planar_ties: false,
            sliver_angle: 0.0,
            min_facing: 0.0,
        };
        let flips = lop(
            &mut TacLop {
                state: &mut st,
                order,
            },
            usize::MAX,
        )
        .unwrap();
        assert!(flips > 0 && st.energy() < e0);
        st.mesh().validate(&st.uv().unwrap()).unwrap();
        let scratch = st.energy_from_scratch();
        assert!((st.energy() - scratch).abs() < 1e-9 * scratch);
        for h in st.mesh().interior_edges().unwrap() {
            if let Some(mv) = st.evaluate(h, Detail::Shape) {
                assert!(
                    !order.improves(&mv, |tol| st.flat_quad_uv(h, tol)),
                    "edge {h} still improves: {mv:?}"
                );
            }
        }
    }
}
