//! scanmesh-core: triangulated surfaces from digitized scan-line points.
//!
//! Pure Rust, no Python. Modules, one concept each:
//! - [`geometry`]: corner angles (atan2 form), areas, exact orientation, normalization;
//! - [`projection`]: points to a plane (least squares, an axis, a normal);
//! - [`delaunay`]: planar Delaunay through spade, with the map back to input indices;
//! - [`mesh`]: flat half-edge triangulation with flips and `validate()`;
//! - [`criteria`]: max-min angle and tac (total absolute curvature) with p-norms;
//! - [`trim`]: removing long hull triangles so outlines and holes stay open;
//! - [`tac_state`]: incremental tac energy under flips;
//! - [`locality`]: Z-order relabelling so annealing's memory accesses stay close;
//! - [`lop`]: Lawson's greedy flipping for any criterion;
//! - [`anneal`]: simulated annealing on tac;
//! - [`ensemble`]: independent annealing chains side by side, the best one kept;
//! - [`tiles`]: one annealing chain on several cores, the plane cut into stripes;
//! - [`enumerate`]: empty triangles and every triangulation of a small point set (exact checks);
//! - [`lines`]: scan lines detected from point order or given by id, split at gaps;
//! - [`fuchs`]: the Fuchs matrix between two lines: weights, α-look-ahead, shortest paths;
//! - [`strips`]: strips between consecutive lines stitched into one mesh (rayon);
//! - [`text`]: numeric text tables (XYZ, CSV rows) parsed from bytes.
// `deny`, not `forbid`: the one exception is the cache prefetch hint in `locality::prefetch`.
#![deny(unsafe_code)]
#![warn(missing_docs)]

pub mod anneal;
pub mod budget;
pub mod criteria;
pub mod delaunay;
pub mod ensemble;
pub mod enumerate;
mod error;
pub mod fuchs;
pub mod geometry;
pub mod lines;
pub mod locality;
pub mod lop;
pub mod mesh;
pub mod projection;
pub mod stl;
pub mod strips;
pub mod tac_state;
#[cfg(test)]
mod testing;
pub mod text;
pub mod tiles;
pub mod trim;

pub use error::{Error, Result};
pub use glam;
