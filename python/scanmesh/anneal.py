"""Simulated annealing on the tac criterion, over a planar triangulation and its scan."""

from __future__ import annotations

import dataclasses
import time
from collections.abc import Callable
from typing import Any

from scanmesh import _core
from scanmesh._checks import Option, check_options
from scanmesh.lop import P_OPTION, SLIVER_GUARD_OPTION, TIE_TOLERANCE_OPTION, planar_start
from scanmesh.noise import noise_tolerance
from scanmesh.surface import Surface

#: Defaults of the annealing schedule, read from the Rust core (one source of truth).
ANNEAL_DEFAULTS: dict[str, Any] = dict(_core.ANNEAL_DEFAULTS)

#: Most tiles per chain (the core's limit).
MAX_TILES: int = 64

#: Each native call runs at most this long (seconds) before Python checks for Ctrl-C and
#: reports progress: bounded in time, not in proposals, so the latency holds on slow machines.
CHUNK_SECONDS = 0.02

#: ... and at most this many proposals per call.
CHUNK_PROPOSALS = 1_000_000

#: Trace columns, in the order the core returns them.
TRACE_COLUMNS = ("temperature", "energy", "best", "acceptance")

#: progress= accepts a bool or a callable(sweeps_done, sweeps_total, energy) -> None.
Progress = bool | Callable[[int, int, float], None]


#: Most chains one run may ask for (automatic runs use at most 128): each holds a copy of
#: the mesh, so the count is bounded by memory as well as by time.
MAX_CHAINS: int = 1024

#: A bound on counts of sweeps and proposals that no run could reach in a lifetime; it keeps
#: absurd values (2**64, 10**30) from overflowing the core's integers.
MAX_COUNT: int = 10**9

#: The most calibration proposals: T0 is a median, a few thousand samples fix it.
MAX_CALIBRATION_SAMPLES: int = 10**6

#: ``seed``, the shared keyword of the random methods: None means 0.
SEED_OPTION = Option(
    "seed", "int", None, "seed of every random choice (default 0)", low=0, high=2**64 - 1
)

#: The annealing schedule's options, defaults from the core.
OPTIONS: tuple[Option, ...] = (
    Option(
        "sweeps",
        "int",
        ANNEAL_DEFAULTS["sweeps"],
        "sweeps (one proposal per live edge each: flippable, by a corner with tac above ties)",
        low=0,
        high=MAX_COUNT,
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
    # None: from the scan's noise (noise.noise_tolerance); exact ties on noise-free scans
    dataclasses.replace(
        TIE_TOLERANCE_OPTION,
        default=None,
        doc=TIE_TOLERANCE_OPTION.doc + " (automatic: from the scan's noise estimate)",
        automatic=True,
    ),
    Option("polish", "bool", ANNEAL_DEFAULTS["polish"], "run LOP from the best state at the end"),
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
)


def _progress_bar(progress: Progress, total: int) -> Callable[[int, int, float], None] | None:
    if callable(progress):
        return progress
    if not progress:
        return None
    from tqdm import tqdm

    bar = tqdm(total=total, unit="sweep", desc="annealing", leave=False)

    def update(done: int, _total: int, energy: float) -> None:
        bar.total = _total
        bar.n = done
        bar.set_postfix(energy=f"{energy:.6g}", refresh=False)
        bar.refresh()
        if done >= _total:
            bar.close()

    update.close = bar.close  # type: ignore[attr-defined]
    return update


def anneal_surface(
    initial: Surface,
    *,
    seed: int | None = None,
    progress: Progress = False,
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
        True shows a progress bar per sweep with the energy; a callable receives
        ``(sweeps_done, sweeps_total, energy)`` after every chunk (sweeps of all chains
        together: ``sweeps_total`` = chains x sweeps).
    **schedule
        ``sweeps`` (1000), ``p`` (1), ``initial_acceptance``, ``final_temperature_ratio``,
        ``patience``, ``sliver_guard`` (True), ``tie_tolerance``, ``polish`` (True),
        ``calibration_samples``, ``chains`` (0: automatic); defaults in
        ``ANNEAL_DEFAULTS`` and the checks in :data:`OPTIONS`. ``chains`` independent runs
        start from ``initial`` with seeds derived from ``seed``, side by side on the cores
        (at most MAX_CHAINS), and the best final energy wins (the result depends on the
        seed, not on the number of cores). Automatic: one chain
        from 8,000 interior edges (about 2,700 points) up, otherwise enough chains (at most
        128) to make 8,000 proposals per sweep in all: on small inputs restarts find the
        optimum far more often than one longer chain (BENCHMARKS.md, "Certified optimum").
        ``tiles`` (1): anneal each chain in this many stripes of the plane at once, on the
        cores (at most 64): each phase of 100 sweeps freezes the triangles that cross a
        stripe border, the stripes shift by half a stripe every phase, and the energy stays
        exact; for large scans and long runs on several cores. The result depends on the
        seed and ``tiles``, not on the number of cores.

    Returns
    -------
    Surface
        method "anneal", with ``trace`` (per sweep temperature, energy, best, acceptance)
        and ``options`` holding the settings used, the initial energy and T0.

    Raises
    ------
    KeyboardInterrupt
        On Ctrl-C, within one chunk (``CHUNK_SECONDS``, 20 ms); the run is discarded.
    """
    params = check_options(OPTIONS, schedule, "annealing")
    seed_value = 0 if seed is None else SEED_OPTION.check(seed)
    start = planar_start(initial, "annealing")
    scan = start.scan
    assert scan is not None
    t0 = time.perf_counter()
    sigma, params["tie_tolerance"] = noise_tolerance(
        start, params["p"], params["tie_tolerance"], ANNEAL_DEFAULTS["tie_tolerance"]
    )
    # The very planar coordinates the initial triangulation was built and trimmed on.
    runner = _core.Annealer(scan.points, scan.uv, start.faces, seed=seed_value, **params)
    total = runner.chains * params["sweeps"]
    report = _progress_bar(progress, total)
    try:
        while not runner.done:
            runner.advance(CHUNK_PROPOSALS, CHUNK_SECONDS)
            if report is not None:
                report(runner.sweeps_done, total, runner.energy)
        if report is not None:
            # Chains that stop early leave the count short of the planned total: the last
            # report ends the stage where the run ended (the total shrinks to what ran).
            report(runner.sweeps_done, runner.sweeps_done, runner.energy)
    finally:
        if report is not None and hasattr(report, "close"):
            report.close()
    faces, trace, summary = runner.finish()
    elapsed = time.perf_counter() - t0
    return Surface(
        vertices=scan.points,
        faces=faces,
        method="anneal",
        options={
            **start.options, **params, "seed": seed_value, "initial": start.method,
            "noise": sigma, **summary
        },
        scan=scan,
        duplicates=start.duplicates,
        timings={**start.timings, "anneal": elapsed},
        trace={name: trace[:, k].copy() for k, name in enumerate(TRACE_COLUMNS)},
        line_ids=start.line_ids,
    )
