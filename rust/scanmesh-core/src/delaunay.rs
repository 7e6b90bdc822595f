//! Planar Delaunay triangulation through spade, with the map back to input indices.

use crate::geometry::{check_planar, orient2d};
use crate::{Error, Result};
use spade::{DelaunayTriangulation, HasPosition, Point2, Triangulation};

/// Marks "no such index" in index arrays (boundary twins, unique points).
pub const NONE: u32 = u32::MAX;

/// A Delaunay triangulation of planar points, in the caller's indices.
#[derive(Debug, Clone)]
pub struct Delaunay {
    /// Counter-clockwise triangles, each three input indices.
    pub triangles: Vec<[u32; 3]>,
    /// For each input point: `NONE` when it is a vertex of the triangulation, else the
    /// index of the earlier point with exactly the same planar coordinates that stands for it.
    pub duplicate_of: Vec<u32>,
}

impl Delaunay {
    /// Pairs (dropped point, the point that stands for it), in input order. O(n).
    pub fn duplicates(&self) -> Vec<(u32, u32)> {
        self.duplicate_of
            .iter()
            .enumerate()
            .filter(|(_, &k)| k != NONE)
            .map(|(i, &k)| (i as u32, k))
            .collect()
    }
}

/// spade's vertex type, carrying the input index through bulk loading's reordering.
struct IndexedPoint {
    position: Point2<f64>,
    index: u32,
}

impl HasPosition for IndexedPoint {
    type Scalar = f64;
    fn position(&self) -> Point2<f64> {
        self.position
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
    let largest = uv
        .iter()
        .flat_map(|p| [p[0].abs(), p[1].abs()])
        .fold(0.0, f64::max);
    unit_square_scaled_by(uv, largest)
}

/// [`unit_square_scaled`] with the scale of a larger set whose largest |coordinate| is
/// `largest` (a part of a scan mapped as the whole scan is). O(n).
pub(crate) fn unit_square_scaled_by(uv: &[[f64; 2]], largest: f64) -> (Vec<[f64; 2]>, (f64, f64)) {
    // largest = f × 2^e with f in [0.5, 1): scaling by 2^-e brings it into [0.5, 1), done
    // in two steps because 2^-e alone over- or underflows at the ends of the f64 range.
    let e = binary_exponent(largest);
    let (first, second) = (pow2(-e / 2), pow2(-e - (-e / 2)));
    let flush = |x: f64| {
        let y = x * first * second;
        if y.abs() < 1e-40 {
            0.0
        } else {
            y
        }
    };
    let unit = uv.iter().map(|p| [flush(p[0]), flush(p[1])]).collect();
    (unit, (first, second))
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

/// Delaunay triangulation of `uv` (planar points, finite). O(n log n).
///
/// Points with exactly equal coordinates are merged: the lowest index stays a vertex, the
/// others are listed in `duplicate_of`. Errors: fewer than 3 distinct points; all points
/// collinear (checked exactly before spade, whose bulk load is quadratic on such input).
pub fn delaunay(uv: &[[f64; 2]]) -> Result<Delaunay> {
    check_planar(uv)?;
    let unit = unit_square(uv);
    let duplicate_of = find_duplicates(&unit);
    let distinct: Vec<u32> = (0..uv.len() as u32)
        .filter(|&i| duplicate_of[i as usize] == NONE)
        .collect();
    if distinct.len() < 3 {
        return Err(Error::TooFewPoints {
            distinct: distinct.len(),
        });
    }
    if all_collinear(&unit, &distinct) {
        return Err(Error::Collinear {
            after_projection: true,
        });
    }
    let vertices = distinct
        .iter()
        .map(|&i| {
            let [x, y] = unit[i as usize];
            IndexedPoint {
                position: Point2::new(x, y),
                index: i,
            }
        })
        .collect();
    let dt = DelaunayTriangulation::<IndexedPoint>::bulk_load(vertices).map_err(|e| {
        Error::InvalidParameter {
            name: "points",
            value: format!("{e:?}"),
            expected: "coordinates spade accepts",
        }
    })?;
    let triangles = dt
        .inner_faces()
        .map(|f| {
            let [a, b, c] = f.vertices();
            let t = [a.data().index, b.data().index, c.data().index];
            // spade's faces are counter-clockwise; we promise it, so we make sure of it.
            if orient2d(
                unit[t[0] as usize],
                unit[t[1] as usize],
                unit[t[2] as usize],
            ) < 0.0
            {
                [t[0], t[2], t[1]]
            } else {
                t
            }
        })
        .collect();
    Ok(Delaunay {
        triangles,
        duplicate_of,
    })
}

/// For each point, the lowest index of an earlier point with identical coordinates, or NONE.
/// O(n log n) by sorting.
fn find_duplicates(uv: &[[f64; 2]]) -> Vec<u32> {
    let mut order: Vec<u32> = (0..uv.len() as u32).collect();
    let key = |i: &u32| uv[*i as usize];
    order.sort_by(|a, b| {
        let (p, q) = (key(a), key(b));
        p[0].total_cmp(&q[0])
            .then(p[1].total_cmp(&q[1]))
            .then(a.cmp(b))
    });
    let mut duplicate_of = vec![NONE; uv.len()];
    let mut run_start = 0;
    for k in 1..order.len() {
        let (first, this) = (order[run_start], order[k]);
        // == (not total_cmp) so that -0.0 and 0.0 count as the same position.
        if uv[first as usize] == uv[this as usize] {
            duplicate_of[this as usize] = first;
        } else {
            run_start = k;
        }
    }
    duplicate_of
}

/// True when all listed points lie on one line (exact predicate). O(n).
fn all_collinear(uv: &[[f64; 2]], ids: &[u32]) -> bool {
    let a = uv[ids[0] as usize];
    let b = uv[ids[1] as usize];
    ids[2..]
        .iter()
        .all(|&i| orient2d(a, b, uv[i as usize]) == 0.0)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::testing::random_points;

    #[test]
    fn triangles_are_ccw_and_cover_all_points() {
        let pts = random_points(500, 7);
        let d = delaunay(&pts).unwrap();
        let mut used = vec![false; pts.len()];
        for t in &d.triangles {
            assert!(orient2d(pts[t[0] as usize], pts[t[1] as usize], pts[t[2] as usize]) > 0.0);
            for &v in t {
                used[v as usize] = true;
            }
        }
        assert!(used.iter().all(|&u| u));
    }

    #[test]
    fn duplicates_are_reported_not_dropped() {
        let mut pts = random_points(50, 3);
        pts.push(pts[10]);
        pts.push(pts[10]);
        pts.push([-0.0 + pts[4][0], pts[4][1]]);
        let d = delaunay(&pts).unwrap();
        assert_eq!(d.duplicates(), vec![(50, 10), (51, 10), (52, 4)]);
        assert!(d.triangles.iter().all(|t| t.iter().all(|&v| v < 50)));
    }

    #[test]
    fn degenerate_inputs() {
        let line: Vec<[f64; 2]> = (0..10).map(|i| [i as f64, 2.0 * i as f64]).collect();
        assert_eq!(
            delaunay(&line).unwrap_err(),
            Error::Collinear {
                after_projection: true
            }
        );
        let two = vec![[0.0, 0.0], [1.0, 0.0], [1.0, 0.0], [0.0, 0.0]];
        assert_eq!(
            delaunay(&two).unwrap_err(),
            Error::TooFewPoints { distinct: 2 }
        );
        let nan = vec![[0.0, 0.0], [1.0, 0.0], [f64::NAN, 0.0]];
        assert!(matches!(
            delaunay(&nan),
            Err(Error::NonFinite { index: 2, .. })
        ));
    }

    #[test]
    fn exact_grids_keep_collinear_rows_collinear() {
        // A 10 x 10 grid off the origin, at scales where 1/half-extent is not a power of
        // two: every cell split in two (2 (n - 1)² triangles), no zero-area hull faces.
        for (scale, offset) in [(1.0, 0.3), (1e-300, 7.0), (1e300, -2.5), (3.0, 0.0)] {
            let uv: Vec<[f64; 2]> = (0..100)
                .map(|k| [((k % 10) as f64 + offset) * scale, (k / 10) as f64 * scale])
                .collect();
            let d = delaunay(&uv).unwrap();
            assert_eq!(d.triangles.len(), 2 * 9 * 9, "scale {scale}");
            let unit = unit_square(&uv);
            for t in &d.triangles {
                let [a, b, c] = t.map(|v| unit[v as usize]);
                assert!(orient2d(a, b, c) > 0.0);
            }
        }
    }

    #[test]
    fn unit_square_keeps_every_orientation_sign() {
        let mut pts = random_points(60, 5);
        // Exactly collinear triples that a rounding scale would bend.
        pts.extend([[0.1, 0.1], [0.2, 0.2], [0.3, 0.3], [1.0 / 3.0, 1.0 / 3.0]]);
        // At 2^±990 the reference signs are those of `pts` (the scaling is exact, and
        // orient2d of the scaled coordinates themselves would under- or overflow); at 3
        // (a rounding scale, whose 1 / half-extent is not a power of two) the scaled ones'.
        for s in [2f64.powi(-990), 3.0, 2f64.powi(990)] {
            let scaled: Vec<[f64; 2]> = pts.iter().map(|p| [p[0] * s, p[1] * s]).collect();
            let reference = if s == 3.0 { &scaled } else { &pts };
            let unit = unit_square(&scaled);
            assert!(unit.iter().flatten().all(|x| x.abs() <= 1.0));
            for i in 0..pts.len() {
                for j in (i + 1)..pts.len() {
                    for k in [(i + j) % pts.len(), pts.len() - 1] {
                        let sign = |p: &[[f64; 2]]| orient2d(p[i], p[j], p[k]).signum();
                        assert_eq!(sign(reference), sign(&unit), "scale {s}: {i} {j} {k}");
                    }
                }
            }
        }
    }

    #[test]
    fn extreme_scales_give_the_same_connectivity() {
        let pts = random_points(200, 11);
        let base = delaunay(&pts).unwrap().triangles;
        let canon = |mut t: Vec<[u32; 3]>| {
            for tri in t.iter_mut() {
                let k = (0..3).min_by_key(|&k| tri[k]).unwrap();
                tri.rotate_left(k);
            }
            t.sort();
            t
        };
        for s in [1e-300, 1e-6, 1e6, 1e300] {
            let scaled: Vec<[f64; 2]> = pts.iter().map(|p| [p[0] * s, p[1] * s]).collect();
            assert_eq!(
                canon(delaunay(&scaled).unwrap().triangles),
                canon(base.clone()),
                "scale {s}"
            );
        }
    }
}
