//! scanmesh-core: triangulated surfaces from digitized scan-line points.
//!
//! Pure Rust, no Python. The public API is the list re-exported below (modules are
//! private); the modules, one concept each:
//! - `geometry`: corner angles (atan2 form), areas, exact orientation, normalization;
//! - `projection`: points to a plane (least squares, an axis, a normal);
//! - `delaunay`: planar Delaunay (delaunator checked exactly, else spade), input indices kept;
//! - `mesh`: flat half-edge triangulation with flips and `validate()`;
//! - `criteria`: max-min angle and tac (total absolute curvature) with p-norms;
//! - `trim`: removing long hull triangles so outlines and holes stay open;
//! - `tac_state`: incremental tac energy under flips;
//! - `locality`: Z-order relabelling so annealing's memory accesses stay close;
//! - `lop`: Lawson's greedy flipping for any criterion;
//! - `active`: the live edges annealing draws from (flips that can lower the energy);
//! - `anneal`: simulated annealing on tac;
//! - `budget`: what options may cost in work and memory, fallible copies;
//! - `ensemble`: independent annealing chains side by side, the best one kept;
//! - `tiles`: one annealing chain on several cores, the plane cut into stripes;
//! - `enumerate`: empty triangles and every triangulation of a small point set (exact checks);
//! - `lines`: scan lines detected from point order or given by id, split at gaps;
//! - `fuchs`: the Fuchs matrix between two lines: weights, α-look-ahead, shortest paths;
//! - `strips`: strips between consecutive lines stitched into one mesh (rayon);
//! - `text`: numeric text tables (XYZ, CSV rows) parsed from bytes.
// `deny`, not `forbid`: the one exception is the cache prefetch hint in `locality::prefetch`.
#![deny(unsafe_code)]
#![warn(missing_docs)]

mod budget;
mod criteria;
mod error;
mod exact;
mod geometry;
mod io;
mod mesh;
mod optimize;
mod projection;
mod strips;
#[cfg(test)]
mod testing;
mod triangulate;

pub use criteria::{steep_count, tac_and_min_angles, Norm, SLIVER_ANGLE_DEG};
pub use error::{Error, Result};
pub use exact::enumerate::{cheapest_fans, empty_triangles, triangulations, CheapestFan};
pub use geometry::unit_square;
pub use geometry::{check_finite, normalize_plane, triangle_angles};
pub use glam;
pub use io::stl::records as stl_records;
pub use io::text::{parse_table, Table, TextError, TextErrorKind};
pub use mesh::locality::Relabel;
pub use mesh::NONE;
pub use mesh::{prev, HalfEdgeMesh};
pub use optimize::anneal::{AnnealParams, AnnealResult, Annealer, SweepRecord};
pub use optimize::ensemble::{Ensemble, EnsembleSummary};
pub use optimize::lop::{run_lop, tac_lop, LopCriterion, TacOrder};
pub use optimize::tac_state::{Detail, FlipMove, TacState};
pub use optimize::tiles::TiledAnnealer;
pub use projection::{project, Frame, Plane, Projection};
pub use strips::fuchs::{
    lookahead, path_cost, shortest_path_banded, shortest_path_dijkstra, shortest_path_dp, Solution,
    Solver, Step, Weight, DEFAULT_BAND,
};
pub use strips::lines::{detect_lines, segment_lines, ScanLines, DEFAULT_GAP_FACTOR};
pub use strips::stitch::{stitch, stitch_part};
pub use strips::{Method, ScanContext, StripMesh, StripParams};
pub use triangulate::delaunay::{delaunay, Delaunay};
pub use triangulate::holes::DEFAULT_HOLE_FACTOR;
pub use triangulate::jumps::{DepthJumps, DEFAULT_BRIDGE_FACTOR, DEFAULT_JUMP_FACTOR};
pub use triangulate::trim::{
    check_trim_lengths, delaunay_trimmed, median_spacing, trim_long_edges, Trimmed,
    DEFAULT_MAX_EDGE_FACTOR,
};
