//! The path kernel alone: `shortest_path_banded` and look-ahead α = 1 on every pair of
//! consecutive lines of the 1M-point synthetic height scan, one thread, no line grouping,
//! jump rule, planar check, triangles or numpy (docs/benchmarks/peers.md, "The floor").
//!
//! ```text
//! cargo bench -p scanmesh-core --bench strips_kernel -- [points] [runs]
//! ```
//! Runs the filtered kernel (the default) and the exact one (`set_strip_filter(false)`)
//! alternating, prints the best and median CPU seconds of each (thread CPU time, which
//! survives a shared machine better than wall time), their ratio, the filter's counters
//! (strips, decisions taken from cheap values, fallbacks to the exact DP) and whether the
//! paths are the same. Defaults: 1,000,000 points, 5 runs.

use scanmesh_core::glam::DVec3;
use scanmesh_core::strips::fuchs::{lookahead, shortest_path_banded, Solution, DEFAULT_BAND};
use scanmesh_core::strips::fuchs::{set_strip_filter, strip_filter_counts};
use std::hint::black_box;

#[path = "strip_scan.rs"]
mod strip_scan;
use strip_scan::{height_scan, DEFAULT_WEIGHT};

/// CPU seconds this thread has used (Linux: /proc/thread-self/stat, clock ticks of 10 ms
/// are too coarse; schedstat gives nanoseconds).
fn thread_cpu() -> f64 {
    let s = std::fs::read_to_string("/proc/thread-self/schedstat").expect("schedstat");
    let ns: f64 = s.split_whitespace().next().unwrap().parse().unwrap();
    ns * 1e-9
}

/// Every strip's solution under the current filter setting, and the CPU seconds.
fn run(lines: &[Vec<DVec3>], greedy: bool) -> (Vec<Solution>, f64) {
    let t0 = thread_cpu();
    let out: Vec<Solution> = lines
        .windows(2)
        .map(|p| {
            if greedy {
                lookahead(&p[0], &p[1], DEFAULT_WEIGHT, 1).unwrap()
            } else {
                shortest_path_banded(&p[0], &p[1], DEFAULT_WEIGHT, DEFAULT_BAND).unwrap()
            }
        })
        .collect();
    (black_box(out), thread_cpu() - t0)
}

fn main() {
    let args: Vec<String> = std::env::args()
        .skip(1)
        .filter(|a| !a.starts_with("--"))
        .collect();
    let n: usize = args
        .first()
        .map_or(1_000_000, |s| s.parse().expect("points"));
    let runs: usize = args.get(1).map_or(5, |s| s.parse().expect("runs"));
    let (points, _, ids) = height_scan(n);
    let mut lines: Vec<Vec<DVec3>> = Vec::new();
    for (p, &id) in points.iter().zip(&ids) {
        if lines.len() as i64 <= id {
            lines.push(Vec::new());
        }
        lines[id as usize].push(*p);
    }
    println!(
        "{} points, {} strips, {runs} runs each, alternating",
        points.len(),
        lines.len() - 1
    );
    for (name, greedy) in [("shortest-path", false), ("lookahead α=1", true)] {
        let mut times = [Vec::new(), Vec::new()];
        let mut same = true;
        for _ in 0..runs {
            set_strip_filter(false);
            let (exact, t) = run(&lines, greedy);
            times[0].push(t);
            set_strip_filter(true);
            strip_filter_counts(true);
            let (filtered, t) = run(&lines, greedy);
            times[1].push(t);
            same &= exact == filtered;
        }
        let counts = strip_filter_counts(true);
        for t in &mut times {
            t.sort_by(f64::total_cmp);
        }
        let (e, f) = (times[0][runs / 2], times[1][runs / 2]);
        println!(
            "{name}: exact {:.3} s (best {:.3}), filtered {:.3} s (best {:.3}), ratio {:.3}; \
             same paths and costs: {same}; last run: {counts:?}",
            e,
            times[0][0],
            f,
            times[1][0],
            f / e
        );
    }
}
