//! Strips against spade's Delaunay on the same points, and the path solvers on one scan.
//!
//! `cargo bench --bench strips`. Groups:
//! - `strips_vs_delaunay/{10000,100000,1000000}`: a line scan of a smooth height field
//!   (square, jittered); `strips` is `segment_lines` + `stitch` with the default weight
//!   (angle + 0.3 dihedral), banded shortest path and the planar check; `strips_unchecked`
//!   the same without the check; `strips_length` with the length weight, unchecked;
//!   `delaunay` is spade's bulk load through `scanmesh_core::triangulate::delaunay` (no trimming);
//! - `strips_threads/{1,2}`: `strips_unchecked` at 1M points on a rayon pool of 1 and of 2
//!   threads (the target is a 2-core speed-up of at least 1.8: the strips are independent);
//! - `solvers`: every solver and look-ahead depth on the embedded ~14,000-point rod scan.

use criterion::{criterion_group, criterion_main, BenchmarkId, Criterion, Throughput};
use scanmesh_core::projection::{project, Plane};
use scanmesh_core::strips::fuchs::{Solver, Weight, DEFAULT_BAND};
use scanmesh_core::strips::{detect_lines, segment_lines, DEFAULT_GAP_FACTOR};
use scanmesh_core::strips::{stitch, Method, StripParams};
use scanmesh_core::triangulate::delaunay;
use scanmesh_core::triangulate::DEFAULT_JUMP_FACTOR;
use std::hint::black_box;
use std::time::Duration;

#[path = "demo_scan.rs"]
mod demo_scan;
#[path = "strip_scan.rs"]
mod strip_scan;
use strip_scan::{height_scan, DEFAULT_WEIGHT};

fn strips_vs_delaunay(c: &mut Criterion) {
    let mut group = c.benchmark_group("strips_vs_delaunay");
    group.sample_size(10);
    group.measurement_time(Duration::from_secs(15));
    for n in [10_000, 100_000, 1_000_000] {
        let (points, uv, ids) = height_scan(n);
        group.throughput(Throughput::Elements(points.len() as u64));
        let banded = Method::ShortestPath(Solver::Banded(DEFAULT_BAND));
        let variants = [
            ("strips", DEFAULT_WEIGHT, true),
            ("strips_unchecked", DEFAULT_WEIGHT, false),
            ("strips_length", Weight::LENGTH, false),
        ];
        for (name, weight, check) in variants {
            let params = StripParams {
                weight,
                method: banded,
                check,
                jump_factor: DEFAULT_JUMP_FACTOR,
            };
            group.bench_with_input(BenchmarkId::new(name, n), &n, |b, _| {
                b.iter(|| {
                    let scan = segment_lines(&uv, &ids, DEFAULT_GAP_FACTOR).unwrap();
                    black_box(stitch(&points, &uv, &scan, &params).unwrap())
                })
            });
        }
        group.bench_with_input(BenchmarkId::new("delaunay", n), &n, |b, _| {
            b.iter(|| black_box(delaunay(&uv).unwrap()))
        });
    }
    group.finish();
}

fn strips_threads(c: &mut Criterion) {
    let mut group = c.benchmark_group("strips_threads");
    group.sample_size(10);
    group.measurement_time(Duration::from_secs(15));
    let (points, uv, ids) = height_scan(1_000_000);
    let params = StripParams {
        weight: DEFAULT_WEIGHT,
        method: Method::ShortestPath(Solver::Banded(DEFAULT_BAND)),
        check: false,
        jump_factor: DEFAULT_JUMP_FACTOR,
    };
    for threads in [1, 2] {
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .unwrap();
        group.bench_with_input(BenchmarkId::from_parameter(threads), &threads, |b, _| {
            b.iter(|| {
                pool.install(|| {
                    let scan = segment_lines(&uv, &ids, DEFAULT_GAP_FACTOR).unwrap();
                    black_box(stitch(&points, &uv, &scan, &params).unwrap())
                })
            })
        });
    }
    group.finish();
}

fn solvers(c: &mut Criterion) {
    let points = demo_scan::demo_points();
    let uv = project(&points, Plane::Axis(1)).unwrap().uv;
    let ids: Vec<i64> = detect_lines(&uv, DEFAULT_GAP_FACTOR)
        .unwrap()
        .into_iter()
        .map(i64::from)
        .collect();
    let scan = segment_lines(&uv, &ids, DEFAULT_GAP_FACTOR).unwrap();
    let mut group = c.benchmark_group("solvers");
    group.sample_size(10);
    group.throughput(Throughput::Elements(points.len() as u64));
    let methods = [
        ("banded", Method::ShortestPath(Solver::Banded(DEFAULT_BAND))),
        ("dp", Method::ShortestPath(Solver::Dp)),
        ("dijkstra", Method::ShortestPath(Solver::Dijkstra)),
        ("lookahead_1", Method::Lookahead(1)),
        ("lookahead_3", Method::Lookahead(3)),
        ("lookahead_6", Method::Lookahead(6)),
    ];
    for (name, method) in methods {
        let params = StripParams {
            weight: DEFAULT_WEIGHT,
            method,
            check: false,
            jump_factor: DEFAULT_JUMP_FACTOR,
        };
        group.bench_function(name, |b| {
            b.iter(|| black_box(stitch(&points, &uv, &scan, &params).unwrap()))
        });
    }
    group.finish();
}

criterion_group!(benches, strips_vs_delaunay, strips_threads, solvers);
criterion_main!(benches);
