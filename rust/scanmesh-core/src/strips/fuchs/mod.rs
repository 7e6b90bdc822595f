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

mod outside;

use crate::geometry::{atan2_upper, check_finite};
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

/// Default initial half width w of [`shortest_path_banded`]: optimal strips between scan
/// lines of similar spacing stray one or two columns from the diagonal, and two columns
/// keep the far triangles' angle bound high enough to prove the band on almost every strip.
/// Measured on the 1M-point synthetic scan (`strips_best vs`, old and new builds
/// alternating, load 9-10 on 2 cores): checked strips 1.74-2.49 s against 1.78-2.63 s with
/// the former unproven band (a DP of half width 2w accepted when its path kept within w).
pub const DEFAULT_BAND: usize = 2;

/// Most bytes the solver of one strip may hold (2 GiB): a strip whose solver would need
/// more is refused with an error naming the option and the memory, before the work starts.
/// Strips run in parallel, so a call may hold this much per thread. The full DP needs
/// about n·m bytes (2 × 40,000 points: 1.6 GB), Dijkstra about 18·n·m.
pub const MAX_STRIP_BYTES: u64 = 2 << 30;

/// Most window cells look-ahead may evaluate on one strip: with α below n + m − 2 every
/// decision runs a DP over up to min(α, n) · min(α, m) cells (above, one DP does it all).
/// A cell costs up to about 0.1 µs with the dihedral weight (α = 100 on 2 × 1,500 points:
/// 3.1e7 cells, 22 s on two cores shared with 15 other jobs), so the limit is about a
/// minute.
pub const MAX_LOOKAHEAD_CELLS: u64 = 500_000_000;

/// `bytes` as "1.6 GB". O(1).
fn human_bytes(bytes: u128) -> String {
    let b = bytes as f64;
    match b {
        b if b >= 1e9 => format!("{:.1} GB", b / 1e9),
        b if b >= 1e6 => format!("{:.1} MB", b / 1e6),
        b => format!("{:.0} kB", (b / 1e3).ceil()),
    }
}

/// What a strip asks of its solver, for the refusals: the option that chose the work
/// (`solver`, `band`, `alpha`), its value and the strip's size.
struct Ask {
    option: &'static str,
    value: String,
    n: usize,
    m: usize,
}

impl Ask {
    /// Refuses `bytes` above [`MAX_STRIP_BYTES`], before anything is allocated. O(1).
    fn check_bytes(&self, bytes: u128) -> Result<()> {
        if bytes > u128::from(MAX_STRIP_BYTES) {
            return Err(self.refusal(
                format!("needs {} of memory", human_bytes(bytes)),
                "at most 2 GiB per strip (the default banded solver needs a narrow band)",
            ));
        }
        Ok(())
    }

    /// The error for this strip: `why` it is refused, and what would do instead.
    fn refusal(&self, why: String, expected: &'static str) -> Error {
        Error::InvalidParameter {
            name: self.option,
            value: format!(
                "{} on a strip of {} × {} points ({why})",
                self.value, self.n, self.m
            ),
            expected,
        }
    }

    /// `len` copies of `fill`, allocated fallibly: memory the system refuses is this
    /// strip's error, not an abort. O(len).
    fn filled<T: Clone>(&self, len: usize, fill: T) -> Result<Vec<T>> {
        let mut v = Vec::new();
        v.try_reserve_exact(len).map_err(|_| {
            let bytes = len as u128 * std::mem::size_of::<T>() as u128;
            self.refusal(
                format!("could not allocate {}", human_bytes(bytes)),
                "a strip whose solver memory the system can provide",
            )
        })?;
        v.resize(len, fill);
        Ok(v)
    }
}

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

/// Dihedral angle (radians, [0, π]) between triangles with normals `n1`, `n2` of any
/// length that share an edge e of length `len`; `apex` is the first triangle's corner off
/// e minus a point of e. π when a normal is zero (a degenerate triangle). O(1).
///
/// The definition is `atan2(|n1 × n2|, n1 · n2)`; both normals are perpendicular to e, so
/// n1 × n2 is parallel to it and, with n1 = ±apex × e, |n1 × n2| = |apex · n2| · |e|
/// (Lagrange: (u × e) × (v × e) = (u · (e × v)) e). That is one dot product where the
/// cross product form needs a cross product and a square root; `len` is the node length
/// every search computes anyway. Equal to the cross product form up to rounding (tested
/// against it to 1e-12 in path costs).
#[inline(always)]
fn dihedral(n1: DVec3, apex: DVec3, len: f64, n2: DVec3) -> f64 {
    if n1 == DVec3::ZERO || n2 == DVec3::ZERO {
        return PI;
    }
    atan2_upper(apex.dot(n2).abs() * len, n1.dot(n2))
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

    /// This strip as chosen by `option` = `value`, for refusals.
    fn ask(&self, option: &'static str, value: String) -> Ask {
        Ask {
            option,
            value,
            n: self.n(),
            m: self.m(),
        }
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

    /// The step `s` leaving (i, j): its cost (including the weight of the node it enters)
    /// and what the turn to the next step needs. O(1).
    #[inline]
    fn step(&self, i: usize, j: usize, s: Step) -> Tri {
        // The entered node (ti, tj) is the edge shared with the next triangle; the apex is
        // this triangle's third corner, taken relative to a_ti.
        let (p, q, r, ti, tj, apex) = match s {
            Step::A => (self.a[i], self.a[i + 1], self.b[j], i + 1, j, self.a[i]),
            Step::B => (self.a[i], self.b[j + 1], self.b[j], i, j + 1, self.b[j]),
        };
        let e = self.b[tj] - self.a[ti];
        let sides = [
            (q - p).length_squared(),
            (r - q).length_squared(),
            (p - r).length_squared(),
        ];
        let dots = [(p - r).dot(q - r), (q - p).dot(r - p), (r - q).dot(p - q)];
        self.triangle(
            e.length(),
            (q - p).cross(r - p),
            sides,
            dots,
            apex - self.a[ti],
        )
    }

    /// Whether any triangle criterion (area, angle, dihedral) is on. O(1).
    #[inline]
    fn needs_triangles(&self) -> bool {
        self.w.area != 0.0 || self.w.angle != 0.0 || self.w.dihedral != 0.0
    }

    /// A step from its parts: `len` = length of the entered node's edge a_i–b_j,
    /// its triangle (p, q, r) by `cross` = (q − p) × (r − p), squared sides
    /// [|pq|², |qr|², |rp|²], the dot products of the two sides at the corners opposite
    /// them [at r, at p, at q], and `apex` = the corner off the entered edge minus a_i.
    /// Every evaluation of a step goes through here, whether its vectors are computed on
    /// the spot ([`Terms::step`]) or taken from the DP's row caches ([`dp_in_band`]), so
    /// both give bit-identical costs. Branch-free apart from the weight switches, which are
    /// the same for every call. O(1).
    #[inline(always)]
    fn triangle(
        &self,
        len: f64,
        cross: DVec3,
        sides: [f64; 3],
        dots: [f64; 3],
        apex: DVec3,
    ) -> Tri {
        let mut cost = if self.w.length == 0.0 {
            0.0
        } else {
            self.w.length * len
        };
        if !self.needs_triangles() {
            // The length weight alone needs no triangle (the hot path of `Weight::LENGTH`).
            return Tri {
                cost,
                normal: DVec3::ZERO,
                apex: DVec3::ZERO,
                len,
            };
        }
        let twice_area = cross.length();
        if self.w.area != 0.0 {
            cost += self.w.area * 0.5 * twice_area;
        }
        if self.w.angle != 0.0 {
            // The smallest angle is at the corner opposite the shortest side (law of sines).
            let [pq, qr, rp] = sides;
            let k = usize::from(pq > qr || pq > rp) * (1 + usize::from(qr > rp));
            // That angle is at most π/3, so its cosine is positive; only a degenerate
            // triangle (coincident corners) gives a dot product of 0 or below, and a
            // -0.0 (the row cache negates differences) would make atan2 return π and the
            // penalty negative. Its smallest angle is 0.
            let dot = if dots[k] > 0.0 { dots[k] } else { 0.0 };
            cost += self.w.angle * (FRAC_PI_3 - atan2_upper(twice_area, dot));
        }
        // The dihedral angle is scale-free: the cross product serves as the normal unscaled.
        let normal = if self.w.dihedral != 0.0 {
            cross
        } else {
            DVec3::ZERO
        };
        Tri {
            cost,
            normal,
            apex,
            len,
        }
    }

    /// Cost of the turn from triangle `from` to the next one, with normal `n2`. O(1).
    #[inline(always)]
    fn turn(&self, n1: DVec3, apex: DVec3, len: f64, n2: DVec3) -> f64 {
        if self.w.dihedral == 0.0 {
            0.0
        } else {
            self.w.dihedral * dihedral(n1, apex, len, n2)
        }
    }

    /// [`Terms::turn`] from a whole step. O(1).
    #[inline]
    fn turn_from(&self, from: &Tri, n2: DVec3) -> f64 {
        self.turn(from.normal, from.apex, from.len, n2)
    }
}

/// A step as the searches need it.
#[derive(Debug, Clone, Copy)]
struct Tri {
    /// Its cost: the weight of the node it enters plus its triangle's terms.
    cost: f64,
    /// (q − p) × (r − p) of its triangle (p, q, r), unnormalized; zero when the dihedral
    /// weight is off.
    normal: DVec3,
    /// Its triangle's corner off the edge a_i–b_j of the node (i, j) it enters, minus a_i.
    apex: DVec3,
    /// |a_i − b_j| of the node it enters.
    len: f64,
}

/// Cost of `path` between lines `a` and `b` under `w`, evaluated step by step: node weights
/// of all n + m − 1 nodes, step weights of all triangles, turn weights of all consecutive
/// pairs. Errors: a path that does not end at (n−1, m−1), or bad input. O(n + m).
pub fn path_cost(a: &[DVec3], b: &[DVec3], w: Weight, path: &[Step]) -> Result<f64> {
    let t = Terms::new(a, b, w)?;
    check_path(t.n(), t.m(), path)?;
    let (mut i, mut j) = (0, 0);
    let mut cost = t.node(0, 0);
    let mut previous: Option<Tri> = None;
    for &s in path {
        let step = t.step(i, j, s);
        cost += step.cost + previous.map_or(0.0, |p| t.turn_from(&p, step.normal));
        previous = Some(step);
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

/// [`path_triangles_into`] as a new list, for the tests. O(n + m).
#[cfg(test)]
pub(crate) fn path_triangles(path: &[Step], a_ids: &[u32], b_ids: &[u32]) -> Result<Vec<[u32; 3]>> {
    let mut out = vec![[0; 3]; path.len()];
    path_triangles_into(path, a_ids, b_ids, &mut out)?;
    Ok(out)
}

/// The triangles of `path`, in the caller's point indices, written into `out` (one entry
/// per step, so the strips write straight into the mesh's list): `a_ids[i]` is a_i,
/// `b_ids[j]` is b_j; step A at (i, j) gives (a_i, a_{i+1}, b_j), step B gives
/// (a_i, b_{j+1}, b_j). Errors: a path that does not fit the two index lists, or an `out`
/// of another length. O(n + m).
pub fn path_triangles_into(
    path: &[Step],
    a_ids: &[u32],
    b_ids: &[u32],
    out: &mut [[u32; 3]],
) -> Result<()> {
    check_path(a_ids.len(), b_ids.len(), path)?;
    if out.len() != path.len() {
        return Err(Error::InvalidParameter {
            name: "out",
            value: format!("{} entries for {} steps", out.len(), path.len()),
            expected: "one triangle per step",
        });
    }
    let (mut i, mut j) = (0, 0);
    for (&s, t) in path.iter().zip(out) {
        match s {
            Step::A => {
                *t = [a_ids[i], a_ids[i + 1], b_ids[j]];
                i += 1;
            }
            Step::B => {
                *t = [a_ids[i], b_ids[j + 1], b_ids[j]];
                j += 1;
            }
        }
    }
    Ok(())
}

/// The cheapest path by dynamic programming over the whole matrix (a DAG).
///
/// State: node and the direction of the step that entered it (for the dihedral weight).
/// Time O(nm), memory O(nm) bytes of back-pointers plus O(m) costs.
pub fn shortest_path_dp(a: &[DVec3], b: &[DVec3], w: Weight) -> Result<Solution> {
    let t = Terms::new(a, b, w)?;
    full_dp(&t, &t.ask("solver", "'dp'".into()))
}

/// [`shortest_path_dp`] on checked terms; refusals name `ask`'s option.
fn full_dp(t: &Terms, ask: &Ask) -> Result<Solution> {
    let lo = vec![0; t.n()];
    let hi = vec![t.m() - 1; t.n()];
    dp_in_band(t, &lo, &hi, ask)
}

/// A matrix cell: per entering direction (A = 0, B = 1), the cheapest cost so far and the
/// entering triangle's normal and apex (see [`Tri`]); the node length, for the turns out.
#[derive(Clone, Copy)]
struct Cell {
    cost: [f64; 2],
    normal: [DVec3; 2],
    apex: [DVec3; 2],
    len: f64,
}

const UNREACHED: Cell = Cell {
    cost: [f64::INFINITY; 2],
    normal: [DVec3::ZERO; 2],
    apex: [DVec3::ZERO; 2],
    len: 0.0,
};

impl Cell {
    /// Records `step` as the way in by direction `d` at cost `cost`. O(1).
    #[inline(always)]
    fn enter(&mut self, d: usize, cost: f64, step: &Tri) {
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
fn best_from(t: &Terms, p: &Cell, normal: DVec3, at_start: bool, start_cost: f64) -> (f64, u8) {
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
trait Steps {
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
struct Direct<'t, 'a>(&'t Terms<'a>);

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
struct Node {
    e: DVec3,
    l2: f64,
    len: f64,
}

/// Steps from cached vectors: each triangle entering (i, j) has two sides that are node
/// edges (a_i–b_j and a_{i−1}–b_j or a_i–b_{j−1}) and one that is a line step, so the
/// node vectors of the current and the last row plus the line steps give every side,
/// cross product and corner product without recomputing a difference, and each node's
/// length is taken once (both steps into a cell need it). The arithmetic is
/// the same as [`Terms::step`]'s term for term (a negated difference only flips signs,
/// exactly), so the costs are bit-identical; tested.
struct RowCache<'t, 'a> {
    t: &'t Terms<'a>,
    /// a_{i+1} − a_i and b_{j+1} − b_j, and their squared lengths.
    da: Vec<DVec3>,
    db: Vec<DVec3>,
    da2: Vec<f64>,
    db2: Vec<f64>,
    /// Nodes of the current and the last row, from their band's `lo`.
    cur: Vec<Node>,
    last: Vec<Node>,
    cur_lo: usize,
    last_lo: usize,
}

impl<'t, 'a> RowCache<'t, 'a> {
    fn new(t: &'t Terms<'a>, width: usize, ask: &Ask) -> Result<Self> {
        let steps =
            |line: &[DVec3]| -> Vec<DVec3> { line.windows(2).map(|w| w[1] - w[0]).collect() };
        let (da, db) = (steps(t.a), steps(t.b));
        let squares = |v: &[DVec3]| v.iter().map(|d| d.length_squared()).collect();
        Ok(RowCache {
            t,
            da2: squares(&da),
            db2: squares(&db),
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
/// lo[0] = 0, hi[n−1] = m−1). O(Σ band widths) time and back-pointer bytes, checked
/// against [`MAX_STRIP_BYTES`] before anything is allocated (refusals name `ask`'s option).
fn dp_in_band(t: &Terms, lo: &[usize], hi: &[usize], ask: &Ask) -> Result<Solution> {
    let width = check_band(t, lo, hi, ask)?;
    let solution = dp_in_band_with(t, RowCache::new(t, width, ask)?, &mut Sealed, lo, hi, ask)?;
    Ok(solution.expect("a sealed band has no way out"))
}

/// Checks the memory of a DP in the band `lo..=hi` against [`MAX_STRIP_BYTES`]; returns
/// the widest row. O(n).
fn check_band(t: &Terms, lo: &[usize], hi: &[usize], ask: &Ask) -> Result<usize> {
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
trait Outside {
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
struct Sealed;

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
fn dp_in_band_with(
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
    let mut offset = Vec::with_capacity(n + 1);
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
        if j < lo[i] || j > hi[i] {
            // Only a way in from outside leads out of the band.
            return Ok(None);
        }
    }
    path.reverse();
    Ok(Some(Solution { path, cost }))
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
/// two outgoing edges; all edge costs are non-negative. Time O(nm log(nm)), memory 9 bytes
/// per state plus the heap (about 18·n·m bytes; refused above [`MAX_STRIP_BYTES`]; the
/// heap grows fallibly). Kept as the reference the DP is tested against; the DP is faster
/// on the same DAG.
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
    let ask = t.ask("solver", "'dijkstra'".into());
    let states = 2 * n as u128 * m as u128;
    ask.check_bytes(states * (std::mem::size_of::<f64>() as u128 + 1))?;
    // State index (i * m + j) * 2 + d; d = 0 entered by A, 1 by B. The predecessor of a
    // state is the cell its step came from; `pred` keeps the direction that entered that
    // cell (bit 0) and whether the state is settled (bit 1).
    let states = 2 * n * m;
    let mut dist = ask.filled(states, f64::INFINITY)?;
    let mut pred = ask.filled(states, 0u8)?;
    const DONE: u8 = 2;
    let mut heap = BinaryHeap::new();
    let relax = |heap: &mut BinaryHeap<Queued>,
                 dist: &mut [f64],
                 pred: &mut [u8],
                 from_dir: u8,
                 i,
                 j,
                 s,
                 before: f64,
                 previous: Option<Tri>|
     -> Result<()> {
        let step = t.step(i, j, s);
        let cost = before + step.cost + previous.map_or(0.0, |p| t.turn_from(&p, step.normal));
        let (ti, tj, d) = match s {
            Step::A => (i + 1, j, 0),
            Step::B => (i, j + 1, 1),
        };
        let to = (ti * m + tj) * 2 + d;
        if cost < dist[to] {
            dist[to] = cost;
            pred[to] = from_dir;
            if heap.len() == heap.capacity() {
                heap.try_reserve(heap.len().max(64)).map_err(|_| {
                    ask.refusal(
                        "could not grow the heap".into(),
                        "a strip whose solver memory the system can provide",
                    )
                })?;
            }
            heap.push(Queued { cost, state: to });
        }
        Ok(())
    };
    // The start has no entering triangle; its successors are relaxed directly.
    if n > 1 {
        relax(
            &mut heap,
            &mut dist,
            &mut pred,
            0,
            0,
            0,
            Step::A,
            start_cost,
            None,
        )?;
    }
    if m > 1 {
        relax(
            &mut heap,
            &mut dist,
            &mut pred,
            0,
            0,
            0,
            Step::B,
            start_cost,
            None,
        )?;
    }
    let goal = ((n - 1) * m + m - 1) * 2;
    while let Some(Queued { cost, state }) = heap.pop() {
        if pred[state] & DONE != 0 {
            continue;
        }
        pred[state] |= DONE;
        if state == goal || state == goal + 1 {
            break;
        }
        let (i, j, d) = (state / 2 / m, state / 2 % m, state % 2);
        // The step that entered (i, j), recomputed: the reference favours clarity over
        // speed.
        let entered = if d == 0 {
            t.step(i - 1, j, Step::A)
        } else {
            t.step(i, j - 1, Step::B)
        };
        for (s, fits) in [(Step::A, i + 1 < n), (Step::B, j + 1 < m)] {
            if fits {
                relax(
                    &mut heap,
                    &mut dist,
                    &mut pred,
                    d as u8,
                    i,
                    j,
                    s,
                    cost,
                    Some(entered),
                )?;
            }
        }
    }
    let mut state = if dist[goal] <= dist[goal + 1] {
        goal
    } else {
        goal + 1
    };
    let cost = dist[state];
    let mut path = Vec::with_capacity(n + m - 2);
    let (mut i, mut j) = (n - 1, m - 1);
    while i > 0 || j > 0 {
        let d = state % 2;
        path.push(if d == 0 { Step::A } else { Step::B });
        if d == 0 {
            i -= 1;
        } else {
            j -= 1;
        }
        state = (i * m + j) * 2 + usize::from(pred[state] & 1);
    }
    path.reverse();
    Ok(Solution { path, cost })
}

/// The cheapest path of the whole matrix by DP inside a band around the diagonal, widened
/// until the band proves its path optimal.
///
/// The diagonal c(i) is the j of the b point nearest a_i along the strip's direction (so
/// lines of unequal extent, length or spacing get a diagonal that follows them). The DP
/// runs in the band of half width w around it (initially w = `half_width`) and lets paths
/// back in from outside at lower bounds of what they cost there (`fuchs/outside.rs`: the
/// length and the angle of a triangle whose corner lies far from the band bound its cost
/// from below). When its cheapest path stays inside the band, no path through the outside
/// can be cheaper, and that path is optimal over the whole matrix; otherwise w doubles and
/// the DP repeats; at the latest the band becomes the whole matrix (the full DP). So the
/// result is always the optimum (up to rounding: the same cost as [`shortest_path_dp`] to
/// about 1e-12 relative; tested against it and Dijkstra on 100,000 fuzzed strips).
///
/// Time O((n + m) · w) and memory O(n · w) bytes for the final w (each round doubles the
/// width, so all rounds together cost less than twice the last); with the default weight
/// on scan strips the first band proves itself on almost every strip. Weights with only
/// area or dihedral angle bound nothing far away and widen to the full DP, O(nm) (refused
/// above [`MAX_STRIP_BYTES`]). Errors as [`shortest_path`], and `half_width` = 0.
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
        let mut hi: Vec<usize> = center
            .iter()
            .map(|&c| c.saturating_add(w).min(m - 1))
            .collect();
        lo[0] = 0;
        hi[n - 1] = m - 1;
        // Consecutive rows must share a column for a path to step down.
        for i in (0..n - 1).rev() {
            hi[i] = hi[i].max(lo[i + 1]).min(hi[i + 1]);
        }
        (lo, hi)
    };
    let ask = t.ask("solver", "'banded'".into());
    let mut width = half_width;
    loop {
        let (lo, hi) = band(width);
        if lo.iter().all(|&x| x == 0) && hi.iter().all(|&x| x == m - 1) {
            return dp_in_band(&t, &lo, &hi, &ask);
        }
        let row_width = check_band(&t, &lo, &hi, &ask)?;
        let steps = RowCache::new(&t, row_width, &ask)?;
        let mut bounds = outside::Bounds::new(&t, &lo, &hi);
        if let Some(solution) = dp_in_band_with(&t, steps, &mut bounds, &lo, &hi, &ask)? {
            return Ok(solution);
        }
        width = width.saturating_mul(2);
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
/// evaluations per triangle). From α = n + m − 2 on, every
/// window reaches the end, the walk follows an optimal path, and a larger α changes
/// nothing: that path is found by one DP instead ([`shortest_path_dp`]: the same cost; among
/// tied optima, the DP's), in O(nm). Memory O(min(α, n) · min(α, m)). Errors: α = 0, a
/// strip whose windows would exceed [`MAX_LOOKAHEAD_CELLS`] or [`MAX_STRIP_BYTES`], and
/// those of [`shortest_path`].
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
        return Ok(greedy(&t));
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
    Ok(windowed(&t, window, alpha))
}

/// The α-look-ahead walk of [`lookahead`] on checked terms, each decision by a window DP
/// in `window` (sized for α). O((n + m) · min(α, n) · min(α, m)).
fn windowed(t: &Terms, mut window: Window, alpha: usize) -> Solution {
    walk(t, |i, j, entered| {
        let via_a = window.best(t, i, j, *entered, Step::A, alpha);
        let via_b = window.best(t, i, j, *entered, Step::B, alpha);
        let s = if via_a <= via_b { Step::A } else { Step::B };
        let step = t.step(i, j, s);
        (s, step, with_turn(t, step, entered))
    })
}

/// [`lookahead`] with α = 1 on checked terms: each decision compares the two steps out of
/// the node by their own cost plus their turn, which is all a window of one step holds, so
/// each step is evaluated once and the one taken is not evaluated again (the greedy walk
/// of VTK's ruled surface, under any weight). The same arithmetic as the windows (a cell
/// reached by one step holds `step.cost + turn`), so the same path and cost bit for bit;
/// tested against the windowed walk. O(n + m) time, O(n + m) memory for the path.
fn greedy(t: &Terms) -> Solution {
    walk(t, |i, j, entered| {
        let (step_a, step_b) = (t.step(i, j, Step::A), t.step(i, j, Step::B));
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
    })
}

/// The cost `step` adds after the triangle `entered` (none at the start): its own cost
/// plus the turn. O(1).
#[inline(always)]
fn with_turn(t: &Terms, step: Tri, entered: &Option<Tri>) -> f64 {
    step.cost + entered.map_or(0.0, |e| t.turn_from(&e, step.normal))
}

/// The walk of the look-ahead variants from (0, 0) to (n − 1, m − 1): on the last row or
/// column the step is forced, elsewhere `choose(i, j, entered)` returns the step to take,
/// its [`Tri`] and the cost it adds ([`with_turn`]). O(n + m) calls of `choose`.
fn walk(
    t: &Terms,
    mut choose: impl FnMut(usize, usize, &Option<Tri>) -> (Step, Tri, f64),
) -> Solution {
    let (n, m) = (t.n(), t.m());
    let mut path = Vec::with_capacity(n + m - 2);
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
    Solution { path, cost }
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

    /// Case `k` of a mixed corpus: every third a pair of random lines, else a scan pair.
    fn mixed_pair(rng: &mut Lcg, k: usize, n: usize, m: usize) -> (Vec<DVec3>, Vec<DVec3>) {
        if k % 3 == 0 {
            (random_line(rng, n), random_line(rng, m))
        } else {
            scan_pair(rng, n, m)
        }
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
    fn smallest_angle_matches_three_atan2() {
        let mut rng = Lcg(7);
        for _ in 0..1000 {
            // Step A at (0, 0) adds triangle (a_0, a_1, b_0) at cost π/3 − smallest angle.
            let p = random_line(&mut rng, 3);
            let t = Terms::new(&p[..2], &p[2..], Weight::ANGLE).unwrap();
            let fast = FRAC_PI_3 - t.step(0, 0, Step::A).cost;
            let slow = geometry::smallest_angle(p[0], p[1], p[2]);
            assert!((fast - slow).abs() < 1e-12, "{fast} vs {slow}");
        }
    }

    #[test]
    fn row_cache_steps_are_bit_identical_to_direct_steps() {
        let mut rng = Lcg(13);
        for trial in 0..80 {
            let (n, m) = (1 + trial % 9, 1 + (trial * 5) % 11);
            let (a, b) = if trial % 2 == 0 {
                (random_line(&mut rng, n), random_line(&mut rng, m))
            } else {
                scan_pair(&mut rng, 3 * n, 3 * m)
            };
            let (n, m) = (a.len(), b.len());
            // The whole matrix, and a band of half width 1 around the diagonal.
            let full = (vec![0; n], vec![m - 1; n]);
            let mut lo: Vec<usize> = (0..n).map(|i| (i * m / n).saturating_sub(1)).collect();
            let mut hi: Vec<usize> = (0..n).map(|i| (i * m / n + 1).min(m - 1)).collect();
            lo[0] = 0;
            hi[n - 1] = m - 1;
            for i in (0..n - 1).rev() {
                hi[i] = hi[i].max(lo[i + 1]).min(hi[i + 1]);
            }
            for (lo, hi) in [full, (lo, hi)] {
                for w in WEIGHTS {
                    let t = Terms::new(&a, &b, w).unwrap();
                    let ask = t.ask("test", String::new());
                    let fast = dp_in_band(&t, &lo, &hi, &ask).unwrap();
                    let slow = dp_in_band_with(&t, Direct(&t), &mut Sealed, &lo, &hi, &ask)
                        .unwrap()
                        .unwrap();
                    assert_eq!(fast.cost.to_bits(), slow.cost.to_bits(), "{trial} {w:?}");
                    assert_eq!(fast.path, slow.path);
                }
            }
        }
    }

    /// The cost of `path` straight from the definitions of [`Weight`], with libm's atan2
    /// and the cross product form of the dihedral angle: the slow reference.
    fn reference_path_cost(a: &[DVec3], b: &[DVec3], w: Weight, path: &[Step]) -> f64 {
        let (mut i, mut j) = (0, 0);
        let mut cost = w.length * (a[0] - b[0]).length();
        let mut previous: Option<DVec3> = None;
        for &s in path {
            let (p, q, r) = match s {
                Step::A => (a[i], a[i + 1], b[j]),
                Step::B => (a[i], b[j + 1], b[j]),
            };
            match s {
                Step::A => i += 1,
                Step::B => j += 1,
            }
            let normal = (q - p).cross(r - p);
            cost += w.length * (a[i] - b[j]).length()
                + w.area * geometry::triangle_area(p, q, r)
                + w.angle * (FRAC_PI_3 - geometry::smallest_angle(p, q, r));
            if let Some(n1) = previous {
                let angle = if n1 == DVec3::ZERO || normal == DVec3::ZERO {
                    PI
                } else {
                    n1.cross(normal).length().atan2(n1.dot(normal))
                };
                cost += w.dihedral * angle;
            }
            previous = Some(normal);
        }
        cost
    }

    #[test]
    fn costs_match_the_reference_definitions() {
        let mut rng = Lcg(17);
        for trial in 0..60 {
            let (n, m) = (2 + trial % 40, 2 + (trial * 7) % 45);
            let (a, b) = mixed_pair(&mut rng, trial, n, m);
            for w in WEIGHTS {
                let s = shortest_path_banded(&a, &b, w, DEFAULT_BAND).unwrap();
                let reference = reference_path_cost(&a, &b, w, &s.path);
                let tolerance = 1e-12 * reference.abs().max(1.0);
                assert!(
                    (s.cost - reference).abs() <= tolerance,
                    "trial {trial} {w:?}: {} vs {reference}",
                    s.cost
                );
                let again = path_cost(&a, &b, w, &s.path).unwrap();
                assert!((again - reference).abs() <= tolerance);
            }
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

    /// One strip of the fuzz corpus: seeded by `k`, one of five kinds.
    fn fuzz_strip(rng: &mut Lcg, k: usize) -> (Vec<DVec3>, Vec<DVec3>) {
        let mut size = |hi: usize| 1 + (rng.next() * hi as f64) as usize;
        match k % 5 {
            // No structure at all.
            0 => {
                let (n, m) = (size(9), size(9));
                (random_line(rng, n), random_line(rng, m))
            }
            // Noisy scan lines, unequal counts.
            1 => {
                let (n, m) = (1 + size(16), 1 + size(16));
                scan_pair(rng, n, m)
            }
            // Small integer coordinates (as the fuzz target decodes bytes): duplicates,
            // collinear runs, coincident points across the lines.
            2 => {
                let (n, m) = (size(8), size(8));
                let mut grid = |count: usize| -> Vec<DVec3> {
                    (0..count)
                        .map(|_| {
                            let c = |r: &mut Lcg| (r.next() * 5.0).floor();
                            DVec3::new(c(rng), c(rng), c(rng) - 2.0)
                        })
                        .collect()
                };
                (grid(n), grid(m))
            }
            // A dense line against a sparse one, and a line folding back on itself.
            3 => {
                let (n, m) = (size(4), 5 + size(20));
                let (a, mut b) = scan_pair(rng, n, m);
                if k % 2 == 0 {
                    let half = b.len() / 2;
                    b[half..].reverse();
                }
                (a, b)
            }
            // Scan lines far apart (slivers everywhere) or nearly on top of each other.
            _ => {
                let (n, m) = (2 + size(12), 2 + size(12));
                let (mut a, b) = scan_pair(rng, n, m);
                let lift = if k % 2 == 0 { 8.0 } else { 0.99 };
                a.iter_mut().for_each(|p| p.y += lift);
                (a, b)
            }
        }
    }

    /// A random weight: each coefficient 0 or one of several magnitudes, one positive.
    fn fuzz_weight(rng: &mut Lcg) -> Weight {
        const LEVELS: [f64; 6] = [0.0, 0.0, 1e-6, 0.3, 1.0, 100.0];
        loop {
            let mut c = || LEVELS[(rng.next() * LEVELS.len() as f64) as usize];
            let w = Weight {
                length: c(),
                area: c(),
                angle: c(),
                dihedral: c(),
            };
            if w.check().is_ok() {
                return w;
            }
        }
    }

    #[test]
    fn banded_is_exact_on_a_fuzz_corpus_of_100_000_strips() {
        let mut rng = Lcg(53);
        let tol = |x: f64| 1e-9 * x.abs().max(1.0);
        for k in 0..100_000 {
            let (a, b) = fuzz_strip(&mut rng, k);
            let w = if k % 3 == 0 {
                WEIGHTS[k / 3 % WEIGHTS.len()]
            } else {
                fuzz_weight(&mut rng)
            };
            let dp = shortest_path_dp(&a, &b, w).unwrap();
            let band = shortest_path_banded(&a, &b, w, 1 + k % 4).unwrap();
            let context = || format!("strip {k}: n={} m={} {w:?}", a.len(), b.len());
            assert!(
                (band.cost - dp.cost).abs() <= tol(dp.cost),
                "{}: banded {} dp {}",
                context(),
                band.cost,
                dp.cost
            );
            let cost = path_cost(&a, &b, w, &band.path).unwrap();
            assert!((cost - band.cost).abs() <= tol(cost), "{}", context());
            // Dijkstra and look-ahead on every 8th strip: they are the slow references.
            if k % 8 == 0 {
                let dijkstra = shortest_path_dijkstra(&a, &b, w).unwrap();
                assert!(
                    (dijkstra.cost - dp.cost).abs() <= tol(dp.cost),
                    "{}",
                    context()
                );
                let look = lookahead(&a, &b, w, 1 + k % 5).unwrap();
                assert!(look.cost >= dp.cost - tol(dp.cost), "{}", context());
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
    fn greedy_walk_is_the_one_step_window_walk_bit_for_bit() {
        let mut rng = Lcg(43);
        for k in 0..300 {
            let (n, m) = (2 + k % 17, 2 + (k * 7) % 23);
            let (a, b) = mixed_pair(&mut rng, k, n, m);
            for w in WEIGHTS {
                let t = Terms::new(&a, &b, w).unwrap();
                let window = Window {
                    cells: vec![UNREACHED; 4],
                };
                let slow = windowed(&t, window, 1);
                let fast = greedy(&t);
                assert_eq!(fast.path, slow.path, "{n} x {m}, {w:?}");
                assert_eq!(fast.cost.to_bits(), slow.cost.to_bits(), "{n} x {m}, {w:?}");
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

    /// `result` is a refusal of `option` whose message says `what`.
    fn assert_refused(result: Result<Solution>, option: &str, what: &str) {
        match result {
            Err(Error::InvalidParameter { name, value, .. }) => {
                assert_eq!(name, option, "{value}");
                assert!(value.contains(what), "{value}");
            }
            other => panic!("expected a refusal of {option}, got {other:?}"),
        }
    }

    #[test]
    fn oversized_strips_are_refused_before_the_work() {
        let line = |n: usize, y: f64| -> Vec<DVec3> {
            (0..n).map(|k| DVec3::new(k as f64, y, 0.0)).collect()
        };
        let (a, b) = (line(20_000, 0.0), line(20_000, 1.0));
        // 8e8 states: 7.2 GB.
        assert_refused(
            shortest_path_dijkstra(&a, &b, Weight::ANGLE),
            "solver",
            "GB",
        );
        let (a, b) = (line(50_000, 0.0), line(50_000, 1.0));
        // 2.5e9 cells of back-pointers.
        assert_refused(shortest_path_dp(&a, &b, Weight::ANGLE), "solver", "GB");
        let (a, b) = (line(1_500, 0.0), line(1_500, 1.0));
        assert_refused(
            lookahead(&a, &b, Weight::ANGLE, 1_000),
            "alpha",
            "window cells",
        );
    }

    #[test]
    fn memory_the_system_refuses_is_an_error() {
        let a = vec![DVec3::ZERO, DVec3::X];
        let t = Terms::new(&a, &a, Weight::ANGLE).unwrap();
        let ask = t.ask("solver", "'dp'".into());
        let huge = ask.filled(usize::MAX / 4, 0u8);
        assert!(
            matches!(&huge, Err(Error::InvalidParameter { name: "solver", value, .. })
                if value.contains("could not allocate")),
            "{huge:?}"
        );
    }

    #[test]
    fn lookahead_beyond_the_strip_is_the_optimum_at_dp_cost() {
        let mut rng = Lcg(47);
        for trial in 0..30 {
            let (a, b) = if trial % 2 == 0 {
                scan_pair(&mut rng, 5 + trial, 3 + 2 * trial)
            } else {
                (
                    random_line(&mut rng, 1 + trial % 7),
                    random_line(&mut rng, 2 + trial % 5),
                )
            };
            let edge = a.len() + b.len() - 2;
            for w in WEIGHTS {
                let best = shortest_path_dp(&a, &b, w).unwrap();
                for alpha in [edge.max(1), edge + 1, usize::MAX] {
                    let look = lookahead(&a, &b, w, alpha).unwrap();
                    assert!(close(look.cost, best.cost), "{trial} {w:?} {alpha}");
                }
                // Just below the edge, the windows still decide: a path, never below.
                if edge > 1 {
                    let look = lookahead(&a, &b, w, edge - 1).unwrap();
                    assert!(look.cost >= best.cost - 1e-9 * best.cost.abs().max(1.0));
                }
            }
        }
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
