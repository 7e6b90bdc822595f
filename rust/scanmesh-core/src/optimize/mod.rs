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

pub use anneal::{AnnealParams, AnnealResult, Annealer, SweepRecord, CURTAIN_ANGLE_DEG, MAX_TILES};
pub use ensemble::{Ensemble, EnsembleSummary};
pub use fixed::FixedEdges;
pub use lop::{curtain_facing, run_lop, tac_lop, LopCriterion, TacOrder};
pub use tac_state::{Detail, FlipMove, TacState};
pub use tiles::TiledAnnealer;
