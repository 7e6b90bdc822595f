//! The filtered greedy walk (look-ahead with α = 1): each decision taken from cheap bounds
//! on the two candidate steps' costs, with a proven error bound, and from today's exact
//! evaluation of both steps only where the bounds do not settle it, so the path and its
//! cost are the exact walk's bit for bit.
//!
//! # What is cheap, and its bound
//!
//! The exact walk (`lookahead`'s `exact_choice`) evaluates both steps A and B out of
//! (i, j) exactly, adds the turn to the cheaper one, takes it when that sum is at most the
//! other's cost (strictly below when B is the cheaper: ties go to A), and otherwise
//! compares both sums. Every term of a step's cost is computed here by the same f64
//! operations as there (differences, cross and dot products, square roots) except one
//! atan2: the smallest angle θ = atan2(2·area, dot) of the step's triangle, replaced by
//! [`atan2_cheap2`] (one division and a degree-15 odd polynomial, both steps in one call),
//! with
//!
//! |atan2_cheap(y, x) − atan2_upper(y, x)| ≤ [`ATAN_ERROR`] = 1e-7 for all finite y ≥ 0, x.
//!
//! Derivation: atan2_cheap reduces to r = min(|x|, y) / max(|x|, y) ∈ [0, 1] (one rounding,
//! relative 2⁻⁵³, and atan is 1-Lipschitz), evaluates p(r) ≈ atan(r), then takes π/2 − p
//! when y > |x| and π − that when x < 0 (each one rounding of at most 2⁻⁵³ · π). The
//! polynomial's coefficients are a weighted least-squares fit; its error e = p − atan on
//! [0, 1] is at most 3.82e-8 on a grid of 10⁷ + 1 points (h = 1e-7, numpy's arctan, correct
//! to an ulp), |e′| at most 1.03e-5 there, and |e″| ≤ Σ k(k−1)|c_k| + max|atan″| ≤ 29.9
//! everywhere, so between grid points |e′| ≤ 1.03e-5 + 29.9 · h/2 < 1.6e-6 and
//! |e| ≤ 3.82e-8 + 1.6e-6 · h/2 < 3.9e-8. The Horner evaluation in f64 adds under 1e-15, and
//! `atan2_upper` itself is within 4 ulp of libm (< 3e-15), so 1e-7 holds with a factor of
//! 2.5 to spare. `atan2_cheap_is_within_its_bound` checks it against `atan2_upper` on
//! 2 million inputs (50 million with `--ignored`) in every decade from 1e-300 to 1e300 and
//! near-degenerate ones (tiny y, x near 0, y = |x|, signed zeros, sliver triangles).
//!
//! # The decision is certified
//!
//! The exact cost is `Terms::cost_at(len, 2·area, θ)`, a chain of rounded f64 operations
//! each monotone in θ (non-increasing overall); rounding to nearest is monotone. So with θ̂
//! the cheap angle, the exact cost lies in [cost_at(θ̂ + ε), cost_at(θ̂ − ε)] evaluated by
//! the very formula of the exact walk (ε = [`ATAN_ERROR`]): no separate rounding analysis.
//! When A's upper end is ≤ B's lower end, A is the exact walk's cheaper step; it is
//! evaluated exactly with its turn, and when that sum is ≤ B's lower end (so ≤ B's exact
//! cost) the exact walk takes A with the same values; likewise for B with strict
//! inequalities. In every other case both steps are evaluated exactly and the exact rule
//! decides (a fallback). The step taken is always evaluated exactly (its cost and turn go
//! into the path's cost and the next turn), so the cost is the exact walk's too. Nothing
//! accumulates: each decision compares one-step costs.
//!
//! What it saves: one exact atan2 (the other step's angle) per decision, for one cheap
//! call for both steps; the turns stay exact. [`set_strip_filter`] switches the filter off
//! process-wide (for benchmarks that time both in one process); [`strip_filter_counts`]
//! reports the decisions and the fallbacks.

use super::weights::{smallest_angle_dot, with_turn, Parts, Terms, Tri};
use super::Step;
use std::f64::consts::{FRAC_PI_2, PI};
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering::Relaxed};

/// Bound on |`atan2_cheap` − `atan2_upper`| in radians (see the module docs).
pub(super) const ATAN_ERROR: f64 = 1e-7;

/// Odd polynomial p(r) = r · Σ `C[k]` r²ᵏ ≈ atan(r) on [0, 1], error < 3.9e-8.
const C: [f64; 8] = [
    0.999_999_336_427_165_9,
    -0.333_298_646_243_033_8,
    0.199_466_141_409_094_05,
    -0.139_088_928_501_950_34,
    0.096_429_176_762_254_75,
    -0.055_922_728_800_599_75,
    0.021_870_518_948_394_518,
    -0.004_056_744_789_545_505_5,
];

/// atan2(y, x) in [0, π] for y ≥ 0 (as `geometry::atan2_upper`), within [`ATAN_ERROR`] of
/// it: one division and eight multiply-adds, no branch. O(1).
#[cfg(test)]
pub(super) fn atan2_cheap(y: f64, x: f64) -> f64 {
    atan2_cheap2([y, 0.0], [x, 1.0])[0]
}

/// `atan2_cheap` of two pairs at once, lane by lane (written so the compiler can pack the
/// lanes into one vector register: one division for both). O(1).
#[inline(always)]
pub(super) fn atan2_cheap2(y: [f64; 2], x: [f64; 2]) -> [f64; 2] {
    let ax = x.map(f64::abs);
    let swapped = [y[0] > ax[0], y[1] > ax[1]];
    let lo = [ax[0].min(y[0]), ax[1].min(y[1])];
    let hi = [ax[0].max(y[0]), ax[1].max(y[1])];
    // hi = 0 only when both are 0: atan2_upper gives 0 or π there, the sign test below too.
    let r = [
        if hi[0] > 0.0 { lo[0] / hi[0] } else { 0.0 },
        if hi[1] > 0.0 { lo[1] / hi[1] } else { 0.0 },
    ];
    let z = [r[0] * r[0], r[1] * r[1]];
    let mut p = [C[7]; 2];
    for c in C[..7].iter().rev() {
        p = [p[0] * z[0] + c, p[1] * z[1] + c];
    }
    let mut out = [0.0; 2];
    for k in 0..2 {
        let a = r[k] * p[k];
        let a = if swapped[k] { FRAC_PI_2 - a } else { a };
        out[k] = if x[k] < 0.0 || (hi[k] == 0.0 && x[k].is_sign_negative()) {
            PI - a
        } else {
            a
        };
    }
    out
}

static ENABLED: AtomicBool = AtomicBool::new(true);
static DECISIONS: AtomicU64 = AtomicU64::new(0);
static FALLBACKS: AtomicU64 = AtomicU64::new(0);

/// What the filtered walk did since the counters were last reset (process-wide, all
/// threads).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct FilterCounts {
    /// Greedy decisions (both steps possible) the filtered walk took.
    pub decisions: u64,
    /// Of those, how many needed both steps exactly (the bounds overlapped, or the
    /// cheaper step's turn made the other's exact cost matter): the fallback rate is
    /// `fallbacks / decisions`.
    pub fallbacks: u64,
}

/// Turns the filtered walk on (the default) or off, process-wide; off, look-ahead with α = 1
/// evaluates every step exactly, as before the filter. The paths and costs are the same
/// either way; for benchmarks that time both in one process. O(1).
pub fn set_strip_filter(on: bool) {
    ENABLED.store(on, Relaxed);
}

/// Whether the filtered walk is on ([`set_strip_filter`]). O(1).
pub(super) fn enabled() -> bool {
    ENABLED.load(Relaxed)
}

/// The counters since the last reset; with `reset`, sets them to zero. O(1).
pub fn strip_filter_counts(reset: bool) -> FilterCounts {
    let take = |c: &AtomicU64| {
        if reset {
            c.swap(0, Relaxed)
        } else {
            c.load(Relaxed)
        }
    };
    FilterCounts {
        decisions: take(&DECISIONS),
        fallbacks: take(&FALLBACKS),
    }
}

/// Adds one strip's `counts` to the process-wide counters. O(1).
pub(super) fn record(counts: FilterCounts) {
    if counts.decisions > 0 {
        DECISIONS.fetch_add(counts.decisions, Relaxed);
        FALLBACKS.fetch_add(counts.fallbacks, Relaxed);
    }
}

/// Bounds [lo, hi] on the exact costs of the steps A and B with `parts` (doubled areas
/// `areas`): the cost at the cheap smallest angle ∓ [`ATAN_ERROR`] (see the module docs).
/// O(1).
#[inline(always)]
fn cost_bounds(t: &Terms, parts: &[Parts; 2], areas: [f64; 2]) -> [[f64; 2]; 2] {
    let dot = |k: usize| smallest_angle_dot(parts[k].sides, parts[k].dots);
    let theta = atan2_cheap2(areas, [dot(0), dot(1)]);
    let cost = |k: usize, theta: f64| t.cost_at(parts[k].len, areas[k], theta);
    [0, 1].map(|k| {
        [
            cost(k, theta[k] + ATAN_ERROR),
            cost(k, theta[k] - ATAN_ERROR),
        ]
    })
}

/// Lower bound on the exact turn from `entered` to the step with `parts` (0 without a
/// previous step or dihedral weight, π × the weight at a degenerate triangle, as
/// `Terms::turn`), from the cheap dihedral angle − [`ATAN_ERROR`]. O(1).
#[inline(always)]
fn turn_lower_bound(t: &Terms, parts: &Parts, entered: &Option<Tri>) -> f64 {
    match entered {
        Some(e) if t.w.dihedral != 0.0 => {
            let n2 = parts.cross;
            if e.normal == glam::DVec3::ZERO || n2 == glam::DVec3::ZERO {
                t.w.dihedral * PI
            } else {
                let y = e.apex.dot(n2).abs() * e.len;
                let phi = atan2_cheap2([y, 0.0], [e.normal.dot(n2), 1.0])[0];
                t.w.dihedral * (phi - ATAN_ERROR)
            }
        }
        _ => 0.0,
    }
}

/// The greedy step out of (i, j) after `entered`, as `lookahead`'s `exact_choice` takes
/// it from the two exact steps (`exact`), with its exact [`Tri`] and the cost it adds;
/// the step the bounds prove the other cannot beat is the only one evaluated exactly.
/// Counts the decision, and a fallback when both had to be. O(1).
#[inline]
pub(super) fn filtered_choice(
    t: &Terms,
    i: usize,
    j: usize,
    entered: &Option<Tri>,
    counts: &mut FilterCounts,
    exact: impl Fn(Tri, Tri) -> (Step, Tri, f64),
) -> (Step, Tri, f64) {
    counts.decisions += 1;
    let parts = [t.parts(i, j, Step::A), t.parts(i, j, Step::B)];
    let areas = parts.map(|p| p.cross.length());
    let bounds = cost_bounds(t, &parts, areas);
    let exact_step = |k: usize| t.triangle_with_area(&parts[k], areas[k]);
    // The exact rule takes the cheaper step c (A on ties) when its cost with its turn is
    // at most the other's with its turn (strictly below when c is B); the bounds decide
    // which is cheaper and stand in for the other's cost, then its cost and turn, from
    // below. `c` is certainly the cheaper when its upper end is at most (for B: below)
    // the other's lower end.
    let cheaper = if bounds[0][1] <= bounds[1][0] {
        Some(0)
    } else if bounds[1][1] < bounds[0][0] {
        Some(1)
    } else {
        None
    };
    if let Some(c) = cheaper {
        let o = 1 - c;
        let step = exact_step(c);
        let via = with_turn(t, step, entered);
        let wins = |other_lo: f64| {
            if c == 0 {
                via <= other_lo
            } else {
                via < other_lo
            }
        };
        if wins(bounds[o][0]) || wins(bounds[o][0] + turn_lower_bound(t, &parts[o], entered)) {
            let s = if c == 0 { Step::A } else { Step::B };
            return (s, step, via);
        }
        counts.fallbacks += 1;
        let other = exact_step(o);
        return if c == 0 {
            exact(step, other)
        } else {
            exact(other, step)
        };
    }
    counts.fallbacks += 1;
    exact(exact_step(0), exact_step(1))
}
