//! The cheapest path by Dijkstra's search, which settles only the nodes cheaper than the
//! optimum.

use super::weights::{Terms, Tri, Weight};
use super::{Solution, Step};
use crate::budget::not_allocated;
use crate::Result;
use glam::DVec3;
use std::cmp::Ordering;
use std::collections::BinaryHeap;

/// A heap entry ordered by ascending cost (BinaryHeap is a max-heap).
#[derive(PartialEq)]
pub(super) struct Queued {
    pub(super) cost: f64,
    pub(super) state: usize,
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
/// per state plus the heap (about 18·n·m bytes; refused above [`MAX_STRIP_BYTES`](super::MAX_STRIP_BYTES); the
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
                heap.try_reserve(heap.len().max(64))
                    .map_err(|_| not_allocated::<Queued>(&ask.what(), 2 * heap.len()))?;
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
    let mut path = ask.vec(n + m - 2)?;
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
