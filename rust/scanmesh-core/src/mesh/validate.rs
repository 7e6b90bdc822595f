//! The invariants of a half-edge mesh, checked: twins, orientation, single fans, no
//! folds, and Euler's characteristic per component.

use super::halfedge::BLOCK;
use crate::budget::{try_filled, try_indices, try_par_collect};
use crate::geometry::orient2d;
use crate::mesh::{prev, HalfEdgeMesh, NONE};
use crate::{Error, Result};
use rayon::prelude::*;
use std::sync::atomic::{AtomicU32, Ordering};

impl HalfEdgeMesh {
    /// Checks every invariant against the planar positions `uv`; the error says which failed.
    /// A mesh left unanchored by [`flip_unanchored`](Self::flip_unanchored) is checked on a
    /// reanchored copy.
    ///
    /// Twins are mutual and reversed; each triangle is strictly counter-clockwise (exact
    /// predicate); no directed edge repeats; every used vertex has a single fan (at most one
    /// boundary half-edge leaves it, and the walk from `vertex_edge` visits all its
    /// half-edges); the fan of each interior vertex winds once around it (its planar angles
    /// sum to 2π: no fold); and the Euler characteristic V − E + F equals 2C − B for C
    /// components and B boundary loops (each component a disc with holes).
    ///
    /// O(m α(m)) time (the components' union-find), no sort and no floating-point angle:
    /// repeated directed edges and folds are found by the fan walks (see
    /// `fan_winding`), exactly. The half-edge, triangle and vertex checks run
    /// in
    /// parallel on the rayon pool; the error named is that of the lowest failing
    /// half-edge, else triangle, else vertex (in that order of checks), so it does not
    /// depend on the thread count.
    pub fn validate(&self, uv: &[[f64; 2]]) -> Result<()> {
        if !self.anchored {
            let mut anchored = self.clone();
            anchored.reanchor();
            return anchored.validate(uv);
        }
        let fail = |s: String| Err(Error::Invariant(s));
        if uv.len() != self.n_vertices() {
            return fail(format!(
                "{} positions for {} vertices",
                uv.len(),
                self.n_vertices()
            ));
        }
        if self.start.len() % 3 != 0 || self.twin.len() != self.start.len() {
            return fail("half-edge arrays of inconsistent length".into());
        }
        let n_he = self.start.len() as u32;
        let half_edge_fault = (0..n_he)
            .into_par_iter()
            .with_min_len(BLOCK)
            .find_map_first(|h| {
                if self.start(h) as usize >= self.n_vertices() {
                    return Some(format!(
                        "half-edge {h} starts at vertex {} out of range",
                        self.start(h)
                    ));
                }
                let t = self.twin(h);
                if t != NONE {
                    if t >= n_he || self.twin(t) != h {
                        return Some(format!("twin of half-edge {h} is not mutual"));
                    }
                    if self.start(t) != self.end(h) || self.end(t) != self.start(h) {
                        return Some(format!(
                            "half-edge {h} and its twin {t} do not join the same vertices"
                        ));
                    }
                }
                None
            });
        if let Some(s) = half_edge_fault {
            return fail(s);
        }
        let triangle_fault = (0..self.n_triangles())
            .into_par_iter()
            .with_min_len(BLOCK)
            .find_map_first(|tri| {
                let [a, b, c] = self.triangle(tri);
                (orient2d(uv[a as usize], uv[b as usize], uv[c as usize]) <= 0.0).then(|| {
                    format!(
                        "triangle {tri} ({a}, {b}, {c}) is not strictly counter-clockwise in the plane"
                    )
                })
            });
        if let Some(s) = triangle_fault {
            return fail(s);
        }
        // The vertex checks need each vertex's out-degree and count of boundary half-edges
        // leaving it, a scattered count over all half-edges. A valid mesh does not: the
        // fan walks leave from different vertices, so they reach disjoint sets of
        // half-edges, and when they reach all of them together every walk reached its
        // vertex's degree and at most one boundary half-edge (the first) leaves each
        // vertex (see `vertex_fault`). So the counts are only taken when that pass fails,
        // to name the fault as a full check would.
        let n = self.n_vertices();
        let walks = (0..n as u32)
            .into_par_iter()
            .with_min_len(BLOCK)
            .map_init(Vec::new, |ends, v| {
                self.vertex_fault(v, uv, None, ends).ok().map(u64::from)
            })
            .sum::<Option<u64>>();
        let v_used = if walks == Some(u64::from(n_he)) {
            self.vertex_edge.par_iter().filter(|&&e| e != NONE).count()
        } else {
            let mut degree = try_filled(CHECK, 0u32, n)?;
            let mut boundary_out = try_filled(CHECK, 0u32, n)?;
            for h in 0..n_he {
                degree[self.start(h) as usize] += 1;
                if self.twin(h) == NONE {
                    boundary_out[self.start(h) as usize] += 1;
                }
            }
            let counts = Some((&degree[..], &boundary_out[..]));
            let vertex_fault = (0..n as u32)
                .into_par_iter()
                .with_min_len(BLOCK)
                .map_init(Vec::new, |ends, v| {
                    self.vertex_fault(v, uv, counts, ends).err()
                })
                .find_map_first(|fault| fault);
            if let Some(s) = vertex_fault {
                return fail(s);
            }
            degree.iter().filter(|&&d| d > 0).count()
        };
        let (components, loops) = self.count_components_and_loops()?;
        let v_used = v_used as i64;
        let e = (0..n_he)
            .into_par_iter()
            .filter(|&h| {
                let t = self.twin(h);
                t == NONE || h < t
            })
            .count() as i64;
        let f = self.n_triangles() as i64;
        if v_used - e + f != 2 * components - loops {
            return fail(format!(
                "Euler characteristic V - E + F = {} but {components} components with {loops} boundary loops need {}",
                v_used - e + f,
                2 * components - loops
            ));
        }
        Ok(())
    }

    /// The first fault of vertex `v` in the order [`validate`](Self::validate) checks
    /// them, or the number of half-edges its fan walk reached. Assumes twins are mutual
    /// and reversed (checked first), so the walk only meets half-edges leaving `v`, never
    /// one twice (the fan map h → twin(prev(h)) is injective), and ends.
    ///
    /// `counts` = (out-degree, boundary half-edges leaving) per vertex gives the full
    /// check. Without it (the fast pass), a vertex without `vertex_edge` passes and the
    /// boundary flag is compared with the first half-edge of the walk: when the walks of
    /// all vertices together reach every half-edge, that is the same check (a second
    /// boundary half-edge leaving v, or one not first in its fan, would not be reached);
    /// otherwise the caller reruns with counts. `ends` is scratch space (the fan's far
    /// ends, to find a repeated directed edge). O(degree), O(degree log degree) above 32.
    fn vertex_fault(
        &self,
        v: u32,
        uv: &[[f64; 2]],
        counts: Option<(&[u32], &[u32])>,
        ends: &mut Vec<u32>,
    ) -> std::result::Result<u32, String> {
        let vi = v as usize;
        let e = self.vertex_edge[vi];
        match counts {
            Some((degree, boundary_out)) => {
                if degree[vi] == 0 {
                    if e != NONE {
                        return Err(format!("unused vertex {v} has an outgoing half-edge"));
                    }
                    return Ok(0);
                }
                if e == NONE || self.start(e) != v {
                    return Err(format!(
                        "vertex {v} does not point at a half-edge leaving it"
                    ));
                }
                if boundary_out[vi] > 1 {
                    return Err(format!(
                        "vertex {v} joins {} separate fans (a pinch)",
                        boundary_out[vi]
                    ));
                }
                if self.on_boundary[vi] != (boundary_out[vi] == 1) {
                    return Err(format!("boundary flag of vertex {v} is stale"));
                }
                if boundary_out[vi] == 1 && self.twin(e) != NONE {
                    return Err(format!(
                        "boundary vertex {v} does not point at its boundary half-edge"
                    ));
                }
            }
            None => {
                if e == NONE {
                    return Ok(0);
                }
                if self.start(e) != v {
                    return Err(format!(
                        "vertex {v} does not point at a half-edge leaving it"
                    ));
                }
                if self.on_boundary[vi] != (self.twin(e) == NONE) {
                    return Err(format!("boundary flag of vertex {v} is stale"));
                }
            }
        }
        // A repeated directed edge v→w shows as w met twice in the walk: a scan of the
        // ends so far (about 6) beats a shared per-vertex stamp array's scattered writes;
        // a long fan switches to a set, so a star of degree d costs O(d log d), not d².
        ends.clear();
        let mut seen = std::collections::BTreeSet::new();
        let mut reached = 0u32;
        for h in self.fan(v) {
            reached += 1;
            let w = self.end(h);
            let repeat = if ends.len() < 32 {
                let r = ends.contains(&w);
                ends.push(w);
                if ends.len() == 32 {
                    seen.extend(ends.iter().copied());
                }
                r
            } else {
                !seen.insert(w)
            };
            if repeat {
                return Err(format!("directed edge {v}->{w} appears twice"));
            }
        }
        if let Some((degree, _)) = counts {
            if reached != degree[vi] {
                return Err(format!(
                    "the fan of vertex {v} reaches {reached} of its {} half-edges",
                    degree[vi]
                ));
            }
        }
        if self.is_interior(v) {
            let winding = self.fan_winding(v, uv);
            if winding != 1 {
                return Err(format!(
                    "the fan of interior vertex {v} winds {winding} times around it (planar angles sum to {winding} × 2π, not 2π: a fold)"
                ));
            }
        }
        Ok(reached)
    }

    /// How many times the closed fan of `v` winds around it in the plane, when every
    /// triangle is strictly counter-clockwise (checked first by [`validate`](Self::validate)).
    ///
    /// Why this is the angle-sum test without angles: going round the fan, the direction
    /// from v to the far end of each half-edge turns counter-clockwise by the triangle's
    /// corner angle at v, which lies strictly between 0 and π because the triangle is
    /// strictly counter-clockwise. The directions return to the first, so the corner
    /// angles sum to 2πk, k ≥ 1 the winding number, and k = 1 exactly when the sum is 2π
    /// (k ≥ 2 is a fold: the fan covers its neighbourhood k times). Split the directions
    /// into the half-open upper half [0, π) (y > 0, or y = 0 and x > 0) and lower half
    /// [π, 2π). A turn by less than π passes the direction 0 (≡ 2π) exactly when it goes
    /// from the lower half into the upper half, and the lifted direction passes 0 exactly
    /// k times in the whole walk; so k = the number of lower-to-upper steps. Each half is
    /// decided by comparing coordinates with v's (exact, no subtraction), and the
    /// orientation was decided by an exact predicate, so the count is exact: no atan2,
    /// and no tolerance where the sum of corner angles needed 1e-6. O(degree).
    pub(super) fn fan_winding(&self, v: u32, uv: &[[f64; 2]]) -> u32 {
        let p = uv[v as usize];
        let lower = |q: [f64; 2]| q[1] < p[1] || (q[1] == p[1] && q[0] < p[0]);
        self.fan(v)
            .map(|h| {
                let (from, to) = (uv[self.end(h) as usize], uv[self.start(prev(h)) as usize]);
                u32::from(lower(from) && !lower(to))
            })
            .sum()
    }

    /// Connected components of triangles (through twins) and boundary loops.
    ///
    /// Components: a concurrent union-find over the interior edges on the rayon pool
    /// (compare-and-swap links, the higher root under the lower, path halving); the count
    /// of roots does not depend on the order of the unions. Loops: the cycles of
    /// h → vertex_edge[end(h)] on the boundary half-edges, walked serially over the
    /// (usually few) boundary half-edges. Errors: an [`Error::OutOfMemory`]. O(m α(m)) work.
    fn count_components_and_loops(&self) -> Result<(i64, i64)> {
        let m = self.n_triangles();
        let parent = try_par_collect(CHECK, (0..m as u32).into_par_iter().map(AtomicU32::new))?;
        fn find(p: &[AtomicU32], mut x: u32) -> u32 {
            loop {
                let up = p[x as usize].load(Ordering::Relaxed);
                if up == x {
                    return x;
                }
                let grand = p[up as usize].load(Ordering::Relaxed);
                if grand != up {
                    // Halving; losing the race only leaves a longer path.
                    let _ = p[x as usize].compare_exchange(
                        up,
                        grand,
                        Ordering::Relaxed,
                        Ordering::Relaxed,
                    );
                }
                x = grand;
            }
        }
        (0..self.start.len() as u32)
            .into_par_iter()
            .with_min_len(BLOCK)
            .for_each(|h| {
                let t = self.twin(h);
                // Each interior edge once (from its lower half-edge).
                if t == NONE || h > t {
                    return;
                }
                let (mut x, mut y) = (h / 3, t / 3);
                loop {
                    x = find(&parent, x);
                    y = find(&parent, y);
                    if x == y {
                        return;
                    }
                    let (lo, hi) = (x.min(y), x.max(y));
                    // Only a root is relinked: if hi stopped being one, retry.
                    if parent[hi as usize]
                        .compare_exchange(hi, lo, Ordering::Relaxed, Ordering::Relaxed)
                        .is_ok()
                    {
                        return;
                    }
                }
            });
        let components = (0..m)
            .into_par_iter()
            .filter(|&x| parent[x].load(Ordering::Relaxed) == x as u32)
            .count() as i64;
        let boundary = try_indices(CHECK, 0..self.start.len() as u32, |h| self.twin(h) == NONE)?;
        // The boundary half-edge leaving end(h) is that vertex's vertex_edge (one fan each);
        // validate has checked that it is a boundary half-edge, so this is a permutation.
        let loops = count_cycles(boundary.len(), |k| {
            let h = self.vertex_edge[self.end(boundary[k]) as usize];
            boundary.binary_search(&h).ok()
        })
        .expect("boundary vertex_edge checked");
        Ok((components, loops as i64))
    }
}

/// What the check's buffers are called in memory errors.
const CHECK: &str = "the mesh check";

/// Number of cycles of the map `successor` on `0..n`, or `None` when it is not a
/// permutation (`successor` returns `None`, or a walk joins a cycle part-way). Counts
/// boundary loops, of a mesh (`validate`) and of strips before they are built
/// (`strips::check`). O(n) calls of `successor`.
pub(crate) fn count_cycles(
    n: usize,
    mut successor: impl FnMut(usize) -> Option<usize>,
) -> Option<usize> {
    let mut seen = vec![false; n];
    let mut cycles = 0;
    for k0 in 0..n {
        if seen[k0] {
            continue;
        }
        cycles += 1;
        let mut k = k0;
        while !seen[k] {
            seen[k] = true;
            k = successor(k)?;
        }
        if k != k0 {
            return None;
        }
    }
    Some(cycles)
}
