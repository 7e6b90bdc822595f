//! Fewer faces where the surface allows: quadric-error edge collapse (Garland & Heckbert
//! 1997) bounded by a distance to the mesh it started from.
//!
//! Each vertex carries the sum of the quadrics of the planes of the input faces merged
//! into it (area-weighted); an edge collapses to the point that minimises the sum of its
//! ends' quadrics, cheapest first. A collapse is made only when the mesh stays what it
//! was and near where it was:
//! - a closed 2-manifold stays one: the ends' common neighbours are exactly the two
//!   vertices across the edge (the link condition), no face turns over (its normal moves
//!   less than `MAX_TURN`) and none gets an angle under `MIN_SINE`'s (unless it had one);
//! - every input vertex lies within `tolerance` of the new faces: each is kept with the
//!   face nearest it, and the vertices kept by the faces a collapse changes must each find
//!   a new face within `tolerance` (a one-sided Hausdorff bound on the input vertices);
//! - the labels' borders stay: a vertex with faces of two labels, or on an open border,
//!   does not move (an edge from it may collapse onto it).
//!
//! Flat and gently curved parts coarsen until their curvature or noise reaches the
//! tolerance; creases keep their edges (the quadric of two planes pins a vertex to their
//! line, and leaving it costs the tolerance at once).

use crate::budget;
use crate::error::{Error, Result};
use glam::{DMat3, DVec3};
use std::cmp::Ordering;
use std::collections::BinaryHeap;

/// A new face's normal may turn at most this far from its face's before (cosine: 45°):
/// beyond, the collapse folds the mesh or moves the surface more than its distance says.
const MAX_TURN: f64 = std::f64::consts::FRAC_1_SQRT_2;

/// Sine of the smallest angle a new face may have (10°), unless the face had a smaller one
/// before: twice the sliver angle (5°, `criteria::SLIVER_ANGLE_DEG`), so that collapses
/// make no slivers (with 0.2 of the shape quality 4√3 · area / Σ edge², the share of
/// faces under 5° went from 9 % to 23 % on a box merged from six views).
const MIN_SINE: f64 = 0.173_648_177_666_930_3;

/// Weight of an edge's squared length in the order of the collapses, against its
/// quadric error (both per unit area).
const LENGTH_ORDER: f64 = 1e-4;

/// The mesh after [`simplify`].
#[derive(Debug, Clone, Default)]
pub struct Simplified {
    /// Vertices (a subset of the input's, moved), world units.
    pub vertices: Vec<DVec3>,
    /// Triangles, oriented as the input's.
    pub faces: Vec<[u32; 3]>,
    /// Per face, the label of the input face it descends from.
    pub labels: Vec<u8>,
}

/// The symmetric 4 × 4 quadric of squared distances to planes: `x`ᵀ`A``x` + 2`b`·`x` + `c`.
#[derive(Debug, Clone, Copy)]
struct Quadric {
    a: DMat3,
    b: DVec3,
    c: f64,
}

impl Quadric {
    /// No plane (glam's default matrix is the identity, not zero).
    const ZERO: Self = Self {
        a: DMat3::ZERO,
        b: DVec3::ZERO,
        c: 0.0,
    };

    /// `weight` × the squared distance to the plane through `p` with unit normal `n`.
    fn plane(n: DVec3, p: DVec3, weight: f64) -> Self {
        let d = -n.dot(p);
        Self {
            a: DMat3::from_cols(n * n.x, n * n.y, n * n.z) * weight,
            b: n * d * weight,
            c: d * d * weight,
        }
    }

    fn add(&self, o: &Self) -> Self {
        Self {
            a: self.a + o.a,
            b: self.b + o.b,
            c: self.c + o.c,
        }
    }

    fn at(&self, x: DVec3) -> f64 {
        x.dot(self.a * x) + 2.0 * self.b.dot(x) + self.c
    }

    /// The point of least error, if the planes fix one (else `None`).
    fn minimum(&self) -> Option<DVec3> {
        let scale = self.a.x_axis.x + self.a.y_axis.y + self.a.z_axis.z;
        let det = self.a.determinant();
        if scale <= 0.0 || det.abs() <= 1e-9 * scale.powi(3) {
            return None;
        }
        let x = self.a.inverse() * -self.b;
        x.is_finite().then_some(x)
    }
}

/// A proposed collapse of edge (a, b), valid while both ends keep their stamps (its point
/// and error are worked out again when it comes up: a small entry keeps the heap fast).
struct Candidate {
    /// The order: the quadric error plus a little of the edge's squared length (times its
    /// ends' area), so that where the error is nil (a plane) the short edges go first and
    /// the faces grow evenly instead of in fans of slivers.
    cost: f64,
    a: u32,
    b: u32,
    stamps: [u32; 2],
}

/// Where a collapse of an edge puts its surviving vertex.
struct Plan {
    /// The surviving end and the one that goes.
    a: u32,
    b: u32,
    to: DVec3,
    /// The quadric error at `to` (area × squared distance).
    error: f64,
    /// The ends' quadrics' total weight (area).
    weight: f64,
    cost: f64,
}

impl PartialEq for Candidate {
    fn eq(&self, o: &Self) -> bool {
        self.cmp(o) == Ordering::Equal
    }
}
impl Eq for Candidate {}
impl PartialOrd for Candidate {
    fn partial_cmp(&self, o: &Self) -> Option<Ordering> {
        Some(self.cmp(o))
    }
}
impl Ord for Candidate {
    /// Cheapest first in a max-heap; ties by the edge, so the order is the same every run.
    fn cmp(&self, o: &Self) -> Ordering {
        o.cost
            .total_cmp(&self.cost)
            .then_with(|| (o.a, o.b).cmp(&(self.a, self.b)))
    }
}

/// The state of the collapse.
struct Collapse<'a> {
    input: &'a [DVec3],
    position: Vec<DVec3>,
    quadric: Vec<Quadric>,
    /// Per vertex: its live faces.
    fans: Vec<Vec<u32>>,
    /// Per vertex: bumped at each change of its fan or place; `u32::MAX` once collapsed away.
    stamp: Vec<u32>,
    fixed: Vec<bool>,
    faces: Vec<[u32; 3]>,
    alive: Vec<bool>,
    /// Per face: the input vertices it keeps (those nearest it).
    kept: Vec<Vec<u32>>,
    tolerance: f64,
}

/// The mesh (`vertices`, `faces` counter-clockwise, `labels` per face) with edges collapsed
/// while every input vertex stays within `tolerance` (world units) of the result, cheapest
/// quadric error first (see the module comment). A closed 2-manifold stays one, with its
/// genus; faces keep their labels and the labels' borders stay where they were. Unused
/// vertices are dropped. O(E log E · fan²) time, O(V + F) memory.
///
/// Errors: `InvalidParameter` when `tolerance` is negative or not finite, `labels` are not
/// one per face, or a face names a vertex out of range or twice; `OutOfMemory`.
pub fn simplify(
    vertices: &[DVec3],
    faces: &[[u32; 3]],
    labels: &[u8],
    tolerance: f64,
) -> Result<Simplified> {
    check(vertices, faces, labels, tolerance)?;
    let mut state = Collapse::new(vertices, faces, labels, tolerance)?;
    let mut heap = BinaryHeap::new();
    heap.try_reserve(3 * faces.len() / 2)
        .map_err(|_| budget::not_allocated::<Candidate>("the collapses", 3 * faces.len() / 2))?;
    for (f, t) in faces.iter().enumerate() {
        for e in 0..3 {
            let (a, b) = (t[e], t[(e + 1) % 3]);
            // each edge once (from either face when the mesh is open: then twice at most)
            if a < b || !state.has_edge(b, a, f) {
                heap.extend(state.propose(a, b));
            }
        }
    }
    while let Some(c) = heap.pop() {
        // an end changed since (the collapse was proposed again then), or the mean
        // squared distance to the merged planes already exceeds the tolerance's square
        if state.stamp[c.a as usize] != c.stamps[0] || state.stamp[c.b as usize] != c.stamps[1] {
            continue;
        }
        let Some(p) = state.plan(c.a, c.b) else {
            continue;
        };
        if p.error > tolerance * tolerance * p.weight {
            continue;
        }
        if let Some(kept) = state.apply(p.a, p.b, p.to) {
            for n in state.neighbours(kept) {
                heap.extend(state.propose(kept, n));
            }
        }
    }
    Ok(state.finish(labels))
}

fn check(vertices: &[DVec3], faces: &[[u32; 3]], labels: &[u8], tolerance: f64) -> Result<()> {
    if !(tolerance.is_finite() && tolerance >= 0.0) {
        return Err(Error::InvalidParameter {
            name: "tolerance",
            value: format!("{tolerance}"),
            expected: "a finite distance >= 0",
        });
    }
    if labels.len() != faces.len() {
        return Err(Error::InvalidParameter {
            name: "labels",
            value: format!("{} labels for {} faces", labels.len(), faces.len()),
            expected: "one label per face",
        });
    }
    if let Some((f, t)) = faces.iter().enumerate().find(|(_, t)| {
        t.iter().any(|&v| v as usize >= vertices.len())
            || t[0] == t[1]
            || t[1] == t[2]
            || t[0] == t[2]
    }) {
        return Err(Error::InvalidParameter {
            name: "faces",
            value: format!("face {f} is {t:?} with {} vertices", vertices.len()),
            expected: "three distinct vertex indices in range per face",
        });
    }
    Ok(())
}

impl<'a> Collapse<'a> {
    fn new(vertices: &'a [DVec3], faces: &[[u32; 3]], labels: &[u8], tol: f64) -> Result<Self> {
        let n = vertices.len();
        let mut quadric = budget::try_filled("the vertices' quadrics", Quadric::ZERO, n)?;
        let mut fans: Vec<Vec<u32>> = budget::try_filled("the vertices' fans", Vec::new(), n)?;
        let mut kept: Vec<Vec<u32>> =
            budget::try_filled("the faces' vertices", Vec::new(), faces.len())?;
        let mut placed = budget::try_filled("the vertices' faces", false, n)?;
        for (f, t) in faces.iter().enumerate() {
            let p = t.map(|v| vertices[v as usize]);
            let cross = (p[1] - p[0]).cross(p[2] - p[0]);
            if let Some(normal) = cross.try_normalize() {
                let q = Quadric::plane(normal, p[0], 0.5 * cross.length());
                for &v in t {
                    quadric[v as usize] = quadric[v as usize].add(&q);
                }
            }
            for &v in t {
                fans[v as usize].push(f as u32);
                if !placed[v as usize] {
                    placed[v as usize] = true;
                    kept[f].push(v);
                }
            }
        }
        let mut fixed = budget::try_filled("the fixed vertices", false, n)?;
        for (v, fan) in fans.iter().enumerate() {
            let mut ends: Vec<u32> = Vec::with_capacity(2 * fan.len());
            for &f in fan {
                let t = faces[f as usize];
                let k = t.iter().position(|&x| x as usize == v).expect("in its fan");
                ends.push(t[(k + 1) % 3]);
                ends.push(t[(k + 2) % 3]);
            }
            // closed around v: every neighbour is met twice, once as each kind of end
            let mut outgoing: Vec<u32> = ends.iter().step_by(2).copied().collect();
            let mut incoming: Vec<u32> = ends.iter().skip(1).step_by(2).copied().collect();
            outgoing.sort_unstable();
            incoming.sort_unstable();
            let first = fan.first().map(|&f| labels[f as usize]);
            fixed[v] = fan.is_empty()
                || outgoing != incoming
                || outgoing.windows(2).any(|w| w[0] == w[1])
                || fan.iter().any(|&f| Some(labels[f as usize]) != first);
        }
        Ok(Self {
            input: vertices,
            position: budget::try_collect("the vertices", vertices.iter().copied())?,
            quadric,
            fans,
            stamp: budget::try_filled("the vertices' stamps", 0, n)?,
            fixed,
            faces: budget::try_collect("the faces", faces.iter().copied())?,
            alive: budget::try_filled("the live faces", true, faces.len())?,
            kept,
            tolerance: tol,
        })
    }

    /// Whether a live face other than `f` holds the directed edge (a, b).
    fn has_edge(&self, a: u32, b: u32, f: usize) -> bool {
        self.fans[a as usize].iter().any(|&g| {
            let t = self.faces[g as usize];
            g as usize != f && (0..3).any(|e| t[e] == a && t[(e + 1) % 3] == b)
        })
    }

    /// The vertices sharing an edge with `v`.
    fn neighbours(&self, v: u32) -> Vec<u32> {
        let mut out: Vec<u32> = self.fans[v as usize]
            .iter()
            .flat_map(|&f| self.faces[f as usize])
            .filter(|&x| x != v)
            .collect();
        out.sort_unstable();
        out.dedup();
        out
    }

    /// The collapse of edge (a, b) to its best point, if an end may move.
    fn propose(&self, a: u32, b: u32) -> Option<Candidate> {
        let p = self.plan(a, b)?;
        Some(Candidate {
            cost: p.cost,
            a: p.a,
            b: p.b,
            stamps: [self.stamp[p.a as usize], self.stamp[p.b as usize]],
        })
    }

    /// The collapse of edge (a, b): its point, error and order.
    fn plan(&self, a: u32, b: u32) -> Option<Plan> {
        let (fa, fb) = (self.fixed[a as usize], self.fixed[b as usize]);
        let q = self.quadric[a as usize].add(&self.quadric[b as usize]);
        let (pa, pb) = (self.position[a as usize], self.position[b as usize]);
        let to = match (fa, fb) {
            (true, true) => return None,
            (true, false) => pa,
            (false, true) => pb,
            // the quadric's minimum unless the planes fix it poorly (nearly parallel: it
            // runs off along the surface)
            (false, false) => q
                .minimum()
                .filter(|x| x.distance(0.5 * (pa + pb)) <= pa.distance(pb))
                .unwrap_or_else(|| {
                    let mid = 0.5 * (pa + pb);
                    [pa, pb, mid]
                        .into_iter()
                        .min_by(|x, y| q.at(*x).total_cmp(&q.at(*y)))
                        .unwrap_or(mid)
                }),
        };
        // the surviving end: a fixed one, else the lower index
        let (a, b) = if fb && !fa { (b, a) } else { (a, b) };
        let error = q.at(to).max(0.0);
        let weight = q.a.x_axis.x + q.a.y_axis.y + q.a.z_axis.z;
        Some(Plan {
            a,
            b,
            to,
            error,
            weight,
            cost: error + LENGTH_ORDER * weight * pa.distance_squared(pb),
        })
    }

    /// Collapses b into a at `to` if every condition of the module comment holds; returns
    /// the surviving vertex.
    fn apply(&mut self, a: u32, b: u32, to: DVec3) -> Option<u32> {
        let (fan_a, fan_b) = (&self.fans[a as usize], &self.fans[b as usize]);
        let shared: Vec<u32> = fan_a
            .iter()
            .copied()
            .filter(|f| fan_b.contains(f))
            .collect();
        if shared.len() != 2 {
            return None; // an open border's edge or a non-manifold one: left
        }
        // link condition: the common neighbours are the two opposite vertices
        let opposite: Vec<u32> = shared
            .iter()
            .map(|&f| {
                let t = self.faces[f as usize];
                t[0] ^ t[1] ^ t[2] ^ a ^ b
            })
            .collect();
        let (na, nb) = (self.neighbours(a), self.neighbours(b));
        let common = na.iter().filter(|v| nb.binary_search(v).is_ok()).count();
        if common != 2 || opposite[0] == opposite[1] || na.len() + nb.len() <= 6 {
            return None;
        }
        // the faces that stay, with b replaced by a, at the new point
        let moved: Vec<u32> = fan_a
            .iter()
            .chain(fan_b)
            .copied()
            .filter(|f| !shared.contains(f))
            .collect();
        let at = |v: u32| {
            if v == a || v == b {
                to
            } else {
                self.position[v as usize]
            }
        };
        let mut new_faces: Vec<(u32, [DVec3; 3])> = Vec::with_capacity(moved.len());
        for &f in &moved {
            let t = self.faces[f as usize];
            let old = t.map(|v| self.position[v as usize]);
            let new = t.map(at);
            let (n_old, n_new) = (normal(&old), normal(&new));
            let (Some(n_old), Some(n_new)) = (n_old, n_new) else {
                return None;
            };
            if n_old.dot(n_new) < MAX_TURN
                || smallest_sine(&new) < MIN_SINE.min(smallest_sine(&old))
            {
                return None;
            }
            new_faces.push((f, new));
        }
        // every input vertex kept by a face that changes or goes finds a new face near
        let mut assigned: Vec<(u32, u32)> = Vec::new();
        for &f in moved.iter().chain(&shared) {
            for &v in &self.kept[f as usize] {
                let p = self.input[v as usize];
                let (best, d) = new_faces
                    .iter()
                    .map(|(g, t)| (*g, distance_to_triangle(p, t)))
                    .min_by(|x, y| x.1.total_cmp(&y.1))?;
                if d > self.tolerance {
                    return None;
                }
                assigned.push((best, v));
            }
        }
        // made: b goes, a moves
        for &f in moved.iter().chain(&shared) {
            self.kept[f as usize].clear();
        }
        for (f, v) in assigned {
            self.kept[f as usize].push(v);
        }
        for &f in &shared {
            self.alive[f as usize] = false;
            for v in self.faces[f as usize] {
                self.fans[v as usize].retain(|&g| g != f);
            }
        }
        let from_b = std::mem::take(&mut self.fans[b as usize]);
        for &f in &from_b {
            for v in self.faces[f as usize].iter_mut() {
                if *v == b {
                    *v = a;
                }
            }
        }
        self.fans[a as usize].extend(from_b);
        self.quadric[a as usize] = self.quadric[a as usize].add(&self.quadric[b as usize]);
        self.position[a as usize] = to;
        self.stamp[a as usize] += 1;
        self.stamp[b as usize] = u32::MAX;
        Some(a)
    }

    /// The live faces and the vertices they use, renumbered in their first use's order.
    fn finish(self, labels: &[u8]) -> Simplified {
        let mut index = vec![u32::MAX; self.position.len()];
        let mut out = Simplified::default();
        for (f, t) in self.faces.iter().enumerate() {
            if !self.alive[f] {
                continue;
            }
            let t = t.map(|v| {
                if index[v as usize] == u32::MAX {
                    index[v as usize] = out.vertices.len() as u32;
                    out.vertices.push(self.position[v as usize]);
                }
                index[v as usize]
            });
            out.faces.push(t);
            out.labels.push(labels[f]);
        }
        out
    }
}

fn normal(t: &[DVec3; 3]) -> Option<DVec3> {
    (t[1] - t[0]).cross(t[2] - t[0]).try_normalize()
}

/// Sine of the triangle's smallest angle (0 for a flat one): twice its area over the
/// product of its two longest edges.
fn smallest_sine(t: &[DVec3; 3]) -> f64 {
    let area2 = (t[1] - t[0]).cross(t[2] - t[0]).length();
    let mut edges = [
        (t[1] - t[0]).length(),
        (t[2] - t[1]).length(),
        (t[0] - t[2]).length(),
    ];
    edges.sort_unstable_by(f64::total_cmp);
    let longest = edges[1] * edges[2];
    if longest > 0.0 {
        area2 / longest
    } else {
        0.0
    }
}

/// Distance from `p` to triangle `t` (Ericson, Real-Time Collision Detection, 5.1.5).
fn distance_to_triangle(p: DVec3, t: &[DVec3; 3]) -> f64 {
    let [a, b, c] = *t;
    let (ab, ac, ap) = (b - a, c - a, p - a);
    let (d1, d2) = (ab.dot(ap), ac.dot(ap));
    if d1 <= 0.0 && d2 <= 0.0 {
        return ap.length();
    }
    let bp = p - b;
    let (d3, d4) = (ab.dot(bp), ac.dot(bp));
    if d3 >= 0.0 && d4 <= d3 {
        return bp.length();
    }
    let vc = d1 * d4 - d3 * d2;
    if vc <= 0.0 && d1 >= 0.0 && d3 <= 0.0 {
        return (p - (a + ab * (d1 / (d1 - d3)))).length();
    }
    let cp = p - c;
    let (d5, d6) = (ab.dot(cp), ac.dot(cp));
    if d6 >= 0.0 && d5 <= d6 {
        return cp.length();
    }
    let vb = d5 * d2 - d1 * d6;
    if vb <= 0.0 && d2 >= 0.0 && d6 <= 0.0 {
        return (p - (a + ac * (d2 / (d2 - d6)))).length();
    }
    let va = d3 * d6 - d5 * d4;
    if va <= 0.0 && (d4 - d3) >= 0.0 && (d5 - d6) >= 0.0 {
        return (p - (b + (c - b) * ((d4 - d3) / ((d4 - d3) + (d5 - d6))))).length();
    }
    let denom = 1.0 / (va + vb + vc);
    (p - (a + ab * (vb * denom) + ac * (vc * denom))).length()
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::collections::HashMap;

    /// The surface of the cube [0, n]³ as a grid of unit squares split in two, closed.
    fn cube(n: usize) -> (Vec<DVec3>, Vec<[u32; 3]>) {
        let mut vertices = Vec::new();
        let mut index: HashMap<[i64; 3], u32> = HashMap::new();
        let mut id = |p: [i64; 3], vertices: &mut Vec<DVec3>| {
            *index.entry(p).or_insert_with(|| {
                vertices.push(DVec3::new(p[0] as f64, p[1] as f64, p[2] as f64));
                (vertices.len() - 1) as u32
            })
        };
        let mut faces = Vec::new();
        let n = n as i64;
        for axis in 0..3 {
            let (u, v) = ((axis + 1) % 3, (axis + 2) % 3);
            for side in [0, n] {
                for i in 0..n {
                    for j in 0..n {
                        let at = |di: i64, dj: i64| {
                            let mut p = [0; 3];
                            p[axis] = side;
                            p[u] = i + di;
                            p[v] = j + dj;
                            p
                        };
                        let q =
                            [at(0, 0), at(1, 0), at(1, 1), at(0, 1)].map(|p| id(p, &mut vertices));
                        // u × v is +axis: counter-clockwise from outside on the far side
                        let q = if side == n {
                            q
                        } else {
                            [q[3], q[2], q[1], q[0]]
                        };
                        faces.push([q[0], q[1], q[2]]);
                        faces.push([q[0], q[2], q[3]]);
                    }
                }
            }
        }
        (vertices, faces)
    }

    /// Every edge in two faces, once each way; V − E + F.
    fn euler(vertices: usize, faces: &[[u32; 3]]) -> i64 {
        let mut edges: HashMap<(u32, u32), u32> = HashMap::new();
        for t in faces {
            for e in 0..3 {
                *edges.entry((t[e], t[(e + 1) % 3])).or_default() += 1;
            }
        }
        for (&(a, b), &n) in &edges {
            assert_eq!(n, 1, "edge {a}-{b} used {n} times one way");
            assert_eq!(edges.get(&(b, a)), Some(&1), "edge {a}-{b} has no twin");
        }
        vertices as i64 - (edges.len() / 2) as i64 + faces.len() as i64
    }

    fn farthest(points: &[DVec3], out: &Simplified) -> f64 {
        points
            .iter()
            .map(|&p| {
                out.faces
                    .iter()
                    .map(|t| distance_to_triangle(p, &t.map(|v| out.vertices[v as usize])))
                    .fold(f64::INFINITY, f64::min)
            })
            .fold(0.0, f64::max)
    }

    #[test]
    fn a_cube_of_small_squares_keeps_its_corners_and_loses_most_faces() {
        let (vertices, faces) = cube(8);
        let out = simplify(&vertices, &faces, &vec![0; faces.len()], 0.01).unwrap();
        assert_eq!(euler(out.vertices.len(), &out.faces), 2);
        assert!(
            out.faces.len() * 10 < faces.len(),
            "{} faces",
            out.faces.len()
        );
        assert!(farthest(&vertices, &out) <= 0.01);
        for corner in [DVec3::ZERO, DVec3::splat(8.0), DVec3::new(8.0, 0.0, 8.0)] {
            assert!(out.vertices.iter().any(|v| v.distance(corner) < 1e-9));
        }
    }

    #[test]
    fn a_curved_surface_stays_within_the_tolerance() {
        // the cube pushed out onto a sphere of radius 4 around its centre
        let (mut vertices, faces) = cube(10);
        let centre = DVec3::splat(5.0);
        for v in &mut vertices {
            *v = centre + (*v - centre).normalize() * 4.0;
        }
        let labels = vec![0; faces.len()];
        let tight = simplify(&vertices, &faces, &labels, 0.02).unwrap();
        let loose = simplify(&vertices, &faces, &labels, 0.1).unwrap();
        for (out, tol) in [(&tight, 0.02), (&loose, 0.1)] {
            assert_eq!(euler(out.vertices.len(), &out.faces), 2);
            assert!(farthest(&vertices, out) <= tol);
        }
        assert!(loose.faces.len() < tight.faces.len());
        assert!(tight.faces.len() < faces.len());
    }

    #[test]
    fn the_labels_borders_stay_where_they_were() {
        let (vertices, faces) = cube(8);
        // the top face (z = 8) another label: its rim stays a closed line of edges
        let labels: Vec<u8> = faces
            .iter()
            .map(|t| u8::from(t.iter().all(|&v| vertices[v as usize].z == 8.0)))
            .collect();
        let out = simplify(&vertices, &faces, &labels, 0.01).unwrap();
        assert_eq!(euler(out.vertices.len(), &out.faces), 2);
        let rim: Vec<DVec3> = vertices
            .iter()
            .copied()
            .filter(|v| v.z == 8.0 && (v.x % 8.0 == 0.0 || v.y % 8.0 == 0.0))
            .collect();
        for p in &rim {
            assert!(
                out.vertices.iter().any(|v| v.distance(*p) < 1e-12),
                "{p:?} moved"
            );
        }
        for (t, &l) in out.faces.iter().zip(&out.labels) {
            let top = t.iter().all(|&v| out.vertices[v as usize].z == 8.0);
            assert_eq!(l == 1, top, "{t:?}");
        }
    }

    #[test]
    fn a_zero_tolerance_collapses_nothing_off_the_surface_and_bad_input_is_refused() {
        let (mut vertices, faces) = cube(4);
        vertices[0] += DVec3::new(0.1, 0.2, -0.3); // a dent: no flat neighbourhood there
        let labels = vec![0; faces.len()];
        let out = simplify(&vertices, &faces, &labels, 0.0).unwrap();
        assert!(farthest(&vertices, &out) <= 1e-12);
        assert!(simplify(&vertices, &faces, &labels, -1.0).is_err());
        assert!(simplify(&vertices, &faces, &labels, f64::NAN).is_err());
        assert!(simplify(&vertices, &faces, &labels[1..], 0.1).is_err());
        assert!(simplify(&vertices, &[[0, 0, 1]], &[0], 0.1).is_err());
        assert!(simplify(&vertices, &[[0, 1, 999]], &[0], 0.1).is_err());
    }
}
