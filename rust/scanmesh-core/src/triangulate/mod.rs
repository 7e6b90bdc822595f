//! Planar Delaunay triangulation and its trimming: long hull triangles, depth jumps and
//! covering holes removed so outlines and holes stay open; and the triangulation along a
//! range grid (`grid`), where the scanner's neighbours form the triangles.

pub(crate) mod delaunay;
pub(crate) mod grid;
pub(crate) mod holes;
pub(crate) mod jumps;
pub(crate) mod notches;
pub(crate) mod trim;

pub use delaunay::{delaunay, Delaunay};
pub use grid::{
    grid_triangulate, GridParams, GridTriangles, DEFAULT_GRID_EDGE_FACTOR, DEFAULT_GRID_TURN_DEG,
};
pub use holes::DEFAULT_HOLE_FACTOR;
pub use jumps::{DepthJumps, DEFAULT_BRIDGE_FACTOR, DEFAULT_JUMP_FACTOR};
pub use trim::{
    check_trim_lengths, delaunay_trimmed, median_spacing, trim_long_edges, Trimmed,
    DEFAULT_MAX_EDGE_FACTOR,
};
