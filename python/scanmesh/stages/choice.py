"""The method chosen by the data (``method="auto"``, the default): a holdout among candidates.

No one method is best on every scan: annealing wins on creased parts and fran_cut, LOP on
SainteHelens, Delaunay on the Autzen ground and a noisy conrod (docs/benchmarks/panel.md).
So the default judges them on the scan itself, as ``scan.plane_choice`` judges planes: in
a window of at most ``WINDOW`` points (whole scan lines around the middle one), a seeded
tenth of the points is withheld, every candidate is built on the rest, and each withheld
point's distance to each mesh along the projection normal is measured (the measure of
:func:`scanmesh.evaluate.holdout.holdout_error`), on the points that every candidate's mesh
covers and that lie on no step: a withheld point whose holding face is tilted more than
``STEP_TILT`` from the plane in any candidate's mesh is left out (unless more than
``STEP_SHARE`` of them are: a steep surface, not a step), since a point beside a wall is
exactly where the strips must bridge and the holdout would rank them last there (the
pocket, the rod along its thickness). Disjoint tenths are withheld in turn until at least
``MEASURED`` points are measured (at most ten: every point once), or fewer once the
verdict is clear (``CLEAR``). The lowest RMS wins
among the candidates whose meshes have at most ``SLIVERS`` slivers, except that the first
candidate stays unless the winner is more than ``PREFER`` lower.
The candidates are built on the parts as ``methods.judge_builder`` builds them (each
triangulation once a part, annealing on a short schedule); the winner is then built on all
points (``methods``: on a gridded scan the grid
triangulation where Delaunay wins, since the parts carry no grid). The candidates are the
registry's (``methods.CANDIDATES``); on a gridded scan the strips are none
(``methods.GRID_CANDIDATES``): the default stays inside the grid's domain.

The judge sees what a holdout sees away from steps: on real scans it agrees with the
panel's holdout; measurements in docs/benchmarks/panel.md.
"""

from __future__ import annotations

import functools
import math
import threading
import time
import warnings
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from dataclasses import dataclass
from typing import Any

import numpy as np

from scanmesh._context import QUIET, Context
from scanmesh._interrupt import POLL_SECONDS
from scanmesh.errors import ScanmeshError
from scanmesh.judge import Seen, rms
from scanmesh.judge import distances as normal_distances
from scanmesh.scan.lines import GAP_FACTOR
from scanmesh.scan.planar import PlanarScan, as_scan
from scanmesh.surface import Surface

#: Points of the window the candidates are judged on, at most (whole lines).
WINDOW: int = 20_000

#: Withheld points measured, at least (tenths withheld in turn, at most ten).
MEASURED: int = 3_000

#: A candidate whose meshes of the window have a larger share of slivers (mean over the
#: tenths; ``measures.SLIVER_ANGLE_DEG``) is chosen only if every candidate has: the
#: default keeps slivers under 5 % (LOP makes 5.7 % on fran_cut, 7.3 % on the Autzen ground).
SLIVERS: float = 0.05

#: A candidate leaving more withheld points outside its mesh than the fewest by this share
#: of them is not judged (strips on points without scan lines): its figure is None.
OUTSIDE: float = 0.10

#: ... and one leaving more than the fewest by this share is built on no further tenth: it
#: cannot come back (the strips on the Autzen ground: 39 % more; on the rod
#: along its thickness they leave 10 % more, judged on some tenths and not on others).
OUTSIDE_FAR: float = 0.20

#: A window of fewer points is not judged: annealing, the first candidate, is taken. Under
#: it every point is withheld once (ten tenths of at most 100 points), and the panel, whose
#: smallest scan has 2,205 points, says nothing of which method wins there.
MIN_POINTS: int = 1_000

#: The first candidate is kept unless another measures more than this share lower: on the
#: pocket at s/10 the strips annealed and Delaunay differ by 0.05 % in the holdout while the
#: former is 8 % closer to the part (the noise, not the mesh, fills the holdout there).
PREFER: float = 0.01

#: A withheld point whose holding face in any candidate's mesh is tilted more than this
#: from the projection plane (degrees) lies beside a step and is not judged.
STEP_TILT: float = 45.0

#: Steps are lines in the plane, a small share of the points: where more of the covered
#: withheld points than this share lie on steep faces, the surface is steep (fran_cut, a
#: cylindrical scan seen flat: 54 %), not stepped, and every covered point is judged.
STEP_SHARE: float = 0.25

#: The tenths are judged in turn; a candidate behind the leader is built on no more of them
#: and the judge stops when every other one is (:func:`_behind`): at least
#: ``CLEAR_MEASURED`` points measured, an RMS more than ``CLEAR`` above the leader's, and
#: the paired differences of squared distances ``CLEAR_Z`` standard errors above zero (a
#: share alone is not enough: on the fandisk turned 30 degrees without noise a few points
#: at the creases carry the RMS, and the first tenth put strips-anneal 45 % behind the
#: candidate that all ten put 15 % behind it).
CLEAR_MEASURED: int = 500
CLEAR: float = 0.03
CLEAR_Z: float = 2.5

#: The method built when nothing was judged (a window under ``MIN_POINTS``): annealing,
#: which needs no scan lines (the strips on a few points in no scan order would follow
#: lines detected from noise).
FALLBACK: str = "anneal"

#: What the holdout figures measure, for reports.
MEASURE = (
    "RMS distance along the projection normal from withheld window points to each"
    " candidate's mesh of the other window points, on the points every mesh covers where"
    f" no mesh's face is tilted over {STEP_TILT:g} degrees"
)


@dataclass(frozen=True)
class MethodChoice:
    """The method ``method="auto"`` chose, and what every candidate measured."""

    #: the chosen method's name
    chosen: str
    #: candidate -> holdout RMS (model units) on the points every judged candidate covers
    #: (nan: not judged, see OUTSIDE)
    holdout: dict[str, float]
    #: candidate -> withheld points its mesh left outside (beyond its outline, in holes)
    outside: dict[str, int]
    #: candidate -> share of slivers of its meshes (mean over the tenths; inf: its build
    #: failed on a part)
    slivers: dict[str, float]
    #: points of the window, withheld points measured (covered by every mesh), tenths used
    window: int
    measured: int
    folds: int
    #: candidate -> seconds building it on the tenths (with the meshes it starts from, when
    #: it needs them first; in its lane, and the lanes run side by side)
    seconds: dict[str, float]

    def as_dict(self) -> dict[str, Any]:
        """JSON-ready summary for ``Surface.options["method_choice"]`` and the report."""
        return {
            "chosen": self.chosen,
            "holdout": {k: None if math.isnan(v) else v for k, v in self.holdout.items()},
            "outside": dict(self.outside),
            "slivers": {k: None if math.isinf(v) else v for k, v in self.slivers.items()},
            "window": self.window,
            "measured": self.measured,
            "folds": self.folds,
            "seconds": dict(self.seconds),
            "measure": MEASURE,
        }


def window(line_ids: np.ndarray, size: int = WINDOW) -> np.ndarray:
    """(W,) int64 sorted indices of whole lines around the middle line id, at most ``size``
    points (all when there are at most ``size``; the middle line alone if it is longer).
    ``line_ids`` (N,) int. O(N log N)."""
    if len(line_ids) <= size:
        return np.arange(len(line_ids))
    ids, counts = np.unique(line_ids, return_counts=True)
    lo = hi = len(ids) // 2
    total = int(counts[lo])
    grew = True
    while grew:
        grew = False
        if hi + 1 < len(ids) and total + counts[hi + 1] <= size:
            hi += 1
            total += int(counts[hi])
            grew = True
        if lo > 0 and total + counts[lo - 1] <= size:
            lo -= 1
            total += int(counts[lo])
            grew = True
    return np.flatnonzero(np.isin(line_ids, ids[lo : hi + 1]))


def folds(n: int, seed: int, measured: int = MEASURED) -> list[np.ndarray]:
    """Disjoint seeded tenths of ``range(n)`` (each (about n/10,) int64, sorted), as many
    as withhold at least ``measured`` points, at most ten. O(n)."""
    perm = np.random.default_rng(seed).permutation(n)
    k = min(10, n, max(1, math.ceil(measured / max(1, n // 10))))
    return [np.sort(perm[f::10]) for f in range(k)]


def _on_steps(seen: Seen, face: np.ndarray) -> np.ndarray:
    """(K,) bool: the triangle ``face`` (-1: none) of ``seen`` holding each withheld point
    is tilted more than ``STEP_TILT`` from the plane (a step): only the holding faces
    are measured. O(K)."""
    held = face >= 0
    tri = seen.tri[face[held]]
    n = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
    tilt = np.arctan2(np.linalg.norm(np.cross(n, seen.normal), axis=1), np.abs(n @ seen.normal))
    steep = np.zeros(len(face), dtype=bool)
    steep[held] = tilt > math.radians(STEP_TILT)
    return steep


def _part(scan: PlanarScan, lines: np.ndarray, index: np.ndarray) -> PlanarScan:
    """The points ``index`` of ``scan`` as a scan of their own, projected along the same
    normal (not chosen again), with their line ids."""
    plane = tuple(float(c) for c in scan.frame.normal)
    return as_scan(scan.points[index], plane=plane, lines=lines[index], up=scan.up)


def _verdict(
    candidates: tuple[str, ...],
    dist: dict[str, list[np.ndarray]],
    steps: list[np.ndarray],
    slivers: dict[str, float],
) -> tuple[str, dict[str, float], dict[str, int], int, dict[str, np.ndarray]]:
    """The judge's verdict on the tenths measured so far among the candidates in ``dist``
    (those still judged, in the order of ``candidates``): the chosen one, each one's
    holdout RMS (nan: not judged), its withheld points outside its mesh, the points
    measured and the squared distances of those eligible to win (``slivers``, the mean
    share over the tenths, within ``SLIVERS``) on the points measured. O(candidates x
    points)."""
    joined = {name: np.concatenate(d) if d else np.empty(0) for name, d in dist.items()}
    outside = {name: int(np.isnan(d).sum()) for name, d in joined.items()}
    n_out = len(next(iter(joined.values()))) if joined else 0
    # a candidate leaving many more points outside its outline than the fewest is not judged
    fair = [k for k, v in outside.items() if v <= min(outside.values()) + OUTSIDE * n_out]
    covered = np.logical_and.reduce([np.isfinite(joined[k]) for k in fair], axis=0)
    flat = ~np.concatenate(steps) if steps else np.ones(0, dtype=bool)
    if covered.any() and (covered & ~flat).sum() <= STEP_SHARE * covered.sum():
        covered &= flat
    holdout = {
        name: rms(d[covered]) if name in fair and covered.any() else math.nan
        for name, d in joined.items()
    }
    measured = {k: v for k, v in holdout.items() if not math.isnan(v)}
    few = {k: v for k, v in measured.items() if slivers[k] <= SLIVERS} or measured
    fallback = FALLBACK if FALLBACK in candidates else candidates[0]
    chosen = min(few, key=few.__getitem__) if few else fallback
    first = candidates[0]  # the first of all: once dropped (behind) it is in none of few
    if chosen != first and first in few and few[first] <= few[chosen] * (1.0 + PREFER):
        chosen = first
    return chosen, holdout, outside, int(covered.sum()), {k: joined[k][covered] ** 2 for k in few}


def _behind(chosen: str, squared: dict[str, np.ndarray]) -> set[str]:
    """The candidates eligible to win (``squared``: their squared distances on the same
    points) that are behind the chosen one: RMS more than ``CLEAR`` above its, and the
    mean of the paired differences of squares more than ``CLEAR_Z`` standard errors above
    zero, on at least ``CLEAR_MEASURED`` points. No more tenths are built for them; the
    verdict is clear when every other eligible one is behind. O(candidates x points)."""
    best = squared.get(chosen)
    if best is None or len(best) < CLEAR_MEASURED:
        return set()
    out = set()
    for name, sq in squared.items():
        diff = sq - best
        error = float(np.std(diff)) / math.sqrt(len(diff))
        lead = float(np.mean(sq)) > (1.0 + CLEAR) ** 2 * float(np.mean(best))
        if name != chosen and lead and float(np.mean(diff)) > CLEAR_Z * error:
            out.add(name)
    return out


#: The logs of :func:`recorded` open now (the main thread's: the judge runs there).
_RECORDING: list[list[tuple[int, warnings.WarningMessage]]] = []


@contextmanager
def recorded() -> Iterator[list[tuple[int, warnings.WarningMessage]]]:
    """While open, every thread's warnings are recorded, none shown: a list of (the ident
    of the thread that raised it, the warning), for :func:`replay`. Python's warning
    filters are the process's, not a thread's, so one log tells the judge's builds from
    a build beside them (``methods``: the first candidate on all points) by the thread;
    :func:`choose` inside it adds no filter of its own."""
    log: list[tuple[int, warnings.WarningMessage]] = []

    def keep(message, category, filename, lineno, file=None, line=None):  # type: ignore[no-untyped-def]
        got = warnings.WarningMessage(message, category, filename, lineno, file, line)
        log.append((threading.get_ident(), got))

    with warnings.catch_warnings():
        warnings.simplefilter("always")
        warnings.showwarning = keep
        _RECORDING.append(log)
        try:
            yield log
        finally:
            _RECORDING.remove(log)


def replay(log: list[tuple[int, warnings.WarningMessage]], thread: int | None) -> None:
    """The warnings of ``log`` (:func:`recorded`) that thread ``thread`` raised, issued
    again here, in order, through the caller's filters."""
    for ident, got in log:
        if ident == thread:
            warnings.warn_explicit(got.message, got.category, got.filename, got.lineno)


@contextmanager
def _quiet_parts() -> Iterator[None]:
    """The judge's builds show no warning (the parts' are not the scan's): ignored, or,
    inside :func:`recorded`, left to its log (a filter here would hide the warnings of a
    build beside the judge too)."""
    if _RECORDING:
        yield
        return
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        yield


#: A candidate's figures on one part: the withheld points' distances to its mesh (nan:
#: outside it), which of them lie on a step of it (:func:`_on_steps`), its sliver share.
Figures = tuple[np.ndarray, np.ndarray, float]


def _measure(held: np.ndarray, surface: Surface) -> Figures:
    """:data:`Figures` of ``surface`` for the withheld points ``held`` (K, 3).
    O((F + K) log F)."""
    seen = Seen.of(surface)
    got, face = normal_distances(held, seen)
    return got, _on_steps(seen, face), surface.quality.sliver_fraction


def _side_by_side(
    lanes: list[list[str]],
    build: Callable[[str, PlanarScan], Surface],
    part: PlanarScan,
    measure: Callable[[Surface], Figures],
) -> dict[str, tuple[Figures | None, float]]:
    """Candidate -> (its mesh of ``part`` measured, None if its build raised a
    ScanmeshError; seconds of the build): each lane's candidates built and measured in
    turn (the measuring beside the other lanes' builds, not after them all), the lanes
    side by side in daemon threads (the core's long calls release the GIL) waited for in
    ``POLL_SECONDS`` slices, so that Ctrl-C reaches the caller (an abandoned build
    finishes in the background, as ``scanmesh._interrupt`` leaves its calls). A lane
    whose thread cannot start (no room for its stack) is built here after the others."""
    results: dict[str, tuple[Figures | None, float]] = {}
    failed: list[BaseException] = []

    def run(lane: list[str]) -> None:
        for name in lane:
            t0 = time.perf_counter()
            try:
                got: Surface | None = build(name, part)
            except ScanmeshError:  # a method that fails on a part is not judged
                got = None
            took = time.perf_counter() - t0
            results[name] = (None if got is None else measure(got), took)

    def beside(lane: list[str]) -> None:
        try:
            run(lane)
        except BaseException as exc:  # noqa: BLE001 - raised in the caller's thread below
            failed.append(exc)

    threads, here = [], []
    for lane in lanes[1:]:
        thread = threading.Thread(target=beside, args=(lane,), name="scanmesh-judge", daemon=True)
        try:
            thread.start()
        except RuntimeError:  # "can't start new thread"
            here.append(lane)
        else:
            threads.append(thread)
    for lane in lanes[:1] + here:
        run(lane)
    for thread in threads:
        while thread.is_alive():
            thread.join(POLL_SECONDS)
    if failed:
        raise failed[0]
    return results


def choose(
    scan: PlanarScan,
    build: Callable[[str, PlanarScan], Surface],
    candidates: tuple[str, ...],
    context: Context = QUIET,
    lanes: tuple[tuple[str, ...], ...] | None = None,
    watch: Callable[[tuple[str, ...]], None] | None = None,
) -> MethodChoice:
    """The candidate whose meshes lie closest to withheld points of ``scan``.

    ``build(name, part)`` builds candidate ``name`` on a part of the scan (the candidates
    in turn on one part, then the next part: a builder may reuse one candidate's mesh of
    the part for another). The window is :func:`window` of the scan's line ids (given,
    else detected), the withheld tenths :func:`folds` of it, seeded by the call's seed,
    judged in turn, a candidate no more once it is behind (:func:`_behind`), until the
    verdict is clear (every other one behind) or all tenths are measured;
    reports the stage "choose" (builds) to the call's progress (``context``). A candidate
    whose build fails on a part is not judged; a window under ``MIN_POINTS`` points is not
    judged at all (``FALLBACK``). ``lanes`` (None: all candidates in one): groups of
    the candidates built in turn, the groups side by side on the cores (a candidate in
    the lane of the one it starts from); the figures do not depend on them. ``watch``
    (optional) hears the candidates still judged after each tenth that does not end the
    judging clear (a build of the first candidate beside the judge stops once it is out). The parts'
    warnings are not the scan's: none is shown (inside :func:`recorded`, they are recorded
    there). O(folds x candidates x a build of WINDOW points)."""
    lines = scan.line_ids_for(GAP_FACTOR)
    win = window(lines)
    parts = folds(len(win), context.seed, MEASURED) if len(win) >= MIN_POINTS else []
    dist: dict[str, list[np.ndarray]] = {name: [] for name in candidates}
    steps: list[np.ndarray] = []  # per tenth: withheld points on a step in some mesh
    slivers = dict.fromkeys(candidates, 0.0)  # summed over the tenths built
    seconds = dict.fromkeys(candidates, 0.0)
    judged = list(candidates)  # those still built; the others' figures are kept as dropped
    holdout: dict[str, float] = {}
    outside: dict[str, int] = {}
    chosen, measured = (FALLBACK if FALLBACK in candidates else candidates[0]), 0
    with context.stage("choose", len(parts) * len(candidates)) as stage:
        for out in parts:
            kept = np.setdiff1d(np.arange(len(win)), out)
            part = _part(scan, lines, win[kept])
            steps.append(np.zeros(len(out), dtype=bool))
            ways = [[k for k in lane if k in judged] for lane in (lanes or (candidates,))]
            held = scan.points[win][out]
            with _quiet_parts():
                results = _side_by_side(
                    [w for w in ways if w], build, part, functools.partial(_measure, held)
                )
            for name in judged:
                figures, took = results[name]
                if figures is None:
                    dist[name].append(np.full(len(out), np.nan))
                    slivers[name] = math.inf
                else:
                    dist[name].append(figures[0])
                    steps[-1] |= figures[1]
                    slivers[name] += figures[2]
                seconds[name] += took
            stage.update(stage.done + len(judged))
            share = {k: slivers[k] / len(dist[k]) for k in judged}
            chosen, now, gone, measured, squared = _verdict(
                candidates, {k: dist[k] for k in judged}, steps, share
            )
            holdout.update(now)
            outside.update(gone)
            behind = _behind(chosen, squared)
            if behind and behind == set(squared) - {chosen}:
                break  # clear: every other eligible candidate is behind
            withheld = sum(len(d) for d in dist[judged[0]])
            far = min(gone.values()) + OUTSIDE_FAR * withheld
            if measured >= CLEAR_MEASURED:  # one far outside cannot win: built no more
                behind |= {k for k in judged if gone[k] > far}
            judged = [k for k in judged if k not in behind]
            if watch is not None:
                watch(tuple(judged))
    return MethodChoice(
        chosen=chosen,
        holdout={k: holdout.get(k, math.nan) for k in candidates},
        outside={k: outside.get(k, 0) for k in candidates},
        slivers={k: v / max(len(dist[k]), 1) for k, v in slivers.items()},
        window=len(win),
        measured=measured,
        folds=len(steps),
        seconds=seconds,
    )


__all__ = [
    "MethodChoice",
    "choose",
    "recorded",
    "replay",
    "window",
    "folds",
    "WINDOW",
]
