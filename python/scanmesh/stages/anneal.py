"""Simulated annealing on the tac criterion, over a planar triangulation and its scan."""

from __future__ import annotations

import dataclasses
import math
import time
from collections.abc import Callable
from typing import Any

import numpy as np

from scanmesh import _core
from scanmesh._checks import Option, check_options
from scanmesh._context import QUIET, Context
from scanmesh._interrupt import interruptible
from scanmesh._progress import Progress, accepts, anneal_progress
from scanmesh.scan.noise import noise_tolerance
from scanmesh.stages.options import (
    CORE_ANNEAL_DEFAULTS,
    CURTAIN_ANGLE_OPTION,
    P_OPTION,
    SEED_OPTION,
    SLIVER_GUARD_OPTION,
    TIE_TOLERANCE_OPTION,
    curtain_sight,
    planar_start,
)
from scanmesh.surface import Surface

#: The core's annealing parameters handled in Python instead: ``seed`` is the shared keyword
#: (:data:`SEED_OPTION`, None: 0), passed apart from the schedule.
PYTHON_HANDLED: frozenset[str] = frozenset({"seed"})

#: Defaults of the annealing schedule, read from the Rust core (one source of truth).
ANNEAL_DEFAULTS: dict[str, Any] = {
    k: v for k, v in CORE_ANNEAL_DEFAULTS.items() if k not in PYTHON_HANDLED
}

#: Most tiles per chain (the core's limit, read from it).
MAX_TILES: int = _core.MAX_TILES

#: Each native call runs at most this long (seconds) before Python checks for Ctrl-C and
#: reports progress: bounded in time, not in proposals, so the latency holds on slow machines.
CHUNK_SECONDS = 0.02

#: ... and at most this many proposals per call.
CHUNK_PROPOSALS = 1_000_000

#: The run's start (its state, the descent to LOP's optimum) per point, in the units of
#: :data:`scanmesh._interrupt.THREAD_MIN_COST`: 0.4 s for the default's 18,000-point parts
#: under load, which held Ctrl-C up when run on the main thread; each calibration proposal
#: counts one more unit.
CALIBRATE_COST = 20

#: Trace columns, in the order the core returns them.
TRACE_COLUMNS = ("temperature", "energy", "best", "acceptance")

#: What ``options["stopped"]`` says ended the run (the winning chain's): the time limit,
#: frozen without a new best for ``patience`` sweeps, every sweep run, or no live edge
#: left ("exhausted": no flip could lower the energy by more than a tie, so more sweeps
#: could not change the result; also when there was none to begin with).
STOP_REASONS = ("time_limit", "patience", "sweeps", "exhausted")

#: What a run's ``options`` take from the core's ``AnnealOutcome``, in this order.
SUMMARY = (
    "initial_energy",
    "energy",
    "initial_temperature",
    "polish_flips",
    "proposals",
    "stopped",
    "chains",
    "best_chain",
    "chain_energies",
)


#: Most chains one run may ask for (automatic runs use at most 128): each holds a copy of
#: the mesh, so the count is bounded by memory as well as by time.
MAX_CHAINS: int = 1024

#: A bound on counts of sweeps and proposals that no run could reach in a lifetime; it keeps
#: absurd values (2**64, 10**30) from overflowing the core's integers.
MAX_COUNT: int = 10**9

#: The most calibration proposals: T0 is a median, a few thousand samples fix it.
MAX_CALIBRATION_SAMPLES: int = 10**6

#: ``time_limit``: wall seconds of annealing, then the best state so far (None: no limit).
TIME_LIMIT_OPTION = Option(
    "time_limit",
    "float",
    None,
    "seconds of annealing (the sweeps), then the best state so far",
    low=0.0,
    low_open=True,
    automatic=True,
)

#: The annealing schedule's options, defaults from the core.
OPTIONS: tuple[Option, ...] = (
    Option(
        "sweeps",
        "int",
        None,
        "sweeps (one proposal per live edge each: flippable, by a corner with tac above ties)"
        " (automatic: sized to the scan, see AnnealParams.auto_sweeps)",
        low=0,
        high=MAX_COUNT,
        automatic=True,
    ),
    P_OPTION,
    Option(
        "initial_acceptance",
        "float",
        ANNEAL_DEFAULTS["initial_acceptance"],
        "probability of accepting the median uphill move at T0",
        low=0.0,
        high=1.0,
        low_open=True,
        high_open=True,
    ),
    Option(
        "final_temperature_ratio",
        "float",
        ANNEAL_DEFAULTS["final_temperature_ratio"],
        "final temperature as a share of T0",
        low=0.0,
        high=1.0,
        low_open=True,
    ),
    Option(
        "patience",
        "int",
        ANNEAL_DEFAULTS["patience"],
        "stop after this many sweeps without a new best once frozen (0: never)",
        low=0,
        high=MAX_COUNT,
    ),
    SLIVER_GUARD_OPTION,
    # None: from the scan's noise (noise.noise_tolerance). Not the default: measured on the
    # panel, the noise's tolerance switched annealing off on real scans (SainteHelens,
    # fran_cut) and the automatic choice of a method guards noisy scans instead.
    dataclasses.replace(
        TIE_TOLERANCE_OPTION,
        doc=TIE_TOLERANCE_OPTION.doc + " (None: from the scan's noise estimate)",
        automatic=True,
    ),
    Option(
        "planar_ties",
        "bool",
        ANNEAL_DEFAULTS["planar_ties"],
        "judge flips between corners flat up to the noise by the planar angle (Delaunay's)",
    ),
    Option("polish", "bool", ANNEAL_DEFAULTS["polish"], "run LOP from the best state at the end"),
    Option(
        "descend",
        "bool",
        ANNEAL_DEFAULTS["descend"],
        "start the walk from LOP's local optimum of the initial triangulation",
    ),
    Option(
        "sliver_angle",
        "float",
        ANNEAL_DEFAULTS["sliver_angle"],
        "refuse flips that make a smallest 3-D angle fall below this (degrees; 0: off)",
        low=0.0,
        high=60.0,
        high_open=True,
    ),
    CURTAIN_ANGLE_OPTION,
    Option(
        "calibration_samples",
        "int",
        ANNEAL_DEFAULTS["calibration_samples"],
        "proposals sampled to calibrate T0",
        low=0,
        high=MAX_CALIBRATION_SAMPLES,
    ),
    Option(
        "chains",
        "int",
        ANNEAL_DEFAULTS["chains"],
        "independent chains, the best kept (0: automatic)",
        low=0,
        high=MAX_CHAINS,
    ),
    Option(
        "tiles",
        "int",
        ANNEAL_DEFAULTS["tiles"],
        "anneal each chain in this many stripes of the plane at once",
        low=1,
        high=MAX_TILES,
    ),
    TIME_LIMIT_OPTION,
)


def _progress_bar(progress: Progress, total: int) -> Callable[..., None] | None:
    """A reporter ``(done, total, energy, seconds_left=)`` for ``progress``, or None."""
    if callable(progress):
        if accepts(progress, "seconds_left"):
            return progress
        call = progress

        def plain(done: int, _total: int, energy: float, seconds_left: float | None) -> None:
            call(done, _total, energy)

        return plain
    if not progress:
        return None
    from tqdm import tqdm  # loaded only when a bar is drawn: `import scanmesh` stays light

    # tqdm's own estimate assumes every planned sweep runs: the time left is ours.
    bar = tqdm(
        total=total,
        unit="sweep",
        desc="annealing",
        leave=False,
        bar_format="{l_bar}{bar}| {n_fmt}/{total_fmt} [{elapsed}{postfix}]",
    )

    def update(done: int, _total: int, energy: float, seconds_left: float | None) -> None:
        bar.total = _total
        bar.n = done
        left = "?" if seconds_left is None else tqdm.format_interval(seconds_left)
        bar.set_postfix(energy=f"{energy:.6g}", left=left, refresh=False)
        bar.refresh()
        if done >= _total:
            bar.close()

    update.close = bar.close  # type: ignore[attr-defined]
    return update


def seconds_left(
    sweeps_done: int,
    sweeps_total: int,
    proposals_done: int,
    proposals_total: int,
    elapsed: float,
    limit_left: float | None,
) -> float | None:
    """Estimated seconds until the run ends: the work still planned at the rate so far, at
    most ``limit_left`` (what the time limit leaves); None before anything ran without a
    limit. Within a sweep the share done is read from the proposals, kept between the
    sweeps done and the next one (a chain's sweep need not be ``sweep_len`` proposals)."""
    if sweeps_total <= 0 or proposals_total <= 0:
        share = 1.0
    else:
        share = min(
            max(sweeps_done / sweeps_total, proposals_done / proposals_total),
            (sweeps_done + 1) / sweeps_total,
            1.0,
        )
    estimate = elapsed * (1.0 - share) / share if share > 0 else None
    if limit_left is None:
        return estimate
    limit_left = max(limit_left, 0.0)
    return limit_left if estimate is None else min(estimate, limit_left)


def drive(
    runner: _core.Annealer, total: int, progress: Progress, time_limit: float | None
) -> str | None:
    """Advances ``runner`` chunk by chunk until it is done (None) or ``time_limit`` seconds
    have passed ("time_limit"), reporting each chunk to ``progress`` (``total``: the sweeps
    planned; ``progress=False`` reports nothing). Ctrl-C is seen between chunks of at most
    CHUNK_SECONDS. Every caller that runs a ``_core.Annealer`` (this module, the tiles of
    :mod:`scanmesh.distributed`) drives it here. O(proposals)."""
    report = _progress_bar(progress, total)
    planned = total * runner.sweep_len
    try:
        ran, t_run = 0, time.perf_counter()
        deadline = None if time_limit is None else t_run + time_limit
        while not runner.done:
            now = time.perf_counter()
            if deadline is not None and now >= deadline:
                break
            chunk = CHUNK_SECONDS if deadline is None else min(CHUNK_SECONDS, deadline - now)
            # in a worker for a large state: a call's start (the first one descends to
            # LOP's optimum) is not bounded by `chunk` (0.35 s on 20,000 points)
            ran += interruptible(runner.sweep_len, runner.advance, CHUNK_PROPOSALS, chunk)
            if report is not None:
                now = time.perf_counter()
                limit_left = None if deadline is None else deadline - now
                left = seconds_left(
                    runner.sweeps_done, total, ran, planned, now - t_run, limit_left
                )
                report(runner.sweeps_done, total, runner.energy, seconds_left=left)
        if report is not None:
            # Chains that stop early (or the time limit) leave the count short of the
            # planned total. The total stays what was announced (a total that changed,
            # even to 0 when no sweep ran, reads as a new stage and divides by zero):
            # the last report keeps the sweeps that ran, and options["stopped"] says why.
            report(runner.sweeps_done, total, runner.energy, seconds_left=0.0)
    finally:
        if report is not None and hasattr(report, "close"):
            report.close()
    return None if runner.done else "time_limit"


def anneal_surface(
    initial: Surface,
    *,
    seed: int | None = None,
    progress: Progress = False,
    fixed: np.ndarray | None = None,
    **schedule: Any,
) -> Surface:
    """Anneal ``initial``'s triangulation in its projection plane, minimizing sum tac^p.

    Parameters
    ----------
    initial : Surface
        A planar triangulation (from :func:`scanmesh.delaunay` or the strip methods) with
        its ``scan``; flips keep its outline and holes and are judged on the scan's planar
        coordinates, the ones the initial triangulation was built on.
    seed : int, optional
        Seed of the PCG-64 generator (default 0): the same seed gives the same faces.
    progress : bool or callable
        True shows a progress bar per sweep with the energy and the estimated time left; a
        callable receives ``(sweeps_done, sweeps_total, energy)`` after every chunk (sweeps
        of all chains together: ``sweeps_total`` = chains x sweeps), and
        ``seconds_left=`` (see :func:`seconds_left`; None while unknown) if it takes that
        keyword or ``**kwargs``. A callable that takes ``stage=`` also hears the stages
        around the sweeps, "noise", "calibrate" and "polish" (``scanmesh._progress``).
    fixed : (K, 2) int, optional
        Edges of ``initial`` (pairs of point indices) that no flip may remove: the walk, the
        descent and the polish keep them (``stages.strips_anneal`` keeps the strips' steps
        so). Not with ``tiles`` > 1.
    **schedule
        ``sweeps`` (automatic: a budget of 24 proposals per point, at least 2 million in
        all, shared by the chains, between 8 and 1000 sweeps; ``AnnealParams.auto_sweeps``),
        ``p`` (1), ``initial_acceptance``, ``final_temperature_ratio``,
        ``patience``, ``sliver_guard`` (True), ``tie_tolerance`` (1e-10, exact ties; None:
        from the scan's noise estimate), ``descend`` (True: the walk starts from the local
        optimum LOP reaches from ``initial``), ``sliver_angle`` (5 degrees: flips that make
        a smaller smallest 3-D angle than this and than before are refused),
        ``curtain_angle`` (the core's CURTAIN_ANGLE_DEG, 5 degrees: flips that bring a
        face's plane within this angle of the line of sight and nearer it than before are
        refused, in the walk, the descent and the polish: no new curtain; only where the
        scan knows its line of sight, ``stages.options.curtain_sight``),
        ``planar_ties``
        (False; True: a flip whose four corners have a tac within twice the tie tolerance,
        flat up to the noise, is judged by the smallest planar angle alone, Delaunay's
        criterion, instead of by tac and 3-D angles, which there are the noise's: noisy
        flat parts then stay at Delaunay's height error, curved ones lose some of tac's
        gain; docs/benchmarks/noise.md), ``polish`` (True),
        ``calibration_samples``, ``chains`` (0: automatic); defaults in
        ``ANNEAL_DEFAULTS`` and the checks in :data:`OPTIONS`. ``chains`` independent runs
        start from ``initial`` with seeds derived from ``seed``, side by side on the cores
        (at most MAX_CHAINS), and the best final energy wins (the result depends on the
        seed, not on the number of cores). Automatic: one chain
        from 8,000 interior edges (about 2,700 points) up, otherwise enough chains (at most
        128) to make 8,000 proposals per sweep in all: on small inputs restarts find the
        optimum far more often than one longer chain (docs/benchmarks/optimum.md).
        ``tiles`` (1): anneal each chain in this many stripes of the plane at once, on the
        cores (at most 64): each phase of 100 sweeps freezes the triangles that cross a
        stripe border, the stripes shift by half a stripe every phase, and the energy stays
        exact; for large scans and long runs on several cores. The result depends on the
        seed and ``tiles``, not on the number of cores.
        ``time_limit`` (None: no limit): wall seconds of annealing proper (the sweeps),
        after which it stops and keeps the best state so far, polished as at the end of a
        full run. The noise estimate and the calibration before, and the polish after,
        come on top (each shows its own progress). A run stopped by the limit depends on
        the machine's speed, not on the seed alone.

    Returns
    -------
    Surface
        method "anneal", with ``trace`` (per sweep temperature, energy, best, acceptance)
        and ``options`` holding the settings used, the initial energy and T0, and
        ``options["stopped"]``: why annealing ended, one of :data:`STOP_REASONS`
        (``"time_limit"``; ``"patience"``: frozen without a new best; ``"sweeps"``: every
        sweep ran; ``"exhausted"``: no live edge left, nothing more to anneal).

    Raises
    ------
    KeyboardInterrupt
        On Ctrl-C, within one chunk (``CHUNK_SECONDS``, 20 ms), also while the annealer
        starts or polishes a large input; the run is discarded.
    """
    params = check_options(OPTIONS, schedule, "annealing")
    given = None if seed is None else SEED_OPTION.check(seed)
    return build_anneal(initial, params, Context.of(progress, given), fixed)


def build_anneal(
    initial: Surface,
    params: dict[str, Any],
    context: Context = QUIET,
    fixed: np.ndarray | None = None,
    live_budget: bool = False,
) -> Surface:
    """:func:`anneal_surface` without its checks: ``params`` the checked options of
    :data:`OPTIONS`, the seed and the progress those of the call (``context``), as the
    registry (``scanmesh.methods``) has them, ``fixed`` the edges kept. Same result,
    warnings and errors otherwise. ``live_budget``: automatic sweeps under a noise tie
    tolerance keep the plan's budget of proposals over the live edges (:func:`live_sweeps`;
    ``tiles`` 1 only)."""
    params = dict(params)
    automatic = params["sweeps"] is None
    time_limit = params.pop("time_limit")
    seed_value = context.seed
    start = planar_start(initial, "annealing")
    scan = start.scan
    assert scan is not None
    t0 = time.perf_counter()
    n = len(scan.points)
    with context.stage("noise", n, blocking=True):
        sigma, params["tie_tolerance"] = noise_tolerance(
            start, params["p"], params["tie_tolerance"], ANNEAL_DEFAULTS["tie_tolerance"]
        )
    # Annealed on the distinct points: the coincident copies left out of the start (in no
    # face) would be in every chain's copy of the state, which sizes the chains' memory.
    keep = _without_duplicates(n, start.duplicates)
    local = np.full(n, -1, dtype=np.int64)
    local[keep] = np.arange(len(keep))
    params = planned(params, len(keep), start.faces)
    # Every chain calibrates on its own proposals before its first sweep: 20 million of
    # them (the core's cap) took 4.4 s on 60 points, on the main thread when counted by
    # the points alone, where Ctrl-C waited for them (1.4-3.6 s). An automatic `chains`
    # (0) is counted at its ceiling: the count only decides whether a thread waits.
    proposals = params["calibration_samples"] * (params["chains"] or MAX_CHAINS)
    with context.stage("calibrate", len(start.faces)) as stage:
        # The very planar coordinates the initial triangulation was built and trimmed on.
        runner = interruptible(
            CALIBRATE_COST * len(keep) + proposals,
            lambda: _core.Annealer(
                scan.points[keep],
                scan.uv[keep],
                local[start.faces],
                _core.AnnealParams(seed=seed_value, **params),
                curtain_sight(scan),
                None if fixed is None else local[np.asarray(fixed, dtype=np.int64)],
                stage.counter,
            ),
            watch=stage.follow,
        )
    # Only the noise's ties: with exact ones the dead edges are those of flat parts (44 of
    # 16,300 live on the pocket turned 30 degrees), where 1,000 sweeps gave the plan's mesh
    # at 0.2-0.3 CPU seconds more (each sweep also costs O(n)).
    if live_budget and automatic and params["tie_tolerance"] > ANNEAL_DEFAULTS["tie_tolerance"]:
        sweeps = live_sweeps(params["sweeps"], interior_edges(start.faces), runner.sweep_len)
        if sweeps != params["sweeps"]:
            runner.replan(sweeps)
            params["sweeps"] = sweeps
    total = runner.chains * params["sweeps"]
    stopped = drive(runner, total, anneal_progress(context.progress), time_limit)
    with context.stage("polish", len(start.faces)) as stage:
        outcome = interruptible(len(keep), runner.finish, stage.counter, watch=stage.follow)
    if stopped is None:
        stopped = outcome.stopped
    summary = {name: getattr(outcome, name) for name in SUMMARY}
    elapsed = time.perf_counter() - t0
    return Surface(
        vertices=scan.points,
        faces=keep[outcome.faces],
        method="anneal",
        options={
            **start.options,
            **params,
            "seed": seed_value,
            "time_limit": time_limit,
            "initial": start.method,
            "noise": sigma,
            **summary,
            "stopped": stopped,
        },
        scan=scan,
        duplicates=start.duplicates,
        timings={**start.timings, "anneal": elapsed},
        trace={name: outcome.trace[:, k].copy() for k, name in enumerate(TRACE_COLUMNS)},
        line_ids=start.line_ids,
    )


def planned(params: dict[str, Any], n_points: int, faces: np.ndarray) -> dict[str, Any]:
    """``params`` (checked options of :data:`OPTIONS`, without ``seed``) with an automatic
    ``sweeps`` (None) replaced by the core's plan for ``n_points`` points triangulated by
    ``faces`` (``AnnealParams.auto_sweeps``); every run of a ``_core.Annealer`` (this module,
    the tiles of :mod:`scanmesh.distributed`) plans here. O(F log F)."""
    if params["sweeps"] is not None:
        return params
    core = {k: v for k, v in params.items() if k != "time_limit"}
    rule = _core.AnnealParams(**{**core, "sweeps": ANNEAL_DEFAULTS["sweeps"]})
    return {**params, "sweeps": rule.auto_sweeps(n_points, interior_edges(faces))}


def live_sweeps(sweeps: int, interior: int, live: int) -> int:
    """The automatic plan's ``sweeps`` (made for one proposal per interior edge, of which
    the triangulation has ``interior``) stretched so that its budget of proposals is spent
    when a sweep proposes only the ``live`` edges (``_core.Annealer.sweep_len``: edges a
    flip could still move by more than a tie); never fewer than planned, at most the
    schedule's ceiling (``ANNEAL_DEFAULTS["sweeps"]``). Under a noise tie tolerance a third
    of the edges are live (the fandisk at s/30: 13,097 of 35,793), and the plan's two
    million proposals were 630,000. O(1)."""
    if live <= 0:
        return sweeps
    return max(sweeps, min(math.ceil(sweeps * interior / live), ANNEAL_DEFAULTS["sweeps"]))


def interior_edges(faces: np.ndarray) -> int:
    """Edges shared by two of ``faces`` (F, 3) int: (3F - boundary edges) / 2. O(F log F)."""
    edges = np.sort(faces[:, [0, 1, 1, 2, 2, 0]].reshape(-1, 2).astype(np.int64), axis=1)
    keys = edges[:, 0] * (int(edges.max(initial=0)) + 1) + edges[:, 1]
    _, counts = np.unique(keys, return_counts=True)
    return int((counts == 2).sum())


def _without_duplicates(n: int, duplicates: np.ndarray | None) -> np.ndarray:
    """Sorted indices of the ``n`` points other than the dropped duplicates (the first
    column of ``duplicates``, (D, 2) (dropped, kept)). O(n)."""
    keep = np.ones(n, dtype=bool)
    if duplicates is not None and len(duplicates):
        keep[np.asarray(duplicates)[:, 0]] = False
    return np.flatnonzero(keep)
