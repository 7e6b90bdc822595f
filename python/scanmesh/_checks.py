"""Input checks shared by every public function: shapes, dtypes and finite values."""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike

from scanmesh.errors import DegenerateInputError, InvalidMeshError, ScanmeshError


def as_points(points: ArrayLike, name: str = "points") -> np.ndarray:
    """Return ``points`` as a C-contiguous (N, 3) float64 array, or raise naming the problem.

    Accepts any real dtype (integers, float32, ...) and any memory layout.
    """
    try:
        arr = np.asarray(points)
    except (ValueError, TypeError) as exc:
        raise ScanmeshError(f"{name} cannot be read as an array: {exc}") from None
    if arr.dtype == object or not (
        np.issubdtype(arr.dtype, np.number) or np.issubdtype(arr.dtype, np.bool_)
    ):
        raise ScanmeshError(f"{name} must hold real numbers, got dtype {arr.dtype}")
    if np.issubdtype(arr.dtype, np.complexfloating):
        raise ScanmeshError(f"{name} must hold real numbers, got dtype {arr.dtype}")
    if arr.ndim != 2 or arr.shape[1] != 3:
        raise ScanmeshError(f"{name} must have shape (N, 3), got {arr.shape}")
    arr = np.ascontiguousarray(arr, dtype=np.float64)
    bad = ~np.isfinite(arr)
    if bad.any():
        row, col = np.argwhere(bad)[0]
        raise DegenerateInputError(
            f"{name}[{row}] has a non-finite coordinate {'xyz'[col]}={arr[row, col]!r}"
            f" ({int(bad.any(axis=1).sum())} such point(s) in all)"
        )
    if len(arr) < 3:
        raise DegenerateInputError(f"need at least 3 points to triangulate, got {len(arr)}")
    return arr


def as_faces(faces: ArrayLike, n_vertices: int) -> np.ndarray:
    """Return ``faces`` as a C-contiguous (M, 3) int64 array of valid vertex indices."""
    arr = np.asarray(faces)
    if arr.ndim != 2 or arr.shape[1] != 3:
        raise InvalidMeshError(f"faces must have shape (M, 3), got {arr.shape}")
    if arr.size and not np.issubdtype(arr.dtype, np.integer):
        if not np.issubdtype(arr.dtype, np.floating) or not np.all(arr == np.round(arr)):
            raise InvalidMeshError(f"faces must hold integer vertex indices, got dtype {arr.dtype}")
    arr = np.ascontiguousarray(arr, dtype=np.int64)
    if arr.size and (arr.min() < 0 or arr.max() >= n_vertices):
        row = int(np.argwhere((arr < 0) | (arr >= n_vertices))[0, 0])
        raise InvalidMeshError(
            f"face {row} {arr[row].tolist()} refers to a vertex outside 0..{n_vertices - 1}"
        )
    return arr
