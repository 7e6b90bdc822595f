//! Projection of 3-D points onto a plane: the least-squares plane, a named axis, or a normal.

use crate::budget::try_par_collect;
use crate::geometry::{check_finite, Normalizer, PAR_BLOCK};
use crate::{Error, Result};
use glam::DVec3;
use rayon::prelude::*;

/// Which plane to project onto.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Plane {
    /// The least-squares plane: its normal is the smallest principal axis of the points.
    BestFit,
    /// Look along a coordinate axis: 0 = x (plane yz), 1 = y (plane zx), 2 = z (plane xy).
    Axis(usize),
    /// Look along this vector (any non-zero length).
    Normal(DVec3),
}

/// An orthonormal, right-handed frame: `u × v = normal`.
///
/// Planar coordinates of a point p are `((p - origin)·u, (p - origin)·v)`, in input units;
/// its height over the plane is `(p - origin)·normal`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Frame {
    /// A point of the plane (the centroid for `BestFit`, the bounding-box centre otherwise).
    pub origin: DVec3,
    /// First in-plane axis (unit).
    pub u: DVec3,
    /// Second in-plane axis (unit).
    pub v: DVec3,
    /// Viewing direction (unit); triangles counter-clockwise in (u, v) face along it.
    pub normal: DVec3,
}

impl Frame {
    /// The frame with this normal and a deterministic in-plane basis. `normal` must be non-zero.
    pub fn from_normal(origin: DVec3, normal: DVec3) -> Frame {
        let n = normal.normalize();
        // Cross with the axis least aligned with n: the best-conditioned perpendicular.
        let a = n.abs();
        let helper = if a.x <= a.y && a.x <= a.z {
            DVec3::X
        } else if a.y <= a.z {
            DVec3::Y
        } else {
            DVec3::Z
        };
        let u = helper.cross(n).normalize();
        let v = n.cross(u);
        Frame {
            origin,
            u,
            v,
            normal: n,
        }
    }

    /// Planar coordinates of `p`. O(1).
    #[inline]
    pub fn to_plane(&self, p: DVec3) -> [f64; 2] {
        let d = p - self.origin;
        [d.dot(self.u), d.dot(self.v)]
    }

    /// Signed height of `p` over the plane, along `normal`. O(1).
    #[inline]
    pub fn height(&self, p: DVec3) -> f64 {
        (p - self.origin).dot(self.normal)
    }
}

/// Projected points and the frame that produced them.
#[derive(Debug, Clone)]
pub struct Projection {
    /// Planar coordinates, one per input point, in input units.
    pub uv: Vec<[f64; 2]>,
    /// The plane.
    pub frame: Frame,
}

/// Projects `points` onto `plane`. O(n).
///
/// Errors: a non-finite coordinate; a zero or non-finite normal; an axis outside 0..3;
/// fewer than 3 points, all points identical, or all collinear in 3-D (checked for
/// `BestFit`, where the plane would be undefined).
pub fn project(points: &[DVec3], plane: Plane) -> Result<Projection> {
    check_finite(points)?;
    if points.len() < 3 {
        return Err(Error::TooFewPoints {
            distinct: points.len(),
        });
    }
    let box_fit = Normalizer::fit(points);
    if box_fit.half_extent == 0.0 {
        return Err(Error::TooFewPoints { distinct: 1 });
    }
    let frame = match plane {
        Plane::BestFit => best_fit_frame(points, &box_fit)?,
        Plane::Axis(axis) => {
            let (u, v, n) = match axis {
                0 => (DVec3::Y, DVec3::Z, DVec3::X),
                1 => (DVec3::Z, DVec3::X, DVec3::Y),
                2 => (DVec3::X, DVec3::Y, DVec3::Z),
                _ => {
                    return Err(Error::InvalidParameter {
                        name: "axis",
                        value: axis.to_string(),
                        expected: "0 (x), 1 (y) or 2 (z)",
                    })
                }
            };
            Frame {
                origin: box_fit.center,
                u,
                v,
                normal: n,
            }
        }
        Plane::Normal(n) => {
            let len = n.length();
            if !(len.is_finite() && len > 0.0) {
                return Err(Error::InvalidParameter {
                    name: "normal",
                    value: format!("{n:?}"),
                    expected: "a finite non-zero 3-vector",
                });
            }
            // Scale first: a normal like (1e300, 1e300, 0) has an infinite length.
            Frame::from_normal(box_fit.center, n / n.abs().max_element())
        }
    };
    // Each point on its own: in parallel, the same coordinates as a serial pass.
    let uv = points
        .par_iter()
        .with_min_len(PAR_BLOCK)
        .map(|&p| frame.to_plane(p));
    let uv = try_par_collect("the projected points", uv)?;
    Ok(Projection { uv, frame })
}

/// The least-squares plane through `points`: centroid and smallest principal axis.
///
/// The normal's sign is chosen so that its largest component is positive, the in-plane u
/// axis is the largest principal axis; both make the frame reproducible. O(n).
fn best_fit_frame(points: &[DVec3], box_fit: &Normalizer) -> Result<Frame> {
    // Work in the unit box: squares of 1e300 overflow, squares of 1e-300 vanish.
    // Mapped as they are summed (no unit-box copy of the points); the sums stay serial,
    // in point order, so the plane does not depend on the thread count.
    let (centroid, values, vectors) = principal_axes(|| points.iter().map(|&p| box_fit.apply(p)));
    // values ascending: values[0] is the normal's, values[2] the longest axis'. A second
    // axis under 1e-7 of the first (1e-14 in variance) is rounding noise: a line.
    if values[1] <= values[2] * 1e-14 {
        return Err(Error::Collinear {
            after_projection: false,
        });
    }
    let normal = canonical_sign(vectors[0]);
    let u0 = canonical_sign(vectors[2]);
    let u = (u0 - normal * u0.dot(normal)).normalize();
    let v = normal.cross(u);
    let origin = box_fit.center + centroid * box_fit.half_extent;
    Ok(Frame {
        origin,
        u,
        v,
        normal,
    })
}

/// Centroid and principal axes of the points `points()` yields: the scatter matrix's
/// eigenvalues ascending (sums of squared distances along each axis) and their unit
/// vectors. `points` is called twice (centroid, then scatter), so nothing is collected;
/// the sums run in the points' order. O(n).
pub(crate) fn principal_axes<I: Iterator<Item = DVec3>>(
    points: impl Fn() -> I,
) -> (DVec3, [f64; 3], [DVec3; 3]) {
    let (sum, count) = points().fold((DVec3::ZERO, 0usize), |(s, n), p| (s + p, n + 1));
    let centroid = sum / count as f64;
    let mut scatter = [[0.0f64; 3]; 3];
    for p in points() {
        let d = p - centroid;
        for (i, row) in scatter.iter_mut().enumerate() {
            for (j, c) in row.iter_mut().enumerate() {
                *c += d[i] * d[j];
            }
        }
    }
    let (values, vectors) = symmetric_eigen3(scatter);
    (centroid, values, vectors)
}

/// Flips `v` so that its largest-magnitude component is positive.
fn canonical_sign(v: DVec3) -> DVec3 {
    let a = v.abs();
    let k = if a.x >= a.y && a.x >= a.z {
        0
    } else if a.y >= a.z {
        1
    } else {
        2
    };
    if v[k] < 0.0 {
        -v
    } else {
        v
    }
}

/// Eigen-decomposition of a symmetric 3×3 matrix by cyclic Jacobi rotations.
///
/// Returns eigenvalues ascending and the matching unit eigenvectors. Jacobi is chosen over
/// the closed-form cubic because it stays accurate when two eigenvalues nearly coincide
/// (a scan of a near-square flat patch). O(1): at most 50 sweeps of 3 rotations.
pub(crate) fn symmetric_eigen3(m: [[f64; 3]; 3]) -> ([f64; 3], [DVec3; 3]) {
    let mut a = m;
    let mut v = [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]];
    for _ in 0..50 {
        let off = a[0][1].abs() + a[0][2].abs() + a[1][2].abs();
        let diag = a[0][0].abs() + a[1][1].abs() + a[2][2].abs();
        if off <= diag * 1e-18 || off == 0.0 {
            break;
        }
        for (p, q) in [(0usize, 1usize), (0, 2), (1, 2)] {
            if a[p][q] == 0.0 {
                continue;
            }
            let theta = (a[q][q] - a[p][p]) / (2.0 * a[p][q]);
            let t = theta.signum() / (theta.abs() + (theta * theta + 1.0).sqrt());
            let t = if theta == 0.0 { 1.0 } else { t };
            let c = 1.0 / (t * t + 1.0).sqrt();
            let s = t * c;
            for row in a.iter_mut() {
                let (akp, akq) = (row[p], row[q]);
                row[p] = c * akp - s * akq;
                row[q] = s * akp + c * akq;
            }
            let (row_p, row_q) = (a[p], a[q]);
            for k in 0..3 {
                a[p][k] = c * row_p[k] - s * row_q[k];
                a[q][k] = s * row_p[k] + c * row_q[k];
            }
            for row in v.iter_mut() {
                let vkp = row[p];
                let vkq = row[q];
                row[p] = c * vkp - s * vkq;
                row[q] = s * vkp + c * vkq;
            }
        }
    }
    let mut order = [0usize, 1, 2];
    order.sort_by(|&i, &j| a[i][i].total_cmp(&a[j][j]));
    let values = order.map(|i| a[i][i]);
    let vectors = order.map(|i| DVec3::new(v[0][i], v[1][i], v[2][i]).normalize());
    (values, vectors)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn tilted_patch(n: usize) -> (Vec<DVec3>, DVec3) {
        let normal = DVec3::new(1.0, -2.0, 3.0).normalize();
        let f = Frame::from_normal(DVec3::new(5.0, 1.0, -2.0), normal);
        let pts = (0..n * n)
            .map(|k| {
                let (i, j) = ((k % n) as f64, (k / n) as f64);
                f.origin + f.u * i * 0.7 + f.v * j * 0.3
            })
            .collect();
        (pts, normal)
    }

    #[test]
    fn best_fit_recovers_the_plane_normal() {
        let (pts, normal) = tilted_patch(6);
        let p = project(&pts, Plane::BestFit).unwrap();
        assert!(p.frame.normal.dot(normal).abs() > 1.0 - 1e-12);
        for &q in &pts {
            assert!(p.frame.height(q).abs() < 1e-10);
        }
        assert!((p.frame.u.cross(p.frame.v) - p.frame.normal).length() < 1e-12);
    }

    #[test]
    fn projection_preserves_in_plane_distances() {
        let (pts, _) = tilted_patch(4);
        let p = project(&pts, Plane::BestFit).unwrap();
        for i in 0..pts.len() {
            for j in 0..pts.len() {
                let d3 = (pts[i] - pts[j]).length();
                let d2 = crate::geometry::planar_distance(p.uv[i], p.uv[j]);
                assert!((d3 - d2).abs() < 1e-9);
            }
        }
    }

    #[test]
    fn named_axes_are_right_handed() {
        let pts = vec![DVec3::ZERO, DVec3::X, DVec3::Y, DVec3::Z];
        for axis in 0..3 {
            let f = project(&pts, Plane::Axis(axis)).unwrap().frame;
            assert!((f.u.cross(f.v) - f.normal).length() < 1e-15);
        }
    }

    #[test]
    fn degenerate_inputs_are_errors() {
        let line: Vec<DVec3> = (0..5).map(|i| DVec3::splat(i as f64)).collect();
        assert_eq!(
            project(&line, Plane::BestFit).unwrap_err(),
            Error::Collinear {
                after_projection: false
            }
        );
        let same = vec![DVec3::ONE; 4];
        assert!(matches!(
            project(&same, Plane::BestFit),
            Err(Error::TooFewPoints { .. })
        ));
        let nan = vec![DVec3::ZERO, DVec3::X, DVec3::new(0.0, f64::NAN, 0.0)];
        assert!(matches!(
            project(&nan, Plane::BestFit),
            Err(Error::NonFinite {
                index: 2,
                axis: 1,
                ..
            })
        ));
        let pts = vec![DVec3::ZERO, DVec3::X, DVec3::Y];
        assert!(project(&pts, Plane::Normal(DVec3::ZERO)).is_err());
        assert!(project(&pts, Plane::Axis(3)).is_err());
    }

    #[test]
    fn jacobi_diagonalizes() {
        let m = [[4.0, 1.0, 0.5], [1.0, 3.0, 0.2], [0.5, 0.2, 1.0]];
        let (vals, vecs) = symmetric_eigen3(m);
        for k in 0..3 {
            let x = vecs[k];
            let mx = DVec3::new(
                m[0][0] * x.x + m[0][1] * x.y + m[0][2] * x.z,
                m[1][0] * x.x + m[1][1] * x.y + m[1][2] * x.z,
                m[2][0] * x.x + m[2][1] * x.y + m[2][2] * x.z,
            );
            assert!((mx - x * vals[k]).length() < 1e-12);
        }
        assert!(vals[0] <= vals[1] && vals[1] <= vals[2]);
    }
}
