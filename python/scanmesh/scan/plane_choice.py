"""The projection plane chosen by the data, for ``plane=None``.

A planar method triangulates the points projected onto a plane, so the plane must make the
surface a height field: seen along the wrong normal, walls and folds become steep triangles
that stand on edge over the plane, and points above one another coincide. The
least-squares plane is not always the right one (a rocker arm scanned along z: 54 % steep
triangles over it). So, for ``plane=None``, :func:`choose_plane` measures on a quick
trimmed Delaunay triangulation of a seeded subsample which candidate normals leave few
steep triangles (``scan.steep.STEEP_ANGLE_DEG``) and few points left out; when several
come close (within ``MARGIN``), a holdout on the subsample decides: a tenth of its points
withheld, each candidate's mesh of the rest measured at them (distance to the plane of the
triangle above or below each withheld point). Steepness alone can prefer a tilted plane
that is a worse height field: the fandisk scanned along y has 3.6 % steep triangles over
its least-squares plane (30 degrees off y) and 8.3 % over y, and the annealed mesh over the
tilted plane is 17 x farther from the part; the holdout says so (0.020 against 0.0015 in
the unit box).

An explicit ``plane=`` (including ``"best-fit"``) is always obeyed unchanged.

Candidates, in order of preference (the earlier wins on ties): the digitizer's ``up``
recorded in the file, the coordinate axes x, y, z (digitizers scan along their machine's
axes), the least-squares plane, and the two larger principal axes of the points. A
candidate within ``SAME_DEG`` of an earlier one is the same plane: a least-squares plane
0.6 degrees off z (the octagonal pocket) is measured, and used, as z.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np

from scanmesh import _core
from scanmesh.errors import ScanmeshError
from scanmesh.judge import Seen, distances, rms, withhold
from scanmesh.scan.projection import PlaneSpec
from scanmesh.scan.spacing import trim_length
from scanmesh.scan.steep import steep_fraction

#: Points triangulated per candidate at most: a larger scan is measured on a seeded random
#: subsample of this size (at most 7 Delaunay triangulations of 20k points).
SAMPLE: int = 20_000

#: Seed of the subsample: the same points always give the same choice.
SAMPLE_SEED: int = 0

#: A score (steep + unused share) at most this counts as a height field with no doubt: the
#: conrod scanned along z scores 3.8 % along its recorded up and 1.9 % over the
#: least-squares plane, both fine.
TIE: float = 0.02

#: Candidates scoring within this much (absolute) of the lowest score are judged by the
#: holdout (the fandisk: 3.6 % and 8.3 %, see above).
MARGIN: float = 0.10

#: Holdout RMS within this share of the lowest counts as a tie, which the earlier candidate
#: wins.
HOLDOUT_TIE: float = 0.02

#: Fewer sampled points are too few to judge by a holdout.
MIN_HOLDOUT_POINTS: int = 30

#: A candidate whose mesh leaves more of the withheld points outside (beyond its outline)
#: than the fewest by this share is not judged by the holdout: it measured too few.
OUTSIDE_MARGIN: float = 0.10

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
    #: candidate label -> holdout RMS on the subsample in the unit box (only candidates
    #: scoring within MARGIN of the lowest, when there were several; None: left out)
    holdout: dict[str, float | None]
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
            "holdout": dict(self.holdout),
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
    raw += [(name, np.array(vec)) for name, vec in _AXES.items()]
    raw.append(("best-fit", vectors[:, 0]))
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


def plane_axes(normal: np.ndarray) -> np.ndarray:
    """(3, 2) float64 the in-plane axes (u, v) of the frame of scanmesh.scan.projection for
    the unit ``normal`` (u x v = normal, so counter-clockwise faces face along it), in
    numpy: a sample needs no checks, and no origin. O(1)."""
    helper = np.zeros(3)
    helper[np.argmin(np.abs(normal))] = 1.0
    u = np.cross(helper, normal)
    u /= np.linalg.norm(u)
    return np.column_stack([u, np.cross(normal, u)])


def quick_faces(points: np.ndarray, normal: np.ndarray) -> np.ndarray | None:
    """(M, 3) int64 Delaunay triangulation of ``points`` seen along ``normal``, trimmed as
    ``delaunay`` trims it (untrimmed if trimming leaves nothing); None when the points are
    collinear or coincide in that plane. O(M log M)."""
    uv = points @ plane_axes(normal)
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


def holdout(points: np.ndarray, normal: np.ndarray) -> tuple[float, float] | None:
    """(RMS, outside share) of a holdout on ``points`` seen along ``normal``, or None.

    A seeded tenth of the points is withheld, :func:`quick_faces` triangulates the rest,
    and each withheld point inside the mesh's outline is measured: its distance to the
    plane of the triangle above or below it (the height difference along ``normal`` times
    the cosine between the triangle's normal and ``normal``), a distance in space, so that
    candidates seen along different normals compare. The outside share is that of the
    withheld points beyond the outline. O(M log M)."""
    n = len(points)
    out = withhold(n, max(1, n // 10), np.random.default_rng(SAMPLE_SEED))
    kept = points[~out]
    faces = quick_faces(kept, normal)
    if faces is None:
        return None
    seen = Seen(kept[faces], normal, plane_axes(normal))
    got, face = distances(points[out], seen)
    inside = face >= 0
    if not inside.any():
        return None
    held = face[inside]
    along = got[inside]
    tri = seen.tri
    cross = np.cross(tri[held, 1] - tri[held, 0], tri[held, 2] - tri[held, 0])
    cosine = np.abs(cross @ normal) / np.maximum(np.linalg.norm(cross, axis=1), 1e-300)
    return rms(along * cosine), 1.0 - float(inside.mean())


def settled(measured: dict[str, tuple[float, float] | None]) -> bool:
    """True when the candidates not yet measured cannot change the choice: the last one
    scores at most ``TIE`` and every earlier one more than MARGIN above it (so none of
    them is close enough to be judged against it)."""
    *earlier, last = measured.values()
    if last is None or sum(last) > TIE:
        return False
    return all(m is None or sum(m) > sum(last) + MARGIN for m in earlier)


def judge(
    sample: np.ndarray, normals: dict[str, np.ndarray], totals: dict[str, float]
) -> tuple[str, dict[str, float | None]]:
    """The chosen label among the candidates scoring within MARGIN of the lowest, and the
    holdout RMS of each one judged: alone, it is chosen; several are judged by
    :func:`holdout` (those leaving too many points outside are not), and the lowest RMS
    wins, the earlier candidate within HOLDOUT_TIE of it. O(M log M) per candidate."""
    lowest = min(totals.values())
    close = [k for k, total in totals.items() if total <= lowest + MARGIN]
    if len(close) == 1:
        return close[0], {}
    judged = {
        k: holdout(sample, normals[k]) if len(sample) >= MIN_HOLDOUT_POINTS else None for k in close
    }
    valid = {k: m for k, m in judged.items() if m is not None}
    if not valid:
        # nothing measured (too few distinct points): no evidence against the least-squares
        # plane, the old default; else the score alone decides
        fallback = "best-fit" if "best-fit" in close else min(close, key=totals.__getitem__)
        return fallback, {k: None for k in close}
    fewest_outside = min(m[1] for m in valid.values())
    fair = {k: m[0] for k, m in valid.items() if m[1] <= fewest_outside + OUTSIDE_MARGIN}
    best = min(fair.values())
    chosen = next(k for k, rms in fair.items() if rms <= best * (1.0 + HOLDOUT_TIE))
    return chosen, {k: None if m is None else m[0] for k, m in judged.items()}


def choose_plane(points: np.ndarray, up: np.ndarray | None = None) -> PlaneChoice:
    """The candidate plane over which ``points`` are most a height field.

    ``points`` (N, 3) float64, checked; ``up`` (3,) float the direction recorded with the
    scan, or None. Every candidate is measured on at most ``SAMPLE`` points (seeded), so
    the choice is deterministic; O(S log S) per candidate, S = min(N, SAMPLE). Candidates
    are scored in order of preference and the rest skipped once :func:`settled` (a scan
    along its recorded up costs one quick triangulation; ``steep`` and ``unused`` list what
    was measured); those within ``MARGIN`` of the lowest score are then judged by
    :func:`judge` (``holdout``). When every candidate degenerates, the least-squares plane
    is returned (its projection then says what is wrong with the points).
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
    chosen, judged = "best-fit", {}
    if totals:
        chosen, judged = judge(sample, normals, totals)
    spec: PlaneSpec = chosen
    if chosen not in ("best-fit", *_AXES):
        spec = tuple(float(c) for c in normals[chosen])
    return PlaneChoice(
        chosen=chosen,
        spec=spec,
        steep={k: None if m is None else m[0] for k, m in measured.items()},
        unused={k: None if m is None else m[1] for k, m in measured.items()},
        normals={k: tuple(float(c) for c in v) for k, v in normals.items()},
        holdout=judged,
        sampled=len(sample),
    )


__all__ = [
    "PlaneChoice",
    "choose_plane",
    "candidates",
    "quick_faces",
    "score",
    "holdout",
    "judge",
    "settled",
    "SAMPLE",
    "TIE",
]
