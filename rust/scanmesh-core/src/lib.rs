//! scanmesh-core: triangulated surfaces from digitized scan-line points.
//!
//! Pure Rust, no Python. The root holds only [`Error`], [`Result`] and `glam`; each family
//! is a public module whose files stay private behind a chosen `pub use` list (what the
//! binding, the benches, the integration tests and the fuzz targets use), so a path reads
//! `scanmesh_core::strips::stitch`, and the strips' solvers `scanmesh_core::strips::fuchs::*`.
//! The modules, grouped by job; a folder imports only from the rows above it (or its own row):
//! - `error`, `budget`, `progress`, `pool`: the one error type; what options may cost in
//!   work and memory; how far a long call has got (a count another thread reads while it
//!   runs); the thread pool started with the workers that fit;
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
//!   chains side by side (`ensemble`), edges no flip may remove (`fixed`);
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
#![deny(rustdoc::broken_intra_doc_links)]
#![warn(missing_docs)]

pub mod budget;
pub mod criteria;
mod error;
pub mod exact;
pub mod fusion;
pub mod geometry;
pub mod io;
pub mod mesh;
pub mod optimize;
pub mod pool;
pub mod progress;
pub mod projection;
pub mod simplify;
pub mod strips;
#[cfg(test)]
mod testing;
pub mod triangulate;

pub use error::{Error, Result};
pub use glam;
