//! Lower bounds on the paths that leave a band of the Fuchs matrix, so that a band DP can
//! prove its path optimal over the whole matrix.
//!
//! # The relaxed graph
//!
//! A band is rows `lo[i]..=hi[i]`, both nondecreasing, consecutive rows overlapping. A
//! path that leaves it goes above it (`j > hi[i]`) or below it (`j < lo[i]`), never from one
//! side to the other without passing through it, and comes back: above by an A-step into
//! (i, j) from (i − 1, j) with `j > hi[i − 1]`, below by a B-step into `(i, lo[i])`. Replace
//! every step outside the band by a lower bound on its cost that depends only on the line
//! edge the step uses (row r for an A-step, column j for a B-step: `a_above[r]` bounds the
//! A-step of row r from any column above the band, and so on), drop the turns outside, and
//! keep the band's cells and the steps out of and back into it exact. Every path of the
//! matrix costs at least its image in this relaxed graph, and paths inside the band cost
//! the same in both. So when the cheapest path of the relaxed graph lies inside the band,
//! it is the cheapest path of the whole matrix.
//!
//! The band DP finds it without visiting a cell outside: an excursion above that leaves
//! row i1 at `(i1, hi[i1] + 1)` and reaches (i − 1, j) uses exactly the A-edges i1..i − 1
//! and the B-edges `hi[i1] + 1..j`, whatever its shape, so its bound is a difference of
//! prefix sums, and the cheapest way back in at (i, j) is
//! `A[i − 1] + B[j] + min over exits so far of (cost at exit − A[i1] − B[hi[i1] + 1])`:
//! one running minimum per side ([`Bounds`]), O(1) per row.
//!
//! # The bounds of one step
//!
//! An A-step of row r adds the triangle (a_r, a_{r+1}, b_j), j in a range J of columns;
//! every b_j of J lies in the bounding box of b_J (a B-step: the same with the lines'
//! roles swapped). With d0 and d1 the distances of a_r and a_{r+1} from that box and
//! s = |a_r a_{r+1}|: the entered node's edge a_{r+1}–b_j is at least d1 long; and when
//! s² ≤ d0² + d1², the angle γ at b_j (opposite s) is not obtuse and sin γ ≤ s / max(d0,
//! d1) (law of sines), so the smallest angle is at most γ ≤ asin(x) ≤ x / √(1 − x²) with
//! x = s / max(d0, d1): the angle penalty is at least π/3 minus that. Area and dihedral
//! angle get no bound (0): a far triangle can be as flat and as smooth as a near one.
//! The boxes of the ranges follow the band's edges as it moves (suffix boxes swept from
//! the end, prefix boxes from the start): O(n + m) per band.
//!
//! The weights that bound far steps well are length and angle (the default weight has the
//! angle); with only area or dihedral the relaxed paths outside are nearly free, the band
//! cannot prove much, and the banded solver widens to the full DP.

use super::dp::{Cell, Outside};
use super::weights::{Terms, Tri};
use super::{Ask, Step};
use crate::Result;
use glam::DVec3;
use std::f64::consts::FRAC_PI_3;

/// Every step bound is shrunk by this factor, so that rounding in the prefix sums (a few
/// ulps of the strip's total) cannot lift a relaxed path above an exact one.
const SHRINK: f64 = 1.0 - 1e-9;

/// An axis-aligned box of points, empty at first.
#[derive(Clone, Copy)]
struct Aabb {
    lo: DVec3,
    hi: DVec3,
}

impl Aabb {
    const EMPTY: Aabb = Aabb {
        lo: DVec3::INFINITY,
        hi: DVec3::NEG_INFINITY,
    };

    fn add(&mut self, p: DVec3) {
        self.lo = self.lo.min(p);
        self.hi = self.hi.max(p);
    }

    fn is_empty(&self) -> bool {
        self.lo.x > self.hi.x
    }

    /// Squared distance from `p` to the (non-empty) box. O(1).
    fn distance_squared(&self, p: DVec3) -> f64 {
        (self.lo - p)
            .max(p - self.hi)
            .max(DVec3::ZERO)
            .length_squared()
    }
}

/// Lower bound on the cost of a step whose line edge runs from `p` to `q` (the entered
/// node's edge ends at `q`) and whose third corner lies in `far` (see the module docs);
/// 0 for an empty box. O(1).
fn step_bound(t: &Terms, p: DVec3, q: DVec3, far: &Aabb) -> f64 {
    if far.is_empty() {
        return 0.0;
    }
    // Squared distances: the angle bound needs no square root but its own, and the length
    // one only when the length weight is on.
    let (d0, d1) = (far.distance_squared(p), far.distance_squared(q));
    let mut cost = if t.w.length == 0.0 {
        0.0
    } else {
        t.w.length * d1.sqrt()
    };
    let s2 = (q - p).length_squared();
    let d2 = d0.max(d1);
    // x = s / d < 1, and x / √(1 − x²) = √(s² / (d² − s²)).
    if t.w.angle != 0.0 && s2 < d2 && s2 <= d0 + d1 {
        let gamma = (s2 / (d2 - s2)).sqrt();
        cost += t.w.angle * (FRAC_PI_3 - gamma).max(0.0);
    }
    cost * SHRINK
}

/// Prefix sums of `bounds` (`len` at most): entry k is the sum of the first k. Allocated
/// as `ask`'s. O(len).
fn prefix_sums(bounds: impl Iterator<Item = f64>, len: usize, ask: &Ask) -> Result<Vec<f64>> {
    let mut sums = ask.vec(len + 1)?;
    let mut total = 0.0;
    sums.push(total);
    for x in bounds {
        total += x;
        sums.push(total);
    }
    Ok(sums)
}

/// The relaxed ways around one band (see the module docs).
pub(super) struct Bounds<'t, 'a> {
    t: &'t Terms<'a>,
    lo: &'t [usize],
    /// Prefix sums over rows of the A-step bounds above and below the band (n + 1 each;
    /// entry r sums rows 0..r), and over columns of the B-step bounds (m + 1 each).
    a_above: Vec<f64>,
    a_below: Vec<f64>,
    b_above: Vec<f64>,
    b_below: Vec<f64>,
    /// Over the exits so far: cost on leaving minus the prefix sums at the exit cell.
    best_above: f64,
    best_below: f64,
}

impl<'t, 'a> Bounds<'t, 'a> {
    /// The bounds around band `lo..=hi` of `t`, allocated as `ask`'s. O(n + m).
    pub(super) fn new(
        t: &'t Terms<'a>,
        lo: &'t [usize],
        hi: &'t [usize],
        ask: &Ask,
    ) -> Result<Self> {
        let (a, b) = (t.a, t.b);
        let (n, m) = (a.len(), b.len());
        // A-steps of row r above the band: columns hi[r] + 1..m, a suffix of b growing as r
        // falls; below: columns 0..lo[r], a prefix growing with r.
        let mut up = ask.filled(n.saturating_sub(1), 0.0)?;
        let mut far = Aabb::EMPTY;
        let mut next = m;
        for r in (0..n.saturating_sub(1)).rev() {
            while next > hi[r] + 1 {
                next -= 1;
                far.add(b[next]);
            }
            up[r] = step_bound(t, a[r], a[r + 1], &far);
        }
        let mut far = Aabb::EMPTY;
        let mut next = 0;
        let down = (0..n.saturating_sub(1)).map(|r| {
            while next < lo[r] {
                far.add(b[next]);
                next += 1;
            }
            step_bound(t, a[r], a[r + 1], &far)
        });
        let a_below = prefix_sums(down, n, ask)?;
        // B-steps of column j above the band: rows with hi[r] < j, a prefix of a growing
        // with j; below: rows with lo[r] > j + 1, a suffix growing as j falls.
        let mut far = Aabb::EMPTY;
        let mut next = 0;
        let up_b = (0..m.saturating_sub(1)).map(|j| {
            while next < n && hi[next] < j {
                far.add(a[next]);
                next += 1;
            }
            step_bound(t, b[j], b[j + 1], &far)
        });
        let b_above = prefix_sums(up_b, m, ask)?;
        let mut down_b = ask.filled(m.saturating_sub(1), 0.0)?;
        let mut far = Aabb::EMPTY;
        let mut next = n;
        for j in (0..m.saturating_sub(1)).rev() {
            while next > 0 && lo[next - 1] > j + 1 {
                next -= 1;
                far.add(a[next]);
            }
            down_b[j] = step_bound(t, b[j], b[j + 1], &far);
        }
        Ok(Bounds {
            t,
            lo,
            a_above: prefix_sums(up.into_iter(), n, ask)?,
            a_below,
            b_above,
            b_below: prefix_sums(down_b.into_iter(), m, ask)?,
            best_above: f64::INFINITY,
            best_below: f64::INFINITY,
        })
    }
}

impl Outside for Bounds<'_, '_> {
    fn in_from_above(&self, i: usize, j: usize, beaten: f64) -> Option<(f64, Tri)> {
        if i == 0 || self.best_above == f64::INFINITY {
            return None;
        }
        let before = self.a_above[i - 1] + self.b_above[j] + self.best_above;
        // The step's cost is ≥ 0 (and adding it never rounds a sum down).
        if before > beaten {
            return None;
        }
        let step = self.t.step(i - 1, j, Step::A);
        Some((before + step.cost, step))
    }

    fn in_from_below(&self, i: usize, j: usize, beaten: f64) -> Option<(f64, Tri)> {
        if j == 0 || self.best_below == f64::INFINITY {
            return None;
        }
        let before = self.a_below[i] + self.b_below[j - 1] + self.best_below;
        if before > beaten {
            return None;
        }
        let step = self.t.step(i, j - 1, Step::B);
        Some((before + step.cost, step))
    }

    fn leave(&mut self, i: usize, row: &[Cell], lo: usize, hi: usize) {
        // The start cell is entered by no step: its cost is its node's.
        let at = |j: usize| {
            if i == 0 && j == 0 {
                self.t.node(0, 0)
            } else {
                row[j - lo].cost[0].min(row[j - lo].cost[1])
            }
        };
        // Out above: a B-step from the row's last cell. The turn into it is ≥ 0: left out.
        // A step's cost is ≥ 0 and the key is monotone in it (the same subtractions in
        // the same order), so a key already at least the best one before the step cannot
        // lower it: then the step is not evaluated.
        if hi + 1 < self.t.m() && at(hi) < f64::INFINITY {
            let key = |leaving: f64| leaving - self.a_above[i] - self.b_above[hi + 1];
            if key(at(hi)) < self.best_above {
                let leaving = at(hi) + self.t.step(i, hi, Step::B).cost;
                self.best_above = self.best_above.min(key(leaving));
            }
        }
        // Out below: A-steps into the next row left of its band.
        if i + 1 < self.lo.len() {
            for j in lo..self.lo[i + 1].min(hi + 1) {
                let key = |leaving: f64| leaving - self.a_below[i + 1] - self.b_below[j];
                if at(j) < f64::INFINITY && key(at(j)) < self.best_below {
                    let leaving = at(j) + self.t.step(i, j, Step::A).cost;
                    self.best_below = self.best_below.min(key(leaving));
                }
            }
        }
    }
}
