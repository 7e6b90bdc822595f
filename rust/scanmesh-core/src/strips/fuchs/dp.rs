//! The cheapest path by dynamic programming: over the whole matrix, or inside a band of
//! columns per row (with an outside bound, see `outside`).

use super::weights::{Terms, Tri, Weight};
use super::{Ask, Solution, Step};
use crate::Result;
use glam::DVec3;
use std::f64::consts::PI;

/// The cheapest path by dynamic programming over the whole matrix (a DAG).
///
/// State: node and the direction of the step that entered it (for the dihedral weight).
/// Time O(nm), memory O(nm) bytes of back-pointers plus O(m) costs.
pub fn shortest_path_dp(a: &[DVec3], b: &[DVec3], w: Weight) -> Result<Solution> {
    let t = Terms::new(a, b, w)?;
    full_dp(&t, &t.ask("solver", "'dp'".into()))
}

/// [`shortest_path_dp`] on checked terms; refusals name `ask`'s option.
pub(super) fn full_dp(t: &Terms, ask: &Ask) -> Result<Solution> {
    let lo = ask.filled(t.n(), 0)?;
    let hi = ask.filled(t.n(), t.m() - 1)?;
    dp_in_band(t, &lo, &hi, ask)
}

/// A matrix cell: per entering direction (A = 0, B = 1), the cheapest cost so far and the
/// entering triangle's normal and apex (see [`Tri`]); the node length, for the turns out.
#[derive(Clone, Copy)]
pub(super) struct Cell {
    pub(super) cost: [f64; 2],
    pub(super) normal: [DVec3; 2],
    pub(super) apex: [DVec3; 2],
    pub(super) len: f64,
}

pub(super) const UNREACHED: Cell = Cell {
    cost: [f64::INFINITY; 2],
    normal: [DVec3::ZERO; 2],
    apex: [DVec3::ZERO; 2],
    len: 0.0,
};

impl Cell {
    /// Records `step` as the way in by direction `d` at cost `cost`. O(1).
    #[inline(always)]
    pub(super) fn enter(&mut self, d: usize, cost: f64, step: &Tri) {
        self.cost[d] = cost;
        self.normal[d] = step.normal;
        self.apex[d] = step.apex;
        self.len = step.len;
    }
}

/// The best way into a cell from predecessor `p` by a step whose triangle has `normal`:
/// (cost before the step, entering direction at `p`: 0 = A, 1 = B). At the start cell
/// there is no previous triangle, so no turn.
#[inline(always)]
pub(super) fn best_from(
    t: &Terms,
    p: &Cell,
    normal: DVec3,
    at_start: bool,
    start_cost: f64,
) -> (f64, u8) {
    if at_start {
        return (start_cost, 0);
    }
    // Turns cost atan2s, the hot spot: when the cheaper state plus its turn is still below
    // the other state before any turn, the other turn cannot win (turns are ≥ 0); on scan
    // strips that settles all but about 1 in 1,000. The choice is a select, not a branch:
    // which state is cheaper is a coin toss the branch predictor loses.
    let cheaper = usize::from(p.cost[1] < p.cost[0]);
    let other = 1 - cheaper;
    let via_cheaper = p.cost[cheaper] + t.turn(p.normal[cheaper], p.apex[cheaper], p.len, normal);
    if p.cost[other] > via_cheaper {
        return (via_cheaper, cheaper as u8);
    }
    let via_other = p.cost[other] + t.turn(p.normal[other], p.apex[other], p.len, normal);
    let (via_a, via_b) = if cheaper == 0 {
        (via_cheaper, via_other)
    } else {
        (via_other, via_cheaper)
    };
    if via_a <= via_b {
        (via_a, 0)
    } else {
        (via_b, 1)
    }
}

/// Where [`dp_in_band`] gets the steps entering a cell.
pub(super) trait Steps {
    /// Called once before the cells of row i (band `lo..=hi`) are evaluated.
    fn begin_row(&mut self, i: usize, lo: usize, hi: usize);
    /// [`Terms::step`] (i − 1, j, A), entering (i, j); (i − 1, j) lies in the last band.
    fn entering_by_a(&self, i: usize, j: usize) -> Tri;
    /// [`Terms::step`] (i, j − 1, B), entering (i, j); j − 1 lies in the current band.
    fn entering_by_b(&self, i: usize, j: usize) -> Tri;
}

/// Every step evaluated from scratch by [`Terms::step`]: the reference the row cache is
/// tested against bit for bit.
#[cfg(test)]
pub(super) struct Direct<'t, 'a>(pub(super) &'t Terms<'a>);

#[cfg(test)]
impl Steps for Direct<'_, '_> {
    fn begin_row(&mut self, _: usize, _: usize, _: usize) {}
    fn entering_by_a(&self, i: usize, j: usize) -> Tri {
        self.0.step(i - 1, j, Step::A)
    }
    fn entering_by_b(&self, i: usize, j: usize) -> Tri {
        self.0.step(i, j - 1, Step::B)
    }
}

/// The vector b_j − a_i of node (i, j), its squared length and its length.
#[derive(Clone, Copy, Default)]
pub(super) struct Node {
    pub(super) e: DVec3,
    pub(super) l2: f64,
    pub(super) len: f64,
}

/// Steps from cached vectors: each triangle entering (i, j) has two sides that are node
/// edges (a_i–b_j and a_{i−1}–b_j or a_i–b_{j−1}) and one that is a line step, so the
/// node vectors of the current and the last row plus the line steps give every side,
/// cross product and corner product without recomputing a difference, and each node's
/// length is taken once (both steps into a cell need it). The arithmetic is
/// the same as [`Terms::step`]'s term for term (a negated difference only flips signs,
/// exactly), so the costs are bit-identical; tested.
pub(super) struct RowCache<'t, 'a> {
    pub(super) t: &'t Terms<'a>,
    /// a_{i+1} − a_i and b_{j+1} − b_j, and their squared lengths.
    pub(super) da: Vec<DVec3>,
    pub(super) db: Vec<DVec3>,
    pub(super) da2: Vec<f64>,
    pub(super) db2: Vec<f64>,
    /// Nodes of the current and the last row, from their band's `lo`.
    pub(super) cur: Vec<Node>,
    pub(super) last: Vec<Node>,
    pub(super) cur_lo: usize,
    pub(super) last_lo: usize,
}

impl<'t, 'a> RowCache<'t, 'a> {
    pub(super) fn new(t: &'t Terms<'a>, width: usize, ask: &Ask) -> Result<Self> {
        let steps = |line: &[DVec3]| ask.collect(line.windows(2).map(|w| w[1] - w[0]));
        let (da, db) = (steps(t.a)?, steps(t.b)?);
        let squares = |v: &[DVec3]| ask.collect(v.iter().map(|d| d.length_squared()));
        Ok(RowCache {
            t,
            da2: squares(&da)?,
            db2: squares(&db)?,
            da,
            db,
            cur: ask.filled(width, Node::default())?,
            last: ask.filled(width, Node::default())?,
            cur_lo: 0,
            last_lo: 0,
        })
    }
}

impl Steps for RowCache<'_, '_> {
    fn begin_row(&mut self, i: usize, lo: usize, hi: usize) {
        std::mem::swap(&mut self.cur, &mut self.last);
        self.last_lo = self.cur_lo;
        self.cur_lo = lo;
        let a = self.t.a[i];
        for (node, &b) in self.cur.iter_mut().zip(&self.t.b[lo..=hi]) {
            let e = b - a;
            let l2 = e.length_squared();
            *node = Node {
                e,
                l2,
                len: l2.sqrt(),
            };
        }
    }

    #[inline(always)]
    fn entering_by_a(&self, i: usize, j: usize) -> Tri {
        // (p, q, r) = (a_{i−1}, a_i, b_j): q − p = da, r − p = last.e, r − q = cur.e; the
        // apex a_{i−1} − a_i = −da.
        let (cur, last) = (self.cur[j - self.cur_lo], self.last[j - self.last_lo]);
        let da = self.da[i - 1];
        self.t.triangle(
            cur.len,
            da.cross(last.e),
            [self.da2[i - 1], cur.l2, last.l2],
            [last.e.dot(cur.e), da.dot(last.e), -cur.e.dot(da)],
            -da,
        )
    }

    #[inline(always)]
    fn entering_by_b(&self, _: usize, j: usize) -> Tri {
        // (p, q, r) = (a_i, b_j, b_{j−1}): q − p = cur.e, r − p = left.e, q − r = db; the
        // apex b_{j−1} − a_i = left.e.
        let (cur, left) = (self.cur[j - self.cur_lo], self.cur[j - 1 - self.cur_lo]);
        let db = self.db[j - 1];
        self.t.triangle(
            cur.len,
            cur.e.cross(left.e),
            [cur.l2, self.db2[j - 1], left.l2],
            [-left.e.dot(db), cur.e.dot(left.e), db.dot(cur.e)],
            left.e,
        )
    }
}

/// DP restricted to row bands `lo[i]..=hi[i]` (nondecreasing, overlapping consecutive rows,
/// `lo[0] = 0`, `hi[n−1] = m−1`). O(Σ band widths) time and back-pointer bytes, checked
/// against [`MAX_STRIP_BYTES`](super::MAX_STRIP_BYTES) before anything is allocated (refusals name `ask`'s option).
pub(super) fn dp_in_band(t: &Terms, lo: &[usize], hi: &[usize], ask: &Ask) -> Result<Solution> {
    let width = check_band(t, lo, hi, ask)?;
    let solution = dp_in_band_with(t, RowCache::new(t, width, ask)?, &mut Sealed, lo, hi, ask)?;
    Ok(solution.expect("a sealed band has no way out"))
}

/// Checks the memory of a DP in the band `lo..=hi` against [`MAX_STRIP_BYTES`](super::MAX_STRIP_BYTES); returns
/// the widest row. O(n).
pub(super) fn check_band(t: &Terms, lo: &[usize], hi: &[usize], ask: &Ask) -> Result<usize> {
    let width = (0..t.n()).map(|i| hi[i] + 1 - lo[i]).max().unwrap_or(1);
    let cells: u128 = (0..t.n()).map(|i| (hi[i] + 1 - lo[i]) as u128).sum();
    let per_column = 2 * (std::mem::size_of::<Cell>() + std::mem::size_of::<Node>());
    ask.check_bytes(cells + width as u128 * per_column as u128)?;
    Ok(width)
}

/// What a band DP knows of the paths outside its band: how cheaply they can come back in.
/// A band DP that lets them in computes the shortest path of a relaxed graph, the band's
/// exact cells plus lower bounds on everything outside (see `outside`), and its optimum,
/// when it stays in the band, is the optimum of the whole matrix.
pub(super) trait Outside {
    /// Lower bound on the cost of reaching (i, j) by an A-step from (i − 1, j) outside
    /// the band (above it), with that step's triangle, or None: also when that bound
    /// exceeds `beaten`, a cost above which this state can never be chosen (the cell's
    /// other state plus the largest turn), so the step need not be evaluated.
    fn in_from_above(&self, i: usize, j: usize, beaten: f64) -> Option<(f64, Tri)>;
    /// The same for a B-step from (i, j − 1) outside the band (below it).
    fn in_from_below(&self, i: usize, j: usize, beaten: f64) -> Option<(f64, Tri)>;
    /// Takes note of the ways out of the band from row i, whose cells `row` (band
    /// `lo..=hi`) are final.
    fn leave(&mut self, i: usize, row: &[Cell], lo: usize, hi: usize);
}

/// A band with no way in from outside: the plain band DP.
pub(super) struct Sealed;

impl Outside for Sealed {
    #[inline(always)]
    fn in_from_above(&self, _: usize, _: usize, _: f64) -> Option<(f64, Tri)> {
        None
    }
    #[inline(always)]
    fn in_from_below(&self, _: usize, _: usize, _: f64) -> Option<(f64, Tri)> {
        None
    }
    #[inline(always)]
    fn leave(&mut self, _: usize, _: &[Cell], _: usize, _: usize) {}
}

/// [`dp_in_band`] with steps from `steps` and the ways in from `outside`: the cheapest
/// path, or None when the cheapest way to the end comes in from outside the band.
pub(super) fn dp_in_band_with(
    t: &Terms,
    mut steps: impl Steps,
    outside: &mut impl Outside,
    lo: &[usize],
    hi: &[usize],
    ask: &Ask,
) -> Result<Option<Solution>> {
    let (n, m) = (t.n(), t.m());
    let start_cost = t.node(0, 0);
    if n == 1 && m == 1 {
        return Ok(Some(Solution {
            path: Vec::new(),
            cost: start_cost,
        }));
    }
    // Row offsets into the flat back-pointer array: bit 0 = direction at the predecessor
    // for entering by A, bit 1 = the same for entering by B.
    let mut offset = ask.vec(n + 1)?;
    offset.push(0usize);
    for i in 0..n {
        offset.push(offset[i] + hi[i] + 1 - lo[i]);
    }
    let mut back = ask.filled(offset[n], 0u8)?;
    let width = (0..n).map(|i| hi[i] + 1 - lo[i]).max().unwrap_or(1);
    let mut prev = ask.filled(width, UNREACHED)?;
    let mut cur = ask.filled(width, UNREACHED)?;
    // Every turn is at most this (a dihedral angle is at most π, and rounding is
    // monotone), so a state costing more than another of its cell plus this is never
    // chosen over it.
    let max_turn = t.w.dihedral * PI;
    for i in 0..n {
        steps.begin_row(i, lo[i], hi[i]);
        for j in lo[i]..=hi[i] {
            let mut cell = UNREACHED;
            let mut bits = 0u8;
            // Rows overlap and `lo` never decreases: (i − 1, j) is in the band unless j
            // is past its end. A way in from outside is taken after the cell's other
            // state, which is then inside the band (j > hi[i − 1] ≥ lo[i] above, j = lo[i]
            // ≤ hi[i − 1] below): a way in costing more than that state plus any turn can
            // never be chosen (not by `best_from`, `leave` or the end), so it is left out.
            let by_a_inside = i > 0 && j <= hi[i - 1];
            if by_a_inside {
                let step = steps.entering_by_a(i, j);
                let (before, from) = best_from(
                    t,
                    &prev[j - lo[i - 1]],
                    step.normal,
                    i == 1 && j == 0,
                    start_cost,
                );
                cell.enter(0, before + step.cost, &step);
                bits |= from;
            }
            if j > lo[i] {
                let step = steps.entering_by_b(i, j);
                let (before, from) = best_from(
                    t,
                    &cur[j - 1 - lo[i]],
                    step.normal,
                    i == 0 && j == 1,
                    start_cost,
                );
                cell.enter(1, before + step.cost, &step);
                bits |= from << 1;
            } else if let Some((cost, step)) = outside.in_from_below(i, j, cell.cost[0] + max_turn)
            {
                cell.enter(1, cost, &step);
            }
            if !by_a_inside {
                if let Some((cost, step)) = outside.in_from_above(i, j, cell.cost[1] + max_turn) {
                    cell.enter(0, cost, &step);
                }
            }
            cur[j - lo[i]] = cell;
            back[offset[i] + j - lo[i]] = bits;
        }
        outside.leave(i, &cur[..hi[i] + 1 - lo[i]], lo[i], hi[i]);
        std::mem::swap(&mut prev, &mut cur);
    }
    let last = prev[m - 1 - lo[n - 1]];
    let mut dir = if last.cost[0] <= last.cost[1] { 0u8 } else { 1 };
    let cost = last.cost[dir as usize];
    let mut path = ask.vec(n + m - 2)?;
    let (mut i, mut j) = (n - 1, m - 1);
    while i > 0 || j > 0 {
        let bits = back[offset[i] + j - lo[i]];
        if dir == 0 {
            path.push(Step::A);
            dir = bits & 1;
            i -= 1;
        } else {
            path.push(Step::B);
            dir = (bits >> 1) & 1;
            j -= 1;
        }
        if j < lo[i] || j > hi[i] {
            // Only a way in from outside leads out of the band.
            return Ok(None);
        }
    }
    path.reverse();
    Ok(Some(Solution { path, cost }))
}
