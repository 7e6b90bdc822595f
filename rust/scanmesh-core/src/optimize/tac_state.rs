//! Incremental total absolute curvature of a triangulation under edge flips.
//!
//! The energy is `E = Σ_v f(S_v)` over interior vertices, with `S_v` the sum of the 3-D
//! corner angles at v and `f(S) = |2π − S|^p` (p ≥ 1; p = 1 is the tac 1-norm). Corner
//! angles are cached per half-edge slot and angle sums per vertex, so a proposed flip
//! computes only the six corner angles of its two new triangles and changes the energy of
//! its four corners alone. Flips of coplanar quadrilaterals (flat parts of a scan) change
//! no angle sum, so they are applied without computing any angle: their two triangles are
//! marked stale (one bit each) and their corners recomputed only when a later evaluation
//! reads them. Both annealing and LOP use this one state.

use crate::budget::{try_collect, try_filled, try_grow};
use crate::geometry::triangle_angles;
use crate::geometry::unit_square;
use crate::geometry::Normalizer;
use crate::mesh::locality::{prefetch, Relabel};
use crate::mesh::NONE;
use crate::mesh::{convex_quad, next, prev, HalfEdgeMesh};
use crate::optimize::fixed::FixedEdges;
use crate::{Error, Result};
use glam::DVec3;
use std::f64::consts::TAU;
use std::sync::Arc;

/// A flip that has been evaluated but not applied.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct FlipMove {
    /// The interior half-edge to flip.
    pub h: u32,
    /// Energy after minus energy before (exactly 0 for a coplanar quadrilateral).
    pub delta_energy: f64,
    /// Change of the angle sums (radians) of the corners (a, b, c, d) of
    /// [`HalfEdgeMesh::quad`]; zeros for a coplanar quadrilateral.
    pub sum_deltas: [f64; 4],
    /// Corner angles (radians) of the two new triangles in slot order h, next(h), prev(h),
    /// t, next(t), prev(t) as [`HalfEdgeMesh::flip`] rewrites them; NaN when not computed
    /// (a coplanar flip evaluated without [`Detail::Shape`]).
    pub new_angles: [f64; 6],
    /// Smallest 3-D angle of the two triangles before the flip (radians; NaN if not computed).
    pub old_min_angle: f64,
    /// Smallest 3-D angle of the two triangles after the flip (radians; NaN if not computed).
    pub new_min_angle: f64,
    /// How squarely the two triangles face the line of sight before the flip: the smaller
    /// |cos| of the angle between a normal and the sight, the sine of the angle between the
    /// plane and the sight (0: edge-on, a curtain; NaN without a sight, see
    /// [`TacState::with_sight`], or if not computed).
    pub old_facing: f64,
    /// The same after the flip.
    pub new_facing: f64,
    /// The four corners are coplanar: angle sums cannot change, the move is an exact tie.
    pub coplanar: bool,
}

/// What [`TacState::propose`] did with a half-edge.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Proposal {
    /// A boundary edge, or a quadrilateral that is not strictly convex: no move.
    NotFlippable,
    /// A coplanar quadrilateral: an exact tie, already flipped (energy unchanged).
    FlippedTie,
    /// Any other flippable edge, evaluated with [`Detail::Energy`] and not applied.
    Move(FlipMove),
}

/// How much a caller needs to know about a move.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Detail {
    /// The energy change only: coplanar moves skip every angle (annealing).
    Energy,
    /// Also the smallest angles before and after (tie-breaking in the polish).
    Shape,
}

/// A quadrilateral counts as coplanar when the sine of its bend across either diagonal is
/// at most this: angle sums then change far below the tie tolerance. Scans of machined
/// parts are mostly flat, and there every flip is such an exact tie.
///
/// Why the bend and not the volume: a volume small against the longest edge cubed (the
/// former test) still bends a quadrilateral of slivers or of tiny triangles next to long
/// ones (clustered points) by a visible angle, and such a "tie" changed an angle sum by
/// 9e-8 without the state knowing (found by the property tests).
pub const COPLANAR_RELATIVE: f64 = 1e-13;

/// With `planar_ties`, a corner is flat up to the noise when its tac is at most this many
/// tie tolerances (per unit of p: tac <= NOISE_TAC × tie_tolerance^(1/p)): nearly every
/// corner of a flat noisy scan is below it and a crease's are above, and 2 kept the noisy
/// rod's height error closer to Delaunay's than 1 (figures in docs/benchmarks/noise.md,
/// "Figures behind the core's constants").
pub const NOISE_TAC: f64 = 2.0;

/// Peak memory of [`TacState::from_input`] and one run of LOP on it, per point, checked
/// before the state is built: a whole LOP run (its Delaunay included) needs about 470 bytes
/// a point more address space (bisected on 200,000 and 800,000 points,
/// docs/benchmarks/memory.md), plus room.
const STATE_PEAK_BYTES_PER_POINT: u64 = 500;

/// What the state's failed allocations name.
const STATE: &str = "the flip state";

/// Optional lines for [`TacState::prefetch`]: each helps on some inputs and crowds the
/// useful hints (a core tracks only so many misses) on others.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct PrefetchHints {
    /// The two triangles' cached corner angles: read only by proposals that measure angles
    /// (curved quadrilaterals), not by ties or unflippable edges.
    pub corners: bool,
    /// What a flip writes outside its two triangles (outer twins, `vertex_edge`): stores
    /// stall the loop only when they miss every cache, on large states.
    pub flip_writes: bool,
}

/// Mesh, positions and the caches that make a flip's energy change O(1).
///
/// Memory: about 165 bytes per vertex (64 for its record, 48 for the corner angles of its
/// six half-edges, 53 for the mesh), the positions held once, in the records.
#[derive(Debug, Clone)]
pub struct TacState {
    mesh: HalfEdgeMesh,
    corner: Vec<f64>,
    // One bit per triangle: its `corner` entries are out of date (a coplanar flip left them).
    // A bit set instead of NaN written into `corner`: a tie flip then touches no corner line
    // at all, and the set (one bit per triangle) stays in L1/L2.
    stale: Vec<u64>,
    vert: Vec<VertexRecord>,
    p: f64,
    energy: f64,
    // Unit line of sight in the positions' frame (normalizing scales and shifts, so it is
    // the caller's direction); None: moves measure no facing.
    sight: Option<DVec3>,
    // Edges no flip may remove (shared by the chains' copies); None: every edge may flip.
    fixed: Option<Arc<FixedEdges>>,
}

/// All a proposal reads about one vertex, in one 64-byte cache line: a random edge's four
/// corners then cost four lines instead of up to twelve (planar position, 3-D position and
/// angle sum in separate arrays), and one prefetch each.
#[derive(Debug, Clone, Copy, PartialEq)]
#[repr(C, align(64))]
struct VertexRecord {
    uv: [f64; 2],
    xyz: DVec3,
    /// Sum of the corner angles around the vertex (radians).
    sum: f64,
    interior: bool,
}

impl VertexRecord {
    /// Interior, with a tac above `floor` (radians).
    #[inline(always)]
    fn above(&self, floor: f64) -> bool {
        self.interior && (TAU - self.sum).abs() > floor
    }
}

/// True when the quadrilateral of triangles (a, b, c) and (b, a, d) is flat (see
/// [`COPLANAR_RELATIVE`]): its bend across diagonal ab and across cd. The sine of the
/// dihedral angle across ab is `6V·|ab| / (|n_abc|·|n_bad|)` for the tetrahedron's volume V
/// and the triangles' normals n (twice their areas), so the test is scale-free and has no
/// division: `(6V)² |ab|² ≤ ε² |n1|² |n2|²`, and the same for cd. A degenerate triangle
/// (zero normal) is never flat: its angles are computed. O(1).
#[inline]
pub fn is_coplanar(a: DVec3, b: DVec3, c: DVec3, d: DVec3) -> bool {
    let (ab, ac, ad) = (b - a, c - a, d - a);
    let volume6 = ab.dot(ac.cross(ad));
    let v2 = volume6 * volume6;
    let e2 = COPLANAR_RELATIVE * COPLANAR_RELATIVE;
    let cd = d - c;
    let (bc, bd) = (c - b, d - b);
    let bent = |diagonal: DVec3, n1: DVec3, n2: DVec3| {
        v2 * diagonal.length_squared() >= e2 * n1.length_squared() * n2.length_squared()
    };
    !(bent(ab, ab.cross(ac), ab.cross(ad)) || bent(cd, ac.cross(ad), bc.cross(bd)))
}

/// How squarely triangle (a, b, c) faces the unit direction `sight`: |cos| of the angle
/// between its normal and `sight` (1: face-on, 0: edge-on); NaN for a degenerate triangle,
/// which no rule judges. O(1).
#[inline]
pub fn facing(sight: DVec3, a: DVec3, b: DVec3, c: DVec3) -> f64 {
    let n = (b - a).cross(c - a);
    n.dot(sight).abs() / n.length()
}

/// Energy contribution `|2π − S|^p` of an interior vertex with angle sum `s`. O(1).
#[inline]
pub fn vertex_energy(s: f64, p: f64) -> f64 {
    let tac = (TAU - s).abs();
    if p == 1.0 {
        tac
    } else if p == 2.0 {
        tac * tac
    } else {
        tac.powf(p)
    }
}

impl TacState {
    /// Builds the caches. `uv` are the planar positions the flips are checked in (use
    /// [`crate::geometry::unit_square`] of the projection), `xyz` the 3-D positions the angles
    /// are measured on (normalize with `crate::geometry::Normalizer` to be scale-safe). O(m).
    pub fn new(mesh: HalfEdgeMesh, uv: Vec<[f64; 2]>, xyz: Vec<DVec3>, p: f64) -> Result<Self> {
        let mut state = TacState::without_sums(mesh, uv, xyz, p)?;
        state.measure_sums();
        Ok(state)
    }

    /// Like [`new`](Self::new), but with each vertex's angle sum and interior flag given
    /// (`sums[v]`, `interior[v]`) instead of measured on `mesh`: for a piece cut out of a
    /// larger triangulation (see [`crate::optimize::tiles`]), whose border vertices have triangles
    /// outside the piece. The energy counts the given interior vertices. O(m).
    pub(crate) fn with_vertex_sums(
        mesh: HalfEdgeMesh,
        uv: Vec<[f64; 2]>,
        xyz: Vec<DVec3>,
        p: f64,
        sums: &[f64],
        interior: &[bool],
    ) -> Result<Self> {
        let mut state = TacState::without_sums(mesh, uv, xyz, p)?;
        for ((r, &s), &i) in state.vert.iter_mut().zip(sums).zip(interior) {
            r.sum = s;
            r.interior = i;
        }
        state.energy = state.recompute_energy();
        Ok(state)
    }

    /// The same vertices (positions, p) on another triangulation `mesh` of them, reusing
    /// this state's arrays: what [`new`](Self::new) would build from `mesh` and the
    /// positions, bit for bit, without a second state in memory (the polish after
    /// annealing builds its state from the best mesh so). O(m).
    pub fn with_mesh(self, mesh: HalfEdgeMesh) -> Result<Self> {
        if mesh.n_vertices() != self.mesh.n_vertices() {
            return Err(Error::InvalidParameter {
                name: "mesh",
                value: format!("{} vertices", mesh.n_vertices()),
                expected: "the state's vertices",
            });
        }
        let TacState {
            mesh: old,
            mut corner,
            mut stale,
            vert,
            p,
            sight,
            fixed,
            ..
        } = self;
        drop(old);
        corner.clear();
        try_grow(STATE, &mut corner, mesh.n_half_edges())?;
        corner.resize(mesh.n_half_edges(), 0.0);
        stale.clear();
        try_grow(STATE, &mut stale, mesh.n_triangles().div_ceil(64))?;
        stale.resize(mesh.n_triangles().div_ceil(64), 0);
        let mut state = TacState::assemble(mesh, vert, corner, stale, p);
        state.sight = sight;
        state.fixed = fixed;
        state.measure_sums();
        Ok(state)
    }

    /// Every vertex's angle sum by a walk of its fan, and the energy. O(m).
    fn measure_sums(&mut self) {
        for v in 0..self.mesh.n_vertices() as u32 {
            self.vert[v as usize].sum = self.fan_sum(v);
        }
        self.energy = self.recompute_energy();
    }

    /// A state of `mesh` (reanchored) with the records `vert` (interior flags set from
    /// `mesh`, sums kept), the buffers `corner` (one per half-edge) and `stale` (one bit
    /// per triangle, all clear), every corner angle measured; energy 0. O(m).
    fn assemble(
        mut mesh: HalfEdgeMesh,
        mut vert: Vec<VertexRecord>,
        corner: Vec<f64>,
        stale: Vec<u64>,
        p: f64,
    ) -> Self {
        // Anchors fix where each fan walk starts, and with it the rounding of the angle sums:
        // recomputed from the connectivity, they do not depend on how a mesh was flipped.
        mesh.reanchor();
        for (v, r) in vert.iter_mut().enumerate() {
            r.interior = mesh.is_interior(v as u32);
        }
        let mut state = TacState {
            corner,
            stale,
            vert,
            mesh,
            p,
            energy: 0.0,
            sight: None,
            fixed: None,
        };
        for t in 0..state.mesh.n_triangles() {
            let [a, b, c] = state.mesh.triangle(t).map(|v| state.vert[v as usize].xyz);
            let angles = triangle_angles(a, b, c);
            state.corner[3 * t..3 * t + 3].copy_from_slice(&angles);
        }
        state
    }

    /// What [`new`](Self::new) and [`with_vertex_sums`](Self::with_vertex_sums) share: the
    /// checks, the anchors, the vertex records (interior as on `mesh`, sums 0) and every
    /// corner angle; energy 0. O(m).
    fn without_sums(
        mesh: HalfEdgeMesh,
        uv: Vec<[f64; 2]>,
        xyz: Vec<DVec3>,
        p: f64,
    ) -> Result<Self> {
        if !(p.is_finite() && p >= 1.0) {
            return Err(Error::InvalidParameter {
                name: "p",
                value: p.to_string(),
                expected: "a finite p >= 1",
            });
        }
        if uv.len() != mesh.n_vertices() || xyz.len() != mesh.n_vertices() {
            return Err(Error::InvalidParameter {
                name: "positions",
                value: format!(
                    "{} planar and {} 3-D for {} vertices",
                    uv.len(),
                    xyz.len(),
                    mesh.n_vertices()
                ),
                expected: "one of each per vertex",
            });
        }
        let vert = try_collect(
            STATE,
            uv.iter().zip(&xyz).map(|(&uv, &xyz)| VertexRecord {
                uv,
                xyz,
                sum: 0.0,
                interior: false,
            }),
        )?;
        // The positions live on in the records only.
        drop((uv, xyz));
        let corner = try_filled(STATE, 0.0, mesh.n_half_edges())?;
        let stale = try_filled(STATE, 0, mesh.n_triangles().div_ceil(64))?;
        Ok(TacState::assemble(mesh, vert, corner, stale, p))
    }

    /// The sum of the 3-D corner angles around `v` (radians), as maintained. O(1).
    pub fn angle_sum(&self, v: u32) -> f64 {
        self.vert[v as usize].sum
    }

    /// Builds the state from input-ordered data: normalizes positions (scale-free), checks that
    /// `triangles` form a valid planar triangulation of `uv`, and relabels everything in
    /// Z-order for memory locality. Map results back with the returned [`Relabel`].
    /// `triangles` are taken, and freed once the mesh holds them. O(m log m).
    pub fn from_input(
        points: &[DVec3],
        uv: &[[f64; 2]],
        triangles: Vec<[u32; 3]>,
        p: f64,
    ) -> Result<(Self, Relabel)> {
        crate::geometry::check_finite(points)?;
        if points.len() != uv.len() {
            return Err(Error::InvalidParameter {
                name: "positions",
                value: format!("{} points and {} planar positions", points.len(), uv.len()),
                expected: "one planar position per point",
            });
        }
        crate::criteria::check_faces(points.len(), &triangles)?;
        crate::budget::check_stage(
            || format!("the flip state of {} points", points.len()),
            STATE_PEAK_BYTES_PER_POINT.saturating_mul(points.len() as u64),
        )?;
        let relabel = Relabel::morton(uv)?;
        // One copy of the triangles at a time, none once the mesh holds them.
        let local = relabel.triangles_to_local(&triangles)?;
        drop(triangles);
        let mesh = HalfEdgeMesh::from_triangles(points.len(), &local)?;
        drop(local);
        let unit_uv = relabel.vertices(&unit_square(uv))?;
        mesh.validate(&unit_uv)?;
        let unit_xyz = relabel.vertices(&Normalizer::fit(points).apply_all(points))?;
        Ok((TacState::new(mesh, unit_uv, unit_xyz, p)?, relabel))
    }

    /// Angle sum around `v` from the corner cache, walking its fan. O(degree).
    fn fan_sum(&mut self, v: u32) -> f64 {
        if !self.mesh.is_used(v) {
            return 0.0;
        }
        let mut total = 0.0;
        let first = self
            .mesh
            .fan(v)
            .next()
            .expect("a used vertex has a half-edge");
        let mut h = first;
        loop {
            let k = (h % 3) as usize;
            total += self.fresh_corners((h / 3) as usize)[k];
            h = self.mesh.twin(prev(h));
            if h == NONE || h == first {
                break;
            }
        }
        total
    }

    /// A copy whose allocations may fail instead of aborting: for copies an option
    /// multiplies (annealing chains). O(m + n).
    pub fn try_clone(&self) -> std::result::Result<Self, std::collections::TryReserveError> {
        use crate::budget::try_copy;
        Ok(TacState {
            mesh: self.mesh.try_clone()?,
            corner: try_copy(&self.corner)?,
            stale: try_copy(&self.stale)?,
            vert: try_copy(&self.vert)?,
            p: self.p,
            energy: self.energy,
            sight: self.sight,
            fixed: self.fixed.clone(),
        })
    }

    /// The state with `sight`, the direction towards the scanner (any length, either sign),
    /// so that every measured move also gives how squarely its triangles face it
    /// ([`FlipMove::old_facing`], [`FlipMove::new_facing`]) for the curtain rule of
    /// [`TacOrder`](crate::optimize::lop::TacOrder); None: no sight. A zero or non-finite
    /// `sight` is an error naming it. O(1).
    pub fn with_sight(mut self, sight: Option<DVec3>) -> Result<Self> {
        self.sight = match sight {
            None => None,
            Some(s) => Some(s.try_normalize().ok_or_else(|| Error::InvalidParameter {
                name: "sight",
                value: format!("{s:?}"),
                expected: "a finite, non-zero direction",
            })?),
        };
        Ok(self)
    }

    /// The state with the edges `fixed` kept: no flip removes one (they are never
    /// flippable, never live), so every optimizer of this state (LOP, annealing, its
    /// descent and polish) keeps them; None: every edge may flip. The set must be over the
    /// state's vertices, in its labels. O(1).
    pub fn with_fixed(mut self, fixed: Option<FixedEdges>) -> Result<Self> {
        if let Some(f) = &fixed {
            if f.n_vertices() != self.mesh.n_vertices() {
                return Err(Error::InvalidParameter {
                    name: "fixed edges",
                    value: format!("a set over {} vertices", f.n_vertices()),
                    expected: "a set over the state's vertices",
                });
            }
        }
        self.fixed = fixed.map(Arc::new);
        Ok(self)
    }

    /// The edges kept by [`with_fixed`](Self::with_fixed), if any. O(1).
    pub fn fixed(&self) -> Option<&FixedEdges> {
        self.fixed.as_deref()
    }

    /// True when the edge {a, b} is fixed. O(1) without fixed edges.
    #[inline(always)]
    fn is_fixed(&self, a: u32, b: u32) -> bool {
        self.fixed.as_ref().is_some_and(|f| f.contains(a, b))
    }

    /// The unit line of sight given by [`with_sight`](Self::with_sight), if any. O(1).
    pub fn sight(&self) -> Option<DVec3> {
        self.sight
    }

    /// Bytes its arrays take (for memory estimates). O(1).
    pub fn heap_bytes(&self) -> u64 {
        use std::mem::size_of_val;
        self.mesh.heap_bytes()
            + (size_of_val(&self.corner[..])
                + size_of_val(&self.stale[..])
                + size_of_val(&self.vert[..])) as u64
    }

    /// The triangulation; unanchored after [`propose`](Self::propose) flipped a tie. O(1).
    pub fn mesh(&self) -> &HalfEdgeMesh {
        &self.mesh
    }

    /// Brings the mesh's vertex anchors up to date (see [`HalfEdgeMesh::reanchor`]). O(1)
    /// when they are, else O(m).
    pub fn reanchor(&mut self) {
        self.mesh.reanchor();
    }

    /// Planar positions, copied out of the vertex records. Errors: an
    /// [`Error::OutOfMemory`] for the copy. O(n).
    pub fn uv(&self) -> Result<Vec<[f64; 2]>> {
        try_collect("the planar positions", self.vert.iter().map(|r| r.uv))
    }

    /// 3-D positions, copied out of the vertex records. Errors: an [`Error::OutOfMemory`]
    /// for the copy. O(n).
    pub fn xyz(&self) -> Result<Vec<DVec3>> {
        try_collect("the 3-D positions", self.vert.iter().map(|r| r.xyz))
    }

    /// Planar positions of the quadrilateral (a, b, c, d) of [`HalfEdgeMesh::quad`] of the
    /// interior half-edge `h` when each of its corners is flat up to the noise of
    /// `tie_tolerance` (a boundary vertex, or a tac at most
    /// `NOISE_TAC` × tie_tolerance^(1/p)), else `None`. O(1).
    pub fn flat_quad_uv(&self, h: u32, tie_tolerance: f64) -> Option<[[f64; 2]; 4]> {
        let floor = NOISE_TAC * tie_tolerance.powf(1.0 / self.p);
        let t = self.mesh.twin(h);
        let quad = self.mesh.quad(h, t).map(|v| &self.vert[v as usize]);
        if quad.iter().any(|r| r.above(floor)) {
            return None;
        }
        Some(quad.map(|r| r.uv))
    }

    /// Current energy, maintained incrementally. O(1).
    pub fn energy(&self) -> f64 {
        self.energy
    }

    /// The energy exponent p.
    pub fn p(&self) -> f64 {
        self.p
    }

    /// Energy recomputed from the cached angle sums, resetting accumulated rounding. O(n).
    pub fn resync_energy(&mut self) -> f64 {
        self.energy = self.recompute_energy();
        self.energy
    }

    /// Energy from the cached vertex sums. O(n).
    fn recompute_energy(&self) -> f64 {
        self.vert
            .iter()
            .filter(|r| r.interior)
            .map(|r| vertex_energy(r.sum, self.p))
            .sum()
    }

    /// Energy computed from scratch from positions and connectivity, sharing no cache: the
    /// reference the incremental value is tested against (it panics when its copies do not
    /// fit in memory). O(m).
    pub fn energy_from_scratch(&self) -> f64 {
        let copies = "the reference's copies fit in memory";
        let (xyz, triangles) = (
            self.xyz().expect(copies),
            self.mesh.triangles().expect(copies),
        );
        let sums = crate::criteria::angle_sums(&xyz, &triangles).expect(copies);
        sums.iter()
            .zip(&self.vert)
            .filter(|(_, r)| r.interior)
            .map(|(&s, _)| vertex_energy(s, self.p))
            .sum()
    }

    /// Number of triangles whose smallest 3-D corner angle is below `angle` (radians). O(m).
    pub fn count_slivers(&mut self, angle: f64) -> usize {
        (0..self.mesh.n_triangles())
            .filter(|&t| {
                self.fresh_corners(t)
                    .into_iter()
                    .fold(f64::INFINITY, f64::min)
                    < angle
            })
            .count()
    }

    /// Number of half-edges that have a twin (twice the number of interior edges). O(m).
    pub fn count_interior_half_edges(&self) -> usize {
        (0..self.mesh.n_half_edges() as u32)
            .filter(|&h| self.mesh.twin(h) != NONE)
            .count()
    }

    /// The three corner angles of triangle `t`, recomputing them if a coplanar flip left
    /// them stale. O(1).
    #[inline]
    fn fresh_corners(&mut self, t: usize) -> [f64; 3] {
        let word = &mut self.stale[t / 64];
        let bit = 1u64 << (t % 64);
        let k = &mut self.corner[3 * t..3 * t + 3];
        if *word & bit != 0 {
            *word &= !bit;
            let [a, b, c] = self.mesh.triangle(t).map(|v| self.vert[v as usize].xyz);
            k.copy_from_slice(&triangle_angles(a, b, c));
        }
        [k[0], k[1], k[2]]
    }

    /// Prefetch hints for a later [`evaluate`](Self::evaluate)`(h)` and [`apply`](Self::apply),
    /// in three stages that a caller issues a few proposals apart, each reading only what the
    /// previous stage requested: 0, the slots of h's triangle; 1, those of its twin's; 2,
    /// the four corners' positions and sums, and what `PrefetchHints` asks for. Hints
    /// never change results (a flip in between only makes one useless). O(1).
    #[inline(always)]
    pub fn prefetch(&self, h: u32, stage: usize, hints: PrefetchHints) {
        // A triangle's three corners (24 bytes) can straddle two lines: hint both ends.
        let corner_lines = |t: u32| {
            if hints.corners {
                prefetch(&self.corner, 3 * t as usize);
                prefetch(&self.corner, 3 * t as usize + 2);
            }
        };
        match stage {
            0 => {
                self.mesh.prefetch_triangle(h / 3);
                corner_lines(h / 3);
            }
            1 => {
                let t = self.mesh.twin(h);
                if t != NONE {
                    self.mesh.prefetch_triangle(t / 3);
                    corner_lines(t / 3);
                }
            }
            _ => {
                if let Some((t, quad)) = self.mesh.twin_and_quad(h) {
                    for v in quad {
                        prefetch(&self.vert, v as usize);
                    }
                    if hints.flip_writes {
                        self.mesh.prefetch_flip_writes(h, t, quad);
                    }
                }
            }
        }
    }

    /// The convexity and coplanarity tests shared by [`evaluate`](Self::evaluate) and
    /// [`propose`](Self::propose): the twin, the corners, their 3-D positions and whether
    /// they are coplanar, or `None` when `h` cannot flip (boundary, or not strictly convex in
    /// the plane; the test of `HalfEdgeMesh::can_flip` on the packed positions). O(1).
    #[inline(always)]
    fn flippable(&self, h: u32) -> Option<(u32, [u32; 4], [DVec3; 4], bool)> {
        let (t, quad) = self.mesh.twin_and_quad(h)?;
        let [ra, rb, rc, rd] = quad.map(|v| &self.vert[v as usize]);
        if !convex_quad(ra.uv, rb.uv, rc.uv, rd.uv) || self.is_fixed(quad[0], quad[1]) {
            return None;
        }
        let pos = [ra.xyz, rb.xyz, rc.xyz, rd.xyz];
        Some((t, quad, pos, is_coplanar(pos[0], pos[1], pos[2], pos[3])))
    }

    /// True when `h` can flip (interior, strictly convex quadrilateral) and one of its four
    /// corners is an interior vertex whose tac exceeds `floor` (radians): the edges
    /// `crate::optimize::active` draws annealing proposals from. O(1).
    #[inline]
    pub fn is_live(&self, h: u32, floor: f64) -> bool {
        let Some((_, quad)) = self.mesh.twin_and_quad(h) else {
            return false;
        };
        let [ra, rb, rc, rd] = quad.map(|v| &self.vert[v as usize]);
        [ra, rb, rc, rd].iter().any(|r| r.above(floor))
            && convex_quad(ra.uv, rb.uv, rc.uv, rd.uv)
            && !self.is_fixed(quad[0], quad[1])
    }

    /// True when `h` is interior and one of its four corners is an interior vertex whose
    /// tac exceeds `floor` (radians): [`is_live`](Self::is_live) without the convexity
    /// test, which a proposal makes anyway. O(1).
    #[inline]
    pub fn has_corner_above(&self, h: u32, floor: f64) -> bool {
        self.mesh
            .twin_and_quad(h)
            .is_some_and(|(_, quad)| quad.iter().any(|&v| self.vert[v as usize].above(floor)))
    }

    /// True when `v` is an interior vertex whose tac exceeds `floor` (radians). O(1).
    #[inline]
    pub fn is_above_floor(&self, v: u32, floor: f64) -> bool {
        self.vert[v as usize].above(floor)
    }

    /// Evaluates flipping `h`: `None` when it is a boundary edge or its quadrilateral is not
    /// strictly convex in the plane. O(1): two orientations, a triple product and, unless the
    /// quadrilateral is coplanar and `detail` is `Energy`, six corner angles.
    #[inline]
    pub fn evaluate(&mut self, h: u32, detail: Detail) -> Option<FlipMove> {
        let (t, quad, pos, coplanar) = self.flippable(h)?;
        if coplanar && detail == Detail::Energy {
            let nan = f64::NAN;
            return Some(FlipMove {
                h,
                delta_energy: 0.0,
                sum_deltas: [0.0; 4],
                new_angles: [nan; 6],
                old_min_angle: nan,
                new_min_angle: nan,
                old_facing: nan,
                new_facing: nan,
                coplanar,
            });
        }
        Some(self.evaluate_angles(h, t, quad, pos, coplanar))
    }

    /// One annealing proposal of `h`: like [`evaluate`](Self::evaluate) with
    /// [`Detail::Energy`], except that a coplanar quadrilateral (an exact tie, which any
    /// Metropolis rule accepts) is flipped at once, as [`apply`](Self::apply) would, without
    /// building a [`FlipMove`]: the common case on scans of machined parts. Such a flip
    /// leaves the mesh unanchored ([`HalfEdgeMesh::flip_unanchored`]): call
    /// [`reanchor`](Self::reanchor) before walking fans (LOP does). O(1).
    #[inline]
    pub fn propose(&mut self, h: u32) -> Proposal {
        match self.flippable(h) {
            None => Proposal::NotFlippable,
            Some((t, _, _, true)) => {
                self.mesh.flip_unanchored(h);
                self.mark_stale(h, t);
                Proposal::FlippedTie
            }
            Some((t, quad, pos, false)) => {
                Proposal::Move(self.evaluate_angles(h, t, quad, pos, false))
            }
        }
    }

    /// Marks the corner angles of the triangles of slots `h` and `t` as unknown. O(1).
    #[inline(always)]
    fn mark_stale(&mut self, h: u32, t: u32) {
        for tri in [h / 3, t / 3] {
            self.stale[tri as usize / 64] |= 1 << (tri % 64);
        }
    }

    /// The angle part of [`evaluate`](Self::evaluate) for the convex quadrilateral of `h`
    /// (twin `t`, corners `quad`, 3-D positions `pos`). Kept out of line so that the tie
    /// path, most proposals on scans of machined parts, stays small (fewer registers
    /// saved, smaller frame). O(1).
    #[inline(never)]
    fn evaluate_angles(
        &mut self,
        h: u32,
        t: u32,
        quad: [u32; 4],
        pos: [DVec3; 4],
        coplanar: bool,
    ) -> FlipMove {
        let [pa, pb, pc, pd] = pos;
        let [d0, c0, a0] = triangle_angles(pd, pc, pa);
        let [c1, d1, b1] = triangle_angles(pc, pd, pb);
        let new_angles = [d0, c0, a0, c1, d1, b1];
        let (ko, kt) = (
            self.fresh_corners((h / 3) as usize),
            self.fresh_corners((t / 3) as usize),
        );
        // Slot order within each triangle starts at its first slot; rotate to h and t.
        let (oh, ot) = ((h % 3) as usize, (t % 3) as usize);
        let old = [
            ko[oh],
            ko[(oh + 1) % 3],
            ko[(oh + 2) % 3],
            kt[ot],
            kt[(ot + 1) % 3],
            kt[(ot + 2) % 3],
        ];
        let min6 = |x: [f64; 6]| x.iter().copied().fold(f64::INFINITY, f64::min);
        let mut delta_energy = 0.0;
        let mut sum_deltas = [0.0; 4];
        if !coplanar {
            sum_deltas = [
                a0 - (old[0] + old[4]),
                b1 - (old[1] + old[3]),
                c0 + c1 - old[2],
                d0 + d1 - old[5],
            ];
            for (v, delta) in quad.into_iter().zip(sum_deltas) {
                let r = &self.vert[v as usize];
                if r.interior {
                    let s = r.sum;
                    delta_energy += vertex_energy(s + delta, self.p) - vertex_energy(s, self.p);
                }
            }
        }
        let [old_facing, new_facing] = match self.sight {
            Some(s) => [
                facing(s, pa, pb, pc).min(facing(s, pb, pa, pd)),
                facing(s, pd, pc, pa).min(facing(s, pc, pd, pb)),
            ],
            None => [f64::NAN; 2],
        };
        FlipMove {
            h,
            delta_energy,
            sum_deltas,
            new_angles,
            old_min_angle: min6(old),
            new_min_angle: min6(new_angles),
            old_facing,
            new_facing,
            coplanar,
        }
    }

    /// Applies an evaluated move: flips and writes the six new corner angles (or marks them
    /// stale for a coplanar move, whose angle sums and energy do not change); otherwise adds
    /// each of the four corners' angle change to its sum and the move's change to the
    /// energy. O(1).
    pub fn apply(&mut self, mv: &FlipMove) {
        let h = mv.h;
        let t = self.mesh.twin(h);
        self.mesh.flip(h);
        let (th, tt) = ((h / 3) as usize, (t / 3) as usize);
        if mv.new_angles[0].is_nan() {
            self.mark_stale(h, t);
        } else {
            for (slot, angle) in [h, next(h), prev(h), t, next(t), prev(t)]
                .into_iter()
                .zip(mv.new_angles)
            {
                self.corner[slot as usize] = angle;
            }
            self.stale[th / 64] &= !(1 << (th % 64));
            self.stale[tt / 64] &= !(1 << (tt % 64));
        }
        if !mv.coplanar {
            // Why increments and not a walk of the four fans: the walk is a chain of
            // dependent loads over some 20 triangles, cache misses on large meshes. The
            // increments are the ones `evaluate` measured the energy change with, so the
            // sums and the energy stay consistent; each adds one rounding (about 1e-16
            // rad), far below what the energy tests allow (1e-9 relative to a recomputation).
            for (e, delta) in [prev(h), prev(t), next(h), h]
                .into_iter()
                .zip(mv.sum_deltas)
            {
                let v = self.mesh.start(e);
                self.vert[v as usize].sum += delta;
            }
            self.energy += mv.delta_energy;
        }
    }

    /// Consumes the state, returning the mesh, anchored. O(1), or O(m) after
    /// [`propose`](Self::propose) flipped ties.
    pub fn into_mesh(mut self) -> HalfEdgeMesh {
        self.mesh.reanchor();
        self.mesh
    }
}

#[cfg(test)]
pub(crate) mod tests;
