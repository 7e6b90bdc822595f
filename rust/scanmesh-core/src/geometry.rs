//! Small 3-D and planar primitives on glam `DVec3` and `[f64; 2]`.

use glam::DVec3;

/// Angle in radians at corner `p` of triangle (p, a, b), in [0, π].
///
/// Uses `atan2(|u × v|, u · v)`, which stays accurate for tiny and near-straight angles
/// where `acos` of a clamped cosine loses half the digits. O(1).
#[inline]
pub fn corner_angle(p: DVec3, a: DVec3, b: DVec3) -> f64 {
    let u = a - p;
    let v = b - p;
    u.cross(v).length().atan2(u.dot(v))
}

/// The three corner angles (radians) of triangle (a, b, c), at a, b and c in that order. O(1).
#[inline]
pub fn triangle_angles(a: DVec3, b: DVec3, c: DVec3) -> [f64; 3] {
    [
        corner_angle(a, b, c),
        corner_angle(b, c, a),
        corner_angle(c, a, b),
    ]
}

/// Smallest corner angle (radians) of triangle (a, b, c). O(1).
#[inline]
pub fn smallest_angle(a: DVec3, b: DVec3, c: DVec3) -> f64 {
    let [x, y, z] = triangle_angles(a, b, c);
    x.min(y).min(z)
}

/// Area of triangle (a, b, c) in squared input units. O(1).
#[inline]
pub fn triangle_area(a: DVec3, b: DVec3, c: DVec3) -> f64 {
    0.5 * (b - a).cross(c - a).length()
}

/// Unit normal of triangle (a, b, c) by the right-hand rule, or zero when it is degenerate. O(1).
#[inline]
pub fn triangle_normal(a: DVec3, b: DVec3, c: DVec3) -> DVec3 {
    (b - a).cross(c - a).normalize_or_zero()
}

/// Angle in radians at corner `p` of the planar triangle (p, a, b), atan2 form. O(1).
#[inline]
pub fn planar_corner_angle(p: [f64; 2], a: [f64; 2], b: [f64; 2]) -> f64 {
    let (ux, uy) = (a[0] - p[0], a[1] - p[1]);
    let (vx, vy) = (b[0] - p[0], b[1] - p[1]);
    (ux * vy - uy * vx).abs().atan2(ux * vx + uy * vy)
}

/// Smallest corner angle (radians) of the planar triangle (a, b, c). O(1).
#[inline]
pub fn planar_smallest_angle(a: [f64; 2], b: [f64; 2], c: [f64; 2]) -> f64 {
    planar_corner_angle(a, b, c)
        .min(planar_corner_angle(b, c, a))
        .min(planar_corner_angle(c, a, b))
}

/// Orientation of the planar triangle (a, b, c) by Shewchuk's exact predicate:
/// positive when counter-clockwise, negative when clockwise, exactly zero when collinear. O(1).
#[inline]
pub fn orient2d(a: [f64; 2], b: [f64; 2], c: [f64; 2]) -> f64 {
    robust::orient2d(
        robust::Coord { x: a[0], y: a[1] },
        robust::Coord { x: b[0], y: b[1] },
        robust::Coord { x: c[0], y: c[1] },
    )
}

/// Euclidean distance between two planar points. O(1).
#[inline]
pub fn planar_distance(a: [f64; 2], b: [f64; 2]) -> f64 {
    (a[0] - b[0]).hypot(a[1] - b[1])
}

/// A translation and uniform scale that maps points into [-1, 1]^d.
///
/// Angles, orientations and the order of lengths are invariant under it, and it keeps
/// products like `u × v` from overflowing at 1e300 or underflowing at 1e-300. O(n) to fit.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Normalizer {
    /// Centre of the bounding box, in input units.
    pub center: DVec3,
    /// Half the largest bounding-box extent, in input units (0 when all points coincide).
    pub half_extent: f64,
}

impl Normalizer {
    /// Fits the bounding box of `points` (finite values assumed).
    pub fn fit(points: &[DVec3]) -> Self {
        let mut lo = DVec3::splat(f64::INFINITY);
        let mut hi = DVec3::splat(f64::NEG_INFINITY);
        for &p in points {
            lo = lo.min(p);
            hi = hi.max(p);
        }
        if points.is_empty() {
            return Normalizer {
                center: DVec3::ZERO,
                half_extent: 0.0,
            };
        }
        // Halve before subtracting: hi - lo overflows for coordinates near f64::MAX.
        let half = hi * 0.5 - lo * 0.5;
        Normalizer {
            center: lo * 0.5 + hi * 0.5,
            half_extent: half.max_element(),
        }
    }

    /// Maps one point into the unit box (identity scale when all points coincide).
    #[inline]
    pub fn apply(&self, p: DVec3) -> DVec3 {
        if self.half_extent > 0.0 {
            (p - self.center) / self.half_extent
        } else {
            p - self.center
        }
    }

    /// Maps every point into the unit box. O(n).
    pub fn apply_all(&self, points: &[DVec3]) -> Vec<DVec3> {
        points.iter().map(|&p| self.apply(p)).collect()
    }
}

/// Planar points moved so their bounding box is centred on 0, then scaled by `1 / half` of
/// its larger extent, so that every coordinate lies in [-1, 1] (no flushing, unlike
/// [`crate::delaunay::unit_square`]). Returns the points and the scale factor (1 when all
/// points coincide). Keeps dot and cross products of 1e300- or 1e-300-sized inputs finite
/// and normal; orientations and length ratios are unchanged up to rounding. O(n).
pub fn normalize_plane(uv: &[[f64; 2]]) -> (Vec<[f64; 2]>, f64) {
    let (mut lo, mut hi) = ([f64::INFINITY; 2], [f64::NEG_INFINITY; 2]);
    for p in uv {
        for k in 0..2 {
            lo[k] = lo[k].min(p[k]);
            hi[k] = hi[k].max(p[k]);
        }
    }
    if uv.is_empty() {
        return (Vec::new(), 1.0);
    }
    // Halve before subtracting: hi - lo overflows for coordinates near f64::MAX.
    let center = [lo[0] * 0.5 + hi[0] * 0.5, lo[1] * 0.5 + hi[1] * 0.5];
    let half = (hi[0] * 0.5 - lo[0] * 0.5).max(hi[1] * 0.5 - lo[1] * 0.5);
    let scale = if half > 0.0 { 1.0 / half } else { 1.0 };
    let scale = if scale.is_finite() { scale } else { 1.0 };
    let out = uv
        .iter()
        .map(|p| [(p[0] - center[0]) * scale, (p[1] - center[1]) * scale])
        .collect();
    (out, scale)
}

/// Checks that every coordinate is finite; the error names the first bad one. O(n).
pub fn check_finite(points: &[DVec3]) -> crate::Result<()> {
    for (index, p) in points.iter().enumerate() {
        for axis in 0..3 {
            if !p[axis].is_finite() {
                return Err(crate::Error::NonFinite {
                    index,
                    axis,
                    value: p[axis],
                });
            }
        }
    }
    Ok(())
}

/// Checks planar points for the triangulation code: every coordinate finite (the error
/// names the first bad one) and fewer than 2^32 − 1 of them (indices are u32). O(n).
pub fn check_planar(uv: &[[f64; 2]]) -> crate::Result<()> {
    if uv.len() >= u32::MAX as usize {
        return Err(crate::Error::InvalidParameter {
            name: "points",
            value: uv.len().to_string(),
            expected: "fewer than 2^32 - 1 points",
        });
    }
    for (index, p) in uv.iter().enumerate() {
        for (axis, &value) in p.iter().enumerate() {
            if !value.is_finite() {
                return Err(crate::Error::NonFinite { index, axis, value });
            }
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::f64::consts::{FRAC_PI_2, PI};

    #[test]
    fn right_angle_and_straight_angle() {
        let p = DVec3::ZERO;
        assert!((corner_angle(p, DVec3::X, DVec3::Y) - FRAC_PI_2).abs() < 1e-15);
        assert!((corner_angle(p, DVec3::X, -DVec3::X) - PI).abs() < 1e-15);
    }

    #[test]
    fn tiny_angle_keeps_its_digits() {
        // acos(cos(1e-9)) returns 0 or ~2e-8; atan2 gives 1e-9 to full precision.
        let a = corner_angle(DVec3::ZERO, DVec3::X, DVec3::new(1.0, 1e-9, 0.0));
        assert!((a - 1e-9).abs() < 1e-22, "{a}");
    }

    #[test]
    fn angles_of_a_triangle_sum_to_pi() {
        let [a, b, c] = triangle_angles(
            DVec3::new(0.3, -1.0, 2.0),
            DVec3::new(4.0, 0.5, -1.0),
            DVec3::new(-2.0, 3.0, 0.25),
        );
        assert!((a + b + c - PI).abs() < 1e-14);
    }

    #[test]
    fn normalizer_survives_extreme_magnitudes() {
        for scale in [1e-300, 1e300, -1.7e308] {
            let pts = vec![DVec3::ZERO, DVec3::X * scale, DVec3::Y * scale];
            let n = Normalizer::fit(&pts);
            let q = n.apply_all(&pts);
            let a = corner_angle(q[0], q[1], q[2]);
            assert!((a - FRAC_PI_2).abs() < 1e-14, "scale {scale}: {a}");
        }
    }

    #[test]
    fn orientation_signs() {
        assert!(orient2d([0.0, 0.0], [1.0, 0.0], [0.0, 1.0]) > 0.0);
        assert!(orient2d([0.0, 0.0], [0.0, 1.0], [1.0, 0.0]) < 0.0);
        assert_eq!(orient2d([0.0, 0.0], [1.0, 1.0], [3.0, 3.0]), 0.0);
    }
}
