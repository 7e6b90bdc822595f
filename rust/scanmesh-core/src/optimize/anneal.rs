//! Simulated annealing of a planar triangulation by random edge flips, minimizing tac.
//!
//! Move: a uniformly random live edge ([`crate::optimize::active`]: its quadrilateral strictly
//! convex,
//! a corner's tac above the floor of ties), flipped.
//! Energy: Σ tac^p ([`TacState`]). Selection: Metropolis. Schedule: T0 calibrated from the
//! uphill energy changes of sampled proposals, geometric cooling per sweep (a sweep is as
//! many proposals as live edges), early stop once frozen, the best state kept, then a
//! greedy polish (LOP) under the order (tac first, then smallest angle).

use crate::budget;
use crate::mesh::HalfEdgeMesh;
use crate::optimize::active::LiveEdges;
use crate::optimize::lop::{curtain_facing, planar_flip_improves, tac_lop_counted, TacOrder};
use crate::optimize::tac_state::{Detail, Proposal, TacState};
use crate::progress::Progress;
use crate::triangulate::grid::DEFAULT_GRID_TURN_DEG;
use crate::{Error, Result};
use rand_core::{RngCore, SeedableRng};
use rand_pcg::Pcg64Mcg;
use std::time::Instant;

/// Annealing parameters; `Default` gives the measured defaults (see docs/benchmarks/quality.md).
#[derive(Debug, Clone, PartialEq)]
pub struct AnnealParams {
    /// Number of sweeps (the paper's "iterations"); one sweep = one proposal per live edge
    /// (see `crate::optimize::active`: flippable, by a corner whose tac is above the ties').
    pub sweeps: usize,
    /// Energy exponent p ≥ 1: the energy is Σ tac^p.
    pub p: f64,
    /// Seed of the PCG-64 (MCG) generator: the same seed gives the same faces everywhere.
    pub seed: u64,
    /// Probability with which the median uphill move of the initial state is accepted at T0.
    pub initial_acceptance: f64,
    /// Final temperature as a fraction of T0; the per-sweep cooling factor follows from it.
    pub final_temperature_ratio: f64,
    /// Stop after this many sweeps without a new best once frozen (0: never stop early).
    pub patience: usize,
    /// In the final polish, break energy ties toward the larger smallest 3-D angle (see
    /// [`TacOrder`]), so flat regions end well shaped instead of where the walk left them.
    pub sliver_guard: bool,
    /// Energy changes of at most this size (radians^p) are ties.
    pub tie_tolerance: f64,
    /// Flips whose four corners are flat up to the noise (see [`TacOrder`]) are judged by
    /// the smallest planar angle alone, in the walk and in the polish: for a tolerance
    /// that stands for the scan's noise. Off: every flip by the energy, ties accepted
    /// freely and broken by the 3-D angle in the polish.
    pub planar_ties: bool,
    /// Run LOP from the best state at the end.
    pub polish: bool,
    /// Start the walk from the local optimum that LOP (under [`order`](Self::order))
    /// reaches from the given triangulation, found once before the chains split: the walk
    /// then spends its proposals below the cheap baseline instead of re-finding it.
    pub descend: bool,
    /// Flips that would make the smallest 3-D angle of their two triangles fall below this
    /// (degrees) and below what it was are refused, in the walk, the descent and the polish:
    /// slivers are held down by the move set, not by the energy (0: off). Coplanar ties are
    /// left to the polish's angle order.
    pub sliver_angle: f64,
    /// Flips that would bring a triangle's plane within this angle (degrees) of the line of
    /// sight, and nearer it than before, are refused in the walk, the descent and the
    /// polish: no new curtain ([`TacOrder::refuses`]; 0: off). Judged only on a state
    /// given a sight ([`TacState::with_sight`]).
    pub curtain_angle: f64,
    /// Proposals sampled to calibrate T0.
    pub calibration_samples: usize,
    /// Independent chains (restarts from the same initial state with derived seeds, see
    /// [`AnnealParams::for_chain`]); the best final state wins. 0 = automatic
    /// ([`AnnealParams::chain_count`]): one chain on large inputs, more on small ones.
    pub chains: usize,
    /// Tiles each chain is annealed in at once, on the rayon pool (see `crate::optimize::tiles`):
    /// 1
    /// runs the plain sequential chain; k > 1 splits the plane into stripes whose
    /// interiors anneal independently, phase by phase, with the stripes shifted every
    /// phase. The result depends on (seed, tiles), never on the thread count.
    pub tiles: usize,
}

/// Automatic chains: as many as it takes for the chains together to propose at least this
/// many flips per sweep (a triangulation with this many interior edges or more gets one
/// chain). Small inputs are cheap, and on them independent restarts find the optimum far
/// more often than one longer chain (docs/benchmarks/optimum.md); counting edges,
/// not planned proposals, keeps a short run asked for (`sweeps`) proportionally short.
pub const AUTO_CHAIN_EDGES: usize = 8_000;

/// Automatic chains never exceed this count.
pub const MAX_AUTO_CHAINS: usize = 128;

/// Proposals per point an automatic schedule plans, all chains together
/// ([`AnnealParams::auto_sweeps`]): each sweep from LOP's optimum still lowers tac on a
/// large terrain, and 24 per point keeps the run within a few times LOP's time (figures in
/// docs/benchmarks/panel.md, "Figures behind the core's constants").
pub const AUTO_PROPOSALS_PER_POINT: u64 = 24;

/// The least proposals an automatic schedule plans in all: small scans are cheap, and on
/// them longer runs keep lowering tac (fran_cut in docs/benchmarks/panel.md, "Figures
/// behind the core's constants").
pub const AUTO_MIN_PROPOSALS: u64 = 2_000_000;

/// The fewest sweeps of an automatic schedule: fewer cool too fast to leave the start.
pub const AUTO_MIN_SWEEPS: usize = 8;

/// Default [`AnnealParams::curtain_angle`] (degrees): 90° less the grid triangulation's
/// largest turn ([`DEFAULT_GRID_TURN_DEG`], 85°: 5°, the curtain report's angle), so that a
/// flip never makes a face the grid would have dropped for its turn: without the rule, LOP
/// and annealing hang curtains across fran_cut's depth jumps, with it none, at a little tac
/// and no height error (figures in docs/benchmarks/curtains.md, "Figures behind the core's
/// constants").
pub const CURTAIN_ANGLE_DEG: f64 = 90.0 - DEFAULT_GRID_TURN_DEG;

/// Largest accepted [`AnnealParams::tiles`].
pub const MAX_TILES: usize = 64;

impl Default for AnnealParams {
    fn default() -> Self {
        AnnealParams {
            sweeps: 1000,
            p: 1.0,
            seed: 0,
            initial_acceptance: 0.8,
            final_temperature_ratio: 1e-4,
            patience: 50,
            sliver_guard: true,
            tie_tolerance: 1e-10,
            planar_ties: false,
            polish: true,
            descend: true,
            sliver_angle: crate::criteria::SLIVER_ANGLE_DEG,
            curtain_angle: CURTAIN_ANGLE_DEG,
            calibration_samples: 2000,
            chains: 0,
            tiles: 1,
        }
    }
}

impl AnnealParams {
    /// Checks every field's range; the error names the field.
    pub fn check(&self) -> Result<()> {
        let bad = |name, value: String, expected| {
            Err(Error::InvalidParameter {
                name,
                value,
                expected,
            })
        };
        if !(self.p.is_finite() && self.p >= 1.0) {
            return bad("p", self.p.to_string(), "a finite p >= 1");
        }
        if !(self.initial_acceptance > 0.0 && self.initial_acceptance < 1.0) {
            return bad(
                "initial_acceptance",
                self.initial_acceptance.to_string(),
                "a probability strictly between 0 and 1",
            );
        }
        if !(self.final_temperature_ratio > 0.0 && self.final_temperature_ratio <= 1.0) {
            return bad(
                "final_temperature_ratio",
                self.final_temperature_ratio.to_string(),
                "a ratio in (0, 1]",
            );
        }
        if !(self.tie_tolerance >= 0.0 && self.tie_tolerance.is_finite()) {
            return bad(
                "tie_tolerance",
                self.tie_tolerance.to_string(),
                "a finite value >= 0",
            );
        }
        if !(self.sliver_angle >= 0.0 && self.sliver_angle < 60.0) {
            return bad(
                "sliver_angle",
                self.sliver_angle.to_string(),
                "an angle in degrees from 0 (off) up to, not including, 60",
            );
        }
        curtain_facing(self.curtain_angle)?;
        if self.tiles == 0 || self.tiles > MAX_TILES {
            return bad("tiles", self.tiles.to_string(), "a tile count from 1 to 64");
        }
        Ok(())
    }

    /// [`check`](Self::check), and that `state` measures the energy with this `p` (and has
    /// no fixed edges when `tiles` > 1: the tiles' pieces keep none).
    pub fn check_for(&self, state: &TacState) -> Result<()> {
        self.check()?;
        if state.p() != self.p {
            return Err(Error::InvalidParameter {
                name: "p",
                value: state.p().to_string(),
                expected: "the state's p to equal the parameters' p",
            });
        }
        if self.tiles > 1 && state.fixed().is_some() {
            return Err(Error::InvalidParameter {
                name: "tiles",
                value: self.tiles.to_string(),
                expected: "1 with fixed edges (the tiles' pieces keep none)",
            });
        }
        Ok(())
    }

    /// Refuses a run from `state` that would plan more flip proposals than
    /// `budget::MAX_PROPOSALS`, calibrate longer than
    /// `budget::MAX_CALIBRATION_PROPOSALS` before it can be interrupted, or need more
    /// memory than this process may have (`budget::memory_available`); the error
    /// ([`Error::TooCostly`]) names the option that asks for it and what it would need.
    /// Returns the number of chains. O(m).
    pub fn check_cost(&self, state: &TacState) -> Result<usize> {
        let edges = (state.count_interior_half_edges() / 2) as u64;
        let chains = self.chain_count(edges as usize);
        let n = chains as u64;
        // One rule for both limits on proposals: `chains` is named when set beyond what
        // automatic counts give and the run would fit with that many; otherwise the
        // per-chain option (`other`) is the cause.
        let refuse = |total: u64,
                      limit: u64,
                      per_chain: u64,
                      other: (&'static str, usize),
                      what: String,
                      limit_text: String| {
            if total <= limit {
                return Ok(());
            }
            let (name, value) =
                if self.chains > MAX_AUTO_CHAINS && per_chain <= limit / MAX_AUTO_CHAINS as u64 {
                    ("chains", self.chains)
                } else {
                    other
                };
            Err(Error::TooCostly {
                name,
                value: value.to_string(),
                needs: budget::describe_proposals(total, &what),
                limit: limit_text,
            })
        };
        let samples = self.calibration_samples as u64;
        refuse(
            n.saturating_mul(samples),
            budget::MAX_CALIBRATION_PROPOSALS,
            samples,
            ("calibration_samples", self.calibration_samples),
            format!("calibration proposals ({chains} chains) before the first sweep"),
            format!(
                "{:.0e}, the most a run may make before it can be interrupted",
                budget::MAX_CALIBRATION_PROPOSALS as f64
            ),
        )?;
        let per_chain = (self.sweeps as u64)
            .saturating_mul(edges)
            .saturating_add(samples);
        refuse(
            n.saturating_mul(per_chain),
            budget::MAX_PROPOSALS,
            per_chain,
            ("sweeps", self.sweeps),
            format!("flip proposals ({chains} chains, {edges} interior edges)"),
            format!("the limit of {:.0e}", budget::MAX_PROPOSALS as f64),
        )?;
        // Per chain: its state, the best copy (and the tiles' pieces), the calibration
        // sample, the flip log (at most about three sweeps), the live edges' list and the
        // sweep records, kept and copied once for the caller.
        let state_bytes = state.heap_bytes();
        let copies = if self.tiles > 1 { 4 } else { 2 };
        let record = std::mem::size_of::<SweepRecord>() as u64;
        let per_chain = (copies * state_bytes)
            .saturating_add(8 * samples)
            .saturating_add(12 * edges)
            .saturating_add(LiveEdges::BYTES_PER_HALF_EDGE * 2 * edges)
            .saturating_add((self.sweeps as u64).saturating_mul(2 * record))
            .saturating_add(std::mem::size_of::<Annealer>() as u64);
        let bytes = n.saturating_mul(per_chain);
        let room = budget::memory_available().unwrap_or(u64::MAX);
        if bytes > room {
            let (name, value) = if self.chains > 1 && per_chain <= room {
                ("chains", self.chains)
            } else {
                ("sweeps", self.sweeps)
            };
            budget::check_memory(name, value, bytes)?;
        }
        Ok(chains)
    }

    /// Number of chains to run on a triangulation with `interior_edges` interior edges:
    /// `chains` when set, otherwise `⌈AUTO_CHAIN_EDGES / interior_edges⌉` between 1 and
    /// `MAX_AUTO_CHAINS`. O(1).
    pub fn chain_count(&self, interior_edges: usize) -> usize {
        if self.chains > 0 {
            return self.chains;
        }
        AUTO_CHAIN_EDGES
            .div_ceil(interior_edges.max(1))
            .clamp(1, MAX_AUTO_CHAINS)
    }

    /// Sweeps of the automatic schedule on a triangulation of `n_vertices` points with
    /// `interior_edges` interior edges: the budget max(`AUTO_PROPOSALS_PER_POINT` × n,
    /// `AUTO_MIN_PROPOSALS`) proposals shared by the [`chain_count`](Self::chain_count)
    /// chains, one proposal per interior edge and sweep, kept between
    /// `AUTO_MIN_SWEEPS` and `self.sweeps`. The plan depends on the input alone, never on
    /// the clock, so a seed still fixes the result. O(1).
    pub fn auto_sweeps(&self, n_vertices: usize, interior_edges: usize) -> usize {
        let edges = interior_edges.max(1) as u64;
        let chains = self.chain_count(interior_edges) as u64;
        let budget = (AUTO_PROPOSALS_PER_POINT * n_vertices as u64).max(AUTO_MIN_PROPOSALS);
        let sweeps = budget.div_ceil(chains * edges);
        (sweeps as usize).clamp(AUTO_MIN_SWEEPS, self.sweeps.max(AUTO_MIN_SWEEPS))
    }

    /// The parameters of chain `chain`: chain 0 keeps `seed`, chain c > 0 runs on a seed
    /// mixed from (seed, c) by the SplitMix64 finalizer, so chains are independent and a
    /// (seed, chain) pair means the same run everywhere. O(1).
    pub fn for_chain(&self, chain: usize) -> AnnealParams {
        let seed = if chain == 0 {
            self.seed
        } else {
            let mut z = self
                .seed
                .wrapping_add((chain as u64).wrapping_mul(0x9E37_79B9_7F4A_7C15));
            z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
            z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
            z ^ (z >> 31)
        };
        AnnealParams {
            seed,
            ..self.clone()
        }
    }

    /// The ordering used for ties and the polish.
    pub fn order(&self) -> TacOrder {
        TacOrder {
            tie_tolerance: self.tie_tolerance,
            sliver_guard: self.sliver_guard,
            planar_ties: self.planar_ties,
            sliver_angle: self.sliver_angle.to_radians(),
            // Out of range only for parameters never checked (`check` refuses them): no rule.
            min_facing: curtain_facing(self.curtain_angle).unwrap_or(0.0),
        }
    }
}

/// What one sweep did.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SweepRecord {
    /// Temperature during the sweep.
    pub temperature: f64,
    /// Energy at the end of the sweep.
    pub energy: f64,
    /// Best energy seen so far.
    pub best: f64,
    /// Accepted flips / proposals in the sweep.
    pub acceptance: f64,
    /// Proposals in the sweep (the live edges at its start, fewer if none was left).
    pub proposals: usize,
    /// At most one in 1,000 uphill proposals of the sweep was accepted (the early stop
    /// waits for this).
    pub frozen: bool,
}

/// The outcome of a run.
#[derive(Debug, Clone)]
pub struct AnnealResult {
    /// The best triangulation found (after the polish).
    pub mesh: HalfEdgeMesh,
    /// Energy of the initial triangulation.
    pub initial_energy: f64,
    /// Energy of the returned triangulation.
    pub energy: f64,
    /// T0 after calibration.
    pub initial_temperature: f64,
    /// One record per sweep run.
    pub trace: Vec<SweepRecord>,
    /// Flips made by the final polish.
    pub polish_flips: usize,
    /// Why the run ended.
    pub stopped: Stop,
}

/// Why an annealing run ended.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Stop {
    /// Every planned sweep ran.
    Sweeps,
    /// Frozen without a new best for `patience` sweeps.
    Patience,
    /// No live edge left (see [`crate::optimize::active`]): no flip could lower the energy by more
    /// than a tie, so further sweeps could not change the best state.
    Exhausted,
    /// Finished before any of these (the caller stopped driving it: a time limit).
    Unfinished,
}

impl Stop {
    /// The reason from a run's state: sweeps run of `sweeps` planned, whether patience
    /// stopped it and whether its live edges ran out. O(1).
    pub(crate) fn of(run: usize, sweeps: usize, patience: bool, exhausted: bool) -> Stop {
        if run >= sweeps {
            Stop::Sweeps
        } else if exhausted {
            Stop::Exhausted
        } else if patience {
            Stop::Patience
        } else {
            Stop::Unfinished
        }
    }

    /// The name `options["stopped"]` gives it in Python: "sweeps", "patience",
    /// "exhausted" or "unfinished". O(1).
    pub fn name(self) -> &'static str {
        match self {
            Stop::Sweeps => "sweeps",
            Stop::Patience => "patience",
            Stop::Exhausted => "exhausted",
            Stop::Unfinished => "unfinished",
        }
    }
}

/// A resumable annealing run: [`advance`](Annealer::advance) a bounded number of proposals
/// at a time, so that a caller can report progress and honour interruption between chunks.
pub struct Annealer {
    state: TacState,
    params: AnnealParams,
    order: TacOrder,
    // Two streams split from the seed: edges (drawn among the live ones, see
    // `LiveEdges`) and the Metropolis uniforms, so drawing edges early never reorders the
    // uniforms.
    edges: LiveEdges,
    uniforms: Pcg64Mcg,
    initial_energy: f64,
    initial_temperature: f64,
    temperature: f64,
    cooling: f64,
    // Proposals of the sweep in progress: the live edges listed at its start.
    sweep_len: usize,
    // Proposals since the energy was last recomputed from the sums.
    since_resync: usize,
    // Counters of the sweep in progress.
    proposed: usize,
    accepted: usize,
    // Proposals of the sweep that measured angles (not a tie, not unflippable).
    measured: usize,
    uphill_proposed: usize,
    uphill_accepted: usize,
    found_best: bool,
    since_best: usize,
    trace: Vec<SweepRecord>,
    stopped_early: bool,
    // The best state is `best` advanced by `log[..pending]`; see `note_best`.
    best: HalfEdgeMesh,
    best_energy: f64,
    log: Vec<u32>,
    pending: usize,
    detached: bool,
}

impl Annealer {
    /// Starts a run from `state`; calibrates T0 from `calibration_samples` random proposals.
    /// O(calibration_samples + m).
    pub fn new(mut state: TacState, params: AnnealParams) -> Result<Self> {
        params.check_for(&state)?;
        let (mut edges, uniforms) = streams(&state, &params)?;
        let initial_temperature = calibrate(&mut state, &params, &mut edges);
        let cooling = cooling(params.final_temperature_ratio, params.sweeps);
        Ok(Self::with_schedule(
            state,
            params,
            (edges, uniforms),
            initial_temperature,
            cooling,
        ))
    }

    /// A run on the given streams whose schedule starts at `temperature` (no calibration)
    /// and multiplies it by `cooling` after each sweep. O(m).
    fn with_schedule(
        state: TacState,
        params: AnnealParams,
        (edges, uniforms): (LiveEdges, Pcg64Mcg),
        temperature: f64,
        cooling: f64,
    ) -> Self {
        let energy = state.energy();
        let sweep_len = edges.len();
        Annealer {
            best: state.mesh().clone(),
            best_energy: energy,
            initial_energy: energy,
            state,
            order: params.order(),
            params,
            edges,
            uniforms,
            initial_temperature: temperature,
            temperature,
            cooling,
            sweep_len,
            since_resync: 0,
            proposed: 0,
            accepted: 0,
            measured: 0,
            uphill_proposed: 0,
            uphill_accepted: 0,
            found_best: false,
            since_best: 0,
            trace: Vec::new(),
            stopped_early: false,
            log: Vec::new(),
            pending: 0,
            detached: false,
        }
    }

    /// A tile's run for one phase of [`crate::optimize::tiles`]: `params.sweeps` sweeps on
    /// `params.seed`'s streams, from `temperature` (the shared schedule's, not calibrated
    /// on the tile), cooled by `cooling` per sweep. Errors: an [`Error::OutOfMemory`] for
    /// its live edges. O(m).
    pub(crate) fn for_phase(
        state: TacState,
        params: AnnealParams,
        temperature: f64,
        cooling: f64,
    ) -> Result<Self> {
        let streams = streams(&state, &params)?;
        Ok(Self::with_schedule(
            state,
            params,
            streams,
            temperature,
            cooling,
        ))
    }

    /// Ends a phase of [`crate::optimize::tiles`]: the best state seen and its energy, the current
    /// state and the sweep records. O(flips since the last sweep's replay).
    pub(crate) fn end_phase(mut self) -> (HalfEdgeMesh, f64, TacState, Vec<SweepRecord>) {
        self.sync_best();
        (self.best, self.best_energy, self.state, self.trace)
    }

    /// Plans `sweeps` sweeps instead of `params.sweeps` (the cooling follows) before the
    /// first proposal; false, with nothing changed, once one ran. O(1).
    pub(crate) fn replan(&mut self, sweeps: usize) -> bool {
        let fresh = self.proposed == 0 && self.trace.is_empty();
        if fresh {
            self.params.sweeps = sweeps;
            self.cooling = cooling(self.params.final_temperature_ratio, sweeps);
        }
        fresh
    }

    /// True when every sweep has run or the run stopped early.
    pub fn is_done(&self) -> bool {
        self.sweep_len == 0 || self.stopped_early || self.trace.len() >= self.params.sweeps
    }

    /// True when the run ended because no live edge was left (see `crate::optimize::active`):
    /// no flip can lower the energy by more than a tie. O(1).
    pub fn is_exhausted(&self) -> bool {
        self.sweep_len == 0
    }

    /// Sweep records so far.
    pub fn trace(&self) -> &[SweepRecord] {
        &self.trace
    }

    /// Proposals in the current sweep: the live edges listed at its start (see
    /// `crate::optimize::active`), 0 once none is left.
    pub fn sweep_len(&self) -> usize {
        self.sweep_len
    }

    /// The current state (for tests and progress reports).
    pub fn state(&self) -> &TacState {
        &self.state
    }

    /// Runs at most `max_proposals` proposals, stopping early at the end of the run.
    /// Returns how many ran. O(max_proposals) plus O(n) per completed sweep.
    pub fn advance(&mut self, max_proposals: usize) -> usize {
        self.advance_until(max_proposals, None)
    }

    /// Like [`advance`](Self::advance), but also returns soon after `deadline` (the clock is
    /// read every 1,024 proposals), so a caller polling for Ctrl-C gets control back in
    /// bounded time on any machine. Where the chunks end never changes the result.
    pub fn advance_until(&mut self, max_proposals: usize, deadline: Option<Instant>) -> usize {
        const CLOCK_EVERY: usize = 1024;
        let mut ran = 0;
        while ran < max_proposals && !self.is_done() {
            let budget = (self.sweep_len - self.proposed)
                .min(max_proposals - ran)
                .min(CLOCK_EVERY);
            for _ in 0..budget {
                if !self.propose() {
                    // No live edge is left: the sweep ends here, and the run with it.
                    self.sweep_len = self.proposed;
                    break;
                }
            }
            ran += budget;
            if self.proposed == self.sweep_len {
                self.end_sweep();
            }
            if deadline.is_some_and(|d| Instant::now() >= d) {
                break;
            }
        }
        ran
    }

    /// One Metropolis step on a live edge; false (and nothing done) when none is left.
    /// O(1) amortized.
    #[inline]
    fn propose(&mut self) -> bool {
        let Some(h) = self.edges.next(&self.state) else {
            return false;
        };
        self.proposed += 1;
        let mv = match self.state.propose(h) {
            // Listed when it was live; it will not be again before a flip relists it.
            Proposal::NotFlippable => {
                self.edges.drop_drawn();
                return true;
            }
            // An exact tie, accepted and applied by `propose`; the energy is unchanged, so
            // it cannot be a new best, and no angle sum moved.
            Proposal::FlippedTie => {
                self.accepted += 1;
                self.log.push(h);
                let t = self.state.mesh().twin(h);
                self.edges.after_flip(&self.state, h, t, [false; 4]);
                return true;
            }
            Proposal::Move(mv) => mv,
        };
        self.measured += 1;
        // Ties are accepted freely: tac is blind on flat and developable parts, and the
        // better optima are reached through long neutral walks there. The sliver guard acts
        // in the final polish, which makes the result a local optimum of (tac, angle).
        // With `planar_ties`, a flip whose corners are all flat up to the noise follows
        // Delaunay's criterion instead (see `TacOrder`): a walk there only picks triangles
        // by the noise.
        let flat = self
            .order
            .planar_ties
            .then(|| self.state.flat_quad_uv(h, self.order.tie_tolerance))
            .flatten();
        let accept = if self.order.refuses(&mv) {
            false
        } else if let Some(quad) = flat {
            planar_flip_improves(quad)
        } else if self.order.is_tie(&mv) || mv.delta_energy < 0.0 {
            true
        } else {
            self.uphill_proposed += 1;
            let u = unit_f64(&mut self.uniforms);
            let ok = self.temperature > 0.0 && u < (-mv.delta_energy / self.temperature).exp();
            self.uphill_accepted += ok as usize;
            ok
        };
        if accept {
            let floor = self.edges.floor();
            let (t, quad) = self
                .state
                .mesh()
                .twin_and_quad(h)
                .expect("a move's edge is interior");
            let low = quad.map(|v| !self.state.is_above_floor(v, floor));
            self.state.apply(&mv);
            let risen = [0, 1, 2, 3].map(|k| low[k] && self.state.is_above_floor(quad[k], floor));
            self.edges.after_flip(&self.state, h, t, risen);
            self.accepted += 1;
            self.log.push(mv.h);
            if self.state.energy() < self.best_energy {
                self.note_best();
            }
        }
        true
    }

    /// Records that the current state is the best seen. Cheap: only a log position, unless
    /// the log was dropped for length, in which case the state is copied. O(1) or O(m).
    fn note_best(&mut self) {
        self.best_energy = self.state.energy();
        self.found_best = true;
        if self.detached {
            self.best = self.state.mesh().clone();
            self.log.clear();
            self.pending = 0;
            self.detached = false;
        } else {
            self.pending = self.log.len();
        }
    }

    /// Replays the flips up to the best state onto the `best` copy (flips rewrite slots
    /// deterministically, so the replay reproduces it exactly). O(flips replayed).
    fn sync_best(&mut self) {
        // Unanchored: what reads `best` next builds a `TacState` (which reanchors) or takes
        // its triangles (tiles).
        for &h in &self.log[..self.pending] {
            self.best.flip_unanchored(h);
        }
        self.log.drain(..self.pending);
        self.pending = 0;
        // A log longer than the mesh with no best ahead would only grow: drop it and copy
        // the state at the next best instead (the copy then costs no more than the log).
        if self.log.len() > self.state.mesh().n_half_edges() {
            self.log.clear();
            self.detached = true;
        }
    }

    fn end_sweep(&mut self) {
        // Recomputing the energy is O(n), so it is done once the sweeps since the last time
        // made as many proposals as there are vertices: rounding is reset as often as with
        // whole-mesh sweeps, and short sweeps (few live edges) stay cheap.
        self.since_resync += self.proposed;
        let energy = if self.since_resync >= self.state.mesh().n_vertices() {
            self.since_resync = 0;
            self.state.resync_energy()
        } else {
            self.state.energy()
        };
        if energy < self.best_energy {
            self.note_best();
        }
        self.sync_best();
        let frozen = self.uphill_accepted * 1000 <= self.uphill_proposed;
        self.trace.push(SweepRecord {
            temperature: self.temperature,
            energy,
            best: self.best_energy,
            acceptance: self.accepted as f64 / self.proposed.max(1) as f64,
            proposals: self.proposed,
            frozen,
        });
        self.since_best = if self.found_best {
            0
        } else {
            self.since_best + 1
        };
        if self.params.patience > 0 && frozen && self.since_best >= self.params.patience {
            self.stopped_early = true;
        }
        self.temperature *= self.cooling;
        // Corner angles are read by measured proposals only: on flat scans (ties and
        // unflippable quadrilaterals, 99.9 % of the rod's proposals) hinting their lines
        // only crowds out the useful hints. Hints never change results.
        self.edges.hints.corners = self.measured * CORNER_HINT_SHARE >= self.proposed;
        // The schedule follows the live part of the mesh: the next sweep proposes once per
        // listed edge (the live ones, and stale entries it will drop when it draws them;
        // pruning them here instead cost a tenth of a second per sweep on 60k points).
        // None left: nothing can lower the energy by more than a tie.
        self.sweep_len = self.edges.len();
        self.measured = 0;
        self.proposed = 0;
        self.accepted = 0;
        self.uphill_proposed = 0;
        self.uphill_accepted = 0;
        self.found_best = false;
    }

    /// Ends the run: takes the best state, polishes it with LOP under the tac-then-angle
    /// order when asked, and returns it. O(m + polish flips).
    pub fn finish(self) -> Result<AnnealResult> {
        self.finish_counted(None)
    }

    /// [`Annealer::finish`], its polish counted as `weight` items of `progress` when `counted` is
    /// `(progress, weight)`.
    pub fn finish_counted(mut self, counted: Option<(&Progress, u64)>) -> Result<AnnealResult> {
        self.sync_best();
        // The polish's state is the run's, moved onto the best mesh: the run's mesh,
        // live list and log are freed first, so two states never share the memory.
        let Annealer {
            state,
            best,
            params,
            initial_energy,
            initial_temperature,
            trace,
            stopped_early,
            sweep_len,
            ..
        } = self;
        let stopped = Stop::of(trace.len(), params.sweeps, stopped_early, sweep_len == 0);
        let (mesh, energy, polish_flips) = polish(state.with_mesh(best)?, &params, counted)?;
        Ok(AnnealResult {
            mesh,
            initial_energy,
            energy,
            initial_temperature,
            trace,
            polish_flips,
            stopped,
        })
    }
}

/// The live edges and the Metropolis uniforms of a run with `params`: edges are drawn from
/// the seed's own stream, the uniforms from a second generator seeded by that stream's
/// first two outputs. Errors: an [`Error::OutOfMemory`] for the live edges. O(m).
fn streams(state: &TacState, params: &AnnealParams) -> Result<(LiveEdges, Pcg64Mcg)> {
    let edge_rng = Pcg64Mcg::seed_from_u64(params.seed);
    let uniforms = Pcg64Mcg::from_rng(&mut edge_rng.clone());
    Ok((
        LiveEdges::new(state, params.tie_tolerance, edge_rng)?,
        uniforms,
    ))
}

/// T0 at which the median uphill energy change of `params.calibration_samples` proposals
/// drawn from `edges` is accepted with probability `params.initial_acceptance`; 0 when no
/// sampled proposal goes uphill. O(calibration_samples).
fn calibrate(state: &mut TacState, params: &AnnealParams, edges: &mut LiveEdges) -> f64 {
    let order = params.order();
    let mut uphill = Vec::new();
    for _ in 0..params.calibration_samples {
        let Some(h) = edges.next(state) else {
            break;
        };
        if let Some(mv) = state.evaluate(h, Detail::Energy) {
            if !order.is_tie(&mv) && mv.delta_energy > 0.0 {
                uphill.push(mv.delta_energy);
            }
        }
    }
    if uphill.is_empty() {
        return 0.0;
    }
    let mid = uphill.len() / 2;
    let median = *uphill.select_nth_unstable_by(mid, f64::total_cmp).1;
    -median / params.initial_acceptance.ln()
}

/// The T0 a run from `state` with `params` calibrates (see [`Annealer::new`]), for
/// schedules shared by several runs. O(calibration_samples + m).
pub(crate) fn initial_temperature(state: &mut TacState, params: &AnnealParams) -> Result<f64> {
    Ok(calibrate(state, params, &mut streams(state, params)?.0))
}

/// Geometric cooling per sweep that takes T0 to `final_ratio` × T0 in `sweeps` sweeps.
/// O(1).
pub(crate) fn cooling(final_ratio: f64, sweeps: usize) -> f64 {
    final_ratio.powf(1.0 / sweeps.max(1) as f64)
}

/// The end of every run: the state of the best mesh, polished by LOP under the
/// tac-then-angle order when `params.polish`; returns the mesh, its energy (recomputed
/// from the sums) and the polish's flips; an [`Error::OutOfMemory`] when LOP's stack cannot
/// be had. The polish is counted as in [`crate::optimize::lop::lop_counted`].
/// O(m + polish flips).
pub(crate) fn polish(
    mut best: TacState,
    params: &AnnealParams,
    counted: Option<(&Progress, u64)>,
) -> Result<(HalfEdgeMesh, f64, usize)> {
    let polish_flips = if params.polish {
        tac_lop_counted(&mut best, params.order(), counted)?
    } else {
        if let Some((progress, weight)) = counted {
            progress.add(weight);
        }
        0
    };
    let energy = best.resync_energy();
    Ok((best.into_mesh(), energy, polish_flips))
}

/// Corner lines are hinted in a sweep when at least one in this many proposals of the
/// previous sweep measured angles.
const CORNER_HINT_SHARE: usize = 8;

/// Uniform f64 in [0, 1) from the top 53 bits. O(1).
#[inline]
fn unit_f64(rng: &mut Pcg64Mcg) -> f64 {
    (rng.next_u64() >> 11) as f64 * (1.0 / (1u64 << 53) as f64)
}

#[cfg(test)]
pub(crate) mod tests;
