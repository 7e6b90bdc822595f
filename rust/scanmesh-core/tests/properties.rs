//! Property tests (proptest) of the core's invariants over awkward point sets: duplicates,
//! collinear runs, regular grids (every cell cocircular), clusters, and scales from 1e-300
//! to 1e300. Each property runs `CASES` cases so the file stays fast in CI.
//!
//! Properties: nothing panics; Delaunay, trimming, LOP, annealing and random flip sequences
//! keep `HalfEdgeMesh::validate`; every input point is a vertex, a reported duplicate or
//! trimmed away; the incremental tac energy equals a full recomputation; strip meshes are
//! valid wherever the lines do not cross, and account for every point.

use proptest::prelude::*;
use scanmesh_core::geometry::{normalize_plane, unit_square};
use scanmesh_core::glam::DVec3;
use scanmesh_core::mesh::{HalfEdgeMesh, NONE};
use scanmesh_core::optimize::{tac_lop, AnnealParams, Annealer, Detail, TacOrder, TacState};
use scanmesh_core::strips::{segment_lines, stitch, Method, StripParams, DEFAULT_GAP_FACTOR};
use scanmesh_core::triangulate::{
    delaunay, median_spacing, trim_long_edges, DEFAULT_MAX_EDGE_FACTOR,
};
use scanmesh_core::Error;

const CASES: u32 = 64;

/// A small deterministic generator, so a case is fully described by its seed.
struct Lcg(u64);

impl Lcg {
    fn unit(&mut self) -> f64 {
        self.0 = self
            .0
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        (self.0 >> 11) as f64 / (1u64 << 53) as f64
    }
    fn below(&mut self, n: usize) -> usize {
        ((self.unit() * n as f64) as usize).min(n - 1)
    }
}

/// The kinds of point sets the properties range over.
#[derive(Debug, Clone, Copy)]
enum Kind {
    Random,
    WithDuplicates,
    CollinearRun,
    Grid,
    Clusters,
}

fn kind() -> impl Strategy<Value = Kind> {
    prop_oneof![
        Just(Kind::Random),
        Just(Kind::WithDuplicates),
        Just(Kind::CollinearRun),
        Just(Kind::Grid),
        Just(Kind::Clusters),
    ]
}

fn scale() -> impl Strategy<Value = f64> {
    prop_oneof![Just(1.0), Just(1e-300), Just(1e-9), Just(1e9), Just(1e300)]
}

/// A height field z = f(x, y) at planar positions of the given kind, times `scale`.
fn points(kind: Kind, n: usize, seed: u64, scale: f64) -> Vec<DVec3> {
    let mut r = Lcg(seed);
    let mut xy: Vec<[f64; 2]> = Vec::with_capacity(n);
    match kind {
        Kind::Random => (0..n).for_each(|_| xy.push([r.unit(), r.unit()])),
        Kind::WithDuplicates => {
            for k in 0..n {
                if k > 0 && r.unit() < 0.3 {
                    let p = xy[r.below(k)];
                    // exact repeat or a near-duplicate 1e-12 away
                    let e = if r.unit() < 0.5 { 0.0 } else { 1e-12 };
                    xy.push([p[0] + e, p[1]]);
                } else {
                    xy.push([r.unit(), r.unit()]);
                }
            }
        }
        Kind::CollinearRun => {
            let run = n.saturating_sub(3).max(1);
            for k in 0..run {
                let t = k as f64 / run as f64;
                xy.push([t, 0.3 + 0.4 * t]);
            }
            while xy.len() < n {
                xy.push([r.unit(), r.unit()]);
            }
        }
        Kind::Grid => {
            let side = ((n as f64).sqrt().ceil() as usize).max(2);
            for k in 0..n.max(4) {
                xy.push([(k % side) as f64 * 0.1, (k / side) as f64 * 0.1]);
            }
        }
        Kind::Clusters => {
            let centres: Vec<[f64; 2]> = (0..3).map(|_| [r.unit(), r.unit()]).collect();
            for _ in 0..n {
                let c = centres[r.below(3)];
                xy.push([c[0] + 1e-4 * r.unit(), c[1] + 1e-4 * r.unit()]);
            }
        }
    }
    xy.iter()
        .map(|&[x, y]| {
            let z = 0.3 * (6.0 * x).sin() * (4.0 * y).cos() + 0.2 * x * x;
            DVec3::new(x, y, z) * scale
        })
        .collect()
}

fn planar(points: &[DVec3]) -> Vec<[f64; 2]> {
    points.iter().map(|p| [p.x, p.y]).collect()
}

/// Delaunay of the planar positions; `None` for the honest refusals (too few distinct
/// points, all collinear), which are the only errors allowed.
fn triangulate(uv: &[[f64; 2]]) -> Option<scanmesh_core::triangulate::Delaunay> {
    match delaunay(uv) {
        Ok(d) => Some(d),
        Err(Error::TooFewPoints { .. }) | Err(Error::Collinear { .. }) => None,
        Err(e) => panic!("unexpected error {e}"),
    }
}

fn used(n: usize, triangles: &[[u32; 3]]) -> Vec<bool> {
    let mut u = vec![false; n];
    triangles
        .iter()
        .flatten()
        .for_each(|&v| u[v as usize] = true);
    u
}

proptest! {
    #![proptest_config(ProptestConfig { cases: CASES, failure_persistence: None, ..ProptestConfig::default() })]

    #[test]
    fn delaunay_and_trimming_are_valid_and_lose_no_point(
        kind in kind(), n in 3usize..90, seed in any::<u64>(), scale in scale(),
    ) {
        let pts = points(kind, n, seed, scale);
        let uv = planar(&pts);
        let Some(d) = triangulate(&uv) else { return Ok(()) };
        let unit = unit_square(&uv);
        let mesh = HalfEdgeMesh::from_triangles(uv.len(), &d.triangles).unwrap();
        mesh.validate(&unit).unwrap();
        // every point: a vertex, or a duplicate of a vertex at the same (unit) position
        let vertex = used(uv.len(), &d.triangles);
        for (i, &k) in d.duplicate_of.iter().enumerate() {
            if k == NONE {
                prop_assert!(vertex[i], "point {i} is neither a vertex nor a duplicate");
            } else {
                prop_assert!(vertex[k as usize] && unit[i] == unit[k as usize]);
            }
        }
        let limit = DEFAULT_MAX_EDGE_FACTOR * median_spacing(&uv, &d.triangles).unwrap();
        let trimmed = trim_long_edges(&uv, &d.triangles, limit, None).unwrap();
        prop_assert!(trimmed.iter().all(|t| d.triangles.contains(t)));
        HalfEdgeMesh::from_triangles(uv.len(), &trimmed).unwrap().validate(&unit).unwrap();
    }

    #[test]
    fn random_flips_keep_the_mesh_valid_and_the_energy_exact(
        kind in kind(), n in 4usize..70, seed in any::<u64>(), scale in scale(),
        p in prop_oneof![Just(1.0), Just(2.0), Just(3.5)], flips in 0usize..300,
    ) {
        let pts = points(kind, n, seed, scale);
        let uv = planar(&pts);
        let Some(d) = triangulate(&uv) else { return Ok(()) };
        let (mut state, _) = TacState::from_input(&pts, &uv, d.triangles.clone(), p).unwrap();
        let before = used(state.mesh().n_vertices(), &state.mesh().triangles().unwrap());
        let mut r = Lcg(seed ^ 0x5eed);
        let edges = state.mesh().n_half_edges();
        for _ in 0..flips {
            let h = r.below(edges) as u32;
            if let Some(mv) = state.evaluate(h, Detail::Shape) {
                state.apply(&mv);
            }
        }
        state.mesh().validate(&state.uv().unwrap()).unwrap();
        let (inc, full) = (state.energy(), state.energy_from_scratch());
        prop_assert!((inc - full).abs() <= 1e-9 * full.max(1.0), "incremental {inc} vs {full}");
        prop_assert_eq!(before, used(state.mesh().n_vertices(), &state.mesh().triangles().unwrap()));
    }

    #[test]
    fn a_flip_twice_is_the_identity(kind in kind(), n in 4usize..60, seed in any::<u64>()) {
        let pts = points(kind, n, seed, 1.0);
        let uv = planar(&pts);
        let Some(d) = triangulate(&uv) else { return Ok(()) };
        let unit = unit_square(&uv);
        let mut mesh = HalfEdgeMesh::from_triangles(uv.len(), &d.triangles).unwrap();
        let canon = |m: &HalfEdgeMesh| {
            let mut t: Vec<[u32; 3]> = m.triangles().unwrap().into_iter().map(|mut t| {
                let k = (0..3).min_by_key(|&k| t[k]).unwrap();
                t.rotate_left(k);
                t
            }).collect();
            t.sort_unstable();
            t
        };
        let original = canon(&mesh);
        for h in mesh.interior_edges().unwrap() {
            if mesh.can_flip(h, &unit) {
                mesh.flip(h);
                mesh.validate(&unit).unwrap();
                mesh.flip(h);
                prop_assert_eq!(canon(&mesh), original.clone());
            }
        }
        mesh.validate(&unit).unwrap();
    }

    #[test]
    fn lop_and_short_annealing_keep_the_mesh_valid(
        kind in kind(), n in 4usize..70, seed in any::<u64>(), scale in scale(),
    ) {
        let pts = points(kind, n, seed, scale);
        let uv = planar(&pts);
        let Some(d) = triangulate(&uv) else { return Ok(()) };
        let limit = DEFAULT_MAX_EDGE_FACTOR * median_spacing(&uv, &d.triangles).unwrap();
        let trimmed = trim_long_edges(&uv, &d.triangles, limit, None).unwrap();
        let (mut state, _) = TacState::from_input(&pts, &uv, trimmed.clone(), 1.0).unwrap();
        let vertices = used(uv.len(), &state.mesh().triangles().unwrap());
        let order = TacOrder { tie_tolerance: 1e-10, sliver_guard: true, planar_ties: false, sliver_angle: 0.0, min_facing: 0.0 };
        tac_lop(&mut state, order).unwrap();
        state.mesh().validate(&state.uv().unwrap()).unwrap();
        let full = state.energy_from_scratch();
        prop_assert!((state.energy() - full).abs() <= 1e-9 * full.max(1.0));
        let plane = state.uv().unwrap();
        let params = AnnealParams { sweeps: 4, seed, calibration_samples: 64, ..AnnealParams::default() };
        let mut annealer = Annealer::new(state, params).unwrap();
        while !annealer.is_done() {
            annealer.advance(1000);
        }
        let result = annealer.finish().unwrap();
        result.mesh.validate(&plane).unwrap();
        prop_assert!(result.energy <= result.initial_energy + 1e-9 * result.initial_energy.max(1.0));
        prop_assert_eq!(vertices, used(uv.len(), &result.mesh.triangles().unwrap()));
    }

    #[test]
    fn strips_of_scan_lines_are_valid_and_lose_no_point(
        rows in 2usize..7, cols in 2usize..14, seed in any::<u64>(), scale in scale(),
        zigzag in any::<bool>(), jitter in prop_oneof![Just(0.0), Just(0.2)],
        repeats in 0usize..4, lookahead in any::<bool>(),
    ) {
        let mut r = Lcg(seed);
        let (mut pts, mut ids) = (Vec::new(), Vec::new());
        for row in 0..rows {
            // lines of unequal length, with jitter along the line only (they never cross)
            let len = (cols as i64 + r.below(5) as i64 - 2).max(1) as usize;
            for c in 0..len {
                let c = if zigzag && row % 2 == 1 { len - 1 - c } else { c };
                let x = c as f64 + jitter * (r.unit() - 0.5);
                let y = row as f64 * 1.3;
                pts.push(DVec3::new(x, y, 0.2 * (x / 3.0).sin() * (y / 2.0).cos()) * scale);
                ids.push(row as i64);
            }
        }
        for _ in 0..repeats {
            // a point scanned twice in a row
            let k = r.below(pts.len());
            pts.insert(k + 1, pts[k]);
            ids.insert(k + 1, ids[k]);
        }
        let uv = planar(&pts);
        let scan = segment_lines(&uv, &ids, DEFAULT_GAP_FACTOR).unwrap();
        let params = StripParams {
            method: if lookahead { Method::Lookahead(1 + r.below(4)) } else { StripParams::default().method },
            ..StripParams::default()
        };
        let mesh = stitch(&pts, &uv, &scan, &params).unwrap();
        prop_assert!(mesh.planar_error.is_none(), "{:?}", mesh.planar_error);
        let (unit, _) = normalize_plane(&uv);
        if !mesh.triangles.is_empty() {
            HalfEdgeMesh::from_triangles(pts.len(), &mesh.triangles).unwrap().validate(&unit).unwrap();
        }
        let vertex = used(pts.len(), &mesh.triangles);
        for (k, &v) in vertex.iter().enumerate() {
            prop_assert!(v != mesh.unused.contains(&(k as u32)), "point {k}");
        }
        for &(dup, of) in &scan.duplicates {
            prop_assert!(!vertex[dup as usize] && uv[dup as usize] == uv[of as usize]);
        }
    }
}

/// Strips never panic on arbitrary line ids: crossing lines are reported, not hidden.
#[test]
fn strips_with_scrambled_line_ids_report_instead_of_panicking() {
    let mut runner = proptest::test_runner::TestRunner::new(ProptestConfig {
        cases: CASES,
        failure_persistence: None,
        ..ProptestConfig::default()
    });
    runner
        .run(&(any::<u64>(), 3usize..60, 1i64..6), |(seed, n, n_ids)| {
            let mut r = Lcg(seed);
            let pts = points(Kind::Random, n, seed, 1.0);
            let ids: Vec<i64> = (0..n).map(|_| r.below(n_ids as usize) as i64).collect();
            let uv = planar(&pts);
            let scan = segment_lines(&uv, &ids, DEFAULT_GAP_FACTOR).unwrap();
            let mesh = stitch(&pts, &uv, &scan, &StripParams::default()).unwrap();
            if mesh.planar_error.is_none() && !mesh.triangles.is_empty() {
                let (unit, _) = normalize_plane(&uv);
                HalfEdgeMesh::from_triangles(n, &mesh.triangles)
                    .unwrap()
                    .validate(&unit)
                    .unwrap();
            }
            Ok(())
        })
        .unwrap();
}

/// Fuzz finding `fuzz/artifacts/fuchs/crash-ef0a4d08…` (weight length 1 + area 3 + angle 3,
/// band 1): a 2 × 4 matrix of random points where the banded DP used to return a path 3x
/// the optimum (its band could not see the optimum; it now widens until it proves it).
fn fuzz_fuchs_ef0a4d08() -> (Vec<DVec3>, Vec<DVec3>, scanmesh_core::strips::fuchs::Weight) {
    let bytes: [u8; 19] = [
        0x0a, 0x0e, 0x80, 0x00, 0x00, 0x0e, 0x00, 0x00, 0x08, 0xb7, 0xee, 0x25, 0x0a, 0x25, 0x0a,
        0x25, 0x48, 0x48, 0x00,
    ];
    let xyz: Vec<DVec3> = bytes
        .chunks_exact(3)
        .map(|c| {
            DVec3::new(
                c[0] as f64 % 17.0,
                c[1] as f64 % 17.0,
                (c[2] as f64 - 128.0) / 16.0,
            )
        })
        .collect();
    let w = scanmesh_core::strips::fuchs::Weight {
        length: 1.0,
        area: 3.0,
        angle: 3.0,
        dihedral: 0.0,
    };
    (xyz[..2].to_vec(), xyz[2..].to_vec(), w)
}

#[test]
fn fuzz_fuchs_ef0a4d08_dp_and_dijkstra_agree_banded_is_a_path() {
    use scanmesh_core::strips::fuchs::*;
    let (a, b, w) = fuzz_fuchs_ef0a4d08();
    let dp = shortest_path_dp(&a, &b, w).unwrap();
    let dijkstra = shortest_path_dijkstra(&a, &b, w).unwrap();
    assert!((dp.cost - dijkstra.cost).abs() <= 1e-9 * dp.cost.max(1.0));
    let banded = shortest_path_banded(&a, &b, w, 1).unwrap();
    assert!(banded.cost >= dp.cost - 1e-9 * dp.cost.max(1.0));
    let cost = path_cost(&a, &b, w, &banded.path).unwrap();
    assert!((cost - banded.cost).abs() <= 1e-9 * cost.max(1.0));
}

#[test]
fn fuzz_fuchs_ef0a4d08_banded_finds_the_optimum() {
    use scanmesh_core::strips::fuchs::*;
    let (a, b, w) = fuzz_fuchs_ef0a4d08();
    let dp = shortest_path_dp(&a, &b, w).unwrap();
    let banded = shortest_path_banded(&a, &b, w, 1).unwrap();
    assert!((dp.cost - banded.cost).abs() <= 1e-9 * dp.cost.max(1.0));
}
