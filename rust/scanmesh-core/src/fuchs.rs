//! The Fuchs matrix between two scan lines: weights, α-look-ahead and shortest paths.
//!
//! For lines a_0..a_{n-1} and b_0..b_{m-1}, node (i, j) stands for the mesh edge a_i–b_j.
//! A monotone path from (0, 0) to (n-1, m-1) is a strip triangulation: the step
//! [`Step::A`] (i, j)→(i+1, j) adds triangle (a_i, a_{i+1}, b_j) and the step [`Step::B`]
//! (i, j)→(i, j+1) adds triangle (a_i, b_{j+1}, b_j). Every path has n + m − 2 steps and
//! there are C(n+m−2, n−1) paths.
//!
//! Triangles are written so that they are counter-clockwise, seen from the side their
//! normals point to, when line b lies to the **left** of line a's direction: the strip
//! orientation is the caller's business (see `strips`), the relative orientation of its
//! triangles is fixed here, which is what the dihedral weight needs.
//!
//! The cost of a path is a weighted sum of four criteria (see [`Weight`]): node weights
//! (edge length), step weights (area, smallest angle) and weights on pairs of consecutive
//! steps (dihedral angle). All are non-negative, which Dijkstra needs and which makes every
//! look-ahead path cost at least the optimum.

use crate::geometry::check_finite;
use crate::{Error, Result};
use glam::DVec3;
use std::cmp::Ordering;
use std::collections::BinaryHeap;
use std::f64::consts::{FRAC_PI_3, PI};

/// One step of a path through the Fuchs matrix.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Step {
    /// (i, j)→(i+1, j): advance on line a, adding triangle (a_i, a_{i+1}, b_j).
    A,
    /// (i, j)→(i, j+1): advance on line b, adding triangle (a_i, b_{j+1}, b_j).
    B,
}

/// Coefficients of the four path criteria; the cost of a path is their weighted sum.
///
/// - `length`: on every node (i, j) of the path, including both ends, the 3-D length
///   |a_i − b_j| of the mesh edge it stands for (input units). Minimizing it with α = 1 is
///   the greedy shortest-diagonal rule.
/// - `area`: on every step, the 3-D area of the triangle it adds (squared input units);
///   the sum is the strip's surface area, the criterion of Fuchs, Kedem and Uselton (1977).
/// - `angle`: on every step, π/3 − (smallest 3-D angle of the triangle it adds), in
///   radians: 0 for an equilateral triangle, π/3 for a degenerate one. A strip always has
///   n + m − 2 triangles, so this maximizes the sum of the smallest angles.
/// - `dihedral`: on every pair of consecutive steps, the angle in [0, π] between the
///   normals of their two triangles, which share the edge of the node between the steps
///   (radians; `atan2(|n1 × n2|, n1 · n2)`); a degenerate triangle counts as a full fold
///   (π). This is smoothness inside the strip; it needs the previous step's direction in
///   the search state, which doubles the states.
///
/// Each coefficient must be finite and ≥ 0, and at least one positive. Mixing criteria of
/// different units is the caller's choice of scale (`strips` measures lengths in median
/// point steps so that mixtures are scale-free).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Weight {
    /// Coefficient of the edge length (per node).
    pub length: f64,
    /// Coefficient of the triangle area (per step).
    pub area: f64,
    /// Coefficient of the smallest-angle penalty π/3 − min angle (per step).
    pub angle: f64,
    /// Coefficient of the dihedral angle between consecutive triangles (per pair of steps).
    pub dihedral: f64,
}

impl Weight {
    /// Only the edge length.
    pub const LENGTH: Weight = Weight {
        length: 1.0,
        area: 0.0,
        angle: 0.0,
        dihedral: 0.0,
    };
    /// Only the triangle area (Fuchs et al.).
    pub const AREA: Weight = Weight {
        length: 0.0,
        area: 1.0,
        angle: 0.0,
        dihedral: 0.0,
    };
    /// Only the smallest-angle penalty.
    pub const ANGLE: Weight = Weight {
        length: 0.0,
        area: 0.0,
        angle: 1.0,
        dihedral: 0.0,
    };
    /// Only the dihedral angle.
    pub const DIHEDRAL: Weight = Weight {
        length: 0.0,
        area: 0.0,
        angle: 0.0,
        dihedral: 1.0,
    };

    /// The named single-criterion weight: "length", "area", "angle" or "dihedral". O(1).
    pub fn by_name(name: &str) -> Option<Weight> {
        match name {
            "length" => Some(Weight::LENGTH),
            "area" => Some(Weight::AREA),
            "angle" => Some(Weight::ANGLE),
            "dihedral" => Some(Weight::DIHEDRAL),
            _ => None,
        }
    }

    /// Checks that every coefficient is finite and ≥ 0 and one is positive. O(1).
    pub fn check(&self) -> Result<()> {
        let all = [self.length, self.area, self.angle, self.dihedral];
        if all.iter().any(|c| !(c.is_finite() && *c >= 0.0)) || all.iter().all(|&c| c == 0.0) {
            return Err(Error::InvalidParameter {
                name: "weight",
                value: format!("{self:?}"),
                expected: "finite non-negative coefficients, at least one positive",
            });
        }
        Ok(())
    }
}

/// A path and its cost.
#[derive(Debug, Clone, PartialEq)]
pub struct Solution {
    /// The n + m − 2 steps from (0, 0) to (n−1, m−1).
    pub path: Vec<Step>,
    /// Its cost under the weight it was found with (see [`path_cost`]).
    pub cost: f64,
}

/// How to find the cheapest path.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Solver {
    /// Dynamic programming over the whole matrix ([`shortest_path_dp`]).
    Dp,
    /// Dijkstra with a binary heap, as the seed paper ([`shortest_path_dijkstra`]).
    Dijkstra,
    /// Dynamic programming in a widening band ([`shortest_path_banded`]) with this initial
    /// half width (in matrix columns).
    Banded(usize),
}

/// Default initial w of [`shortest_path_banded`] (the DP band is twice as wide): optimal
/// strips between scan lines of similar spacing stray one or two columns from the diagonal.
/// Measured on a 1M-point rod scan: 8.9 band cells per point with w = 2, 13.9 with w = 1
/// (more widening rounds), 16.8 with w = 4.
pub const DEFAULT_BAND: usize = 2;

/// The cheapest path by `solver`. See the solver functions for complexity. Errors: an empty
/// line, a non-finite coordinate, a bad weight or a zero band width.
pub fn shortest_path(a: &[DVec3], b: &[DVec3], w: Weight, solver: Solver) -> Result<Solution> {
    match solver {
        Solver::Dp => shortest_path_dp(a, b, w),
        Solver::Dijkstra => shortest_path_dijkstra(a, b, w),
        Solver::Banded(width) => shortest_path_banded(a, b, w, width),
    }
}

/// Per-criterion terms of one strip; every search below evaluates costs through it.
struct Terms<'a> {
    a: &'a [DVec3],
    b: &'a [DVec3],
    w: Weight,
}

/// Dihedral angle (radians, [0, π]) between two normals of any length; π when one is zero
/// (a degenerate triangle). O(1).
#[inline]
fn dihedral(n1: DVec3, n2: DVec3) -> f64 {
    if n1 == DVec3::ZERO || n2 == DVec3::ZERO {
        return PI;
    }
    atan2_upper(n1.cross(n2).length(), n1.dot(n2))
}

/// `y.atan2(x)` for y ≥ 0 (a result in [0, π]), to within a few units in the last place.
///
/// Why not libm: its atan2 was half the run time of strips under the angle and dihedral
/// weights (up to six calls per matrix cell). This is Cephes' `atan` (Moshier): one
/// reduction to |t| ≤ 0.66 and a degree 4/5 rational function; tested within 4 ulp of
/// libm over 40 decades, and twice as fast (10M calls: 95 ms against 190 ms). O(1).
#[inline]
fn atan2_upper(y: f64, x: f64) -> f64 {
    use std::f64::consts::{FRAC_PI_2, FRAC_PI_4};
    const MOREBITS: f64 = 6.123_233_995_736_766e-17;
    const P: [f64; 5] = [
        -8.750_608_600_031_904e-1,
        -1.615_753_718_733_365e1,
        -7.500_855_792_314_705e1,
        -1.228_866_684_490_136e2,
        -6.485_021_904_942_025e1,
    ];
    const Q: [f64; 5] = [
        2.485_846_490_142_306e1,
        1.650_270_098_316_988e2,
        4.328_810_604_912_903e2,
        4.853_903_996_359_137e2,
        1.945_506_571_482_614e2,
    ];
    let ax = x.abs();
    if y == 0.0 && ax == 0.0 {
        return if x.is_sign_negative() { PI } else { 0.0 };
    }
    // t = min/max in [0, 1]; atan2 = atan(t), or π/2 − atan(t) when y > |x|.
    let (t, swapped) = if y <= ax {
        (y / ax, false)
    } else {
        (ax / y, true)
    };
    let (base, u, more) = if t <= 0.66 {
        (0.0, t, 0.0)
    } else {
        (FRAC_PI_4, (t - 1.0) / (t + 1.0), 0.5 * MOREBITS)
    };
    let z = u * u;
    let p = (((P[0] * z + P[1]) * z + P[2]) * z + P[3]) * z + P[4];
    let q = ((((z + Q[0]) * z + Q[1]) * z + Q[2]) * z + Q[3]) * z + Q[4];
    let mut a = base + (u + u * z * p / q + more);
    if swapped {
        a = FRAC_PI_2 - a;
    }
    if x < 0.0 {
        a = PI - a;
    }
    a
}

impl<'a> Terms<'a> {
    fn new(a: &'a [DVec3], b: &'a [DVec3], w: Weight) -> Result<Self> {
        w.check()?;
        for (name, line) in [("a", a), ("b", b)] {
            if line.is_empty() {
                return Err(Error::InvalidParameter {
                    name: "line",
                    value: format!("{name} with 0 points"),
                    expected: "at least one point on each line",
                });
            }
            check_finite(line)?;
        }
        Ok(Terms { a, b, w })
    }

    fn n(&self) -> usize {
        self.a.len()
    }

    fn m(&self) -> usize {
        self.b.len()
    }

    /// Weight of node (i, j). O(1).
    #[inline]
    fn node(&self, i: usize, j: usize) -> f64 {
        if self.w.length == 0.0 {
            0.0
        } else {
            self.w.length * (self.a[i] - self.b[j]).length()
        }
    }

    /// Cost of the step `s` leaving (i, j), including the weight of the node it enters,
    /// and a normal of its triangle, of any length (zero when degenerate or not needed). O(1).
    #[inline]
    fn step(&self, i: usize, j: usize, s: Step) -> (f64, DVec3) {
        let (p, q, r, target) = match s {
            Step::A => (self.a[i], self.a[i + 1], self.b[j], (i + 1, j)),
            Step::B => (self.a[i], self.b[j + 1], self.b[j], (i, j + 1)),
        };
        let mut cost = self.node(target.0, target.1);
        if self.w.area == 0.0 && self.w.angle == 0.0 && self.w.dihedral == 0.0 {
            // The length weight alone needs no triangle (the hot path of `Weight::LENGTH`).
            return (cost, DVec3::ZERO);
        }
        let c = (q - p).cross(r - p);
        let twice_area = c.length();
        if self.w.area != 0.0 {
            cost += self.w.area * 0.5 * twice_area;
        }
        if self.w.angle != 0.0 {
            cost += self.w.angle * (FRAC_PI_3 - smallest_angle(p, q, r, twice_area));
        }
        // The dihedral angle is scale-free: the cross product serves as the normal unscaled.
        let normal = if self.w.dihedral != 0.0 {
            c
        } else {
            DVec3::ZERO
        };
        (cost, normal)
    }

    /// Cost of the turn between consecutive triangles with normals `n1`, `n2`. O(1).
    #[inline]
    fn turn(&self, n1: DVec3, n2: DVec3) -> f64 {
        if self.w.dihedral == 0.0 {
            0.0
        } else {
            self.w.dihedral * dihedral(n1, n2)
        }
    }
}

/// Smallest corner angle of (p, q, r) given twice its area: the angle opposite the shortest
/// side (law of sines), by one atan2 instead of three. O(1).
#[inline]
fn smallest_angle(p: DVec3, q: DVec3, r: DVec3, twice_area: f64) -> f64 {
    let (pq, qr, rp) = (
        (q - p).length_squared(),
        (r - q).length_squared(),
        (p - r).length_squared(),
    );
    // The corner opposite the shortest side and its two sides.
    let (corner, x, y) = if pq <= qr && pq <= rp {
        (r, p, q)
    } else if qr <= rp {
        (p, q, r)
    } else {
        (q, r, p)
    };
    atan2_upper(twice_area, (x - corner).dot(y - corner))
}

/// Cost of `path` between lines `a` and `b` under `w`, evaluated step by step: node weights
/// of all n + m − 1 nodes, step weights of all triangles, turn weights of all consecutive
/// pairs. Errors: a path that does not end at (n−1, m−1), or bad input. O(n + m).
pub fn path_cost(a: &[DVec3], b: &[DVec3], w: Weight, path: &[Step]) -> Result<f64> {
    let t = Terms::new(a, b, w)?;
    check_path(t.n(), t.m(), path)?;
    let (mut i, mut j) = (0, 0);
    let mut cost = t.node(0, 0);
    let mut previous: Option<DVec3> = None;
    for &s in path {
        let (c, normal) = t.step(i, j, s);
        cost += c + previous.map_or(0.0, |p| t.turn(p, normal));
        previous = Some(normal);
        match s {
            Step::A => i += 1,
            Step::B => j += 1,
        }
    }
    Ok(cost)
}

/// Checks that `path` has n − 1 A-steps and m − 1 B-steps. O(n + m).
fn check_path(n: usize, m: usize, path: &[Step]) -> Result<()> {
    let n_a = path.iter().filter(|&&s| s == Step::A).count();
    let n_b = path.len() - n_a;
    if n_a + 1 != n || n_b + 1 != m {
        return Err(Error::InvalidParameter {
            name: "path",
            value: format!("{n_a} A-steps and {n_b} B-steps"),
            expected: "n − 1 A-steps and m − 1 B-steps",
        });
    }
    Ok(())
}

/// The triangles of `path`, in the caller's point indices: `a_ids[i]` is a_i, `b_ids[j]` is
/// b_j. Step A at (i, j) gives (a_i, a_{i+1}, b_j), step B gives (a_i, b_{j+1}, b_j).
/// Errors: a path that does not fit the two index lists. O(n + m).
pub fn path_triangles(path: &[Step], a_ids: &[u32], b_ids: &[u32]) -> Result<Vec<[u32; 3]>> {
    check_path(a_ids.len(), b_ids.len(), path)?;
    let (mut i, mut j) = (0, 0);
    let mut out = Vec::with_capacity(path.len());
    for &s in path {
        match s {
            Step::A => {
                out.push([a_ids[i], a_ids[i + 1], b_ids[j]]);
                i += 1;
            }
            Step::B => {
                out.push([a_ids[i], b_ids[j + 1], b_ids[j]]);
                j += 1;
            }
        }
    }
    Ok(out)
}

/// The cheapest path by dynamic programming over the whole matrix (a DAG).
///
/// State: node and the direction of the step that entered it (for the dihedral weight).
/// Time O(nm), memory O(nm) bytes of back-pointers plus O(m) costs.
pub fn shortest_path_dp(a: &[DVec3], b: &[DVec3], w: Weight) -> Result<Solution> {
    let t = Terms::new(a, b, w)?;
    let lo = vec![0; t.n()];
    let hi = vec![t.m() - 1; t.n()];
    Ok(dp_in_band(&t, &lo, &hi))
}

/// Cost and normal of the triangle entering a cell, per entering direction (A = 0, B = 1).
#[derive(Clone, Copy)]
struct Cell {
    cost: [f64; 2],
    normal: [DVec3; 2],
}

const UNREACHED: Cell = Cell {
    cost: [f64::INFINITY; 2],
    normal: [DVec3::ZERO; 2],
};

/// The best way into a cell from predecessor `p` by a step whose triangle has `normal`:
/// (cost before the step, entering direction at `p`: 0 = A, 1 = B). At the start cell
/// there is no previous triangle, so no turn.
#[inline]
fn best_from(t: &Terms, p: &Cell, normal: DVec3, at_start: bool, start_cost: f64) -> (f64, u8) {
    if at_start {
        return (start_cost, 0);
    }
    // Turns cost atan2s, the hot spot: when the cheaper state plus its turn is still below
    // the other state before any turn, the other turn cannot win (turns are ≥ 0).
    let (cheaper, other) = if p.cost[1] < p.cost[0] {
        (1, 0)
    } else {
        (0, 1)
    };
    let via_cheaper = p.cost[cheaper] + t.turn(p.normal[cheaper], normal);
    if p.cost[other] > via_cheaper {
        return (via_cheaper, cheaper as u8);
    }
    let via_other = p.cost[other] + t.turn(p.normal[other], normal);
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

/// DP restricted to row bands `lo[i]..=hi[i]` (nondecreasing, overlapping consecutive rows,
/// lo[0] = 0, hi[n−1] = m−1). O(Σ band widths) time and back-pointer bytes.
fn dp_in_band(t: &Terms, lo: &[usize], hi: &[usize]) -> Solution {
    let (n, m) = (t.n(), t.m());
    let start_cost = t.node(0, 0);
    if n == 1 && m == 1 {
        return Solution {
            path: Vec::new(),
            cost: start_cost,
        };
    }
    // Row offsets into the flat back-pointer array: bit 0 = direction at the predecessor
    // for entering by A, bit 1 = the same for entering by B.
    let mut offset = Vec::with_capacity(n + 1);
    offset.push(0usize);
    for i in 0..n {
        offset.push(offset[i] + hi[i] + 1 - lo[i]);
    }
    let mut back = vec![0u8; offset[n]];
    let width = (0..n).map(|i| hi[i] + 1 - lo[i]).max().unwrap_or(1);
    let mut prev = vec![UNREACHED; width];
    let mut cur = vec![UNREACHED; width];
    for i in 0..n {
        for j in lo[i]..=hi[i] {
            let mut cell = UNREACHED;
            let mut bits = 0u8;
            if i > 0 && j >= lo[i - 1] && j <= hi[i - 1] {
                let (c, normal) = t.step(i - 1, j, Step::A);
                let (before, from) = best_from(
                    t,
                    &prev[j - lo[i - 1]],
                    normal,
                    i == 1 && j == 0,
                    start_cost,
                );
                cell.cost[0] = before + c;
                cell.normal[0] = normal;
                bits |= from;
            }
            if j > lo[i] {
                let (c, normal) = t.step(i, j - 1, Step::B);
                let (before, from) =
                    best_from(t, &cur[j - 1 - lo[i]], normal, i == 0 && j == 1, start_cost);
                cell.cost[1] = before + c;
                cell.normal[1] = normal;
                bits |= from << 1;
            }
            cur[j - lo[i]] = cell;
            back[offset[i] + j - lo[i]] = bits;
        }
        std::mem::swap(&mut prev, &mut cur);
    }
    let last = prev[m - 1 - lo[n - 1]];
    let mut dir = if last.cost[0] <= last.cost[1] { 0u8 } else { 1 };
    let cost = last.cost[dir as usize];
    let mut path = Vec::with_capacity(n + m - 2);
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
    }
    path.reverse();
    Solution { path, cost }
}

/// A heap entry ordered by ascending cost (BinaryHeap is a max-heap).
#[derive(PartialEq)]
struct Queued {
    cost: f64,
    state: usize,
}

impl Eq for Queued {}

impl Ord for Queued {
    fn cmp(&self, other: &Self) -> Ordering {
        other
            .cost
            .total_cmp(&self.cost)
            .then_with(|| other.state.cmp(&self.state))
    }
}

impl PartialOrd for Queued {
    fn partial_cmp(&self, other: &Self) -> Option<Ordering> {
        Some(self.cmp(other))
    }
}

/// The cheapest path by Dijkstra's algorithm with a binary heap, as in the seed paper.
///
/// Graph: states (i, j, direction of the entering step), 2nm of them, each with at most
/// two outgoing edges; all edge costs are non-negative. Time O(nm log(nm)), memory O(nm).
/// Kept as the reference the DP is tested against; the DP is faster on the same DAG.
pub fn shortest_path_dijkstra(a: &[DVec3], b: &[DVec3], w: Weight) -> Result<Solution> {
    let t = Terms::new(a, b, w)?;
    let (n, m) = (t.n(), t.m());
    let start_cost = t.node(0, 0);
    if n == 1 && m == 1 {
        return Ok(Solution {
            path: Vec::new(),
            cost: start_cost,
        });
    }
    // State index (i * m + j) * 2 + d; d = 0 entered by A, 1 by B.
    let mut dist = vec![f64::INFINITY; 2 * n * m];
    let mut pred = vec![usize::MAX; 2 * n * m];
    let mut done = vec![false; 2 * n * m];
    let mut heap = BinaryHeap::new();
    let relax = |heap: &mut BinaryHeap<Queued>,
                 dist: &mut [f64],
                 pred: &mut [usize],
                 from,
                 i,
                 j,
                 s,
                 before: f64,
                 previous: Option<DVec3>| {
        let (c, normal) = t.step(i, j, s);
        let cost = before + c + previous.map_or(0.0, |p| t.turn(p, normal));
        let (ti, tj, d) = match s {
            Step::A => (i + 1, j, 0),
            Step::B => (i, j + 1, 1),
        };
        let to = (ti * m + tj) * 2 + d;
        if cost < dist[to] {
            dist[to] = cost;
            pred[to] = from;
            heap.push(Queued { cost, state: to });
        }
    };
    // The start has no entering triangle; its successors are relaxed directly.
    const START: usize = usize::MAX - 1;
    if n > 1 {
        relax(
            &mut heap,
            &mut dist,
            &mut pred,
            START,
            0,
            0,
            Step::A,
            start_cost,
            None,
        );
    }
    if m > 1 {
        relax(
            &mut heap,
            &mut dist,
            &mut pred,
            START,
            0,
            0,
            Step::B,
            start_cost,
            None,
        );
    }
    let goal = ((n - 1) * m + m - 1) * 2;
    while let Some(Queued { cost, state }) = heap.pop() {
        if done[state] {
            continue;
        }
        done[state] = true;
        if state == goal || state == goal + 1 {
            break;
        }
        let (i, j, d) = (state / 2 / m, state / 2 % m, state % 2);
        // Normal of the triangle that entered (i, j), recomputed: the reference favours
        // clarity over speed.
        let entered = if d == 0 {
            t.step(i - 1, j, Step::A).1
        } else {
            t.step(i, j - 1, Step::B).1
        };
        if i + 1 < n {
            relax(
                &mut heap,
                &mut dist,
                &mut pred,
                state,
                i,
                j,
                Step::A,
                cost,
                Some(entered),
            );
        }
        if j + 1 < m {
            relax(
                &mut heap,
                &mut dist,
                &mut pred,
                state,
                i,
                j,
                Step::B,
                cost,
                Some(entered),
            );
        }
    }
    let mut state = if dist[goal] <= dist[goal + 1] {
        goal
    } else {
        goal + 1
    };
    let cost = dist[state];
    let mut path = Vec::with_capacity(n + m - 2);
    while state != START {
        path.push(if state % 2 == 0 { Step::A } else { Step::B });
        state = pred[state];
    }
    path.reverse();
    Ok(Solution { path, cost })
}

/// The cheapest path by DP inside a band around the diagonal, widened until the path keeps
/// well inside it.
///
/// The diagonal c(i) is the j of the b point nearest a_i along the strip's direction (so
/// lines of unequal extent, length or spacing get a diagonal that follows them). The DP
/// runs in the band of half width 2w around it (initially w = `half_width`); its path is
/// accepted when it keeps strictly inside the inner band of half width w (apart from edges
/// of the matrix), and otherwise w doubles and the DP repeats; at the latest the band
/// becomes the whole matrix. An accepted path is optimal among all paths within 2w, and
/// the best path within w is the same.
///
/// Exactness: the result is the optimum whenever the optimum lies inside the final band.
/// No band rule can prove that for arbitrary non-negative weights (a path inside a band is
/// optimal only among paths inside it: a cheap detour far outside stays unseen, and on a
/// near-planar strip the area weight makes most paths almost tie). Measured on 300 noisy
/// scan-line strips of 5–125 points and every weight, a rule that accepted any path off
/// the edges of its band missed 10 of 1,500 optima (area, dihedral); with the factor-2
/// margin, none. On random points (no diagonal at all), 1 of 6,400. Tests compare it with
/// the full DP on scan-like strips and on real scans.
///
/// Time O((n + m) · w) and memory O(n · w) bytes for the final w (each round doubles the
/// width, so all rounds together cost less than twice the last). Errors as
/// [`shortest_path`], and `half_width` = 0.
pub fn shortest_path_banded(
    a: &[DVec3],
    b: &[DVec3],
    w: Weight,
    half_width: usize,
) -> Result<Solution> {
    let t = Terms::new(a, b, w)?;
    if half_width == 0 {
        return Err(Error::InvalidParameter {
            name: "half_width",
            value: "0".into(),
            expected: "a band half width of at least 1 column",
        });
    }
    let (n, m) = (t.n(), t.m());
    let center = diagonal(a, b);
    // Rows of the band of half width `w` around the diagonal, made passable.
    let band = |w: usize| -> (Vec<usize>, Vec<usize>) {
        let mut lo: Vec<usize> = center.iter().map(|&c| c.saturating_sub(w)).collect();
        let mut hi: Vec<usize> = center.iter().map(|&c| (c + w).min(m - 1)).collect();
        lo[0] = 0;
        hi[n - 1] = m - 1;
        // Consecutive rows must share a column for a path to step down.
        for i in (0..n - 1).rev() {
            hi[i] = hi[i].max(lo[i + 1]).min(hi[i + 1]);
        }
        (lo, hi)
    };
    let mut width = half_width;
    loop {
        let (lo, hi) = band(2 * width);
        let solution = dp_in_band(&t, &lo, &hi);
        let full = lo.iter().all(|&x| x == 0) && hi.iter().all(|&x| x == m - 1);
        let (inner_lo, inner_hi) = band(width);
        if full || !leaves_band(&solution.path, &inner_lo, &inner_hi, m) {
            return Ok(solution);
        }
        width *= 2;
    }
}

/// For each i, the index j of the b point nearest a_i along the strip's direction: the
/// projections onto d = (a_{n−1} − a_0) + (b_{m−1} − b_0) are matched by a merge walk. This
/// follows lines of unequal extent, spacing and point count; when d vanishes (closed or
/// coincident lines) normalized arc length stands in. O(n + m).
fn diagonal(a: &[DVec3], b: &[DVec3]) -> Vec<usize> {
    let d = (a[a.len() - 1] - a[0]) + (b[b.len() - 1] - b[0]);
    let (ta, tb): (Vec<f64>, Vec<f64>) = if d.length_squared() > 0.0 {
        (
            a.iter().map(|p| p.dot(d)).collect(),
            b.iter().map(|p| p.dot(d)).collect(),
        )
    } else {
        (arc_length_fractions(a), arc_length_fractions(b))
    };
    let mut j = 0;
    ta.iter()
        .map(|&x| {
            while j + 1 < tb.len() && (tb[j + 1] - x).abs() <= (tb[j] - x).abs() {
                j += 1;
            }
            j
        })
        .collect()
}

/// Cumulative 3-D arc length of a line divided by its total (index fractions when the
/// points coincide). O(n).
fn arc_length_fractions(line: &[DVec3]) -> Vec<f64> {
    let mut s = Vec::with_capacity(line.len());
    let mut total = 0.0;
    s.push(0.0);
    for k in 1..line.len() {
        total += (line[k] - line[k - 1]).length();
        s.push(total);
    }
    let count = (line.len().max(2) - 1) as f64;
    s.iter()
        .enumerate()
        .map(|(k, &x)| {
            if total > 0.0 {
                x / total
            } else {
                k as f64 / count
            }
        })
        .collect()
}

/// True when a node of `path` lies on or beyond an edge of the band that is not an edge of
/// the matrix. O(n + m).
fn leaves_band(path: &[Step], lo: &[usize], hi: &[usize], m: usize) -> bool {
    let out = |i: usize, j: usize| (j <= lo[i] && lo[i] > 0) || (j >= hi[i] && hi[i] < m - 1);
    let (mut i, mut j) = (0, 0);
    if out(0, 0) {
        return true;
    }
    for &s in path {
        match s {
            Step::A => i += 1,
            Step::B => j += 1,
        }
        if out(i, j) {
            return true;
        }
    }
    false
}

/// Reusable buffers of the look-ahead window, so the walk allocates only when a window
/// grows past every earlier one.
struct Window {
    cells: Vec<Cell>,
}

impl Window {
    /// The cost of the cheapest path of k = min(α, steps left) steps from (i, j) whose first
    /// step is `first`, given the normal of the triangle that entered (i, j). O(min(α, n) ·
    /// min(α, m)).
    fn best(
        &mut self,
        t: &Terms,
        i: usize,
        j: usize,
        entered: Option<DVec3>,
        first: Step,
        alpha: usize,
    ) -> f64 {
        let (n, m) = (t.n(), t.m());
        let k = alpha.min(n - 1 - i + m - 1 - j);
        let (rows, cols) = (k.min(n - 1 - i) + 1, k.min(m - 1 - j) + 1);
        self.cells.clear();
        self.cells.resize(rows * cols, UNREACHED);
        let cells = &mut self.cells;
        let (c, normal) = t.step(i, j, first);
        let at = |p: usize, q: usize| p * cols + q;
        let d = match first {
            Step::A => 0,
            Step::B => 1,
        };
        let first_cell = if d == 0 { at(1, 0) } else { at(0, 1) };
        cells[first_cell].cost[d] = c + entered.map_or(0.0, |e| t.turn(e, normal));
        cells[first_cell].normal[d] = normal;
        let mut best = f64::INFINITY;
        for p in 0..rows {
            for q in 0..cols.min(k + 1 - p) {
                if p + q >= 2 {
                    let mut cell = UNREACHED;
                    if p > 0 {
                        let (c, normal) = t.step(i + p - 1, j + q, Step::A);
                        let (before, _) = best_from(t, &cells[at(p - 1, q)], normal, false, 0.0);
                        cell.cost[0] = before + c;
                        cell.normal[0] = normal;
                    }
                    if q > 0 {
                        let (c, normal) = t.step(i + p, j + q - 1, Step::B);
                        let (before, _) = best_from(t, &cells[at(p, q - 1)], normal, false, 0.0);
                        cell.cost[1] = before + c;
                        cell.normal[1] = normal;
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
/// O((n + m) · min(α, n) · min(α, m)): O(n + m) for fixed α, O((n + m) · n · m) for
/// α ≥ n + m (where the walk follows an optimal path, since each window then reaches the
/// end). Memory O(min(α, n) · min(α, m)). Errors: α = 0, and those of [`shortest_path`].
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
    let mut window = Window { cells: Vec::new() };
    let mut path = Vec::with_capacity(n + m - 2);
    let (mut i, mut j) = (0, 0);
    let mut entered: Option<DVec3> = None;
    let mut cost = t.node(0, 0);
    while i + 1 < n || j + 1 < m {
        let s = if i + 1 == n {
            Step::B
        } else if j + 1 == m {
            Step::A
        } else {
            let via_a = window.best(&t, i, j, entered, Step::A, alpha);
            let via_b = window.best(&t, i, j, entered, Step::B, alpha);
            if via_a <= via_b {
                Step::A
            } else {
                Step::B
            }
        };
        let (c, normal) = t.step(i, j, s);
        cost += c + entered.map_or(0.0, |e| t.turn(e, normal));
        entered = Some(normal);
        path.push(s);
        match s {
            Step::A => i += 1,
            Step::B => j += 1,
        }
    }
    Ok(Solution { path, cost })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geometry;

    /// A deterministic generator for test data (LCG, top 53 bits).
    struct Lcg(u64);
    impl Lcg {
        fn next(&mut self) -> f64 {
            self.0 = self
                .0
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            (self.0 >> 11) as f64 / (1u64 << 53) as f64
        }
    }

    /// Random 3-D points, no structure at all.
    fn random_line(rng: &mut Lcg, n: usize) -> Vec<DVec3> {
        (0..n)
            .map(|_| DVec3::new(rng.next(), rng.next(), rng.next()))
            .collect()
    }

    /// Two noisy scan lines along x, at y = 0 and y = 1, over a bumpy height, with
    /// unequal point counts and a shifted start: what strips see in practice.
    fn scan_pair(rng: &mut Lcg, n: usize, m: usize) -> (Vec<DVec3>, Vec<DVec3>) {
        let mut line = |count: usize, y: f64, shift: f64| -> Vec<DVec3> {
            let step = 10.0 / count as f64;
            (0..count)
                .map(|k| {
                    let x = shift + step * (k as f64 + 0.3 * rng.next());
                    let y = y + 0.1 * rng.next();
                    DVec3::new(
                        x,
                        y,
                        (x * 0.9).sin() + 0.5 * (y * 2.0).cos() + 0.05 * rng.next(),
                    )
                })
                .collect()
        };
        let a = line(n, 0.0, 0.0);
        let shift = 0.4 * (n as f64 * 0.618).fract();
        (a, line(m, 1.0, shift))
    }

    const WEIGHTS: [Weight; 5] = [
        Weight::LENGTH,
        Weight::AREA,
        Weight::ANGLE,
        Weight::DIHEDRAL,
        Weight {
            length: 0.5,
            area: 2.0,
            angle: 1.0,
            dihedral: 0.3,
        },
    ];

    /// Every monotone path with n − 1 A-steps and m − 1 B-steps, by recursion.
    fn all_paths(n: usize, m: usize) -> Vec<Vec<Step>> {
        fn go(na: usize, nb: usize, prefix: &mut Vec<Step>, out: &mut Vec<Vec<Step>>) {
            if na == 0 && nb == 0 {
                out.push(prefix.clone());
                return;
            }
            for (s, left) in [(Step::A, na), (Step::B, nb)] {
                if left > 0 {
                    prefix.push(s);
                    if s == Step::A {
                        go(na - 1, nb, prefix, out);
                    } else {
                        go(na, nb - 1, prefix, out);
                    }
                    prefix.pop();
                }
            }
        }
        let mut out = Vec::new();
        go(n - 1, m - 1, &mut Vec::new(), &mut out);
        out
    }

    fn binomial(n: usize, k: usize) -> usize {
        (0..k).fold(1, |acc, i| acc * (n - i) / (i + 1))
    }

    fn close(x: f64, y: f64) -> bool {
        (x - y).abs() <= 1e-9 * (1.0 + x.abs().max(y.abs()))
    }

    #[test]
    fn atan2_upper_matches_libm() {
        let mut rng = Lcg(3);
        let mut worst = 0.0f64;
        for k in 0..200_000 {
            // Magnitudes over 40 decades, both signs of x, and the special lines.
            let scale = |r: f64| 10f64.powf(40.0 * r - 20.0);
            let y = if k % 97 == 0 {
                0.0
            } else {
                rng.next() * scale(rng.next())
            };
            let x = match k % 89 {
                0 => 0.0,
                1 => -y,
                2 => y,
                _ => (rng.next() - 0.5) * scale(rng.next()),
            };
            let (fast, exact) = (atan2_upper(y, x), y.atan2(x));
            worst = worst.max((fast - exact).abs() / exact.abs().max(f64::MIN_POSITIVE));
            assert!(
                (fast - exact).abs() <= 4.0 * f64::EPSILON * exact.abs(),
                "atan2({y}, {x}): {fast} vs {exact}"
            );
        }
        assert_eq!(atan2_upper(0.0, 0.0), 0.0);
        assert_eq!(atan2_upper(0.0, -0.0), PI);
        assert_eq!(atan2_upper(0.0, -1.0), PI);
        assert!(worst < 4.0 * f64::EPSILON, "{worst}");
    }

    #[test]
    fn smallest_angle_matches_three_atan2() {
        let mut rng = Lcg(7);
        for _ in 0..1000 {
            let p = random_line(&mut rng, 3);
            let twice = (p[1] - p[0]).cross(p[2] - p[0]).length();
            let fast = smallest_angle(p[0], p[1], p[2], twice);
            let slow = geometry::smallest_angle(p[0], p[1], p[2]);
            assert!((fast - slow).abs() < 1e-12, "{fast} vs {slow}");
        }
    }

    #[test]
    fn dp_dijkstra_and_brute_force_agree_on_random_strips() {
        let mut rng = Lcg(11);
        for n in 1..=8 {
            for m in 1..=8 {
                let (a, b) = (random_line(&mut rng, n), random_line(&mut rng, m));
                let paths = all_paths(n, m);
                assert_eq!(paths.len(), binomial(n + m - 2, n - 1));
                for w in WEIGHTS {
                    let brute = paths
                        .iter()
                        .map(|p| path_cost(&a, &b, w, p).unwrap())
                        .fold(f64::INFINITY, f64::min);
                    let dp = shortest_path_dp(&a, &b, w).unwrap();
                    let dij = shortest_path_dijkstra(&a, &b, w).unwrap();
                    assert!(
                        close(dp.cost, brute),
                        "n={n} m={m} {w:?}: dp {} brute {brute}",
                        dp.cost
                    );
                    assert!(
                        close(dij.cost, brute),
                        "n={n} m={m} {w:?}: dijkstra {} brute {brute}",
                        dij.cost
                    );
                    // The reported cost is the cost of the reported path.
                    assert!(close(path_cost(&a, &b, w, &dp.path).unwrap(), dp.cost));
                    assert!(close(path_cost(&a, &b, w, &dij.path).unwrap(), dij.cost));
                }
            }
        }
    }

    #[test]
    fn banded_equals_full_dp_on_scan_strips() {
        let mut rng = Lcg(23);
        for trial in 0..60 {
            let n = 5 + (rng.next() * 120.0) as usize;
            let m = 5 + (rng.next() * 120.0) as usize;
            let (a, b) = scan_pair(&mut rng, n, m);
            for w in WEIGHTS {
                let full = shortest_path_dp(&a, &b, w).unwrap();
                let band = shortest_path_banded(&a, &b, w, 1 + trial % 4).unwrap();
                assert!(
                    close(full.cost, band.cost),
                    "trial {trial} n={n} m={m} {w:?}: {} vs {}",
                    full.cost,
                    band.cost
                );
                assert!(close(path_cost(&a, &b, w, &band.path).unwrap(), band.cost));
            }
        }
    }

    #[test]
    fn banded_is_a_valid_path_never_below_the_optimum_on_random_points() {
        let mut rng = Lcg(29);
        for n in 1..=8 {
            for m in 1..=8 {
                let (a, b) = (random_line(&mut rng, n), random_line(&mut rng, m));
                for w in WEIGHTS {
                    let full = shortest_path_dp(&a, &b, w).unwrap();
                    let band = shortest_path_banded(&a, &b, w, 1).unwrap();
                    assert!(close(path_cost(&a, &b, w, &band.path).unwrap(), band.cost));
                    assert!(band.cost >= full.cost - 1e-12, "n={n} m={m} {w:?}");
                }
            }
        }
    }

    #[test]
    fn shortest_path_is_never_above_lookahead() {
        let mut rng = Lcg(31);
        for trial in 0..40 {
            let (n, m) = (2 + trial % 9, 2 + (trial * 7) % 13);
            let (a, b) = if trial % 2 == 0 {
                scan_pair(&mut rng, n * 3, m * 3)
            } else {
                (random_line(&mut rng, n), random_line(&mut rng, m))
            };
            for w in WEIGHTS {
                let best = shortest_path_dp(&a, &b, w).unwrap().cost;
                for alpha in 1..=6 {
                    let look = lookahead(&a, &b, w, alpha).unwrap();
                    assert!(close(path_cost(&a, &b, w, &look.path).unwrap(), look.cost));
                    assert!(
                        best <= look.cost + 1e-9 * (1.0 + best.abs()),
                        "alpha {alpha} {w:?}: {best} > {}",
                        look.cost
                    );
                }
            }
        }
    }

    #[test]
    fn lookahead_reaching_the_end_is_optimal() {
        let mut rng = Lcg(37);
        for _ in 0..20 {
            let (a, b) = (random_line(&mut rng, 6), random_line(&mut rng, 5));
            for w in WEIGHTS {
                let look = lookahead(&a, &b, w, 9).unwrap();
                let best = shortest_path_dp(&a, &b, w).unwrap();
                assert!(
                    close(look.cost, best.cost),
                    "{w:?}: {} vs {}",
                    look.cost,
                    best.cost
                );
            }
        }
    }

    #[test]
    fn greedy_lookahead_is_the_shortest_diagonal_rule() {
        let mut rng = Lcg(41);
        let (a, b) = scan_pair(&mut rng, 30, 20);
        let look = lookahead(&a, &b, Weight::LENGTH, 1).unwrap();
        let (mut i, mut j) = (0, 0);
        for &s in &look.path {
            if i + 1 < a.len() && j + 1 < b.len() {
                let shorter_a = (a[i + 1] - b[j]).length() <= (a[i] - b[j + 1]).length();
                assert_eq!(s == Step::A, shorter_a);
            }
            if s == Step::A {
                i += 1;
            } else {
                j += 1;
            }
        }
    }

    #[test]
    fn unequal_lines_give_n_plus_m_minus_2_ccw_triangles() {
        let mut rng = Lcg(43);
        let (a, b) = scan_pair(&mut rng, 17, 40);
        for w in WEIGHTS {
            let s = shortest_path_banded(&a, &b, w, DEFAULT_BAND).unwrap();
            assert_eq!(s.path.len(), 17 + 40 - 2);
            let a_ids: Vec<u32> = (0..17).collect();
            let b_ids: Vec<u32> = (17..57).collect();
            let tris = path_triangles(&s.path, &a_ids, &b_ids).unwrap();
            let all: Vec<DVec3> = a.iter().chain(&b).copied().collect();
            let uv: Vec<[f64; 2]> = all.iter().map(|p| [p.x, p.y]).collect();
            // b lies at larger y, to the left of a's +x direction: every triangle is CCW.
            for t in &tris {
                assert!(
                    geometry::orient2d(uv[t[0] as usize], uv[t[1] as usize], uv[t[2] as usize])
                        > 0.0
                );
            }
            let mesh = crate::mesh::HalfEdgeMesh::from_triangles(all.len(), &tris).unwrap();
            mesh.validate(&uv).unwrap();
        }
    }

    #[test]
    fn bad_input_is_an_error() {
        let a = vec![DVec3::ZERO, DVec3::X];
        assert!(shortest_path_dp(&a, &[], Weight::LENGTH).is_err());
        assert!(lookahead(&a, &a, Weight::LENGTH, 0).is_err());
        assert!(shortest_path_banded(&a, &a, Weight::LENGTH, 0).is_err());
        let zero = Weight {
            length: 0.0,
            area: 0.0,
            angle: 0.0,
            dihedral: 0.0,
        };
        assert!(shortest_path_dp(&a, &a, zero).is_err());
        let negative = Weight {
            length: -1.0,
            ..Weight::AREA
        };
        assert!(shortest_path_dp(&a, &a, negative).is_err());
        let nan = vec![DVec3::ZERO, DVec3::new(f64::NAN, 0.0, 0.0)];
        assert!(shortest_path_dijkstra(&nan, &a, Weight::LENGTH).is_err());
        assert!(path_cost(&a, &a, Weight::LENGTH, &[Step::A]).is_err());
        assert!(path_triangles(&[Step::A, Step::A], &[0, 1], &[2, 3]).is_err());
    }

    #[test]
    fn single_points_make_fans() {
        let a: Vec<DVec3> = (0..5).map(|k| DVec3::new(k as f64, 0.0, 0.0)).collect();
        let b = vec![DVec3::new(2.0, 1.0, 0.0)];
        let s = shortest_path_dp(&a, &b, Weight::ANGLE).unwrap();
        assert_eq!(s.path, vec![Step::A; 4]);
        let one = shortest_path_dp(&a[..1], &b, Weight::LENGTH).unwrap();
        assert!(one.path.is_empty());
        assert!(close(one.cost, (a[0] - b[0]).length()));
    }
}
