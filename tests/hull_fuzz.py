"""Untrimmed meshes against the convex hull, in exact arithmetic: the property behind
tests/test_hull_coverage.py (a bounded number of hypothesis examples in CI) and
benches/hull_fuzz.py (the long run over seeded inputs).

With ``max_edge=math.inf`` nothing is trimmed: the faces of ``delaunay``, ``lop`` and
``anneal`` must tile the convex hull of the distinct points, near-duplicates (points
1e-12..1e-7 of the extent apart) included. Checked on the float coordinates of
``surface.scan.uv`` (every float is a Fraction exactly): every face strictly
counter-clockwise, the face areas summing to the hull's area, every hull vertex a vertex of
some face unless it is a reported duplicate.
"""

from __future__ import annotations

import math
import warnings
from fractions import Fraction
from typing import Any

import numpy as np

import scanmesh

#: Per method: keywords that keep a call short.
OPTIONS = {
    "delaunay": {},
    "lop": {},
    # two chains, not the automatic 128 of a small input: chains restart the same walk,
    # each flipping interior edges only, and 128 made a case 0.24 s instead of 0.02 s
    "anneal": {"sweeps": 3, "seed": 0, "chains": 2},
}


def _orient(a, b, c) -> Fraction:
    return (b[0] - a[0]) * (c[1] - a[1]) - (b[1] - a[1]) * (c[0] - a[0])


def exact_hull(points: list[tuple[Fraction, Fraction]]) -> list[tuple[Fraction, Fraction]]:
    """The convex hull's vertices (no collinear ones), counter-clockwise: monotone chain."""
    pts = sorted(set(points))
    if len(pts) < 3:
        return pts

    def chain(seq):
        out: list[tuple[Fraction, Fraction]] = []
        for p in seq:
            while len(out) >= 2 and _orient(out[-2], out[-1], p) <= 0:
                out.pop()
            out.append(p)
        return out

    lower, upper = chain(pts), chain(pts[::-1])
    return lower[:-1] + upper[:-1]


def hull_faults(surface: scanmesh.Surface) -> list[str]:
    """What keeps the faces from covering the hull of the non-duplicate points exactly."""
    uv = [(Fraction(float(u)), Fraction(float(v))) for u, v in surface.scan.uv]
    duplicates = {int(i) for i in surface.duplicates[:, 0]}
    hull = exact_hull([p for i, p in enumerate(uv) if i not in duplicates])
    hull_area = sum(_orient(hull[0], hull[i], hull[i + 1]) for i in range(1, len(hull) - 1))
    areas = [_orient(uv[a], uv[b], uv[c]) for a, b, c in surface.faces.tolist()]
    faults = []
    if not all(a > 0 for a in areas):
        faults.append(f"{sum(a <= 0 for a in areas)} faces not counter-clockwise")
    if sum(areas) != hull_area:
        faults.append(f"faces cover {float(sum(areas) / hull_area):.9f} of the hull")
    corners = {uv[v] for v in surface.faces.ravel().tolist()}
    missing = [p for p in hull if p not in corners]
    if missing:
        faults.append(f"{len(missing)} hull vertices in no face")
    return faults


def untrimmed(points: np.ndarray, method: str) -> scanmesh.Surface:
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", scanmesh.ScanmeshWarning)
        return scanmesh.reconstruct(points, method, plane="z", max_edge=math.inf, **OPTIONS[method])


def with_near_duplicates(
    n: int, seed: int, copies: int, exponent: float, origin: float
) -> np.ndarray:
    """n random points in [origin, origin + 1]² (scaled by 1e3), then `copies` of them
    repeated 10**exponent of the extent away in a random direction."""
    rng = np.random.default_rng(seed)
    xy = rng.random((n, 2))
    src = rng.integers(0, n, size=copies)
    angle = rng.random(copies) * 2 * np.pi
    offset = 10.0**exponent * np.column_stack([np.cos(angle), np.sin(angle)])
    xy = np.vstack([xy, xy[src] + offset])
    xy = (xy + origin) * 1e3
    order = rng.permutation(len(xy))
    z = 0.3 * np.sin(6 * xy[:, 0] / 1e3) * np.cos(4 * xy[:, 1] / 1e3)
    return np.column_stack([xy, z])[order]


#: The ranges inputs are drawn from (the hypothesis strategies of the test, and
#: :func:`case_of` for the long run): points, copies 10**exponent of the extent away, the
#: square's origin (x 1e3).
N_POINTS = (4, 40)
COPIES = (1, 8)
EXPONENTS = (-12.0, -7.0)
ORIGINS = (0.0, 1e3)


def case_of(seed: int) -> dict[str, Any]:
    """The input of long-run case ``seed``: keywords of :func:`with_near_duplicates`."""
    rng = np.random.default_rng(seed)
    return {
        "n": int(rng.integers(N_POINTS[0], N_POINTS[1] + 1)),
        "seed": int(rng.integers(0, 2**32)),
        "copies": int(rng.integers(COPIES[0], COPIES[1] + 1)),
        "exponent": float(rng.uniform(*EXPONENTS)),
        "origin": float(ORIGINS[rng.integers(len(ORIGINS))]),
    }


def faults_of(points: np.ndarray, method: str) -> list[str]:
    """What keeps ``method``'s untrimmed mesh of ``points`` from covering their hull
    exactly (points trimmed count too); empty when it does."""
    surface = untrimmed(points, method)
    trimmed = len(surface.options["trimmed"])
    return ([f"{trimmed} points trimmed"] if trimmed else []) + hull_faults(surface)
