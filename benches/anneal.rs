//! Annealing throughput on the embedded ~14,000-point connecting-rod scan.
//!
//! `cargo bench --bench anneal`. Groups (each twice: timed by wall clock, and by thread CPU
//! time with the prefix `cpu_`, the figure to quote on a loaded machine):
//! - `proposals`: Metropolis proposals per second at the start temperature (hot) and at the
//!   end of the schedule (cold: uphill moves are rejected, coplanar ties still flip);
//! - `six_corner_angles`: the floor of a proposal's cost: the six new corner angles of a proposal
//!   alone, for the same random edges, with no convexity test, energy or bookkeeping;
//! - `tiles` (wall clock only): the sustained hot rate of one chain annealed in stripes at
//!   once ([`TiledAnnealer`], phase changes included): on the rod in 1, 2, 4 and 8 stripes
//!   on the rayon pool (the ratio to 1 stripe is the multi-core speed-up of one run), and
//!   on the 1M grid in 1 and 64 stripes on one thread (what smaller pieces do for cache
//!   locality alone) and in 64 on the pool;
//! - `scaling`: the sustained hot rate on one synthetic surface (a jittered grid over a
//!   gently curved height field) at about 14,000 and 1,000,000 points, to show how much
//!   memory locality costs once the state (about 200 MB at 1M) outgrows the caches.

use criterion::measurement::{Measurement, ValueFormatter, WallTime};
use criterion::{criterion_group, criterion_main, BenchmarkId, Criterion, Throughput};
use scanmesh_core::geometry::triangle_angles;
use scanmesh_core::glam::DVec3;
use scanmesh_core::mesh::prev;
use scanmesh_core::optimize::TacState;
use scanmesh_core::optimize::TiledAnnealer;
use scanmesh_core::optimize::{AnnealParams, Annealer};
use scanmesh_core::projection::{project, Plane};
use scanmesh_core::triangulate::delaunay;
use scanmesh_core::triangulate::{median_spacing, trim_long_edges, DEFAULT_MAX_EDGE_FACTOR};
use std::hint::black_box;
use std::time::Duration;

#[path = "demo_scan.rs"]
mod demo_scan;
#[path = "jitter.rs"]
mod jitter;

/// The rod's trimmed Delaunay triangulation seen along y, as the Python layer builds it.
fn rod_state() -> TacState {
    trimmed_state(&demo_scan::demo_points())
}

/// Trimmed Delaunay triangulation of `points` seen along y, relabelled in Z-order. O(n log n).
fn trimmed_state(points: &[DVec3]) -> TacState {
    let uv = project(points, Plane::Axis(1)).unwrap().uv;
    let d = delaunay(&uv).unwrap();
    let max_edge = DEFAULT_MAX_EDGE_FACTOR
        * median_spacing(&uv, &d.triangles).expect("the rod fits in memory");
    let triangles = trim_long_edges(&uv, &d.triangles, max_edge, None).unwrap();
    TacState::from_input(points, &uv, triangles, 1.0).unwrap().0
}

const CHUNK: usize = 100_000;

fn proposals<M: Measurement>(c: &mut Criterion<M>, prefix: &str) {
    let state = rod_state();
    let mut group = c.benchmark_group(format!("{prefix}proposals"));
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
                state.uv().unwrap(),
                state.xyz().unwrap(),
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

fn six_corner_angles<M: Measurement>(c: &mut Criterion<M>, prefix: &str) {
    let state = rod_state();
    let mesh = state.mesh();
    let xyz = state.xyz().unwrap();
    let edges = mesh.interior_edges().unwrap();
    let mut s = 1u64;
    let picks: Vec<u32> = (0..CHUNK)
        .map(|_| {
            s = s
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            edges[((s >> 33) as usize) % edges.len()]
        })
        .collect();
    let mut group = c.benchmark_group(format!("{prefix}six_corner_angles"));
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

/// About `n` points on a jittered square grid over the unit square (x, z), with height
/// y = 0.1 sin(3x) cos(2z) + 0.05 xz: gently curved everywhere, so no flip is a coplanar
/// tie and every proposal computes its six angles. The same surface at every size; the
/// jitter (±15 % of the spacing, a fixed LCG) keeps Delaunay free of cocircular ties.
fn grid_points(n: usize) -> Vec<DVec3> {
    let side = (n as f64).sqrt().round() as usize;
    let mut jitter = jitter::jitter(12_345, 0.3);
    let mut points = Vec::with_capacity(side * side);
    for j in 0..side {
        for i in 0..side {
            let x = (i as f64 + jitter()) / side as f64;
            let z = (j as f64 + jitter()) / side as f64;
            let y = 0.1 * (3.0 * x).sin() * (2.0 * z).cos() + 0.05 * x * z;
            points.push(DVec3::new(x, y, z));
        }
    }
    points
}

fn tiles(c: &mut Criterion) {
    let mut group = c.benchmark_group("tiles");
    group.throughput(Throughput::Elements(CHUNK as u64));
    group.sample_size(20);
    let one_thread = rayon::ThreadPoolBuilder::new()
        .num_threads(1)
        .build()
        .unwrap();
    let rod = rod_state();
    let grid = trimmed_state(&grid_points(1_000_000));
    let cases = [
        ("rod_14k", &rod, 1, false),
        ("rod_14k", &rod, 2, false),
        ("rod_14k", &rod, 4, false),
        ("rod_14k", &rod, 8, false),
        ("grid_1M", &grid, 1, true),
        ("grid_1M", &grid, 64, true),
        ("grid_1M", &grid, 64, false),
    ];
    for (name, state, tiles, serial) in cases {
        let params = AnnealParams {
            sweeps: usize::MAX / 2,
            final_temperature_ratio: 1.0,
            patience: 0,
            tiles,
            ..AnnealParams::default()
        };
        let mut annealer = TiledAnnealer::new(state.clone(), params).unwrap();
        let threads = if serial { "1_thread" } else { "pool" };
        // A call runs each tile up to its budget and returns at a phase's end, so the count
        // per call varies: time whole calls and scale to CHUNK proposals.
        let id = BenchmarkId::new(format!("{name}/{threads}"), tiles);
        group.bench_function(id, |b| {
            b.iter_custom(|iters| {
                let target = iters as usize * CHUNK;
                let started = std::time::Instant::now();
                let mut ran = 0;
                let mut step = |a: &mut TiledAnnealer| {
                    while ran < target {
                        ran += a
                            .advance_until((target - ran).div_ceil(tiles), None)
                            .expect("the bench's tiles fit in memory");
                    }
                };
                if serial {
                    one_thread.install(|| step(&mut annealer));
                } else {
                    step(&mut annealer);
                }
                started.elapsed().mul_f64(target as f64 / ran as f64)
            })
        });
    }
    group.finish();
}

fn scaling<M: Measurement>(c: &mut Criterion<M>, prefix: &str) {
    let mut group = c.benchmark_group(format!("{prefix}scaling"));
    group.throughput(Throughput::Elements(CHUNK as u64));
    group.sample_size(20);
    for (name, n) in [("grid_14k", 14_000), ("grid_1M", 1_000_000)] {
        // Setup (points, Delaunay, trimming, Z-order, calibration) stays outside the timing;
        // one sweep first, so both sizes are measured in the same kind of state.
        let params = AnnealParams {
            sweeps: usize::MAX / 2,
            final_temperature_ratio: 1.0,
            patience: 0,
            ..AnnealParams::default()
        };
        let state = trimmed_state(&grid_points(n));
        let mut annealer = Annealer::new(state, params).unwrap();
        annealer.advance(annealer.sweep_len());
        group.bench_function(BenchmarkId::new("hot", name), |b| {
            b.iter(|| black_box(annealer.advance(CHUNK)))
        });
    }
    group.finish();
}

/// Thread CPU time, read from `/proc/thread-self/schedstat` (nanoseconds the thread has
/// run; Linux). Why: the bench machine is shared, and wall time there measures the loop's
/// share of the cores as much as its cost. The kernel updates the figure at scheduler
/// ticks, so one reading can lag by a few ms; criterion's samples of 100+ ms keep that to
/// a few percent. Where the file is missing every reading is 0 (use the wall-time groups).
struct ThreadCpu;

fn thread_cpu_ns() -> u64 {
    std::fs::read_to_string("/proc/thread-self/schedstat")
        .ok()
        .and_then(|s| s.split_whitespace().next()?.parse().ok())
        .unwrap_or(0)
}

/// Formats CPU durations like wall durations.
static WALL: WallTime = WallTime;

impl Measurement for ThreadCpu {
    type Intermediate = u64;
    type Value = Duration;
    fn start(&self) -> u64 {
        thread_cpu_ns()
    }
    fn end(&self, started: u64) -> Duration {
        Duration::from_nanos(thread_cpu_ns().saturating_sub(started))
    }
    fn add(&self, a: &Duration, b: &Duration) -> Duration {
        *a + *b
    }
    fn zero(&self) -> Duration {
        Duration::ZERO
    }
    fn to_f64(&self, value: &Duration) -> f64 {
        value.as_nanos() as f64
    }
    fn formatter(&self) -> &dyn ValueFormatter {
        WALL.formatter()
    }
}

fn wall(c: &mut Criterion) {
    proposals(c, "");
    six_corner_angles(c, "");
    tiles(c);
    scaling(c, "");
}

/// The same groups timed by thread CPU time, prefixed `cpu_`.
fn cpu(c: &mut Criterion<ThreadCpu>) {
    proposals(c, "cpu_");
    six_corner_angles(c, "cpu_");
    scaling(c, "cpu_");
}

criterion_group!(wall_time, wall);
criterion_group! {
    name = cpu_time;
    config = Criterion::default().with_measurement(ThreadCpu);
    targets = cpu
}
criterion_main!(wall_time, cpu_time);
