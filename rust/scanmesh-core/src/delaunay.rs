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

/// Maps planar coordinates into [-1, 1]² and flushes values below 1e-40 to zero.
///
/// spade accepts only coordinates that are 0 or of magnitude 2^-142..2^201; after this map
/// every input from 1e-300 to 1e300 qualifies. Orientation and in-circle signs are unchanged
/// (a translation and a uniform scale), except for the flushed sub-1e-40 offsets. O(n).
pub fn unit_square(uv: &[[f64; 2]]) -> Vec<[f64; 2]> {
    let (mut lo, mut hi) = ([f64::INFINITY; 2], [f64::NEG_INFINITY; 2]);
    for p in uv {
        for k in 0..2 {
            lo[k] = lo[k].min(p[k]);
            hi[k] = hi[k].max(p[k]);
        }
    }
    let center = [lo[0] * 0.5 + hi[0] * 0.5, lo[1] * 0.5 + hi[1] * 0.5];
    let half = (hi[0] * 0.5 - lo[0] * 0.5).max(hi[1] * 0.5 - lo[1] * 0.5);
    let scale = if half > 0.0 { 1.0 / half } else { 1.0 };
    let flush = |x: f64| if x.abs() < 1e-40 { 0.0 } else { x };
    // below about 5.6e-309 (subnormal) 1 / half overflows: divide instead (rarely taken,
    // so the usual roundings stay those of the multiplication)
    let map = |x: f64, c: f64| {
        if scale.is_finite() {
            flush((x - c) * scale)
        } else {
            flush((x - c) / half)
        }
    };
    uv.iter()
        .map(|p| [map(p[0], center[0]), map(p[1], center[1])])
        .collect()
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
