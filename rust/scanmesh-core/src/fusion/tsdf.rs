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
//! rays) in another view, outside the part (a view's vote, `EMPTY_VOTES`). Neither a vote
//! nor empty within the view's margin of a nearer surface's silhouette
//! ([`DepthView::with_margin`]): a misaligned view's rays there may pass through a thin part.

use super::blocks::{block_nodes, Blocks, Entry};
use super::depth::{DepthView, Lookup};
use super::footprint::Footprint;
use super::reach::{self, Reach};
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

/// Nodes along each axis, on a regular grid `origin + (i, j, k) * voxel`, stored by blocks
/// (8³ (`BLOCK`) nodes): allocated where some view's evidence varies within the block, else
/// one state for the whole block.
#[derive(Debug, Clone)]
pub struct Volume {
    origin: DVec3,
    voxel: f64,
    dims: [usize; 3],
    truncation: f64,
    behind: f64,
    blocks: Blocks,
    /// Per carved view, in the order carved: [`Volume::ray_stops`] (8 bytes per ray), for
    /// the evidence between nodes ([`Volume::value_at`]).
    stops: Vec<Vec<f64>>,
    /// The measured nodes, for the rays' stops: made at the first carve (carving changes
    /// no node's measure).
    reach: Option<Reach>,
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

/// What one view does to the nodes of one block, decided from the block's footprint.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Action {
    /// Nothing to any node.
    Nothing,
    /// The same to every node: a vote for empty ([`Volume::integrate`]) or marked empty
    /// ([`Volume::carve`]).
    All,
    /// Node by node, a vote for empty or nothing: no distance ([`Volume::integrate`]).
    Votes,
    /// Node by node.
    Each,
}

/// A block's nodes seen from a view: the pixel coordinates (u, v) and the scanner z they
/// span, widened by far more than rounding can move a node's own.
struct Span {
    u: [f64; 2],
    v: [f64; 2],
    z: [f64; 2],
    /// The margin (world units) the depths are widened by.
    margin: f64,
}

impl Span {
    /// Every node outside the image ([`DepthView::lookup`]'s `Outside`).
    fn outside(&self, (w, h): (usize, usize)) -> bool {
        self.u[1] <= -0.5
            || self.v[1] <= -0.5
            || self.u[0] >= w as f64 - 0.5
            || self.v[0] >= h as f64 - 0.5
    }

    /// Every node inside the image.
    fn inside(&self, (w, h): (usize, usize)) -> bool {
        self.u[0] > -0.5
            && self.v[0] > -0.5
            && self.u[1] < w as f64 - 0.5
            && self.v[1] < h as f64 - 0.5
    }

    /// The pixels any node's lookup may read (the nearest and the four around it), inside
    /// the image; for a span not [`Span::outside`] it.
    fn pixels(&self, (w, h): (usize, usize)) -> [[usize; 2]; 2] {
        let range = |[a, b]: [f64; 2], n: usize| {
            let lo = a.floor().max(0.0) as usize;
            let hi = (b.floor() + 1.0).clamp(0.0, (n - 1) as f64) as usize;
            [lo.min(n - 1), hi]
        };
        [range(self.u, w), range(self.v, h)]
    }
}

impl Volume {
    /// An empty grid of `dims` nodes spaced `voxel` apart from `origin` (world units), the
    /// signed distance truncated at `truncation` in front of a surface and at the smaller of
    /// it and [`BEHIND_VOXELS`] behind (world units, at least one voxel). No node is
    /// allocated yet: 4 bytes per block of 8³ (`BLOCK`) nodes; [`Volume::with_max_voxels`]
    /// bounds the nodes allocated later.
    ///
    /// Errors: `InvalidParameter` for a non-positive voxel or truncation, fewer than 2 nodes
    /// along an axis; `OutOfMemory` when the block index does not fit.
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
        n.ok_or_else(|| bad("dims", format!("{dims:?}"), "a grid that can be counted"))?;
        Ok(Self {
            origin: DVec3::from_array(origin),
            voxel,
            dims,
            truncation,
            behind: truncation.min(BEHIND_VOXELS * voxel),
            blocks: Blocks::new(dims)?,
            stops: Vec::new(),
            reach: None,
        })
    }

    /// The same grid, at most `max_voxels` nodes ever allocated (whole blocks of
    /// 8³ (`BLOCK`)): `integrate` or `carve` needing more is refused (`TooCostly`). O(1).
    pub fn with_max_voxels(mut self, max_voxels: usize) -> Self {
        self.blocks.limit(max_voxels);
        self
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

    /// Nodes allocated so far (whole blocks of 8³ (`BLOCK`)): with a distance (9 bytes each:
    /// the distance sum, the weight, the flags) and with flags alone (1 byte each), where
    /// only a silhouette or a carving edge passes. Both count towards
    /// [`Volume::with_max_voxels`].
    pub fn allocated(&self) -> [usize; 2] {
        self.blocks.allocated()
    }

    /// World position of node (i, j, k).
    pub fn node(&self, i: usize, j: usize, k: usize) -> DVec3 {
        self.origin + DVec3::new(i as f64, j as f64, k as f64) * self.voxel
    }

    /// Flat index of node (i, j, k): x fastest.
    pub fn index(&self, i: usize, j: usize, k: usize) -> usize {
        (k * self.dims[1] + j) * self.dims[0] + i
    }

    /// Grid coordinates of flat index `n`.
    pub(super) fn coords(&self, n: usize) -> [usize; 3] {
        let [nx, ny, _] = self.dims;
        [n % nx, (n / nx) % ny, n / (nx * ny)]
    }

    /// The node nearest to world point `p`, if inside the grid.
    pub fn nearest(&self, p: DVec3) -> Option<usize> {
        self.nearest_coords(p).map(|[i, j, k]| self.index(i, j, k))
    }

    fn nearest_coords(&self, p: DVec3) -> Option<[usize; 3]> {
        let g = ((p - self.origin) / self.voxel).round();
        let inside = (0..3).all(|a| g[a] >= 0.0 && g[a] < self.dims[a] as f64);
        inside.then_some([g.x as usize, g.y as usize, g.z as usize])
    }

    /// What is known of node `n`: measured unless its mean is negative and
    /// `EMPTY_VOTES` views saw it well in front of their surfaces (then empty). O(1).
    pub fn evidence(&self, n: usize) -> Evidence {
        self.evidence_at(self.coords(n))
    }

    fn evidence_at(&self, node: [usize; 3]) -> Evidence {
        let (sum, weight, flags) = self.blocks.state(node);
        classify(sum, weight, flags)
    }

    /// The fused signed distance at node `n` (world units, positive outside): the weighted
    /// mean where measured, `+truncation` where seen empty, `−truncation` where unseen
    /// (unseen space counts as solid, so what no ray entered closes the surface). O(1).
    pub fn value(&self, n: usize) -> f64 {
        let (sum, weight, flags) = self.blocks.state(self.coords(n));
        distance(sum, weight, flags, self.truncation)
    }

    /// Whether the evidence at node `n` decides its side firmly: measured by returns whose
    /// weights (cosine times trust) sum to at least `min_weight`, or seen more than the
    /// truncation in front of some view's surface. Not so: unseen nodes, nodes only a ray
    /// without a return crossed, and nodes few or grazing returns measured. O(1).
    pub(super) fn is_firm(&self, n: usize, min_weight: f32) -> bool {
        let (sum, weight, flags) = self.blocks.state(self.coords(n));
        match classify(sum, weight, flags) {
            Evidence::Measured => weight >= min_weight,
            Evidence::Empty => flags / VOTE > 0,
            Evidence::Unseen => false,
        }
    }

    /// The blocks, for the extraction's walk over those where the surface may be.
    pub(super) fn blocks(&self) -> &Blocks {
        &self.blocks
    }

    /// The fused signed distance every node of block `b` has, if they all have one (an
    /// unallocated block). O(1).
    pub(super) fn uniform_value(&self, b: usize) -> Option<f64> {
        match self.blocks.entry(b) {
            Entry::Uniform(flags) => Some(distance(0.0, 0.0, flags, self.truncation)),
            Entry::Flags(_) | Entry::Slot(_) => None,
        }
    }

    /// Block `b`'s nodes in `view`'s scanner coordinates, as pixel coordinates and depth.
    fn span(&self, b: usize, view: &DepthView) -> Span {
        let [lo, hi] = self.blocks.nodes(b);
        let (mut u, mut v, mut z) = ([f64::INFINITY, f64::NEG_INFINITY], [0.0; 2], [0.0; 2]);
        (v[0], v[1], z[0], z[1]) = (u[0], u[1], u[0], u[1]);
        let mut scale: f64 = 0.0;
        for c in 0..8 {
            let at = |a: usize, bit: usize| if c & bit == 0 { lo[a] } else { hi[a] };
            let q = view.to_scanner(self.node(at(0, 1), at(1, 2), at(2, 4)));
            let [pu, pv] = view.pixel(q.x, q.y);
            (u[0], u[1]) = (u[0].min(pu), u[1].max(pu));
            (v[0], v[1]) = (v[0].min(pv), v[1].max(pv));
            (z[0], z[1]) = (z[0].min(q.z), z[1].max(q.z));
            scale = scale.max(q.abs().max_element());
        }
        // the nodes between the corners are affine combinations of them: a margin of
        // 1e-9 relative to the coordinates holds their rounding many times over
        let margin = 1e-9 * (self.voxel + scale);
        let du = 1e-9 * (1.0 + u[0].abs().max(u[1].abs()));
        let dv = 1e-9 * (1.0 + v[0].abs().max(v[1].abs()));
        Span {
            u: [u[0] - du, u[1] + du],
            v: [v[0] - dv, v[1] + dv],
            z: [z[0] - margin, z[1] + margin],
            margin,
        }
    }

    /// What `view`'s returns do to block `b`'s nodes ([`add_return`]): nothing where every
    /// node is outside the image, on a ray without return or farther behind its surface
    /// than the band; a vote for empty where every node is inside the image, on a return,
    /// and farther in front of its surface than the truncation; votes alone where every
    /// node on a return is that far in front.
    fn returns_action(&self, b: usize, view: &DepthView, foot: &Footprint<'_>) -> Action {
        let size = view.size();
        let s = self.span(b, view);
        if s.outside(size) {
            return Action::Nothing;
        }
        let [across, down] = s.pixels(size);
        let seen = foot.query(across, down);
        if seen.missing == seen.pixels {
            return Action::Nothing;
        }
        // a lookup's depth and cosine are convex combinations of its pixels'
        let cos = seen.cos * (1.0 - 1e-9);
        let (lo, hi) = (seen.lo - s.margin, seen.hi + s.margin);
        if (s.z[1] - lo) * cos < -self.behind * (1.0 + 1e-9) && s.z[1] < lo {
            return Action::Nothing;
        }
        if s.z[0] > hi && (s.z[0] - hi) * cos > self.truncation * (1.0 + 1e-9) {
            // every node also clear of the returns within the vote's margin (`front`)
            let m = view.margin();
            let widen = |[a, b]: [usize; 2], n: usize| [a.saturating_sub(m), (b + m).min(n - 1)];
            let around = foot.query(widen(across, size.0), widen(down, size.1));
            let front = around.hi + s.margin;
            let clear = (s.z[0] - front) * cos > self.truncation * (1.0 + 1e-9);
            if clear && s.inside(size) && seen.missing == 0 {
                return Action::All;
            }
            return Action::Votes;
        }
        Action::Each
    }

    /// What carving `view` with ray stops `stop` does to block `b`'s nodes: nothing where
    /// every node is outside the image or no farther from the scanner than its ray's stop;
    /// marked empty where every node is inside the image and beyond the stop of its ray.
    fn carve_action(&self, b: usize, view: &DepthView, foot: &Footprint<'_>) -> Action {
        let size = view.size();
        let s = self.span(b, view);
        if s.outside(size) {
            return Action::Nothing;
        }
        let [across, down] = s.pixels(size);
        let stops = foot.query(across, down);
        if s.z[1] <= stops.lo - s.margin {
            return Action::Nothing;
        }
        if s.inside(size) && s.z[0] > stops.hi + s.margin {
            return Action::All;
        }
        Action::Each
    }

    /// The actions of one view on every block, on every core.
    fn actions(&self, act: impl Fn(usize) -> Action + Sync + Send) -> Result<Vec<Action>> {
        budget::try_par_collect(
            "the fusion grid's blocks seen by a view",
            (0..self.blocks.len()).into_par_iter().map(act),
        )
    }

    /// Makes room for what a view does to each block ([`Volume::integrate`] with
    /// `returns`, else [`Volume::carve`]): a uniform block changed alike gets `all`
    /// applied to its shared flags; one changed node by node gets its nodes' flags, and
    /// their distances where the view may add one.
    fn allocate_for(&mut self, actions: &[Action], returns: bool) -> Result<()> {
        for (b, &a) in actions.iter().enumerate() {
            match (a, self.blocks.entry(b)) {
                (Action::All, Entry::Uniform(flags)) => self.blocks.set_uniform(
                    b,
                    if returns {
                        flags.saturating_add(VOTE) | EMPTY
                    } else {
                        flags | EMPTY
                    },
                ),
                // a node seen empty stays so: carving it again changes nothing
                (_, Entry::Uniform(flags)) if !returns && flags & EMPTY != 0 => {}
                (Action::Each, Entry::Uniform(_)) if !returns => self.blocks.allocate_flags(b)?,
                (Action::Votes, Entry::Uniform(_)) => self.blocks.allocate_flags(b)?,
                (Action::Each, Entry::Uniform(_) | Entry::Flags(_)) if returns => {
                    self.blocks.allocate(b)?
                }
                _ => {}
            }
        }
        Ok(())
    }

    /// Adds one view's returns: the truncated distance near its surfaces, empty in front of
    /// them. Blocks are decided from their footprint in the image where the view does the
    /// same to every node, else node by node (and allocated: with distances near its
    /// surfaces, flags alone near its silhouettes). O(blocks + pixels + nodes of the
    /// blocks near the view's surfaces and silhouettes), on every core.
    ///
    /// Errors: `TooCostly` beyond [`Volume::with_max_voxels`]; `OutOfMemory`;
    /// `InvalidParameter` after a view was carved.
    pub fn integrate(&mut self, view: &DepthView) -> Result<()> {
        if !self.stops.is_empty() {
            return Err(Error::InvalidParameter {
                name: "view",
                value: format!("a view integrated after {} carved", self.stops.len()),
                expected: "every view integrated before the first is carved",
            });
        }
        let (w, h) = view.size();
        // the returns' weights, not their cosines alone: a block where some return is not
        // trusted (weight 0: it neither averages nor votes) is decided node by node
        let weights = view.return_weights();
        let foot = Footprint::new(w, h, view.depths(), Some(&weights))?;
        let actions = self.actions(|b| self.returns_action(b, view, &foot))?;
        drop(foot);
        self.allocate_for(&actions, true)?;
        let bands = [self.truncation, self.behind];
        let (origin, voxel) = (self.origin, self.voxel);
        let layout = self.blocks.layout();
        // each node of block `b` on a return: its place in the block, distance and weight
        // (the cosine times the return's trust)
        let each = |b: usize, add: &mut dyn FnMut(usize, [f64; 2], f64)| {
            for ([i, j, k], n) in block_nodes(layout.nodes(b)) {
                let p = origin + DVec3::new(i as f64, j as f64, k as f64) * voxel;
                let q = view.to_scanner(p);
                if let Lookup::Hit {
                    depth,
                    cos,
                    weight: trust,
                    front,
                } = view.lookup(q.x, q.y)
                {
                    add(n, [(q.z - depth) * cos, (q.z - front) * cos], cos * trust);
                }
            }
        };
        self.blocks
            .par_slots_mut()
            .filter(|(b, _)| actions[*b] != Action::Nothing)
            .for_each(|(b, ((sum, weight), flags))| {
                each(b, &mut |n, d, w| {
                    add_return(d, w, bands, (&mut sum[n], &mut weight[n], &mut flags[n]));
                });
            });
        self.blocks
            .par_marks_mut()
            .filter(|(b, _)| actions[*b] != Action::Nothing)
            .for_each(|(b, marks)| {
                // votes alone: no node within the band (a distance would be lost here)
                each(b, &mut |n, d, w| {
                    let (mut sum, mut weight) = (0.0, 0.0);
                    add_return(d, w, bands, (&mut sum, &mut weight, &mut marks[n]));
                    debug_assert_eq!(weight, 0.0, "a distance in a block of flags alone");
                });
            });
        Ok(())
    }

    /// Marks empty the nodes on this view's rays without a return, from the scanner to the
    /// first node some view measured, or all along the ray when there is none; a ray whose
    /// return was lost (a short run between returns, [`DepthView::lost_return_depth`])
    /// only in front of the depth it was lost at. Run after every view is integrated.
    /// O(rays · blocks along a ray + blocks + nodes of the blocks the carving's edge
    /// crosses), on every core.
    ///
    /// Errors: `TooCostly` beyond [`Volume::with_max_voxels`]; `OutOfMemory`.
    pub fn carve(&mut self, view: &DepthView) -> Result<()> {
        if self.stops.is_empty() {
            // every view integrated: the votes of a node without distance count no more
            self.blocks.settle_flags(EMPTY);
        }
        let reach = match self.reach.take() {
            Some(reach) => reach,
            None => {
                let blocks = &self.blocks;
                Reach::new(blocks, |n| {
                    classify(blocks.sum[n], blocks.weight[n], blocks.flags[n]) == Evidence::Measured
                })?
            }
        };
        let stop = self.ray_stops(view, &reach)?;
        self.reach = Some(reach);
        let (w, h) = view.size();
        let foot = Footprint::new(w, h, &stop, None)?;
        let actions = self.actions(|b| self.carve_action(b, view, &foot))?;
        drop(foot);
        self.allocate_for(&actions, false)?;
        let (origin, voxel) = (self.origin, self.voxel);
        let layout = self.blocks.layout();
        let (wf, hf) = (w as f64, h as f64);
        let each = |b: usize, flags: &mut [u8]| {
            for ([i, j, k], n) in block_nodes(layout.nodes(b)) {
                if flags[n] & EMPTY != 0 {
                    continue; // an earlier view emptied it: nothing to add
                }
                let p = origin + DVec3::new(i as f64, j as f64, k as f64) * voxel;
                let q = view.to_scanner(p);
                // `view.lookup`'s miss (its nearest ray, inside the image, had no return)
                // without the interpolation a return would need
                let [u, v] = view.pixel(q.x, q.y);
                if u > -0.5 && v > -0.5 && u < wf - 0.5 && v < hf - 0.5 {
                    let pixel = reach::round(v) as usize * w + reach::round(u) as usize;
                    if view.is_miss(pixel) && q.z > stop[pixel] {
                        flags[n] |= EMPTY;
                    }
                }
            }
        };
        self.blocks
            .par_slots_mut()
            .filter(|(b, _)| actions[*b] != Action::Nothing)
            .for_each(|(b, (_, flags))| each(b, flags));
        self.blocks
            .par_marks_mut()
            .filter(|(b, _)| actions[*b] != Action::Nothing)
            .for_each(|(b, marks)| each(b, marks));
        self.stops.push(stop);
        Ok(())
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
                    front,
                } => {
                    let d = [(q.z - depth) * cos, (q.z - front) * cos];
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
    /// node (`reach`'s), coming from the scanner, or its lost return's depth if nearer (−∞: neither;
    /// +∞: the ray returned). A ray's steps (half a voxel) are taken many at once
    /// ([`reach::skip`]) where no measured node is near. O(rays · steps near the measured
    /// nodes + rays · log of the grid's size).
    fn ray_stops(&self, view: &DepthView, reach: &Reach) -> Result<Vec<f64>> {
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
        let top = self.dims.map(|d| (d - 1) as f64);
        let dims = self.dims.map(|d| d as f64);
        let (origin, voxel) = (self.origin, self.voxel);
        let [along_x, along_y, along_z] = view.rotation_axes();
        let shift = view.to_world(DVec3::ZERO);
        budget::try_par_collect(
            "the rays' stops",
            (0..w * h).into_par_iter().map(|pixel| {
                if !view.is_miss(pixel) {
                    return f64::INFINITY;
                }
                let lost = view.lost_return_depth(pixel).unwrap_or(f64::NEG_INFINITY);
                let [x, y] = view.ray_xy(pixel);
                // `view.to_world` of the ray's points, the same operations in the same order
                let across = along_x * x + along_y * y;
                let mut s = 0;
                let mut measured = f64::NEG_INFINITY;
                while s < steps {
                    let z = z_hi - s as f64 * dz;
                    let p = across + along_z * z + shift;
                    // the nearest node (`Volume::nearest_coords`)
                    let g = ((p - origin) / voxel).to_array().map(reach::round);
                    // the nearest node clamped into the grid: the next steps' nearest
                    // nodes lie near it (or near the grid)
                    let d =
                        reach.distance(std::array::from_fn(|a| g[a].clamp(0.0, top[a]) as usize));
                    if d >= 2 {
                        s += reach::skip(d);
                        continue;
                    }
                    if (0..3).all(|a| g[a] >= 0.0 && g[a] < dims[a])
                        && reach.measured(g.map(|v| v as usize))
                    {
                        measured = z;
                        break;
                    }
                    s += 1;
                }
                measured.max(lost)
            }),
        )
    }
}

/// Adds one view's return to a node's state (`sum`, `weight` of distances, `flags`): `d`,
/// the distance along the view's normal from its surface to the node (positive in
/// front), `clear`, the same from the surface nearest the scanner within the view's margin
/// ([`DepthView::with_margin`]; at most `d`), and the return's weight `cos` (the ray-to-normal cosine times the return's
/// trust, [`DepthView::with_weight`]). More than `trunc` in front is a vote for empty
/// (nothing, unless `clear` is too: a misaligned view's ray beside a silhouette); from
/// `trunc` in front to `behind` behind, a weighted distance; a return of weight 0 (not
/// trusted: a mixed pixel on a silhouette may lie anywhere between the surfaces) neither
/// averages nor votes, it only shows the space beyond the truncation in front of it
/// empty; farther behind, nothing. The
/// one rule of [`Volume::integrate`] at the nodes and of [`Volume::value_at`] between
/// them. O(1).
fn add_return(
    [d, clear]: [f64; 2],
    cos: f64,
    [trunc, behind]: [f64; 2],
    node: (&mut f32, &mut f32, &mut u8),
) {
    let (sum, weight, flags) = node;
    if d > trunc {
        // beside a nearer surface's silhouette the node may lie inside it: no evidence
        if clear > trunc {
            *flags = if cos <= 0.0 {
                *flags | EMPTY
            } else {
                flags.saturating_add(VOTE) | EMPTY
            };
        }
    } else if cos > 0.0 && d >= -behind {
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
mod tests;
