//! Planar Delaunay triangulation and its trimming: long hull triangles, depth jumps and
//! covering holes removed so outlines and holes stay open.

pub(crate) mod delaunay;
pub(crate) mod holes;
pub(crate) mod jumps;
pub(crate) mod trim;
