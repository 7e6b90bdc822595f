"""Height grids as scan points: a matrix of heights, each row one scan line.

Sources: a 2-D array (:func:`height_grid`), a text or CSV matrix or a ``.npy`` matrix read
with ``scanmesh.read(path, grid=True)`` (:func:`read_matrix`), and ESRI ASCII grids
(``.asc`` files whose header starts with ``ncols``; :func:`read_esri_ascii`). Row i, column j
of a matrix is the point ``(x0 + j * dx, y0 + i * dy, z[i, j])``; NaN cells (and an ESRI
grid's ``NODATA_value``) are holes, left out of the points and -1 in ``ScanPoints.grid``.
"""

from __future__ import annotations

import math
import os
import warnings
from pathlib import Path

import numpy as np
from numpy.typing import ArrayLike

from scanmesh._context import QUIET, Context
from scanmesh.errors import FileFormatError, ParameterError, ScanmeshWarning
from scanmesh.formats._source import check_declared, check_text, quote, read_bytes
from scanmesh.formats.npy import load_arrays
from scanmesh.formats.points import ScanPoints
from scanmesh.formats.table import parse_free, read_table

#: Cell size: one spacing for both directions, or (dx along a row, dy between rows).
Cell = float | tuple[float, float] | None

_ESRI_KEYS = ("ncols", "nrows", "xllcorner", "yllcorner", "xllcenter", "yllcenter")


def _cell(cell: Cell, default: tuple[float, float]) -> tuple[float, float]:
    """(dx, dy) from ``cell=``, checked, or ``default``."""
    if cell is None:
        return default
    try:
        pair = (float(cell), float(cell)) if np.ndim(cell) == 0 else tuple(map(float, cell))  # type: ignore[arg-type]
    except (TypeError, ValueError):
        pair = ()
    if len(pair) != 2 or not all(np.isfinite(v) and v > 0 for v in pair):
        raise ParameterError(
            f"cell must be a positive spacing or (dx, dy) of positive spacings, got {cell!r}"
        )
    return pair  # type: ignore[return-value]


def height_grid(
    heights: ArrayLike,
    *,
    cell: Cell = None,
    origin: tuple[float, float] = (0.0, 0.0),
    source: str | os.PathLike = "<array>",
    extra: dict | None = None,
) -> ScanPoints:
    """Scan points of a (R, C) matrix of heights: row i is scan line i, its points at
    ``(x0 + j * dx, y0 + i * dy)``; NaN cells are holes. ``cell`` is the spacing (default 1).

    Returns
    -------
    ScanPoints
        ``points`` (N, 3) float64 row by row, ``line_ids`` the row, ``grid`` (R, C).
    """
    z = np.asarray(heights)
    if z.ndim != 2 or z.dtype.kind not in "iuf" or min(z.shape) < 2:
        raise ParameterError(
            f"a height grid must be a 2-D real matrix of at least 2 x 2, got {z.dtype} {z.shape}"
        )
    z = z.astype(np.float64)
    if np.isinf(z).any():
        row, col = np.argwhere(np.isinf(z))[0]
        raise FileFormatError(f"{source}: height at row {row}, column {col} is infinite")
    dx, dy = _cell(cell, (1.0, 1.0))
    rows, cols = np.indices(z.shape)
    have = ~np.isnan(z)
    if not have.any():
        raise FileFormatError(f"{source}: every cell of the height grid is empty (NaN)")
    grid = np.full(z.shape, -1, dtype=np.int64)
    grid[have] = np.arange(int(have.sum()))
    points = np.column_stack([origin[0] + cols[have] * dx, origin[1] + rows[have] * dy, z[have]])
    info = {"format": "height grid", "cell": (dx, dy), "origin": tuple(origin)}
    info |= extra or {}
    info["line_ids_from"] = "grid rows"
    return ScanPoints(
        points=points,
        line_ids=rows[have].astype(np.int64),
        source=Path(source),
        extra=info,
        grid=grid,
    )


def read_matrix(
    path: str | os.PathLike, *, cell: Cell = None, context: Context = QUIET
) -> ScanPoints:
    """A matrix of heights from a ``.npy`` array or a text/CSV table (header lines allowed,
    e.g. R's ``V1,...,V61``), as in :func:`height_grid`. Such a file records no cell size:
    without ``cell`` a ``ScanmeshWarning`` says that cells of 1 are assumed."""
    path = Path(path)
    if cell is None:
        warnings.warn(
            f"{path.name}: a matrix of heights records no cell size; read with cells of 1"
            " (x and y are column and row numbers): give cell= (the spacing, or (dx, dy))"
            " for the scan's true size",
            ScanmeshWarning,
            stacklevel=3,
        )
    if path.suffix.lower() in (".npy", ".npz"):
        arrays = load_arrays(path)
        if len(arrays) != 1:
            raise FileFormatError(
                f"{path}: a height grid needs one array, the archive has {sorted(arrays)}"
            )
        z = next(iter(arrays.values()))
        if z.dtype.kind not in "iuf":
            raise FileFormatError(f"{path}: heights must be real numbers, got dtype {z.dtype}")
        return height_grid(z, cell=cell, source=path, extra={"format": "npy height grid"})
    data = read_bytes(path)
    table = read_table(path, data, "rows of heights", context)
    return height_grid(table.values, cell=cell, source=path, extra={"format": "text height grid"})


def is_esri_ascii(data: bytes) -> bool:
    """True when ``data`` opens with an ESRI ASCII grid header keyword."""
    first = data[:64].lstrip().split(None, 1)
    return bool(first) and first[0].lower().decode("latin-1") in _ESRI_KEYS


def read_esri_ascii(path: str | os.PathLike, *, cell: Cell = None) -> ScanPoints:
    """Read an ESRI ASCII grid (``ncols``, ``nrows``, ``xllcorner``/``xllcenter``,
    ``yllcorner``/``yllcenter``, ``cellsize`` (or ``dx``/``dy``), optional ``NODATA_value``,
    then ``nrows`` rows of ``ncols`` heights, the first row northernmost).

    Each grid row is a scan line; ``cell`` overrides the header's cell size. Points are cell
    centres: ``x = xll + (j + 1/2) dx`` for a corner reference, ``x = xll + j dx`` for a
    centre one, and likewise y, which decreases down the rows.

    Returns
    -------
    ScanPoints
        ``points`` (N, 3) float64, ``line_ids`` the row (0 = first, northernmost) and
        ``grid`` (nrows, ncols) of point indices, -1 at NODATA.
    """
    path = Path(path)
    data = read_bytes(path)
    check_text(path, data, "an ESRI ASCII grid")
    head: dict[str, float] = {}
    head_lines: dict[str, int] = {}  # the line of each header keyword, for messages
    pos, line = 0, 1
    while True:
        end = data.find(b"\n", pos)
        end = len(data) if end < 0 else end
        words = data[pos:end].split()
        if not words:
            if end >= len(data):
                break
        elif words[0][:1].isalpha() and words[0].lower() != b"nan":
            key = words[0].decode("latin-1").lower()
            try:
                head[key] = float(words[1])
                head_lines[key] = line
            except (IndexError, ValueError):
                raise FileFormatError(
                    f"{path}, line {line}: bad ESRI grid header line: {quote(data[pos:end])}"
                ) from None
        else:
            break
        pos, line = end + 1, line + 1
    missing = [k for k in ("ncols", "nrows") if k not in head]
    if missing:
        raise FileFormatError(f"{path}: ESRI grid header lacks {' and '.join(missing)}")
    ncols, nrows = int(head["ncols"]), int(head["nrows"])
    if ncols != head["ncols"] or nrows != head["nrows"] or ncols < 2 or nrows < 2:
        raise FileFormatError(
            f"{path}: ESRI grid header gives {head['nrows']} rows x {head['ncols']} columns;"
            " need whole numbers of at least 2"
        )
    check_declared(path, ncols * nrows, 2, len(data) - pos, "grid cells", f", line {line}")
    if "cellsize" in head:
        default = (head["cellsize"], head["cellsize"])
    elif "dx" in head and "dy" in head:
        default = (head["dx"], head["dy"])
    elif cell is None:
        raise FileFormatError(
            f"{path}: ESRI grid header gives no cellsize (nor dx, dy); pass cell="
        )
    else:
        default = (1.0, 1.0)
    if cell is None:
        for key in ("cellsize", "dx", "dy"):
            value = head.get(key)
            if key in head_lines and not (value is not None and 0 < value < math.inf):
                raise FileFormatError(
                    f"{path}, line {head_lines[key]}: ESRI grid header gives {key} {value!r};"
                    f" {key} must be a positive finite spacing"
                )
    dx, dy = _cell(cell if cell is not None else default, (1.0, 1.0))
    values = parse_free(path, data, pos, len(data), " in the ESRI grid")
    if len(values) != ncols * nrows:
        raise FileFormatError(
            f"{path}: the ESRI grid header declares {nrows} x {ncols} = {nrows * ncols}"
            f" heights, the file holds {len(values)}"
        )
    z = values.reshape(nrows, ncols)
    if "nodata_value" in head:
        z = np.where(z == head["nodata_value"], np.nan, z)
    centre = "xllcenter" in head
    x0 = head.get("xllcenter", head.get("xllcorner", 0.0)) + (0 if centre else dx / 2)
    ytop = head.get("yllcenter", head.get("yllcorner", 0.0)) + (0 if centre else dy / 2)
    ytop += (nrows - 1) * dy
    return _esri_points(z, dx, dy, x0, ytop, path, head)


def _esri_points(
    z: np.ndarray, dx: float, dy: float, x0: float, ytop: float, path: Path, head: dict
) -> ScanPoints:
    """ScanPoints of an ESRI grid whose first row lies at ``ytop``, rows going south."""
    sp = height_grid(
        z, cell=(dx, dy), source=path, extra={"format": "esri ascii grid", "header": head}
    )
    pts = sp.points.copy()
    pts[:, 0] += x0
    pts[:, 1] = ytop - pts[:, 1]
    return ScanPoints(points=pts, line_ids=sp.line_ids, source=path, extra=sp.extra, grid=sp.grid)
