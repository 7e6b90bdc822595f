//! Edge flips that make the extracted mesh follow its samples (data-dependent triangulation).
//!
//! Dual contouring joins the cells' vertices by quads whose split is a guess: where a crease
//! crosses the grid at a slant, the vertices lie on the crease but an edge between them is
//! missing, and triangles straddle it with a normal between the two faces'. An edge (a, b)
//! of triangles (a, b, c), (b, a, d) is flipped to (c, d) when the samples over the quad
//! a-d-b-c lie closer to the two new triangles than to the old ones (sum of squared
//! distances to the plane of the triangle above each sample). A flip keeps the mesh closed
//! and 2-manifold: it is refused when (c, d) is already an edge, when the quad is not convex
//! seen along its mean normal (a fold), across a change of label, or when c and d are more
//! than one cell apart (edges stay short and the samples gathered cover the quad).

use super::samples::SampleIndex;
use crate::budget;
use crate::error::Result;
use crate::progress::Share;
use glam::DVec3;
use rayon::prelude::*;
use std::collections::HashMap;

/// Passes over the edges at most (a pass that flips nothing ends the loop sooner).
pub(super) const MAX_PASSES: usize = 4;

/// A flip must lower the samples' squared distances by this share at least: flat parts,
/// where both splits fit equally up to the noise, keep the first.
const MARGIN: f64 = 0.2;

/// Samples over the quad needed to judge it.
const MIN_SAMPLES: usize = 1;

/// A triangle of a flip must face within this cosine of the quad's mean normal (80°).
const MIN_FACING: f64 = 0.17;

/// Flips the edges of the closed mesh (`vertices`, `faces`) towards the samples; `cells`
/// holds each vertex's cell (grid coordinates), `labels` the faces' labels. Returns the
/// flips made; counts each pass in `passes` (of `MAX_PASSES`). O(passes · faces · samples
/// per cell neighbourhood).
///
/// Errors: `OutOfMemory` when the edges' map does not fit.
#[allow(clippy::too_many_arguments)] // the mesh, the samples and the progress: no struct holds them
pub(super) fn follow_samples(
    vertices: &[DVec3],
    cells: &[[usize; 3]],
    faces: &mut [[u32; 3]],
    labels: &[u8],
    near: &SampleIndex,
    samples: &[DVec3],
    normals: &[DVec3],
    passes: &Share<'_>,
) -> Result<usize> {
    let mut owner: HashMap<(u32, u32), u32> = HashMap::new();
    owner.try_reserve(faces.len() * 3).map_err(|_| {
        budget::not_allocated::<((u32, u32), u32)>("the fused mesh's edges", faces.len() * 3)
    })?;
    for (f, t) in faces.iter().enumerate() {
        for e in 0..3 {
            owner.insert((t[e], t[(e + 1) % 3]), f as u32);
        }
    }
    let mut flips = 0;
    let mut touched: Vec<bool> = budget::try_filled("the fused mesh's faces", false, faces.len())?;
    // the faces whose edges a pass judges: all at first, then those a flip changed and their
    // neighbours (an edge whose two faces stayed keeps its quad, and so its verdict)
    let mut judge: Vec<bool> = budget::try_filled("the fused mesh's faces", true, faces.len())?;
    for _ in 0..MAX_PASSES {
        passes.add(1); // counted as it starts: one hook, wherever the pass's work is done
                       // judged on every core against the mesh as the pass found it, then made one by one;
                       // a flip whose faces an earlier flip of the pass changed waits for the next pass
        let judged: Vec<bool> = budget::try_par_collect(
            "the fused mesh's flips",
            (0..3 * faces.len()).into_par_iter().map_init(
                Vec::new,
                |gathered: &mut Vec<usize>, k| {
                    if !judge[k / 3] {
                        return false;
                    }
                    let Some((_, [a, b, c, d])) = quad(faces, &owner, labels, cells, k / 3, k % 3)
                    else {
                        return false;
                    };
                    gathered.clear();
                    for v in [a, b] {
                        gathered.extend(near.around(cells[v as usize]));
                    }
                    gathered.sort_unstable();
                    gathered.dedup();
                    let p = [a, b, c, d].map(|v| vertices[v as usize]);
                    better(p, gathered, samples, normals)
                },
            ),
        )?;
        touched.iter_mut().for_each(|t| *t = false);
        let before = flips;
        for k in (0..judged.len()).filter(|&k| judged[k]) {
            let (f, e) = (k / 3, k % 3);
            if touched[f] {
                continue;
            }
            let Some((g, [a, b, c, d])) = quad(faces, &owner, labels, cells, f, e) else {
                continue;
            };
            if touched[g] {
                continue;
            }
            for (x, y) in [(a, b), (b, c), (c, a), (b, a), (a, d), (d, b)] {
                owner.remove(&(x, y));
            }
            faces[f] = [a, d, c];
            faces[g] = [b, c, d];
            for (x, y, h) in [
                (a, d, f),
                (d, c, f),
                (c, a, f),
                (b, c, g),
                (c, d, g),
                (d, b, g),
            ] {
                owner.insert((x, y), h as u32);
            }
            (touched[f], touched[g]) = (true, true);
            flips += 1;
        }
        if flips == before {
            break;
        }
        judge.copy_from_slice(&touched);
        for f in (0..faces.len()).filter(|&f| touched[f]) {
            let t = faces[f];
            for e in 0..3 {
                if let Some(&g) = owner.get(&(t[(e + 1) % 3], t[e])) {
                    judge[g as usize] = true;
                }
            }
        }
    }
    Ok(flips)
}

/// The quad of edge `e` of face `f` that a flip may turn: the other face `g` and the
/// vertices (a, b) of the edge, c of `f` and d of `g` across it; `None` where the edge is
/// judged from its other face, or a flip would break the mesh (see the module comment).
fn quad(
    faces: &[[u32; 3]],
    owner: &HashMap<(u32, u32), u32>,
    labels: &[u8],
    cells: &[[usize; 3]],
    f: usize,
    e: usize,
) -> Option<(usize, [u32; 4])> {
    let t = faces[f];
    let (a, b, c) = (t[e], t[(e + 1) % 3], t[(e + 2) % 3]);
    if a > b {
        return None; // each edge once, from the face where it runs upwards
    }
    let g = *owner.get(&(b, a))? as usize;
    let u = faces[g];
    let d = u[0] ^ u[1] ^ u[2] ^ a ^ b;
    if labels[f] != labels[g]
        || c == d
        || owner.contains_key(&(c, d))
        || owner.contains_key(&(d, c))
    {
        return None;
    }
    let (cc, cd) = (cells[c as usize], cells[d as usize]);
    if (0..3).any(|k| cc[k].abs_diff(cd[k]) > 1) {
        return None;
    }
    Some((g, [a, b, c, d]))
}

/// Whether triangles (a, d, c), (b, c, d) fit the samples better than (a, b, c), (b, a, d);
/// `p` holds a, b, c, d.
fn better(p: [DVec3; 4], gathered: &[usize], samples: &[DVec3], normals: &[DVec3]) -> bool {
    let [a, b, c, d] = p;
    let old = [[a, b, c], [b, a, d]];
    let new = [[a, d, c], [b, c, d]];
    // the quad's mean normal: the same for both splits (the outline a-d-b-c's vector area)
    let axis = (d - a).cross(b - a) + (b - a).cross(c - a);
    let Some(axis) = axis.try_normalize() else {
        return false;
    };
    let unit = |t: &[DVec3; 3]| (t[1] - t[0]).cross(t[2] - t[0]).try_normalize();
    let (Some(o0), Some(o1), Some(n0), Some(n1)) =
        (unit(&old[0]), unit(&old[1]), unit(&new[0]), unit(&new[1]))
    else {
        return false;
    };
    if [o0, o1, n0, n1].iter().any(|n| n.dot(axis) < MIN_FACING) {
        return false; // not convex seen along the axis: one split folds
    }
    let (mut e_old, mut e_new, mut count) = (0.0, 0.0, 0);
    for &s in gathered {
        let (q, n) = (samples[s], normals[s]);
        if n.dot(axis) <= 0.0 {
            continue; // another sheet
        }
        let (Some(i), Some(j)) = (above(&old, axis, q), above(&new, axis, q)) else {
            continue;
        };
        e_old += [o0, o1][i].dot(q - old[i][0]).powi(2);
        e_new += [n0, n1][j].dot(q - new[j][0]).powi(2);
        count += 1;
    }
    count >= MIN_SAMPLES && e_new < (1.0 - MARGIN) * e_old
}

/// Which of the two triangles `q` lies over, seen along `axis`.
fn above(tris: &[[DVec3; 3]; 2], axis: DVec3, q: DVec3) -> Option<usize> {
    tris.iter().position(|t| {
        (0..3).all(|k| {
            let (u, v) = (t[k], t[(k + 1) % 3]);
            (v - u).cross(q - u).dot(axis) >= 0.0
        })
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_quad_over_a_ridge_is_split_along_the_ridge() {
        // a ridge along y = x (z = 1 - |x - y|): the diagonal (a, b) crosses it, (c, d)
        // follows it
        let height = |x: f64, y: f64| 1.0 - (x - y).abs();
        let at = |x: f64, y: f64| DVec3::new(x, y, height(x, y));
        let (a, b, c, d) = (at(0.0, 1.0), at(1.0, 0.0), at(1.0, 1.0), at(0.0, 0.0));
        let mut samples = Vec::new();
        let mut normals = Vec::new();
        for i in 0..=10 {
            for j in 0..=10 {
                let (x, y) = (i as f64 / 10.0, j as f64 / 10.0);
                samples.push(at(x, y));
                let s = (x - y).signum();
                normals.push(DVec3::new(s, -s, 1.0).normalize());
            }
        }
        let all: Vec<usize> = (0..samples.len()).collect();
        assert!(better([a, b, c, d], &all, &samples, &normals));
        assert!(!better([d, c, a, b], &all, &samples, &normals));
    }
}
