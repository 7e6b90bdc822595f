use super::*;
use crate::optimize::lop::{lop, tac_lop, TacLop};
use crate::optimize::tac_state::tests::{bumpy_state, plateau_state};
use glam::DVec3;

/// One plain chain run to its end in one call.
pub(crate) fn anneal(state: TacState, params: AnnealParams) -> Result<AnnealResult> {
    let mut run = Annealer::new(state, params)?;
    while !run.is_done() {
        run.advance(usize::MAX);
    }
    run.finish()
}

fn quick(seed: u64) -> AnnealParams {
    AnnealParams {
        sweeps: 60,
        seed,
        chains: 1,
        ..AnnealParams::default()
    }
}

#[test]
fn automatic_chains_give_small_inputs_a_work_floor() {
    let auto = AnnealParams::default();
    assert_eq!(auto.chain_count(1_000_000), 1);
    assert_eq!(auto.chain_count(8_000), 1);
    assert_eq!(auto.chain_count(7_999), 2);
    assert_eq!(auto.chain_count(75), 107);
    assert_eq!(auto.chain_count(10), MAX_AUTO_CHAINS);
    assert_eq!(auto.chain_count(0), MAX_AUTO_CHAINS);
    let set = AnnealParams { chains: 3, ..auto };
    assert_eq!(set.chain_count(75), 3);
    assert_eq!(set.chain_count(1_000_000), 3);
}

#[test]
fn chain_zero_keeps_the_seed_and_other_chains_differ() {
    let params = quick(11);
    assert_eq!(params.for_chain(0), params);
    let seeds: std::collections::HashSet<u64> =
        (0..100).map(|c| params.for_chain(c).seed).collect();
    assert_eq!(seeds.len(), 100);
    assert_eq!(params.for_chain(5).sweeps, params.sweeps);
}

#[test]
fn annealing_beats_lop_and_keeps_invariants() {
    let st = bumpy_state(600, 21, 1.0);
    let e0 = st.energy();
    let mut lop_state = st.clone();
    lop(
        &mut TacLop {
            state: &mut lop_state,
            order: AnnealParams::default().order(),
        },
        usize::MAX,
    )
    .unwrap();
    let r = anneal(st.clone(), quick(1)).unwrap();
    r.mesh.validate(&st.uv().unwrap()).unwrap();
    assert!(r.energy <= e0);
    assert!(
        r.energy < lop_state.energy(),
        "anneal {} vs lop {}",
        r.energy,
        lop_state.energy()
    );
    assert_eq!(r.trace.len(), 60);
    assert!(r
        .trace
        .windows(2)
        .all(|w| w[1].best <= w[0].best && w[1].temperature < w[0].temperature));
}

#[test]
fn same_seed_same_faces_other_seed_other_faces() {
    let st = bumpy_state(300, 22, 1.0);
    let a = anneal(st.clone(), quick(7)).unwrap();
    let b = anneal(st.clone(), quick(7)).unwrap();
    let c = anneal(st, quick(8)).unwrap();
    assert_eq!(a.mesh.triangles().unwrap(), b.mesh.triangles().unwrap());
    assert_ne!(a.mesh.triangles().unwrap(), c.mesh.triangles().unwrap());
}

#[test]
fn incremental_energy_tracks_full_recomputation_during_a_run() {
    let st = bumpy_state(400, 23, 1.5);
    let mut ann = Annealer::new(
        st,
        AnnealParams {
            p: 1.5,
            sweeps: 30,
            ..quick(3)
        },
    )
    .unwrap();
    while !ann.is_done() {
        ann.advance(1_000);
        let scratch = ann.state().energy_from_scratch();
        let inc = ann.state().energy();
        assert!(
            (inc - scratch).abs() <= 1e-9 * scratch,
            "{inc} vs {scratch}"
        );
    }
    let best = ann.trace().last().unwrap().best;
    let r = ann.finish().unwrap();
    assert!(r.energy <= best + 1e-12);
}

#[test]
fn corner_hints_follow_the_share_of_measured_proposals() {
    // Live edges have a curved corner, so most proposals measure angles, on a curved
    // state and on a plateau alike (whose flat interior is not live): hints stay on.
    for (state, hinted) in [
        (bumpy_state(400, 31, 1.0), true),
        (plateau_state(400, 31, 1.0), true),
    ] {
        let mut ann = Annealer::new(state, quick(2)).unwrap();
        assert!(ann.edges.hints.corners);
        ann.advance(2 * ann.sweep_len());
        assert_eq!(ann.edges.hints.corners, hinted);
    }
}

#[test]
fn chunked_run_equals_one_shot_run() {
    let st = bumpy_state(250, 24, 1.0);
    let one = anneal(st.clone(), quick(5)).unwrap();
    let mut ann = Annealer::new(st, quick(5)).unwrap();
    while !ann.is_done() {
        ann.advance(37);
    }
    assert_eq!(
        ann.finish().unwrap().mesh.triangles().unwrap(),
        one.mesh.triangles().unwrap()
    );
}

#[test]
fn deadline_chunks_change_nothing() {
    let st = bumpy_state(250, 26, 1.0);
    let one = anneal(st.clone(), quick(6)).unwrap();
    let mut ann = Annealer::new(st, quick(6)).unwrap();
    while !ann.is_done() {
        ann.advance_until(usize::MAX, Some(Instant::now()));
    }
    assert_eq!(
        ann.finish().unwrap().mesh.triangles().unwrap(),
        one.mesh.triangles().unwrap()
    );
}

#[test]
fn best_state_survives_a_detached_log() {
    // A long hot run detaches the log; the returned state must still be the best seen.
    let st = bumpy_state(200, 25, 1.0);
    let params = AnnealParams {
        sweeps: 40,
        initial_acceptance: 0.9,
        final_temperature_ratio: 0.5,
        polish: false,
        patience: 0,
        ..quick(9)
    };
    let r = anneal(st.clone(), params).unwrap();
    let recomputed = TacState::new(r.mesh.clone(), st.uv().unwrap(), st.xyz().unwrap(), 1.0)
        .unwrap()
        .energy_from_scratch();
    let best_seen = r.trace.iter().map(|s| s.best).fold(f64::INFINITY, f64::min);
    assert!(
        (recomputed - best_seen).abs() <= 1e-9 * best_seen,
        "{recomputed} vs {best_seen}"
    );
    r.mesh.validate(&st.uv().unwrap()).unwrap();
}

#[test]
fn runs_that_cost_too_much_are_refused_before_they_start() {
    let st = bumpy_state(50, 1, 1.0);
    let named = |params: AnnealParams| match params.check_cost(&st) {
        Err(Error::TooCostly { name, .. }) => name,
        other => panic!("{params:?}: {other:?}"),
    };
    let auto = AnnealParams::default();
    // Too many chains calibrating before the run can be interrupted (was an abort).
    assert_eq!(
        named(AnnealParams {
            chains: 1_000_000,
            ..auto.clone()
        }),
        "chains"
    );
    // One chain's calibration alone too long (was a run without end).
    assert_eq!(
        named(AnnealParams {
            calibration_samples: 1_000_000_000,
            chains: 1,
            ..auto.clone()
        }),
        "calibration_samples"
    );
    assert_eq!(
        named(AnnealParams {
            sweeps: usize::MAX,
            ..auto.clone()
        }),
        "sweeps"
    );
    let e = AnnealParams {
        sweeps: 1 << 40,
        chains: 1,
        ..auto.clone()
    }
    .check_cost(&st)
    .unwrap_err();
    assert!(
        e.to_string().starts_with("sweeps=1099511627776 needs"),
        "{e}"
    );
    assert!(e.to_string().contains("hours on one core"), "{e}");
    // The sweep records of 10^10 sweeps outgrow any machine's memory.
    if crate::budget::memory_available().is_some() {
        assert_eq!(
            named(AnnealParams {
                sweeps: 10_000_000_000,
                chains: 1,
                ..auto.clone()
            }),
            "sweeps"
        );
    }
    // The defaults pass.
    let chains = auto.check_cost(&st).unwrap();
    assert_eq!(chains, auto.chain_count(st.count_interior_half_edges() / 2));
}

#[test]
fn no_live_edge_is_reported_as_exhaustion() {
    // A plane: no vertex above the floor, nothing to anneal, no sweep.
    let plane = |x: f64, y: f64| 0.3 * x - 0.2 * y;
    let flat = crate::optimize::tac_state::tests::height_state(300, 2, 1.0, plane);
    let r = anneal(flat, quick(1)).unwrap();
    assert_eq!(r.stopped, Stop::Exhausted);
    assert!(r.trace.is_empty());
    // Curved: every sweep runs; with patience, the early stop says so.
    let r = anneal(bumpy_state(200, 3, 1.0), quick(1)).unwrap();
    assert_eq!(r.stopped, Stop::Sweeps);
    assert_eq!(r.trace.len(), quick(1).sweeps);
    let patient = AnnealParams {
        sweeps: 100_000,
        patience: 3,
        ..quick(1)
    };
    let r = anneal(bumpy_state(200, 3, 1.0), patient).unwrap();
    assert_eq!(r.stopped, Stop::Patience);
    assert_eq!(Stop::of(5, 10, false, false), Stop::Unfinished);
}

#[test]
fn invalid_parameters_are_refused() {
    let st = bumpy_state(50, 1, 1.0);
    for bad in [
        AnnealParams {
            initial_acceptance: 1.0,
            ..Default::default()
        },
        AnnealParams {
            final_temperature_ratio: 0.0,
            ..Default::default()
        },
        AnnealParams {
            p: 0.5,
            ..Default::default()
        },
        AnnealParams {
            tie_tolerance: -1.0,
            ..Default::default()
        },
        AnnealParams {
            sliver_angle: 60.0,
            ..Default::default()
        },
        AnnealParams {
            curtain_angle: 90.0,
            ..Default::default()
        },
    ] {
        assert!(Annealer::new(st.clone(), bad).is_err());
    }
}

#[test]
fn the_automatic_schedule_shares_its_budget_among_the_chains() {
    let p = AnnealParams::default();
    // one chain (many edges): the budget per point over the edges, rounded up
    let (n, edges) = (1_000_000, 3_000_000);
    let per_point = AUTO_PROPOSALS_PER_POINT as usize * n;
    assert_eq!(p.chain_count(edges), 1);
    assert_eq!(p.auto_sweeps(n, edges), per_point.div_ceil(edges));
    // a small scan: at least AUTO_MIN_PROPOSALS in all, shared by its automatic chains
    let (n, edges) = (2_000, 5_800);
    let chains = p.chain_count(edges);
    assert!(chains > 1);
    let expected = (AUTO_MIN_PROPOSALS as usize).div_ceil(chains * edges);
    assert_eq!(
        p.auto_sweeps(n, edges),
        expected.clamp(AUTO_MIN_SWEEPS, p.sweeps)
    );
    // never fewer than AUTO_MIN_SWEEPS, never more than the sweeps asked for
    assert_eq!(p.auto_sweeps(10_000_000, 100_000_000), AUTO_MIN_SWEEPS);
    let short = AnnealParams {
        sweeps: 20,
        ..Default::default()
    };
    assert_eq!(short.auto_sweeps(100, 250), 20);
}

/// The largest turn (degrees) of a face's normal away from the z axis, measured apart from
/// the state's `facing` (by atan2 of the normal's horizontal and vertical parts).
fn steepest_turn_deg(xyz: &[DVec3], mesh: &HalfEdgeMesh) -> f64 {
    mesh.triangles()
        .unwrap()
        .iter()
        .map(|t| {
            let [a, b, c] = t.map(|v| xyz[v as usize]);
            let n = (b - a).cross(c - a);
            n.x.hypot(n.y).atan2(n.z.abs()).to_degrees()
        })
        .fold(0.0, f64::max)
}

/// A tiled chain run to its end.
fn tiled(state: TacState, params: AnnealParams) -> HalfEdgeMesh {
    let mut run = crate::optimize::tiles::TiledAnnealer::new(state, params).unwrap();
    while !run.is_done() {
        run.advance_until(usize::MAX, None).unwrap();
    }
    run.finish().unwrap().mesh
}

#[test]
fn no_flip_brings_a_face_nearer_the_line_of_sight_than_the_curtain_angle() {
    // Steep bumps seen from above (sight z): Delaunay's steepest face stands `start` off
    // the sight, and tac's flips, free to, make steeper ones (a failing test's check).
    // A grid jittered inside: random points' Delaunay has near-vertical slivers on its hull.
    let uv: Vec<[f64; 2]> = crate::testing::random_points(400, 21)
        .iter()
        .enumerate()
        .map(|(k, j)| {
            let (i, r) = (k % 20, k / 20);
            let inside = if i % 19 == 0 || r % 19 == 0 { 0.0 } else { 0.4 };
            [
                (i as f64 + inside * j[0]) / 20.0,
                (r as f64 + inside * j[1]) / 20.0,
            ]
        })
        .collect();
    let xyz: Vec<DVec3> = uv
        .iter()
        .map(|&[x, y]| DVec3::new(x, y, 0.2 * (9.0 * x).sin() * (7.0 * y).cos()))
        .collect();
    let unit = crate::geometry::unit_square(&uv);
    let d = crate::triangulate::delaunay::delaunay(&unit).unwrap();
    let mesh = HalfEdgeMesh::from_triangles(uv.len(), &d.triangles).unwrap();
    let st = TacState::new(mesh, unit, xyz.clone(), 1.0).unwrap();
    let start = steepest_turn_deg(&xyz, st.mesh());
    // A curtain angle that the start respects: no face within it of the sight.
    let curtain_angle = 90.0 - start - 0.5;
    assert!(curtain_angle > 2.0, "{start}");
    let sighted = st
        .clone()
        .with_sight(Some(DVec3::new(0.0, 0.0, -3.0)))
        .unwrap();
    let params = |angle: f64, tiles: usize| AnnealParams {
        curtain_angle: angle,
        tiles,
        ..quick(3)
    };
    let lop_mesh = |state: &TacState, angle: f64| {
        let mut s = state.clone();
        tac_lop(&mut s, params(angle, 1).order()).unwrap();
        s.into_mesh()
    };
    let free = [
        lop_mesh(&sighted, 0.0),
        anneal(sighted.clone(), params(0.0, 1)).unwrap().mesh,
    ];
    for mesh in &free {
        assert!(steepest_turn_deg(&xyz, mesh) > 90.0 - curtain_angle);
    }
    let guarded = [
        lop_mesh(&sighted, curtain_angle),
        anneal(sighted.clone(), params(curtain_angle, 1))
            .unwrap()
            .mesh,
        tiled(sighted.clone(), params(curtain_angle, 2)),
        // no sight, no rule
        lop_mesh(&st, curtain_angle),
    ];
    for (k, mesh) in guarded.iter().enumerate() {
        mesh.validate(&st.uv().unwrap()).unwrap();
        let steepest = steepest_turn_deg(&xyz, mesh);
        assert_eq!(steepest <= 90.0 - curtain_angle, k < 3, "{k}: {steepest}");
    }
}
