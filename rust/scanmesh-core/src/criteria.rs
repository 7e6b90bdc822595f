//! Quality criteria of a triangulation: the max-min angle and total absolute curvature (tac).
//!
//! Both are measured in 3-D on any triangle list (not only planar triangulations), so that
//! every method, and meshes from elsewhere, are judged by the same code.

use crate::budget::try_par_collect;
use crate::geometry::{triangle_angles, Normalizer};
use crate::mesh::Fans;
use crate::{Error, Result};
use glam::DVec3;
use rayon::prelude::*;
use std::f64::consts::TAU;

/// A p-norm on a quality vector: `(Σ x^p)^(1/p)` for p ≥ 1, or the maximum (p = ∞).
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Norm {
    /// Finite p ≥ 1.
    P(f64),
    /// p = ∞: the largest entry.
    Max,
}

impl Norm {
    /// The norm for exponent `p` (≥ 1; `f64::INFINITY` gives `Max`).
    pub fn new(p: f64) -> Result<Norm> {
        if p == f64::INFINITY {
            Ok(Norm::Max)
        } else if p.is_finite() && p >= 1.0 {
            Ok(Norm::P(p))
        } else {
            Err(Error::InvalidParameter {
                name: "p",
                value: p.to_string(),
                expected: "p >= 1 or infinity",
            })
        }
    }

    /// The norm of the non-NaN entries of `values` (NaN marks "not measured", e.g. boundary
    /// vertices). Scaled by the largest entry so that neither p-th powers overflow nor tiny
    /// entries vanish. 0 for no entries. O(n).
    pub fn of(&self, values: &[f64]) -> f64 {
        let largest = values
            .iter()
            .filter(|x| !x.is_nan())
            .fold(0.0f64, |m, &x| m.max(x.abs()));
        match *self {
            Norm::Max => largest,
            Norm::P(_) if largest == 0.0 => 0.0,
            Norm::P(p) => {
                let sum: f64 = values
                    .iter()
                    .filter(|x| !x.is_nan())
                    .map(|&x| (x.abs() / largest).powf(p))
                    .sum();
                largest * sum.powf(1.0 / p)
            }
        }
    }
}

/// Checks face indices: in range and three distinct vertices; the error names the face. O(m).
pub(crate) fn check_faces(n_vertices: usize, faces: &[[u32; 3]]) -> Result<()> {
    for (f, t) in faces.iter().enumerate() {
        if let Some(&v) = t.iter().find(|&&v| v as usize >= n_vertices) {
            return Err(Error::InvalidFace {
                face: f,
                reason: format!("vertex index {v} out of range (there are {n_vertices} vertices)"),
            });
        }
        if t[0] == t[1] || t[1] == t[2] || t[0] == t[2] {
            return Err(Error::InvalidFace {
                face: f,
                reason: format!("repeats a vertex: {t:?}"),
            });
        }
    }
    Ok(())
}

/// The two other corners of face `t` after vertex `v`, in the face's cyclic order.
#[inline]
fn others(t: [u32; 3], v: u32) -> (u32, u32) {
    let k = t
        .iter()
        .position(|&x| x == v)
        .expect("v is a corner of its fan");
    (t[(k + 1) % 3], t[(k + 2) % 3])
}

/// Whether vertex `v` with the faces `fan` around it is interior: at least three faces,
/// every edge (v, a) in exactly two of them, and the link one cycle. `link` and `ends` are
/// scratch space. O(d²) for d faces around v.
///
/// Why local suffices: every face containing the edge (v, a) is a face around v, and each
/// one puts `a` once into v's link, so the edge's use count is a's degree in the link.
fn is_interior(
    v: u32,
    fan: &[u32],
    faces: &[[u32; 3]],
    link: &mut Vec<(u32, u32)>,
    ends: &mut Vec<u32>,
) -> bool {
    if fan.len() < 3 {
        return false;
    }
    link.clear();
    ends.clear();
    for &f in fan {
        let (a, b) = others(faces[f as usize], v);
        link.push((a, b));
        ends.extend([a, b]);
    }
    ends.sort_unstable();
    // Every neighbour must occur exactly twice: runs of equal values of length 2.
    let all_twice = ends.chunks_exact(2).all(|p| p[0] == p[1])
        && ends.windows(3).step_by(2).all(|w| w[1] != w[2]);
    // Every neighbour now has link degree 2, so the link is a union of cycles; one cycle
    // means one fan. Walk it.
    all_twice && link_is_one_cycle(link)
}

/// True when the undirected link edges (every node of degree 2) form a single cycle. O(d²), d
/// small.
fn link_is_one_cycle(link: &[(u32, u32)]) -> bool {
    let mut used = vec![false; link.len()];
    let (first, mut node) = link[0];
    used[0] = true;
    let mut steps = 1;
    while node != first {
        let Some(k) =
            (0..link.len()).find(|&k| !used[k] && (link[k].0 == node || link[k].1 == node))
        else {
            return false;
        };
        used[k] = true;
        node = if link[k].0 == node {
            link[k].1
        } else {
            link[k].0
        };
        steps += 1;
    }
    steps == link.len()
}

/// The three 3-D corner angles (radians) of every face, at its corners in order, of the
/// points after `map` (applied on the fly: no mapped copy of the points). Each corner's
/// angle is computed once, here, for both the angle sums and the smallest angles (atan2 is
/// most of the quality report's time). O(m) time, 24 bytes per face, in parallel.
fn corner_angles(
    points: &[DVec3],
    faces: &[[u32; 3]],
    map: impl Fn(DVec3) -> DVec3 + Sync,
) -> Result<Vec<[f64; 3]>> {
    let angles = faces.par_iter().map(|t| {
        let [a, b, c] = t.map(|v| map(points[v as usize]));
        triangle_angles(a, b, c)
    });
    try_par_collect(ANGLES, angles)
}

/// What the measures' failed allocations name.
const ANGLES: &str = "the corner angles";

/// Sum of the corner angles at `v` over the faces `fan` around it, added in the fan's
/// (increasing face) order, so exactly as a serial pass over the faces would add them. O(d).
#[inline]
fn fan_angle_sum(faces: &[[u32; 3]], angles: &[[f64; 3]], v: u32, fan: &[u32]) -> f64 {
    fan.iter().fold(0.0, |sum, &f| {
        let t = faces[f as usize];
        let k = t
            .iter()
            .position(|&x| x == v)
            .expect("v is a corner of its fan");
        sum + angles[f as usize][k]
    })
}

/// Per-vertex sum of incident 3-D corner angles (radians); 0 for unused vertices. Faces
/// must be in range. O(n + m), in parallel; each sum adds its corners in face order, so the
/// result does not depend on the thread count. Errors: an [`Error::OutOfMemory`].
pub(crate) fn angle_sums(points: &[DVec3], faces: &[[u32; 3]]) -> Result<Vec<f64>> {
    let angles = corner_angles(points, faces, |p| p)?;
    let fans = Fans::new(points.len(), faces)?;
    let sums = (0..points.len())
        .into_par_iter()
        .map(|v| fan_angle_sum(faces, &angles, v as u32, fans.of(v)));
    try_par_collect(ANGLES, sums)
}

/// Sum of the corner angles at `v` over the faces `fan` around it, added in ascending
/// order of the angles (`scratch` holds them), so that the sum depends on the set of faces
/// around `v` only, not on their order in the face list nor on the order of the corners
/// within a face (a corner's angle is the same number either way). O(d log d).
#[inline]
fn canonical_angle_sum(
    faces: &[[u32; 3]],
    angles: &[[f64; 3]],
    v: u32,
    fan: &[u32],
    scratch: &mut Vec<f64>,
) -> f64 {
    scratch.clear();
    scratch.extend(fan.iter().map(|&f| {
        let t = faces[f as usize];
        let k = t
            .iter()
            .position(|&x| x == v)
            .expect("v is a corner of its fan");
        angles[f as usize][k]
    }));
    scratch.sort_unstable_by(f64::total_cmp);
    scratch.iter().fold(0.0, |sum, &a| sum + a)
}

/// tac per vertex from the corner angles of every face (interior check and angle sum
/// from one fan table); each sum adds its angles in ascending order, so the same faces in
/// any order give the same tac, bit for bit. O(n + m), in parallel over the vertices.
fn tac_from_angles(n_vertices: usize, faces: &[[u32; 3]], angles: &[[f64; 3]]) -> Result<Vec<f64>> {
    let fans = Fans::new(n_vertices, faces)?;
    let tac = (0..n_vertices).into_par_iter().map_init(
        || (Vec::new(), Vec::new(), Vec::new()),
        |(link, ends, scratch), v| {
            let fan = fans.of(v);
            if is_interior(v as u32, fan, faces, link, ends) {
                (TAU - canonical_angle_sum(faces, angles, v as u32, fan, scratch)).abs()
            } else {
                f64::NAN
            }
        },
    );
    try_par_collect(ANGLES, tac)
}

/// tac of every vertex (`|2π − Σ angles|` on interior vertices, NaN elsewhere, angles
/// measured on the points mapped into the unit box) and the smallest 3-D angle of every
/// face, with every corner angle computed once. O(n + m) time, in parallel; memory 24 bytes per
/// face
/// for the angles and 12 per face + 8 per vertex for the fan table, besides the outputs.
pub fn tac_and_min_angles(points: &[DVec3], faces: &[[u32; 3]]) -> Result<(Vec<f64>, Vec<f64>)> {
    check_faces(points.len(), faces)?;
    let normalizer = Normalizer::fit(points);
    let angles = corner_angles(points, faces, |p| normalizer.apply(p))?;
    let tac = tac_from_angles(points.len(), faces, &angles)?;
    let min_angle = try_par_collect(ANGLES, angles.par_iter().map(|a| a[0].min(a[1]).min(a[2])))?;
    Ok((tac, min_angle))
}

/// Number of `faces` whose normal (right-hand rule) is tilted more than `max_tilt`
/// radians from `normal` (any finite non-zero vector), so that upside-down faces (a fold
/// seen from the plane) count as steep and degenerate faces (zero normal) do not.
///
/// Faces are taken in the caller's index type (the binding hands numpy's int64 rows over
/// without a u32 copy: 240 MB at 20M faces). Scale-free: edge vectors are multiplied by
/// 1 / (half the largest bounding-box extent of `points`) before the cross product, as
/// `scanmesh.surface.steep_fraction` did in numpy. Errors: a face index out of range (the
/// first such face is named), a zero or non-finite normal. O(m), in parallel over the faces.
pub fn steep_count<I>(
    points: &[DVec3],
    faces: &[[I; 3]],
    normal: DVec3,
    max_tilt: f64,
) -> Result<usize>
where
    I: Copy + Sync + TryInto<usize>,
{
    let length = normal.length();
    if !(length.is_finite() && length > 0.0) {
        return Err(Error::InvalidParameter {
            name: "normal",
            value: format!("{normal:?}"),
            expected: "a finite non-zero vector",
        });
    }
    let n = normal / length;
    let index = |i: I| i.try_into().ok().filter(|&k| k < points.len());
    let half = Normalizer::fit(points).half_extent;
    let scale = if half > 0.0 { 1.0 / half } else { 1.0 };
    let limit = max_tilt.cos();
    // One pass counts and checks the indices together (a face out of range counts as
    // `faces.len() + 1`, more than any count of valid faces); only a bad face makes a
    // second pass, to name the first one.
    let bad = faces.len() + 1;
    let count: usize = faces
        .par_iter()
        .map(|t| match t.map(index) {
            [Some(a), Some(b), Some(c)] => {
                let [a, b, c] = [points[a], points[b], points[c]];
                let normal = ((b - a) * scale).cross((c - a) * scale);
                // tilt > max_tilt  <=>  cos(tilt) = normal·n / |normal| < cos(max_tilt)
                usize::from(normal.dot(n) < limit * normal.length())
            }
            _ => bad,
        })
        .reduce(|| 0, |x, y| x.saturating_add(y));
    if count <= faces.len() {
        return Ok(count);
    }
    let f = faces
        .par_iter()
        .position_first(|t| t.iter().any(|&i| index(i).is_none()))
        .expect("a face out of range was counted");
    let corner = faces[f]
        .iter()
        .position(|&i| index(i).is_none())
        .unwrap_or(0);
    Err(Error::InvalidFace {
        face: f,
        reason: format!(
            "corner {corner}: vertex index out of range (there are {} vertices)",
            points.len()
        ),
    })
}

/// Sliver threshold: a triangle with a smallest angle under 5° counts as a sliver.
pub const SLIVER_ANGLE_DEG: f64 = 5.0;

#[cfg(test)]
mod tests {
    use super::*;

    /// A square pyramid apex over a 3×3 grid: the centre is the only interior vertex.
    fn tent(height: f64) -> (Vec<DVec3>, Vec<[u32; 3]>) {
        let mut pts = Vec::new();
        for j in 0..3 {
            for i in 0..3 {
                let h = if i == 1 && j == 1 { height } else { 0.0 };
                pts.push(DVec3::new(i as f64, j as f64, h));
            }
        }
        let mut faces = Vec::new();
        for j in 0..2u32 {
            for i in 0..2u32 {
                let v = j * 3 + i;
                faces.push([v, v + 1, v + 4]);
                faces.push([v, v + 4, v + 3]);
            }
        }
        (pts, faces)
    }

    #[test]
    fn flat_grid_has_zero_tac_and_one_interior_vertex() {
        let (pts, faces) = tent(0.0);
        let (tac, _) = tac_and_min_angles(&pts, &faces).unwrap();
        assert!(tac[4].abs() < 1e-14);
        assert!(tac.iter().enumerate().all(|(i, t)| (i == 4) != t.is_nan()));
    }

    #[test]
    fn raised_centre_has_the_angle_defect() {
        let (pts, faces) = tent(1.0);
        let (tac, _) = tac_and_min_angles(&pts, &faces).unwrap();
        let manual: f64 = faces
            .iter()
            .filter_map(|t| {
                let k = t.iter().position(|&v| v == 4)?;
                Some(crate::geometry::corner_angle(
                    pts[4],
                    pts[t[(k + 1) % 3] as usize],
                    pts[t[(k + 2) % 3] as usize],
                ))
            })
            .sum();
        assert!((tac[4] - (TAU - manual)).abs() < 1e-14);
        assert!(tac[4] > 0.5);
        assert_eq!(Norm::P(1.0).of(&tac), tac[4]);
        assert_eq!(Norm::Max.of(&tac), tac[4]);
    }

    #[test]
    fn norms() {
        let v = [3.0, f64::NAN, 4.0];
        assert!((Norm::P(2.0).of(&v) - 5.0).abs() < 1e-15);
        assert_eq!(Norm::P(1.0).of(&v), 7.0);
        assert_eq!(Norm::Max.of(&v), 4.0);
        assert!((Norm::P(3.0).of(&[1e200, 1e200]) - 1e200 * 2f64.powf(1.0 / 3.0)).abs() < 1e186);
        assert!(Norm::new(0.5).is_err());
        assert!(Norm::new(f64::NAN).is_err());
        assert_eq!(Norm::new(f64::INFINITY).unwrap(), Norm::Max);
    }

    #[test]
    fn pinched_double_fan_is_not_interior() {
        // Two closed fans (two tents) glued at vertex 0 only: 0 has two cycles in its link.
        let faces = vec![
            [0, 1, 2],
            [0, 2, 3],
            [0, 3, 1],
            [0, 4, 5],
            [0, 5, 6],
            [0, 6, 4],
        ];
        let points: Vec<DVec3> = (0..7)
            .map(|k| DVec3::new(k as f64, (k * k) as f64, (k % 2) as f64))
            .collect();
        let (tac, _) = tac_and_min_angles(&points, &faces).unwrap();
        assert!(tac[0].is_nan());
    }

    /// The former implementation, kept as the oracle: edge uses by binary search in the
    /// sorted edge list, angle sums by a serial pass over the faces (each vertex's angles
    /// then added in ascending order).
    fn reference_tac(points: &[DVec3], faces: &[[u32; 3]]) -> (Vec<bool>, Vec<f64>) {
        let key = |a: u32, b: u32| ((a.min(b) as u64) << 32) | a.max(b) as u64;
        let mut edges: Vec<u64> = faces
            .iter()
            .flat_map(|t| [key(t[0], t[1]), key(t[1], t[2]), key(t[2], t[0])])
            .collect();
        edges.sort_unstable();
        let uses = |k: u64| edges.partition_point(|&e| e <= k) - edges.partition_point(|&e| e < k);
        let n = points.len();
        let mut interior = vec![false; n];
        for v in 0..n as u32 {
            let fan: Vec<[u32; 3]> = faces.iter().copied().filter(|t| t.contains(&v)).collect();
            if fan.len() < 3 {
                continue;
            }
            let link: Vec<(u32, u32)> = fan.iter().map(|&t| others(t, v)).collect();
            let closed = link
                .iter()
                .all(|&(a, b)| uses(key(v, a)) == 2 && uses(key(v, b)) == 2);
            interior[v as usize] = closed && link_is_one_cycle(&link);
        }
        let unit = Normalizer::fit(points).apply_all(points);
        let mut corners = vec![Vec::new(); n];
        for t in faces {
            let [a, b, c] = t.map(|v| unit[v as usize]);
            let angles = triangle_angles(a, b, c);
            for k in 0..3 {
                corners[t[k] as usize].push(angles[k]);
            }
        }
        let tac = corners
            .iter_mut()
            .zip(&interior)
            .map(|(c, &i)| {
                c.sort_by(f64::total_cmp);
                let s: f64 = c.iter().fold(0.0, |sum, &a| sum + a);
                if i {
                    (TAU - s).abs()
                } else {
                    f64::NAN
                }
            })
            .collect();
        (interior, tac)
    }

    #[test]
    fn fan_table_matches_the_edge_sort_on_random_meshes_with_holes() {
        use rand_core::{RngCore, SeedableRng};
        let mut rng = rand_pcg::Pcg64::seed_from_u64(9);
        let mut unit = || (rng.next_u64() >> 11) as f64 / (1u64 << 53) as f64;
        for (rows, cols) in [(6usize, 7usize), (25, 31)] {
            let at = |r: usize, c: usize| (r * cols + c) as u32;
            let mut points = Vec::new();
            for r in 0..rows {
                for c in 0..cols {
                    points.push(DVec3::new(
                        c as f64 + 0.3 * unit(),
                        r as f64 + 0.3 * unit(),
                        (c as f64 * 0.7).sin() + 0.5 * unit(),
                    ));
                }
            }
            // A grid with random diagonals, about 5 % of its faces dropped (holes),
            // mixed orientations, one face repeated (edges used three times) and a second
            // fan glued on at one vertex (a pinch).
            let mut faces = Vec::new();
            for r in 0..rows - 1 {
                for c in 0..cols - 1 {
                    let (a, b, d, e) = (at(r, c), at(r, c + 1), at(r + 1, c), at(r + 1, c + 1));
                    let pair = if unit() < 0.5 {
                        [[a, b, e], [a, e, d]]
                    } else {
                        [[a, b, d], [b, e, d]]
                    };
                    for mut t in pair {
                        if unit() < 0.05 {
                            continue;
                        }
                        if unit() < 0.3 {
                            t.swap(1, 2);
                        }
                        faces.push(t);
                    }
                }
            }
            faces.push(faces[faces.len() / 2]);
            let centre = at(rows / 2, cols / 2);
            let n = points.len() as u32;
            points.extend([DVec3::new(0.0, 0.0, 9.0), DVec3::X * 9.0, DVec3::Y * 9.0]);
            faces.extend([
                [centre, n, n + 1],
                [centre, n + 1, n + 2],
                [centre, n + 2, n],
            ]);
            let (interior, tac_ref) = reference_tac(&points, &faces);
            assert!(interior.iter().filter(|&&i| i).count() > rows * cols / 5);
            assert!(interior.iter().filter(|&&i| !i).count() > 2 * (rows + cols));
            let (tac, min_angle) = tac_and_min_angles(&points, &faces).unwrap();
            for (v, (x, y)) in tac.iter().zip(&tac_ref).enumerate() {
                assert_eq!(x.to_bits(), y.to_bits(), "vertex {v}: {x} vs {y}");
            }
            assert_eq!(
                tac.iter().map(|t| !t.is_nan()).collect::<Vec<_>>(),
                interior
            );
            let unit = Normalizer::fit(&points).apply_all(&points);
            assert!(faces.iter().zip(&min_angle).all(|(t, &m)| {
                let [a, b, c] = t.map(|v| unit[v as usize]);
                m == crate::geometry::smallest_angle(a, b, c)
            }));
        }
    }

    #[test]
    fn tac_does_not_depend_on_face_order_or_corner_order() {
        use rand_core::{RngCore, SeedableRng};
        let mut rng = rand_pcg::Pcg64::seed_from_u64(29);
        let (rows, cols) = (12u32, 15u32);
        let at = |r: u32, c: u32| r * cols + c;
        let mut points = Vec::new();
        for r in 0..rows {
            for c in 0..cols {
                let z = (rng.next_u64() >> 11) as f64 / (1u64 << 53) as f64;
                points.push(DVec3::new(c as f64, r as f64 + 0.1 * c as f64, z));
            }
        }
        let mut faces = Vec::new();
        for r in 0..rows - 1 {
            for c in 0..cols - 1 {
                let (a, b, d, e) = (at(r, c), at(r, c + 1), at(r + 1, c), at(r + 1, c + 1));
                faces.extend([[a, b, e], [a, e, d]]);
            }
        }
        let (tac, min_angle) = tac_and_min_angles(&points, &faces).unwrap();
        for _ in 0..20 {
            let mut shuffled = faces.clone();
            for i in (1..shuffled.len()).rev() {
                let j = (rng.next_u64() % (i as u64 + 1)) as usize;
                shuffled.swap(i, j);
            }
            for t in &mut shuffled {
                t.rotate_left((rng.next_u64() % 3) as usize);
                if rng.next_u64() % 2 == 0 {
                    t.swap(1, 2);
                }
            }
            let (tac2, _) = tac_and_min_angles(&points, &shuffled).unwrap();
            let bits = |v: &[f64]| v.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
            assert_eq!(bits(&tac), bits(&tac2));
            assert_eq!(
                Norm::P(1.0).of(&tac).to_bits(),
                Norm::P(1.0).of(&tac2).to_bits()
            );
        }
        assert_eq!(min_angle.len(), faces.len());
    }

    #[test]
    fn steep_count_by_tilt_fold_and_degeneracy() {
        // A right triangle whose normal is tilted by `deg` from z (about the x axis).
        let ramp = |deg: f64| {
            let (s, c) = deg.to_radians().sin_cos();
            vec![DVec3::ZERO, DVec3::X, DVec3::new(0.0, c, s)]
        };
        let limit = 75f64.to_radians();
        let up = DVec3::Z * 3.0; // any length
        assert_eq!(
            steep_count(&ramp(20.0), &[[0u32, 1, 2]], up, limit).unwrap(),
            0
        );
        assert_eq!(
            steep_count(&ramp(80.0), &[[0i64, 1, 2]], up, limit).unwrap(),
            1
        );
        // upside down: steep; degenerate (zero normal): not steep
        assert_eq!(
            steep_count(&ramp(60.0), &[[0u32, 2, 1]], up, limit).unwrap(),
            1
        );
        assert_eq!(
            steep_count(&ramp(60.0), &[[0u32, 1, 1]], up, limit).unwrap(),
            0
        );
        let pts = ramp(60.0);
        for scale in [1e-300, 1e300] {
            let scaled: Vec<DVec3> = pts.iter().map(|&p| p * scale).collect();
            assert_eq!(steep_count(&scaled, &[[0u32, 2, 1]], up, limit).unwrap(), 1);
        }
        assert!(matches!(
            steep_count(&pts, &[[0i64, 1, 2], [0, -1, 2]], up, limit),
            Err(Error::InvalidFace { face: 1, .. })
        ));
        assert!(matches!(
            steep_count(&pts, &[[0i64, 1, 3]], up, limit),
            Err(Error::InvalidFace { face: 0, .. })
        ));
        assert!(steep_count(&pts, &[[0u32, 1, 2]], DVec3::ZERO, limit).is_err());
        assert!(steep_count(&pts, &[[0u32, 1, 2]], DVec3::NAN, limit).is_err());
    }

    #[test]
    fn bad_faces_are_errors() {
        let points = [DVec3::ZERO, DVec3::X, DVec3::Y];
        assert!(matches!(
            tac_and_min_angles(&points, &[[0, 1, 5]]),
            Err(Error::InvalidFace { face: 0, .. })
        ));
        assert!(matches!(
            tac_and_min_angles(&points, &[[0, 1, 2], [2, 2, 1]]),
            Err(Error::InvalidFace { face: 1, .. })
        ));
    }
}
