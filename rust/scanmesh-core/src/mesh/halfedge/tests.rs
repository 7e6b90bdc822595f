use super::*;
use crate::mesh::count_cycles;
use crate::testing::random_points;
use crate::triangulate::delaunay::delaunay;

fn canonical(mut t: Vec<[u32; 3]>) -> Vec<[u32; 3]> {
    for tri in t.iter_mut() {
        let k = (0..3).min_by_key(|&k| tri[k]).unwrap();
        tri.rotate_left(k);
    }
    t.sort();
    t
}

fn delaunay_mesh(n: usize, seed: u64) -> (Vec<[f64; 2]>, HalfEdgeMesh) {
    let uv = random_points(n, seed);
    let d = delaunay(&uv).unwrap();
    (
        uv.clone(),
        HalfEdgeMesh::from_triangles(uv.len(), &d.triangles).unwrap(),
    )
}

#[test]
fn delaunay_mesh_is_valid() {
    let (uv, mesh) = delaunay_mesh(300, 1);
    mesh.validate(&uv).unwrap();
    let interior = mesh.interior_edges().unwrap();
    assert!(interior.iter().all(|&h| mesh.twin(h) != NONE));
    let boundary = mesh.edges().filter(|&h| mesh.twin(h) == NONE).count();
    assert_eq!(interior.len() + boundary, mesh.edges().count());
    let interior = (0..300).filter(|&v| mesh.is_interior(v)).count();
    assert!(interior > 200 && interior < 300);
}

#[test]
fn flipping_twice_restores_the_mesh() {
    let (uv, mut mesh) = delaunay_mesh(100, 2);
    let before = canonical(mesh.triangles().unwrap());
    for h in mesh.interior_edges().unwrap() {
        if mesh.can_flip(h, &uv) {
            let copy = mesh.clone();
            mesh.flip(h);
            mesh.validate(&uv).unwrap();
            assert_ne!(canonical(mesh.triangles().unwrap()), before);
            assert!(mesh.can_flip(h, &uv), "the flipped quad is still convex");
            mesh.flip(h);
            assert_eq!(canonical(mesh.triangles().unwrap()), before);
            mesh.validate(&uv).unwrap();
            mesh = copy;
        }
    }
}

#[test]
fn ten_thousand_random_flips_keep_every_invariant() {
    let (uv, mut mesh) = delaunay_mesh(400, 3);
    let edges = mesh.interior_edges().unwrap();
    let mut s = 99u64;
    let mut flips = 0;
    for step in 0..10_000 {
        s = s.wrapping_mul(6364136223846793005).wrapping_add(1);
        let h = edges[((s >> 33) as usize) % edges.len()];
        if mesh.can_flip(h, &uv) {
            mesh.flip(h);
            flips += 1;
        }
        if step % 2_500 == 0 {
            mesh.validate(&uv).unwrap();
        }
    }
    mesh.validate(&uv).unwrap();
    assert!(flips > 3_000, "only {flips} flips were legal");
}

#[test]
fn unanchored_flips_then_reanchor_equal_a_fresh_build() {
    // Mixed full and unanchored flips: reanchoring gives exactly the anchors that
    // `from_triangles` gives the same slots (so fan sums cannot depend on history),
    // and `validate` accepts the mesh before and after.
    let (uv, mut mesh) = delaunay_mesh(400, 4);
    let edges = mesh.interior_edges().unwrap();
    let mut s = 7u64;
    let mut unanchored = 0;
    for step in 0..6_000 {
        s = s.wrapping_mul(6364136223846793005).wrapping_add(1);
        let h = edges[((s >> 33) as usize) % edges.len()];
        if !mesh.can_flip(h, &uv) {
            continue;
        }
        if step % 3 == 0 {
            mesh.flip(h);
        } else {
            mesh.flip_unanchored(h);
            unanchored += 1;
        }
        if step % 1_500 == 0 {
            mesh.validate(&uv).unwrap();
        }
    }
    assert!(unanchored > 1_000, "only {unanchored} unanchored flips");
    assert!(!mesh.is_anchored());
    mesh.validate(&uv).unwrap();
    let fresh = HalfEdgeMesh::from_triangles(uv.len(), &mesh.triangles().unwrap()).unwrap();
    assert_ne!(
        mesh.vertex_edge, fresh.vertex_edge,
        "the flips left anchors stale"
    );
    mesh.reanchor();
    assert_eq!(mesh, fresh);
    mesh.validate(&uv).unwrap();
    // A fresh build is already anchored by the same rule.
    let mut rebuilt = fresh.clone();
    rebuilt.anchored = false;
    rebuilt.reanchor();
    assert_eq!(rebuilt, fresh);
}

#[test]
fn nonconvex_quads_are_refused() {
    // A convex kite (a, d, b, c) = (0, 3, 1, 2): flippable.
    let uv = vec![[0.0, 0.0], [2.0, 0.0], [1.0, 3.0], [1.0, -0.2]];
    let mesh = HalfEdgeMesh::from_triangles(4, &[[0, 1, 2], [1, 0, 3]]).unwrap();
    assert!(mesh.can_flip(0, &uv));
    // Move c so that the turn d -> b -> c is clockwise: a reflex corner at b.
    let uv2 = vec![[0.0, 0.0], [2.0, 0.0], [3.0, 0.5], [1.0, -1.0]];
    assert!(!mesh.can_flip(0, &uv2));
    // Collinear: c, b, d in a line makes the quad degenerate at b.
    let uv3 = vec![[0.0, 0.0], [2.0, 0.0], [3.0, 1.0], [1.0, -1.0]];
    let mesh3 = HalfEdgeMesh::from_triangles(4, &[[0, 1, 2], [1, 0, 3]]).unwrap();
    assert!(!mesh3.can_flip(0, &uv3));
    // Numerically collinear: d, b, c lie on x + y = 0.4 in the reals, but the rounded
    // coordinates make (c, d, b) counter-clockwise by 5.6e-18: still not a legal flip.
    let uv4 = vec![[0.0, 0.0], [0.2, 0.2], [0.1, 0.3], [0.3, 0.1]];
    assert!(orient2d(uv4[2], uv4[3], uv4[1]) > 0.0);
    assert!(!mesh3.can_flip(0, &uv4));
    assert!(!mesh3.can_flip(1, &uv3), "boundary edge");
}

#[test]
fn bad_triangles_are_rejected() {
    assert!(HalfEdgeMesh::from_triangles(3, &[[0, 1, 3]]).is_err());
    assert!(HalfEdgeMesh::from_triangles(3, &[[0, 1, 1]]).is_err());
    // Same orientation of a shared edge: inconsistent.
    assert!(HalfEdgeMesh::from_triangles(4, &[[0, 1, 2], [0, 1, 3]]).is_err());
}

#[test]
fn validate_catches_clockwise_and_pinches() {
    let uv = vec![[0.0, 0.0], [1.0, 0.0], [0.0, 1.0]];
    let cw = HalfEdgeMesh::from_triangles(3, &[[0, 2, 1]]).unwrap();
    assert!(cw.validate(&uv).is_err());
    // Two triangles sharing only vertex 0: a pinch.
    let uv = vec![
        [0.0, 0.0],
        [1.0, 0.0],
        [1.0, 1.0],
        [-1.0, 0.0],
        [-1.0, -1.0],
    ];
    let bow = HalfEdgeMesh::from_triangles(5, &[[0, 1, 2], [0, 3, 4]]).unwrap();
    let err = bow.validate(&uv).unwrap_err();
    assert!(format!("{err}").contains("pinch"), "{err}");
}

#[test]
fn validate_catches_a_fan_that_winds_twice() {
    // Centre 0 and five points at 0°, 144°, 288°, 72°, 216°: every triangle
    // (0, k, k + 1) is counter-clockwise and the fan closes, but it covers the plane
    // around 0 twice (corner angles 5 × 144° = 720°); V − E + F = 6 − 10 + 5 = 1 with
    // one boundary loop, so only the fold check can see it.
    let mut uv = vec![[0.0, 0.0]];
    for k in 0..5 {
        let a = (144.0 * k as f64).to_radians();
        uv.push([a.cos(), a.sin()]);
    }
    let tris: Vec<[u32; 3]> = (0..5).map(|k| [0, k + 1, (k + 1) % 5 + 1]).collect();
    let mesh = HalfEdgeMesh::from_triangles(6, &tris).unwrap();
    assert!(mesh.is_interior(0));
    assert_eq!(mesh.fan_winding(0, &uv), 2);
    let err = mesh.validate(&uv).unwrap_err();
    assert!(format!("{err}").contains("fold"), "{err}");
    // The same fan with the points in angular order winds once and is valid.
    let mut once = vec![[0.0, 0.0]];
    for k in 0..5 {
        let a = (72.0 * k as f64).to_radians();
        once.push([a.cos(), a.sin()]);
    }
    assert_eq!(mesh.fan_winding(0, &once), 1);
    mesh.validate(&once).unwrap();
}

#[test]
fn winding_counts_agree_with_angle_sums_on_random_meshes() {
    // Every interior fan whose triangles are counter-clockwise, on Delaunay meshes with
    // one vertex moved: the exact count against the corner angles summed with atan2
    // (mostly k = 1; the test above builds k = 2).
    for seed in 0..20 {
        let (mut uv, mesh) = delaunay_mesh(60, 100 + seed);
        // Fans with a clockwise triangle are skipped: validate rejects those first.
        uv[(seed % 60) as usize] = [0.5, 0.5];
        for v in 0..60u32 {
            if !mesh.is_interior(v) {
                continue;
            }
            let ccw = mesh.fan(v).all(|h| {
                let t = (h / 3) as usize;
                let [a, b, c] = mesh.triangle(t).map(|k| uv[k as usize]);
                orient2d(a, b, c) > 0.0
            });
            if !ccw {
                continue;
            }
            let sum: f64 = mesh
                .fan(v)
                .map(|h| {
                    crate::geometry::planar_corner_angle(
                        uv[v as usize],
                        uv[mesh.end(h) as usize],
                        uv[mesh.start(prev(h)) as usize],
                    )
                })
                .sum();
            let k = (sum / std::f64::consts::TAU).round() as u32;
            assert!((sum - k as f64 * std::f64::consts::TAU).abs() < 1e-9);
            assert_eq!(mesh.fan_winding(v, &uv), k, "seed {seed} vertex {v}");
        }
    }
}

#[test]
fn count_cycles_counts_permutation_cycles_and_refuses_other_maps() {
    let perm = [1, 2, 0, 4, 3, 5];
    assert_eq!(count_cycles(6, |k| Some(perm[k])), Some(3));
    assert_eq!(count_cycles(0, |_| None), Some(0));
    // 0 -> 1 -> 2 -> 1: the walk from 0 joins a cycle part-way.
    let tail = [1, 2, 1];
    assert_eq!(count_cycles(3, |k| Some(tail[k])), None);
    assert_eq!(count_cycles(2, |k| (k == 0).then_some(1)), None);
}

#[test]
fn validate_catches_a_repeated_directed_edge() {
    // Built by hand (from_triangles refuses it): triangles (0, 1, 2) and (0, 1, 3) both
    // use 0→1, both counter-clockwise.
    let uv = vec![[0.0, 0.0], [1.0, 0.0], [0.0, 1.0], [1.0, 1.0]];
    let mesh = HalfEdgeMesh {
        start: vec![0, 1, 2, 0, 1, 3],
        twin: vec![NONE; 6],
        vertex_edge: vec![0, 1, 2, 5],
        on_boundary: vec![true; 4],
        anchored: true,
    };
    assert!(mesh.validate(&uv).is_err());
}

/// `f` on a rayon pool of `threads` threads.
fn on_pool<T: Send>(threads: usize, f: impl FnOnce() -> T + Send) -> T {
    rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .build()
        .unwrap()
        .install(f)
}

#[test]
fn errors_name_the_lowest_fault_on_any_thread_count() {
    // 60,000 points: every parallel pass splits into several blocks of BLOCK items.
    let (uv, mesh) = delaunay_mesh(60_000, 7);
    let tris = mesh.triangles().unwrap();
    let both = |f: &(dyn Fn() -> String + Sync)| {
        let (one, two) = (on_pool(1, f), on_pool(2, f));
        assert_eq!(one, two);
        one
    };
    // from_triangles: the same mesh, and the lowest bad face, on 1 and 2 threads.
    let build = |t: &[[u32; 3]]| match HalfEdgeMesh::from_triangles(uv.len(), t) {
        Ok(m) => format!("{m:?}"),
        Err(e) => format!("{e}"),
    };
    assert_eq!(both(&|| build(&tris)), format!("{mesh:?}"));
    let mut bad = tris.clone();
    bad[100_000][1] = 70_000; // out of range
    bad[90_000][2] = bad[90_000][0]; // repeated vertex: the lowest fault
    let err = both(&|| build(&bad));
    assert!(
        err.contains("face 90000") && err.contains("repeats"),
        "{err}"
    );
    // Repeated directed edges (a face copied over another twice): the lowest edge key.
    let mut bad = tris.clone();
    bad[110_000] = bad[3];
    bad[5] = bad[100_000];
    let sorted_error = format!(
        "{}",
        HalfEdgeMesh::repeated_edge_by_sort(bad.as_flattened())
    );
    assert_eq!(both(&|| build(&bad)), sorted_error);
    // validate: several stale flags, a vertex pointing elsewhere and a fold; the
    // lowest faulty vertex is named whatever the split.
    let mut broken = mesh.clone();
    let interior: Vec<u32> = (0..60_000).filter(|&v| mesh.is_interior(v)).collect();
    let [v1, v2, v3] = [interior[20_000], interior[35_000], interior[50_000]];
    broken.on_boundary[v3 as usize] = true;
    broken.on_boundary[v2 as usize] = true;
    broken.vertex_edge[v1 as usize] = broken.vertex_edge[v3 as usize];
    let err = both(&|| format!("{}", broken.validate(&uv).unwrap_err()));
    assert_eq!(
        err,
        format!("mesh invariant violated: vertex {v1} does not point at a half-edge leaving it")
    );
    // Clockwise triangles at both ends: the lowest triangle is named.
    let mut flipped = uv.clone();
    let [a, b, _] = mesh.triangle(110_000);
    flipped.swap(a as usize, b as usize);
    let [a, b, _] = mesh.triangle(40_000);
    flipped.swap(a as usize, b as usize);
    let one = on_pool(1, || broken.validate(&flipped).unwrap_err());
    assert_eq!(
        format!("{one}"),
        format!("{}", on_pool(2, || broken.validate(&flipped).unwrap_err()))
    );
    assert!(format!("{one}").contains("triangle"), "{one}");
}

#[test]
fn fans_go_counter_clockwise() {
    let (uv, mesh) = delaunay_mesh(200, 5);
    for v in 0..200u32 {
        if !mesh.is_interior(v) {
            continue;
        }
        let ends: Vec<[f64; 2]> = mesh.fan(v).map(|h| uv[mesh.end(h) as usize]).collect();
        let p = uv[v as usize];
        for k in 0..ends.len() {
            let (a, b) = (ends[k], ends[(k + 1) % ends.len()]);
            assert!(orient2d(p, a, b) > 0.0);
        }
    }
}

#[test]
fn a_vertex_count_no_memory_can_hold_is_an_error_not_an_abort() {
    // One triangle over an absurd vertex count: its per-vertex arrays cannot be allocated,
    // and from_triangles says so instead of aborting the process.
    match HalfEdgeMesh::from_triangles(usize::MAX / 16, &[[0, 1, 2]]) {
        Err(Error::OutOfMemory { what, .. }) => assert!(what.contains("vertex"), "{what}"),
        other => panic!("{:?}", other.map(|m| m.n_vertices())),
    }
}
