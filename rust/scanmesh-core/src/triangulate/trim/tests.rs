use super::*;
use crate::mesh::well_formed;
use crate::triangulate::delaunay::delaunay;
use crate::triangulate::jumps::*;
use glam::DVec3;
use std::sync::atomic::Ordering;

/// A grid with the middle cells missing (a bore), triangulated over its convex hull.
fn grid_with_hole() -> Vec<[f64; 2]> {
    let mut pts = Vec::new();
    for j in 0..20 {
        for i in 0..20 {
            let inside = (7..13).contains(&i) && (7..13).contains(&j);
            if !inside {
                pts.push([i as f64 + 0.01 * ((i * j) % 3) as f64, j as f64]);
            }
        }
    }
    pts
}

#[test]
fn hole_stays_open_and_mesh_is_valid() {
    let uv = grid_with_hole();
    let d = delaunay(&uv).unwrap();
    let s = median_spacing(&uv, &d.triangles).unwrap();
    assert!((s - 1.0).abs() < 0.05, "{s}");
    let kept = trim_long_edges(&uv, &d.triangles, DEFAULT_MAX_EDGE_FACTOR * s * 0.5, None).unwrap();
    let mesh = HalfEdgeMesh::from_triangles(uv.len(), &kept).unwrap();
    mesh.validate(&uv).unwrap();
    // A point near the centre of the hole (off the grid's diagonals) is covered by no
    // triangle.
    let centre = [9.4, 9.3];
    let covers = |t: &[u32; 3]| {
        (0..3).all(|k| {
            crate::geometry::orient2d(uv[t[k] as usize], uv[t[(k + 1) % 3] as usize], centre) > 0.0
        })
    };
    assert!(!kept.iter().any(covers));
    assert!(d.triangles.iter().any(covers));
    let untrimmed = trim_long_edges(&uv, &d.triangles, f64::INFINITY, None).unwrap();
    assert_eq!(untrimmed.len(), d.triangles.len());
}

/// A jittered grid of `nx` × `ny` points, `dy` apart across lines, with height `z(x, y)`.
fn terrain(nx: usize, ny: usize, dy: f64, z: impl Fn(f64, f64) -> f64) -> Vec<DVec3> {
    (0..nx * ny)
        .map(|k| {
            let (i, j) = ((k % nx) as f64, (k / nx) as f64);
            let (x, y) = (i + 0.01 * ((k * 7) % 5) as f64, j * dy);
            DVec3::new(x, y, z(x, y))
        })
        .collect()
}

fn planar(p: &[DVec3]) -> Vec<[f64; 2]> {
    p.iter().map(|q| [q.x, q.y]).collect()
}

#[test]
fn local_spacing_is_the_median_edge_at_each_vertex() {
    let p = terrain(12, 9, 1.0, |x, y| 0.3 * x * x - y);
    let d = delaunay(&planar(&p)).unwrap();
    let jumps = DepthJumps {
        points: &p,
        factor: DEFAULT_JUMP_FACTOR,
        gaps: true,
    };
    let unit = UnitJumps::gathered(jumps, None).unwrap();
    let local: Vec<f64> = spacings(&unit.unit, unit.scale, &d.triangles, |_| true)
        .unwrap()
        .iter()
        .map(|s| s.median)
        .collect();
    // Brute force: every distinct edge at v, sorted, the upper middle one.
    for (v, &got) in local.iter().enumerate() {
        let mut at: Vec<f64> = Vec::new();
        for t in &d.triangles {
            for k in 0..3 {
                let (a, b) = (t[k] as usize, t[(k + 1) % 3] as usize);
                let other = if a == v {
                    b
                } else if b == v {
                    a
                } else {
                    continue;
                };
                let len = (p[v] - p[other]).length();
                if !at.contains(&len) {
                    at.push(len);
                }
            }
        }
        at.sort_by(f64::total_cmp);
        assert!((got - at[at.len() / 2]).abs() <= 1e-12 * got, "vertex {v}");
    }
}

#[test]
fn triangles_across_a_step_are_dropped_and_slopes_kept() {
    let step = |h: f64| terrain(20, 20, 1.0, move |x, _| if x < 9.5 { 0.0 } else { h });
    let trim = |p: &[DVec3]| {
        let uv = planar(p);
        let d = delaunay(&uv).unwrap();
        let jumps = DepthJumps {
            points: p,
            factor: DEFAULT_JUMP_FACTOR,
            gaps: true,
        };
        let kept = trim_long_edges(&uv, &d.triangles, 5.0, Some(jumps)).unwrap();
        HalfEdgeMesh::from_triangles(uv.len(), &kept)
            .unwrap()
            .validate(&uv)
            .unwrap();
        (d.triangles.len(), kept)
    };
    // A wall 10 spacings high: every triangle with corners on both terraces goes.
    let high = step(10.0);
    let (all, kept) = trim(&high);
    let bridging = |t: &[u32; 3]| {
        let low = t.iter().filter(|&&v| high[v as usize].z == 0.0).count();
        low > 0 && low < 3
    };
    assert!(!kept.iter().any(bridging));
    assert_eq!(
        all - kept.len(),
        2 * 19,
        "one strip of cells along the wall"
    );
    // A step of half a spacing is no jump.
    assert_eq!(trim(&step(0.5)).1.len(), all);
    // A 60° slope across lines 4 times farther apart than their points is no jump either.
    let slope = terrain(20, 8, 4.0, |_, y| y * 3f64.sqrt());
    let (all, kept) = trim(&slope);
    assert_eq!(kept.len(), all);
    // Off with an infinite factor, and at any scale the same.
    let uv = planar(&high);
    let d = delaunay(&uv).unwrap();
    let off = DepthJumps {
        points: &high,
        factor: f64::INFINITY,
        gaps: true,
    };
    assert_eq!(
        trim_long_edges(&uv, &d.triangles, 5.0, Some(off))
            .unwrap()
            .len(),
        d.triangles.len()
    );
    for s in [1e-300, 1e300] {
        let scaled: Vec<DVec3> = high.iter().map(|&q| q * s).collect();
        let uv_s = planar(&scaled);
        let jumps = DepthJumps {
            points: &scaled,
            factor: DEFAULT_JUMP_FACTOR,
            gaps: true,
        };
        let got = trim_long_edges(&uv_s, &d.triangles, 5.0 * s, Some(jumps)).unwrap();
        assert_eq!(got.len(), trim(&high).1.len(), "scale {s}");
    }
}

#[test]
fn a_gap_between_lines_is_left_open_at_any_slope_and_sparse_lines_are_kept() {
    // Flat lines 1 apart with eight lines missing: the planar rule is off (max_edge = ∞),
    // so only the bridge rule can open the gap.
    let mut p = terrain(25, 20, 1.0, |x, y| 0.1 * (0.3 * x).sin() + 0.05 * y);
    p.retain(|q| !(6.5..14.5).contains(&q.y));
    let uv = planar(&p);
    let d = delaunay(&uv).unwrap();
    let jumps = DepthJumps {
        points: &p,
        factor: DEFAULT_JUMP_FACTOR,
        gaps: true,
    };
    let kept = trim_long_edges(&uv, &d.triangles, f64::INFINITY, Some(jumps)).unwrap();
    let low = |v: u32| p[v as usize].y < 6.5;
    let spans = |t: &[u32; 3]| t.iter().any(|&v| low(v)) && !t.iter().all(|&v| low(v));
    assert!(
        d.triangles.iter().any(spans),
        "the fixture must bridge the gap"
    );
    assert!(!kept.iter().any(spans));
    // Everything inside the bands stays.
    let inside = d.triangles.iter().filter(|t| !spans(t)).count();
    assert_eq!(kept.len(), inside);
    // Lines 10 times farther apart than their points are sampled sparsely, not gapped:
    // even the strips of the first and last line stay.
    let sparse = terrain(30, 8, 10.0, |x, _| 0.2 * (0.2 * x).sin());
    let uv = planar(&sparse);
    let d = delaunay(&uv).unwrap();
    let jumps = DepthJumps {
        points: &sparse,
        factor: DEFAULT_JUMP_FACTOR,
        gaps: true,
    };
    assert!(!bridging_triangles(&uv, &d.triangles, jumps)
        .unwrap()
        .into_iter()
        .any(|b| b));
}

#[test]
fn one_call_trims_as_the_two_steps_do() {
    let mut p = terrain(30, 25, 1.5, |x, _| if x < 14.5 { 0.0 } else { 12.0 });
    // A bore: drop the points of a disc so long edges span it.
    p.retain(|q| (q.x - 8.0).powi(2) + (q.y - 18.0).powi(2) > 9.0);
    let uv = planar(&p);
    let d = delaunay(&uv).unwrap();
    let limit = DEFAULT_MAX_EDGE_FACTOR * median_spacing(&uv, &d.triangles).unwrap();
    let jumps = DepthJumps {
        points: &p,
        factor: DEFAULT_JUMP_FACTOR,
        gaps: true,
    };
    let two_steps = trim_long_edges(&uv, &d.triangles, limit, Some(jumps)).unwrap();
    let one = delaunay_trimmed(&uv, &p, None, DEFAULT_JUMP_FACTOR, &Progress::new()).unwrap();
    assert_eq!(one.max_edge, limit);
    assert_eq!(one.triangles, two_steps);
    assert!(one.triangles.len() < d.triangles.len());
    // trimmed: exactly the vertices of the triangulation that no kept face uses.
    let in_faces = |t: &[[u32; 3]], v: u32| t.iter().flatten().any(|&w| w == v);
    let lost: Vec<u32> = (0..uv.len() as u32)
        .filter(|&v| in_faces(&d.triangles, v) && !in_faces(&one.triangles, v))
        .collect();
    assert_eq!(one.trimmed, lost);
    // max_edge = inf turns the depth jumps off too.
    let all = delaunay_trimmed(
        &uv,
        &p,
        Some(f64::INFINITY),
        DEFAULT_JUMP_FACTOR,
        &Progress::new(),
    )
    .unwrap();
    assert_eq!(all.triangles.len(), d.triangles.len());
}

#[test]
fn the_progress_of_a_trimmed_delaunay_reaches_the_passes_it_planned() {
    // The sweep (a jittered terrain) and spade (an exact grid, refused by the proof) both
    // count every point of every pass, and plan them all before the first is done.
    let jittered = terrain(40, 30, 1.5, |x, y| x * y);
    let grid: Vec<DVec3> = (0..40 * 30)
        .map(|k| DVec3::new((k % 40) as f64, (k / 40) as f64, 0.0))
        .collect();
    for p in [jittered, grid] {
        let (uv, n) = (planar(&p), p.len() as u64);
        let progress = Progress::new();
        delaunay_trimmed(&uv, &p, None, DEFAULT_JUMP_FACTOR, &progress).unwrap();
        assert_eq!(progress.total(), TRIMMED_PASSES * n);
        assert_eq!(progress.done(), progress.total());
        let alone = Progress::new();
        crate::triangulate::delaunay::delaunay_ordered(&uv, &alone).unwrap();
        assert_eq!((alone.done(), alone.total()), (3 * n, 3 * n));
    }
}

#[test]
fn the_spacing_of_a_triangulation_is_median_spacing_bit_for_bit() {
    // Each edge once and the points' own box give median_spacing's value: a jittered
    // terrain, the same with exact copies and near-duplicates (the near-duplicate rule
    // reads the box), an exact grid (spade answers, input labels), at extreme scales.
    let base = planar(&terrain(30, 20, 1.3, |x, y| x * y));
    let mut copies = base.clone();
    copies.extend([base[3], base[40], base[3]]);
    copies.push([base[7][0] + 1e-12, base[7][1]]);
    let grid: Vec<[f64; 2]> = (0..225)
        .map(|k| [(k % 15) as f64, (k / 15) as f64 * 0.7])
        .collect();
    for uv in [base, copies, grid] {
        for scale in [1.0, 1e-300, 1e300] {
            let uv: Vec<[f64; 2]> = uv.iter().map(|p| [p[0] * scale, p[1] * scale]).collect();
            let (d, order) =
                crate::triangulate::delaunay::delaunay_ordered(&uv, &Progress::new()).unwrap();
            let local: Vec<[f64; 2]> = match &order {
                Some(to_input) => to_input.iter().map(|&i| uv[i as usize]).collect(),
                None => uv.clone(),
            };
            let fused = triangulation_spacing(&local, &d.triangles, &d.twins).unwrap();
            assert_eq!(
                fused.to_bits(),
                median_spacing(&local, &d.triangles).unwrap().to_bits()
            );
            assert!(fused > 0.0, "scale {scale}");
        }
    }
}

#[test]
fn the_sweep_ordered_trimming_is_that_of_input_labels_on_any_thread_count() {
    // A step and a bore; trimming in the sweep's labels (delaunay_trimmed) keeps the
    // triangles that trimming spade's triangulation in input labels keeps.
    let mut p = terrain(40, 30, 1.2, |x, _| if x < 20.5 { 0.0 } else { 9.0 });
    p.retain(|q| (q.x - 10.0).powi(2) + (q.y - 15.0).powi(2) > 12.0);
    let uv = planar(&p);
    let spade = crate::triangulate::delaunay::spade_delaunay(&crate::geometry::unit_square(&uv))
        .unwrap()
        .triangles;
    let limit = DEFAULT_MAX_EDGE_FACTOR * median_spacing(&uv, &spade).unwrap();
    let jumps = DepthJumps {
        points: &p,
        factor: DEFAULT_JUMP_FACTOR,
        gaps: true,
    };
    let sorted = |mut t: Vec<[u32; 3]>| {
        t.iter_mut().for_each(|f| {
            let k = (0..3).min_by_key(|&k| f[k]).unwrap();
            f.rotate_left(k);
        });
        t.sort_unstable();
        t
    };
    let reference = sorted(trim_long_edges(&uv, &spade, limit, Some(jumps)).unwrap());
    let run = |threads| {
        rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .unwrap()
            .install(|| {
                delaunay_trimmed(&uv, &p, None, DEFAULT_JUMP_FACTOR, &Progress::new()).unwrap()
            })
    };
    let (one, two) = (run(1), run(2));
    assert_eq!(one.triangles, two.triangles);
    assert_eq!(one.trimmed, two.trimmed);
    assert_eq!(one.max_edge, limit);
    assert!(reference.len() < spade.len());
    assert_eq!(sorted(one.triangles), reference);
}

#[test]
fn collinear_hull_slivers_are_peeled() {
    // Three hull points on x + y = 1 with the middle one 1e-12 inside: the hull edge
    // skips it and Delaunay fills the gap with a zero-area sliver, which trimming drops.
    let inward = 0.5 - (2.0f64).powi(-40);
    let uv = vec![
        [0.0, 0.0],
        [0.25, 0.75],
        [inward, inward],
        [0.75, 0.25],
        [0.0, 0.5],
    ];
    let d = delaunay(&uv).unwrap();
    let slivers = |t: &[[u32; 3]]| {
        t.iter()
            .filter(|f| !well_formed(uv[f[0] as usize], uv[f[1] as usize], uv[f[2] as usize]))
            .count()
    };
    assert!(
        slivers(&d.triangles) > 0,
        "the fixture must contain a sliver"
    );
    let kept = trim_long_edges(&uv, &d.triangles, 10.0, None).unwrap();
    assert_eq!(slivers(&kept), 0);
    assert_eq!(kept.len(), d.triangles.len() - slivers(&d.triangles));
    HalfEdgeMesh::from_triangles(uv.len(), &kept)
        .unwrap()
        .validate(&uv)
        .unwrap();
}

#[test]
fn pinches_are_resolved() {
    // Two squares touching at one corner; trimming the long diagonals leaves a bow tie.
    let uv = vec![
        [0.0, 0.0],
        [1.0, 0.0],
        [1.0, 1.0],
        [0.0, 1.0],
        [2.0, 1.0],
        [2.0, 2.0],
        [1.0, 2.0],
        [1.0, 1.0 + 1e-9],
    ];
    let tris = vec![[0, 1, 2], [0, 2, 3], [2, 4, 5], [2, 5, 6]];
    let kept = trim_long_edges(&uv, &tris, f64::INFINITY, None).unwrap();
    assert_eq!(kept.len(), 2);
    HalfEdgeMesh::from_triangles(uv.len(), &kept)
        .unwrap()
        .validate(&uv)
        .unwrap();
    // Equal fans: the one holding the smallest sorted corner triple stays, whatever
    // the order of the triangles (a tile lists them in its own order).
    assert_eq!(kept, vec![[0, 1, 2], [0, 2, 3]]);
    let reordered = vec![[2, 5, 6], [2, 4, 5], [0, 2, 3], [0, 1, 2]];
    let kept = trim_long_edges(&uv, &reordered, f64::INFINITY, None).unwrap();
    assert_eq!(kept, vec![[0, 2, 3], [0, 1, 2]]);
}

#[test]
fn later_bridge_rounds_on_the_neighbourhood_are_full_rounds() {
    // Reference: every round after the first over all kept triangles, as the rule reads.
    let full = |uv: &[[f64; 2]], triangles: &[[u32; 3]], jumps: &UnitJumps| {
        let (shape, shortest_at) = shapes(uv, triangles, jumps).unwrap();
        let mut dropped = round(&jumps.unit, triangles, &shape, jumps, true, |v| {
            f64::from_bits(shortest_at[v as usize].load(Ordering::Relaxed))
        })
        .unwrap();
        let mut rounds = 1;
        loop {
            let live: Vec<usize> = (0..triangles.len()).filter(|&i| !dropped[i]).collect();
            let list: Vec<[u32; 3]> = live.iter().map(|&i| triangles[i]).collect();
            let mut at = vec![f64::INFINITY; jumps.unit.len()];
            for t in &list {
                let shortest = jumps.lengths(t).into_iter().fold(f64::INFINITY, f64::min);
                t.iter()
                    .for_each(|&v| at[v as usize] = at[v as usize].min(shortest));
            }
            let live_shape: Vec<f64> = live.iter().map(|&i| shape[i]).collect();
            let more = round(&jumps.unit, &list, &live_shape, jumps, false, |v| {
                at[v as usize]
            })
            .unwrap();
            if !more.contains(&true) {
                return (dropped, rounds);
            }
            rounds += 1;
            live.iter().zip(more).for_each(|(&i, m)| dropped[i] |= m);
        }
    };
    let mut most = 0;
    for seed in 0..12u64 {
        // Jittered lines as benches/peers.py scans them (the convex hull's slivers along
        // the ragged ends of the lines go over several rounds), some with missed
        // stretches and a step.
        let (per, lines) = (40 + 7 * seed as usize, 30 + 5 * seed as usize);
        let jitter = crate::testing::random_points(per * lines, seed);
        let mut p: Vec<DVec3> = (0..per * lines)
            .map(|k| {
                let x = (k % per) as f64 + 0.1 * jitter[k][0] - 0.05;
                let y = (k / per) as f64 * 1.3 + 0.13 * jitter[k][1] - 0.065;
                let step = if seed % 3 == 1 && x > 20.5 { 6.0 } else { 0.0 };
                DVec3::new(x, y, 0.05 * (x + y) + step)
            })
            .collect();
        if seed % 3 == 2 {
            p.retain(|q| ((q.y * 0.37 + q.x * 0.11) % 7.0) > 1.0 || q.x < 10.0);
        }
        let uv = planar(&p);
        let d = delaunay(&uv).unwrap();
        let jumps = UnitJumps::gathered(
            DepthJumps {
                points: &p,
                factor: DEFAULT_JUMP_FACTOR,
                gaps: true,
            },
            None,
        )
        .unwrap();
        let (expected, rounds) = full(&uv, &d.triangles, &jumps);
        assert_eq!(
            bridging_in_box(&uv, &d.triangles, &jumps).unwrap(),
            expected,
            "seed {seed}"
        );
        most = most.max(rounds);
    }
    assert!(most >= 3, "the fixtures must need several rounds ({most})");
}

#[test]
fn trimming_refuses_lengths_and_factors_out_of_range() {
    let uv = vec![[0.0, 0.0], [1.0, 0.0], [0.0, 1.0], [1.0, 1.0]];
    let points: Vec<DVec3> = uv.iter().map(|p| DVec3::new(p[0], p[1], 0.0)).collect();
    let triangles = delaunay(&uv).unwrap().triangles;
    let named = |r: crate::Result<Vec<[u32; 3]>>| match r {
        Err(crate::Error::InvalidParameter { name, .. }) => name,
        other => panic!("{other:?}"),
    };
    for bad in [f64::NAN, 0.0, -1.0, f64::NEG_INFINITY] {
        assert_eq!(
            named(trim_long_edges(&uv, &triangles, bad, None)),
            "max_edge"
        );
        let jumps = DepthJumps {
            points: &points,
            factor: bad,
            gaps: true,
        };
        let r = trim_long_edges(&uv, &triangles, 1.0, Some(jumps));
        assert_eq!(named(r), "jump_factor");
        let err = delaunay_trimmed(&uv, &points, Some(bad), 3.0, &Progress::new()).unwrap_err();
        assert!(err.to_string().contains("max_edge"), "{err}");
        let err = delaunay_trimmed(&uv, &points, None, bad, &Progress::new()).unwrap_err();
        assert!(err.to_string().contains("jump_factor"), "{err}");
    }
    let short = DepthJumps {
        points: &points[..3],
        factor: 3.0,
        gaps: true,
    };
    assert_eq!(
        named(trim_long_edges(&uv, &triangles, 1.0, Some(short))),
        "points"
    );
    assert!(delaunay_trimmed(&uv, &points[..3], None, 3.0, &Progress::new()).is_err());
    // Infinite values turn the rules off; jumps off need no 3-D points.
    assert!(trim_long_edges(&uv, &triangles, f64::INFINITY, None).is_ok());
    assert!(delaunay_trimmed(
        &uv,
        &[],
        Some(f64::INFINITY),
        f64::INFINITY,
        &Progress::new()
    )
    .is_ok());
}

/// Twice the area of `t` over `uv`, summed (floating point; the exact check is Python's).
fn area2_sum(uv: &[[f64; 2]], t: &[[u32; 3]]) -> f64 {
    t.iter()
        .map(|f| orient2d(uv[f[0] as usize], uv[f[1] as usize], uv[f[2] as usize]))
        .sum()
}

#[test]
fn near_duplicate_corners_are_not_peeled_as_slivers() {
    // Points 0 and 3 are 1.4e-9 apart (a few ulps at 1e6). The needle (3, 2, 0)
    // on the hull has one tiny angle only; peeling it as a collinear sliver pinched the
    // mesh at 2 and dropped (2, 3, 4): one face left, 62 % of the hull gone, at ∞.
    let uv = vec![
        [864018.0169228879, 578188.7247198023],
        [982831.7604447701, 466903.4418308231],
        [50990.34647276224, 311484.921899309],
        [864018.0169228867, 578188.7247198031],
        [120643.19475619245, 574708.3977747394],
    ];
    let d = delaunay(&uv).unwrap();
    assert_eq!(d.triangles.len(), 3);
    assert!(d.duplicates().is_empty());
    let kept = trim_long_edges(&uv, &d.triangles, f64::INFINITY, None).unwrap();
    assert_eq!(kept, d.triangles);
    let t = delaunay_trimmed(
        &uv,
        &[],
        Some(f64::INFINITY),
        f64::INFINITY,
        &Progress::new(),
    )
    .unwrap();
    assert_eq!(t.triangles.len(), 3);
    assert!(t.trimmed.is_empty());
    assert_eq!(area2_sum(&uv, &t.triangles), area2_sum(&uv, &d.triangles));
    HalfEdgeMesh::from_triangles(uv.len(), &t.triangles)
        .unwrap()
        .validate(&uv)
        .unwrap();
}

#[test]
fn only_slivers_with_a_straight_angle_are_collinear() {
    let (a, b) = ([0.0, 0.0], [1.0, 0.0]);
    // A corner 1e-12 off the middle of a-b: angles (0, 0, π).
    assert!(collinear_sliver(a, b, [0.5, 1e-12]));
    // A near-duplicate of a, 1e-12 away at 60°: angles (0, 60°, 120°), a real needle.
    let needle = [0.5e-12, 0.866e-12];
    assert!(!collinear_sliver(a, b, needle));
    assert!(!well_formed(a, b, needle));
    // Clockwise or flat: always peeled.
    assert!(collinear_sliver(a, [0.5, 1e-12], b));
    assert!(collinear_sliver(a, [0.5, 0.0], b));
}
