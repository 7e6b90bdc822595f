//! The mesh: a flat half-edge triangulation with flips, its checks, the faces around each
//! vertex, and the vertex order that keeps memory accesses close.

mod fans;
mod halfedge;
pub(crate) mod locality;
mod validate;

pub(crate) use fans::Fans;
pub(crate) use halfedge::{convex_quad, well_formed, COLLINEAR_SINE};
pub use halfedge::{next, prev, HalfEdgeMesh, NONE};
pub use locality::Relabel;
pub(crate) use validate::count_cycles;
