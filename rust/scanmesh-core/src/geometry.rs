//! Small 3-D and planar primitives on glam `DVec3` and `[f64; 2]`.

use glam::DVec3;
use rayon::prelude::*;

/// Points per rayon task in the passes over all points here: large enough that splitting
/// costs nothing next to the work, small enough to share a million among threads.
pub(crate) const PAR_BLOCK: usize = 1 << 14;

/// `y.atan2(x)` for y ≥ 0 (a result in [0, π]), to within a few units in the last place.
///
/// Why not libm: its atan2 was half the run time of strips under the angle and dihedral
/// weights (up to six calls per matrix cell), and a quarter of annealing's on curved
/// surfaces (six corner angles per proposal). The one implementation for both. This is Cephes'
/// `atan` (Moshier): a
/// reduction to |u| ≤ 0.66 and a degree 4/5 rational function; tested within 4 ulp of
/// libm over 40 decades. The reduction is written without branches (selects), because
/// the DP's cost comparisons wait on these results and a mispredicted branch here stalls
/// them: u = min/max, or (min − max)/(min + max) when min > 0.66 max (one division
/// where Cephes divides twice; min − max is exact there by Sterbenz). O(1).
#[inline(always)]
pub(crate) fn atan2_upper(y: f64, x: f64) -> f64 {
    use std::f64::consts::{FRAC_PI_2, FRAC_PI_4, PI};
    const MOREBITS: f64 = 6.123_233_995_736_766e-17;
    const P: [f64; 5] = [
        -8.750_608_600_031_904e-1,
        -1.615_753_718_733_365e1,
        -7.500_855_792_314_705e1,
        -1.228_866_684_490_136e2,
        -6.485_021_904_942_025e1,
    ];
    const Q: [f64; 5] = [
        2.485_846_490_142_306e1,
        1.650_270_098_316_988e2,
        4.328_810_604_912_903e2,
        4.853_903_996_359_137e2,
        1.945_506_571_482_614e2,
    ];
    let ax = x.abs();
    if y == 0.0 && ax == 0.0 {
        return if x.is_sign_negative() { PI } else { 0.0 };
    }
    // atan2 = atan(min/max), or π/2 − that when y > |x|; then π − that when x < 0.
    let swapped = y > ax;
    let (lo, hi) = if swapped { (ax, y) } else { (y, ax) };
    let big = lo > 0.66 * hi;
    let u = if big { lo - hi } else { lo } / if big { lo + hi } else { hi };
    let z = u * u;
    let p = (((P[0] * z + P[1]) * z + P[2]) * z + P[3]) * z + P[4];
    let q = ((((z + Q[0]) * z + Q[1]) * z + Q[2]) * z + Q[3]) * z + Q[4];
    let (base, more) = if big {
        (FRAC_PI_4, 0.5 * MOREBITS)
    } else {
        (0.0, 0.0)
    };
    let a = base + (u + u * z * p / q + more);
    let a = if swapped { FRAC_PI_2 - a } else { a };
    if x < 0.0 {
        PI - a
    } else {
        a
    }
}

/// Angle in radians at corner `p` of triangle (p, a, b), in [0, π].
///
/// Uses `atan2(|u × v|, u · v)`, which stays accurate for tiny and near-straight angles
/// where `acos` of a clamped cosine loses half the digits. O(1).
#[inline]
pub(crate) fn corner_angle(p: DVec3, a: DVec3, b: DVec3) -> f64 {
    let u = a - p;
    let v = b - p;
    atan2_upper(u.cross(v).length(), u.dot(v))
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

/// Smallest corner angle (radians) of triangle (a, b, c), for tests' reference costs. O(1).
#[cfg(test)]
pub(crate) fn smallest_angle(a: DVec3, b: DVec3, c: DVec3) -> f64 {
    let [x, y, z] = triangle_angles(a, b, c);
    x.min(y).min(z)
}

/// Area of triangle (a, b, c) in squared input units, for tests' reference costs. O(1).
#[cfg(test)]
pub(crate) fn triangle_area(a: DVec3, b: DVec3, c: DVec3) -> f64 {
    0.5 * (b - a).cross(c - a).length()
}

/// Angle in radians at corner `p` of the planar triangle (p, a, b), atan2 form. O(1).
#[inline]
pub(crate) fn planar_corner_angle(p: [f64; 2], a: [f64; 2], b: [f64; 2]) -> f64 {
    let (ux, uy) = (a[0] - p[0], a[1] - p[1]);
    let (vx, vy) = (b[0] - p[0], b[1] - p[1]);
    atan2_upper((ux * vy - uy * vx).abs(), ux * vx + uy * vy)
}

/// Smallest corner angle (radians) of the planar triangle (a, b, c). O(1).
#[inline]
pub(crate) fn planar_smallest_angle(a: [f64; 2], b: [f64; 2], c: [f64; 2]) -> f64 {
    planar_corner_angle(a, b, c)
        .min(planar_corner_angle(b, c, a))
        .min(planar_corner_angle(c, a, b))
}

/// Orientation of the planar triangle (a, b, c) by Shewchuk's exact predicate:
/// positive when counter-clockwise, negative when clockwise, exactly zero when collinear. O(1).
#[inline]
pub(crate) fn orient2d(a: [f64; 2], b: [f64; 2], c: [f64; 2]) -> f64 {
    robust::orient2d(
        robust::Coord { x: a[0], y: a[1] },
        robust::Coord { x: b[0], y: b[1] },
        robust::Coord { x: c[0], y: c[1] },
    )
}

/// Euclidean distance between two planar points. O(1).
#[inline]
pub(crate) fn planar_distance(a: [f64; 2], b: [f64; 2]) -> f64 {
    (a[0] - b[0]).hypot(a[1] - b[1])
}

/// A translation and uniform scale that maps points into [-1, 1]^d.
///
/// Angles, orientations and the order of lengths are invariant under it, and it keeps
/// products like `u × v` from overflowing at 1e300 or underflowing at 1e-300. O(n) to fit.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct Normalizer {
    /// Centre of the bounding box, in input units.
    pub center: DVec3,
    /// Half the largest bounding-box extent, in input units (0 when all points coincide).
    pub half_extent: f64,
}

impl Normalizer {
    /// Fits the bounding box of `points` (finite values assumed). O(n), in parallel above
    /// [`PAR_BLOCK`] points: the smallest and largest coordinates do not depend on the
    /// order they are compared in, so the fit is the serial one bit for bit.
    pub fn fit(points: &[DVec3]) -> Self {
        let bounds = |chunk: &[DVec3]| {
            chunk.iter().fold(
                (DVec3::splat(f64::INFINITY), DVec3::splat(f64::NEG_INFINITY)),
                |(lo, hi), &p| (lo.min(p), hi.max(p)),
            )
        };
        let (lo, hi) = if points.len() > PAR_BLOCK {
            points
                .par_chunks(PAR_BLOCK)
                .map(bounds)
                .reduce_with(|(lo, hi), (p, q)| (lo.min(p), hi.max(q)))
                .expect("more than one block")
        } else {
            bounds(points)
        };
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

/// Scales planar coordinates by a power of two into [-1, 1]² and flushes values below 1e-40
/// to zero.
///
/// spade accepts only coordinates that are 0 or of magnitude 2^-142..2^201; after this map
/// every input from 1e-300 to 1e300 qualifies. Multiplying by a power of two is exact, so
/// every orientation and in-circle sign is that of the caller's own coordinates (collinear
/// stays exactly collinear, the root of valid faces on exact grids), except where a
/// coordinate below 1e-40 of the largest magnitude is flushed. No translation: it would
/// round. O(n).
pub fn unit_square(uv: &[[f64; 2]]) -> Vec<[f64; 2]> {
    unit_square_scaled(uv).0
}

/// [`unit_square`] and its scale as two powers of two whose product maps a length into the
/// unit square (`x * s.0 * s.1`; one number could over- or underflow). O(n).
pub(crate) fn unit_square_scaled(uv: &[[f64; 2]]) -> (Vec<[f64; 2]>, (f64, f64)) {
    UnitSquare::of(uv).all(uv)
}

/// [`unit_square_scaled`] with the scale of a larger set whose largest |coordinate| is
/// `largest` (a part of a scan mapped as the whole scan is). O(n).
pub(crate) fn unit_square_scaled_by(uv: &[[f64; 2]], largest: f64) -> (Vec<[f64; 2]>, (f64, f64)) {
    UnitSquare::by(largest).all(uv)
}

/// The map of [`unit_square`], for callers that need a few points of a large set mapped
/// (the corners of boundary triangles) rather than all of them.
#[derive(Debug, Clone, Copy)]
pub(crate) struct UnitSquare {
    first: f64,
    second: f64,
}

impl UnitSquare {
    /// The map that brings `uv` into the unit square. O(n), on the rayon pool.
    pub(crate) fn of(uv: &[[f64; 2]]) -> Self {
        let largest = uv
            .par_iter()
            .with_min_len(1 << 14)
            .map(|p| p[0].abs().max(p[1].abs()))
            .reduce(|| 0.0, f64::max);
        Self::by(largest)
    }

    /// The map for a set whose largest |coordinate| is `largest`. O(1).
    pub(crate) fn by(largest: f64) -> Self {
        // largest = f × 2^e with f in [0.5, 1): scaling by 2^-e brings it into [0.5, 1), done
        // in two steps because 2^-e alone over- or underflows at the ends of the f64 range.
        let e = binary_exponent(largest);
        Self {
            first: pow2(-e / 2),
            second: pow2(-e - (-e / 2)),
        }
    }

    /// One point mapped: scaled, and coordinates below 1e-40 flushed to zero. O(1).
    pub(crate) fn map(self, p: [f64; 2]) -> [f64; 2] {
        let flush = |x: f64| {
            let y = self.scale(x);
            if y.abs() < 1e-40 {
                0.0
            } else {
                y
            }
        };
        [flush(p[0]), flush(p[1])]
    }

    /// `x` scaled by the map's power of two, exactly (no flushing). O(1).
    pub(crate) fn scale(self, x: f64) -> f64 {
        x * self.first * self.second
    }

    /// `x` brought back from the map's scale (the inverse of [`scale`](Self::scale)). O(1).
    pub(crate) fn unscale(self, x: f64) -> f64 {
        x / self.first / self.second
    }

    /// Every point mapped, and the scale. O(n).
    fn all(self, uv: &[[f64; 2]]) -> (Vec<[f64; 2]>, (f64, f64)) {
        (
            uv.iter().map(|&p| self.map(p)).collect(),
            (self.first, self.second),
        )
    }
}

/// The e with `x = f × 2^e`, f in [0.5, 1), for finite x > 0; 0 for x = 0. O(1).
fn binary_exponent(x: f64) -> i32 {
    if x == 0.0 {
        return 0;
    }
    let biased = ((x.to_bits() >> 52) & 0x7ff) as i32;
    if biased == 0 {
        // Subnormal: scale into the normal range first (exact).
        return binary_exponent(x * pow2(64)) - 64;
    }
    biased - 1022
}

/// 2^k for k in -1022..=1023, exactly. O(1).
fn pow2(k: i32) -> f64 {
    debug_assert!((-1022..=1023).contains(&k));
    f64::from_bits(((k + 1023) as u64) << 52)
}

/// Planar points moved so their bounding box is centred on 0, then scaled by `1 / half` of
/// its larger extent, so that every coordinate lies in [-1, 1] (no flushing, unlike
/// [`crate::geometry::unit_square`]). Returns the points and the scale factor (1 when all
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
    // The common case (all finite) in parallel; the serial walk names the first bad one.
    if points.len() > PAR_BLOCK
        && points
            .par_chunks(PAR_BLOCK)
            .all(|c| c.iter().all(|p| p.is_finite()))
    {
        return Ok(());
    }
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
pub(crate) fn check_planar(uv: &[[f64; 2]]) -> crate::Result<()> {
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
    fn atan2_upper_matches_libm() {
        let mut state = 3u64;
        let mut next = || {
            state = state
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            (state >> 11) as f64 / (1u64 << 53) as f64
        };
        let mut worst = 0.0f64;
        for k in 0..200_000 {
            // Magnitudes over 40 decades, both signs of x, and the special lines.
            let scale = |r: f64| 10f64.powf(40.0 * r - 20.0);
            let y = if k % 97 == 0 {
                0.0
            } else {
                next() * scale(next())
            };
            let x = match k % 89 {
                0 => 0.0,
                1 => -y,
                2 => y,
                _ => (next() - 0.5) * scale(next()),
            };
            let (fast, exact) = (atan2_upper(y, x), y.atan2(x));
            worst = worst.max((fast - exact).abs() / exact.abs().max(f64::MIN_POSITIVE));
            assert!(
                (fast - exact).abs() <= 4.0 * f64::EPSILON * exact.abs(),
                "atan2({y}, {x}): {fast} vs {exact}"
            );
        }
        assert_eq!(atan2_upper(0.0, 0.0), 0.0);
        assert_eq!(atan2_upper(0.0, -0.0), PI);
        assert_eq!(atan2_upper(0.0, -1.0), PI);
        assert!(worst < 4.0 * f64::EPSILON, "{worst}");
    }

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
