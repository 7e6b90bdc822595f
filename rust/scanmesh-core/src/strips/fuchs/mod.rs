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

mod banded;
mod dijkstra;
mod dp;
mod filter;
mod lookahead;
mod outside;
mod weights;

pub use banded::shortest_path_banded;
pub use dijkstra::shortest_path_dijkstra;
pub use dp::shortest_path_dp;
pub use filter::{set_strip_filter, strip_filter_counts, FilterCounts};
pub use lookahead::lookahead;
pub use weights::Weight;

use crate::{Error, Result};
use glam::DVec3;
use weights::{Terms, Tri};

/// One step of a path through the Fuchs matrix.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Step {
    /// (i, j)→(i+1, j): advance on line a, adding triangle (a_i, a_{i+1}, b_j).
    A,
    /// (i, j)→(i, j+1): advance on line b, adding triangle (a_i, b_{j+1}, b_j).
    B,
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
/// keep the far triangles' angle bound high enough to prove the band on almost every strip
/// (timed against the former unproven band in docs/benchmarks/speed.md, "Figures behind the
/// core's constants").
pub const DEFAULT_BAND: usize = 2;

/// Most bytes the solver of one strip may hold (2 GiB): a strip whose solver would need
/// more is refused with an error naming the option and the memory, before the work starts.
/// Strips run in parallel, so a call may hold this much per thread. The full DP needs
/// about n·m bytes (2 × 40,000 points: 1.6 GB), Dijkstra about 18·n·m.
pub const MAX_STRIP_BYTES: u64 = 2 << 30;

/// Most window cells look-ahead may evaluate on one strip: with α below n + m − 2 every
/// decision runs a DP over up to min(α, n) · min(α, m) cells (above, one DP does it all).
/// The limit is about a minute of work at the cost of a cell with the dihedral weight
/// (measured in docs/benchmarks/speed.md, "Figures behind the core's constants").
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

    /// What this strip's failed allocations name ("the solver 'dp' on a strip of 3 × 4
    /// points"). O(1).
    fn what(&self) -> String {
        format!(
            "the {} {} on a strip of {} × {} points",
            self.option, self.value, self.n, self.m
        )
    }

    /// `len` copies of `fill`, allocated fallibly: memory the system refuses is an
    /// [`Error::OutOfMemory`] naming this strip, not an abort. O(len).
    fn filled<T: Clone + Send + Sync>(&self, len: usize, fill: T) -> Result<Vec<T>> {
        crate::budget::try_filled(&self.what(), fill, len)
    }

    /// An empty vector with room for `len` items, allocated as [`filled`](Self::filled).
    /// O(1).
    fn vec<T>(&self, len: usize) -> Result<Vec<T>> {
        crate::budget::try_vec(&self.what(), len)
    }

    /// The items of `items`, allocated as [`filled`](Self::filled). O(len).
    fn collect<T>(&self, items: impl ExactSizeIterator<Item = T>) -> Result<Vec<T>> {
        crate::budget::try_collect(&self.what(), items)
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
pub(crate) fn path_triangles_into(
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

#[cfg(test)]
mod tests;
