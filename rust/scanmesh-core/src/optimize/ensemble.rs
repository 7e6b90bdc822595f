//! Independent annealing chains run side by side; the best final state wins.
//!
//! Why chains: on small inputs one annealing run often ends in a deep local minimum of tac,
//! and independent restarts find the optimum far more often than one longer run (measured
//! against the certified optimum, docs/benchmarks/optimum.md). Small inputs are
//! cheap, so [`AnnealParams::chain_count`] gives them many chains and large inputs one.
//!
//! Chains share nothing but the initial state; chain c runs on the seed
//! [`AnnealParams::for_chain`] derives, so the result depends on (seed, chains) only, not on
//! the thread count or on where the caller's chunks end.

use crate::budget;
use crate::mesh::HalfEdgeMesh;
use crate::optimize::anneal::{AnnealParams, AnnealResult, Annealer, SweepRecord};
use crate::optimize::lop::{tac_lop_counted, TacOrder};
use crate::optimize::tac_state::TacState;
use crate::optimize::tiles::TiledAnnealer;
use crate::progress::{Progress, Share};
use crate::{Error, Result};
use rayon::prelude::*;
use std::time::Instant;

/// A resumable set of annealing chains, advanced together on the rayon pool.
pub struct Ensemble {
    chains: Vec<Chain>,
    // The triangulation the caller gave and its energy: a run never returns a state above
    // it (the descent and the polish may trade ties within the tolerance).
    start: HalfEdgeMesh,
    start_energy: f64,
}

/// One chain: the sequential annealer, or the tiled one when [`AnnealParams::tiles`] > 1.
// Unboxed: a few chains per run, and the annealer's hot fields stay one load away.
#[allow(clippy::large_enum_variant)]
enum Chain {
    Plain(Annealer),
    Tiled(TiledAnnealer),
}

impl Chain {
    fn new(state: TacState, params: AnnealParams) -> Result<Self> {
        Ok(if params.tiles > 1 {
            Chain::Tiled(TiledAnnealer::new(state, params)?)
        } else {
            Chain::Plain(Annealer::new(state, params)?)
        })
    }

    fn is_done(&self) -> bool {
        match self {
            Chain::Plain(a) => a.is_done(),
            Chain::Tiled(a) => a.is_done(),
        }
    }

    fn trace(&self) -> &[SweepRecord] {
        match self {
            Chain::Plain(a) => a.trace(),
            Chain::Tiled(a) => a.trace(),
        }
    }

    fn sweep_len(&self) -> usize {
        match self {
            Chain::Plain(a) => a.sweep_len(),
            Chain::Tiled(a) => a.sweep_len(),
        }
    }

    fn energy(&self) -> f64 {
        match self {
            Chain::Plain(a) => a.state().energy(),
            Chain::Tiled(a) => a.energy(),
        }
    }

    fn advance_until(&mut self, max_proposals: usize, deadline: Option<Instant>) -> Result<usize> {
        match self {
            Chain::Plain(a) => Ok(a.advance_until(max_proposals, deadline)),
            Chain::Tiled(a) => a.advance_until(max_proposals, deadline),
        }
    }

    fn finish(self, counted: (&Progress, u64)) -> Result<AnnealResult> {
        match self {
            Chain::Plain(a) => a.finish_counted(Some(counted)),
            Chain::Tiled(a) => a.finish_counted(Some(counted)),
        }
    }
}

/// What [`Ensemble::finish`] says about the chains besides the winner.
#[derive(Debug, Clone, PartialEq)]
pub struct EnsembleSummary {
    /// Index of the winning chain (the lowest final energy; ties to the lower index).
    pub best_chain: usize,
    /// Final energy of every chain, in chain order.
    pub energies: Vec<f64>,
}

impl Ensemble {
    /// Starts `params.chain_count(interior edges)` chains from `state` (the last chain) and
    /// copies of it (the others), each
    /// calibrating its own T0, after checking the parameters and what the run will cost
    /// ([`AnnealParams::check_cost`]); the copies are fallible, so memory that runs out
    /// ends in an error naming `chains`. O(chains × (calibration_samples + m)) work, in
    /// parallel; memory O(chains × m).
    pub fn new(state: TacState, params: AnnealParams) -> Result<Self> {
        Self::new_counted(state, params, &Progress::new())
    }

    /// [`Ensemble::new`], counting its work on `progress`: it plans three passes of
    /// `pass_weight` items each (the descent's two LOPs, then the chains' set-up, a
    /// chain at a time). Same result.
    pub fn new_counted(
        mut state: TacState,
        params: AnnealParams,
        progress: &Progress,
    ) -> Result<Self> {
        params.check_for(&state)?;
        let count = params.check_cost(&state)?;
        let weight = pass_weight(state.mesh());
        progress.plan(3 * weight);
        let start = state.mesh().clone();
        let start_energy = state.resync_energy();
        descend(&mut state, &params, progress, weight)?;
        let set_up = Share::new(progress, weight, count as u64);
        let out_of_memory =
            || budget::allocation_failed("chains", count, count as u64 * state.heap_bytes());
        let mut chains = Vec::new();
        chains
            .try_reserve_exact(count)
            .map_err(|_| out_of_memory())?;
        // The last chain takes `state` itself: one chain (every large input) holds no copy.
        chains.par_extend((0..count - 1).into_par_iter().map(|chain| {
            let copy = state.try_clone().map_err(|_| out_of_memory())?;
            let chain = Chain::new(copy, params.for_chain(chain));
            set_up.add(1);
            chain
        }));
        chains.push(Chain::new(state, params.for_chain(count - 1)));
        set_up.finish();
        let chains = chains.into_iter().collect::<Result<Vec<_>>>()?;
        Ok(Ensemble {
            chains,
            start,
            start_energy,
        })
    }

    /// Plans `sweeps` sweeps per chain instead of `params.sweeps` (each chain's cooling
    /// follows), before any proposal: for a budget of proposals spread over the live edges,
    /// known only after the descent ([`Ensemble::sweep_len`]). Errors:
    /// [`Error::InvalidParameter`] naming "sweeps" for 0, for tiled chains (their phases
    /// are planned at the start) or once a chain has proposed. O(chains).
    pub fn replan(&mut self, sweeps: usize) -> Result<()> {
        let refused = |expected| Error::InvalidParameter {
            name: "sweeps",
            value: sweeps.to_string(),
            expected,
        };
        if sweeps == 0 {
            return Err(refused("at least one sweep"));
        }
        for chain in &mut self.chains {
            match chain {
                Chain::Plain(a) => {
                    if !a.replan(sweeps) {
                        return Err(refused("a plan made before the first proposal"));
                    }
                }
                Chain::Tiled(_) => return Err(refused("a plan of untiled chains")),
            }
        }
        Ok(())
    }

    /// Number of chains. O(1).
    pub fn len(&self) -> usize {
        self.chains.len()
    }

    /// Always false: an ensemble has at least one chain.
    pub fn is_empty(&self) -> bool {
        self.chains.is_empty()
    }

    /// True when every chain has finished its sweeps or stopped early. O(chains).
    pub fn is_done(&self) -> bool {
        self.chains.iter().all(Chain::is_done)
    }

    /// Proposals per sweep of each chain (interior edges). O(1).
    pub fn sweep_len(&self) -> usize {
        self.chains[0].sweep_len()
    }

    /// Sweeps completed, summed over the chains. O(chains).
    pub fn sweeps_done(&self) -> usize {
        self.chains.iter().map(|c| c.trace().len()).sum()
    }

    /// The lowest current energy among the chains (radians^p). O(chains).
    pub fn energy(&self) -> f64 {
        self.chains
            .iter()
            .map(Chain::energy)
            .fold(f64::INFINITY, f64::min)
    }

    /// Advances every unfinished chain by at most `max_proposals` proposals, in parallel,
    /// each returning soon after `deadline` (see [`Annealer::advance_until`]). Returns the
    /// proposals run in all. Where chunks end never changes a chain's result. Errors: an
    /// [`Error::OutOfMemory`] when a tiled chain cannot allocate a
    /// phase's tiles.
    pub fn advance_until(
        &mut self,
        max_proposals: usize,
        deadline: Option<Instant>,
    ) -> Result<usize> {
        self.chains
            .par_iter_mut()
            .filter(|c| !c.is_done())
            .map(|c| c.advance_until(max_proposals, deadline))
            .try_reduce(|| 0, |a, b| Ok(a + b))
    }

    /// Runs every chain to its end. O(chains × sweeps × m) work, in parallel.
    pub fn run(mut self) -> Result<(AnnealResult, EnsembleSummary)> {
        while !self.is_done() {
            self.advance_until(usize::MAX, None)?;
        }
        self.finish()
    }

    /// Ends every chain (best state, polish) and returns the winner with the chain summary.
    /// O(chains × (m + polish flips)), in parallel.
    pub fn finish(self) -> Result<(AnnealResult, EnsembleSummary)> {
        self.finish_counted(&Progress::new())
    }

    /// [`Ensemble::finish`], counting its work on `progress`: it plans one pass of
    /// `pass_weight` items per chain, its polish. Same result.
    pub fn finish_counted(self, progress: &Progress) -> Result<(AnnealResult, EnsembleSummary)> {
        let Ensemble {
            chains,
            start,
            start_energy,
        } = self;
        let weight = pass_weight(&start);
        progress.plan(chains.len() as u64 * weight);
        let results = chains
            .into_par_iter()
            .map(|chain| chain.finish((progress, weight)))
            .collect::<Result<Vec<_>>>()?;
        let energies: Vec<f64> = results.iter().map(|r| r.energy).collect();
        // `min_by` keeps the first of equal minima: ties go to the lower chain.
        let best_chain = (0..energies.len())
            .min_by(|&a, &b| energies[a].total_cmp(&energies[b]))
            .expect("an ensemble has at least one chain");
        let mut best = results
            .into_iter()
            .nth(best_chain)
            .expect("best_chain indexes the results");
        best.initial_energy = start_energy;
        if best.energy > start_energy {
            best.mesh = start;
            best.energy = start_energy;
        }
        Ok((
            best,
            EnsembleSummary {
                best_chain,
                energies,
            },
        ))
    }
}

/// A start without the sliver rule is taken when its energy is below this share of the
/// start with it: refusing slivers then costs more than half of the attainable tac.
pub(crate) const SLIVER_COST: f64 = 0.5;

/// ... and at most this share of its triangles are slivers (the panel's goal is 5 %).
pub(crate) const SLIVER_BUDGET: f64 = 0.01;

/// The walk's start: when `params.descend`, the local optimum LOP reaches from `state`
/// under the run's order (with its sliver rule), found once for every chain.
///
/// A crease that crosses the scan lines obliquely can only be followed by thin triangles,
/// so the sliver rule can hold the walk far above LOP's own optimum (the octagonal pocket
/// turned 30 degrees: docs/benchmarks/panel.md, "Figures behind the core's constants"). LOP is
/// therefore also run without the rule, on a copy, and its optimum is the start when it
/// is below [`SLIVER_COST`] × the other's energy with at most [`SLIVER_BUDGET`] slivers;
/// the walk still refuses new slivers from there. The copy is skipped when memory for it
/// cannot be had; LOP's own stack may fail too (an
/// [`Error::OutOfMemory`]). O(flips + m), twice.
pub(crate) fn descend(
    state: &mut TacState,
    params: &AnnealParams,
    progress: &Progress,
    weight: u64,
) -> Result<()> {
    if !params.descend {
        progress.add(2 * weight);
        return Ok(());
    }
    let order = params.order();
    let free = (order.sliver_angle > 0.0)
        .then(|| state.try_clone().ok())
        .flatten();
    tac_lop_counted(state, order, Some((progress, weight)))?;
    let ruled = state.resync_energy();
    if let Some(mut free) = free {
        tac_lop_counted(
            &mut free,
            TacOrder {
                sliver_angle: 0.0,
                ..order
            },
            Some((progress, weight)),
        )?;
        let budget = SLIVER_BUDGET * free.mesh().n_triangles() as f64;
        if free.resync_energy() < SLIVER_COST * ruled
            && free.count_slivers(order.sliver_angle) as f64 <= budget
        {
            *state = free;
        }
    } else {
        progress.add(weight);
    }
    Ok(())
}

/// Items one counted pass of a run on `mesh` is worth: its edges (every pass is O(m)).
/// O(1).
fn pass_weight(mesh: &HalfEdgeMesh) -> u64 {
    (mesh.n_half_edges() as u64 / 2).max(1)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::optimize::tac_state::tests::bumpy_state;

    fn params(chains: usize, seed: u64) -> AnnealParams {
        AnnealParams {
            sweeps: 20,
            seed,
            chains,
            ..AnnealParams::default()
        }
    }

    /// One plain chain from `state`, descended first as the ensemble does.
    fn single(state: &TacState, params: AnnealParams) -> AnnealResult {
        let mut start = state.clone();
        descend(&mut start, &params, &Progress::new(), 1).unwrap();
        let mut one = Annealer::new(start, params).unwrap();
        while !one.is_done() {
            one.advance(usize::MAX);
        }
        one.finish().unwrap()
    }

    #[test]
    fn the_winner_is_the_best_of_the_single_chains_whatever_the_thread_count() {
        let st = bumpy_state(120, 27, 1.0);
        let p = params(5, 13);
        let singles: Vec<AnnealResult> = (0..5).map(|c| single(&st, p.for_chain(c))).collect();
        let energies: Vec<f64> = singles.iter().map(|r| r.energy).collect();
        let winner = (0..5)
            .min_by(|&a, &b| energies[a].total_cmp(&energies[b]))
            .unwrap();
        assert!(
            energies.iter().any(|&e| e != energies[winner]),
            "chains should differ: {energies:?}"
        );
        for threads in [1, 2, 3] {
            let pool = rayon::ThreadPoolBuilder::new()
                .num_threads(threads)
                .build()
                .unwrap();
            let (r, summary) = pool
                .install(|| Ensemble::new(st.clone(), p.clone()).unwrap().run())
                .unwrap();
            assert_eq!(summary.energies, energies);
            assert_eq!(summary.best_chain, winner);
            assert_eq!(
                r.mesh.triangles().unwrap(),
                singles[winner].mesh.triangles().unwrap()
            );
        }
    }

    #[test]
    fn chunked_and_deadline_runs_equal_one_shot_runs() {
        let st = bumpy_state(150, 28, 1.0);
        let (one, _) = Ensemble::new(st.clone(), params(3, 5))
            .unwrap()
            .run()
            .unwrap();
        let mut chunked = Ensemble::new(st.clone(), params(3, 5)).unwrap();
        assert_eq!(chunked.len(), 3);
        let mut total = 0;
        while !chunked.is_done() {
            total += chunked.advance_until(37, Some(Instant::now())).unwrap();
            assert!(chunked.energy().is_finite());
        }
        assert!(total >= 3 * chunked.sweep_len());
        assert!(chunked.sweeps_done() <= 3 * 20);
        let (r, _) = chunked.finish().unwrap();
        assert_eq!(r.mesh.triangles().unwrap(), one.mesh.triangles().unwrap());
    }

    #[test]
    fn one_chain_is_the_plain_annealer() {
        let st = bumpy_state(150, 29, 1.0);
        let (r, summary) = Ensemble::new(st.clone(), params(1, 8))
            .unwrap()
            .run()
            .unwrap();
        assert_eq!(summary.best_chain, 0);
        assert_eq!(
            r.mesh.triangles().unwrap(),
            single(&st, params(1, 8)).mesh.triangles().unwrap()
        );
    }

    #[test]
    fn a_counted_run_reaches_what_it_planned_and_is_the_same_run() {
        let st = bumpy_state(150, 30, 1.0);
        let variants = [
            params(3, 2),
            AnnealParams {
                descend: false,
                polish: false,
                ..params(1, 3)
            },
            AnnealParams {
                tiles: 2,
                ..params(1, 4)
            },
        ];
        for p in variants {
            let (plain, _) = Ensemble::new(st.clone(), p.clone()).unwrap().run().unwrap();
            let progress = Progress::new();
            let mut run = Ensemble::new_counted(st.clone(), p.clone(), &progress).unwrap();
            let planned = progress.total();
            assert!(planned > 0 && progress.done() == planned, "{p:?}");
            while !run.is_done() {
                run.advance_until(usize::MAX, None).unwrap();
            }
            let (counted, _) = run.finish_counted(&progress).unwrap();
            assert!(progress.total() > planned && progress.done() == progress.total());
            assert_eq!(
                counted.mesh.triangles().unwrap(),
                plain.mesh.triangles().unwrap()
            );
        }
    }

    #[test]
    fn a_replanned_run_is_the_run_planned_so_from_the_start() {
        let st = bumpy_state(150, 31, 1.0);
        let longer = AnnealParams {
            sweeps: 33,
            patience: 0,
            ..params(2, 5)
        };
        let (planned, _) = Ensemble::new(st.clone(), longer.clone())
            .unwrap()
            .run()
            .unwrap();
        let shorter = AnnealParams {
            sweeps: 20,
            ..longer
        };
        let mut run = Ensemble::new(st.clone(), shorter).unwrap();
        run.replan(33).unwrap();
        let (replanned, _) = run.run().unwrap();
        assert_eq!(replanned.trace.len(), planned.trace.len());
        assert_eq!(
            replanned.mesh.triangles().unwrap(),
            planned.mesh.triangles().unwrap()
        );
        let mut started = Ensemble::new(st.clone(), params(1, 20)).unwrap();
        assert!(started.replan(0).is_err());
        started.advance_until(1, None).unwrap();
        assert!(started.replan(40).is_err());
        let tiled = AnnealParams {
            tiles: 2,
            ..params(1, 20)
        };
        assert!(Ensemble::new(st, tiled).unwrap().replan(40).is_err());
    }

    #[test]
    fn bad_parameters_fail_before_any_chain_runs() {
        let st = bumpy_state(50, 1, 1.0);
        let bad = AnnealParams {
            p: 0.5,
            ..params(4, 1)
        };
        assert!(Ensemble::new(st.clone(), bad).is_err());
        // A million chains would calibrate for minutes before the first chunk.
        match Ensemble::new(st, params(1_000_000, 1)) {
            Err(crate::Error::TooCostly { name: "chains", .. }) => {}
            other => panic!("{:?}", other.map(|e| e.len())),
        }
    }
}
