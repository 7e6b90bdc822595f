//! Flip optimization of a triangulation on tac (total absolute curvature): the incremental
//! energy, the live edges, Lawson's greedy flips, simulated annealing, its tiled and
//! ensemble runs, and the edges a run must keep.

pub(crate) mod active;
pub(crate) mod anneal;
pub(crate) mod ensemble;
pub(crate) mod fixed;
pub(crate) mod lop;
pub(crate) mod tac_state;
pub(crate) mod tiles;
