"""The table of triangulation methods: what each one runs, which keywords and options it
takes, and what it can do.

:func:`scanmesh.reconstruct` and the ``scanmesh`` command read everything about a method
from here: the option checks (one :class:`scanmesh._checks.Option` each, so a bad value is
refused with the option's name whichever way it came in), the keywords a method uses (a
keyword it would not use is refused, not dropped), and the command's flags and help. So do
the default's choice (:data:`CANDIDATES`), ``scanmesh compare`` (:data:`COMPARED`) and the
Dask path (:data:`STRIP_METHODS`, :data:`TILE_METHODS`): no other module lists method names.
"""

from __future__ import annotations

import dataclasses
import threading
from collections.abc import Callable, Mapping
from dataclasses import dataclass
from enum import Enum
from typing import Any

from scanmesh._checks import Option, check_options
from scanmesh._context import QUIET, Context
from scanmesh._interrupt import POLL_SECONDS
from scanmesh._progress import Progress, Stage, accepts, takes_stage
from scanmesh.errors import ParameterError
from scanmesh.scan.planar import PlanarScan
from scanmesh.stages import anneal, choice, grid, lop, optimal, strips, strips_anneal
from scanmesh.stages.delaunay import delaunay
from scanmesh.stages.options import MAX_EDGE_OPTION
from scanmesh.surface import Surface

#: Keywords of :func:`scanmesh.reconstruct` that several methods share, with their checks
#: ("plane" is checked by the projection; every method takes it).
SHARED: dict[str, Option] = {
    "lines": Option(
        "lines", "any", None, "scan line id of each point", convert=lambda value: value
    ),
    "max_edge": MAX_EDGE_OPTION,
    "seed": anneal.SEED_OPTION,
}

#: Initial triangulations LOP and annealing start from, by name ("auto": see
#: :func:`default_initial`).
INITIALS = ("auto", "delaunay", "shortest-path", "grid")


def default_initial(scan: PlanarScan, max_edge: float | None = None) -> str:
    """The start ``initial="auto"`` (the default) names for ``scan``: "grid" for a gridded
    scan (a range grid of at least 2 x 2 samples: ``grid.is_gridded``) unless a Delaunay
    trimming length ``max_edge`` was given, else "delaunay"."""
    return "grid" if grid.is_gridded(scan) and max_edge is None else "delaunay"


@dataclass(frozen=True)
class Keywords:
    """The shared keywords of one call that are no option of one stage: ``max_edge`` as
    given (None: not given), and the call's progress and seed."""

    max_edge: float | None = None
    context: Context = QUIET


class Tiles(Enum):
    """How a method runs in tiles of the plane on Dask (``scanmesh.distributed._tiles``)."""

    #: the tiled Delaunay triangulation, trimmed, is the mesh
    BUILT = "built"
    #: the tiled Delaunay triangulation, then optimized piece by piece in two passes
    OPTIMIZED = "optimized"


@dataclass(frozen=True)
class Method:
    """One triangulation method of :func:`scanmesh.reconstruct`, and what it can do."""

    #: name passed as ``method=``
    name: str
    #: builds the surface from a scan, the checked options and the shared keywords
    run: Callable[[PlanarScan, dict[str, Any], Keywords], Surface]
    #: shared keywords (of SHARED) the method can use
    shared: frozenset[str]
    #: the method's own options
    options: tuple[Option, ...]
    #: one line for help texts
    doc: str
    #: the shared keywords the method uses with these checked options (default: ``shared``)
    uses: Callable[[dict[str, Any]], frozenset[str]] | None = None
    #: builds strips between consecutive scan lines (on Dask: partitions of whole lines)
    strips: bool = False
    #: how it runs in tiles of the plane on Dask (None: it does not)
    tiles: Tiles | None = None
    #: optimizes by seeded random flips: its tie tolerance follows the scan's noise and its
    #: chains the size of what it anneals
    anneals: bool = False
    #: its mesh starts from the strips (so, as the strips, no candidate on gridded scans)
    from_strips: bool = False
    #: a candidate of the default (``stages.choice``): its place in the order of preference
    #: (the earlier wins an exact tie); None: not judged
    judged: int | None = None
    #: ``scanmesh compare`` runs it when no method is named
    compared: bool = False
    #: needs a range grid (``compare`` runs it on gridded scans only)
    needs_grid: bool = False
    #: its mesh is the points' Delaunay triangulation in the plane (trimmed): the max-min
    #: angle one, with the fewest slivers of any triangulation of them
    max_min_angle: bool = False

    @property
    def distributed(self) -> bool:
        """Whether :func:`scanmesh.distributed.reconstruct_distributed` runs it."""
        return self.strips or self.tiles is not None

    @property
    def starts(self) -> bool:
        """Whether it starts from another method's triangulation (option ``initial``)."""
        return any(option.name == "initial" for option in self.options)

    def check(self, options: Mapping[str, Any], shared: Mapping[str, Any]) -> dict[str, Any]:
        """The options checked (defaults filled in) and the shared keywords given (not
        None) checked against what the method uses; ParameterError names the first
        problem."""
        params = check_options(self.options, options, f"method {self.name!r}")
        used = self.shared if self.uses is None else self.uses(params)
        for name, value in shared.items():
            if value is None:
                continue
            if name not in used:
                raise ParameterError(self._unused(name, params))
            SHARED[name].check(value)
        return params

    def _unused(self, keyword: str, params: dict[str, Any]) -> str:
        """Why this method does not use ``keyword`` with these options."""
        if keyword in self.shared and "initial" in params:
            initial = params["initial"]
            if isinstance(initial, Surface):
                return (
                    f"method {self.name!r} does not use {keyword}= with an initial Surface"
                    " (it is built already)"
                )
            need = "delaunay" if keyword == "max_edge" else "shortest-path"
            return (
                f"method {self.name!r} does not use {keyword}= with initial={initial!r}"
                f" (initial={need!r} does)"
            )
        return f"method {self.name!r} does not use {keyword}="


def _initial_uses(params: dict[str, Any]) -> frozenset[str]:
    """LOP and annealing use the keywords of their initial triangulation."""
    initial = params["initial"]
    if isinstance(initial, Surface) or initial == "grid":
        return frozenset()
    return frozenset({"max_edge"} if initial in ("auto", "delaunay") else {"lines"})


def _anneal_uses(params: dict[str, Any]) -> frozenset[str]:
    """Annealing uses its initial triangulation's keywords, the seed, and the scan lines:
    its noise estimate (the tie tolerance) follows them when they are given."""
    built = isinstance(params["initial"], Surface)
    return _initial_uses(params) | {"seed"} | (frozenset() if built else {"lines"})


def _check_initial(value: Any) -> str | Surface:
    if isinstance(value, Surface):
        return value
    if not isinstance(value, str) or value not in INITIALS:
        raise ParameterError(
            f"unknown initial {value!r}; choose one of {', '.join(INITIALS)} or a Surface"
            " built on the same scan"
        )
    return value


INITIAL_OPTION = Option(
    "initial",
    "any",
    "auto",
    "starting triangulation: auto (grid for gridded scans, else delaunay), delaunay,"
    " shortest-path, grid (or a Surface on the same scan)",
    convert=_check_initial,
)


def initial_surface(scan: PlanarScan, initial: str | Surface, keywords: Keywords) -> Surface:
    """The triangulation LOP and annealing start from: built on ``scan``, or the given
    Surface if it was built on this very scan (so no triangulation is made twice)."""
    if isinstance(initial, Surface):
        if initial.scan is not scan:
            raise ParameterError(
                "initial Surface was built on another scan: pass the PlanarScan it was built on"
                " (Surface.scan) as the source"
            )
        return initial
    if initial == "auto":
        initial = default_initial(scan, keywords.max_edge)
    spec = TABLE[initial]  # built with its default options
    return spec.run(scan, spec.check({}, {}), keywords)


def _run_delaunay(scan: PlanarScan, _params: dict[str, Any], kw: Keywords) -> Surface:
    return delaunay(scan, max_edge=kw.max_edge, progress=kw.context.progress)


def _run_grid(scan: PlanarScan, params: dict[str, Any], kw: Keywords) -> Surface:
    return grid.build_grid(scan, params, kw.context)


def _strip_runner(name: str) -> Callable[[PlanarScan, dict[str, Any], Keywords], Surface]:
    def run(scan: PlanarScan, params: dict[str, Any], kw: Keywords) -> Surface:
        return strips.build_strips(scan, name, params, kw.context)

    return run


def _run_lop(scan: PlanarScan, params: dict[str, Any], kw: Keywords) -> Surface:
    rest = dict(params)
    start = initial_surface(scan, rest.pop("initial"), kw)
    return lop.lop_surface(start, **rest)


def _run_anneal(scan: PlanarScan, params: dict[str, Any], kw: Keywords) -> Surface:
    rest = dict(params)
    start = initial_surface(scan, rest.pop("initial"), kw)
    return anneal.build_anneal(start, rest, kw.context)


def _run_strips_anneal(scan: PlanarScan, params: dict[str, Any], kw: Keywords) -> Surface:
    return strips_anneal.build_strips_anneal(scan, params, kw.context)


#: In the default's judge a candidate starts from another's mesh of the same part, so each
#: triangulation is made once per part: LOP from the part's Delaunay mesh, annealing from
#: LOP's optimum (the state its own descent reaches from Delaunay).
JUDGE_STARTS: dict[str, str] = {"lop": "delaunay", "anneal": "lop"}

#: The annealing schedule of the candidates that anneal, in the judge: one chain of the
#: fewest automatic sweeps (``AnnealParams.auto_sweeps``' least, 8), not the small scans'
#: floor of two million proposals, and no polish (the greedy descent after the sweeps);
#: the winner is built on all points with the full schedule. Measured on the 16 panel
#: scans (docs/benchmarks/panel.md): the same verdicts as the full schedule; the short
#: schedule alone cut the judge's time 1.2-7 x (the pocket, fran_cut), the polish left
#: out another 4-40 % of its CPU (on the 14 scans under 20,000 points).
JUDGE_SCHEDULE: dict[str, Any] = {"sweeps": 8, "chains": 1, "polish": False}


def judge_builder(quiet: Keywords) -> Callable[[str, PlanarScan], Surface]:
    """``build(name, part)`` for :func:`scanmesh.stages.choice.choose`: candidate ``name``
    built on ``part`` with its default options, annealers on :data:`JUDGE_SCHEDULE`, each
    mesh of a part made once and reused as another's start (:data:`JUDGE_STARTS`); the
    meshes of the previous part are dropped when a new part comes. An annealer whose tie
    tolerance follows the noise (strips-anneal) estimates it on the first part and keeps
    it for the others (the parts are 90 % of one window: the estimate was a fifth of the
    judge's strips-anneal build)."""
    made: dict[str, Surface] = {}
    current: list[PlanarScan] = []
    tolerance: dict[str, float] = {}  # annealer -> the tie tolerance of its first part
    lock = threading.Lock()  # the judge's lanes call it side by side on one part

    def build(name: str, part: PlanarScan) -> Surface:
        with lock:
            if not current or current[0] is not part:
                current[:] = [part]
                made.clear()
            surface = made.get(name)
        if surface is None:
            spec = TABLE[name]
            options: dict[str, Any] = dict(JUDGE_SCHEDULE) if spec.anneals else {}
            if name in JUDGE_STARTS:
                options["initial"] = build(JUDGE_STARTS[name], part)
            if name in tolerance:
                options["tie_tolerance"] = tolerance[name]
            params = spec.check(options, {})
            surface = made[name] = spec.run(part, params, quiet)
            if spec.anneals and params["tie_tolerance"] is None:  # from the part's noise
                tolerance[name] = surface.options["tie_tolerance"]
        return surface

    return build


def judge_lanes(candidates: tuple[str, ...]) -> tuple[tuple[str, ...], ...]:
    """``candidates`` in lanes the judge builds side by side: each with the candidates it
    starts from (:data:`JUDGE_STARTS`), in the order given; e.g. strips-anneal alone and
    annealing, LOP, Delaunay together."""

    def root(name: str) -> str:
        start = JUDGE_STARTS.get(name)
        return root(start) if start in candidates else name

    lanes: dict[str, list[str]] = {}
    for name in candidates:
        lanes.setdefault(root(name), []).append(name)
    return tuple(tuple(lane) for lane in lanes.values())


#: On a scan of at most this many points (the judge's window is then all of it, and the
#: first candidate won 11 of the panel's 14 such scans) the first candidate is built on all
#: points beside the judge (:class:`_Ahead`): the winner's build overlaps the judge's on
#: the two cores instead of following it. Larger scans are not: there the first candidate
#: won none of the panel's, and the build would take the judge's cores for longer.
AHEAD_POINTS: int = choice.WINDOW


class _Stopped(Exception):
    """Raised in a build beside the judge by its own progress once it is no longer wanted."""


class _Ahead:
    """Candidate ``name`` built on all of ``scan`` with the call's keywords in a daemon
    thread while the judge runs (the same seed: the very mesh built after the judge).
    Its progress is the call's only once it is taken (:meth:`take`: the stages still to
    come and the one running); :meth:`stop` ends it at its next progress report (a chunk
    of annealing or one native call). Its warnings are replayed when it is taken
    (:func:`scanmesh.stages.choice.recorded`)."""

    def __init__(self, name: str, scan: PlanarScan, kw: Keywords) -> None:
        self.name = name
        self.result: Surface | None = None
        self.error: BaseException | None = None
        self._stop = threading.Event()
        self._shown: Progress = False  # the call's progress, once taken
        self._stage: Stage | None = None  # the bar or log line of the stage shown
        own = Keywords(kw.max_edge, dataclasses.replace(kw.context, progress=self._report))
        self._thread = threading.Thread(
            target=self._run, args=(scan, own), name="scanmesh-ahead", daemon=True
        )
        self._thread.start()  # RuntimeError when no thread can start: the caller's to skip

    @property
    def ident(self) -> int | None:
        """The build's thread (whose warnings are its)."""
        return self._thread.ident

    def _run(self, scan: PlanarScan, own: Keywords) -> None:
        spec = TABLE[self.name]
        try:
            self.result = spec.run(scan, spec.check({}, {}), own)
        except _Stopped:
            pass
        except BaseException as exc:  # noqa: BLE001 - the caller builds again and sees it
            self.error = exc

    def _report(self, done: int, total: int, value: float | None = None, **extra: Any) -> None:
        if self._stop.is_set():
            raise _Stopped
        shown = self._shown
        name = extra.get("stage", "anneal")
        if shown is True:  # bars: one at a time, the stage running
            if self._stage is None or self._stage.name != name:
                self._close()
                self._stage = Stage(True, name, total)
            self._stage.update(done, value)
        elif callable(shown):
            if takes_stage(shown):
                keep = {k: v for k, v in extra.items() if accepts(shown, k) or k == "stage"}
                shown(done, total, value, **keep)
            elif name == "anneal":  # annealing's (done, total, energy) only
                shown(done, total, value)

    def _close(self) -> None:
        if self._stage is not None:
            self._stage.close()
            self._stage = None

    def take(self, progress: Progress) -> Surface | None:
        """The mesh, waited for in ``POLL_SECONDS`` slices (Ctrl-C reaches the caller),
        its progress from now on ``progress``'s; None if its build failed (the caller
        builds again, and raises)."""
        self._shown = progress
        while self._thread.is_alive():
            self._thread.join(POLL_SECONDS)
        self._close()
        return self.result if self.error is None else None

    def stop(self, wait: bool = True) -> None:
        """Ends the build at its next progress report (``wait``: waited for, in slices)."""
        self._stop.set()
        while wait and self._thread.is_alive():
            self._thread.join(POLL_SECONDS)


def _ahead(scan: PlanarScan, name: str, kw: Keywords) -> _Ahead | None:
    """Candidate ``name`` built beside the judge (:class:`_Ahead`) on a scan of
    ``choice.MIN_POINTS`` to :data:`AHEAD_POINTS` points, else None (none either when no
    thread can start)."""
    if not choice.MIN_POINTS <= len(scan.points) <= AHEAD_POINTS:
        return None
    try:
        return _Ahead(name, scan, kw)
    except RuntimeError:  # "can't start new thread": the winner is built after the judge
        return None


def _run_auto(scan: PlanarScan, _params: dict[str, Any], kw: Keywords) -> Surface:
    """The candidate a holdout on a window of the scan prefers (``stages.choice``), built on
    all points with the call's keywords; ``options["method_choice"]`` says what each
    candidate measured. On a small scan the first candidate is built beside the judge
    (:data:`AHEAD_POINTS`) and stopped once the judge puts it out."""
    build = judge_builder(Keywords(max_edge=kw.max_edge, context=kw.context.quiet()))
    gridded = default_initial(scan, kw.max_edge) == "grid"
    candidates = GRID_CANDIDATES if gridded else CANDIDATES
    lanes = judge_lanes(candidates)
    surface = None
    with choice.recorded() as log:
        ahead = _ahead(scan, candidates[0], kw)

        def watch(judged: tuple[str, ...]) -> None:
            if ahead is not None and ahead.name not in judged:
                ahead.stop(wait=False)

        try:
            made = choice.choose(scan, build, candidates, kw.context, lanes, watch)
            if ahead is not None and made.chosen == ahead.name:
                surface = ahead.take(kw.context.progress)
        except BaseException:
            if ahead is not None:
                ahead.stop(wait=False)  # Ctrl-C: not waited for
            raise
        if ahead is not None and surface is None:
            ahead.stop()  # waited for: its last warnings go to the log, not to the caller
    if surface is not None and ahead is not None:
        choice.replay(log, ahead.ident)
        built = ahead.name
    else:
        # The parts have no range grid, so Delaunay stands in for the grid triangulation in
        # the judge; on a gridded scan the grid is built, as LOP and annealing start from it
        # there (Delaunay keeps the curtains the grid drops).
        planar = "grid" if gridded else "delaunay"
        built = planar if made.chosen == "delaunay" else made.chosen
        spec = TABLE[built]
        surface = spec.run(scan, spec.check({}, {}), kw)
    surface.options = {**surface.options, "method_choice": {**made.as_dict(), "built": built}}
    return surface


def _run_optimal(scan: PlanarScan, params: dict[str, Any], _kw: Keywords) -> Surface:
    return optimal.optimal_surface(scan, **params)


#: Every method, fast to slow (``auto`` builds several).
TABLE: dict[str, Method] = {
    m.name: m
    for m in (
        Method(
            "delaunay",
            _run_delaunay,
            frozenset({"max_edge"}),
            (),
            "max-min angle optimum in the plane, trimmed to the outline",
            tiles=Tiles.BUILT,
            judged=3,
            compared=True,
            max_min_angle=True,
        ),
        Method(
            "grid",
            _run_grid,
            frozenset(),
            grid.OPTIONS,
            "range-grid neighbours, less the faces the scanner cannot have seen",
            compared=True,
            needs_grid=True,
        ),
        Method(
            "lookahead",
            _strip_runner("lookahead"),
            frozenset({"lines"}),
            strips.OPTIONS["lookahead"],
            "Friedhoff's look-ahead strips between consecutive scan lines",
            strips=True,
            compared=True,
        ),
        Method(
            "shortest-path",
            _strip_runner("shortest-path"),
            frozenset({"lines"}),
            strips.OPTIONS["shortest-path"],
            "cheapest Fuchs-matrix path per strip between consecutive scan lines",
            strips=True,
            compared=True,
        ),
        Method(
            "lop",
            _run_lop,
            frozenset({"lines", "max_edge"}),
            (INITIAL_OPTION, *lop.OPTIONS),
            "Lawson's flips while tac drops (greedy)",
            uses=_initial_uses,
            tiles=Tiles.OPTIMIZED,
            judged=2,
            compared=True,
        ),
        Method(
            "anneal",
            _run_anneal,
            frozenset({"lines", "max_edge", "seed"}),
            (INITIAL_OPTION, *anneal.OPTIONS),
            "simulated annealing on tac",
            uses=_anneal_uses,
            tiles=Tiles.OPTIMIZED,
            anneals=True,
            judged=1,
            compared=True,
        ),
        Method(
            "strips-anneal",
            _run_strips_anneal,
            frozenset({"lines", "seed"}),
            strips_anneal.OPTIONS,
            "the strips, annealed on tac where tac rises above the noise",
            anneals=True,
            judged=0,
            from_strips=True,
        ),
        Method(
            "auto",
            _run_auto,
            frozenset({"lines", "max_edge", "seed"}),
            (),
            "the default: the method a holdout away from steps prefers (strips-anneal, anneal,"
            " lop, delaunay)",
        ),
        Method(
            "optimal",
            _run_optimal,
            frozenset(),
            optimal.OPTIONS,
            "certified tac optimum of the convex hull (small inputs only)",
        ),
    )
}

#: The method of :func:`scanmesh.reconstruct` and the command when none is named.
DEFAULT_METHOD = "auto"

#: Method names, fast to slow.
METHODS: tuple[str, ...] = tuple(TABLE)

#: The default's candidates, in order of preference (the earlier wins an exact tie).
#: The strips enter as strips-anneal (as close to the part as shortest-path or closer on
#: every panel scan); look-ahead is left out: it never beat shortest-path by more than 0.1 %
#: on the panel, and its defect on the fandisk (40 x the height error) does not show in a
#: holdout.
CANDIDATES: tuple[str, ...] = tuple(
    sorted((m.name for m in TABLE.values() if m.judged is not None), key=lambda n: TABLE[n].judged)
)

#: The candidates on a gridded scan: those that stay inside the grid's domain (the grid,
#: for which Delaunay stands in on the judge's parts, and LOP and annealing started from
#: it). The strips join neighbouring lines wherever both have samples, whatever the scanner
#: saw between them: on the conrod scanned along y (benches/curtains.py) the holdout picked
#: them and the default missed 1.62 points more of the part than the best peer, the grid
#: 0.54 less.
GRID_CANDIDATES: tuple[str, ...] = tuple(
    n for n in CANDIDATES if not (TABLE[n].strips or TABLE[n].from_strips)
)

#: What ``scanmesh compare`` runs when no method is named (those needing a range grid on
#: gridded scans only): every method but the default (which builds several) and the exact
#: one (small inputs only).
COMPARED: tuple[str, ...] = tuple(n for n, m in TABLE.items() if m.compared)

#: Methods the Dask path solves in partitions of consecutive lines.
STRIP_METHODS: tuple[str, ...] = tuple(n for n, m in TABLE.items() if m.strips)

#: Methods the Dask path runs in tiles of the plane.
TILE_METHODS: tuple[str, ...] = tuple(n for n, m in TABLE.items() if m.tiles is not None)

#: The initial triangulations a method runs from in tiles: the tiled Delaunay's.
TILE_INITIALS: tuple[str, ...] = ("auto", "delaunay")

#: The method named where the default cannot serve: on Dask (no "auto" there), and when
#: only its own flags are given (it was the default before "auto").
FALLBACK_METHOD = "anneal"


def method(name: str) -> Method:
    """The method called ``name``, or ParameterError listing the methods."""
    if not isinstance(name, str) or name not in TABLE:
        raise ParameterError(f"unknown method {name!r}; choose one of {', '.join(METHODS)}")
    return TABLE[name]


def used_keywords(name: str, options: Mapping[str, Any]) -> frozenset[str]:
    """The shared keywords (of :data:`SHARED`) method ``name`` uses with these options
    (``options`` may hold shared keywords and ``plane`` too: they are left aside)."""
    spec = method(name)
    if spec.uses is None:
        return spec.shared
    own = {k: v for k, v in options.items() if k not in SHARED and k != "plane"}
    return spec.uses(check_options(spec.options, own, f"method {name!r}"))


__all__ = [
    "Method",
    "Tiles",
    "CANDIDATES",
    "GRID_CANDIDATES",
    "COMPARED",
    "STRIP_METHODS",
    "TILE_METHODS",
    "TILE_INITIALS",
    "FALLBACK_METHOD",
    "Keywords",
    "TABLE",
    "METHODS",
    "DEFAULT_METHOD",
    "SHARED",
    "method",
    "initial_surface",
    "default_initial",
    "used_keywords",
]
