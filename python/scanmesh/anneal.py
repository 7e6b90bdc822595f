"""Simulated annealing and Lawson's LOP on the tac criterion, over a planar triangulation."""

from __future__ import annotations

import math
import time
from collections.abc import Callable
from typing import Any

import numpy as np

from scanmesh import _core
from scanmesh.errors import ParameterError
from scanmesh.noise import noise_tolerance
from scanmesh.projection import project
from scanmesh.surface import Surface

#: Defaults of the annealing schedule, read from the Rust core (one source of truth).
ANNEAL_DEFAULTS: dict[str, Any] = dict(_core.ANNEAL_DEFAULTS)

#: Each native call runs at most this long (seconds) before Python checks for Ctrl-C and
#: reports progress: bounded in time, not in proposals, so the latency holds on slow machines.
CHUNK_SECONDS = 0.02

#: ... and at most this many proposals per call.
CHUNK_PROPOSALS = 1_000_000

#: Trace columns, in the order the core returns them.
TRACE_COLUMNS = ("temperature", "energy", "best", "acceptance")

#: progress= accepts a bool or a callable(sweeps_done, sweeps_total, energy) -> None.
Progress = bool | Callable[[int, int, float], None]


def _check_schedule(options: dict[str, Any]) -> dict[str, Any]:
    unknown = sorted(set(options) - set(ANNEAL_DEFAULTS))
    if unknown:
        raise ParameterError(
            f"unknown annealing option(s) {unknown}; known: {sorted(ANNEAL_DEFAULTS)}"
        )
    params = {**ANNEAL_DEFAULTS, **{k: v for k, v in options.items() if v is not None}}
    for name in ("sweeps", "patience", "chains", "tiles"):
        value = params[name]
        if isinstance(value, bool) or not isinstance(value, (int, np.integer)) or value < 0:
            raise ParameterError(f"{name} must be a whole number >= 0, got {value!r}")
    p = float(params["p"])
    if not (p >= 1.0) or math.isinf(p):
        raise ParameterError(f"p must be a finite number >= 1 for annealing, got {params['p']!r}")
    params["p"] = p
    return params


def _seed(seed: int | None) -> int:
    if seed is None:
        return 0
    if isinstance(seed, bool) or not isinstance(seed, (int, np.integer)) or not 0 <= seed < 2**64:
        raise ParameterError(f"seed must be an integer in 0..2**64-1, got {seed!r}")
    return int(seed)


def _progress_bar(progress: Progress, total: int) -> Callable[[int, int, float], None] | None:
    if callable(progress):
        return progress
    if not progress:
        return None
    from tqdm import tqdm

    bar = tqdm(total=total, unit="sweep", desc="annealing", leave=False)

    def update(done: int, _total: int, energy: float) -> None:
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
        its ``frame``; flips keep its outline and holes.
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
        ``ANNEAL_DEFAULTS``. ``chains`` independent runs start from ``initial`` with
        seeds derived from ``seed``, side by side on the cores, and the best final energy
        wins (the result depends on the seed, not on the number of cores). Automatic: one chain
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
    params = _check_schedule(schedule)
    seed_value = _seed(seed)
    if initial.frame is None:
        raise ParameterError(
            "the initial surface has no projection frame (build it with delaunay())"
        )
    t0 = time.perf_counter()
    sigma, params["tie_tolerance"] = noise_tolerance(
        initial, params["p"], schedule.get("tie_tolerance"), ANNEAL_DEFAULTS["tie_tolerance"]
    )
    uv, _ = project(initial.vertices, initial.frame.normal)
    runner = _core.Annealer(initial.vertices, uv, initial.faces, seed=seed_value, **params)
    total = runner.chains * params["sweeps"]
    report = _progress_bar(progress, total)
    try:
        while not runner.done:
            runner.advance(CHUNK_PROPOSALS, CHUNK_SECONDS)
            if report is not None:
                report(runner.sweeps_done, total, runner.energy)
        if report is not None:
            # Chains that stop early leave the count short of the total: close it.
            report(total, total, runner.energy)
    finally:
        if report is not None and hasattr(report, "close"):
            report.close()
    faces, trace, summary = runner.finish()
    elapsed = time.perf_counter() - t0
    return Surface(
        vertices=initial.vertices,
        faces=faces,
        method="anneal",
        options={
            **initial.options, **params, "seed": seed_value, "initial": initial.method,
            "noise": sigma, **summary
        },
        frame=initial.frame,
        duplicates=initial.duplicates,
        timings={**initial.timings, "anneal": elapsed},
        trace={name: trace[:, k].copy() for k, name in enumerate(TRACE_COLUMNS)},
        line_ids=initial.line_ids,
    )


def lop_surface(
    initial: Surface,
    *,
    criterion: str = "tac",
    p: float = 1.0,
    sliver_guard: bool = True,
    tie_tolerance: float | None = None,
) -> Surface:
    """Lawson's LOP from ``initial``: flip while a flip improves ``criterion``.

    ``criterion="tac"`` minimizes sum tac^p (annealing at T = 0; energy ties go to the larger
    smallest angle when ``sliver_guard``); ``"max-min"`` maximizes the smallest angle in the
    projection plane and so converges to the Delaunay triangulation.
    """
    if criterion not in ("tac", "max-min"):
        raise ParameterError(f"unknown LOP criterion {criterion!r}: use 'tac' or 'max-min'")
    if initial.frame is None:
        raise ParameterError(
            "the initial surface has no projection frame (build it with delaunay())"
        )
    p = float(p)
    if not (p >= 1.0) or math.isinf(p):
        raise ParameterError(f"p must be a finite number >= 1, got {p!r}")
    tie = ANNEAL_DEFAULTS["tie_tolerance"] if tie_tolerance is None else float(tie_tolerance)
    t0 = time.perf_counter()
    uv, _ = project(initial.vertices, initial.frame.normal)
    faces, flips = _core.lop(initial.vertices, uv, initial.faces, criterion, p, sliver_guard, tie)
    return Surface(
        vertices=initial.vertices,
        faces=faces,
        method="lop",
        options={**initial.options, "criterion": criterion, "p": p, "sliver_guard": sliver_guard,
                 "flips": flips, "initial": initial.method},
        frame=initial.frame,
        duplicates=initial.duplicates,
        timings={**initial.timings, "lop": time.perf_counter() - t0},
        line_ids=initial.line_ids,
    )
