//! One range view as a depth image: the scanner looks down its own -z from above (the
//! scanner sits towards +z), pixel (i, j) is the ray through scanner coordinates
//! `origin + (i, j) * step`, and its depth is the z of the nearest return (NaN: no return).

use crate::error::{Error, Result};
use glam::{DMat3, DVec3};

/// How far a pose's rotation may be from orthonormal (largest entry of `RᵀR − I`).
pub const RIGID_TOL: f64 = 1e-6;

/// Neighbouring depths further apart than this many pixel steps are a depth jump: the
/// lookup does not interpolate across it.
pub const JUMP_STEPS: f64 = 4.0;

/// Smallest ray-to-normal cosine a sample is weighted with (grazing returns count little).
pub const MIN_COS: f64 = 0.05;

/// Longest run of rays without return (along a row or a column of the image) between two
/// returns that is read as returns lost rather than as a gap the rays passed through: a
/// real scanner loses its returns on surfaces it grazes (as `simulate_range_scan(grazing=
/// ...)` does). Such a ray carved on to the first node some view measured: beside a depth
/// jump it cut slots into a connecting rod seen 45° from its axes, and inside a face no
/// other view samples, on a grid finer than the rays (whose nodes around it look up that
/// ray), it bored a tunnel through a turbine blade (`test_merge.py`). A gap this narrow
/// (two rays) is below what a view resolves.
pub const LOST_RUN: usize = 2;

/// Largest margin ([`DepthView::with_margin`]) a view may be given, in pixels.
pub const MAX_MARGIN: usize = 16;

/// A depth image with its pose (scanner to world: `world = rotation * scanner + translation`).
#[derive(Debug, Clone)]
pub struct DepthView {
    rotation: DMat3,
    translation: DVec3,
    origin: [f64; 2],
    step: f64,
    width: usize,
    height: usize,
    /// (height * width) row-major by j, z of the return in scanner coordinates, NaN: none.
    depth: Vec<f64>,
    /// (height * width) |cos| between the ray and the surface normal at each return.
    cos: Vec<f64>,
    /// (height * width) how far each return is trusted, in [0, 1] (1 unless
    /// [`DepthView::with_weight`] says otherwise): it scales the return's weight in the
    /// fused average, and a return of weight 0 only votes for empty space in front of it.
    weight: Vec<f64>,
    /// Pixels (rows and columns) around a return within which a return nearer the scanner
    /// makes its evidence of empty space uncertain ([`DepthView::with_margin`]).
    margin: usize,
    /// (height * width) the depth nearest the scanner among the returns within `margin`
    /// pixels of each pixel, NaN where none.
    front: Vec<f64>,
}

/// What a ray through a point of the image plane saw.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Lookup {
    /// A return at this depth (scanner z) on a surface at this ray-to-normal cosine.
    Hit {
        /// Scanner z of the surface on this ray.
        depth: f64,
        /// |cos| of the angle between the ray and the surface normal, at least [`MIN_COS`].
        cos: f64,
        /// How far the return is trusted, in [0, 1] ([`DepthView::with_weight`]).
        weight: f64,
        /// The depth nearest the scanner within the view's margin
        /// ([`DepthView::with_margin`]) of the nearest pixel (at least `depth`): only a
        /// point farther in front of it than the truncation is shown empty by this return.
        front: f64,
    },
    /// The nearest ray (pixel index) had no return.
    Miss(usize),
    /// The point is outside the image.
    Outside,
}

impl DepthView {
    /// Checks and stores one view. `pose` is a row-major 4 × 4 scanner-to-world matrix (a
    /// rotation and a translation, last row 0 0 0 1); `depth` and `cos` hold
    /// `width * height` values row by row. O(width · height).
    ///
    /// Errors: `InvalidParameter` for a pose that is not finite or not rigid (a reflection,
    /// a scale, a shear), a step that is not positive, or lengths that do not match.
    pub fn new(
        pose: [f64; 16],
        origin: [f64; 2],
        step: f64,
        width: usize,
        height: usize,
        depth: Vec<f64>,
        cos: Vec<f64>,
    ) -> Result<Self> {
        let bad =
            |name: &'static str, value: String, expected: &'static str| Error::InvalidParameter {
                name,
                value,
                expected,
            };
        if let Some(v) = pose.iter().find(|v| !v.is_finite()) {
            return Err(bad("pose", v.to_string(), "finite entries"));
        }
        if pose[12..] != [0.0, 0.0, 0.0, 1.0] {
            return Err(bad(
                "pose",
                format!("{:?}", &pose[12..]),
                "a last row 0 0 0 1",
            ));
        }
        let rotation = DMat3::from_cols(
            DVec3::new(pose[0], pose[4], pose[8]),
            DVec3::new(pose[1], pose[5], pose[9]),
            DVec3::new(pose[2], pose[6], pose[10]),
        );
        let gram = rotation.transpose() * rotation - DMat3::IDENTITY;
        let off = gram
            .to_cols_array()
            .iter()
            .fold(0.0_f64, |m, v| m.max(v.abs()));
        if off > RIGID_TOL || rotation.determinant() <= 0.0 {
            return Err(bad(
                "pose",
                format!(
                    "rotation with |RᵀR − I| = {off:.3e}, det {:.6}",
                    rotation.determinant()
                ),
                "a rigid motion (orthonormal rotation, determinant +1)",
            ));
        }
        if !(step.is_finite() && step > 0.0) {
            return Err(bad(
                "step",
                step.to_string(),
                "a positive finite pixel step",
            ));
        }
        if !(origin[0].is_finite() && origin[1].is_finite()) {
            return Err(bad("origin", format!("{origin:?}"), "finite coordinates"));
        }
        let n = width.saturating_mul(height);
        if depth.len() != n || cos.len() != n {
            return Err(bad(
                "depth",
                format!(
                    "{} depths and {} cosines for {width} × {height} pixels",
                    depth.len(),
                    cos.len()
                ),
                "one depth and one cosine per pixel",
            ));
        }
        let cos = cos
            .into_iter()
            .map(|c| {
                if c.is_finite() {
                    c.abs().clamp(MIN_COS, 1.0)
                } else {
                    1.0
                }
            })
            .collect();
        Ok(Self {
            rotation,
            translation: DVec3::new(pose[3], pose[7], pose[11]),
            origin,
            step,
            width,
            height,
            front: depth.clone(),
            depth,
            cos,
            weight: vec![1.0; n],
            margin: 0,
        })
    }

    /// The view with a margin of `pixels` rays around each return: a node more than the
    /// truncation in front of the surface its ray met, but within `pixels` rays of a nearer
    /// surface's silhouette, is neither voted nor marked empty by that return, as it may
    /// lie inside the nearer surface once the view's misalignment against the others (its
    /// alignment residual) is allowed for. On the dragon's two series together (30 views
    /// whose frames differ by up to 0.9 mm) a single view's returns beside a horn's
    /// silhouette emptied the inside of the horn and cut it off the body. 0 (the default):
    /// every return beyond the truncation shows space empty. O(width · height · pixels).
    ///
    /// Errors: `InvalidParameter` for more than [`MAX_MARGIN`] pixels.
    pub fn with_margin(mut self, pixels: usize) -> Result<Self> {
        if pixels > MAX_MARGIN {
            return Err(Error::InvalidParameter {
                name: "margin",
                value: pixels.to_string(),
                expected: "at most MAX_MARGIN (16) pixels",
            });
        }
        self.margin = pixels;
        self.front = nearest_within(&self.depth, self.width, self.height, pixels);
        Ok(self)
    }

    /// The depth nearest the scanner within the margin of pixel `nearest`, for a lookup
    /// there that found `depth`: `depth` itself without a margin (an interpolated depth,
    /// not the pixel's own).
    fn front_at(&self, nearest: usize, depth: f64) -> f64 {
        if self.margin == 0 {
            depth
        } else {
            self.front[nearest].max(depth)
        }
    }

    /// The margin in pixels ([`DepthView::with_margin`]).
    pub fn margin(&self) -> usize {
        self.margin
    }

    /// The view with a trust per return (`width * height` values row by row, each in
    /// [0, 1]; NaN reads as 0): the scanner's own confidence, lower near the range grid's
    /// edges, its depth jumps and at grazing angles. O(width · height).
    ///
    /// Errors: `InvalidParameter` when the length does not match or a value is outside
    /// [0, 1].
    pub fn with_weight(mut self, weight: Vec<f64>) -> Result<Self> {
        if weight.len() != self.depth.len() {
            return Err(Error::InvalidParameter {
                name: "weight",
                value: format!("{} weights for {} pixels", weight.len(), self.depth.len()),
                expected: "one weight per pixel",
            });
        }
        if let Some(w) = weight
            .iter()
            .find(|w| !w.is_nan() && !(0.0..=1.0).contains(*w))
        {
            return Err(Error::InvalidParameter {
                name: "weight",
                value: w.to_string(),
                expected: "weights in [0, 1]",
            });
        }
        self.weight = weight
            .into_iter()
            .map(|w| if w.is_nan() { 0.0 } else { w })
            .collect();
        Ok(self)
    }

    /// Pixels across and down.
    pub fn size(&self) -> (usize, usize) {
        (self.width, self.height)
    }

    /// The ray direction towards the scanner (the view's +z), in world coordinates.
    pub fn toward_scanner(&self) -> DVec3 {
        self.rotation.z_axis
    }

    /// A world point in scanner coordinates.
    pub fn to_scanner(&self, p: DVec3) -> DVec3 {
        self.rotation.transpose() * (p - self.translation)
    }

    /// A scanner point in world coordinates.
    pub fn to_world(&self, q: DVec3) -> DVec3 {
        self.rotation * q + self.translation
    }

    /// The columns of the rotation (scanner to world): where the scanner's x, y and z axes
    /// point in the world, so that a ray's points are found as [`DepthView::to_world`]
    /// finds them, a multiply and two adds each.
    pub fn rotation_axes(&self) -> [DVec3; 3] {
        [
            self.rotation.x_axis,
            self.rotation.y_axis,
            self.rotation.z_axis,
        ]
    }

    /// Scanner (x, y) of pixel `index`'s ray.
    pub fn ray_xy(&self, index: usize) -> [f64; 2] {
        let (i, j) = (index % self.width, index / self.width);
        [
            self.origin[0] + i as f64 * self.step,
            self.origin[1] + j as f64 * self.step,
        ]
    }

    /// Pixel coordinates (u, v) of scanner (x, y): pixel (i, j)'s ray is at (i, j), as
    /// [`DepthView::lookup`] reads them. O(1).
    pub fn pixel(&self, x: f64, y: f64) -> [f64; 2] {
        [
            (x - self.origin[0]) / self.step,
            (y - self.origin[1]) / self.step,
        ]
    }

    /// The depths row by row (scanner z, NaN: no return).
    pub fn depths(&self) -> &[f64] {
        &self.depth
    }

    /// Each pixel's weight where a return is added to a node: its cosine times its trust
    /// ([`DepthView::with_weight`]), row by row, in [0, 1]. O(pixels).
    pub fn return_weights(&self) -> Vec<f64> {
        self.cos
            .iter()
            .zip(&self.weight)
            .map(|(c, t)| c * t)
            .collect()
    }

    /// True when pixel `index` has no return.
    pub fn is_miss(&self, index: usize) -> bool {
        self.depth[index].is_nan()
    }

    /// For pixel `index` without a return that lies in a run of at most `LOST_RUN` such
    /// pixels between two returns, along its row or its column: the depth (scanner z) its
    /// return was lost at, as far as the ray proves space empty. Across a depth jump
    /// ([`JUMP_STEPS`]) that is the nearer return's depth (the return was lost on the
    /// jump's side, somewhere between them); on one continuous surface, the two returns'
    /// depths interpolated at the pixel. Of the row's and the column's, the one nearer the
    /// scanner; `None` for a return or a wider gap. O(LOST_RUN).
    pub fn lost_return_depth(&self, index: usize) -> Option<f64> {
        if !self.is_miss(index) {
            return None;
        }
        let (i, j) = (index % self.width, index / self.width);
        // the first return from pixel (i, j) in direction (di, dj) and how many steps away,
        // if within the run's length and inside the image
        let return_towards = |di: isize, dj: isize| -> Option<(isize, usize)> {
            for k in 1..=LOST_RUN as isize {
                let (x, y) = (i as isize + k * di, j as isize + k * dj);
                if x < 0 || y < 0 || x >= self.width as isize || y >= self.height as isize {
                    return None;
                }
                let at = y as usize * self.width + x as usize;
                if !self.is_miss(at) {
                    return Some((k, at));
                }
            }
            None
        };
        [(1, 0), (0, 1)]
            .into_iter()
            .filter_map(|(di, dj)| {
                let (k1, a) = return_towards(di, dj)?;
                let (k2, b) = return_towards(-di, -dj)?;
                let (za, zb) = (self.depth[a], self.depth[b]);
                (k1 + k2 - 1 <= LOST_RUN as isize).then(|| {
                    if (za - zb).abs() > JUMP_STEPS * self.step {
                        za.max(zb)
                    } else {
                        za + (zb - za) * k1 as f64 / (k1 + k2) as f64
                    }
                })
            })
            .reduce(f64::max)
    }

    /// What the ray through scanner (x, y) saw: the depth interpolated bilinearly between
    /// the four surrounding returns when none is missing and no depth jump separates them,
    /// else the nearest pixel's. O(1).
    pub fn lookup(&self, x: f64, y: f64) -> Lookup {
        let u = (x - self.origin[0]) / self.step;
        let v = (y - self.origin[1]) / self.step;
        let (w, h) = (self.width as f64, self.height as f64);
        if !(u > -0.5 && v > -0.5 && u < w - 0.5 && v < h - 0.5) {
            return Lookup::Outside;
        }
        let nearest = (v.round() as usize) * self.width + u.round() as usize;
        let d = self.depth[nearest];
        if d.is_nan() {
            return Lookup::Miss(nearest);
        }
        let (i0, j0) = (u.floor(), v.floor());
        if i0 >= 0.0 && j0 >= 0.0 && i0 + 1.0 < w && j0 + 1.0 < h {
            let base = j0 as usize * self.width + i0 as usize;
            let corners = [base, base + 1, base + self.width, base + self.width + 1];
            let z = corners.map(|c| self.depth[c]);
            let lo = z.iter().copied().fold(f64::INFINITY, f64::min);
            let hi = z.iter().copied().fold(f64::NEG_INFINITY, f64::max);
            // NaN fails both comparisons, so a missing corner keeps `lo`/`hi` finite only
            // when it is absent from the fold's result: check it explicitly.
            if z.iter().all(|v| !v.is_nan()) && hi - lo <= JUMP_STEPS * self.step {
                let (fu, fv) = (u - i0, v - j0);
                let c = corners.map(|c| self.cos[c]);
                let t = corners.map(|c| self.weight[c]);
                let mix = |a: [f64; 4]| {
                    (a[0] * (1.0 - fu) + a[1] * fu) * (1.0 - fv)
                        + (a[2] * (1.0 - fu) + a[3] * fu) * fv
                };
                let depth = mix(z);
                return Lookup::Hit {
                    depth,
                    cos: mix(c),
                    weight: mix(t),
                    front: self.front_at(nearest, depth),
                };
            }
        }
        Lookup::Hit {
            depth: d,
            cos: self.cos[nearest],
            weight: self.weight[nearest],
            front: self.front_at(nearest, d),
        }
    }
}

/// Per pixel of a `width` × `height` depth image, the largest depth (nearest the scanner)
/// among the pixels within `reach` rows and columns, NaN where all are NaN: a running
/// maximum along the rows, then along the columns. O(pixels · reach).
fn nearest_within(depth: &[f64], width: usize, height: usize, reach: usize) -> Vec<f64> {
    // f64::max ignores NaN
    let along = |src: &[f64], at: &dyn Fn(usize, usize) -> usize, n: usize, m: usize| {
        let mut out = vec![f64::NAN; src.len()];
        for line in 0..m {
            for k in 0..n {
                let lo = k.saturating_sub(reach);
                let hi = (k + reach).min(n - 1);
                out[at(line, k)] = (lo..=hi).map(|j| src[at(line, j)]).fold(f64::NAN, f64::max);
            }
        }
        out
    };
    let rows = along(depth, &|row, k| row * width + k, width, height);
    along(&rows, &|col, k| k * width + col, height, width)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn identity() -> [f64; 16] {
        let mut m = [0.0; 16];
        for k in 0..4 {
            m[k * 5] = 1.0;
        }
        m
    }

    #[test]
    fn interpolates_a_plane_and_stops_at_misses() {
        // z = 0.5 x on a 4 × 3 grid, one pixel without a return
        let mut depth: Vec<f64> = (0..12).map(|k| 0.5 * (k % 4) as f64).collect();
        depth[11] = f64::NAN;
        let view = DepthView::new(identity(), [0.0, 0.0], 1.0, 4, 3, depth, vec![1.0; 12]).unwrap();
        match view.lookup(1.25, 0.5) {
            Lookup::Hit { depth, .. } => assert!((depth - 0.625).abs() < 1e-12),
            other => panic!("{other:?}"),
        }
        assert_eq!(view.lookup(3.0, 2.0), Lookup::Miss(11));
        assert_eq!(view.lookup(-0.6, 0.0), Lookup::Outside);
        // next to the miss: the nearest pixel's depth, not an interpolation with NaN
        match view.lookup(2.4, 1.6) {
            Lookup::Hit { depth, .. } => assert_eq!(depth, 1.0),
            other => panic!("{other:?}"),
        }
    }

    /// A view looking down with unit steps, every return head-on.
    fn looking_down(width: usize, height: usize, depth: Vec<f64>) -> DepthView {
        let n = depth.len();
        DepthView::new(
            identity(),
            [0.0; 2],
            1.0,
            width,
            height,
            depth,
            vec![1.0; n],
        )
        .unwrap()
    }

    #[test]
    fn a_short_run_without_returns_between_returns_is_lost_a_long_one_a_gap() {
        let nan = f64::NAN;
        // returns at 0, 2 and 5 (depths 1, 9, 2: jumps of 8 and 7 steps) with runs of 1
        // and 2 between them, and a run of 2 open towards the border
        let line = vec![1.0, nan, 9.0, nan, nan, 2.0, nan, nan];
        for view in [looking_down(8, 1, line.clone()), looking_down(1, 8, line)] {
            assert_eq!(view.lost_return_depth(0), None); // a return
            assert_eq!(view.lost_return_depth(1), Some(9.0)); // the nearer: towards +z
            assert_eq!(view.lost_return_depth(3), Some(9.0));
            assert_eq!(view.lost_return_depth(4), Some(9.0));
            assert_eq!(view.lost_return_depth(6), None);
        }
        // on one surface (depths 1, 4: 3 steps apart), the depth between them
        let smooth = looking_down(4, 1, vec![1.0, nan, nan, 4.0]);
        assert_eq!(smooth.lost_return_depth(1), Some(2.0));
        assert_eq!(smooth.lost_return_depth(2), Some(3.0));
        // three rays without return between two returns are a gap
        let wide = looking_down(5, 1, vec![1.0, nan, nan, nan, 9.0]);
        assert!((1..4).all(|k| wide.lost_return_depth(k).is_none()));
    }

    #[test]
    fn refuses_poses_that_are_not_rigid() {
        let mut scaled = identity();
        scaled[0] = 2.0;
        let mut mirrored = identity();
        mirrored[0] = -1.0;
        let mut nan = identity();
        nan[3] = f64::NAN;
        for pose in [scaled, mirrored, nan] {
            let err = DepthView::new(pose, [0.0; 2], 1.0, 1, 1, vec![0.0], vec![1.0]);
            assert!(matches!(
                err,
                Err(Error::InvalidParameter { name: "pose", .. })
            ));
        }
    }

    #[test]
    fn poses_map_both_ways() {
        // a quarter turn about x, then a shift
        let pose = [
            1.0, 0.0, 0.0, 1.0, //
            0.0, 0.0, -1.0, 2.0, //
            0.0, 1.0, 0.0, 3.0, //
            0.0, 0.0, 0.0, 1.0,
        ];
        let view = DepthView::new(pose, [0.0; 2], 1.0, 1, 1, vec![0.0], vec![1.0]).unwrap();
        let q = DVec3::new(0.3, -0.7, 1.1);
        let p = view.to_world(q);
        assert!((p - DVec3::new(1.3, 2.0 - 1.1, 3.0 - 0.7)).length() < 1e-12);
        assert!((view.to_scanner(p) - q).length() < 1e-12);
        assert!((view.toward_scanner() - DVec3::new(0.0, -1.0, 0.0)).length() < 1e-12);
    }
}
