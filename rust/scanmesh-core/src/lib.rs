//! scanmesh-core: triangulated surfaces from digitized scan-line points.
//!
//! Pure Rust, no Python. The public API is the list re-exported below, what the binding,
//! the benches, the integration tests and the fuzz targets use (modules are private). The
//! modules, grouped by job; a folder imports only from the rows above it (or its own row):
//! - `error`, `budget`: the one error type; what options may cost in work and memory;
//! - `geometry`: corner angles (atan2 form), areas, exact orientation, normalization, the
//!   power-of-two unit square;
//! - `projection`: points to a plane (least squares, an axis, a normal);
//! - `mesh/`: the flat half-edge triangulation with flips (`halfedge`, `NONE`, `next`,
//!   `prev`), its invariants checked (`validate`), the faces around each vertex (`fans`),
//!   the Z-order relabelling that keeps memory accesses close (`locality`);
//! - `criteria`: max-min angle and tac (total absolute curvature) with p-norms;
//! - `triangulate/`: planar Delaunay (delaunator checked exactly, else spade; input indices
//!   kept) and its trimming: long hull triangles (`trim`), depth jumps and gaps (`jumps`),
//!   covering holes (`holes`), so outlines and holes stay open; the triangulation along a
//!   range grid, curtains across depth jumps left out (`grid`);
//! - `strips/`: scan lines detected from point order or given by id, split at gaps
//!   (`lines`); the Fuchs matrix between two lines, one solver per file (`fuchs/`: weights,
//!   dp, banded, dijkstra, lookahead, outside); strips stitched into one mesh in parallel
//!   (`stitch`), checked from the strips (`check`), cut at depth jumps (`jumps`) and
//!   repaired where lines cross (`repair`);
//! - `optimize/`: incremental tac energy under flips (`tac_state`, with `NOISE_TAC`), the
//!   live edges annealing draws from (`active`), Lawson's greedy flipping (`lop`),
//!   simulated annealing (`anneal`), one chain on several cores (`tiles`), independent
//!   chains side by side (`ensemble`);
//! - `fusion/`: aligned range views fused into one closed mesh: a view's depth image and
//!   pose (`depth`), the truncated signed distance and the space carved by the rays in a
//!   voxel grid (`tsdf`) stored by blocks of 8³ allocated near the surfaces (`blocks`),
//!   decided per block from its footprint in a view's image (`footprint`), the nodes'
//!   sides by blocks (`sides`), the samples' tangent planes near a cell (`samples`), the zero set
//!   as a labelled closed 2-manifold (`extract`), its edges flipped along creases (`flips`);
//! - `exact/`: empty triangles and every triangulation of a small point set (`enumerate`);
//! - `io/`: numeric text tables (XYZ, CSV rows) parsed from bytes (`text`), binary STL
//!   records (`stl`).
// `deny`, not `forbid`: the one exception is the cache prefetch hint in `mesh::locality::prefetch`.
#![deny(unsafe_code)]
#![warn(missing_docs)]

mod budget;
mod criteria;
mod error;
mod exact;
mod fusion;
mod geometry;
mod io;
mod mesh;
mod optimize;
mod projection;
mod strips;
#[cfg(test)]
mod testing;
mod triangulate;

pub use budget::{try_filled, try_vec};
pub use criteria::{steep_count, tac_and_min_angles, Norm, SLIVER_ANGLE_DEG};
pub use error::{Error, Result};
pub use exact::enumerate::{cheapest_fans, empty_triangles, triangulations, CheapestFan};
pub use fusion::depth::{DepthView, Lookup, JUMP_STEPS, MIN_COS, RIGID_TOL};
pub use fusion::extract::{extract, Fused, FILLED, INFERRED, MEASURED};
pub use fusion::tsdf::{Evidence, Volume, BEHIND_VOXELS};
pub use geometry::unit_square;
pub use geometry::{check_finite, normalize_plane, triangle_angles};
pub use glam;
pub use io::stl::records as stl_records;
pub use io::text::{parse_table, Table, TextError, TextErrorKind};
pub use mesh::locality::Relabel;
pub use mesh::NONE;
pub use mesh::{prev, HalfEdgeMesh};
pub use optimize::anneal::{AnnealParams, AnnealResult, Annealer, SweepRecord, CURTAIN_ANGLE_DEG};
pub use optimize::ensemble::{Ensemble, EnsembleSummary};
pub use optimize::lop::{curtain_facing, run_lop, tac_lop, LopCriterion, TacOrder};
pub use optimize::tac_state::{Detail, FlipMove, TacState};
pub use optimize::tiles::TiledAnnealer;
pub use projection::{project, Frame, Plane, Projection};
pub use strips::fuchs::{
    lookahead, path_cost, shortest_path_banded, shortest_path_dijkstra, shortest_path_dp, Solution,
    Solver, Step, Weight, DEFAULT_BAND,
};
pub use strips::fuchs::{set_strip_filter, strip_filter_counts, FilterCounts};
pub use strips::lines::{detect_lines, segment_lines, ScanLines, DEFAULT_GAP_FACTOR};
pub use strips::stitch::{stitch, stitch_part};
pub use strips::{Method, ScanContext, StripMesh, StripParams};
pub use triangulate::delaunay::{delaunay, Delaunay};
pub use triangulate::grid::{
    grid_triangulate, GridParams, GridTriangles, DEFAULT_GRID_EDGE_FACTOR, DEFAULT_GRID_TURN_DEG,
};
pub use triangulate::holes::DEFAULT_HOLE_FACTOR;
pub use triangulate::jumps::{DepthJumps, DEFAULT_BRIDGE_FACTOR, DEFAULT_JUMP_FACTOR};
pub use triangulate::trim::{
    check_trim_lengths, delaunay_trimmed, median_spacing, trim_long_edges, Trimmed,
    DEFAULT_MAX_EDGE_FACTOR,
};
