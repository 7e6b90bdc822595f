use super::super::testing::{assert_beyond_max_voxels, fused_volume, view_from_above};
use super::*;
use crate::fusion::MAX_MARGIN;
use glam::DMat3;

fn looking_down(depth: Vec<f64>, width: usize, height: usize, step: f64) -> DepthView {
    view_from_above([0.0; 2], step, [width, height], |i, j| depth[j * width + i])
}

#[test]
fn a_plane_gives_its_distance_and_empty_space_above() {
    let mut vol = Volume::new([0.0; 3], 1.0, [5, 5, 9], 2.0).unwrap();
    vol.integrate(&looking_down(vec![4.0; 25], 5, 5, 1.0))
        .unwrap();
    for k in 0..9 {
        let n = vol.index(2, 2, k);
        let d = k as f64 - 4.0;
        // averaged from the truncation (2) in front to BEHIND_VOXELS (1.5) behind
        match vol.evidence(n) {
            Evidence::Measured => {
                assert!(
                    (vol.value(n) - d).abs() < 1e-6 && d >= -BEHIND_VOXELS,
                    "{k}"
                )
            }
            Evidence::Empty => assert!(d > 2.0, "{k}"),
            Evidence::Unseen => assert!(d < -BEHIND_VOXELS, "{k}"),
        }
    }
    assert_eq!(vol.evidence(vol.index(2, 2, 8)), Evidence::Empty);
    assert_eq!(vol.evidence(vol.index(2, 2, 2)), Evidence::Unseen);
}

#[test]
fn a_slab_thinner_than_the_truncation_keeps_its_far_face() {
    // a slab from z = 4 to z = 5 seen from above (its face z = 5) and from below (its
    // face z = 4), with a truncation (3) longer than the slab is thick
    let mut vol = Volume::new([0.0; 3], 1.0, [5, 5, 9], 3.0).unwrap();
    vol.integrate(&looking_down(vec![5.0; 25], 5, 5, 1.0))
        .unwrap();
    // from below: world = (x, 4 - y, -z) of the scanner's (x, y, z)
    let mut pose = [0.0; 16];
    (pose[0], pose[5], pose[7], pose[10], pose[15]) = (1.0, -1.0, 4.0, -1.0, 1.0);
    let below = DepthView::new(pose, [0.0, 0.0], 1.0, 5, 5, vec![-4.0; 25], vec![1.0; 25]);
    vol.integrate(&below.unwrap()).unwrap();
    // node z = 3 lies 1 in front of the face seen from below and 2 behind the one seen
    // from above: that view's guess of solid behind its face (2 < 3) no longer outvotes
    // the view that saw the node empty (the mean would be -0.5: the face pushed out)
    let n = vol.index(2, 2, 3);
    assert_eq!(vol.evidence(n), Evidence::Measured);
    assert!((vol.value(n) - 1.0).abs() < 1e-6, "{}", vol.value(n));
    assert!((vol.value(vol.index(2, 2, 6)) - 1.0).abs() < 1e-6);
}

#[test]
fn rays_without_return_carve_down_to_the_first_measured_surface() {
    // view 1 (from above) sees a plane at z = 4 over x < 3, nothing beyond
    let depth: Vec<f64> = (0..25)
        .map(|k| if k % 5 < 3 { 4.0 } else { f64::NAN })
        .collect();
    let top = looking_down(depth, 5, 5, 1.0);
    let mut vol = Volume::new([0.0; 3], 1.0, [5, 5, 9], 2.0).unwrap();
    vol.integrate(&top).unwrap();
    vol.carve(&top).unwrap();
    // under the missed rays: empty all the way down
    assert_eq!(vol.evidence(vol.index(4, 2, 0)), Evidence::Empty);
    // under the plane: unseen (solid)
    assert_eq!(vol.evidence(vol.index(1, 2, 0)), Evidence::Unseen);
    // a view whose returns were all lost stops at the measured plane: it carves nothing
    // below it
    let mut lower = Volume::new([0.0; 3], 1.0, [5, 5, 9], 2.0).unwrap();
    let plane = looking_down(vec![4.0; 25], 5, 5, 1.0);
    lower.integrate(&plane).unwrap();
    let lost = looking_down(vec![f64::NAN; 25], 5, 5, 1.0);
    lower.carve(&lost).unwrap();
    assert_eq!(lower.evidence(lower.index(1, 2, 0)), Evidence::Unseen);
}

#[test]
fn a_view_that_saw_a_node_in_front_outvotes_one_behind_a_surface() {
    // one view sees a surface at z = 4 (node z = 3 lies 1 behind it, within the
    // truncation), another a surface at z = 0 (node z = 3 lies 3 in front of it)
    let mut vol = Volume::new([0.0; 3], 1.0, [5, 5, 9], 2.0).unwrap();
    vol.integrate(&looking_down(vec![4.0; 25], 5, 5, 1.0))
        .unwrap();
    let n = vol.index(2, 2, 3);
    assert_eq!(vol.evidence(n), Evidence::Measured);
    assert!(vol.value(n) < 0.0);
    vol.integrate(&looking_down(vec![0.0; 25], 5, 5, 1.0))
        .unwrap();
    assert_eq!(vol.evidence(n), Evidence::Empty);
    // a positive mean stays measured: the node z = 5 is 1 in front of the first surface
    let m = vol.index(2, 2, 5);
    assert_eq!(vol.evidence(m), Evidence::Measured);
    assert!((vol.value(m) - 1.0).abs() < 1e-6);
}

#[test]
fn between_nodes_the_carving_ends_where_the_rays_footprints_meet() {
    // rays at x = 0.3 + i: a plane at z = 4 for i < 3 (x <= 2.3), no return beyond
    // (x >= 3.3): the carved space begins halfway, at x = 2.8, between nodes x = 2, 3
    let view = view_from_above(
        [0.3, 0.0],
        1.0,
        [5, 5],
        |i, _| {
            if i < 3 {
                4.0
            } else {
                f64::NAN
            }
        },
    );
    let vol = fused_volume(&view, [0.0; 3], [5, 5, 9], 2.0);
    assert!(vol.value_at(DVec3::ZERO, &[]).is_err());
    for n in 0..5 * 5 * 9 {
        let p = vol.node(n % 5, (n / 5) % 5, n / 25);
        assert_eq!(vol.value_at(p, &[&view]).unwrap(), vol.value(n));
    }
    let at = |x: f64| vol.value_at(DVec3::new(x, 2.0, 0.0), &[&view]).unwrap();
    assert_eq!(at(2.0), -2.0);
    assert_eq!(at(2.75), -2.0);
    assert_eq!(at(2.85), 2.0);
    assert_eq!(at(3.0), 2.0);
}

/// A view of a ball of radius `r` about `centre` (world) from the pose `pose`
/// (scanner to world), rays `step` apart over scanner x, y in [-30, 30]; the rays of
/// every 7th pixel lose their return (grazing-angle losses: runs of one).
fn ball_view(pose: [f64; 16], centre: DVec3, r: f64, step: f64) -> DepthView {
    let n = (60.0 / step) as usize;
    let rot = DMat3::from_cols(
        DVec3::new(pose[0], pose[4], pose[8]),
        DVec3::new(pose[1], pose[5], pose[9]),
        DVec3::new(pose[2], pose[6], pose[10]),
    );
    let c = rot.transpose() * (centre - DVec3::new(pose[3], pose[7], pose[11]));
    let (mut depth, mut cos) = (vec![f64::NAN; n * n], vec![1.0; n * n]);
    for p in 0..n * n {
        let (x, y) = (-30.0 + (p % n) as f64 * step, -30.0 + (p / n) as f64 * step);
        let h2 = r * r - (x - c.x).powi(2) - (y - c.y).powi(2);
        if h2 > 0.0 && p % 7 != 3 {
            depth[p] = c.z + h2.sqrt();
            cos[p] = h2.sqrt() / r;
        }
    }
    DepthView::new(pose, [-30.0, -30.0], step, n, n, depth, cos).unwrap()
}

/// Scanner-to-world poses: the rotation taking +z to `toward`, about the origin.
fn pose_toward(toward: DVec3) -> [f64; 16] {
    let z = toward.normalize();
    let x = z.any_orthonormal_vector();
    let y = z.cross(x);
    let mut pose = [0.0; 16];
    for (col, axis) in [x, y, z].into_iter().enumerate() {
        for row in 0..3 {
            pose[row * 4 + col] = axis[row];
        }
    }
    pose[15] = 1.0;
    pose
}

/// The fusion of `views` node by node over every node of the grid (the dense grid it
/// replaced): per node the state `add_return` and the carving leave, ray stops found
/// by stepping every ray through every node.
fn dense_reference(vol: &Volume, views: &[DepthView]) -> Vec<(f32, f32, u8)> {
    let [nx, ny, nz] = vol.dims();
    let mut state = vec![(0.0_f32, 0.0_f32, 0_u8); nx * ny * nz];
    let node = |n: usize| vol.node(n % nx, (n / nx) % ny, n / (nx * ny));
    for view in views {
        for (n, s) in state.iter_mut().enumerate() {
            let q = view.to_scanner(node(n));
            if let Lookup::Hit {
                depth,
                cos,
                weight: trust,
                front,
            } = view.lookup(q.x, q.y)
            {
                let d = [(q.z - depth) * cos, (q.z - front) * cos];
                add_return(
                    d,
                    cos * trust,
                    [vol.truncation, vol.behind],
                    (&mut s.0, &mut s.1, &mut s.2),
                );
            }
        }
    }
    let measured: Vec<bool> = state
        .iter()
        .map(|s| classify(s.0, s.1, s.2) == Evidence::Measured)
        .collect();
    for view in views {
        let (w, h) = view.size();
        let zs: Vec<f64> = (0..8)
            .map(|c| {
                let at = |bit: usize, n: usize| if c & bit == 0 { 0 } else { n - 1 };
                view.to_scanner(vol.node(at(1, nx), at(2, ny), at(4, nz))).z
            })
            .collect();
        let z_lo = zs.iter().copied().fold(f64::INFINITY, f64::min);
        let z_hi = zs.iter().copied().fold(f64::NEG_INFINITY, f64::max);
        let dz = 0.5 * vol.voxel();
        let steps = ((z_hi - z_lo) / dz).ceil() as usize + 1;
        let stop: Vec<f64> = (0..w * h)
            .map(|pixel| {
                if !view.is_miss(pixel) {
                    return f64::INFINITY;
                }
                let lost = view.lost_return_depth(pixel).unwrap_or(f64::NEG_INFINITY);
                let [x, y] = view.ray_xy(pixel);
                let hit = (0..steps).map(|s| z_hi - s as f64 * dz).find(|&z| {
                    let p = view.to_world(DVec3::new(x, y, z));
                    vol.nearest(p).is_some_and(|n| measured[n])
                });
                hit.unwrap_or(f64::NEG_INFINITY).max(lost)
            })
            .collect();
        for (n, s) in state.iter_mut().enumerate() {
            let q = view.to_scanner(node(n));
            if let Lookup::Miss(pixel) = view.lookup(q.x, q.y) {
                if q.z > stop[pixel] {
                    s.2 |= EMPTY;
                }
            }
        }
    }
    state
}

#[test]
fn the_blocks_hold_what_a_dense_grid_would_and_only_near_the_surface() {
    let centre = DVec3::new(0.7, -1.3, 0.4);
    let views: Vec<DepthView> = [
        DVec3::Z,
        -DVec3::Z,
        DVec3::X,
        DVec3::new(-0.3, 1.0, 0.2),
        DVec3::new(0.5, -0.4, -0.8),
    ]
    .into_iter()
    .map(|t| ball_view(pose_toward(t), centre, 9.0, 0.9))
    .collect();
    // a grid whose sides are no multiple of the block's, the ball off its centre, the
    // image's edge inside the grid along x
    let dims = [62, 58, 61];
    let mut vol = Volume::new([-30.2, -28.9, -31.0], 1.0, dims, 3.0).unwrap();
    for view in &views {
        vol.integrate(view).unwrap();
    }
    for view in &views {
        vol.carve(view).unwrap();
    }
    let reference = dense_reference(&vol, &views);
    let mut kinds = [0; 3];
    for (n, &(sum, weight, flags)) in reference.iter().enumerate() {
        let evidence = classify(sum, weight, flags);
        assert_eq!(vol.evidence(n), evidence, "node {n}");
        assert_eq!(
            vol.value(n).to_bits(),
            distance(sum, weight, flags, vol.truncation()).to_bits(),
            "node {n}"
        );
        kinds[evidence as usize] += 1;
    }
    // all three kinds of evidence, and distances allocated for a part of the grid only
    // (a large one here: a return at a grazing angle, its cosine down to MIN_COS,
    // averages along its ray up to 1 / MIN_COS truncations in front of its surface)
    assert!(kinds.iter().all(|&k| k > 1000), "{kinds:?}");
    let nodes: usize = dims.iter().product();
    let [distances, _] = vol.allocated();
    assert!(
        distances > 0 && distances < nodes * 2 / 3,
        "{distances} of {nodes}"
    );
    let views: Vec<&DepthView> = views.iter().collect();
    for n in (0..nodes).step_by(97) {
        let [i, j, k] = vol.coords(n);
        assert_eq!(
            vol.value_at(vol.node(i, j, k), &views).unwrap(),
            vol.value(n)
        );
    }
}

#[test]
fn a_volume_refuses_to_allocate_beyond_max_voxels() {
    let view = ball_view(pose_toward(DVec3::Z), DVec3::ZERO, 9.0, 0.9);
    let mut vol = Volume::new([-20.0; 3], 1.0, [41, 41, 41], 3.0)
        .unwrap()
        .with_max_voxels(4 * 512);
    assert_beyond_max_voxels(&vol.integrate(&view).unwrap_err());
    assert!(vol.allocated().iter().sum::<usize>() <= 4 * 512);
    // the same view in a volume allowed enough
    let mut roomy = Volume::new([-20.0; 3], 1.0, [41, 41, 41], 3.0).unwrap();
    roomy.integrate(&view).unwrap();
    assert!(roomy.allocated().iter().sum::<usize>() > 4 * 512);
}

#[test]
fn refuses_bad_grids() {
    assert!(Volume::new([0.0; 3], 0.0, [4, 4, 4], 1.0).is_err());
    assert!(Volume::new([0.0; 3], 1.0, [4, 1, 4], 1.0).is_err());
    assert!(Volume::new([0.0; 3], 1.0, [4, 4, 4], 0.5).is_err());
    assert!(Volume::new([0.0; 3], 1.0, [usize::MAX, 4, 4], 1.0).is_err());
}

#[test]
fn a_return_of_weight_zero_neither_averages_nor_votes() {
    // one view sees a plane at z = 4; another, from above too, a return at z = 0 that
    // is not trusted (a mixed pixel): node z = 3 lies 1 behind the plane and 3 (over
    // the truncation) in front of that return, which must not vote it empty
    let mut vol = Volume::new([0.0; 3], 1.0, [5, 5, 9], 2.0).unwrap();
    vol.integrate(&looking_down(vec![4.0; 25], 5, 5, 1.0))
        .unwrap();
    let ghost = looking_down(vec![0.0; 25], 5, 5, 1.0)
        .with_weight(vec![0.0; 25])
        .unwrap();
    vol.integrate(&ghost).unwrap();
    let n = vol.index(2, 2, 3);
    assert_eq!(vol.evidence(n), Evidence::Measured);
    assert!((vol.value(n) + 1.0).abs() < 1e-6, "{}", vol.value(n));
    // trusted, the same return votes the node empty
    let mut trusted = Volume::new([0.0; 3], 1.0, [5, 5, 9], 2.0).unwrap();
    trusted
        .integrate(&looking_down(vec![4.0; 25], 5, 5, 1.0))
        .unwrap();
    trusted
        .integrate(&looking_down(vec![0.0; 25], 5, 5, 1.0))
        .unwrap();
    assert_eq!(trusted.evidence(n), Evidence::Empty);
    // weights outside [0, 1] or of the wrong length are refused
    assert!(looking_down(vec![1.0; 4], 2, 2, 1.0)
        .with_weight(vec![1.5; 4])
        .is_err());
    assert!(looking_down(vec![1.0; 4], 2, 2, 1.0)
        .with_weight(vec![1.0; 3])
        .is_err());
}

#[test]
fn an_untrusted_return_does_not_vote_in_a_block_decided_whole() {
    // the untrusted return lies far behind the grid (z = -10): every node of the first
    // blocks is more than the truncation in front of it, so each block is decided whole
    // from the footprint, not node by node; it must still not vote the plane's nodes empty
    let mut vol = Volume::new([0.0; 3], 1.0, [16, 16, 16], 2.0).unwrap();
    let ghost = looking_down(vec![-10.0; 400], 20, 20, 1.0)
        .with_weight(vec![0.0; 400])
        .unwrap();
    vol.integrate(&ghost).unwrap();
    // the plane seen after it, in the blocks the untrusted view left whole
    vol.integrate(&looking_down(vec![4.0; 400], 20, 20, 1.0))
        .unwrap();
    let n = vol.index(2, 2, 3);
    assert_eq!(vol.evidence(n), Evidence::Measured);
    assert!((vol.value(n) + 1.0).abs() < 1e-6, "{}", vol.value(n));
}

#[test]
fn a_return_beside_a_nearer_silhouette_shows_no_space_empty() {
    // a floor at z = 1 for x < 6 and a plateau at z = 10 from x = 6 (a depth jump): a
    // node at z = 6 is 5 in front of the floor (more than the truncation, 2), but within
    // the view's margin (2 rays) of the plateau's silhouette it may lie inside the plateau
    // once the view is misaligned by a ray or two: neither a vote nor empty, so unseen
    // (solid); with no margin, every such node is empty
    let depth: Vec<f64> = (0..60)
        .map(|k| if k % 12 < 6 { 1.0 } else { 10.0 })
        .collect();
    let sharp = looking_down(depth, 12, 5, 1.0);
    let mut exact = Volume::new([0.0; 3], 1.0, [12, 5, 12], 2.0).unwrap();
    exact.integrate(&sharp).unwrap();
    for i in 0..6 {
        assert_eq!(
            exact.evidence(exact.index(i, 2, 6)),
            Evidence::Empty,
            "x = {i}"
        );
    }
    let view = sharp.with_margin(2).unwrap();
    assert!(looking_down(vec![1.0], 1, 1, 1.0)
        .with_margin(MAX_MARGIN + 1)
        .is_err());
    let mut vol = Volume::new([0.0; 3], 1.0, [12, 5, 12], 2.0).unwrap();
    vol.integrate(&view).unwrap();
    vol.carve(&view).unwrap();
    for i in 0..6 {
        let n = vol.index(i, 2, 6);
        let expected = if i + 2 >= 6 {
            Evidence::Unseen
        } else {
            Evidence::Empty
        };
        assert_eq!(vol.evidence(n), expected, "x = {i}");
        let p = vol.node(i, 2, 6);
        assert_eq!(vol.value_at(p, &[&view]).unwrap(), vol.value(n), "x = {i}");
    }
}
