//! Exhaustive enumeration for small inputs: the empty triangles of a planar point set and
//! every (fine) triangulation of its convex hull.
//!
//! Both are ground truth for exact optimization: the empty triangles are the candidate
//! variables of the tac-optimal mixed-integer program (`scanmesh.optimal`), and the list of
//! all triangulations is the brute force that checks it on a handful of points.
//!
//! A *triangulation* here always means a fine triangulation of the convex hull: every input
//! point is a vertex, the triangles cover the hull and meet only in common edges or
//! vertices. Its triangles are then exactly *empty*: no input point other than their three
//! corners lies in the closed triangle (a point on an edge would have to be a vertex on that
//! edge). Points on the hull's edges are boundary vertices in every triangulation.
//!
//! Enumeration walks the flip graph breadth first from a starting triangulation, flipping
//! with [`HalfEdgeMesh::can_flip`] / [`HalfEdgeMesh::flip`]. The flip graph of the
//! triangulations of a planar point set is connected (Lawson, *Transforming
//! triangulations*, Discrete Math. 3 (1972) 365–372: every triangulation flips to a
//! Delaunay one, and the Delaunay triangulations differ only inside cocircular convex
//! polygons, whose triangulations are flip-connected), so the walk reaches all of them.

use crate::delaunay::NONE;
use crate::geometry::orient2d;
use crate::mesh::HalfEdgeMesh;
use crate::{Error, Result};
use rayon::prelude::*;
use std::collections::{HashSet, VecDeque};

/// Every non-degenerate triangle over `uv` whose closed area holds no other input point,
/// counter-clockwise, sorted (by first, second, third index after rotating the smallest
/// index first).
///
/// `uv` must be finite and pairwise distinct (merge coincident points first). Exact
/// predicates throughout: a triangle with three collinear corners, or with an input point
/// strictly inside or on one of its edges, is left out. Runs in parallel; O(n⁴) worst case
/// (each of the C(n, 3) triples is tested against the points within its x-range). For
/// random points about 2n² triangles are empty.
pub fn empty_triangles(uv: &[[f64; 2]]) -> Result<Vec<[u32; 3]>> {
    check_distinct(uv)?;
    let n = uv.len();
    // Points sorted by x, so that each triple tests only those within its x-range.
    let mut by_x: Vec<u32> = (0..n as u32).collect();
    by_x.sort_by(|&a, &b| uv[a as usize][0].total_cmp(&uv[b as usize][0]));
    let xs: Vec<f64> = by_x.iter().map(|&i| uv[i as usize][0]).collect();
    let mut found: Vec<[u32; 3]> = (0..n as u32)
        .into_par_iter()
        .flat_map_iter(|i| {
            let (by_x, xs) = (&by_x, &xs);
            ((i + 1)..n as u32).flat_map(move |j| {
                ((j + 1)..n as u32).filter_map(move |k| {
                    let (a, b, c) = (uv[i as usize], uv[j as usize], uv[k as usize]);
                    let o = orient2d(a, b, c);
                    if o == 0.0 {
                        return None;
                    }
                    let t = if o > 0.0 { [i, j, k] } else { [i, k, j] };
                    let (lo, hi) = (a[0].min(b[0]).min(c[0]), a[0].max(b[0]).max(c[0]));
                    let first = xs.partition_point(|&x| x < lo);
                    let last = xs.partition_point(|&x| x <= hi);
                    let occupied = by_x[first..last].iter().any(|&p| {
                        p != i && p != j && p != k && in_closed_triangle(uv, t, uv[p as usize])
                    });
                    (!occupied).then_some(t)
                })
            })
        })
        .collect();
    found.sort_unstable();
    Ok(found)
}

/// True when `p` lies in the closed counter-clockwise triangle `t` (exact). O(1).
#[inline]
fn in_closed_triangle(uv: &[[f64; 2]], t: [u32; 3], p: [f64; 2]) -> bool {
    let [a, b, c] = t.map(|v| uv[v as usize]);
    orient2d(a, b, p) >= 0.0 && orient2d(b, c, p) >= 0.0 && orient2d(c, a, p) >= 0.0
}

/// Errors unless every coordinate is finite and no two points coincide. O(n log n).
fn check_distinct(uv: &[[f64; 2]]) -> Result<()> {
    if uv.len() >= NONE as usize {
        return Err(Error::InvalidParameter {
            name: "uv",
            value: uv.len().to_string(),
            expected: "fewer than 2^32 - 1 points",
        });
    }
    for (index, p) in uv.iter().enumerate() {
        for (axis, &x) in p.iter().enumerate() {
            if !x.is_finite() {
                return Err(Error::NonFinite {
                    index,
                    axis,
                    value: x,
                });
            }
        }
    }
    let mut order: Vec<usize> = (0..uv.len()).collect();
    order.sort_by(|&a, &b| {
        uv[a][0]
            .total_cmp(&uv[b][0])
            .then(uv[a][1].total_cmp(&uv[b][1]))
    });
    // == (not total_cmp) so that -0.0 and 0.0 count as the same position.
    if let Some(w) = order.windows(2).find(|w| uv[w[0]] == uv[w[1]]) {
        return Err(Error::InvalidParameter {
            name: "uv",
            value: format!(
                "points {} and {} at {:?}",
                w[0].min(w[1]),
                w[0].max(w[1]),
                uv[w[0]]
            ),
            expected: "pairwise distinct planar points (merge coincident points first)",
        });
    }
    Ok(())
}

/// The canonical form of a triangle list: each triangle rotated so that its smallest index
/// comes first (orientation kept), then the list sorted. Two lists describe the same
/// triangulation exactly when their canonical forms are equal. O(m log m).
pub fn canonical(triangles: &[[u32; 3]]) -> Vec<[u32; 3]> {
    let mut out: Vec<[u32; 3]> = triangles
        .iter()
        .map(|t| {
            let k = (0..3).min_by_key(|&k| t[k]).unwrap_or(0);
            let mut r = *t;
            r.rotate_left(k);
            r
        })
        .collect();
    out.sort_unstable();
    out
}

/// Checks that `mesh` is a fine triangulation of the convex hull of `uv`; the error says
/// what fails.
///
/// Conditions: [`HalfEdgeMesh::validate`] passes; every point is a vertex; no point lies
/// strictly right of any boundary half-edge (the boundary is convex and encloses all
/// points: this also rules out holes, as every hole has a point on the right of each of its
/// edges); and the triangle count is `2n − b − 2` for `b` boundary edges, which, with
/// validate's Euler check V − E + F = 2C − B and no holes, leaves exactly one disc. A
/// locally embedded disc whose boundary only turns left is embedded, so the triangles tile
/// the hull. O(n·b + m log m).
pub fn check_full_triangulation(uv: &[[f64; 2]], mesh: &HalfEdgeMesh) -> Result<()> {
    mesh.validate(uv)?;
    let fail = |s: String| Err(Error::Invariant(s));
    if let Some(v) = (0..uv.len() as u32).find(|&v| !mesh.is_used(v)) {
        return fail(format!(
            "point {v} is not a vertex: a triangulation must use every point"
        ));
    }
    let boundary: Vec<u32> = (0..mesh.n_half_edges() as u32)
        .filter(|&h| mesh.twin(h) == NONE)
        .collect();
    for &h in &boundary {
        let (a, b) = (mesh.start(h), mesh.end(h));
        if let Some(p) =
            (0..uv.len()).find(|&p| orient2d(uv[a as usize], uv[b as usize], uv[p]) < 0.0)
        {
            return fail(format!(
                "boundary edge {a}->{b} has point {p} on its outer side: the triangles do not fill the convex hull"
            ));
        }
    }
    let expected = 2 * uv.len() as i64 - boundary.len() as i64 - 2;
    if mesh.n_triangles() as i64 != expected {
        return fail(format!(
            "{} triangles, but one disc over {} points with {} boundary edges has {expected}",
            mesh.n_triangles(),
            uv.len(),
            boundary.len()
        ));
    }
    Ok(())
}

/// Every triangulation of the convex hull of `uv`, found by breadth-first search over edge
/// flips from `start`; each in [`canonical`] form, `start` first, in the order found.
///
/// `start` must be a triangulation of the hull using every point (checked with
/// [`check_full_triangulation`]); `uv` must be pairwise distinct. Errors with
/// `InvalidParameter { name: "max_count" }` as soon as more than `max_count` triangulations
/// are found (their number grows exponentially: Catalan(n − 2) for n points in convex
/// position). O(K·m·(m log m)) time and O(K·m) memory for K triangulations of m triangles.
pub fn triangulations(
    uv: &[[f64; 2]],
    start: &[[u32; 3]],
    max_count: usize,
) -> Result<Vec<Vec<[u32; 3]>>> {
    check_distinct(uv)?;
    let mesh = HalfEdgeMesh::from_triangles(uv.len(), start)?;
    check_full_triangulation(uv, &mesh)?;
    let too_many = |found: usize| Error::InvalidParameter {
        name: "max_count",
        value: max_count.to_string(),
        expected: if found > max_count {
            "at least the number of triangulations (more were found: raise max_count)"
        } else {
            "at least 1"
        },
    };
    if max_count == 0 {
        return Err(too_many(0));
    }
    let first = canonical(&mesh.triangles());
    let mut seen: HashSet<Vec<[u32; 3]>> = HashSet::from([first.clone()]);
    let mut found = vec![first];
    let mut queue = VecDeque::from([mesh]);
    while let Some(current) = queue.pop_front() {
        for h in current.interior_edges() {
            if !current.can_flip(h, uv) {
                continue;
            }
            let mut flipped = current.clone();
            flipped.flip(h);
            let key = canonical(&flipped.triangles());
            if seen.contains(&key) {
                continue;
            }
            seen.insert(key.clone());
            found.push(key);
            if found.len() > max_count {
                return Err(too_many(found.len()));
            }
            queue.push_back(flipped);
        }
    }
    Ok(found)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::delaunay::delaunay;

    fn lcg_points(n: usize, seed: u64) -> Vec<[f64; 2]> {
        let mut s = seed;
        let mut next = || {
            s = s
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            (s >> 11) as f64 / (1u64 << 53) as f64
        };
        (0..n).map(|_| [next(), next()]).collect()
    }

    fn all(uv: &[[f64; 2]], cap: usize) -> Result<Vec<Vec<[u32; 3]>>> {
        let d = delaunay(uv)?;
        triangulations(uv, &d.triangles, cap)
    }

    fn catalan(k: u64) -> u64 {
        (0..k).fold(1u64, |c, i| c * 2 * (2 * i + 1) / (i + 2))
    }

    fn binomial(n: u64, k: u64) -> u64 {
        (0..k).fold(1u64, |c, i| c * (n - i) / (i + 1))
    }

    fn grid(cols: usize, rows: usize) -> Vec<[f64; 2]> {
        (0..rows)
            .flat_map(|j| (0..cols).map(move |i| [i as f64, j as f64]))
            .collect()
    }

    #[test]
    fn convex_polygons_have_catalan_many_triangulations() {
        for n in 3..=11usize {
            let uv: Vec<[f64; 2]> = (0..n)
                .map(|k| {
                    let a = std::f64::consts::TAU * k as f64 / n as f64 + 0.1;
                    [a.cos(), 0.7 * a.sin()]
                })
                .collect();
            let found = all(&uv, 100_000).unwrap();
            assert_eq!(found.len() as u64, catalan(n as u64 - 2), "{n}-gon");
            // In convex position every triangle is empty.
            assert_eq!(
                empty_triangles(&uv).unwrap().len() as u64,
                binomial(n as u64, 3)
            );
        }
    }

    #[test]
    fn lattice_grids_match_the_known_counts() {
        // Unimodular triangulations of the 1 x k lattice rectangle: C(2k, k); of 2 x 2: 64;
        // of 2 x 3: 852 (Kaibel and Ziegler, Counting lattice triangulations, 2003).
        // Collinear points on the hull's edges and cocircular squares everywhere.
        for k in 1..=5usize {
            assert_eq!(
                all(&grid(k + 1, 2), 1_000_000).unwrap().len() as u64,
                binomial(2 * k as u64, k as u64)
            );
        }
        assert_eq!(all(&grid(3, 3), 1_000).unwrap().len(), 64);
        assert_eq!(all(&grid(4, 3), 10_000).unwrap().len(), 852);
    }

    #[test]
    fn every_enumerated_triangulation_is_distinct_full_and_made_of_empty_triangles() {
        for seed in 0..6 {
            let uv = lcg_points(9, seed);
            let empty: HashSet<[u32; 3]> = empty_triangles(&uv).unwrap().into_iter().collect();
            let found = all(&uv, 100_000).unwrap();
            let distinct: HashSet<&Vec<[u32; 3]>> = found.iter().collect();
            assert_eq!(distinct.len(), found.len());
            for t in &found {
                let mesh = HalfEdgeMesh::from_triangles(uv.len(), t).unwrap();
                check_full_triangulation(&uv, &mesh).unwrap();
                assert!(
                    t.iter().all(|tri| empty.contains(tri)),
                    "a non-empty triangle was used"
                );
            }
        }
    }

    #[test]
    fn square_with_centre() {
        // The centre lies on both diagonals: only the four triangles around it are empty.
        let uv = vec![[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 1.0], [0.5, 0.5]];
        assert_eq!(
            empty_triangles(&uv).unwrap(),
            vec![[0, 1, 4], [0, 4, 3], [1, 2, 4], [2, 3, 4]]
        );
        assert_eq!(all(&uv, 10).unwrap().len(), 1);
        // Off-centre, inside triangle (0, 1, 2): the quad has 3 fine triangulations.
        let uv = vec![[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 1.0], [0.7, 0.4]];
        assert_eq!(all(&uv, 10).unwrap().len(), 3);
    }

    #[test]
    fn the_cap_is_an_error_not_a_truncation() {
        let uv: Vec<[f64; 2]> = (0..9)
            .map(|k| {
                let a = std::f64::consts::TAU * k as f64 / 9.0;
                [a.cos(), a.sin()]
            })
            .collect();
        assert_eq!(all(&uv, 429).unwrap().len(), 429);
        assert!(matches!(
            all(&uv, 428),
            Err(Error::InvalidParameter {
                name: "max_count",
                ..
            })
        ));
        assert!(matches!(
            all(&uv, 0),
            Err(Error::InvalidParameter {
                name: "max_count",
                ..
            })
        ));
    }

    #[test]
    fn bad_inputs_are_errors() {
        let dup = vec![[0.0, 0.0], [1.0, 0.0], [0.0, 1.0], [1.0, 0.0]];
        assert!(matches!(
            empty_triangles(&dup),
            Err(Error::InvalidParameter { name: "uv", .. })
        ));
        let nan = vec![[0.0, 0.0], [1.0, f64::NAN], [0.0, 1.0]];
        assert!(matches!(
            empty_triangles(&nan),
            Err(Error::NonFinite {
                index: 1,
                axis: 1,
                ..
            })
        ));
        // A start that leaves out the interior point, or only half the square.
        let uv = vec![[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 1.0], [0.7, 0.4]];
        assert!(triangulations(&uv, &[[0, 1, 2], [0, 2, 3]], 10).is_err());
        let square = vec![[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 1.0]];
        let err = triangulations(&square, &[[0, 1, 2], [0, 2, 3], [0, 1, 2]], 10).unwrap_err();
        assert!(matches!(err, Error::InvalidFace { .. }), "{err}");
        let half = vec![[0.0, 0.0], [1.0, 0.0], [1.0, 1.0]];
        assert!(triangulations(&half, &[[0, 1, 2]], 10).is_ok());
        let err = triangulations(
            &square[..3]
                .iter()
                .chain([[0.2, 0.9]].iter())
                .copied()
                .collect::<Vec<_>>(),
            &[[0, 1, 2]],
            10,
        )
        .unwrap_err();
        assert!(format!("{err}").contains("not a vertex"), "{err}");
    }
}
