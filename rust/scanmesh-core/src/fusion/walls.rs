//! Never-sampled walls laid flat, and their rims squared. A vertex that no sample placed
//! sits at the mean of its cell's crossings, each found on the rays and so known only to
//! the nearest ray (± half a spacing): a plane wall at a slant to the rows of rays comes out
//! as a staircase. Each such vertex is moved onto the least-squares plane of the unsampled
//! vertices around it on the same wall, where they are flat: the staircase averages out
//! across the rows, while a wall running along a row of rays, whose offset no ray can tell,
//! keeps it. Where such a wall meets a sampled face, the face's last vertex sat at the mean
//! of its cell's crossings too, a bevel about a voxel wide; it is moved along the face
//! halfway onto the wall's plane: two estimates of where the face ends, each to the rays'
//! spacing, whose mean is better than either.

use crate::projection::principal_axes;
use glam::DVec3;

/// Rings of mesh neighbours whose unsampled vertices make a vertex's plane: 3 voxels each
/// way, several steps of a staircase 10° off the rows; 3 laid the fandisk's never-sampled
/// wall closer than 2 (docs/benchmarks/merge.md, "Figures behind the core's constants").
const RINGS: usize = 3;

/// Neighbours on the same wall: vertex normals within this cosine (14°). The wall across a
/// corner or the floor below a rim is another plane, and a corner cell's vertex, the mean of
/// its crossings on two walls, leans towards the other: at 0.9 such vertices tilted the
/// planes of a box's exact walls (`extract`'s tests) and moved the blade's root face off
/// (figures in docs/benchmarks/merge.md).
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

/// How samples placed a mesh vertex (`extract`).
#[derive(Clone, Copy, Debug, PartialEq)]
pub(super) enum Placed {
    /// No sample near: the mean of its cell's crossings.
    Unsampled,
    /// On the samples of one smooth surface, whose mean unit normal this is: they fix the
    /// vertex across that surface only.
    Smooth(DVec3),
    /// On samples whose normals differ (a crease): they fix it.
    Crease,
}

/// A rim vertex (smooth, sampled, beside a never-sampled wall) is moved along its samples'
/// plane this share of the way to the wall's plane: halfway balanced the parts best of the
/// shares tried on benches/merge.py's parts (figures in docs/benchmarks/merge.md); all the
/// way, the wall's offset along a row of rays (up to half a spacing) becomes the face's.
const RIM_SHARE: f64 = 0.5;

/// A rim vertex is moved only where the wall's plane is at most this many voxels away
/// along its samples' plane: its own cell and the next.
const RIM_REACH: f64 = 1.0;

/// Rings around a rim vertex whose unsampled vertices make its wall's plane: fewer than
/// the wall's own [`RINGS`], as they are not limited to one wall's normals: with 3, a
/// curved wall's chord moved the conrod's rims from fourteen views and the blade's from six
/// (figures in docs/benchmarks/merge.md).
const RIM_RINGS: usize = 2;

/// The wall's plane must be at least 30° (this cosine) from the samples' for a rim vertex to
/// be moved: a never-sampled patch of a smooth surface is no wall.
const RIM_ANGLE: f64 = 0.866;

/// Vertex adjacency of a closed 2-manifold (each directed edge once, so each neighbour
/// comes once), in compressed rows.
struct Rings {
    start: Vec<usize>,
    neighbours: Vec<u32>,
}

impl Rings {
    /// O(faces).
    fn new(n: usize, faces: &[[u32; 3]]) -> Self {
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
        for t in faces {
            for e in 0..3 {
                let a = t[e] as usize;
                neighbours[fill[a]] = t[(e + 1) % 3];
                fill[a] += 1;
            }
        }
        Rings { start, neighbours }
    }

    /// The neighbours of `v`.
    fn of(&self, v: usize) -> &[u32] {
        &self.neighbours[self.start[v]..self.start[v + 1]]
    }
}

/// Scratch for breadth-first walks over [`Rings`], allocated once per call of
/// [`flatten_unsampled`] rather than once per vertex.
struct Walk {
    /// The centre of the walk that last reached each vertex (`usize::MAX`: none).
    seen: Vec<usize>,
    ring: Vec<usize>,
    next: Vec<usize>,
}

impl Walk {
    fn new(n: usize) -> Self {
        Walk {
            seen: vec![usize::MAX; n],
            ring: Vec::new(),
            next: Vec::new(),
        }
    }

    /// The vertices within `depth` edges of `v` (not `v`) that `keep`, into `out`.
    /// O(vertices within the rings).
    fn around(
        &mut self,
        rings: &Rings,
        v: usize,
        depth: usize,
        out: &mut Vec<usize>,
        keep: impl Fn(usize) -> bool,
    ) {
        out.clear();
        self.seen[v] = v;
        self.ring.clear();
        self.ring.push(v);
        for _ in 0..depth {
            self.next.clear();
            for &r in &self.ring {
                for &w in rings.of(r) {
                    let w = w as usize;
                    if self.seen[w] != v {
                        self.seen[w] = v;
                        self.next.push(w);
                        if keep(w) {
                            out.push(w);
                        }
                    }
                }
            }
            std::mem::swap(&mut self.ring, &mut self.next);
        }
    }
}

/// Area-weighted unit vertex normals. O(faces).
fn vertex_normals(vertices: &[DVec3], faces: &[[u32; 3]]) -> Vec<DVec3> {
    let mut normal = vec![DVec3::ZERO; vertices.len()];
    for t in faces {
        let p = t.map(|i| vertices[i as usize]);
        let area_normal = (p[1] - p[0]).cross(p[2] - p[0]);
        for &a in t {
            normal[a as usize] += area_normal;
        }
    }
    normal.iter().map(|m| m.normalize_or_zero()).collect()
}

/// Lays the never-sampled walls flat, then squares their rims. Each vertex `placed`
/// [`Placed::Unsampled`] is moved onto the plane of the unsampled vertices within [`RINGS`]
/// edges of it that face its way, where they are flat (planes fitted to the positions
/// before any moves: one Jacobi-style pass). Then each [`Placed::Smooth`] vertex with an
/// unsampled neighbour is moved along its samples' plane [`RIM_SHARE`] of the way onto the
/// plane of the unsampled vertices within [`RIM_RINGS`] edges that face at least 30° away
/// from it, where that is at most [`RIM_REACH`] voxels (`voxel`, world units) away. `faces`
/// must make a closed 2-manifold. Returns the vertices moved.
/// O(faces + (unsampled vertices + rim vertices) · vertices within the rings).
pub(super) fn flatten_unsampled(
    vertices: &mut [DVec3],
    faces: &[[u32; 3]],
    placed: &[Placed],
    voxel: f64,
) -> usize {
    let unsampled = |v: usize| placed[v] == Placed::Unsampled;
    if !(0..vertices.len()).any(unsampled) {
        return 0;
    }
    let n = vertices.len();
    let rings = Rings::new(n, faces);
    let mut walk = Walk::new(n);
    let mut wall = Vec::new();
    let mut moved = 0;

    let normal = vertex_normals(vertices, faces);
    let before = vertices.to_vec();
    for v in (0..n).filter(|&v| unsampled(v)) {
        walk.around(&rings, v, RINGS, &mut wall, |w| {
            unsampled(w) && normal[w].dot(normal[v]) > SAME_WALL
        });
        wall.push(v);
        if let Some((centroid, axis)) = trimmed_plane(&before, &mut wall) {
            vertices[v] = before[v] - axis * (before[v] - centroid).dot(axis);
            moved += 1;
        }
    }

    let normal = vertex_normals(vertices, faces);
    // a walk's marks are its centre: the rims (sampled) were no centre of the first pass
    let flat = vertices.to_vec();
    for v in 0..n {
        let Placed::Smooth(m) = placed[v] else {
            continue;
        };
        if !rings.of(v).iter().any(|&w| unsampled(w as usize)) {
            continue;
        }
        // the unsampled vertices that face away from the samples: the wall's
        walk.around(&rings, v, RIM_RINGS, &mut wall, |w| {
            unsampled(w) && normal[w].dot(m).abs() < RIM_ANGLE
        });
        let Some((centroid, axis)) = trimmed_plane(&flat, &mut wall) else {
            continue;
        };
        let cos = axis.dot(m);
        if cos.abs() >= RIM_ANGLE {
            continue;
        }
        // the shortest step within the samples' plane (normal m) onto the wall's
        let along = axis - m * cos;
        let step = -along * (flat[v] - centroid).dot(axis) / along.length_squared();
        if step.length() <= RIM_REACH * voxel {
            vertices[v] = flat[v] + RIM_SHARE * step;
            moved += 1;
        }
    }
    moved
}

/// The plane of `points[wall]` fitted twice, the second time without the points beyond
/// [`TRIM`] times the first fit's RMS distance (a vertex of a corner cell, the mean of its
/// crossings on two walls, would tilt it): centroid and unit normal, where both fits have
/// [`MIN_VERTICES`] and are flat. O(wall).
fn trimmed_plane(points: &[DVec3], wall: &mut Vec<usize>) -> Option<(DVec3, DVec3)> {
    if wall.len() < MIN_VERTICES {
        return None;
    }
    let (centroid, axis, spread) = plane(points, wall)?;
    wall.retain(|&w| (points[w] - centroid).dot(axis).abs() <= TRIM * spread);
    if wall.len() < MIN_VERTICES {
        return None;
    }
    let (centroid, axis, _) = plane(points, wall)?;
    Some((centroid, axis))
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

    /// Unsampled where `unsampled`, else fixed by samples.
    fn placements(unsampled: &[bool]) -> Vec<Placed> {
        let how = |&u: &bool| if u { Placed::Unsampled } else { Placed::Crease };
        unsampled.iter().map(how).collect()
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
        let placed = placements(&unsampled);
        let moved = flatten_unsampled(&mut vertices, &faces, &placed, 1.0 / n as f64);
        let rms_after = off(&vertices);
        assert!(moved > 0);
        assert!(rms_after < 0.2 * rms_before, "{rms_before} -> {rms_after}");
        assert_eq!(sampled_before, sampled(&vertices));
    }

    #[test]
    fn a_sampled_face_is_taken_halfway_along_itself_onto_its_never_sampled_wall() {
        let n = 12;
        let voxel = 1.0 / n as f64;
        let (mut vertices, faces) = cube(n);
        let top = |p: &DVec3| p.z > 1.0 - 1e-9;
        let wall = |p: &DVec3| p.x > 1.0 - 1e-9;
        // the top sampled, the +x side never: the top's last row of vertices a bevel 0.4
        // voxel short of the side
        let placed: Vec<Placed> = vertices
            .iter()
            .map(|p| match (top(p), wall(p)) {
                (true, _) => Placed::Smooth(DVec3::Z),
                (false, true) => Placed::Unsampled,
                _ => Placed::Crease,
            })
            .collect();
        let rim: Vec<usize> = (0..vertices.len())
            .filter(|&v| top(&vertices[v]) && wall(&vertices[v]))
            .filter(|&v| vertices[v].y > 0.2 && vertices[v].y < 0.8)
            .collect();
        for &v in &rim {
            vertices[v].x -= 0.4 * voxel;
        }
        let before = vertices.clone();
        flatten_unsampled(&mut vertices, &faces, &placed, voxel);
        for &v in &rim {
            let short = (1.0 - vertices[v].x) / voxel;
            assert!(
                (short - 0.2).abs() < 0.03,
                "rim vertex {v} {short} voxel short"
            );
            assert!(
                (vertices[v].z - 1.0).abs() < 1e-12,
                "left the top: {}",
                vertices[v]
            );
        }
        // the top's vertices away from the side stay
        for v in (0..vertices.len()).filter(|&v| top(&before[v]) && before[v].x < 0.7) {
            assert_eq!(vertices[v], before[v]);
        }
    }

    #[test]
    fn an_unsampled_corner_is_not_planed_off() {
        let n = 12;
        let (mut vertices, faces) = cube(n);
        // every face unsampled: the cube's edges and corners are where two walls meet
        let unsampled = vec![true; vertices.len()];
        let before = vertices.clone();
        flatten_unsampled(
            &mut vertices,
            &faces,
            &placements(&unsampled),
            1.0 / n as f64,
        );
        let worst = vertices
            .iter()
            .zip(&before)
            .map(|(a, b)| (*a - *b).length())
            .fold(0.0, f64::max);
        assert!(worst < 1e-12, "a vertex moved by {worst}");
    }
}
