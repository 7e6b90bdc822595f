//! Trimming a convex-hull triangulation back to the scanned outline: long edges span gaps.

use crate::delaunay::{unit_square, NONE};
use crate::geometry::planar_distance;
use crate::mesh::{prev, well_formed, HalfEdgeMesh};
use crate::Result;

/// Default `max_edge` as a multiple of the median nearest-neighbour spacing. Five spacings
/// keep scans whose lines are up to about 4.5 times farther apart than their points, and
/// still open a bore or a missed region a few lines wide.
pub const DEFAULT_MAX_EDGE_FACTOR: f64 = 5.0;

/// Distances below this fraction of the planar extent are not spacings but near-duplicates
/// (a point scanned twice, a surface folded onto itself in the plane); `median_spacing`
/// skips them, or a scan with many of them would be trimmed away entirely.
pub const NEAR_DUPLICATE_RELATIVE: f64 = 1e-9;

/// Median over used vertices of the planar distance to the nearest neighbour, taken along
/// triangulation edges (the nearest-neighbour graph is a subgraph of Delaunay's), ignoring
/// near-duplicates (see [`NEAR_DUPLICATE_RELATIVE`]). 0 when there are no triangles.
/// O(m + n log n).
pub fn median_spacing(uv: &[[f64; 2]], triangles: &[[u32; 3]]) -> f64 {
    let mut nearest = vec![f64::INFINITY; uv.len()];
    let (mut lo, mut hi) = ([f64::INFINITY; 2], [f64::NEG_INFINITY; 2]);
    for t in triangles {
        for &v in t {
            for k in 0..2 {
                lo[k] = lo[k].min(uv[v as usize][k]);
                hi[k] = hi[k].max(uv[v as usize][k]);
            }
        }
    }
    let extent = (hi[0] * 0.5 - lo[0] * 0.5).max(hi[1] * 0.5 - lo[1] * 0.5);
    let negligible = NEAR_DUPLICATE_RELATIVE * extent;
    for t in triangles {
        for k in 0..3 {
            let (a, b) = (t[k] as usize, t[(k + 1) % 3] as usize);
            let d = planar_distance(uv[a], uv[b]);
            if d <= negligible {
                continue;
            }
            nearest[a] = nearest[a].min(d);
            nearest[b] = nearest[b].min(d);
        }
    }
    let mut finite: Vec<f64> = nearest.into_iter().filter(|d| d.is_finite()).collect();
    if finite.is_empty() {
        return 0.0;
    }
    let mid = finite.len() / 2;
    *finite.select_nth_unstable_by(mid, f64::total_cmp).1
}

/// Drops triangles whose longest planar edge exceeds `max_edge`, then peels numerically
/// degenerate triangles off the boundary and resolves pinches.
///
/// Straight stretches of a scanned outline put collinear points on the convex hull, and
/// Delaunay closes them with zero-area slivers whose angles (0, 0, π) make a boundary
/// vertex look interior; they cover no area, so dropping them changes no surface. A pinch is a vertex where two fans touch only at a point; there the triangles of all
/// fans but the largest are dropped (repeatedly, as a drop can pinch a neighbour), so the
/// result is a valid [`HalfEdgeMesh`]. `max_edge = ∞` keeps everything. Input triangles must
/// form a valid planar triangulation. O(m log m).
pub fn trim_long_edges(
    uv: &[[f64; 2]],
    triangles: &[[u32; 3]],
    max_edge: f64,
) -> Result<Vec<[u32; 3]>> {
    let longest = |t: &[u32; 3]| {
        (0..3)
            .map(|k| planar_distance(uv[t[k] as usize], uv[t[(k + 1) % 3] as usize]))
            .fold(0.0, f64::max)
    };
    let mut kept: Vec<[u32; 3]> = triangles
        .iter()
        .copied()
        .filter(|t| longest(t) <= max_edge)
        .collect();
    // Degeneracy is judged scale-free: areas of 1e-300-sized triangles underflow.
    let unit = unit_square(uv);
    loop {
        let mesh = HalfEdgeMesh::from_triangles(uv.len(), &kept)?;
        let mut drop = pinched_fans_to_drop(&mesh);
        drop.extend(degenerate_boundary_triangles(&mesh, &unit));
        if drop.is_empty() {
            return Ok(kept);
        }
        let mut keep_flag = vec![true; kept.len()];
        for t in drop {
            keep_flag[t as usize] = false;
        }
        kept = kept
            .into_iter()
            .zip(keep_flag)
            .filter(|(_, k)| *k)
            .map(|(t, _)| t)
            .collect();
    }
}

/// Boundary triangles (an edge without twin) that are numerically collinear. O(m).
fn degenerate_boundary_triangles<'a>(
    mesh: &'a HalfEdgeMesh,
    uv: &'a [[f64; 2]],
) -> impl Iterator<Item = u32> + 'a {
    (0..mesh.n_triangles() as u32).filter(move |&t| {
        let on_boundary = (3 * t..3 * t + 3).any(|h| mesh.twin(h) == NONE);
        let [a, b, c] = mesh.triangle(t as usize).map(|v| uv[v as usize]);
        on_boundary && !well_formed(a, b, c)
    })
}

/// Triangles of the smaller fans at every pinched vertex. O(m).
fn pinched_fans_to_drop(mesh: &HalfEdgeMesh) -> Vec<u32> {
    let mut boundary_out: Vec<Vec<u32>> = vec![Vec::new(); mesh.n_vertices()];
    for h in 0..mesh.n_half_edges() as u32 {
        if mesh.twin(h) == NONE {
            boundary_out[mesh.start(h) as usize].push(h);
        }
    }
    let mut drop = Vec::new();
    for starts in boundary_out.iter().filter(|s| s.len() > 1) {
        // Each boundary half-edge leaving the vertex begins one fan; walk it counter-clockwise.
        let mut fans: Vec<Vec<u32>> = starts
            .iter()
            .map(|&first| {
                let mut tris = vec![first / 3];
                let mut h = first;
                while mesh.twin(prev(h)) != NONE {
                    h = mesh.twin(prev(h));
                    tris.push(h / 3);
                }
                tris
            })
            .collect();
        fans.sort_by_key(|f| (std::cmp::Reverse(f.len()), f.iter().min().copied()));
        drop.extend(fans.into_iter().skip(1).flatten());
    }
    drop.sort_unstable();
    drop.dedup();
    drop
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::delaunay::delaunay;

    /// A grid with the middle cells missing (a bore), triangulated over its convex hull.
    fn grid_with_hole() -> Vec<[f64; 2]> {
        let mut pts = Vec::new();
        for j in 0..20 {
            for i in 0..20 {
                let inside = (7..13).contains(&i) && (7..13).contains(&j);
                if !inside {
                    pts.push([i as f64 + 0.01 * ((i * j) % 3) as f64, j as f64]);
                }
            }
        }
        pts
    }

    #[test]
    fn hole_stays_open_and_mesh_is_valid() {
        let uv = grid_with_hole();
        let d = delaunay(&uv).unwrap();
        let s = median_spacing(&uv, &d.triangles);
        assert!((s - 1.0).abs() < 0.05, "{s}");
        let kept = trim_long_edges(&uv, &d.triangles, DEFAULT_MAX_EDGE_FACTOR * s * 0.5).unwrap();
        let mesh = HalfEdgeMesh::from_triangles(uv.len(), &kept).unwrap();
        mesh.validate(&uv).unwrap();
        // A point near the centre of the hole (off the grid's diagonals) is covered by no
        // triangle.
        let centre = [9.4, 9.3];
        let covers = |t: &[u32; 3]| {
            (0..3).all(|k| {
                crate::geometry::orient2d(uv[t[k] as usize], uv[t[(k + 1) % 3] as usize], centre)
                    > 0.0
            })
        };
        assert!(!kept.iter().any(covers));
        assert!(d.triangles.iter().any(covers));
        let untrimmed = trim_long_edges(&uv, &d.triangles, f64::INFINITY).unwrap();
        assert_eq!(untrimmed.len(), d.triangles.len());
    }

    #[test]
    fn collinear_hull_slivers_are_peeled() {
        // Three hull points on x + y = 1 with the middle one 1e-12 inside: the hull edge
        // skips it and Delaunay fills the gap with a zero-area sliver, which trimming drops.
        let inward = 0.5 - (2.0f64).powi(-40);
        let uv = vec![
            [0.0, 0.0],
            [0.25, 0.75],
            [inward, inward],
            [0.75, 0.25],
            [0.0, 0.5],
        ];
        let d = delaunay(&uv).unwrap();
        let slivers = |t: &[[u32; 3]]| {
            t.iter()
                .filter(|f| !well_formed(uv[f[0] as usize], uv[f[1] as usize], uv[f[2] as usize]))
                .count()
        };
        assert!(
            slivers(&d.triangles) > 0,
            "the fixture must contain a sliver"
        );
        let kept = trim_long_edges(&uv, &d.triangles, 10.0).unwrap();
        assert_eq!(slivers(&kept), 0);
        assert_eq!(kept.len(), d.triangles.len() - slivers(&d.triangles));
        HalfEdgeMesh::from_triangles(uv.len(), &kept)
            .unwrap()
            .validate(&uv)
            .unwrap();
    }

    #[test]
    fn pinches_are_resolved() {
        // Two squares touching at one corner; trimming the long diagonals leaves a bow tie.
        let uv = vec![
            [0.0, 0.0],
            [1.0, 0.0],
            [1.0, 1.0],
            [0.0, 1.0],
            [2.0, 1.0],
            [2.0, 2.0],
            [1.0, 2.0],
            [1.0, 1.0 + 1e-9],
        ];
        let tris = vec![[0, 1, 2], [0, 2, 3], [2, 4, 5], [2, 5, 6]];
        let kept = trim_long_edges(&uv, &tris, f64::INFINITY).unwrap();
        assert_eq!(kept.len(), 2);
        HalfEdgeMesh::from_triangles(uv.len(), &kept)
            .unwrap()
            .validate(&uv)
            .unwrap();
    }
}
