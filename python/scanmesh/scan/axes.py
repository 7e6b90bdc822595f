"""Axes given by name ("x", "-y", "+Z") or as 3-vectors, and the scanning frame they span.

Frame: ``along`` (lines run this way), ``across = up x along`` (lines are stacked this way)
and ``up`` form a right-handed frame; seen from above, ``along`` points right and
``across`` points up the page, like x and y on a map.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike

from scanmesh.errors import ParameterError

#: An axis: "x", "+y", "-z" (any case), or a 3-vector.
AxisSpec = str | ArrayLike

_AXES = {"x": 0, "y": 1, "z": 2}


def parse_axis(spec: AxisSpec, name: str) -> np.ndarray:
    """Return an axis given as "x", "-y", "+Z" or a 3-vector as a (3,) float64 unit vector."""
    if isinstance(spec, str):
        text = spec.strip().lower()
        sign = 1.0
        if text[:1] in "+-" and text:
            sign = -1.0 if text[0] == "-" else 1.0
            text = text[1:]
        if text not in _AXES:
            raise ParameterError(
                f"{name} must be an axis name ('x', 'y', 'z', optionally signed like '-y') "
                f"or a 3-vector, got {spec!r}"
            )
        vec = np.zeros(3)
        vec[_AXES[text]] = sign
        return vec
    try:
        vec = np.asarray(spec, dtype=np.float64).ravel()
    except (TypeError, ValueError):
        raise ParameterError(f"{name} must be an axis name or a 3-vector, got {spec!r}") from None
    if vec.shape != (3,):
        raise ParameterError(f"{name} vector must have 3 components, got {vec.shape[0]}")
    length = float(np.linalg.norm(vec))
    if not np.all(np.isfinite(vec)) or length == 0.0:
        raise ParameterError(f"{name} vector must be finite and non-zero, got {vec.tolist()}")
    return vec / length


def scan_frame(up: AxisSpec = "z", along: AxisSpec = "x") -> np.ndarray:
    """The scanning frame as a (3, 3) float64 matrix with rows ``along``, ``across``, ``up``.

    ``along`` loses its component along ``up`` (so it need not be exactly perpendicular),
    but may not be parallel to it. For named axes the rows hold only 0 and +-1, so frame
    coordinates convert back to the model's without rounding.
    """
    u = parse_axis(up, "up")
    a = parse_axis(along, "along")
    a = a - np.dot(a, u) * u
    norm = float(np.linalg.norm(a))
    if norm < 1e-9:
        raise ParameterError(
            f"along ({along!r}) is parallel to up ({up!r}): scan lines need a direction "
            "across the scanning direction"
        )
    a = a / norm
    c = np.cross(u, a)
    return np.array([a, c, u])
