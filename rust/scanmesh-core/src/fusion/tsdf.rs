//! The voxel grid of the fusion: per node the weighted sum of the truncated signed distances
//! the views measured there, their weight, and whether a ray showed the node empty.
//!
//! A view's evidence at a node (world point p, scanner point q, the depth d its ray met):
//! the distance along the ray `q.z − d` (positive towards the scanner) times the cosine
//! between ray and surface is the distance to the surface's tangent plane. From the
//! truncation in front to [`BEHIND_VOXELS`] behind it is averaged (weight: that cosine);
//! farther in front the node is empty; farther behind, unseen. A ray without a return
//! travelled through empty space up to the truncation band of the first surface another
//! view measured on its way (where its return was lost, at a grazing angle, say), or
//! through the whole grid when it met none; in a short run between returns, only up to
//! where they say it was lost (`DepthView::lost_return_depth`): `carve` marks those
//! nodes. (Stopping at the band, not behind the surface: a node behind a surface may
//! average to a positive distance where views disagree, and a ray let through there would
//! carve the part's inside.)
//!
//! A node averaging to a negative distance that a view saw more than the truncation in
//! front of its surface is empty: it lies behind a thin wedge (an edge seen along the
//! rays) in another view, outside the part (a view's vote, `EMPTY_VOTES`).

use super::depth::{DepthView, Lookup};
use crate::budget;
use crate::error::{Error, Result};
use glam::DVec3;
use rayon::prelude::*;

/// Node state bit: a ray showed this node empty (in front of a surface, or on a ray
/// without return).
pub const EMPTY: u8 = 1;

/// The node's other 7 bits count the views that saw it more than the truncation in front
/// of their surface (saturating at 127).
const VOTE: u8 = 2;

/// Views that saw a node well in front of their surface that outvote a negative mean: the
/// node is empty. A node just behind a thin wedge (a turned box's edge, a blade's trailing
/// edge) is within the band behind the surface its view saw in front, though it lies
/// outside the part; averaged, it would close a speck of solid 3-4 voxels off the part.
pub const EMPTY_VOTES: u8 = 1;

/// How far behind its surface (voxels) a view's distance is averaged, at most the
/// truncation. Behind a surface a view saw nothing: it guesses solid there, and where the
/// part is thinner than the band (a blade's trailing edge, a rib) that guess reaches past
/// the far side and outvotes the view that saw the far side from in front, pushing it out
/// (the blade from six views: faces on parts under 6 voxels thick 0.2-0.8 voxels off,
/// +0.03 to +0.44 voxels outward, 70 % of its squared error, at the truncation's 3
/// voxels). 1.5: the node across an edge the surface crosses lies within a voxel of it,
/// and half a voxel more of noise; measured on benches/merge.py's four parts
/// (docs/benchmarks/merge.md): blade RMS 0.0225 → 0.0096, fandisk 0.00026 → 0.00017,
/// pocket 0.00017 → 0.00008, conrod 0.00122 both; 1 voxel gave much the same, 2 voxels
/// kept a fifth of the blade's excess.
pub const BEHIND_VOXELS: f64 = 1.5;

/// Bytes per node: the distance sum, the weight, the flags.
pub const NODE_BYTES: u64 = 9;

/// Nodes along each axis, on a regular grid `origin + (i, j, k) * voxel`.
#[derive(Debug, Clone)]
pub struct Volume {
    origin: DVec3,
    voxel: f64,
    dims: [usize; 3],
    truncation: f64,
    behind: f64,
    sum: Vec<f32>,
    weight: Vec<f32>,
    flags: Vec<u8>,
    /// Per carved view, in the order carved: [`Volume::ray_stops`] (8 bytes per ray), for
    /// the evidence between nodes ([`Volume::value_at`]).
    stops: Vec<Vec<f64>>,
}

/// What the fusion knows of a node.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Evidence {
    /// Within the truncation of a measured surface: the averaged signed distance is known.
    Measured,
    /// Seen empty by some ray.
    Empty,
    /// No ray reached it (inside the part, or hidden).
    Unseen,
}

impl Volume {
    /// An empty grid of `dims` nodes spaced `voxel` apart from `origin` (world units), the
    /// signed distance truncated at `truncation` in front of a surface and at the smaller of
    /// it and [`BEHIND_VOXELS`] behind (world units, at least one voxel).
    ///
    /// Errors: `InvalidParameter` for a non-positive voxel or truncation, fewer than 2 nodes
    /// along an axis; `OutOfMemory` when 9 bytes per node do not fit.
    pub fn new(origin: [f64; 3], voxel: f64, dims: [usize; 3], truncation: f64) -> Result<Self> {
        let bad =
            |name: &'static str, value: String, expected: &'static str| Error::InvalidParameter {
                name,
                value,
                expected,
            };
        if !(voxel.is_finite() && voxel > 0.0) {
            return Err(bad("voxel", voxel.to_string(), "a positive finite size"));
        }
        if !(truncation.is_finite() && truncation >= voxel) {
            return Err(bad(
                "truncation",
                truncation.to_string(),
                "at least one voxel",
            ));
        }
        if origin.iter().any(|v| !v.is_finite()) {
            return Err(bad("origin", format!("{origin:?}"), "finite coordinates"));
        }
        if dims.iter().any(|&d| d < 2) {
            return Err(bad(
                "dims",
                format!("{dims:?}"),
                "at least 2 nodes along each axis",
            ));
        }
        let n = dims.iter().try_fold(1usize, |a, &d| a.checked_mul(d));
        let n = n.ok_or_else(|| bad("dims", format!("{dims:?}"), "a grid that can be counted"))?;
        budget::check_stage(
            || {
                format!(
                    "a fusion grid of {} × {} × {} nodes",
                    dims[0], dims[1], dims[2]
                )
            },
            n as u64 * NODE_BYTES,
        )?;
        Ok(Self {
            origin: DVec3::from_array(origin),
            voxel,
            dims,
            truncation,
            behind: truncation.min(BEHIND_VOXELS * voxel),
            sum: budget::try_vec("the fusion grid", n)?,
            weight: budget::try_vec("the fusion grid", n)?,
            flags: budget::try_vec("the fusion grid", n)?,
            stops: Vec::new(),
        })
        .map(|mut v: Self| {
            v.sum.resize(n, 0.0);
            v.weight.resize(n, 0.0);
            v.flags.resize(n, 0);
            v
        })
    }

    /// Nodes along x, y, z.
    pub fn dims(&self) -> [usize; 3] {
        self.dims
    }

    /// Node spacing (world units).
    pub fn voxel(&self) -> f64 {
        self.voxel
    }

    /// The truncation distance (world units).
    pub fn truncation(&self) -> f64 {
        self.truncation
    }

    /// World position of node (i, j, k).
    pub fn node(&self, i: usize, j: usize, k: usize) -> DVec3 {
        self.origin + DVec3::new(i as f64, j as f64, k as f64) * self.voxel
    }

    /// Flat index of node (i, j, k): x fastest.
    pub fn index(&self, i: usize, j: usize, k: usize) -> usize {
        (k * self.dims[1] + j) * self.dims[0] + i
    }

    /// The node nearest to world point `p`, if inside the grid.
    pub fn nearest(&self, p: DVec3) -> Option<usize> {
        let g = ((p - self.origin) / self.voxel).round();
        let inside = (0..3).all(|a| g[a] >= 0.0 && g[a] < self.dims[a] as f64);
        inside.then(|| self.index(g.x as usize, g.y as usize, g.z as usize))
    }

    /// What is known of node `n`: measured unless its mean is negative and
    /// `EMPTY_VOTES` views saw it well in front of their surfaces (then empty).
    pub fn evidence(&self, n: usize) -> Evidence {
        classify(self.sum[n], self.weight[n], self.flags[n])
    }

    /// The fused signed distance at node `n` (world units, positive outside): the weighted
    /// mean where measured, `+truncation` where seen empty, `−truncation` where unseen
    /// (unseen space counts as solid, so what no ray entered closes the surface).
    pub fn value(&self, n: usize) -> f64 {
        distance(self.sum[n], self.weight[n], self.flags[n], self.truncation)
    }

    /// Adds one view's returns: the truncated distance near its surfaces, empty in front of
    /// them. O(nodes), in parallel over z slices.
    pub fn integrate(&mut self, view: &DepthView) {
        let trunc = self.truncation;
        let behind = self.behind;
        let (nx, ny) = (self.dims[0], self.dims[1]);
        let (origin, voxel) = (self.origin, self.voxel);
        self.sum
            .par_chunks_mut(nx * ny)
            .zip(self.weight.par_chunks_mut(nx * ny))
            .zip(self.flags.par_chunks_mut(nx * ny))
            .enumerate()
            .for_each(|(k, ((sum, weight), flags))| {
                for j in 0..ny {
                    for i in 0..nx {
                        let p = origin + DVec3::new(i as f64, j as f64, k as f64) * voxel;
                        let q = view.to_scanner(p);
                        if let Lookup::Hit {
                            depth,
                            cos,
                            weight: trust,
                        } = view.lookup(q.x, q.y)
                        {
                            let n = j * nx + i;
                            let d = (q.z - depth) * cos;
                            add_return(
                                d,
                                cos * trust,
                                [trunc, behind],
                                (&mut sum[n], &mut weight[n], &mut flags[n]),
                            );
                        }
                    }
                }
            });
    }

    /// Marks empty the nodes on this view's rays without a return, from the scanner to the
    /// first node some view measured, or all along the ray when there is none; a ray whose
    /// return was lost (a short run between returns, [`DepthView::lost_return_depth`])
    /// only in front of the depth it was lost at. Run after every view is integrated.
    /// O(rays · nodes along a ray + nodes).
    pub fn carve(&mut self, view: &DepthView) {
        let stop = self.ray_stops(view);
        let (nx, ny) = (self.dims[0], self.dims[1]);
        let (origin, voxel) = (self.origin, self.voxel);
        self.flags
            .par_chunks_mut(nx * ny)
            .enumerate()
            .for_each(|(k, flags)| {
                for j in 0..ny {
                    for i in 0..nx {
                        let p = origin + DVec3::new(i as f64, j as f64, k as f64) * voxel;
                        let q = view.to_scanner(p);
                        if let Lookup::Miss(pixel) = view.lookup(q.x, q.y) {
                            if q.z > stop[pixel] {
                                flags[j * nx + i] |= EMPTY;
                            }
                        }
                    }
                }
            });
        self.stops.push(stop);
    }

    /// The fused signed distance at any world point `p`, as [`Volume::value`] would give
    /// it were a node there: every view's lookup at `p` integrated and carved by the same
    /// rules, so it equals `value` at the nodes, and between them it places the boundary
    /// between space a ray showed empty and space none entered (or a depth jump) where the
    /// rays' footprints meet, not where the nodes happen to sit. `views`: those integrated
    /// and carved, in the order carved. O(views).
    ///
    /// Errors: `InvalidParameter` when `views` are not as many as the views carved.
    pub fn value_at(&self, p: DVec3, views: &[&DepthView]) -> Result<f64> {
        self.check_views(views)?;
        Ok(self.value_between(p, views))
    }

    /// `InvalidParameter` unless `views` are as many as the views carved.
    pub fn check_views(&self, views: &[&DepthView]) -> Result<()> {
        if views.len() != self.stops.len() {
            return Err(Error::InvalidParameter {
                name: "views",
                value: format!("{} views for {} carved", views.len(), self.stops.len()),
                expected: "the views integrated and carved, in that order",
            });
        }
        Ok(())
    }

    /// [`Volume::value_at`] for views already checked.
    pub(super) fn value_between(&self, p: DVec3, views: &[&DepthView]) -> f64 {
        let trunc = self.truncation;
        let behind = self.behind;
        let (mut sum, mut weight, mut flags) = (0.0_f32, 0.0_f32, 0_u8);
        for (view, stop) in views.iter().zip(&self.stops) {
            let q = view.to_scanner(p);
            match view.lookup(q.x, q.y) {
                Lookup::Hit {
                    depth,
                    cos,
                    weight: trust,
                } => {
                    let d = (q.z - depth) * cos;
                    let w = cos * trust;
                    add_return(d, w, [trunc, behind], (&mut sum, &mut weight, &mut flags));
                }
                Lookup::Miss(pixel) => {
                    if q.z > stop[pixel] {
                        flags |= EMPTY;
                    }
                }
                Lookup::Outside => {}
            }
        }
        distance(sum, weight, flags, trunc)
    }

    /// Per pixel of `view`: the scanner z where a ray without return met the first measured
    /// node, coming from the scanner, or its lost return's depth if nearer (−∞: neither;
    /// +∞: the ray returned).
    fn ray_stops(&self, view: &DepthView) -> Vec<f64> {
        let (w, h) = view.size();
        // the ray's stretch through the grid: scanner z over the grid's 8 corners
        let hi = self.node(self.dims[0] - 1, self.dims[1] - 1, self.dims[2] - 1);
        let (mut z_lo, mut z_hi) = (f64::INFINITY, f64::NEG_INFINITY);
        for c in 0..8 {
            let corner = DVec3::new(
                if c & 1 == 0 { self.origin.x } else { hi.x },
                if c & 2 == 0 { self.origin.y } else { hi.y },
                if c & 4 == 0 { self.origin.z } else { hi.z },
            );
            let z = view.to_scanner(corner).z;
            z_lo = z_lo.min(z);
            z_hi = z_hi.max(z);
        }
        let dz = 0.5 * self.voxel;
        let steps = ((z_hi - z_lo) / dz).ceil() as usize + 1;
        (0..w * h)
            .into_par_iter()
            .map(|pixel| {
                if !view.is_miss(pixel) {
                    return f64::INFINITY;
                }
                let lost = view.lost_return_depth(pixel).unwrap_or(f64::NEG_INFINITY);
                let [x, y] = view.ray_xy(pixel);
                let measured = (0..steps)
                    .map(|s| z_hi - s as f64 * dz)
                    .find(|&z| {
                        let p = view.to_world(DVec3::new(x, y, z));
                        self.nearest(p)
                            .is_some_and(|n| self.evidence(n) == Evidence::Measured)
                    })
                    .unwrap_or(f64::NEG_INFINITY);
                measured.max(lost)
            })
            .collect()
    }
}

/// Adds one view's return to a node's state (`sum`, `weight` of distances, `flags`): `d`,
/// the distance along the view's normal from its surface to the node (positive in
/// front), and the return's weight `cos` (the ray-to-normal cosine times the return's
/// trust, [`DepthView::with_weight`]). More than `trunc` in front is a vote for empty; from
/// `trunc` in front to `behind` behind, a weighted distance; a return of weight 0 (not
/// trusted: a mixed pixel on a silhouette may lie anywhere between the surfaces) neither
/// averages nor votes, it only shows the space beyond the truncation in front of it
/// empty; farther behind, nothing. The
/// one rule of [`Volume::integrate`] at the nodes and of [`Volume::value_at`] between
/// them. O(1).
fn add_return(d: f64, cos: f64, [trunc, behind]: [f64; 2], node: (&mut f32, &mut f32, &mut u8)) {
    let (sum, weight, flags) = node;
    if cos <= 0.0 {
        if d > trunc {
            *flags |= EMPTY;
        }
    } else if d > trunc {
        *flags = flags.saturating_add(VOTE) | EMPTY;
    } else if d >= -behind {
        *sum += (cos * d) as f32;
        *weight += cos as f32;
    }
}

/// What a node's state says ([`Volume::evidence`]): measured unless its mean is negative
/// and [`EMPTY_VOTES`] views saw it well in front of their surfaces. O(1).
fn classify(sum: f32, weight: f32, flags: u8) -> Evidence {
    if weight > 0.0 && (sum >= 0.0 || flags / VOTE < EMPTY_VOTES) {
        Evidence::Measured
    } else if flags & EMPTY != 0 {
        Evidence::Empty
    } else {
        Evidence::Unseen
    }
}

/// The fused signed distance of a node's state ([`Volume::value`]): the weighted mean
/// where measured, `+trunc` where seen empty, `−trunc` where unseen. O(1).
fn distance(sum: f32, weight: f32, flags: u8, trunc: f64) -> f64 {
    match classify(sum, weight, flags) {
        Evidence::Measured => f64::from(sum / weight),
        Evidence::Empty => trunc,
        Evidence::Unseen => -trunc,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn looking_down(depth: Vec<f64>, width: usize, height: usize, step: f64) -> DepthView {
        let mut pose = [0.0; 16];
        for k in 0..4 {
            pose[k * 5] = 1.0;
        }
        let cos = vec![1.0; depth.len()];
        DepthView::new(pose, [0.0, 0.0], step, width, height, depth, cos).unwrap()
    }

    #[test]
    fn a_plane_gives_its_distance_and_empty_space_above() {
        let mut vol = Volume::new([0.0; 3], 1.0, [5, 5, 9], 2.0).unwrap();
        vol.integrate(&looking_down(vec![4.0; 25], 5, 5, 1.0));
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
        vol.integrate(&looking_down(vec![5.0; 25], 5, 5, 1.0));
        // from below: world = (x, 4 - y, -z) of the scanner's (x, y, z)
        let mut pose = [0.0; 16];
        (pose[0], pose[5], pose[7], pose[10], pose[15]) = (1.0, -1.0, 4.0, -1.0, 1.0);
        let below = DepthView::new(pose, [0.0, 0.0], 1.0, 5, 5, vec![-4.0; 25], vec![1.0; 25]);
        vol.integrate(&below.unwrap());
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
        vol.integrate(&top);
        vol.carve(&top);
        // under the missed rays: empty all the way down
        assert_eq!(vol.evidence(vol.index(4, 2, 0)), Evidence::Empty);
        // under the plane: unseen (solid)
        assert_eq!(vol.evidence(vol.index(1, 2, 0)), Evidence::Unseen);
        // a view whose returns were all lost stops at the measured plane: it carves nothing
        // below it
        let mut lower = Volume::new([0.0; 3], 1.0, [5, 5, 9], 2.0).unwrap();
        let plane = looking_down(vec![4.0; 25], 5, 5, 1.0);
        lower.integrate(&plane);
        let lost = looking_down(vec![f64::NAN; 25], 5, 5, 1.0);
        lower.carve(&lost);
        assert_eq!(lower.evidence(lower.index(1, 2, 0)), Evidence::Unseen);
    }

    #[test]
    fn a_view_that_saw_a_node_in_front_outvotes_one_behind_a_surface() {
        // one view sees a surface at z = 4 (node z = 3 lies 1 behind it, within the
        // truncation), another a surface at z = 0 (node z = 3 lies 3 in front of it)
        let mut vol = Volume::new([0.0; 3], 1.0, [5, 5, 9], 2.0).unwrap();
        vol.integrate(&looking_down(vec![4.0; 25], 5, 5, 1.0));
        let n = vol.index(2, 2, 3);
        assert_eq!(vol.evidence(n), Evidence::Measured);
        assert!(vol.value(n) < 0.0);
        vol.integrate(&looking_down(vec![0.0; 25], 5, 5, 1.0));
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
        let depth: Vec<f64> = (0..25)
            .map(|k| if k % 5 < 3 { 4.0 } else { f64::NAN })
            .collect();
        let mut pose = [0.0; 16];
        for k in 0..4 {
            pose[k * 5] = 1.0;
        }
        pose[3] = 0.3;
        let view = DepthView::new(pose, [0.0, 0.0], 1.0, 5, 5, depth, vec![1.0; 25]).unwrap();
        let mut vol = Volume::new([0.0; 3], 1.0, [5, 5, 9], 2.0).unwrap();
        vol.integrate(&view);
        vol.carve(&view);
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

    #[test]
    fn a_return_of_weight_zero_neither_averages_nor_votes() {
        // one view sees a plane at z = 4; another, from above too, a return at z = 0 that
        // is not trusted (a mixed pixel): node z = 3 lies 1 behind the plane and 3 (over
        // the truncation) in front of that return, which must not vote it empty
        let mut vol = Volume::new([0.0; 3], 1.0, [5, 5, 9], 2.0).unwrap();
        vol.integrate(&looking_down(vec![4.0; 25], 5, 5, 1.0));
        let ghost = looking_down(vec![0.0; 25], 5, 5, 1.0)
            .with_weight(vec![0.0; 25])
            .unwrap();
        vol.integrate(&ghost);
        let n = vol.index(2, 2, 3);
        assert_eq!(vol.evidence(n), Evidence::Measured);
        assert!((vol.value(n) + 1.0).abs() < 1e-6, "{}", vol.value(n));
        // trusted, the same return votes the node empty
        let mut trusted = Volume::new([0.0; 3], 1.0, [5, 5, 9], 2.0).unwrap();
        trusted.integrate(&looking_down(vec![4.0; 25], 5, 5, 1.0));
        trusted.integrate(&looking_down(vec![0.0; 25], 5, 5, 1.0));
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
    fn refuses_bad_grids() {
        assert!(Volume::new([0.0; 3], 0.0, [4, 4, 4], 1.0).is_err());
        assert!(Volume::new([0.0; 3], 1.0, [4, 1, 4], 1.0).is_err());
        assert!(Volume::new([0.0; 3], 1.0, [4, 4, 4], 0.5).is_err());
        assert!(Volume::new([0.0; 3], 1.0, [usize::MAX, 4, 4], 1.0).is_err());
    }
}
