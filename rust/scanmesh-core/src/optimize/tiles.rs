//! One annealing chain on several cores: the plane cut into stripes that anneal at once.
//!
//! Why the energy stays exact: it is a sum over vertices, and a flip changes the angle sums
//! of its quadrilateral's four corners only. Every vertex is given to one tile (a stripe
//! of the plane); a triangle whose three corners share a tile belongs to that tile, any
//! other triangle (crossing a stripe border) is frozen for the phase. A flip among a
//! tile's triangles has its four corners in that tile, so it changes that tile's vertices
//! alone, and the tiles share nothing: each runs as an ordinary [`Annealer`] on its own
//! piece, with its border vertices' angle sums taken from the whole triangulation (their
//! frozen triangles' angles included), so its energy changes are the global ones.
//!
//! Phases: each runs [`PHASE_SWEEPS`] sweeps (a tile's sweep is one proposal per interior
//! edge of the tile), then the pieces are put back together and the stripes shifted by
//! half a stripe (the two outer half stripes then form one tile: a tile need not be
//! connected), so an edge frozen in one phase lies inside a tile in the next. One T0,
//! calibrated on the whole triangulation with the chain's seed, and one cooling per sweep
//! as for the sequential chain. Best state: tiles are independent, so each tile's best of
//! a phase together is a triangulation whose energy is the sum; it is kept when lower than
//! the best so far. The early stop is decided on the sweep records of the whole but takes
//! effect at the end of a phase. Tile i of phase j runs on a seed derived from
//! (seed, j, i), so the result depends on (seed, tiles) and not on the thread count or the
//! chunking.

use crate::budget::{try_collect, try_filled, try_grow, try_vec};
use crate::mesh::HalfEdgeMesh;
use crate::optimize::anneal::SweepRecord;
use crate::optimize::anneal::{
    cooling, initial_temperature, polish, AnnealParams, AnnealResult, Annealer, Stop,
};
use crate::optimize::tac_state::{vertex_energy, TacState};
use crate::progress::Progress;
use crate::Result;
use glam::DVec3;
use rayon::prelude::*;
use std::time::Instant;

/// Sweeps per phase. Longer phases amortize the cut, the reassembly (O(m) each, a few
/// milliseconds on the rod) and the wait for the slowest tile; shorter ones move the frozen
/// borders more often; 100 ran faster than 50 to the same energy (docs/benchmarks/speed.md,
/// "Figures behind the core's constants").
pub const PHASE_SWEEPS: usize = 100;

/// What the tiled run's failed allocations name.
const TILES: &str = "the annealing tiles";

/// `values` of `vertices`, in a vector whose allocation may fail. O(len).
fn gather<T: Copy>(values: &[T], vertices: &[u32]) -> Result<Vec<T>> {
    try_collect(TILES, vertices.iter().map(|&v| values[v as usize]))
}

/// A resumable annealing chain run in [`AnnealParams::tiles`] stripes at once.
pub struct TiledAnnealer {
    params: AnnealParams,
    uv: Vec<[f64; 2]>,
    xyz: Vec<DVec3>,
    sight: Option<DVec3>,
    // Per vertex, fixed for the run: interior flag and rank along the stripe axis.
    interior: Vec<bool>,
    rank: Vec<u32>,
    // The current triangulation and angle sums, exact between phases (a running phase
    // holds its tiles' parts).
    triangles: Vec<[u32; 3]>,
    sums: Vec<f64>,
    energy: f64,
    interior_edges: usize,
    running: Option<Phase>,
    phases_done: usize,
    initial_energy: f64,
    initial_temperature: f64,
    temperature: f64,
    cooling: f64,
    trace: Vec<SweepRecord>,
    best: Vec<[u32; 3]>,
    best_energy: f64,
    since_best: usize,
    stopped_early: bool,
    proposals: u64,
}

/// A phase in progress: the frozen triangles, the energy of the vertices in no tile, the
/// sweeps it runs and the tiles' runs.
struct Phase {
    frozen: Vec<[u32; 3]>,
    constant: f64,
    sweeps: usize,
    tiles: Vec<Tile>,
}

/// One tile's piece: its vertices (local index → global) and its run.
struct Tile {
    vertices: Vec<u32>,
    run: Annealer,
}

impl TiledAnnealer {
    /// Starts a run from `state` in `params.tiles` stripes; calibrates T0 on the whole state
    /// as [`Annealer::new`] does. O(calibration_samples + m + n log n).
    pub fn new(mut state: TacState, params: AnnealParams) -> Result<Self> {
        params.check_for(&state)?;
        let initial_temperature = initial_temperature(&mut state, &params)?;
        let n = state.mesh().n_vertices();
        let interior = try_collect(TILES, (0..n as u32).map(|v| state.mesh().is_interior(v)))?;
        // Stripes across the longer side of the used vertices' box: shorter borders.
        let mut used: Vec<u32> = try_vec(TILES, n)?;
        used.extend((0..n as u32).filter(|&v| state.mesh().is_used(v)));
        let uv = state.uv()?;
        let spread = |k: usize| {
            let (lo, hi) = used
                .iter()
                .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), &v| {
                    let x = uv[v as usize][k];
                    (lo.min(x), hi.max(x))
                });
            hi - lo
        };
        let axis = usize::from(spread(1) > spread(0));
        let mut order: Vec<u32> = try_collect(TILES, 0..n as u32)?;
        order.sort_by(|&a, &b| {
            uv[a as usize][axis]
                .total_cmp(&uv[b as usize][axis])
                .then(a.cmp(&b))
        });
        let mut rank = try_filled(TILES, 0, n)?;
        for (r, &v) in order.iter().enumerate() {
            rank[v as usize] = r as u32;
        }
        let energy = state.energy();
        let triangles = state.mesh().triangles()?;
        Ok(TiledAnnealer {
            sums: try_collect(TILES, (0..n as u32).map(|v| state.angle_sum(v)))?,
            interior_edges: state.count_interior_half_edges() / 2,
            uv,
            xyz: state.xyz()?,
            sight: state.sight(),
            interior,
            rank,
            best: try_collect(TILES, triangles.iter().copied())?,
            triangles,
            energy,
            running: None,
            phases_done: 0,
            initial_energy: energy,
            initial_temperature,
            temperature: initial_temperature,
            cooling: cooling(params.final_temperature_ratio, params.sweeps),
            trace: Vec::new(),
            best_energy: energy,
            since_best: 0,
            stopped_early: false,
            proposals: 0,
            params,
        })
    }

    /// True when every sweep has run or the run stopped early. O(1).
    pub fn is_done(&self) -> bool {
        self.interior_edges == 0 || self.stopped_early || self.trace.len() >= self.params.sweeps
    }

    /// Sweep records of the finished phases (energy and best of the whole triangulation).
    pub fn trace(&self) -> &[SweepRecord] {
        &self.trace
    }

    /// Interior edges of the whole triangulation (about the proposals of one sweep). O(1).
    pub fn sweep_len(&self) -> usize {
        self.interior_edges
    }

    /// Proposals made in the finished phases: a tile's sweep proposes once per interior edge
    /// of the tile, so edges frozen across stripe borders make this smaller than sweeps ×
    /// [`sweep_len`](Self::sweep_len). O(1).
    pub fn proposals(&self) -> u64 {
        self.proposals
    }

    /// Current energy of the whole triangulation (radians^p). O(tiles).
    pub fn energy(&self) -> f64 {
        match &self.running {
            None => self.energy,
            Some(phase) => {
                phase.constant
                    + phase
                        .tiles
                        .iter()
                        .map(|t| t.run.state().energy())
                        .sum::<f64>()
            }
        }
    }

    /// Runs the tiles of the current phase (starting one if needed) in parallel, each for
    /// at most `max_proposals` proposals, returning soon after `deadline` and at the end of
    /// the phase. Returns the proposals run. Where calls end never changes the result.
    /// Errors: an [`Error::OutOfMemory`](crate::Error::OutOfMemory) when a phase's tiles, or
    /// the triangulation they are put back into, cannot be allocated.
    pub fn advance_until(
        &mut self,
        max_proposals: usize,
        deadline: Option<Instant>,
    ) -> Result<usize> {
        let mut ran = 0;
        while !self.is_done() {
            if self.running.is_none() {
                self.start_phase()?;
            }
            let phase = self.running.as_mut().expect("a phase was started");
            ran += phase
                .tiles
                .par_iter_mut()
                .filter(|t| !t.run.is_done())
                .map(|t| t.run.advance_until(max_proposals, deadline))
                .sum::<usize>();
            // Returning at a phase's end lets a caller see every whole triangulation.
            if phase.tiles.iter().all(|t| t.run.is_done()) {
                self.end_phase()?;
                break;
            }
            if ran >= max_proposals || deadline.is_some_and(|d| Instant::now() >= d) {
                break;
            }
        }
        Ok(ran)
    }

    /// Cuts the current triangulation into this phase's tiles; the copies that grow with
    /// the input are allocated fallibly (an
    /// [`Error::OutOfMemory`](crate::Error::OutOfMemory)). O(m).
    fn start_phase(&mut self) -> Result<()> {
        let n = self.uv.len();
        let k = self.params.tiles;
        // Even phases: k stripes of equal vertex counts; odd phases: the borders in the
        // middle of those stripes, the two outer half stripes making one tile, so that
        // every phase has k tiles of equal counts (k + 1 unequal tiles on k cores would
        // leave one core waiting).
        let shift = (self.phases_done % 2) as u64;
        let tile_of = |v: u32| {
            let r = self.rank[v as usize] as u64;
            ((2 * r * k as u64 + shift * n as u64) / (2 * n as u64)) as usize % k
        };
        let mut pieces: Vec<Vec<[u32; 3]>> = vec![Vec::new(); k];
        let mut frozen = Vec::new();
        for &tri in &self.triangles {
            let t = tile_of(tri[0]);
            let to = if tile_of(tri[1]) == t && tile_of(tri[2]) == t {
                &mut pieces[t]
            } else {
                &mut frozen
            };
            try_grow(TILES, to, 1)?;
            to.push(tri);
        }
        // Local indices: each vertex belongs to one tile, so one array serves all tiles.
        const UNSET: u32 = u32::MAX;
        let mut local = try_filled(TILES, UNSET, n)?;
        let mut vertices: Vec<Vec<u32>> = vec![Vec::new(); k];
        for (t, piece) in pieces.iter().enumerate() {
            for &v in piece.iter().flatten() {
                if local[v as usize] == UNSET {
                    local[v as usize] = vertices[t].len() as u32;
                    try_grow(TILES, &mut vertices[t], 1)?;
                    vertices[t].push(v);
                }
            }
        }
        let constant: f64 = (0..n)
            .filter(|&v| self.interior[v] && local[v] == UNSET)
            .map(|v| vertex_energy(self.sums[v], self.params.p))
            .sum();
        let sweeps = PHASE_SWEEPS.min(self.params.sweeps - self.trace.len());
        let phase = self.phases_done;
        let tiles = pieces
            .into_par_iter()
            .zip(vertices)
            .enumerate()
            .map(|(t, (piece, vertices))| {
                let local_tris = try_collect(
                    TILES,
                    piece.iter().map(|tri| tri.map(|v| local[v as usize])),
                )?;
                // A subset of a valid triangulation: only its allocations can fail.
                let mesh = HalfEdgeMesh::from_triangles(vertices.len(), &local_tris)?;
                // Positions, p and the sight were checked for the whole state: as above.
                let state = TacState::with_vertex_sums(
                    mesh,
                    gather(&self.uv, &vertices)?,
                    gather(&self.xyz, &vertices)?,
                    self.params.p,
                    &gather(&self.sums, &vertices)?,
                    &gather(&self.interior, &vertices)?,
                )?
                .with_sight(self.sight)?;
                let params = AnnealParams {
                    sweeps,
                    patience: 0,
                    seed: tile_seed(self.params.seed, phase, t),
                    ..self.params.clone()
                };
                Ok(Tile {
                    vertices,
                    run: Annealer::for_phase(state, params, self.temperature, self.cooling)?,
                })
            })
            .collect::<Result<Vec<_>>>()?;
        self.running = Some(Phase {
            frozen,
            constant,
            sweeps,
            tiles,
        });
        Ok(())
    }

    /// Puts the tiles back together: the current triangulation and sums, the sweep records
    /// of the phase, and the phase's best when it beats the best so far. Errors: an
    /// [`Error::OutOfMemory`](crate::Error::OutOfMemory) for the triangulations (before
    /// anything changes). O(m).
    fn end_phase(&mut self) -> Result<()> {
        let phase = self.running.take().expect("a phase is running");
        let ends: Vec<TileEnd> = phase
            .tiles
            .into_par_iter()
            .map(|tile| {
                let exhausted = tile.run.is_exhausted();
                let (best, best_energy, state, trace) = tile.run.end_phase();
                TileEnd {
                    vertices: tile.vertices,
                    best,
                    best_energy,
                    state,
                    trace,
                    exhausted,
                }
            })
            .collect();
        // The triangulations put back together, allocated before anything changes.
        let phase_best = ends
            .iter()
            .fold(phase.constant, |sum, e| sum + e.best_energy);
        let mut triangles = try_vec(TILES, phase.frozen.len() + count(&ends, |e| e.state.mesh()))?;
        let beats = phase_best < self.best_energy;
        let mut best = phase.frozen;
        if beats {
            try_grow(TILES, &mut best, count(&ends, |e| &e.best))?;
        }
        // Sweeps every tile finished (all of the phase's, unless the run was interrupted);
        // a tile without live edges (from the start or from some sweep on) runs no more
        // sweeps and keeps its energy. When no tile has a live edge (flat pieces, or
        // stripes narrower than a triangle: tiny inputs, many tiles) the phase's sweeps
        // pass with every edge frozen; counting none would start the same empty phase
        // again forever.
        let swept = ends
            .iter()
            .filter(|e| !e.exhausted)
            .map(|e| e.trace.len())
            .min()
            .unwrap_or(phase.sweeps);
        for j in 0..swept {
            let (mut energy, mut best, mut accepted, mut proposed) =
                (phase.constant, phase.constant, 0.0, 0);
            let mut frozen = true;
            for e in &ends {
                match e.trace.get(j) {
                    Some(r) => {
                        energy += r.energy;
                        best += r.best;
                        accepted += r.acceptance * r.proposals as f64;
                        proposed += r.proposals;
                        frozen &= r.frozen;
                    }
                    None => {
                        energy += e.state.energy();
                        best += e.best_energy;
                    }
                }
            }
            let before = self.trace.last().map_or(self.best_energy, |r| r.best);
            // A new best by less than the tie tolerance is rounding in some tile's
            // incremental energy, summed over many tiles: it does not reset the early stop.
            self.since_best = if best < before - self.params.tie_tolerance {
                0
            } else {
                self.since_best + 1
            };
            if self.params.patience > 0 && frozen && self.since_best >= self.params.patience {
                self.stopped_early = true;
            }
            self.trace.push(SweepRecord {
                temperature: self.temperature,
                energy,
                best: best.min(before),
                acceptance: accepted / proposed.max(1) as f64,
                proposals: proposed,
                frozen,
            });
            self.temperature *= self.cooling;
        }
        // Summed in the order of the sweep records' best, so the two agree to the bit.
        self.proposals += ends
            .iter()
            .flat_map(|e| &e.trace)
            .map(|r| r.proposals as u64)
            .sum::<u64>();
        triangles.extend_from_slice(&best);
        for e in &ends {
            triangles.extend(globalize(&e.vertices, e.state.mesh()));
            for (l, &v) in e.vertices.iter().enumerate() {
                self.sums[v as usize] = e.state.angle_sum(l as u32);
            }
        }
        if beats {
            self.best_energy = phase_best;
            for e in &ends {
                best.extend(globalize(&e.vertices, &e.best));
            }
            self.best = best;
        }
        self.triangles = triangles;
        self.energy = (0..self.sums.len())
            .filter(|&v| self.interior[v])
            .map(|v| vertex_energy(self.sums[v], self.params.p))
            .sum();
        self.phases_done += 1;
        Ok(())
    }

    /// Ends the run: the best state, polished as [`Annealer::finish`] polishes. A phase
    /// still running (an interrupted run) is ended first. O(m + polish flips).
    pub fn finish(self) -> Result<AnnealResult> {
        self.finish_counted(None)
    }

    /// [`TiledAnnealer::finish`], its polish counted as `weight` items of `progress` when `counted` is
    /// `(progress, weight)`.
    pub fn finish_counted(mut self, counted: Option<(&Progress, u64)>) -> Result<AnnealResult> {
        if self.running.is_some() {
            self.end_phase()?;
        }
        let best = HalfEdgeMesh::from_triangles(self.uv.len(), &self.best)?;
        let best = TacState::new(best, self.uv, self.xyz, self.params.p)?.with_sight(self.sight)?;
        let (mesh, energy, polish_flips) = polish(best, &self.params, counted)?;
        Ok(AnnealResult {
            mesh,
            initial_energy: self.initial_energy,
            energy,
            initial_temperature: self.initial_temperature,
            stopped: Stop::of(
                self.trace.len(),
                self.params.sweeps,
                self.stopped_early,
                self.interior_edges == 0,
            ),
            trace: self.trace,
            polish_flips,
        })
    }
}

/// What a tile hands back at the end of a phase.
struct TileEnd {
    vertices: Vec<u32>,
    best: HalfEdgeMesh,
    best_energy: f64,
    state: TacState,
    trace: Vec<SweepRecord>,
    // The tile ran out of live edges: it stopped before the phase's sweeps, done.
    exhausted: bool,
}

/// A piece's triangles in global vertex indices (`vertices`: local → global), in the
/// order of [`HalfEdgeMesh::triangles`]. O(1), then O(1) per triangle.
fn globalize<'a>(
    vertices: &'a [u32],
    mesh: &'a HalfEdgeMesh,
) -> impl Iterator<Item = [u32; 3]> + 'a {
    (0..mesh.n_triangles()).map(|t| mesh.triangle(t).map(|v| vertices[v as usize]))
}

/// The triangles of the meshes `mesh` picks from the tiles' ends. O(tiles).
fn count(ends: &[TileEnd], mesh: impl Fn(&TileEnd) -> &HalfEdgeMesh) -> usize {
    ends.iter().map(|e| mesh(e).n_triangles()).sum()
}

/// Seed of tile `tile` in phase `phase`: [`AnnealParams::for_chain`]'s mixing of the pair.
/// O(1).
fn tile_seed(seed: u64, phase: usize, tile: usize) -> u64 {
    let base = AnnealParams {
        seed,
        ..AnnealParams::default()
    };
    base.for_chain(1 + phase * crate::optimize::anneal::MAX_TILES + tile)
        .seed
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::optimize::anneal::tests::anneal;
    use crate::optimize::lop::{lop, TacLop};
    use crate::optimize::tac_state::tests::{bumpy_state, plateau_state};

    fn params(tiles: usize, sweeps: usize, seed: u64) -> AnnealParams {
        AnnealParams {
            sweeps,
            seed,
            tiles,
            chains: 1,
            patience: 0,
            ..AnnealParams::default()
        }
    }

    fn run(st: &TacState, p: AnnealParams) -> AnnealResult {
        let mut a = TiledAnnealer::new(st.clone(), p).unwrap();
        while !a.is_done() {
            a.advance_until(usize::MAX, None).unwrap();
        }
        a.finish().unwrap()
    }

    /// The state of `triangles` over `st`'s positions, measured from scratch.
    fn measured(st: &TacState, triangles: &[[u32; 3]]) -> TacState {
        let mesh = HalfEdgeMesh::from_triangles(st.uv().unwrap().len(), triangles).unwrap();
        TacState::new(mesh, st.uv().unwrap(), st.xyz().unwrap(), st.p()).unwrap()
    }

    #[test]
    fn phases_keep_sums_energy_and_best_exact() {
        for (st, tiles) in [
            (bumpy_state(900, 31, 1.0), 3),
            (plateau_state(900, 32, 2.0), 2),
        ] {
            let p = AnnealParams {
                p: st.p(),
                ..params(tiles, 3 * PHASE_SWEEPS, 4)
            };
            let mut a = TiledAnnealer::new(st.clone(), p).unwrap();
            let mut checked = 0;
            while !a.is_done() {
                a.advance_until(1_000, None).unwrap();
                if a.running.is_some() {
                    continue;
                }
                checked += 1;
                // Between phases: the triangulation is valid, and its angle sums and energy
                // measured from scratch equal the ones the tiles maintained.
                let now = measured(&st, &a.triangles);
                now.mesh().validate(&st.uv().unwrap()).unwrap();
                for v in 0..st.mesh().n_vertices() as u32 {
                    assert!((now.angle_sum(v) - a.sums[v as usize]).abs() < 1e-9);
                }
                let scratch = now.energy_from_scratch();
                assert!(
                    (a.energy() - scratch).abs() <= 1e-9 * scratch.max(1.0),
                    "{} vs {scratch}",
                    a.energy()
                );
                // The best kept is a valid triangulation with the recorded energy.
                let best = measured(&st, &a.best);
                best.mesh().validate(&st.uv().unwrap()).unwrap();
                let e = best.energy_from_scratch();
                assert!((a.best_energy - e).abs() <= 1e-9 * e.max(1.0));
                assert_eq!(a.trace().last().unwrap().best, a.best_energy);
            }
            assert_eq!((checked, a.phases_done), (3, 3));
            assert_eq!(a.trace().len(), 3 * PHASE_SWEEPS);
        }
    }

    #[test]
    fn tiles_anneal_as_well_as_one_chain_and_beat_lop() {
        let st = bumpy_state(1500, 33, 1.0);
        let mut lop_state = st.clone();
        lop(
            &mut TacLop {
                state: &mut lop_state,
                order: AnnealParams::default().order(),
            },
            usize::MAX,
        )
        .unwrap();
        let plain = anneal(st.clone(), params(1, 200, 5)).unwrap();
        let tiled = run(&st, params(3, 200, 5));
        tiled.mesh.validate(&st.uv().unwrap()).unwrap();
        assert_eq!(tiled.mesh.n_triangles(), st.mesh().n_triangles());
        assert!(tiled.energy < lop_state.energy());
        assert!(
            tiled.energy < 1.1 * plain.energy,
            "tiled {} vs one chain {}",
            tiled.energy,
            plain.energy
        );
        assert_eq!(tiled.trace.len(), 200);
        assert!(tiled
            .trace
            .windows(2)
            .all(|w| w[1].best <= w[0].best && w[1].temperature < w[0].temperature));
        // The polish starts from the best: it can only go lower.
        assert!(tiled.energy <= tiled.trace.last().unwrap().best + 1e-9);
    }

    #[test]
    fn same_result_on_any_thread_count_and_chunking() {
        let st = bumpy_state(700, 34, 1.0);
        let p = params(4, 120, 9);
        let one = run(&st, p.clone());
        for threads in [1, 2, 3] {
            let pool = rayon::ThreadPoolBuilder::new()
                .num_threads(threads)
                .build()
                .unwrap();
            let r = pool.install(|| run(&st, p.clone()));
            assert_eq!(r.mesh.triangles().unwrap(), one.mesh.triangles().unwrap());
            assert_eq!(r.trace, one.trace);
        }
        let mut chunked = TiledAnnealer::new(st.clone(), p.clone()).unwrap();
        while !chunked.is_done() {
            chunked.advance_until(37, Some(Instant::now())).unwrap();
        }
        let r = chunked.finish().unwrap();
        assert_eq!(r.mesh.triangles().unwrap(), one.mesh.triangles().unwrap());
        assert_eq!(r.trace, one.trace);
        let other = run(&st, params(4, 120, 10));
        assert_ne!(
            other.mesh.triangles().unwrap(),
            one.mesh.triangles().unwrap()
        );
    }

    #[test]
    fn early_stop_and_interruption_end_cleanly() {
        let st = bumpy_state(600, 35, 1.0);
        let r = run(
            &st,
            // Cold enough by the end that every tile freezes (no uphill move accepted).
            AnnealParams {
                patience: 20,
                final_temperature_ratio: 1e-12,
                ..params(2, 5_000, 3)
            },
        );
        assert!(r.stopped == Stop::Patience && r.trace.len() < 5_000);
        assert_eq!(r.trace.len() % PHASE_SWEEPS, 0);
        // Interrupted in the middle of a phase: finish still returns a valid best.
        let mut a = TiledAnnealer::new(st.clone(), params(2, 1_000, 3)).unwrap();
        a.advance_until(500, None).unwrap();
        assert!(a.running.is_some());
        let r = a.finish().unwrap();
        r.mesh.validate(&st.uv().unwrap()).unwrap();
        assert!(r.energy <= r.initial_energy);
    }

    #[test]
    fn stripes_without_interior_edges_still_end() {
        // 8 points in 3 stripes, or 300 in 64: some or every phase has no tile with an
        // interior edge. Each phase must still count its sweeps, or the run never ends.
        for (n, tiles) in [(8, 3), (8, crate::optimize::anneal::MAX_TILES), (300, 64)] {
            let st = bumpy_state(n, 37, 1.0);
            let r = run(&st, params(tiles, 250, 2));
            assert_eq!(r.trace.len(), 250, "{n} points in {tiles} tiles");
            r.mesh.validate(&st.uv().unwrap()).unwrap();
            assert!(r.energy <= r.initial_energy + 1e-12);
        }
    }

    #[test]
    fn bad_tile_counts_are_refused() {
        let st = bumpy_state(100, 36, 1.0);
        for tiles in [0, crate::optimize::anneal::MAX_TILES + 1] {
            assert!(TiledAnnealer::new(st.clone(), params(tiles, 10, 1)).is_err());
        }
        let other_p = AnnealParams {
            p: 2.0,
            ..params(2, 10, 1)
        };
        assert!(TiledAnnealer::new(st, other_p).is_err());
    }
}
