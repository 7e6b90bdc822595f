//! Quality criteria of a triangulation: the max-min angle and total absolute curvature (tac).
//!
//! Both are measured in 3-D on any triangle list (not only planar triangulations), so that
//! every method, and meshes from elsewhere, are judged by the same code.

use crate::geometry::{smallest_angle, triangle_angles, Normalizer};
use crate::{Error, Result};
use glam::DVec3;
use std::cmp::Ordering;
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

/// Compares two tac vectors under `norm`: `Less` when `a` is the better (smaller) one. O(n).
pub fn compare_tac(a: &[f64], b: &[f64], norm: Norm) -> Ordering {
    norm.of(a).total_cmp(&norm.of(b))
}

/// Compares two triangulations by their smallest angles m(Δ): `Less` when `a` is better,
/// i.e. its smallest angle is **larger** (the optimum maximizes it; see DESIGN.md on the
/// paper's sign slip). O(1).
pub fn compare_max_min(min_angle_a: f64, min_angle_b: f64) -> Ordering {
    min_angle_b.total_cmp(&min_angle_a)
}

/// Checks face indices: in range and three distinct vertices; the error names the face. O(m).
pub fn check_faces(n_vertices: usize, faces: &[[u32; 3]]) -> Result<()> {
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

/// Which vertices are interior: used, every incident edge shared by exactly two faces, and
/// the incident faces form one closed fan (a single cycle of neighbours). Works on any
/// triangle list, oriented or not. O(m log m).
pub fn interior_vertices(n_vertices: usize, faces: &[[u32; 3]]) -> Result<Vec<bool>> {
    check_faces(n_vertices, faces)?;
    let key = |a: u32, b: u32| ((a.min(b) as u64) << 32) | a.max(b) as u64;
    let mut edges: Vec<u64> = faces
        .iter()
        .flat_map(|t| [key(t[0], t[1]), key(t[1], t[2]), key(t[2], t[0])])
        .collect();
    edges.sort_unstable();
    let uses = |k: u64| edges.partition_point(|&e| e <= k) - edges.partition_point(|&e| e < k);
    // Faces around each vertex, as compressed rows.
    let mut offsets = vec![0usize; n_vertices + 1];
    for t in faces {
        for &v in t {
            offsets[v as usize + 1] += 1;
        }
    }
    for v in 0..n_vertices {
        offsets[v + 1] += offsets[v];
    }
    let mut fill = offsets.clone();
    let mut around = vec![0u32; offsets[n_vertices]];
    for (f, t) in faces.iter().enumerate() {
        for &v in t {
            around[fill[v as usize]] = f as u32;
            fill[v as usize] += 1;
        }
    }
    let mut interior = vec![false; n_vertices];
    let mut link: Vec<(u32, u32)> = Vec::new();
    for v in 0..n_vertices as u32 {
        let fan = &around[offsets[v as usize]..offsets[v as usize + 1]];
        if fan.len() < 3 {
            continue;
        }
        link.clear();
        let mut closed = true;
        for &f in fan {
            let t = faces[f as usize];
            let k = t.iter().position(|&x| x == v).unwrap();
            let (a, b) = (t[(k + 1) % 3], t[(k + 2) % 3]);
            closed &= uses(key(v, a)) == 2 && uses(key(v, b)) == 2;
            link.push((a, b));
        }
        // Every neighbour now has link degree 2, so the link is a union of cycles; one
        // cycle means one fan. Walk it.
        interior[v as usize] = closed && link_is_one_cycle(&link);
    }
    Ok(interior)
}

/// True when the undirected link edges (every node of degree 2) form a single cycle. O(d²), d small.
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

/// Per-vertex sum of incident 3-D corner angles (radians); 0 for unused vertices. O(m).
pub fn angle_sums(points: &[DVec3], faces: &[[u32; 3]]) -> Vec<f64> {
    let mut sums = vec![0.0; points.len()];
    for t in faces {
        let [a, b, c] = t.map(|v| points[v as usize]);
        let angles = triangle_angles(a, b, c);
        for k in 0..3 {
            sums[t[k] as usize] += angles[k];
        }
    }
    sums
}

/// tac of every vertex: `|2π − Σ angles|` on interior vertices, NaN elsewhere. O(m log m).
pub fn tac(points: &[DVec3], faces: &[[u32; 3]]) -> Result<Vec<f64>> {
    let interior = interior_vertices(points.len(), faces)?;
    let unit = Normalizer::fit(points).apply_all(points);
    let sums = angle_sums(&unit, faces);
    Ok(sums
        .iter()
        .zip(&interior)
        .map(|(&s, &i)| if i { (TAU - s).abs() } else { f64::NAN })
        .collect())
}

/// Smallest 3-D corner angle (radians) of each face. O(m).
pub fn min_angles(points: &[DVec3], faces: &[[u32; 3]]) -> Vec<f64> {
    let unit = Normalizer::fit(points).apply_all(points);
    faces
        .iter()
        .map(|t| {
            let [a, b, c] = t.map(|v| unit[v as usize]);
            smallest_angle(a, b, c)
        })
        .collect()
}

/// Everything a quality report says about one mesh.
#[derive(Debug, Clone)]
pub struct Quality {
    /// tac per vertex (radians), NaN on vertices that are not interior.
    pub tac: Vec<f64>,
    /// Smallest 3-D angle per face (radians).
    pub min_angle: Vec<f64>,
    /// Number of interior vertices.
    pub n_interior: usize,
    /// tac 1-, 2- and ∞-norms.
    pub tac_1: f64,
    /// See `tac_1`.
    pub tac_2: f64,
    /// See `tac_1`.
    pub tac_inf: f64,
    /// m(Δ): the smallest angle of the mesh (radians; NaN with no faces).
    pub min_angle_overall: f64,
    /// Share of faces whose smallest angle is below the sliver threshold.
    pub sliver_fraction: f64,
}

/// Sliver threshold: a triangle with a smallest angle under 5° counts as a sliver.
pub const SLIVER_ANGLE_DEG: f64 = 5.0;

/// Measures `faces` over `points` (finite). O(m log m).
pub fn quality(points: &[DVec3], faces: &[[u32; 3]]) -> Result<Quality> {
    let tac = tac(points, faces)?;
    let min_angle = min_angles(points, faces);
    let n_interior = tac.iter().filter(|x| !x.is_nan()).count();
    let threshold = SLIVER_ANGLE_DEG.to_radians();
    let slivers = min_angle.iter().filter(|&&a| a < threshold).count();
    Ok(Quality {
        tac_1: Norm::P(1.0).of(&tac),
        tac_2: Norm::P(2.0).of(&tac),
        tac_inf: Norm::Max.of(&tac),
        n_interior,
        min_angle_overall: min_angle.iter().copied().fold(f64::NAN, f64::min),
        sliver_fraction: if faces.is_empty() {
            0.0
        } else {
            slivers as f64 / faces.len() as f64
        },
        tac,
        min_angle,
    })
}

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
        let q = quality(&pts, &faces).unwrap();
        assert_eq!(q.n_interior, 1);
        assert!(q.tac[4].abs() < 1e-14);
        assert!(q
            .tac
            .iter()
            .enumerate()
            .all(|(i, t)| (i == 4) != t.is_nan()));
    }

    #[test]
    fn raised_centre_has_the_angle_defect() {
        let (pts, faces) = tent(1.0);
        let q = quality(&pts, &faces).unwrap();
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
        assert!((q.tac[4] - (TAU - manual)).abs() < 1e-14);
        assert!(q.tac[4] > 0.5);
        assert_eq!(q.tac_1, q.tac[4]);
        assert_eq!(q.tac_inf, q.tac[4]);
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
        assert_eq!(
            compare_tac(&[1.0, 1.0], &[1.5, 0.0], Norm::P(1.0)),
            Ordering::Greater
        );
        assert_eq!(
            compare_tac(&[1.0, 1.0], &[1.5, 0.0], Norm::Max),
            Ordering::Less
        );
        assert_eq!(compare_max_min(0.5, 0.2), Ordering::Less);
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
        let interior = interior_vertices(7, &faces).unwrap();
        assert!(!interior[0]);
    }

    #[test]
    fn bad_faces_are_errors() {
        assert!(matches!(
            interior_vertices(3, &[[0, 1, 5]]),
            Err(Error::InvalidFace { face: 0, .. })
        ));
        assert!(matches!(
            interior_vertices(3, &[[0, 1, 2], [2, 2, 1]]),
            Err(Error::InvalidFace { face: 1, .. })
        ));
    }
}
