use super::*;
use crate::strips::fuchs::path_triangles;
use crate::strips::fuchs::Solver;
use crate::strips::lines::{segment_lines, DEFAULT_GAP_FACTOR};

/// A height field z = f(x, y) sampled on `rows` lines y = r·dy of points x = c·dx,
/// `zigzag` alternating their direction, minus the points for which `drop` holds.
fn grid(
    rows: usize,
    cols: usize,
    zigzag: bool,
    drop: impl Fn(f64, f64) -> bool,
) -> (Vec<DVec3>, Vec<i64>) {
    let mut pts = Vec::new();
    let mut ids = Vec::new();
    for r in 0..rows {
        for c in 0..cols {
            let c = if zigzag && r % 2 == 1 {
                cols - 1 - c
            } else {
                c
            };
            let (x, y) = (c as f64 * 0.5 + 0.05 * (r % 3) as f64, r as f64 * 0.7);
            if !drop(x, y) {
                pts.push(DVec3::new(x, y, (0.4 * x).sin() * (0.3 * y).cos()));
                ids.push(r as i64);
            }
        }
    }
    (pts, ids)
}

fn run(pts: &[DVec3], ids: &[i64], params: &StripParams) -> StripMesh {
    let uv: Vec<[f64; 2]> = pts.iter().map(|p| [p.x, p.y]).collect();
    let scan = segment_lines(&uv, ids, DEFAULT_GAP_FACTOR).unwrap();
    stitch(pts, &uv, &scan, params).unwrap()
}

fn methods() -> Vec<StripParams> {
    let mut out = Vec::new();
    for weight in [
        Weight::LENGTH,
        Weight::AREA,
        Weight::ANGLE,
        Weight::DIHEDRAL,
    ] {
        for method in [
            Method::ShortestPath(Solver::Dp),
            Method::ShortestPath(Solver::Banded(2)),
            Method::Lookahead(1),
            Method::Lookahead(4),
        ] {
            out.push(StripParams {
                weight,
                method,
                ..StripParams::default()
            });
        }
    }
    out
}

/// The strips of a whole scan (no context), as [`stitch_part`] gives them.
fn whole_scan(pts: &[DVec3], uv: &[[f64; 2]], ids: &[i64], params: &StripParams) -> StripMesh {
    let progress = Progress::new();
    stitch_part(pts, uv, ids, DEFAULT_GAP_FACTOR, params, None, &progress)
        .unwrap()
        .0
}

#[test]
fn parts_with_the_scan_context_give_the_whole_scans_triangles() {
    // Zig-zag lines (every other one turned round) with a hole across a part border.
    let hole = |x: f64, y: f64| (x - 6.0).powi(2) + (y - 2.8).powi(2) < 1.6f64.powi(2);
    let (pts, ids) = grid(11, 25, true, hole);
    let uv: Vec<[f64; 2]> = pts.iter().map(|p| [p.x + 0.3 * p.z, p.y]).collect();
    let (lo, hi) = pts.iter().fold(
        (DVec3::splat(f64::INFINITY), DVec3::splat(f64::NEG_INFINITY)),
        |(lo, hi), &p| (lo.min(p), hi.max(p)),
    );
    let largest = uv
        .iter()
        .flat_map(|p| [p[0].abs(), p[1].abs()])
        .fold(0.0, f64::max);
    for params in methods() {
        let whole = whole_scan(&pts, &uv, &ids, &params);
        let median = segment_lines(&uv, &ids, DEFAULT_GAP_FACTOR)
            .unwrap()
            .median_step;
        let mut joined = Vec::new();
        // Lines 0..=4, 4..=7, 7..=10: each part repeats the last line of the one before.
        for (first, last) in [(0, 4), (4, 7), (7, 10)] {
            let start = ids.partition_point(|&l| l < first);
            let end = ids.partition_point(|&l| l <= last);
            let context = ScanContext {
                bounds: [lo, hi],
                largest_planar: largest,
                median_step: median,
                first_turned: first % 2 == 1,
                own_rows: None,
            };
            let (part, _) = stitch_part(
                &pts[start..end],
                &uv[start..end],
                &ids[start..end],
                DEFAULT_GAP_FACTOR,
                &params,
                Some(&context),
                &Progress::new(),
            )
            .unwrap();
            assert!(part.signed_area > 0.0);
            joined.extend(part.triangles.iter().map(|t| t.map(|k| k + start as u32)));
        }
        assert_eq!(joined, whole.triangles, "{params:?}");
    }
}

#[test]
fn parts_solved_with_their_overlap_drop_at_border_jumps_what_the_whole_scan_drops() {
    // Depth steps across the lines at both part borders (lines 4 and 7) and along them.
    let (mut pts, ids) = grid(11, 25, true, |_, _| false);
    for p in &mut pts {
        p.z += 3.0 * f64::from(u8::from(p.y > 3.1)) + 2.5 * f64::from(u8::from(p.y > 5.2));
        p.z += 2.0 * f64::from(u8::from(p.x > 6.0 + 0.2 * p.y.sin()));
    }
    let uv: Vec<[f64; 2]> = pts.iter().map(|p| [p.x, p.y]).collect();
    let (lo, hi) = pts.iter().fold(
        (DVec3::splat(f64::INFINITY), DVec3::splat(f64::NEG_INFINITY)),
        |(lo, hi), &p| (lo.min(p), hi.max(p)),
    );
    let largest = uv.iter().flat_map(|p| [p[0].abs(), p[1].abs()]);
    let largest = largest.fold(0.0, f64::max);
    let median = segment_lines(&uv, &ids, DEFAULT_GAP_FACTOR)
        .unwrap()
        .median_step;
    let params = StripParams {
        jump_factor: crate::triangulate::jumps::DEFAULT_JUMP_FACTOR,
        ..StripParams::default()
    };
    let whole = whole_scan(&pts, &uv, &ids, &params);
    assert!(whole.dropped_jumps > 0);
    let (mut joined, mut dropped, mut strips, mut cost) = (Vec::new(), 0, 0, 0.0);
    for (first, last) in [(0, 4), (4, 7), (7, 10)] {
        // Three lines beyond each border; only the part's own strips come back.
        let (lo_line, hi_line) = (first.max(3) - 3, (last + 3).min(10));
        let start = ids.partition_point(|&l| l < lo_line);
        let end = ids.partition_point(|&l| l <= hi_line);
        let own = (
            ids.partition_point(|&l| l < first) - start,
            ids.partition_point(|&l| l <= last) - start,
        );
        let context = ScanContext {
            bounds: [lo, hi],
            largest_planar: largest,
            median_step: median,
            first_turned: lo_line % 2 == 1,
            own_rows: Some(own),
        };
        let (part, _) = stitch_part(
            &pts[start..end],
            &uv[start..end],
            &ids[start..end],
            DEFAULT_GAP_FACTOR,
            &params,
            Some(&context),
            &Progress::new(),
        )
        .unwrap();
        joined.extend(part.triangles.iter().map(|t| t.map(|k| k + start as u32)));
        dropped += part.dropped_jumps;
        strips += part.n_strips;
        cost += part.cost;
    }
    assert_eq!(joined, whole.triangles);
    assert_eq!((dropped, strips), (whole.dropped_jumps, whole.n_strips));
    assert!((cost - whole.cost).abs() <= 1e-9 * whole.cost);
}

#[test]
fn a_grid_becomes_one_valid_mesh_using_every_point() {
    for zigzag in [false, true] {
        let (pts, ids) = grid(9, 25, zigzag, |_, _| false);
        for params in methods() {
            let mesh = run(&pts, &ids, &params);
            assert!(
                mesh.planar_error.is_none(),
                "{params:?}: {:?}",
                mesh.planar_error
            );
            assert!(mesh.unused.is_empty());
            assert_eq!(mesh.triangles.len(), 8 * (25 + 25 - 2));
            assert_eq!(mesh.n_strips, 8);
        }
    }
}

#[test]
fn a_hole_stays_open() {
    let centre = (6.0, 2.8);
    let hole = |x: f64, y: f64| (x - centre.0).powi(2) + (y - centre.1).powi(2) < 1.6f64.powi(2);
    let (pts, ids) = grid(9, 25, true, hole);
    let uv: Vec<[f64; 2]> = pts.iter().map(|p| [p.x, p.y]).collect();
    for params in methods() {
        let mesh = run(&pts, &ids, &params);
        assert!(
            mesh.planar_error.is_none(),
            "{params:?}: {:?}",
            mesh.planar_error
        );
        assert!(mesh.unused.is_empty());
        for t in &mesh.triangles {
            let [a, b, c] = t.map(|k| uv[k as usize]);
            let inside = orient2d(a, b, [centre.0, centre.1]) > 0.0
                && orient2d(b, c, [centre.0, centre.1]) > 0.0
                && orient2d(c, a, [centre.0, centre.1]) > 0.0;
            assert!(
                !inside,
                "{params:?}: triangle {t:?} covers the hole's centre"
            );
        }
        // One hole: one extra boundary loop, so V − E + F = 0.
        let m = HalfEdgeMesh::from_triangles(pts.len(), &mesh.triangles).unwrap();
        let e = m.edges().count() as i64;
        assert_eq!(pts.len() as i64 - e + mesh.triangles.len() as i64, 0);
    }
}

#[test]
fn lines_of_unequal_length_are_used_whole() {
    // A rotated rectangle cut into horizontal lines: ends shift from line to line.
    let (pts, ids) = grid(12, 40, false, |x, y| x < 0.3 * y || x > 14.0 + 0.25 * y);
    let mesh = run(&pts, &ids, &StripParams::default());
    assert!(mesh.planar_error.is_none(), "{:?}", mesh.planar_error);
    assert!(mesh.unused.is_empty(), "unused {:?}", mesh.unused);
}

#[test]
fn one_point_lines_are_inserted() {
    let (mut pts, mut ids) = grid(4, 10, false, |_, _| false);
    // A lone point between lines 1 and 2, inside the strip: its own line id 1.5 → 1.
    pts.push(DVec3::new(2.1, 1.05, 0.0));
    ids.push(1);
    for id in ids.iter_mut().take(pts.len() - 1) {
        if *id >= 2 {
            *id += 1;
        }
    }
    *ids.last_mut().unwrap() = 2;
    let mesh = run(&pts, &ids, &StripParams::default());
    assert!(mesh.planar_error.is_none(), "{:?}", mesh.planar_error);
    assert!(mesh.unused.is_empty());
    assert_eq!(mesh.triangles.len(), 3 * 18 + 2);
}

#[test]
fn crossing_lines_give_a_valid_mesh_and_count_what_was_dropped() {
    let mut pts = Vec::new();
    let mut ids = Vec::new();
    for r in 0..3 {
        for c in 0..10 {
            let x = c as f64;
            // Line 2 crosses line 1 halfway.
            let y = if r == 2 { 2.0 - 0.3 * x } else { r as f64 };
            pts.push(DVec3::new(x, y, 0.0));
            ids.push(r);
        }
    }
    let uv: Vec<[f64; 2]> = pts.iter().map(|p| [p.x, p.y]).collect();
    let scan = segment_lines(&uv, &ids, DEFAULT_GAP_FACTOR).unwrap();
    for params in methods() {
        let (mesh, _, first) =
            stitch_with(&pts, &uv, &scan, &params, true, None, &Progress::new()).unwrap();
        assert!(first.is_some(), "the strips overlap before the repair");
        assert!(mesh.planar_error.is_none(), "{:?}", mesh.planar_error);
        assert!(mesh.dropped_overlaps > 0);
        HalfEdgeMesh::from_triangles(pts.len(), &mesh.triangles)
            .unwrap()
            .validate(&uv)
            .unwrap();
        // The strip between the lines that do not cross is kept whole.
        assert!(mesh.triangles.len() >= 18, "{}", mesh.triangles.len());
    }
}

#[test]
fn no_triangle_bridges_a_wall_across_or_along_the_lines() {
    // A wall 6 high at x = 6: across the lines of `grid` (they run along x), and the
    // same points with lines along y, where the wall runs between two lines.
    let (mut pts, ids) = grid(9, 25, false, |_, _| false);
    pts.iter_mut()
        .for_each(|p| p.z += if p.x >= 6.0 { 6.0 } else { 0.0 });
    let columns: Vec<i64> = pts.iter().map(|p| (p.x * 2.0).round() as i64).collect();
    let mut order: Vec<usize> = (0..pts.len()).collect();
    order.sort_by_key(|&k| columns[k]);
    let along_y: Vec<DVec3> = order.iter().map(|&k| pts[k]).collect();
    let along_y_ids: Vec<i64> = order.iter().map(|&k| columns[k]).collect();
    for (pts, ids) in [(pts, ids), (along_y, along_y_ids)] {
        let uv: Vec<[f64; 2]> = pts.iter().map(|p| [p.x, p.y]).collect();
        let bridges = |t: &[u32; 3]| {
            let z = t.map(|k| pts[k as usize].z);
            z.iter().cloned().fold(f64::MIN, f64::max) - z.iter().cloned().fold(f64::MAX, f64::min)
                > 3.0
        };
        for params in methods() {
            let whole = StripParams {
                jump_factor: f64::INFINITY,
                ..params
            };
            let mut scan = segment_lines(&uv, &ids, DEFAULT_GAP_FACTOR).unwrap();
            assert!(stitch(&pts, &uv, &scan, &whole)
                .unwrap()
                .triangles
                .iter()
                .any(bridges));
            crate::strips::lines::split_at_jumps(&mut scan, &pts, &uv, params.jump_factor).unwrap();
            let mesh = stitch(&pts, &uv, &scan, &params).unwrap();
            assert!(!mesh.triangles.iter().any(bridges), "{params:?}");
            assert!(mesh.planar_error.is_none(), "{:?}", mesh.planar_error);
            // Points away from the wall are all stitched by the shortest path (a
            // greedy path's fans can leave a pinch whose smaller fan goes).
            assert!(mesh.unused.len() <= 4, "{params:?}: {:?}", mesh.unused);
            if let Method::ShortestPath(_) = params.method {
                for &k in &mesh.unused {
                    let x = pts[k as usize].x;
                    assert!((x - 5.75).abs() < 1.0, "{params:?}: point {k} at x = {x}");
                }
            }
        }
    }
}

#[test]
fn no_duplicate_or_degenerate_triangles() {
    let (pts, ids) = grid(9, 25, true, |x, y| {
        (x - 4.0).abs() < 1.2 && y > 1.0 && y < 4.0
    });
    for params in methods() {
        let mesh = run(&pts, &ids, &params);
        let mut keys: Vec<[u32; 3]> = mesh
            .triangles
            .iter()
            .map(|t| {
                let mut s = *t;
                s.sort_unstable();
                s
            })
            .collect();
        keys.sort_unstable();
        let n = keys.len();
        keys.dedup();
        assert_eq!(keys.len(), n);
        for t in &mesh.triangles {
            let [a, b, c] = t.map(|k| pts[k as usize]);
            assert!(crate::geometry::triangle_area(a, b, c) > 0.0);
        }
    }
}

#[test]
fn ties_on_flat_strips_are_broken_by_length_not_by_search_order() {
    // Flat: every path has the same area and no dihedral angle. Without the tie-break
    // the search order would pick fans of slivers.
    let (mut pts, ids) = grid(6, 20, false, |_, _| false);
    pts.iter_mut().for_each(|p| p.z = 0.0);
    for weight in [Weight::AREA, Weight::DIHEDRAL] {
        for method in [Method::ShortestPath(Solver::Dp), Method::Lookahead(3)] {
            let mesh = run(
                &pts,
                &ids,
                &StripParams {
                    weight,
                    method,
                    ..StripParams::default()
                },
            );
            for t in &mesh.triangles {
                let [a, b, c] = t.map(|k| pts[k as usize]);
                let angle = crate::geometry::smallest_angle(a, b, c).to_degrees();
                assert!(angle > 20.0, "{weight:?} {method:?}: {angle} degrees");
            }
        }
    }
}

/// Stitches `scan` with the planar check decided locally and globally: the meshes and
/// errors must be the same, and the local check may only accept what the global one
/// accepts. Returns (local verdict, global verdict).
fn local_against_global(
    pts: &[DVec3],
    uv: &[[f64; 2]],
    scan: &ScanLines,
    params: &StripParams,
) -> (bool, bool) {
    let (local, verdict, local_first) =
        stitch_with(pts, uv, scan, params, true, None, &Progress::new()).unwrap();
    let (global, none, first) =
        stitch_with(pts, uv, scan, params, false, None, &Progress::new()).unwrap();
    assert_eq!(none, None);
    assert_eq!(local.triangles, global.triangles);
    assert_eq!(local.unused, global.unused);
    assert_eq!(local.dropped_overlaps, global.dropped_overlaps);
    assert_eq!(format!("{local_first:?}"), format!("{first:?}"));
    let valid = first.is_none();
    let accepted = verdict.expect("the check was asked for");
    assert!(
        !accepted || valid,
        "the local check accepted an invalid mesh"
    );
    // Whatever the strips were, the mesh returned is valid, and only a repair drops.
    assert!(global.planar_error.is_none(), "{:?}", global.planar_error);
    assert_eq!(valid, global.dropped_overlaps == 0 || first.is_none());
    if !global.triangles.is_empty() {
        let unit = crate::geometry::unit_square(uv);
        assert!(global_check(pts.len(), &global.triangles, &unit).is_none());
    }
    (accepted, valid)
}

/// A small LCG in [0, 1), for the random scans below.
fn lcg(seed: u64) -> impl FnMut() -> f64 {
    let mut s = seed;
    move || {
        s = s
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        (s >> 11) as f64 / (1u64 << 53) as f64
    }
}

#[test]
fn the_local_check_accepts_valid_scans_like_the_global_one() {
    let centre = (6.0, 2.8);
    let hole = |x: f64, y: f64| (x - centre.0).powi(2) + (y - centre.1).powi(2) < 1.6f64.powi(2);
    let cases: Vec<(Vec<DVec3>, Vec<i64>)> = vec![
        grid(9, 25, false, |_, _| false),
        grid(9, 25, true, |_, _| false),
        grid(9, 25, true, hole),
        grid(12, 40, false, |x, y| x < 0.3 * y || x > 14.0 + 0.25 * y),
        grid(9, 25, true, |x, y| {
            (x - 4.0).abs() < 1.2 && y > 1.0 && y < 4.0
        }),
    ];
    for (pts, ids) in cases {
        let uv: Vec<[f64; 2]> = pts.iter().map(|p| [p.x, p.y]).collect();
        let scan = segment_lines(&uv, &ids, DEFAULT_GAP_FACTOR).unwrap();
        for params in methods() {
            assert_eq!(
                local_against_global(&pts, &uv, &scan, &params),
                (true, true)
            );
        }
    }
}

/// Random scans, from tame to wild: lines with holes, jitter across the lines (up to
/// crossings and folds), lines turned or shifted, random line ids, lone points. The
/// local check must agree with the global one; it may only refer valid meshes to it
/// when lone points were inserted or windows of one side touch (counted, and rare).
#[test]
fn the_local_check_refuses_exactly_what_the_global_one_refuses() {
    let (mut valid, mut invalid, mut referred) = (0, 0, 0);
    for seed in 0..600u64 {
        let mut r = lcg(seed);
        let rows = 2 + (r() * 8.0) as usize;
        let cols = 2 + (r() * 30.0) as usize;
        let across = [0.0, 0.1, 0.4, 0.9, 2.0][seed as usize % 5];
        let along = [0.0, 0.3, 1.5][(seed / 5) as usize % 3];
        let holes = r() < 0.5;
        let zigzag = r() < 0.5;
        let (mut pts, mut ids) = (Vec::new(), Vec::new());
        for row in 0..rows {
            let len = (cols as f64 * (0.5 + r())) as usize + 1;
            let shift = if r() < 0.3 { r() * 6.0 - 3.0 } else { 0.0 };
            let tilt = if r() < 0.15 { r() * 0.6 - 0.3 } else { 0.0 };
            for c in 0..len {
                let c = if zigzag && row % 2 == 1 {
                    len - 1 - c
                } else {
                    c
                };
                let x = c as f64 + shift + along * (r() - 0.5);
                let y = row as f64 + tilt * x + across * (r() - 0.5);
                if holes && ((x - 7.0).powi(2) + (y - 3.0).powi(2)).sqrt() < 2.0 {
                    continue;
                }
                pts.push(DVec3::new(x, y, (0.4 * x).sin() * (0.3 * y).cos()));
                ids.push(row as i64);
            }
        }
        if seed % 7 == 0 {
            // Lone points: a line of one point between two lines.
            for _ in 0..3 {
                let (x, y) = (r() * cols as f64, (r() * rows as f64).floor() + 0.5);
                pts.push(DVec3::new(x, y, 0.0));
                ids.push(1000 + (y * 2.0) as i64);
            }
        }
        if seed % 11 == 0 {
            // Scrambled ids: lines all over the plane.
            let n_ids = 1 + (r() * 5.0) as usize;
            ids.iter_mut()
                .for_each(|id| *id = (r() * n_ids as f64) as i64);
        }
        let mut uv: Vec<[f64; 2]> = pts.iter().map(|p| [p.x, p.y]).collect();
        if seed % 13 == 0 {
            // A fold: the plane of the second half of the points mirrored.
            let half = uv.len() / 2;
            uv[half..].iter_mut().for_each(|p| p[0] = -p[0]);
        }
        let Ok(scan) = segment_lines(&uv, &ids, DEFAULT_GAP_FACTOR) else {
            continue;
        };
        let params = StripParams {
            method: if seed % 3 == 0 {
                Method::Lookahead(2)
            } else {
                StripParams::default().method
            },
            ..StripParams::default()
        };
        let (accepted, ok) = local_against_global(&pts, &uv, &scan, &params);
        match (accepted, ok) {
            (true, _) => valid += 1,
            (false, false) => invalid += 1,
            (false, true) => referred += 1,
        }
    }
    assert!(
        valid > 150 && invalid > 50,
        "{valid} valid, {invalid} invalid"
    );
    assert!(
        referred <= 60,
        "{referred} valid meshes referred to the global check"
    );
}

/// Hand-made scan lines the local check must not trust: a point in two lines, windows
/// of one side touching or sharing an edge (a repeated directed edge), a fold.
#[test]
fn adversarial_scan_lines_go_to_the_global_check() {
    let (pts, ids) = grid(4, 10, false, |_, _| false);
    let uv: Vec<[f64; 2]> = pts.iter().map(|p| [p.x, p.y]).collect();
    let params = StripParams::default();
    let base = segment_lines(&uv, &ids, DEFAULT_GAP_FACTOR).unwrap();
    assert_eq!(
        local_against_global(&pts, &uv, &base, &params),
        (true, true)
    );
    // Point 15 (line 1) repeated in line 2.
    let mut twice = base.clone();
    twice.lines[2][0].insert(5, 15);
    assert_eq!(
        local_against_global(&pts, &uv, &twice, &params),
        (false, false)
    );
    // Line 1 split so that its two halves share point 14: two windows of one side
    // touch in one point.
    let mut touch = base.clone();
    let line = touch.lines[1][0].clone();
    touch.lines[1] = vec![line[..5].to_vec(), line[4..].to_vec()];
    let (_, ok) = local_against_global(&pts, &uv, &touch, &params);
    assert!(!ok);
    // Line 1 split into overlapping halves: repeated directed edges.
    let mut overlap = base.clone();
    overlap.lines[1] = vec![line[..6].to_vec(), line[3..].to_vec()];
    assert_eq!(
        local_against_global(&pts, &uv, &overlap, &params),
        (false, false)
    );
    // A fold: the middle line mirrored, so its strips turn clockwise.
    let mut fold_uv = uv.clone();
    for (p, &id) in fold_uv.iter_mut().zip(&ids) {
        if id == 2 {
            p[1] = 0.7 * 0.5;
        }
    }
    let fold = segment_lines(&fold_uv, &ids, DEFAULT_GAP_FACTOR).unwrap();
    assert_eq!(
        local_against_global(&pts, &fold_uv, &fold, &params),
        (false, false)
    );
}

/// A below and an above window of one line meeting in one point: a pinch, which the
/// local plan refers to the global check and the global check refuses.
#[test]
fn windows_meeting_in_one_point_are_a_pinch_for_both_checks() {
    use crate::strips::fuchs::Step::{A, B};
    // Lines 0, 1, 2: points 0-2, 3-5, 6-8 on y = 0, 1, 2, each shifted by one.
    let uv: Vec<[f64; 2]> = (0..9)
        .map(|k| [(k % 3 + k / 3) as f64, (k / 3) as f64])
        .collect();
    let at = |line, lo| check::Window {
        line,
        segment: 0,
        lo,
    };
    // Strip 0 uses points 3, 4 of line 1, strip 1 points 4, 5: they meet in point 4.
    let tasks = [
        (vec![0, 1, 2], vec![3, 4], at(0, 0), at(1, 0), [A, A, B]),
        (vec![4, 5], vec![6, 7, 8], at(1, 1), at(2, 0), [A, B, B]),
    ];
    let mut triangles = Vec::new();
    for (a, b, _, _, path) in &tasks {
        triangles.extend(path_triangles(path, a, b).unwrap());
    }
    let tasks: Vec<Task> = tasks
        .into_iter()
        .enumerate()
        .map(|(line, (a, b, a_at, b_at, _))| Task {
            a,
            b,
            a_at,
            b_at,
            line,
        })
        .collect();
    let lines = vec![
        vec![vec![0, 1, 2]],
        vec![vec![3, 4, 5]],
        vec![vec![6, 7, 8]],
    ];
    assert!(check::plan(&tasks, &lines, 9).unwrap().is_none());
    let error = global_check(9, &triangles, &uv).expect("a pinch");
    assert!(error.to_string().contains("pinch"), "{error}");
}

#[test]
fn bad_input_is_an_error() {
    let (pts, ids) = grid(3, 5, false, |_, _| false);
    let uv: Vec<[f64; 2]> = pts.iter().map(|p| [p.x, p.y]).collect();
    let scan = segment_lines(&uv, &ids, 4.0).unwrap();
    assert!(stitch(&pts[1..], &uv, &scan, &StripParams::default()).is_err());
    let bad = StripParams {
        method: Method::Lookahead(0),
        ..StripParams::default()
    };
    assert!(stitch(&pts, &uv, &scan, &bad).is_err());
    let mut nan = pts.clone();
    nan[3].z = f64::NAN;
    assert!(stitch(&nan, &uv, &scan, &StripParams::default()).is_err());
}

#[test]
fn the_progress_of_the_strips_reaches_the_triangles_planned() {
    // A hole splits some lines into segments: several strips per line pair.
    let hole = |x: f64, y: f64| (x - 6.0).powi(2) + (y - 2.8).powi(2) < 1.6f64.powi(2);
    let (pts, ids) = grid(11, 25, true, hole);
    let uv: Vec<[f64; 2]> = pts.iter().map(|p| [p.x, p.y]).collect();
    for params in methods() {
        let progress = Progress::new();
        stitch_part(
            &pts,
            &uv,
            &ids,
            DEFAULT_GAP_FACTOR,
            &params,
            None,
            &progress,
        )
        .unwrap();
        // 10 line pairs of about 2 x 25 - 2 triangles each, less the hole's
        assert!(
            (400..=480).contains(&progress.total()),
            "{}",
            progress.total()
        );
        assert_eq!(progress.done(), progress.total());
    }
}
