//! The zero set of the fused distance as a closed 2-manifold with a label per face.
//!
//! The inside (negative) nodes are first made *well-composed* (Latecki): no 2 × 2 square
//! of nodes holds a checkerboard and no 2 × 2 × 2 cube holds exactly two opposite corners
//! on one side, the configurations where the boundary of a union of voxels pinches. Each is
//! removed by moving one outside node inside (the one nearest the surface), which only
//! grows the inside, so the repair ends. Then dual contouring: one vertex per cell whose
//! corners differ, one quad (two triangles) per grid edge whose ends differ, so the faces
//! are the boundary of the voxel union: closed, and a 2-manifold because it is
//! well-composed. A vertex is placed by a quadratic error function on the samples within a
//! voxel of its cell (their tangent planes meet at a crease or corner, so creases stay
//! sharp; half a voxel around the cell left the fandisk 2.3 × the error away from
//! creases), pulled slightly towards the mean of the cell's edge crossings (which alone
//! places it where no sample is near), and may leave its cell by a voxel. A crossing between
//! space seen empty and space no ray entered is found on the rays themselves, not halfway
//! between the nodes (`Grid::crossing`): that is where never-sampled walls close. Last, edges are
//! flipped where the samples lie closer to the other split (`flips`): they follow creases.

use super::blocks::BLOCK;
use super::depth::DepthView;
use super::flips::{follow_samples, MAX_PASSES};
use super::samples::SampleIndex;
use super::sides::{Sides, INSIDE, MOVED};
use super::topology::{settle, Settled};
use super::tsdf::{Evidence, Volume};
use super::walls::{flatten_unsampled, Placed};
use crate::budget;
use crate::error::{Error, Result};
use crate::progress::{Progress, Share};
use glam::{DMat3, DVec3};
use rayon::prelude::*;
use std::collections::HashMap;

/// Face label: within the truncation of a measured surface.
pub const MEASURED: u8 = 0;
/// Face label: between space seen empty and space no ray entered (closed by carving).
pub const INFERRED: u8 = 1;
/// Face label: closed with no evidence (against the grid's border, or where the manifold
/// repair moved a node).
pub const FILLED: u8 = 2;

/// Pull of a vertex towards its cell's mass point, relative to the samples' tangent planes:
/// small, so it only picks the point along the directions the planes leave free (0.05
/// rounded creases of 30-40°, whose planes' smaller eigenvalue is about 3 % of the larger).
const REGULARIZE: f64 = 0.005;

/// Width (voxels) of the Gaussian that weighs a sample's tangent plane by its distance
/// from the cell's mass point. The planes of a curved surface meet above it, by about
/// r² / 2R for samples r from the vertex on a radius R, so the nearer samples count more;
/// too near and too few are left to average the noise. On benches/merge.py's four parts
/// (docs/benchmarks/merge.md): with no weight (every sample within a voxel of the cell)
/// the blade's vertices lay 0.071 voxels RMS off its surface, 0.5 gave the blade its
/// lowest RMS but the fandisk's crease normals 5.3° (4.5° at 0.7), 1.0 kept half the
/// blade's gain.
const PLANE_WIDTH_VOXELS: f64 = 0.7;

/// Length of the samples' weighted mean normal (1: all parallel) above which the plane
/// through their centroid joins their tangent planes. On a curved surface the centroid's
/// plane lies below it by about as much as the tangent planes meet above it, so the two
/// together cancel that bias (to second order); at a crease the mean normal is shorter
/// (two faces 36° apart: 0.95) and the tangent planes alone keep the corner. Measured with
/// [`PLANE_WIDTH_VOXELS`]: the fandisk's RMS 0.52 × Poisson's (0.56 × without), the
/// conrod's normals away from creases 1.3° (1.7°).
const SMOOTH_RESULTANT: f64 = 0.95;

/// A cell edge whose ends' fused distances differ by more than this many voxels does not
/// hold a distance field sampled at its ends (a distance changes by at most the edge's
/// length) but a jump: space a ray showed empty against space none entered, or two depths
/// of one view across a depth jump. Its crossing is found on the rays themselves
/// ([`Volume::value_at`], bisected), not by interpolating the ends' values, which would
/// put it at the edge's middle whatever the rays said.
const JUMP_VOXELS: f64 = 1.5;

/// Bisection steps for such a crossing: 1/128 of a voxel.
const BISECTIONS: usize = 7;

/// Parallel edges across such an edge whose crossings are averaged, per side of the square
/// window (half a voxel apart): 3 × 3. The vertices on a bored box's never-sampled wall
/// (`test_merge.py`) were 0.18 voxel RMS off with 3 × 3 or 5 × 5, 0.21 with 9 × 9 (which
/// also averages the wall's curvature and rims) and 0.24 with the edge alone.
const ACROSS: usize = 3;

/// The extracted mesh.
#[derive(Debug, Clone, Default)]
pub struct Fused {
    /// Vertices, world units.
    pub vertices: Vec<DVec3>,
    /// Triangles, counter-clockwise seen from outside.
    pub faces: Vec<[u32; 3]>,
    /// Per face: [`MEASURED`], [`INFERRED`] or [`FILLED`].
    pub labels: Vec<u8>,
    /// Nodes the manifold repair moved inside.
    pub repaired: usize,
    /// Nodes whose side the evidence did not decide, moved to take off thin handles.
    pub settled: Settled,
}

/// Corners of a cell's six faces in cyclic order (corner bit 1: +x, 2: +y, 4: +z).
const CELL_FACES: [[usize; 4]; 6] = [
    [0, 2, 6, 4],
    [1, 3, 7, 5],
    [0, 1, 5, 4],
    [2, 3, 7, 6],
    [0, 1, 3, 2],
    [4, 5, 7, 6],
];

/// The closed mesh of `volume`'s zero set (its thin handles of weakly measured nodes first
/// taken off: `topology`), vertices placed on `samples` (world points) with
/// their outward unit `normals`; `views` (those integrated and carved, in the order carved)
/// place the crossings on edges across a jump of the evidence; a vertex with no sample near
/// is then laid on the plane of its wall, and a face's last vertex beside such a wall taken
/// halfway onto it (`flatten_unsampled`). O(nodes · repair passes +
/// samples log samples + surface cells · views).
///
/// Errors: `InvalidParameter` when `samples` and `normals` differ in length, or `views` are
/// not as many as the views carved.
pub fn extract(
    volume: &Volume,
    samples: &[DVec3],
    normals: &[DVec3],
    views: &[&DepthView],
) -> Result<Fused> {
    extract_counted(volume, samples, normals, views, &Progress::new())
}

/// [`extract`], counting in `progress` the passes of [`EXTRACT_WEIGHTS`] as they go: the
/// repair's first pass and the walk a slice of the grid at a time, the vertices placed a
/// cell at a time, the samples followed a pass at a time.
pub fn extract_counted(
    volume: &Volume,
    samples: &[DVec3],
    normals: &[DVec3],
    views: &[&DepthView],
    progress: &Progress,
) -> Result<Fused> {
    volume.check_views(views)?;
    if samples.len() != normals.len() {
        return Err(Error::InvalidParameter {
            name: "normals",
            value: format!("{} normals for {} samples", normals.len(), samples.len()),
            expected: "one normal per sample",
        });
    }
    let slices = volume.dims()[2] as u64;
    progress.plan(EXTRACT_WEIGHTS.iter().sum::<u64>() * slices);
    let mut side = Sides::new(volume)?;
    let settled = settle(volume, &mut side)?;
    Ok(Fused {
        settled,
        ..extract_from(volume, side, samples, normals, views, (progress, slices))?
    })
}

/// What the passes [`extract_counted`] counts are worth in its progress, in slices of the
/// grid: the repair's first pass, the walk along the three axes, the vertices placed, the
/// samples followed. In about the proportions of their times on the Stanford dragon (15
/// views, 62 million nodes: 22, 2, 130 and 66 s), so that the rate gives the time left.
pub const EXTRACT_WEIGHTS: [u64; 4] = [2, 1, 10, 5];

/// [`extract`] from the nodes' sides `side` (the blocks it walks), inputs checked, counting
/// its passes in `progress` ([`EXTRACT_WEIGHTS`] of the grid's `slices`).
fn extract_from(
    volume: &Volume,
    mut side: Sides,
    samples: &[DVec3],
    normals: &[DVec3],
    views: &[&DepthView],
    (progress, slices): (&Progress, u64),
) -> Result<Fused> {
    let grid = Grid::new(volume);
    let [repair, walk, place, follow] = EXTRACT_WEIGHTS.map(|w| w * slices);
    let repaired = grid.repair(&mut side, Share::new(progress, repair, slices))?;
    let walked = Share::new(progress, walk, 3 * slices);
    let near = SampleIndex::new(volume, samples)?;
    let mut out = Fused {
        repaired,
        ..Fused::default()
    };
    // the quads in the order of their edges (axis by axis, x fastest), their vertices in
    // the order first met; placed afterwards on every core
    let mut cell_vertex: HashMap<usize, u32> = HashMap::new();
    let mut cells: Vec<usize> = Vec::new();
    // per quad: its cells' vertices, its label and the grid edge it crosses
    let mut quads: Vec<([u32; 4], u8, [usize; 2])> = Vec::new();
    let [nx, ny, nz] = grid.dims;
    let steps = [1, nx, nx * ny];
    for axis in 0..3 {
        // the two axes across the edge, in right-handed order
        let (u, v) = ((axis + 1) % 3, (axis + 2) % 3);
        for k in 0..nz {
            walked.add(1);
            for j in 0..ny {
                if !side.row_active(j, k) {
                    continue;
                }
                let mut i = 0;
                while i < nx {
                    let at = [i, j, k];
                    if !side.is_active(at) {
                        i = (i / BLOCK + 1) * BLOCK;
                        continue;
                    }
                    i += 1;
                    if at[axis] + 1 >= grid.dims[axis] {
                        continue;
                    }
                    let a = grid.volume.index(at[0], j, k);
                    let b = a + steps[axis];
                    let a_in = side.get(a) & INSIDE != 0;
                    if a_in == (side.get(b) & INSIDE != 0) {
                        continue;
                    }
                    // the four cells around the edge, counter-clockwise about +axis
                    let cell = |du: usize, dv: usize| {
                        let mut c = at;
                        c[u] = c[u] + du - 1;
                        c[v] = c[v] + dv - 1;
                        grid.volume.index(c[0], c[1], c[2])
                    };
                    let mut quad = [cell(0, 0), cell(1, 0), cell(1, 1), cell(0, 1)];
                    if !a_in {
                        quad.reverse();
                    }
                    budget::try_grow("the fused mesh's vertices", &mut cells, 4)?;
                    cell_vertex.try_reserve(4).map_err(|_| {
                        budget::not_allocated::<(usize, u32)>(
                            "the fused mesh's cells",
                            cells.len() + 4,
                        )
                    })?;
                    let ids = quad.map(|c| {
                        *cell_vertex.entry(c).or_insert_with(|| {
                            cells.push(c);
                            (cells.len() - 1) as u32
                        })
                    });
                    budget::try_grow("the fused mesh's quads", &mut quads, 1)?;
                    quads.push((ids, grid.label(a, b, &side), [a, b]));
                }
            }
        }
    }
    drop(cell_vertex);
    walked.finish();
    // the crossings and the vertices placed: one share of the progress (a crossing or a
    // cell takes thousands of operations: one add each is nothing)
    let placing = Share::new(progress, place, (quads.len() + cells.len()) as u64);
    // each crossed edge's crossing once (its four cells share it), then each cell's mass
    // point: the mean of its edges' crossings
    let crossings: Vec<DVec3> = budget::try_par_collect(
        "the fused mesh's crossings",
        quads.par_iter().map(|&(_, _, [a, b])| {
            placing.add(1);
            grid.edge_crossing(a, b, &side, views)
        }),
    )?;
    let mut mass: Vec<(DVec3, f64)> =
        budget::try_filled("the fused mesh's vertices", (DVec3::ZERO, 0.0), cells.len())?;
    for ((ids, _, _), p) in quads.iter().zip(&crossings) {
        for &id in ids {
            mass[id as usize].0 += *p;
            mass[id as usize].1 += 1.0;
        }
    }
    drop(crossings);
    let placed: Vec<(DVec3, Placed)> = budget::try_par_collect(
        "the fused mesh's vertices",
        cells.par_iter().zip(&mass).map(|(&c, &(sum, n))| {
            placing.add(1);
            grid.place(c, sum / n, &side, &near, samples, normals)
        }),
    )?;
    drop(mass);
    placing.finish();
    out.vertices = budget::try_collect("the fused mesh's vertices", placed.iter().map(|v| v.0))?;
    let placed = budget::try_collect("the fused mesh's vertices", placed.iter().map(|v| v.1))?;
    let vertex_cells = budget::try_collect(
        "the fused mesh's vertices",
        cells.iter().map(|&c| grid.coords(c)),
    )?;
    budget::try_grow("the fused mesh's faces", &mut out.faces, 2 * quads.len())?;
    budget::try_grow("the fused mesh's faces", &mut out.labels, 2 * quads.len())?;
    for (ids, label, _) in quads {
        for t in split(&out.vertices, ids) {
            out.faces.push(t);
            out.labels.push(label);
        }
    }
    // by passes (those not needed counted at the end)
    let following = Share::new(progress, follow, MAX_PASSES as u64);
    follow_samples(
        &out.vertices,
        &vertex_cells,
        &mut out.faces,
        &out.labels,
        &near,
        samples,
        normals,
        &following,
    )?;
    following.finish();
    flatten_unsampled(&mut out.vertices, &out.faces, &placed, grid.volume.voxel())?;
    Ok(out)
}

/// A quad as two triangles, split along the diagonal that leaves them flatter.
fn split(vertices: &[DVec3], q: [u32; 4]) -> [[u32; 3]; 2] {
    let p = q.map(|i| vertices[i as usize]);
    let normal =
        |a: usize, b: usize, c: usize| (p[b] - p[a]).cross(p[c] - p[a]).normalize_or_zero();
    let along_02 = normal(0, 1, 2).dot(normal(0, 2, 3));
    let along_13 = normal(0, 1, 3).dot(normal(1, 2, 3));
    if along_02 >= along_13 {
        [[q[0], q[1], q[2]], [q[0], q[2], q[3]]]
    } else {
        [[q[0], q[1], q[3]], [q[1], q[2], q[3]]]
    }
}

/// The volume with its border: border nodes are outside whatever the evidence says.
struct Grid<'a> {
    volume: &'a Volume,
    dims: [usize; 3],
}

impl<'a> Grid<'a> {
    fn new(volume: &'a Volume) -> Self {
        Self {
            volume,
            dims: volume.dims(),
        }
    }

    fn coords(&self, n: usize) -> [usize; 3] {
        let [nx, ny, _] = self.dims;
        [n % nx, (n / nx) % ny, n / (nx * ny)]
    }

    fn on_border(&self, n: usize) -> bool {
        let c = self.coords(n);
        (0..3).any(|a| c[a] == 0 || c[a] + 1 == self.dims[a])
    }

    /// The signed distance used for crossings: a moved node sits just inside.
    fn value(&self, n: usize, side: &Sides) -> f64 {
        if side.get(n) & MOVED != 0 {
            -1e-3 * self.volume.voxel()
        } else {
            self.volume.value(n)
        }
    }

    /// The flat indices of the 8 corners of the cell whose lowest corner is node `n`.
    fn corners(&self, n: usize) -> [usize; 8] {
        let [nx, ny, _] = self.dims;
        std::array::from_fn(|c| n + (c & 1) + ((c >> 1) & 1) * nx + ((c >> 2) & 1) * nx * ny)
    }

    /// Makes the inside well-composed (see the module comment); returns the nodes moved.
    /// Visits the cells in the order of the whole grid (x fastest), skipping those of
    /// blocks where the sides cannot differ (which a move makes active as it happens).
    /// Counts the first pass's slices in `first` (the later passes visit what moves made
    /// active, an amount not known beforehand).
    ///
    /// Errors: `OutOfMemory`.
    fn repair(&self, side: &mut Sides, first: Share<'_>) -> Result<usize> {
        let [nx, ny, nz] = self.dims;
        let mut moved = 0;
        let mut first = Some(first);
        loop {
            let before = moved;
            for k in 0..nz - 1 {
                if let Some(first) = &first {
                    first.add(1);
                }
                for j in 0..ny - 1 {
                    if !side.row_active(j, k) {
                        continue;
                    }
                    let mut i = 0;
                    while i < nx - 1 {
                        if !side.is_active([i, j, k]) {
                            i = (i / BLOCK + 1) * BLOCK;
                            continue;
                        }
                        let c = self.corners(self.volume.index(i, j, k));
                        while let Some(n) = self.critical(&c, side) {
                            side.add(n, INSIDE | MOVED)?;
                            moved += 1;
                        }
                        i += 1;
                    }
                }
            }
            if let Some(first) = first.take() {
                first.finish();
            }
            if moved == before {
                return Ok(moved);
            }
        }
    }

    /// An outside node whose move inside removes a critical configuration of cell `c`.
    fn critical(&self, c: &[usize; 8], side: &Sides) -> Option<usize> {
        let mask: u8 = (0..8)
            .map(|k| u8::from(side.get(c[k]) & INSIDE != 0) << k)
            .sum();
        if mask == 0 || mask == u8::MAX {
            return None; // one side (most cells a pass visits): nothing to pinch
        }
        let inside = |k: usize| (mask >> k) & 1 != 0;
        let candidates: Vec<usize> = if let Some(f) = CELL_FACES.iter().find(|f| {
            inside(f[0]) == inside(f[2])
                && inside(f[1]) == inside(f[3])
                && inside(f[0]) != inside(f[1])
        }) {
            f.iter().copied().filter(|&k| !inside(k)).collect()
        } else {
            let opposite = |m: u8| (0..4).any(|k| m == (1 << k) | (1 << (7 - k)));
            if opposite(mask) || opposite(!mask) {
                (0..8).filter(|&k| !inside(k)).collect()
            } else {
                return None;
            }
        };
        candidates
            .into_iter()
            .map(|k| c[k])
            .filter(|&n| !self.on_border(n))
            .min_by(|&a, &b| self.volume.value(a).total_cmp(&self.volume.value(b)))
    }

    /// The label of the quad across edge (a, b).
    fn label(&self, a: usize, b: usize, side: &Sides) -> u8 {
        let ends = [a, b];
        if ends
            .iter()
            .any(|&n| self.volume.evidence(n) == Evidence::Measured)
        {
            MEASURED
        } else if ends.iter().any(|&n| {
            side.get(n) & MOVED != 0
                || (self.on_border(n) && self.volume.evidence(n) == Evidence::Unseen)
        }) {
            FILLED
        } else {
            INFERRED
        }
    }

    /// The crossing of the evidence's sign between `a` and `b` (fraction), whose values
    /// are `fa` and `fb`, if their signs differ.
    fn bisect(
        &self,
        (a, fa): (DVec3, f64),
        (b, fb): (DVec3, f64),
        views: &[&DepthView],
    ) -> Option<f64> {
        let at = |t: f64| self.volume.value_between(a.lerp(b, t), views);
        let (mut lo, mut hi, mut f_lo, mut f_hi) = (0.0, 1.0, fa, fb);
        if (f_lo < 0.0) == (f_hi < 0.0) {
            return None;
        }
        for _ in 0..BISECTIONS {
            let mid = 0.5 * (lo + hi);
            let f = at(mid);
            if (f < 0.0) == (f_lo < 0.0) {
                (lo, f_lo) = (mid, f);
            } else {
                (hi, f_hi) = (mid, f);
            }
        }
        Some(lo + (hi - lo) * (f_lo / (f_lo - f_hi)).clamp(0.0, 1.0))
    }

    /// Where the surface crosses the edge from `a` (fused distance `fa`) to `b` (`fb`, of
    /// the other sign), as a fraction of the edge (in [-1, 2]: the vertex may leave its cell
    /// by a voxel, as the samples' point may).
    ///
    /// Interpolated between the ends' values, unless the edge spans a jump ([`JUMP_VOXELS`])
    /// with at least one end unmeasured (seen empty or unseen: `±truncation` stands in for a
    /// distance nobody measured, so the interpolation puts the crossing mid-edge whatever
    /// the rays said). Then the crossing is found on the views' own evidence between the
    /// nodes ([`Volume::value_at`], bisected), as the mean over the [`ACROSS`]² parallel
    /// edges half a voxel apart across the edge (each crossing found in this edge or the
    /// next one along it): one line of rays places a wall only to its nearest ray, half a
    /// ray spacing either way, and a wall crossing the rays at an angle meets them at other
    /// fractions of a spacing on the neighbouring lines. Two measured ends keep the
    /// interpolation (a measured jump is a depth jump or a crease, where the measured
    /// distances are the better guide: bisecting there moved a curtain on the fandisk 0.3
    /// spacing further out). When the ends' evidence does not change sign (a node the
    /// manifold repair moved), the interpolation stays too.
    fn crossing(
        &self,
        ends: [usize; 2],
        a: DVec3,
        b: DVec3,
        fa: f64,
        fb: f64,
        views: &[&DepthView],
    ) -> f64 {
        let linear = (fa / (fa - fb)).clamp(0.0, 1.0);
        if views.is_empty()
            || (fa - fb).abs() <= JUMP_VOXELS * self.volume.voxel()
            || ends
                .iter()
                .all(|&n| self.volume.evidence(n) == Evidence::Measured)
        {
            return linear;
        }
        let value = |p: DVec3| self.volume.value_between(p, views);
        if (value(a) < 0.0) == (value(b) < 0.0) {
            return linear;
        }
        let axis = (b - a).abs().max_position();
        let (u, v) = ((axis + 1) % 3, (axis + 2) % 3);
        let step = 0.5 * self.volume.voxel();
        let reach = (ACROSS as i32 - 1) / 2;
        let d = b - a;
        let (mut sum, mut found) = (0.0, 0.0);
        for du in -reach..=reach {
            for dv in -reach..=reach {
                let mut o = DVec3::ZERO;
                o[u] = f64::from(du) * step;
                o[v] = f64::from(dv) * step;
                let (p, q) = (a + o, b + o);
                let (fp, fq) = (value(p), value(q));
                let t = if (fp < 0.0) != (fq < 0.0) {
                    self.bisect((p, fp), (q, fq), views)
                } else if (fp < 0.0) == (fa < 0.0) {
                    self.bisect((q, fq), (q + d, value(q + d)), views)
                        .map(|t| 1.0 + t)
                } else {
                    self.bisect((p - d, value(p - d)), (p, fp), views)
                        .map(|t| t - 1.0)
                };
                if let Some(t) = t {
                    sum += t;
                    found += 1.0;
                }
            }
        }
        // the edge itself crosses, so at least one line was found
        (sum / found).clamp(-1.0, 2.0)
    }

    /// The point where the surface crosses the grid edge from node `a` to node `b` (one
    /// step up an axis; their sides differ).
    fn edge_crossing(&self, a: usize, b: usize, side: &Sides, views: &[&DepthView]) -> DVec3 {
        let [i, j, k] = self.coords(a);
        let [p, q] = [self.volume.node(i, j, k), {
            let [i, j, k] = self.coords(b);
            self.volume.node(i, j, k)
        }];
        let (fa, fb) = (self.value(a, side), self.value(b, side));
        p.lerp(q, self.crossing([a, b], p, q, fa, fb, views))
    }

    /// The vertex of cell `cell` (its lowest node's index) whose edges' crossings have the
    /// mean `mass`, and how samples placed it.
    fn place(
        &self,
        cell: usize,
        mass: DVec3,
        side: &Sides,
        near: &SampleIndex,
        samples: &[DVec3],
        normals: &[DVec3],
    ) -> (DVec3, Placed) {
        let c = self.corners(cell);
        let f = c.map(|n| self.value(n, side));
        let [i, j, k] = self.coords(cell);
        let lo = self.volume.node(i, j, k);
        let voxel = self.volume.voxel();
        let hi = lo + DVec3::splat(voxel);
        // the cell's distance gradient: which way is out, to drop samples of another sheet
        let gradient = DVec3::new(
            (0..8).map(|q| if q & 1 != 0 { f[q] } else { -f[q] }).sum(),
            (0..8).map(|q| if q & 2 != 0 { f[q] } else { -f[q] }).sum(),
            (0..8).map(|q| if q & 4 != 0 { f[q] } else { -f[q] }).sum(),
        );
        // the samples' tangent planes fix the vertex across the surface (and at creases
        // along it), nearer samples more; the mass point fixes it where they leave it free,
        // as in dual contouring
        let margin = DVec3::splat(voxel);
        let width = PLANE_WIDTH_VOXELS * voxel;
        let (mut a, mut rhs, mut count) = (DMat3::ZERO, DVec3::ZERO, 0.0);
        let (mut normal_sum, mut point_sum) = (DVec3::ZERO, DVec3::ZERO);
        for s in near.around(self.coords(cell)) {
            let (p, n) = (samples[s], normals[s]);
            if p.cmplt(lo - margin).any() || p.cmpgt(hi + margin).any() || n.dot(gradient) <= 0.0 {
                continue;
            }
            let w = (-(p - mass).length_squared() / (2.0 * width * width)).exp();
            a += DMat3::from_cols(n * n.x, n * n.y, n * n.z) * w;
            rhs += n * n.dot(p) * w;
            count += w;
            normal_sum += n * w;
            point_sum += p * w;
        }
        let how = if count == 0.0 {
            Placed::Unsampled
        } else if normal_sum.length() > SMOOTH_RESULTANT * count {
            Placed::Smooth(normal_sum.normalize())
        } else {
            Placed::Crease
        };
        if let Placed::Smooth(m) = how {
            // smooth here: the centroid's plane cancels the tangent planes' curvature bias
            a += DMat3::from_cols(m * m.x, m * m.y, m * m.z) * count;
            rhs += m * m.dot(point_sum);
            count *= 2.0;
        }
        if count == 0.0 {
            return (mass, how);
        }
        let reg = REGULARIZE * count;
        let x = (a + DMat3::from_diagonal(DVec3::splat(reg))).inverse() * (rhs + reg * mass);
        if x.is_finite() {
            // as far out as the samples used: a surface on a layer of nodes (a CAD face on
            // the grid) wanders between the cells on either side, and a crease's point may
            // lie in the next cell
            (x.clamp(lo - margin, hi + margin), how)
        } else {
            (mass, how)
        }
    }
}

#[cfg(test)]
mod tests {
    use super::super::depth::DepthView;
    use super::super::testing::{fused_volume, view_from_above};
    use super::*;
    use std::collections::HashMap as Map;

    /// Every edge in exactly two faces, in opposite directions; V − E + F.
    fn euler(f: &Fused) -> i64 {
        let mut edges: Map<(u32, u32), i32> = Map::new();
        for t in &f.faces {
            for e in 0..3 {
                *edges.entry((t[e], t[(e + 1) % 3])).or_default() += 1;
            }
        }
        for (&(a, b), &n) in &edges {
            assert_eq!(n, 1, "edge {a}-{b} used {n} times in one direction");
            assert_eq!(edges.get(&(b, a)), Some(&1), "edge {a}-{b} has no twin");
        }
        f.vertices.len() as i64 - (edges.len() / 2) as i64 + f.faces.len() as i64
    }

    /// A 12 × 12 view from above (rays along z at x = `shift` + i, y = `shift` + j) with
    /// returns at z = 5 for 3 <= i, j <= 8 and none elsewhere, integrated and carved into a
    /// 14 × 14 × 10 grid of unit voxels from (−1, −1, −1).
    fn plateau_from_above(shift: f64) -> (DepthView, Volume) {
        let view = view_from_above([shift; 2], 1.0, [12, 12], |i, j| {
            if (3..9).contains(&i) && (3..9).contains(&j) {
                5.0
            } else {
                f64::NAN
            }
        });
        let vol = fused_volume(&view, [-1.0, -1.0, -1.0], [14, 14, 10], 2.0);
        (view, vol)
    }

    /// A box seen from above only: carving closes it against unseen space below.
    #[test]
    fn a_plateau_seen_from_above_closes_into_one_sphere() {
        let (view, vol) = plateau_from_above(0.0);
        let samples: Vec<DVec3> = (3..9)
            .flat_map(|i| (3..9).map(move |j| DVec3::new(i as f64, j as f64, 5.0)))
            .collect();
        let normals = vec![DVec3::Z; samples.len()];
        let fused = extract(&vol, &samples, &normals, &[&view]).unwrap();
        assert_eq!(euler(&fused), 2);
        // the top is measured and lies on the samples' plane
        let top: Vec<_> = fused
            .faces
            .iter()
            .zip(&fused.labels)
            .filter(|(_, &l)| l == MEASURED)
            .collect();
        assert!(!top.is_empty());
        assert!(
            fused.labels.contains(&FILLED),
            "the bottom closes against the border"
        );
        for v in &fused.vertices {
            assert!(v.z <= 5.0 + 1e-9);
        }
    }

    /// A box seen from above, its sides never sampled: they close where the rays without a
    /// return begin, halfway between the last ray on the box and the first beside it, not
    /// on the nodes' midpoints.
    #[test]
    fn walls_no_sample_saw_close_where_the_rays_footprints_meet() {
        // rays at x = 0.3 + i, y = 0.3 + j; returns for 3 <= i, j <= 8: the footprint's
        // sides are at 2.8 and 8.8 (halfway to the rays without return)
        let (view, vol) = plateau_from_above(0.3);
        let fused = extract(&vol, &[], &[], &[&view]).unwrap();
        assert_eq!(euler(&fused), 2);
        // vertices on the sides, away from the top (z = 5), the bottom (the border) and the
        // vertical edges (a corner cell's vertex is the mean of its crossings on both sides)
        let mut sides = 0;
        for v in fused.vertices.iter().filter(|v| v.z > 1.0 && v.z < 3.0) {
            let (across_x, across_y) = (v.y > 3.5 && v.y < 8.0, v.x > 3.5 && v.x < 8.0);
            let off = if across_x {
                (v.x - 2.8).abs().min((v.x - 8.8).abs())
            } else if across_y {
                (v.y - 2.8).abs().min((v.y - 8.8).abs())
            } else {
                continue;
            };
            assert!(off < 0.02, "{v:?} is {off} off the footprint's side");
            sides += 1;
        }
        assert!(sides > 20);
    }

    /// A plateau (a box's top at z = 12 over 10 <= x, y < 25) seen from above in a grid
    /// of 6 × 6 × 4 blocks, most of them uniform: the walk over the blocks where the sides
    /// may differ gives the mesh the walk over every node gives, vertex for vertex.
    #[test]
    fn walking_the_active_blocks_gives_the_mesh_of_walking_every_node() {
        let view = view_from_above([0.0; 2], 1.0, [44, 44], |i, j| {
            if (10..25).contains(&i) && (10..25).contains(&j) && (j * 44 + i) % 13 != 5 {
                12.0 + 0.01 * (i as f64 - 0.3 * j as f64)
            } else {
                f64::NAN
            }
        });
        let vol = fused_volume(&view, [-1.7, -2.2, -1.4], [46, 45, 27], 3.0);
        let samples: Vec<DVec3> = (10..25)
            .flat_map(|i| (10..25).map(move |j| DVec3::new(i as f64, j as f64, 12.0)))
            .collect();
        let normals = vec![DVec3::Z; samples.len()];
        let sparse = extract(&vol, &samples, &normals, &[&view]).unwrap();
        let mut all = Sides::new(&vol).unwrap();
        all.activate_all();
        let dense = extract_from(
            &vol,
            all,
            &samples,
            &normals,
            &[&view],
            (&Progress::new(), 0),
        )
        .unwrap();
        assert!(sparse.faces.len() > 1000);
        assert_eq!(sparse.repaired, dense.repaired);
        assert_eq!(sparse.faces, dense.faces);
        assert_eq!(sparse.labels, dense.labels);
        assert_eq!(sparse.vertices, dense.vertices);
        let [distances, _] = vol.allocated();
        assert!(distances < 46 * 45 * 27 / 2, "{distances}");
    }

    #[test]
    fn two_columns_touching_along_an_edge_are_repaired_into_one_manifold() {
        // rays through pixels (2, 2) and (3, 3) meet a surface above the grid (so the grid
        // is behind it: unseen); every other ray has no return and carves
        let view = view_from_above([0.0; 2], 1.0, [6, 6], |i, j| {
            if [(2, 2), (3, 3)].contains(&(i, j)) {
                100.0
            } else {
                f64::NAN
            }
        });
        let mut vol = Volume::new([0.0; 3], 1.0, [6, 6, 6], 1.0).unwrap();
        vol.carve(&view).unwrap();
        assert_eq!(vol.evidence(vol.index(2, 2, 3)), Evidence::Unseen);
        assert_eq!(vol.evidence(vol.index(2, 3, 3)), Evidence::Empty);
        let fused = extract(&vol, &[], &[], &[&view]).unwrap();
        assert!(fused.repaired > 0);
        assert_eq!(euler(&fused), 2);
        assert!(fused.labels.contains(&FILLED));
    }

    /// The progress reaches what it planned, and the mesh is the uncounted call's.
    #[test]
    fn the_counted_extraction_reaches_its_plan() {
        let (view, vol) = plateau_from_above(0.0);
        let progress = Progress::new();
        let counted = extract_counted(&vol, &[], &[], &[&view], &progress).unwrap();
        let planned = EXTRACT_WEIGHTS.iter().sum::<u64>() * 10; // 10 slices along z
        assert_eq!((progress.done(), progress.total()), (planned, planned));
        assert_eq!(
            counted.faces,
            extract(&vol, &[], &[], &[&view]).unwrap().faces
        );
    }
}
