//! Friedhoff's α-look-ahead walk: each step chosen by the cheapest path of α steps
//! beyond it.

use super::dp::{best_from, full_dp, Cell, UNREACHED};
use super::filter::{self, FilterCounts};
use super::weights::{with_turn, Terms, Tri, Weight};
use super::{Solution, Step, MAX_LOOKAHEAD_CELLS};
use crate::{Error, Result};
use glam::DVec3;

/// Reusable buffers of the look-ahead window, so the walk allocates only when a window
/// grows past every earlier one.
pub(super) struct Window {
    pub(super) cells: Vec<Cell>,
}

impl Window {
    /// The cost of the cheapest path of k = min(α, steps left) steps from (i, j) whose first
    /// step is `first`, given the normal of the triangle that entered (i, j). O(min(α, n) ·
    /// min(α, m)).
    pub(super) fn best(
        &mut self,
        t: &Terms,
        i: usize,
        j: usize,
        entered: Option<Tri>,
        first: Step,
        alpha: usize,
    ) -> f64 {
        let (n, m) = (t.n(), t.m());
        let k = alpha.min(n - 1 - i + m - 1 - j);
        let (rows, cols) = (k.min(n - 1 - i) + 1, k.min(m - 1 - j) + 1);
        self.cells.clear();
        self.cells.resize(rows * cols, UNREACHED);
        let cells = &mut self.cells;
        let step = t.step(i, j, first);
        let at = |p: usize, q: usize| p * cols + q;
        let d = match first {
            Step::A => 0,
            Step::B => 1,
        };
        let first_cell = if d == 0 { at(1, 0) } else { at(0, 1) };
        let turn = entered.map_or(0.0, |e| t.turn_from(&e, step.normal));
        cells[first_cell].enter(d, step.cost + turn, &step);
        let mut best = f64::INFINITY;
        for p in 0..rows {
            for q in 0..cols.min(k + 1 - p) {
                if p + q >= 2 {
                    let mut cell = UNREACHED;
                    if p > 0 {
                        let step = t.step(i + p - 1, j + q, Step::A);
                        let (before, _) =
                            best_from(t, &cells[at(p - 1, q)], step.normal, false, 0.0);
                        cell.enter(0, before + step.cost, &step);
                    }
                    if q > 0 {
                        let step = t.step(i + p, j + q - 1, Step::B);
                        let (before, _) =
                            best_from(t, &cells[at(p, q - 1)], step.normal, false, 0.0);
                        cell.enter(1, before + step.cost, &step);
                    }
                    cells[at(p, q)] = cell;
                }
                if p + q == k {
                    best = best
                        .min(cells[at(p, q)].cost[0])
                        .min(cells[at(p, q)].cost[1]);
                }
            }
        }
        best
    }
}

/// Friedhoff's α-look-ahead: from (0, 0), at each node compare the two possible steps by the
/// cheapest path of α steps (fewer near the end) that starts with each, take the cheaper
/// (A on ties), repeat. α = 1 with the length weight is the greedy shortest-diagonal rule.
///
/// Each decision runs a small DP over the window of nodes within α steps, so the time is
/// O((n + m) · min(α, n) · min(α, m)): O(n + m) for fixed α; at α = 1 the window is the
/// two steps themselves, compared without a DP (the same path bit for bit, about two step
/// evaluations per triangle), each decision first from cheap bounds with exact fallback
/// (`filter`: the same path and cost bit for bit; [`set_strip_filter`](super::set_strip_filter) turns it off). From α = n + m − 2 on, every
/// window reaches the end, the walk follows an optimal path, and a larger α changes
/// nothing: that path is found by one DP instead ([`shortest_path_dp`](super::shortest_path_dp): the same cost; among
/// tied optima, the DP's), in O(nm). Memory O(min(α, n) · min(α, m)). Errors: α = 0, a
/// strip whose windows would exceed [`MAX_LOOKAHEAD_CELLS`] or [`MAX_STRIP_BYTES`](super::MAX_STRIP_BYTES), and
/// those of [`shortest_path`](super::shortest_path).
pub fn lookahead(a: &[DVec3], b: &[DVec3], w: Weight, alpha: usize) -> Result<Solution> {
    let t = Terms::new(a, b, w)?;
    if alpha == 0 {
        return Err(Error::InvalidParameter {
            name: "alpha",
            value: "0".into(),
            expected: "a look-ahead depth of at least 1 step",
        });
    }
    let (n, m) = (t.n(), t.m());
    let ask = t.ask("alpha", alpha.to_string());
    if alpha >= n + m - 2 {
        // Every window reaches the end: the walk follows an optimal path, which one DP finds.
        return full_dp(&t, &ask);
    }
    if alpha == 1 {
        // Only the angle term has an atan2 to filter (turns are taken exactly).
        if filter::enabled() && w.angle != 0.0 {
            let mut counts = FilterCounts::default();
            let solution = greedy_filtered(&t, &mut counts);
            filter::record(counts);
            return solution;
        }
        return greedy(&t);
    }
    let (rows, cols) = (alpha.min(n - 1) + 1, alpha.min(m - 1) + 1);
    ask.check_bytes(rows as u128 * cols as u128 * std::mem::size_of::<Cell>() as u128)?;
    let per_window =
        (rows as u128 * cols as u128).min((alpha as u128 + 1) * (alpha as u128 + 2) / 2);
    let work = 2 * (n + m - 2) as u128 * per_window;
    if work > u128::from(MAX_LOOKAHEAD_CELLS) {
        return Err(ask.refusal(
            format!("{work:.1e} window cells, about {:.0} s", work as f64 * 1e-7),
            "a look-ahead depth whose windows stay under 5e8 cells per strip \
             (or alpha >= n + m - 2, which costs one shortest-path DP)",
        ));
    }
    let window = Window {
        cells: ask.filled(rows * cols, UNREACHED)?,
    };
    windowed(&t, window, alpha)
}

/// The α-look-ahead walk of [`lookahead()`] on checked terms, each decision by a window DP
/// in `window` (sized for α). O((n + m) · min(α, n) · min(α, m)).
pub(super) fn windowed(t: &Terms, mut window: Window, alpha: usize) -> Result<Solution> {
    walk(t, |i, j, entered| {
        let via_a = window.best(t, i, j, *entered, Step::A, alpha);
        let via_b = window.best(t, i, j, *entered, Step::B, alpha);
        let s = if via_a <= via_b { Step::A } else { Step::B };
        let step = t.step(i, j, s);
        (s, step, with_turn(t, step, entered))
    })
}

/// [`lookahead()`] with α = 1 on checked terms: each decision compares the two steps out of
/// the node by their own cost plus their turn, which is all a window of one step holds, so
/// each step is evaluated once and the one taken is not evaluated again (the greedy walk
/// of VTK's ruled surface, under any weight). The same arithmetic as the windows (a cell
/// reached by one step holds `step.cost + turn`), so the same path and cost bit for bit;
/// tested against the windowed walk. O(n + m) time, O(n + m) memory for the path.
pub(super) fn greedy(t: &Terms) -> Result<Solution> {
    walk(t, |i, j, entered| {
        exact_choice(t, t.step(i, j, Step::A), t.step(i, j, Step::B), entered)
    })
}

/// [`greedy`] with each decision taken from cheap bounds where they settle it
/// (`filter::certified_step`), else from the exact steps: the same path and cost bit for
/// bit (tested on the fuzz corpus); the decisions and fallbacks are added to `counts`.
/// O(n + m).
pub(super) fn greedy_filtered(t: &Terms, counts: &mut FilterCounts) -> Result<Solution> {
    walk(t, |i, j, entered| {
        filter::filtered_choice(t, i, j, entered, counts, |a, b| {
            exact_choice(t, a, b, entered)
        })
    })
}

/// The greedy decision between the exact steps `step_a` and `step_b` after `entered`:
/// the step, its [`Tri`] and the cost it adds. O(1).
#[inline(always)]
fn exact_choice(t: &Terms, step_a: Tri, step_b: Tri, entered: &Option<Tri>) -> (Step, Tri, f64) {
    // Turns are ≥ 0 (and adding one never rounds a sum down), so when the cheaper
    // step with its turn still beats the other before any turn, the other's turn
    // (an atan2) cannot change the choice; ties go to A as in the windows.
    let (via_a, via_b) = if step_a.cost <= step_b.cost {
        let via_a = with_turn(t, step_a, entered);
        if via_a <= step_b.cost {
            (via_a, f64::INFINITY)
        } else {
            (via_a, with_turn(t, step_b, entered))
        }
    } else {
        let via_b = with_turn(t, step_b, entered);
        if via_b < step_a.cost {
            (f64::INFINITY, via_b)
        } else {
            (with_turn(t, step_a, entered), via_b)
        }
    };
    if via_a <= via_b {
        (Step::A, step_a, via_a)
    } else {
        (Step::B, step_b, via_b)
    }
}

/// The walk of the look-ahead variants from (0, 0) to (n − 1, m − 1): on the last row or
/// column the step is forced, elsewhere `choose(i, j, entered)` returns the step to take,
/// its [`Tri`] and the cost it adds ([`with_turn`]). O(n + m) calls of `choose`.
pub(super) fn walk(
    t: &Terms,
    mut choose: impl FnMut(usize, usize, &Option<Tri>) -> (Step, Tri, f64),
) -> Result<Solution> {
    let (n, m) = (t.n(), t.m());
    let mut path = t.ask("look-ahead", "walk".into()).vec(n + m - 2)?;
    let (mut i, mut j) = (0, 0);
    let mut entered: Option<Tri> = None;
    let mut cost = t.node(0, 0);
    while i + 1 < n || j + 1 < m {
        let (s, step, added) = if i + 1 == n || j + 1 == m {
            let s = if i + 1 == n { Step::B } else { Step::A };
            let step = t.step(i, j, s);
            (s, step, with_turn(t, step, &entered))
        } else {
            choose(i, j, &entered)
        };
        cost += added;
        entered = Some(step);
        path.push(s);
        match s {
            Step::A => i += 1,
            Step::B => j += 1,
        }
    }
    Ok(Solution { path, cost })
}
