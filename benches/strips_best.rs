//! Best-of timings of the strips at 1M points, runs alternating, for a shared machine where
//! criterion's means also catch other processes' work (docs/benchmarks/speed.md, "Strips on two
//! threads and the planar check from the strips"). The best of several runs drops the ones
//! another process disturbed; alternating puts both sides under the same conditions.
//!
//! ```text
//! cargo bench -p scanmesh-core --bench strips_best -- threads [points] [runs]
//! cargo bench -p scanmesh-core --bench strips_best -- vs [points] [runs]
//! ```
//! - `threads`: `segment_lines` + `stitch` (default weight, banded shortest path, no planar
//!   check) on rayon pools of 1 and 2 threads alternating: best wall time of each and the
//!   speed-up (the target is at least 1.8 on 2 cores: the strips are independent);
//! - `vs`: the strips with and without the planar check and spade's Delaunay
//!   (`scanmesh_core::triangulate::delaunay`, no trimming) alternating on the global pool: best and
//!   median of each and the ratios (the target: the checked strips take at most half of
//!   spade's time at 1M points, or the strips lose their reason to exist beside Delaunay).
//!
//! Defaults: 1,000,000 points, 10 runs.

use scanmesh_core::strips::fuchs::{Solver, DEFAULT_BAND};
use scanmesh_core::strips::{segment_lines, DEFAULT_GAP_FACTOR};
use scanmesh_core::strips::{stitch, Method, StripParams};
use scanmesh_core::triangulate::delaunay;
use scanmesh_core::triangulate::DEFAULT_JUMP_FACTOR;
use std::hint::black_box;
use std::time::Instant;

#[path = "strip_scan.rs"]
mod strip_scan;
use strip_scan::{height_scan, DEFAULT_WEIGHT};

/// Seconds one call of `f` takes (wall).
fn seconds(f: impl FnOnce()) -> f64 {
    let t0 = Instant::now();
    f();
    t0.elapsed().as_secs_f64()
}

/// Smallest and median of `times` (sorted in place).
fn best_and_median(times: &mut [f64]) -> (f64, f64) {
    times.sort_by(f64::total_cmp);
    (times[0], times[times.len() / 2])
}

fn main() {
    // `cargo bench` passes `--bench` (and criterion-style flags) along: keep the rest.
    let args: Vec<String> = std::env::args()
        .skip(1)
        .filter(|a| !a.starts_with("--"))
        .collect();
    let mode = args.first().map_or("threads", String::as_str);
    let n: usize = args
        .get(1)
        .map_or(1_000_000, |s| s.parse().expect("points"));
    let runs: usize = args.get(2).map_or(10, |s| s.parse().expect("runs"));
    let (points, uv, ids) = height_scan(n);
    let strips = |check: bool| {
        let params = StripParams {
            weight: DEFAULT_WEIGHT,
            method: Method::ShortestPath(Solver::Banded(DEFAULT_BAND)),
            check,
            jump_factor: DEFAULT_JUMP_FACTOR,
        };
        let scan = segment_lines(&uv, &ids, DEFAULT_GAP_FACTOR).unwrap();
        black_box(stitch(&points, &uv, &scan, &params).unwrap());
    };
    println!("{} points, {runs} runs each, alternating", points.len());
    match mode {
        "threads" => {
            let pools: Vec<_> = [1, 2]
                .map(|t| {
                    rayon::ThreadPoolBuilder::new()
                        .num_threads(t)
                        .build()
                        .unwrap()
                })
                .into();
            let mut times = [Vec::new(), Vec::new()];
            for _ in 0..runs {
                for (pool, t) in pools.iter().zip(&mut times) {
                    t.push(seconds(|| pool.install(|| strips(false))));
                }
            }
            let [(one, one_median), (two, two_median)] = times.map(|mut t| best_and_median(&mut t));
            println!("1 thread: best {one:.3} s, median {one_median:.3} s");
            println!("2 threads: best {two:.3} s, median {two_median:.3} s");
            println!(
                "speed-up: {:.2} (best), {:.2} (median)",
                one / two,
                one_median / two_median
            );
        }
        "vs" => {
            let mut times = [Vec::new(), Vec::new(), Vec::new()];
            for _ in 0..runs {
                times[0].push(seconds(|| strips(true)));
                times[1].push(seconds(|| strips(false)));
                times[2].push(seconds(|| {
                    black_box(delaunay(&uv).unwrap());
                }));
            }
            let [checked, unchecked, spade] = times.map(|mut t| best_and_median(&mut t));
            for (name, (best, median)) in [
                ("strips, checked", checked),
                ("strips, unchecked", unchecked),
                ("spade Delaunay", spade),
            ] {
                println!("{name}: best {best:.3} s, median {median:.3} s");
            }
            println!(
                "checked / spade: {:.2} (best), {:.2} (median); unchecked / spade: {:.2}, {:.2}",
                checked.0 / spade.0,
                checked.1 / spade.1,
                unchecked.0 / spade.0,
                unchecked.1 / spade.1
            );
        }
        other => panic!("unknown mode {other:?}: use `threads` or `vs`"),
    }
}
