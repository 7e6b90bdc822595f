//! Volumetric fusion of aligned range views into one closed mesh (Curless & Levoy 1996,
//! with space carving): each view is a depth image seen along its own +z (`depth`), the
//! truncated signed distance along its rays is averaged in a voxel grid and the space its
//! rays crossed is marked empty (`tsdf`), and the zero set is extracted as a closed
//! 2-manifold with vertices placed on the samples (`extract`) whose edges are then flipped
//! towards the samples (`flips`), and the vertices no sample placed are laid on the plane
//! of their wall (`walls`).

pub(crate) mod blocks;
pub(crate) mod depth;
pub(crate) mod extract;
pub(crate) mod flips;
pub(crate) mod footprint;
pub(crate) mod reach;
pub(crate) mod samples;
pub(crate) mod sides;
#[cfg(test)]
mod testing;
pub(crate) mod topology;
pub(crate) mod tsdf;
pub(crate) mod walls;

pub use depth::{DepthView, Lookup, JUMP_STEPS, MAX_MARGIN, MIN_COS, RIGID_TOL};
pub use extract::{extract, extract_counted, Fused, EXTRACT_WEIGHTS, FILLED, INFERRED, MEASURED};
pub use tsdf::{Evidence, Volume, BEHIND_VOXELS};
