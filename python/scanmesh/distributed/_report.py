"""The quality report of a mesh made in blocks: per-block sums, added up on the client.

tac is a property of a vertex's whole fan, so each block counts only the vertices whose
fans it holds entirely; a line shared by two strip partitions is counted once from the
faces of both sides (:func:`seam_sums`). Face figures (count, slivers, smallest angle) add
up block by block. The tac norms then follow from the sums: tac_1 = sum, tac_2 = sqrt of the
sum of squares, tac_inf = max (as :class:`scanmesh.Quality` defines them).
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Mapping

import numpy as np

from scanmesh import _core
from scanmesh.measures import SLIVER_ANGLE_DEG

#: Sums combined by max and by min; every other key is added.
BY_MAX: tuple[str, ...] = ("tac_inf",)
BY_MIN: tuple[str, ...] = ("min_angle_deg",)


def _tac_sums(tac: np.ndarray) -> dict[str, float]:
    t = tac[~np.isnan(tac)]
    return {
        "n_interior": float(len(t)),
        "tac_1": float(t.sum()),
        "tac_2_squared": float((t * t).sum()),
        "tac_inf": float(t.max(initial=0.0)),
    }


def vertex_sums(points: np.ndarray, faces: np.ndarray, counted: np.ndarray) -> dict[str, float]:
    """Sums of one block over (n, 3) ``points`` and (m, 3) local ``faces``: tac of the
    interior vertices where ``counted`` (n,) bool holds, and every face's figures. O(n + m)."""
    tac, min_angle = _core.mesh_quality(points, np.ascontiguousarray(faces, dtype=np.int64))
    degrees = np.degrees(min_angle)
    return {
        **_tac_sums(tac[counted]),
        "faces": float(len(faces)),
        "slivers": float(np.count_nonzero(degrees < SLIVER_ANGLE_DEG)),
        "min_angle_deg": float(degrees.min(initial=math.inf)),
    }


def seam_sums(vertices: np.ndarray, faces: np.ndarray, corners: np.ndarray) -> dict[str, float]:
    """tac sums of ``vertices`` (global indices) from every face touching them: (m, 3)
    global ``faces`` and their (m, 3, 3) ``corners``. O(m log m)."""
    ids, local = np.unique(faces.ravel(), return_inverse=True)
    positions = np.empty((len(ids), 3))
    positions[local] = corners.reshape(-1, 3)
    tac, _ = _core.mesh_quality(positions, local.reshape(-1, 3).astype(np.int64))
    return _tac_sums(tac[np.isin(ids, vertices)])


def combine(sums: Iterable[Mapping[str, float]]) -> dict[str, float]:
    """Per-block sums combined: max for :data:`BY_MAX`, min for :data:`BY_MIN`, else added."""
    out: dict[str, float] = {}
    for s in sums:
        for key, value in s.items():
            if key not in out:
                out[key] = value
            elif key in BY_MAX:
                out[key] = max(out[key], value)
            elif key in BY_MIN:
                out[key] = min(out[key], value)
            else:
                out[key] += value
    return out


def report(total: Mapping[str, float]) -> dict[str, float | int]:
    """The quality figures (as :meth:`scanmesh.Quality.as_dict`) from combined sums."""
    faces = int(total.get("faces", 0))
    return {
        "tac_1": total.get("tac_1", 0.0),
        "tac_2": math.sqrt(total.get("tac_2_squared", 0.0)),
        "tac_inf": total.get("tac_inf", 0.0),
        "n_interior": int(total.get("n_interior", 0)),
        "min_angle_deg": total.get("min_angle_deg", math.nan) if faces else math.nan,
        "sliver_fraction": total.get("slivers", 0.0) / faces if faces else 0.0,
    }
