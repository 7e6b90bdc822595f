"""The table of triangulation methods: what each one runs, which keywords and options it takes.

:func:`scanmesh.reconstruct` and the ``scanmesh`` command read everything about a method
from here: the option checks (one :class:`scanmesh._checks.Option` each, so a bad value is
refused with the option's name whichever way it came in), the keywords a method uses (a
keyword it would not use is refused, not dropped), and the command's flags and help.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from dataclasses import dataclass
from typing import Any

from scanmesh._checks import Option, check_options
from scanmesh._context import QUIET, Context
from scanmesh.errors import ParameterError
from scanmesh.scan.planar import PlanarScan
from scanmesh.stages import anneal, choice, grid, lop, optimal, strips
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


@dataclass(frozen=True)
class Method:
    """One triangulation method of :func:`scanmesh.reconstruct`."""

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
    if initial == "grid":
        return grid.grid_surface(scan, context=keywords.context)
    if initial == "delaunay":
        return delaunay(scan, max_edge=keywords.max_edge, progress=keywords.context.progress)
    return strips.strip_surface(scan, method="shortest-path", context=keywords.context)


def _run_delaunay(scan: PlanarScan, _params: dict[str, Any], kw: Keywords) -> Surface:
    return delaunay(scan, max_edge=kw.max_edge, progress=kw.context.progress)


def _run_grid(scan: PlanarScan, params: dict[str, Any], kw: Keywords) -> Surface:
    return grid.grid_surface(scan, context=kw.context, **params)


def _strip_runner(name: str) -> Callable[[PlanarScan, dict[str, Any], Keywords], Surface]:
    def run(scan: PlanarScan, params: dict[str, Any], kw: Keywords) -> Surface:
        return strips.strip_surface(scan, method=name, context=kw.context, **params)

    return run


def _run_lop(scan: PlanarScan, params: dict[str, Any], kw: Keywords) -> Surface:
    rest = dict(params)
    start = initial_surface(scan, rest.pop("initial"), kw)
    return lop.lop_surface(start, **rest)


def _run_anneal(scan: PlanarScan, params: dict[str, Any], kw: Keywords) -> Surface:
    rest = dict(params)
    start = initial_surface(scan, rest.pop("initial"), kw)
    return anneal.anneal_surface(start, context=kw.context, **rest)


def _run_auto(scan: PlanarScan, _params: dict[str, Any], kw: Keywords) -> Surface:
    """The candidate a holdout on a window of the scan prefers (``stages.choice``), built on
    all points with the call's keywords; ``options["method_choice"]`` says what each
    candidate measured."""
    quiet = Keywords(max_edge=kw.max_edge, context=kw.context.quiet())

    def build(name: str, part: PlanarScan) -> Surface:
        spec = TABLE[name]
        return spec.run(part, spec.check({}, {}), quiet)

    gridded = default_initial(scan, kw.max_edge) == "grid"
    candidates = choice.GRID_CANDIDATES if gridded else choice.CANDIDATES
    made = choice.choose(scan, build, candidates=candidates, context=kw.context)
    # The parts have no range grid, so Delaunay stands in for the grid triangulation in the
    # judge; on a gridded scan the grid is built, as LOP and annealing start from it there
    # (Delaunay keeps the curtains the grid drops).
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
        ),
        Method(
            "grid",
            _run_grid,
            frozenset(),
            grid.OPTIONS,
            "range-grid neighbours, less the faces the scanner cannot have seen",
        ),
        Method(
            "lookahead",
            _strip_runner("lookahead"),
            frozenset({"lines"}),
            strips.OPTIONS["lookahead"],
            "Friedhoff's look-ahead strips between consecutive scan lines",
        ),
        Method(
            "shortest-path",
            _strip_runner("shortest-path"),
            frozenset({"lines"}),
            strips.OPTIONS["shortest-path"],
            "cheapest Fuchs-matrix path per strip between consecutive scan lines",
        ),
        Method(
            "lop",
            _run_lop,
            frozenset({"lines", "max_edge"}),
            (INITIAL_OPTION, *lop.OPTIONS),
            "Lawson's flips while tac drops (greedy)",
            uses=_initial_uses,
        ),
        Method(
            "anneal",
            _run_anneal,
            frozenset({"lines", "max_edge", "seed"}),
            (INITIAL_OPTION, *anneal.OPTIONS),
            "simulated annealing on tac",
            uses=_anneal_uses,
        ),
        Method(
            "auto",
            _run_auto,
            frozenset({"lines", "max_edge", "seed"}),
            (),
            "the default: the method a holdout on a window of the scan prefers (anneal, lop,"
            " delaunay, shortest-path)",
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
