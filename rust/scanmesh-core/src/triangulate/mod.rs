//! Planar Delaunay triangulation and its trimming: long hull triangles, depth jumps and
//! covering holes removed so outlines and holes stay open; and the triangulation along a
//! range grid (`grid`), where the scanner's neighbours form the triangles.

pub(crate) mod delaunay;
pub(crate) mod grid;
pub(crate) mod holes;
pub(crate) mod jumps;
pub(crate) mod notches;
pub(crate) mod trim;
