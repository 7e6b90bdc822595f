//! Annealing throughput on the embedded ~14,000-point connecting-rod scan.
//!
//! `cargo bench --bench anneal`. Groups:
//! - `proposals`: Metropolis proposals per second at the start temperature (hot) and at the
//!   end of the schedule (cold, where almost every proposal is rejected);
//! - `six_corner_angles`: the floor the issue names: the six new corner angles of a proposal
//!   alone, for the same random edges, with no convexity test, energy or bookkeeping.

use criterion::{criterion_group, criterion_main, BenchmarkId, Criterion, Throughput};
use scanmesh_core::anneal::{AnnealParams, Annealer};
use scanmesh_core::delaunay::delaunay;
use scanmesh_core::geometry::triangle_angles;
use scanmesh_core::mesh::prev;
use scanmesh_core::projection::{project, Plane};
use scanmesh_core::tac_state::TacState;
use scanmesh_core::trim::{median_spacing, trim_long_edges, DEFAULT_MAX_EDGE_FACTOR};
use std::hint::black_box;

#[path = "demo_scan.rs"]
mod demo_scan;

/// The rod's trimmed Delaunay triangulation seen along y, as the Python layer builds it.
fn rod_state() -> TacState {
    let points = demo_scan::demo_points();
    let uv = project(&points, Plane::Axis(1)).unwrap().uv;
    let d = delaunay(&uv).unwrap();
    let max_edge = DEFAULT_MAX_EDGE_FACTOR * median_spacing(&uv, &d.triangles);
    let triangles = trim_long_edges(&uv, &d.triangles, max_edge).unwrap();
    TacState::from_input(&points, &uv, &triangles, 1.0)
        .unwrap()
        .0
}

const CHUNK: usize = 100_000;

fn proposals(c: &mut Criterion) {
    let state = rod_state();
    let mut group = c.benchmark_group("proposals");
    group.throughput(Throughput::Elements(CHUNK as u64));
    group.sample_size(30);
    for (name, ratio) in [("hot", 1.0), ("cold", 1e-4)] {
        // A flat schedule at T0 (hot) or at T0 x 1e-4 (cold), reached by a one-sweep run.
        let params = AnnealParams {
            sweeps: usize::MAX / 2,
            final_temperature_ratio: 1.0,
            patience: 0,
            ..AnnealParams::default()
        };
        let mut annealer = Annealer::new(state.clone(), params.clone()).unwrap();
        if ratio < 1.0 {
            let cold = AnnealParams {
                sweeps: 200,
                final_temperature_ratio: ratio,
                ..params
            };
            let mut warmup = Annealer::new(state.clone(), cold).unwrap();
            while !warmup.is_done() {
                warmup.advance(usize::MAX);
            }
            let finished = warmup.finish().unwrap();
            let s = TacState::new(
                finished.mesh,
                state.uv().to_vec(),
                state.xyz().to_vec(),
                1.0,
            )
            .unwrap();
            let frozen = AnnealParams {
                initial_acceptance: 1e-6,
                ..params
            };
            annealer = Annealer::new(s, frozen).unwrap();
        }
        group.bench_function(BenchmarkId::new("rod_14k", name), |b| {
            b.iter(|| black_box(annealer.advance(CHUNK)))
        });
    }
    group.finish();
}

fn six_corner_angles(c: &mut Criterion) {
    let state = rod_state();
    let mesh = state.mesh();
    let xyz = state.xyz();
    let edges = mesh.interior_edges();
    let mut s = 1u64;
    let picks: Vec<u32> = (0..CHUNK)
        .map(|_| {
            s = s
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            edges[((s >> 33) as usize) % edges.len()]
        })
        .collect();
    let mut group = c.benchmark_group("six_corner_angles");
    group.throughput(Throughput::Elements(CHUNK as u64));
    group.sample_size(30);
    group.bench_function("rod_14k", |b| {
        b.iter(|| {
            let mut total = 0.0;
            for &h in &picks {
                let t = mesh.twin(h);
                let [_, _, c, d] = [
                    mesh.start(h),
                    mesh.start(t),
                    mesh.start(prev(h)),
                    mesh.start(prev(t)),
                ];
                let (a, b) = (mesh.start(h), mesh.start(t));
                let [p, q, r, w] = [a, b, c, d].map(|v| xyz[v as usize]);
                let x = triangle_angles(w, r, p);
                let y = triangle_angles(r, w, q);
                total += x[0] + x[1] + x[2] + y[0] + y[1] + y[2];
            }
            black_box(total)
        })
    });
    group.finish();
}

criterion_group!(benches, proposals, six_corner_angles);
criterion_main!(benches);
