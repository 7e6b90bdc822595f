//! Never-sampled walls laid flat. A vertex that no sample placed sits at the mean of its
//! cell's crossings, each found on the rays and so known only to the nearest ray (± half a
//! spacing): a plane wall at a slant to the rows of rays comes out as a staircase. Each
//! such vertex is moved onto the least-squares plane of the unsampled vertices around it on
//! the same wall, where they are flat: the staircase averages out across the rows, while a
//! wall running along a row of rays, whose offset no ray can tell, keeps it.

use crate::projection::principal_axes;
use glam::DVec3;

/// Rings of mesh neighbours whose unsampled vertices make a vertex's plane: 3 voxels each
/// way, several steps of a staircase 10° off the rows. On benches/merge.py's four parts
/// from six views (docs/benchmarks/merge.md) the fandisk's never-sampled wall was 0.00123
/// RMS with 2 rings, 0.00102 with 3 (0.0015 before).
const RINGS: usize = 3;

/// Neighbours on the same wall: vertex normals within this cosine (14°). The wall across a
/// corner or the floor below a rim is another plane, and a corner cell's vertex, the mean of
/// its crossings on two walls, leans towards the other: at 0.9 such vertices tilted the
/// planes of a box's exact walls, moving them 0.022 voxel off (`extract`'s tests), and put
/// the blade's root face 6 % further off.
const SAME_WALL: f64 = 0.97;

/// Vertices farther from the first plane than this many times the RMS distance are left out
/// of the second.
const TRIM: f64 = 2.0;

/// Vertices (the vertex itself included) needed to fit a plane.
const MIN_VERTICES: usize = 6;

/// Flat enough to be one plane: the smallest principal variance at most this share of the
/// total (a staircase of ± half a voxel over 7 × 7 vertices gives about 0.01, a right-angled
/// fold through them 0.08).
const FLAT_SHARE: f64 = 0.05;

/// Moves each vertex with `unsampled[v]` onto the plane of the unsampled vertices within
/// [`RINGS`] edges of it that face its way, where they are flat; the planes are fitted to
/// the positions before any moves (one Jacobi-style pass). `faces` must make a closed
/// 2-manifold (each directed edge once). Returns the vertices moved.
/// O(faces + unsampled vertices · vertices within the rings).
pub(super) fn flatten_unsampled(
    vertices: &mut [DVec3],
    faces: &[[u32; 3]],
    unsampled: &[bool],
) -> usize {
    if !unsampled.iter().any(|&u| u) {
        return 0;
    }
    let n = vertices.len();
    // neighbours by directed edge: in a closed 2-manifold each neighbour comes once
    let mut start = vec![0usize; n + 1];
    for t in faces {
        for &a in t {
            start[a as usize + 1] += 1;
        }
    }
    for v in 0..n {
        start[v + 1] += start[v];
    }
    let mut fill = start.clone();
    let mut neighbours = vec![0u32; start[n]];
    let mut normal = vec![DVec3::ZERO; n];
    for t in faces {
        let p = t.map(|i| vertices[i as usize]);
        let area_normal = (p[1] - p[0]).cross(p[2] - p[0]);
        for e in 0..3 {
            let a = t[e] as usize;
            neighbours[fill[a]] = t[(e + 1) % 3];
            fill[a] += 1;
            normal[a] += area_normal;
        }
    }
    let normal: Vec<DVec3> = normal.iter().map(|m| m.normalize_or_zero()).collect();
    let before = vertices.to_vec();
    let mut seen = vec![usize::MAX; n];
    let (mut ring, mut next, mut wall) = (Vec::new(), Vec::new(), Vec::new());
    let mut moved = 0;
    for v in (0..n).filter(|&v| unsampled[v]) {
        seen[v] = v;
        ring.clear();
        ring.push(v as u32);
        wall.clear();
        wall.push(v);
        for _ in 0..RINGS {
            next.clear();
            for &r in &ring {
                let r = r as usize;
                for &w in &neighbours[start[r]..start[r + 1]] {
                    let w = w as usize;
                    if seen[w] == v {
                        continue;
                    }
                    seen[w] = v;
                    next.push(w as u32);
                    if unsampled[w] && normal[w].dot(normal[v]) > SAME_WALL {
                        wall.push(w);
                    }
                }
            }
            std::mem::swap(&mut ring, &mut next);
        }
        if wall.len() < MIN_VERTICES {
            continue;
        }
        let Some((centroid, axis, spread)) = plane(&before, &wall) else {
            continue;
        };
        // once more without the vertices beyond twice the residual: a vertex of a corner
        // cell, the mean of its crossings on two walls, would tilt the plane
        wall.retain(|&w| (before[w] - centroid).dot(axis).abs() <= TRIM * spread);
        if wall.len() < MIN_VERTICES {
            continue;
        }
        let Some((centroid, axis, _)) = plane(&before, &wall) else {
            continue;
        };
        vertices[v] = before[v] - axis * (before[v] - centroid).dot(axis);
        moved += 1;
    }
    moved
}

/// The least-squares plane of `points[wall]` where it is flat ([`FLAT_SHARE`]): centroid,
/// unit normal, RMS distance of the points from it. O(wall).
fn plane(points: &[DVec3], wall: &[usize]) -> Option<(DVec3, DVec3, f64)> {
    let (centroid, values, vectors) = principal_axes(|| wall.iter().map(|&w| points[w]));
    let flat = values[0] <= FLAT_SHARE * (values[0] + values[1] + values[2]);
    flat.then(|| {
        (
            centroid,
            vectors[0],
            (values[0].max(0.0) / wall.len() as f64).sqrt(),
        )
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A closed box of `n` × `n` quads a face (unit cube), each face split into triangles.
    fn cube(n: usize) -> (Vec<DVec3>, Vec<[u32; 3]>) {
        let mut vertices = Vec::new();
        let mut faces = Vec::new();
        let mut index = std::collections::HashMap::new();
        let mut id = |p: [i64; 3], vertices: &mut Vec<DVec3>| {
            *index.entry(p).or_insert_with(|| {
                vertices.push(DVec3::new(p[0] as f64, p[1] as f64, p[2] as f64) / n as f64);
                (vertices.len() - 1) as u32
            })
        };
        let m = n as i64;
        for axis in 0..3 {
            for high in [false, true] {
                let (u, w) = ((axis + 1) % 3, (axis + 2) % 3);
                for i in 0..m {
                    for j in 0..m {
                        let at = |di: i64, dj: i64| {
                            let mut p = [0i64; 3];
                            p[axis] = if high { m } else { 0 };
                            p[u] = i + di;
                            p[w] = j + dj;
                            p
                        };
                        let q =
                            [at(0, 0), at(1, 0), at(1, 1), at(0, 1)].map(|p| id(p, &mut vertices));
                        // counter-clockwise seen from outside
                        let q = if high { q } else { [q[0], q[3], q[2], q[1]] };
                        faces.push([q[0], q[1], q[2]]);
                        faces.push([q[0], q[2], q[3]]);
                    }
                }
            }
        }
        (vertices, faces)
    }

    #[test]
    fn a_staircase_on_an_unsampled_wall_is_laid_flat_and_the_sampled_faces_stay() {
        let n = 12;
        let (mut vertices, faces) = cube(n);
        let step = 0.4 / n as f64;
        // the +x face unsampled, its vertices a staircase of ± 0.2 voxel in x
        let unsampled: Vec<bool> = vertices.iter().map(|p| p.x > 1.0 - 1e-9).collect();
        for (v, p) in vertices.iter_mut().enumerate() {
            if unsampled[v] {
                let row = (p.y * n as f64).round() as i64 + (p.z * n as f64).round() as i64;
                p.x += if row % 2 == 0 {
                    step / 2.0
                } else {
                    -step / 2.0
                };
            }
        }
        let off = |vertices: &[DVec3]| {
            let (sum, count) = vertices
                .iter()
                .zip(&unsampled)
                .filter(|(p, &u)| u && p.y > 0.2 && p.y < 0.8 && p.z > 0.2 && p.z < 0.8)
                .fold((0.0, 0.0), |(s, c), (p, _)| {
                    (s + (p.x - 1.0).powi(2), c + 1.0)
                });
            (sum / count).sqrt()
        };
        let sampled = |vertices: &[DVec3]| -> Vec<DVec3> {
            let kept = vertices.iter().zip(&unsampled).filter(|(_, &u)| !u);
            kept.map(|(p, _)| *p).collect()
        };
        let sampled_before = sampled(&vertices);
        let rms_before = off(&vertices);
        let moved = flatten_unsampled(&mut vertices, &faces, &unsampled);
        let rms_after = off(&vertices);
        assert!(moved > 0);
        assert!(rms_after < 0.2 * rms_before, "{rms_before} -> {rms_after}");
        assert_eq!(sampled_before, sampled(&vertices));
    }

    #[test]
    fn an_unsampled_corner_is_not_planed_off() {
        let n = 12;
        let (mut vertices, faces) = cube(n);
        // every face unsampled: the cube's edges and corners are where two walls meet
        let unsampled = vec![true; vertices.len()];
        let before = vertices.clone();
        flatten_unsampled(&mut vertices, &faces, &unsampled);
        let worst = vertices
            .iter()
            .zip(&before)
            .map(|(a, b)| (*a - *b).length())
            .fold(0.0, f64::max);
        assert!(worst < 1e-12, "a vertex moved by {worst}");
    }
}
