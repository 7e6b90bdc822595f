"""NumPy ``.npy`` arrays and ``.npz`` archives of points, never unpickled.

Before numpy allocates an array, its header's shape and dtype are checked against the
bytes that hold it (the file for ``.npy``; for an ``.npz`` member, its size in the archive:
stored members byte for byte, deflated ones at most ``DEFLATE_RATIO`` times larger, the
most deflate can expand).
"""

from __future__ import annotations

import os
import zipfile
from pathlib import Path
from typing import IO, Any

import numpy as np

from scanmesh.errors import FileFormatError
from scanmesh.formats._source import check_declared, check_finite, check_regular
from scanmesh.formats.points import ScanPoints

#: Deflate expands at most about 1032:1; a member declaring more is corrupt.
DEFLATE_RATIO: int = 1032


def _checked_array(path: Path, handle: IO[bytes], available: int, name: str) -> np.ndarray:
    """Read one .npy stream after checking that its header's array fits ``available``."""
    fmt = np.lib.format
    try:
        version = fmt.read_magic(handle)
        if version == (1, 0):
            shape, _, dtype = fmt.read_array_header_1_0(handle)
        else:
            shape, _, dtype = fmt.read_array_header_2_0(handle)
    except ValueError as exc:
        raise FileFormatError(f"{path}: {name} is not a .npy array: {exc}") from None
    if dtype.hasobject:
        raise FileFormatError(
            f"{path}: the array holds Python objects, which are never unpickled; save"
            " numbers (float or int arrays) instead"
        )
    count = int(np.prod(shape, dtype=object))
    check_declared(path, count, max(dtype.itemsize, 1), available, f"values of {dtype} in {name}")
    handle.seek(0)
    return np.load(handle, allow_pickle=False)


def load_arrays(path: Path) -> dict[str, np.ndarray]:
    """The arrays of a .npy ("" key) or .npz file, every failure a FileFormatError."""
    try:
        return _load(path)
    except FileFormatError:
        raise
    except Exception as exc:  # truncated or corrupt: EOFError, OSError, zlib errors, ...
        raise FileFormatError(f"{path}: not a readable .npy/.npz file: {exc}") from None


def _load(path: Path) -> dict[str, np.ndarray]:
    """The arrays of a .npy ("" key) or .npz file."""
    size = check_regular(path)
    with open(path, "rb") as handle:
        magic = handle.read(6)
        handle.seek(0)
        if magic == b"\x93NUMPY":
            return {"": _checked_array(path, handle, size, "the array")}
    try:
        archive = zipfile.ZipFile(path)
    except zipfile.BadZipFile:
        raise FileFormatError(f"{path}: not a readable .npy/.npz file") from None
    arrays = {}
    with archive:
        for info in archive.infolist():
            name = info.filename.removesuffix(".npy")
            room = info.compress_size * (
                1 if info.compress_type == zipfile.ZIP_STORED else DEFLATE_RATIO
            )
            check_declared(path, info.file_size, 1, room, f"bytes in member {name!r}")
            with archive.open(info) as member:
                arrays[name] = _checked_array(path, member, info.file_size, f"member {name!r}")
    return arrays


def read_npy(path: str | os.PathLike) -> ScanPoints:
    """Read points from a ``.npy`` array or an ``.npz`` archive, never unpickling objects.

    ``.npy``: an (N, 3) array (x, y, z) or (N, 4) (x, y, z, line id), any real dtype, or a
    structured array with fields ``x``, ``y``, ``z`` (and ``line``). ``.npz``: arrays
    ``points`` (N, 3) and optionally ``line_ids`` (N,). A 2-D array of heights is read with
    ``scanmesh.read(path, grid=True)`` (:mod:`scanmesh.formats.grid`).

    Returns
    -------
    ScanPoints
        ``points`` (N, 3) float64, ``line_ids`` (N,) int64 or None.
    """
    path = Path(path)
    arrays = load_arrays(path)

    def numeric(arr: np.ndarray, name: str) -> np.ndarray:
        if arr.dtype.kind not in "iuf":
            raise FileFormatError(f"{path}: {name} must hold real numbers, got dtype {arr.dtype}")
        return arr

    line_ids: Any = None
    if "" in arrays:
        arr = arrays[""]
        if arr.dtype.names:
            missing = [c for c in "xyz" if c not in arr.dtype.names]
            if missing or arr.ndim != 1:
                raise FileFormatError(
                    f"{path}: structured array needs fields x, y, z in 1-D, has"
                    f" {arr.dtype.names} with shape {arr.shape}"
                )
            points = np.column_stack([numeric(arr[c], f"field {c!r}") for c in "xyz"])
            if "line" in arr.dtype.names:
                line_ids = numeric(arr["line"], "field 'line'")
        else:
            numeric(arr, "the array")
            if arr.ndim != 2 or arr.shape[1] not in (3, 4):
                hint = "; for a matrix of heights read it with grid=True" if arr.ndim == 2 else ""
                raise FileFormatError(
                    f"{path}: expected an (N, 3) or (N, 4) array, got shape {arr.shape}{hint}"
                )
            points = arr[:, :3]
            if arr.shape[1] == 4:
                line_ids = arr[:, 3]
    else:
        if "points" not in arrays:
            raise FileFormatError(
                f"{path}: the .npz archive needs an array named 'points', has {sorted(arrays)}"
            )
        points = numeric(arrays["points"], "'points'")
        if points.ndim != 2 or points.shape[1] != 3:
            raise FileFormatError(f"{path}: 'points' must be (N, 3), got shape {points.shape}")
        if "line_ids" in arrays:
            line_ids = numeric(arrays["line_ids"], "'line_ids'")
            if line_ids.ndim != 1 or len(line_ids) != len(points):
                raise FileFormatError(
                    f"{path}: 'line_ids' has shape {line_ids.shape}, but there are"
                    f" {len(points)} points: one line id per point is needed"
                )
    points = points.astype(np.float64)
    if not len(points):
        raise FileFormatError(f"{path}: the array holds no points (shape {points.shape})")
    check_finite(path, points, "row")
    if line_ids is not None:
        ids = np.asarray(line_ids)
        if ids.dtype.kind == "f":
            wrong = ~np.isfinite(ids) | (ids != np.round(ids)) | (np.abs(ids) >= 2**53)
            if wrong.any():
                row = int(np.flatnonzero(wrong)[0])
                raise FileFormatError(
                    f"{path}: row {row} has line id {float(ids[row])!r}, which is not an integer"
                    " below 2**53"
                )
        elif ids.dtype.kind == "u" and ids.size and int(ids.max()) >= 2**63:
            raise FileFormatError(f"{path}: line id {int(ids.max())} does not fit in int64")
        line_ids = ids.astype(np.int64)
    return ScanPoints(
        points=points,
        line_ids=line_ids,
        source=path,
        extra={"format": "npz" if "" not in arrays else "npy"},
    )
