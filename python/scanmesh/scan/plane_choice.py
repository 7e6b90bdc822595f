"""The projection plane chosen by the data, for ``plane=None``.

A planar method triangulates the points projected onto a plane, so the plane must make the
surface a height field: seen along the wrong normal, walls and folds become steep triangles
that stand on edge over the plane, and points above one another coincide. The
least-squares plane is not always the right one (a rocker arm scanned along z: 54 % steep
triangles over it). So, for ``plane=None``, :func:`choose_plane` measures on a quick
trimmed Delaunay triangulation of a seeded subsample which candidate normal leaves the
fewest steep triangles (``scan.steep.STEEP_ANGLE_DEG``) and the fewest points left out, and
picks it.

This replaces the earlier default, the least-squares plane (docs/definitions.md,
"Projection"): a planar method needs a plane over which the surface is a height field, and
the data show which one; an explicit ``plane=`` (including ``"best-fit"``) is always obeyed
unchanged.

Candidates, in order of preference (the first within ``TIE`` of the lowest score wins):
the digitizer's ``up`` recorded in the file, the least-squares plane (the old default), the
coordinate axes x, y, z, and the two larger principal axes of the points (the smallest is
the least-squares normal). A candidate within ``SAME_DEG`` of an earlier one is not
measured twice.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np

from scanmesh import _core
from scanmesh.errors import ScanmeshError
from scanmesh.scan.projection import PlaneSpec
from scanmesh.scan.spacing import trim_length
from scanmesh.scan.steep import steep_fraction

#: Points triangulated per candidate at most: a larger scan is measured on a seeded random
#: subsample of this size (at most 7 Delaunay triangulations of 20k points).
SAMPLE: int = 20_000

#: Seed of the subsample: the same points always give the same choice.
SAMPLE_SEED: int = 0

#: Scores (steep + unused share) within this much (absolute) of the lowest count as a tie,
#: which the earlier candidate (``up`` first) wins: the conrod scanned along z scores 3.8 %
#: along its recorded up and 1.9 % over the least-squares plane, both fine.
TIE: float = 0.02

#: Candidates closer than this many degrees to an earlier one are the same plane.
SAME_DEG: float = 2.0

_AXES = {"x": (1.0, 0.0, 0.0), "y": (0.0, 1.0, 0.0), "z": (0.0, 0.0, 1.0)}


@dataclass(frozen=True)
class PlaneChoice:
    """The plane ``plane=None`` resolved to, and what every candidate measured."""

    #: label of the chosen candidate: "up", "best-fit", "x", "y", "z", "axis 1", "axis 2"
    chosen: str
    #: the plane spec the points are projected with ("best-fit", an axis name or a normal)
    spec: PlaneSpec
    #: candidate label -> share of steep triangles of its quick triangulation (None: it
    #: degenerated, e.g. collinear in that plane)
    steep: dict[str, float | None]
    #: candidate label -> share of the points no quick triangle uses (coincident in that
    #: plane, or trimmed); the choice minimises steep + unused
    unused: dict[str, float | None]
    #: candidate label -> its unit normal (the candidates measured)
    normals: dict[str, tuple[float, ...]]
    #: points the candidates were measured on
    sampled: int

    def as_dict(self, normal: np.ndarray) -> dict[str, Any]:
        """JSON-ready summary for ``Surface.options["plane_choice"]`` and the report, with
        ``normal`` the normal of the frame actually used."""
        return {
            "chosen": self.chosen,
            "normal": [float(c) for c in normal],
            "steep": dict(self.steep),
            "unused": dict(self.unused),
            "candidates": {k: list(v) for k, v in self.normals.items()},
            "sampled": self.sampled,
        }


def candidates(points: np.ndarray, up: np.ndarray | None) -> dict[str, np.ndarray]:
    """Candidate unit normals by label, in order of preference, without near-repeats (none
    for points on a line).

    ``points`` (M, 3) float64 (the subsample, in the unit box); the principal axes are its
    covariance's eigenvectors, signed so that their largest component is positive (as the
    core signs the least-squares normal). O(M)."""
    centred = points - points.mean(axis=0)
    values, vectors = np.linalg.eigh(centred.T @ centred)  # eigenvalues ascending
    if values[1] <= values[2] * 1e-14:
        # a line (the core's test): no plane to choose, and rounding in a projection could
        # make one look like a sliver triangle; the least-squares projection refuses it
        return {}
    raw: list[tuple[str, np.ndarray]] = []
    if up is not None:
        raw.append(("up", np.asarray(up, dtype=np.float64)))
    raw.append(("best-fit", vectors[:, 0]))
    raw += [(name, np.array(vec)) for name, vec in _AXES.items()]
    raw += [("axis 1", vectors[:, 2]), ("axis 2", vectors[:, 1])]
    same = math.cos(math.radians(SAME_DEG))
    kept: dict[str, np.ndarray] = {}
    for label, vec in raw:
        unit = vec / np.linalg.norm(vec)
        if label.startswith(("axis", "best")) and unit[np.argmax(np.abs(unit))] < 0:
            unit = -unit
        if all(abs(float(unit @ other)) < same for other in kept.values()):
            kept[label] = unit
    return kept


def quick_faces(points: np.ndarray, normal: np.ndarray) -> np.ndarray | None:
    """(M, 3) int64 Delaunay triangulation of ``points`` seen along ``normal``, trimmed as
    ``delaunay`` trims it (untrimmed if trimming leaves nothing); None when the points are
    collinear or coincide in that plane. O(M log M)."""
    # the frame of scanmesh.scan.projection (u x v = normal, so counter-clockwise faces face
    # along it), in numpy: the sample needs no checks, and no origin (steepness ignores it)
    helper = np.zeros(3)
    helper[np.argmin(np.abs(normal))] = 1.0
    u = np.cross(helper, normal)
    u /= np.linalg.norm(u)
    uv = points @ np.column_stack([u, np.cross(normal, u)])
    try:
        faces, _ = _core.delaunay(uv)
        if len(faces) == 0:
            return None
        # trimmed at the default max_edge, as delaunay() trims
        trimmed = _core.trim_long_edges(uv, faces, trim_length(uv, faces))
    except ScanmeshError:
        return None
    return trimmed if len(trimmed) else faces


def score(points: np.ndarray, normal: np.ndarray) -> tuple[float, float] | None:
    """(steep share, unused share) of :func:`quick_faces` seen along ``normal``, or None.

    Unused points (in no triangle: coincident in the plane, or trimmed) count too: a surface
    folded over the plane puts points above one another, and those are dropped as
    duplicates instead of making steep triangles (a flat plate seen edge-on keeps almost
    no steep triangle)."""
    faces = quick_faces(points, normal)
    if faces is None:
        return None
    used = np.zeros(len(points), dtype=bool)
    used[faces.ravel()] = True
    return steep_fraction(points, faces, normal), 1.0 - float(used.mean())


def settled(measured: dict[str, tuple[float, float] | None]) -> bool:
    """True when the candidates not yet measured cannot change the choice: the last one
    scores at most ``TIE`` (so it is within TIE of any lower score) and every earlier one
    more than TIE above it (so none of them is within TIE of the lowest)."""
    *earlier, last = measured.values()
    if last is None or sum(last) > TIE:
        return False
    return all(m is None or sum(m) > sum(last) + TIE for m in earlier)


def choose_plane(points: np.ndarray, up: np.ndarray | None = None) -> PlaneChoice:
    """The candidate plane over which ``points`` are most a height field.

    ``points`` (N, 3) float64, checked; ``up`` (3,) float the direction recorded with the
    scan, or None. Every candidate is measured on at most ``SAMPLE`` points (seeded), so
    the choice is deterministic; O(S log S) per candidate, S = min(N, SAMPLE). Candidates
    are measured in order of preference and the rest skipped once :func:`settled` (a scan
    along its recorded up, or a flat patch over its least-squares plane, costs one quick
    triangulation; ``steep`` and ``unused`` list what was measured). When every
    candidate degenerates, the least-squares plane is returned (its projection then says
    what is wrong with the points).
    """
    if len(points) > SAMPLE:
        rng = np.random.default_rng(SAMPLE_SEED)
        sample = points[np.sort(rng.choice(len(points), SAMPLE, replace=False))]
    else:
        sample = points
    # into the unit box (translation and scale change no angle): 1e308-sized coordinates
    # would overflow in the covariance and the projections
    lo, hi = sample.min(axis=0), sample.max(axis=0)
    half = float(np.max(hi / 2 - lo / 2))
    if half > 0:
        sample = (sample - (lo / 2 + hi / 2)) / half
    normals = candidates(sample, up) if half > 0 else {}
    measured: dict[str, tuple[float, float] | None] = {}
    for label, normal in normals.items():
        measured[label] = score(sample, normal)
        if settled(measured):
            break
    normals = {k: normals[k] for k in measured}
    totals = {k: sum(m) for k, m in measured.items() if m is not None}
    chosen = "best-fit"
    if totals:
        lowest = min(totals.values())
        chosen = next(k for k, total in totals.items() if total <= lowest + TIE)
    spec: PlaneSpec = chosen
    if chosen not in ("best-fit", *_AXES):
        spec = tuple(float(c) for c in normals[chosen])
    return PlaneChoice(
        chosen=chosen,
        spec=spec,
        steep={k: None if m is None else m[0] for k, m in measured.items()},
        unused={k: None if m is None else m[1] for k, m in measured.items()},
        normals={k: tuple(float(c) for c in v) for k, v in normals.items()},
        sampled=len(sample),
    )


__all__ = [
    "PlaneChoice",
    "choose_plane",
    "candidates",
    "quick_faces",
    "score",
    "settled",
    "SAMPLE",
    "TIE",
]
