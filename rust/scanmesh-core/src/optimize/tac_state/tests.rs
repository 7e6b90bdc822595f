use super::*;
use crate::geometry::unit_square;
use crate::triangulate::delaunay::delaunay;

#[test]
fn coplanar_means_unbent_not_thin() {
    // A flat quadrilateral, rounded: a tie.
    let plane = |x: f64, y: f64| DVec3::new(x, y, 0.3 * x + 0.7 * y);
    let flat = [
        plane(0.0, 0.0),
        plane(1.0, 0.1),
        plane(0.4, 0.9),
        plane(0.6, -0.8),
    ];
    assert!(is_coplanar(flat[0], flat[1], flat[2], flat[3]));
    // A short diagonal ab between two long triangles whose far corners c, d nearly line
    // up with a, d raised by 9e-10: the tetrahedron's volume is below 1e-13 of the
    // longest edge cubed (the former test called it flat), but the quadrilateral bends by
    // 9e-10 rad where the new angle at a is 1e-9 short of π, so a's angle sum moves by
    // more than the tie tolerance: no tie.
    let (a, b) = (DVec3::ZERO, DVec3::new(1e-4, 0.0, 0.0));
    let (c, d) = (DVec3::new(5e-10, 1.0, 0.0), DVec3::new(5e-10, -1.0, 9e-10));
    assert!(b.dot((c - a).cross(d - a)).abs() < COPLANAR_RELATIVE);
    assert!(!is_coplanar(a, b, c, d));
    let (old1, old2) = (triangle_angles(a, b, c), triangle_angles(b, a, d));
    let new1 = triangle_angles(d, c, a);
    let at_a = new1[2] - (old1[0] + old2[1]);
    assert!(at_a.abs() > 1e-10, "{at_a}");
    // Zero area: never a tie, whatever the volume.
    assert!(!is_coplanar(a, b, DVec3::new(2.0, 0.0, 0.0), d));
}

/// A bumpy height field sampled at random planar points.
pub(crate) fn bumpy_state(n: usize, seed: u64, p: f64) -> TacState {
    height_state(n, seed, p, |x, y| {
        0.3 * (6.0 * x).sin() * (4.0 * y).cos() + 0.2 * x * x
    })
}

/// Mostly flat: a plateau with one smooth bump, so most flips are coplanar ties.
pub(crate) fn plateau_state(n: usize, seed: u64, p: f64) -> TacState {
    height_state(n, seed, p, |x, y| {
        (0.04 - (x - 0.5).powi(2) - (y - 0.5).powi(2)).max(0.0)
    })
}

/// The height field `f` sampled at `n` random planar points, Delaunay-triangulated.
pub(crate) fn height_state(n: usize, seed: u64, p: f64, f: impl Fn(f64, f64) -> f64) -> TacState {
    let uv = crate::testing::random_points(n, seed);
    let xyz: Vec<DVec3> = uv
        .iter()
        .map(|q| DVec3::new(q[0], q[1], f(q[0], q[1])))
        .collect();
    let uv = unit_square(&uv);
    let d = delaunay(&uv).unwrap();
    let mesh = HalfEdgeMesh::from_triangles(n, &d.triangles).unwrap();
    TacState::new(mesh, uv, xyz, p).unwrap()
}

#[test]
fn delta_energy_matches_recomputation() {
    for p in [1.0, 2.0, 3.5] {
        let mut st = bumpy_state(300, 4, p);
        let e0 = st.energy_from_scratch();
        assert!((st.energy() - e0).abs() <= 1e-12 * e0.max(1.0));
        let edges = st.mesh().interior_edges().unwrap();
        let mut applied = 0;
        for &h in edges.iter().take(400) {
            if let Some(mv) = st.evaluate(h, Detail::Energy) {
                let before = st.energy_from_scratch();
                st.apply(&mv);
                let after = st.energy_from_scratch();
                assert!(
                    ((after - before) - mv.delta_energy).abs() <= 1e-10 * before.max(1.0),
                    "p={p}"
                );
                applied += 1;
            }
        }
        assert!(applied > 100);
        let scratch = st.energy_from_scratch();
        assert!(
            (st.energy() - scratch).abs() <= 1e-9 * scratch,
            "{} vs {scratch}",
            st.energy()
        );
        st.mesh().validate(&st.uv().unwrap()).unwrap();
    }
}

#[test]
fn coplanar_moves_skip_angles_and_stale_corners_stay_exact() {
    let mut st = plateau_state(600, 6, 1.0);
    let edges = st.mesh().interior_edges().unwrap();
    let (mut flat, mut curved) = (0, 0);
    for round in 0..3 {
        for &h in &edges {
            if let Some(mv) = st.evaluate(h, Detail::Energy) {
                if mv.coplanar {
                    assert_eq!(mv.delta_energy, 0.0);
                    assert!(mv.new_angles.iter().all(|a| a.is_nan()));
                    flat += 1;
                } else {
                    curved += 1;
                }
                // Flip everything legal: chains of coplanar flips leave stale corners
                // that later non-coplanar moves must recompute.
                if round < 2 || !mv.coplanar {
                    st.apply(&mv);
                }
            }
        }
        let scratch = st.energy_from_scratch();
        assert!(
            (st.energy() - scratch).abs() <= 1e-9 * scratch,
            "{} vs {scratch}",
            st.energy()
        );
        st.mesh().validate(&st.uv().unwrap()).unwrap();
    }
    assert!(flat > 1000 && curved > 50, "flat {flat}, curved {curved}");
    // A shape evaluation of a coplanar move computes its angles and is still a tie.
    let mv = edges
        .iter()
        .find_map(|&h| st.evaluate(h, Detail::Shape).filter(|m| m.coplanar))
        .unwrap();
    assert!(mv.new_min_angle > 0.0 && mv.delta_energy == 0.0);
}

#[test]
fn boundary_and_reflex_edges_are_not_moves() {
    let mut st = bumpy_state(100, 5, 1.0);
    let uv = st.uv().unwrap();
    for h in 0..st.mesh().n_half_edges() as u32 {
        if st.mesh().twin(h) == NONE {
            assert!(st.evaluate(h, Detail::Energy).is_none());
        } else {
            assert_eq!(
                st.evaluate(h, Detail::Energy).is_some(),
                st.mesh().can_flip(h, &uv)
            );
        }
    }
}

#[test]
fn incremental_sums_match_fan_sums_and_records_fill_one_line() {
    assert_eq!(std::mem::size_of::<VertexRecord>(), 64);
    assert_eq!(std::mem::align_of::<VertexRecord>(), 64);
    let mut st = bumpy_state(400, 8, 1.0);
    let edges = st.mesh().interior_edges().unwrap();
    let mut applied = 0;
    for round in 0..4 {
        for &h in edges.iter().skip(round) {
            if let Some(mv) = st.evaluate(h, Detail::Energy) {
                assert!(!mv.coplanar);
                st.apply(&mv);
                applied += 1;
            }
        }
    }
    assert!(applied > 1000, "{applied}");
    for v in 0..st.mesh().n_vertices() as u32 {
        let (kept, walked) = (st.vert[v as usize].sum, st.fan_sum(v));
        assert!(
            (kept - walked).abs() <= 1e-12,
            "vertex {v}: {kept} vs {walked}"
        );
        assert_eq!(st.vert[v as usize].uv, st.uv().unwrap()[v as usize]);
    }
}

#[test]
fn propose_matches_evaluate_then_apply() {
    let mut fused = plateau_state(500, 11, 1.0);
    let mut plain = fused.clone();
    let edges = fused.mesh().interior_edges().unwrap();
    let (mut ties, mut moves) = (0, 0);
    for &h in edges.iter().chain(&edges) {
        let expected = plain.evaluate(h, Detail::Energy);
        match fused.propose(h) {
            Proposal::NotFlippable => assert!(expected.is_none()),
            Proposal::FlippedTie => {
                let mv = expected.unwrap();
                assert!(mv.coplanar && mv.delta_energy == 0.0);
                plain.apply(&mv);
                ties += 1;
            }
            Proposal::Move(mv) => {
                // Debug prints every f64 exactly (shortest round trip) and NaN as NaN: the
                // facings are NaN without a sight, and NaN != NaN under PartialEq.
                assert_eq!(format!("{:?}", Some(mv)), format!("{expected:?}"));
                if mv.delta_energy < 0.0 {
                    fused.apply(&mv);
                    plain.apply(&mv);
                }
                moves += 1;
            }
        }
        // Same slots; only the vertex anchors differ (ties leave them stale).
        assert_eq!(
            fused.mesh().triangles().unwrap(),
            plain.mesh().triangles().unwrap()
        );
    }
    assert!(ties > 500 && moves > 50, "ties {ties}, moves {moves}");
    assert!(!fused.mesh().is_anchored());
    let n = plain.mesh().n_vertices();
    let fresh = HalfEdgeMesh::from_triangles(n, &plain.mesh().triangles().unwrap()).unwrap();
    assert_eq!(fused.clone().into_mesh(), fresh);
    assert_eq!(fused.energy(), plain.energy());
    let scratch = fused.energy_from_scratch();
    assert!((fused.energy() - scratch).abs() <= 1e-9 * scratch);
}

#[test]
fn prefetch_hints_change_nothing() {
    let st = bumpy_state(100, 9, 1.0);
    let before = st.clone();
    for h in 0..st.mesh().n_half_edges() as u32 {
        for stage in 0..3 {
            st.prefetch(
                h,
                stage,
                PrefetchHints {
                    corners: stage == 0,
                    flip_writes: stage == 2,
                },
            );
        }
    }
    assert_eq!(st.mesh(), before.mesh());
    assert_eq!(st.energy(), before.energy());
}

#[test]
fn with_mesh_equals_a_fresh_state_of_that_mesh() {
    // A state flipped away from its start (ties left stale, sums incremented), moved
    // onto the start's mesh: the same caches, sums and energy as a state built anew.
    let start = plateau_state(500, 12, 2.0);
    let mut st = start.clone();
    for &h in &st.mesh().interior_edges().unwrap() {
        if let Proposal::Move(mv) = st.propose(h) {
            st.apply(&mv);
        }
    }
    assert_ne!(
        st.mesh().triangles().unwrap(),
        start.mesh().triangles().unwrap()
    );
    let fresh = TacState::new(
        start.mesh().clone(),
        start.uv().unwrap(),
        start.xyz().unwrap(),
        2.0,
    )
    .unwrap();
    let moved = st.with_mesh(start.mesh().clone()).unwrap();
    assert_eq!(moved.mesh(), fresh.mesh());
    assert_eq!(moved.corner, fresh.corner);
    assert_eq!(moved.stale, fresh.stale);
    assert_eq!(moved.vert, fresh.vert);
    assert_eq!(moved.energy(), fresh.energy());
    // Another vertex count is refused.
    let other = bumpy_state(40, 1, 2.0);
    assert!(moved.with_mesh(other.mesh().clone()).is_err());
}

#[test]
fn bad_p_is_refused() {
    let st = bumpy_state(20, 1, 1.0);
    let (mesh, uv) = (st.mesh().clone(), st.uv().unwrap());
    assert!(TacState::new(mesh, uv, st.xyz().unwrap(), 0.5).is_err());
}
