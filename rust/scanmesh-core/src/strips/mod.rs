//! Strips between consecutive scan lines: the lines, the Fuchs matrix solvers, the
//! stitching of the strips into one mesh, its check, depth jumps and repair.

mod check;
pub mod fuchs;
mod jumps;
pub(crate) mod lines;
mod repair;
pub(crate) mod stitch;

pub use lines::{detect_lines, segment_lines, ScanLines, DEFAULT_GAP_FACTOR};
pub use stitch::{stitch, stitch_part};

use crate::strips::fuchs::{Solver, Weight};
use crate::Error;
use glam::DVec3;

/// Points or triangles per rayon task in the passes over all of them: large enough that
/// splitting costs nothing next to the work, small enough to share a million among threads.
const BLOCK: usize = 1 << 14;

/// One strip to triangulate: the clipped segments, oriented along the scan direction.
struct Task {
    a: Vec<u32>,
    b: Vec<u32>,
    /// Where `a` and `b` lie in their oriented lines (for the planar check).
    a_at: check::Window,
    b_at: check::Window,
    /// Index of the first of the two lines (for inserting lone points).
    line: usize,
}

/// How each strip's path through the Fuchs matrix is chosen.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Method {
    /// The cheapest path, by the given solver.
    ShortestPath(Solver),
    /// Friedhoff's α-look-ahead with this α ≥ 1.
    Lookahead(usize),
}

/// Options of [`stitch()`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct StripParams {
    /// The path cost. Inside strips, lengths are measured in median steps of the scan and
    /// areas in squared median steps, so that criteria can be mixed and the result does
    /// not depend on the units; `TIE_BREAK` is added to the length coefficient.
    pub weight: Weight,
    /// Shortest path or look-ahead.
    pub method: Method,
    /// Whether to check that the mesh is a valid planar triangulation (as
    /// [`HalfEdgeMesh::validate`](crate::mesh::HalfEdgeMesh::validate)): O(n) in parallel
    /// from the strips when they fit together as strips do, else O(m α(m)) on the half-edge
    /// mesh. An invalid mesh (lines that
    /// cross or fold in the plane) is then made valid by dropping the conflicting
    /// triangles (`strips/repair.rs`), counted in [`StripMesh::dropped_overlaps`].
    pub check: bool,
    /// Depth-jump factor ([`DEFAULT_JUMP_FACTOR`](crate::triangulate::DEFAULT_JUMP_FACTOR);
    /// `∞` turns it off): [`stitch_part`] cuts lines where consecutive points jump in depth
    /// (`split_at_jumps`), and triangles that still bridge a jump by the rule of
    /// `bridging_triangles` (a strip between a line on top of a wall and one below it) are
    /// dropped, counted in [`StripMesh::dropped_jumps`].
    pub jump_factor: f64,
}

impl Default for StripParams {
    fn default() -> Self {
        StripParams {
            weight: Weight::ANGLE,
            method: Method::ShortestPath(Solver::Banded(crate::strips::fuchs::DEFAULT_BAND)),
            check: true,
            jump_factor: crate::triangulate::jumps::DEFAULT_JUMP_FACTOR,
        }
    }
}

/// The stitched mesh.
#[derive(Debug, Clone)]
pub struct StripMesh {
    /// Triangles in the caller's point indices, counter-clockwise in the plane.
    pub triangles: Vec<[u32; 3]>,
    /// Points that are in no triangle, ascending (duplicates of
    /// [`ScanLines`] included).
    pub unused: Vec<u32>,
    /// Number of strips (pairs of overlapping segments) triangulated.
    pub n_strips: usize,
    /// Sum of the strips' path costs (in the scaled units of [`StripParams::weight`]).
    pub cost: f64,
    /// Why the mesh is not a valid planar triangulation (crossing lines, a pinch), or
    /// `None` when it is (or when `check` was off).
    pub planar_error: Option<Error>,
    /// Triangles dropped for bridging a depth jump ([`StripParams::jump_factor`]).
    pub dropped_jumps: usize,
    /// Triangles dropped to make the mesh a valid planar triangulation (overlapping or
    /// folded where lines cross, then pinched fans), with `check` on.
    pub dropped_overlaps: usize,
    /// Points of [`StripMesh::unused`] that were in strips until every triangle of theirs
    /// was dropped (at a depth jump or an overlap), ascending.
    pub trimmed: Vec<u32>,
    /// Twice the planar signed area of the strips' triangles before the mesh was turned
    /// counter-clockwise (negative: they were turned round). Summed over the parts of a
    /// scan solved with [`stitch_part`], its sign says which
    /// way the whole scan turns.
    pub signed_area: f64,
}

/// What a run over some consecutive lines of a scan shares with the whole scan, so that
/// its strips are exactly the whole scan's strips between those lines
/// ([`stitch_part`]).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ScanContext {
    /// The whole scan's 3-D bounding box (lowest corner, highest corner): the unit box the
    /// path weights are computed in.
    pub bounds: [DVec3; 2],
    /// The largest |planar coordinate| of the whole scan: the power of two the planar
    /// positions are scaled by.
    pub largest_planar: f64,
    /// The whole scan's median planar step
    /// ([`ScanLines::median_step`](crate::strips::lines::ScanLines::median_step)): lengths in
    /// weights, and the gap length.
    pub median_step: f64,
    /// Whether the first line with a segment of two points or more is turned round in the
    /// whole scan (the orientation walk over the lines before it).
    pub first_turned: bool,
    /// The rows (start, end) of these points whose strips are returned, `None`: all. The
    /// lines around them are solved too and only inform what is dropped at depth jumps and
    /// overlaps (local spacings, conflicts, peeling), so those decisions at the border are
    /// the whole scan's; the triangles, counts, cost and area returned are those of the
    /// strips between lines within the rows.
    pub own_rows: Option<(usize, usize)>,
}
