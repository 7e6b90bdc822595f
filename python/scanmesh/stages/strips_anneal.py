"""Steps from the strips, smoothness from annealing (``method="strips-anneal"``).

The strips follow the scanner's lines: they bridge a wall or step between a line's own
samples, cut the lines at depth jumps, and on noisy flat parts keep a regular mesh whose
height error is the noise's. Annealing on tac finds the smooth surface and turns edges
along creases, but on noisy flats its flips fit the noise. This method takes each where it
is right: it builds the shortest-path strips and anneals them on tac (``stages.anneal``,
the same schedule), with the tie tolerance taken from the scan's noise, so that flips
changing tac by no more than the noise does are ties: noisy flats and the walls between
them keep the strips, curved and creased parts are annealed. Flips keep the strips'
outline and holes, so the depth jumps the strips cut stay open. Edges of the strips' step
triangles (tilted more than ``step_angle`` from the projection plane) can also be kept
fixed: no flip of the walk, the descent or the polish removes them (the core's
``FixedEdges``). The automatic schedule spends annealing's budget of proposals on the
edges the noise's ties leave live (a third of them on a noisy part), from a hotter start:
the strips' fans across steps are left only by a long, hot walk. Measurements:
docs/benchmarks/panel.md.
"""

from __future__ import annotations

import dataclasses
import math
from typing import Any

import numpy as np

from scanmesh._checks import Option, check_options
from scanmesh._context import QUIET, Context
from scanmesh._progress import Progress
from scanmesh.scan.planar import PlanarScan
from scanmesh.stages import anneal, strips
from scanmesh.stages.options import SEED_OPTION
from scanmesh.surface import Surface

#: A strip triangle whose normal is tilted more than this from the projection normal is a
#: step (degrees): its edges are kept. Default 90, none: measured on the panel, keeping the
#: edges of triangles steeper than 45, 60 or 75 degrees raised the height error on the
#: fandisk at s/10 (by 3.5-8 %) and the oblique pocket at s/10 (by 5 %) against annealing them
#: from the strips, and changed nothing on the pocket along its axis: the noise's tie
#: tolerance already keeps the strips where flips only fit the noise.
STEP_ANGLE_OPTION = Option(
    "step_angle",
    "float",
    90.0,
    "strip triangles tilted more than this from the projection plane (degrees) are steps:"
    " their edges are kept (90: none)",
    low=0.0,
    high=90.0,
    low_open=True,
)

#: The automatic schedule's ``initial_acceptance``: a hotter start than annealing's 0.8.
#: The descent from the strips leaves a fan across a step where tac alone finds no way down
#: (the fandisk along its axis at s/30: one triangle from the upper level over the lower
#: one, 6 % of the squared height error); at 0.95 and the full budget of proposals
#: (:func:`scanmesh.stages.anneal.live_sweeps`) the walk leaves it (height error 0.985 x
#: annealing's, seeds 0 and 1; tac_1 50 against 54). Only with that budget: at 0.95 and the
#: plan's shorter walk the fandisk turned at s/10 and the oblique pocket at s/10 rose 8-9 %.
HOT_ACCEPTANCE = 0.95


def _schedule_option(option: Option) -> Option:
    """Annealing's ``option`` as this method takes it: the tie tolerance and the initial
    acceptance automatic (None: from the noise; :data:`HOT_ACCEPTANCE` with automatic
    sweeps)."""
    if option.name == "tie_tolerance":
        return dataclasses.replace(option, default=None)
    if option.name == "initial_acceptance":
        doc = option.doc + f" (automatic: {HOT_ACCEPTANCE} with automatic sweeps)"
        return dataclasses.replace(option, default=None, automatic=True, doc=doc)
    return option


#: The annealing schedule's options this method passes on: all but ``tiles`` (the tiled
#: annealer rebuilds its pieces' states and knows no fixed edges), the tie tolerance taken
#: from the scan's noise by default: flips that change tac by less than the noise's share
#: are ties, so noisy flat parts keep the strips (the pocket at s/10: the strips' height
#: error, where tac-driven flips raised it 3 %) and curved or creased parts are annealed.
#: Automatic sweeps spend the plan's budget of proposals on the live edges (the noise's ties
#: leave a third of them) from a hotter start (:data:`HOT_ACCEPTANCE`).
SCHEDULE: tuple[Option, ...] = tuple(
    _schedule_option(o) for o in anneal.OPTIONS if o.name != "tiles"
)

#: The method's options: the step angle, then the annealing schedule.
OPTIONS: tuple[Option, ...] = (STEP_ANGLE_OPTION, *SCHEDULE)


def step_edges(surface: Surface, step_angle: float) -> np.ndarray:
    """(K, 2) int64 edges (point indices, smaller first, each once) of the faces of
    ``surface`` whose normal is tilted more than ``step_angle`` degrees from its scan's
    projection normal (tilt measured as atan2(|n x N|, |n . N|)). O(F log F)."""
    assert surface.scan is not None
    normal = np.asarray(surface.scan.frame.normal, dtype=np.float64)
    tri = surface.vertices[surface.faces]
    n = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
    tilt = np.arctan2(np.linalg.norm(np.cross(n, normal), axis=1), np.abs(n @ normal))
    steep = tilt > math.radians(step_angle) if step_angle < 90.0 else np.zeros(len(tilt), bool)
    steps = surface.faces[steep]
    edges = np.sort(steps[:, [0, 1, 1, 2, 2, 0]].reshape(-1, 2).astype(np.int64), axis=1)
    return np.unique(edges, axis=0).reshape(-1, 2)


def strips_anneal_surface(
    scan: PlanarScan,
    *,
    seed: int | None = None,
    progress: Progress = False,
    **options: Any,
) -> Surface:
    """The shortest-path strips of ``scan`` annealed on tac (with their step triangles'
    edges kept when ``step_angle`` < 90).

    ``options``: ``step_angle`` (degrees, 90: none kept) and the annealing schedule of
    :func:`scanmesh.stages.anneal.anneal_surface` (all but ``tiles``; ``tie_tolerance``
    None by default: from the scan's noise; automatic ``sweeps`` spend the plan's budget
    of proposals on the live edges, :func:`scanmesh.stages.anneal.live_sweeps`, and
    ``initial_acceptance`` None is then :data:`HOT_ACCEPTANCE`, otherwise annealing's);
    checked against :data:`OPTIONS`. ``seed``
    fixes every random choice; ``progress`` reports the strips' and annealing's stages;
    Ctrl-C ends the run within annealing's chunk. O(strips + annealing's proposals).

    Returns
    -------
    Surface
        method "strips-anneal", on ``scan``; ``options["step_edges"]`` counts the edges
        kept, ``options["initial"]`` is "shortest-path".
    """
    params = check_options(OPTIONS, options, "method 'strips-anneal'")
    given = None if seed is None else SEED_OPTION.check(seed)
    return build_strips_anneal(scan, params, Context.of(progress, given))


def build_strips_anneal(
    scan: PlanarScan, params: dict[str, Any], context: Context = QUIET
) -> Surface:
    """:func:`strips_anneal_surface` without its checks: ``params`` the checked options of
    :data:`OPTIONS`, the seed and progress those of the call (``context``), as the registry
    (``scanmesh.methods``) has them. O(strips + annealing's proposals)."""
    params = dict(params)
    step_angle = params.pop("step_angle")
    defaults = check_options(strips.OPTIONS["shortest-path"], {}, "the strips")
    start = strips.build_strips(scan, "shortest-path", defaults, context)
    fixed = step_edges(start, step_angle)
    if params["initial_acceptance"] is None:
        automatic = params["sweeps"] is None
        params["initial_acceptance"] = (
            HOT_ACCEPTANCE if automatic else anneal.ANNEAL_DEFAULTS["initial_acceptance"]
        )
    out = anneal.build_anneal(start, {**params, "tiles": 1}, context, fixed, live_budget=True)
    out.method = "strips-anneal"
    out.options = {**out.options, "step_angle": step_angle, "step_edges": len(fixed)}
    return out


__all__ = [
    "strips_anneal_surface",
    "build_strips_anneal",
    "step_edges",
    "OPTIONS",
    "STEP_ANGLE_OPTION",
    "HOT_ACCEPTANCE",
]
