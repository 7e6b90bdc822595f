//! Strips between consecutive scan lines: the lines, the Fuchs matrix solvers, the
//! stitching of the strips into one mesh, its check, depth jumps and repair.

mod check;
pub(crate) mod fuchs;
mod jumps;
pub(crate) mod lines;
mod repair;
pub(crate) mod stitch;
