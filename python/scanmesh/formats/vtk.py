"""Legacy VTK files (ASCII or BINARY; POLYDATA, UNSTRUCTURED_GRID, STRUCTURED_GRID): the
points, and the scan lines when the cells reveal them (see :func:`read_vtk`).

Every declared count (points, cells, cell types) is checked against the bytes left before
its block is read; ASCII numbers are parsed natively (``parse_free``).
"""

from __future__ import annotations

import os
import re
from pathlib import Path
from typing import Any

import numpy as np

from scanmesh.errors import FileFormatError
from scanmesh.formats._source import (
    check_declared,
    check_text,
    line_at,
    quote,
    read_bytes,
)
from scanmesh.formats.points import ScanPoints
from scanmesh.formats.table import parse_free

_VTK_TYPES = {
    "bit": None,
    "unsigned_char": "u1",
    "char": "i1",
    "unsigned_short": "u2",
    "short": "i2",
    "unsigned_int": "u4",
    "int": "i4",
    "unsigned_long": "u8",
    "long": "i8",
    "float": "f4",
    "double": "f8",
    "vtktypeint64": "i8",
    "vtktypeuint64": "u8",
    "vtktypeint32": "i4",
    "vtkidtype": "i8",
}
# VTK cell types: poly-lines and polygonal faces (for grid detection)
_VTK_LINE_TYPES = {3, 4}


class _VtkCursor:
    """A position in a legacy VTK file: keyword lines and ASCII or binary number blocks."""

    def __init__(self, path: Path, data: bytes, pos: int, binary: bool) -> None:
        self.path, self.data, self.pos, self.binary = path, data, pos, binary

    def line_no(self, pos: int | None = None) -> int:
        return self.data.count(b"\n", 0, self.pos if pos is None else pos) + 1

    def next_line(self) -> tuple[list[str], int] | None:
        """Tokens and line number of the next non-blank line, or None at the end."""
        data = self.data
        while self.pos < len(data):
            end = data.find(b"\n", self.pos)
            end = len(data) if end < 0 else end
            raw, start = data[self.pos : end], self.pos
            self.pos = end + 1
            if raw.strip():
                return raw.decode("latin-1").split(), self.line_no(start)
        return None

    def peek_word(self) -> str:
        save = self.pos
        got = self.next_line()
        self.pos = save
        return got[0][0].upper() if got else ""

    def numbers(self, count: int, vtk_type: str, what: str) -> np.ndarray:
        """The next ``count`` numbers of a data block."""
        kind = _VTK_TYPES.get(vtk_type.lower())
        if kind is None:
            raise FileFormatError(
                f"{self.path}, line {self.line_no()}: unsupported VTK data type {vtk_type!r}"
                f" for {what}"
            )
        check_declared(self.path, count, 0, 0, f"values for {what}")  # not negative
        if self.binary:
            dtype = np.dtype(">" + kind)
            need = count * dtype.itemsize
            if len(self.data) - self.pos < need:
                raise FileFormatError(
                    f"{self.path}: truncated VTK: {what} needs {need} bytes at offset"
                    f" {self.pos}, only {len(self.data) - self.pos} remain"
                )
            out = np.frombuffer(self.data, dtype=dtype, count=count, offset=self.pos)
            self.pos += need
            if self.data[self.pos : self.pos + 1] == b"\n":
                self.pos += 1
            return out
        if count == 0:
            return np.empty(0)
        left = len(self.data) - self.pos
        check_declared(self.path, count, 2, left, f"values for {what}", f", line {self.line_no()}")
        u = np.frombuffer(self.data, dtype=np.uint8, offset=self.pos)
        sep = np.isin(u, np.frombuffer(b" \t\r\n", dtype=np.uint8))
        starts_mask = ~sep
        starts_mask[1:] &= sep[:-1]
        starts = np.flatnonzero(starts_mask)
        if len(starts) < count:
            raise FileFormatError(
                f"{self.path}, line {self.line_no(len(self.data))}: truncated VTK: {what}"
                f" needs {count} values, the file ends after {len(starts)}"
            )
        a = self.pos + int(starts[0])
        nxt = np.flatnonzero(sep[int(starts[count - 1]) :])
        b = self.pos + int(starts[count - 1]) + (int(nxt[0]) if len(nxt) else len(u))
        values = parse_free(self.path, self.data, a, b, f" ({what})")
        if len(values) != count:  # a '#' among the numbers
            line, text = line_at(self.data, a)
            raise FileFormatError(
                f"{self.path}, line {line}: {what}: expected {count} numbers, found"
                f" {len(values)}: {quote(text)}"
            )
        self.pos = b
        if kind[0] in "iu" and (values != np.round(values)).any():
            i = int(np.flatnonzero(values != np.round(values))[0])
            raise FileFormatError(
                f"{self.path}: {what} must be integers, value {i} is {float(values[i])!r}"
            )
        return values.astype(kind) if kind[0] in "iu" else values

    def skip_metadata(self) -> None:
        """Skip a METADATA block (it ends at a blank line)."""
        match = re.compile(rb"\n[ \t\r]*\n").search(self.data, self.pos)
        self.pos = len(self.data) if match is None else match.end()


def _vtk_cells(cur: _VtkCursor, count: int, size: int, what: str) -> list[np.ndarray]:
    """Cells of a POLYGONS/LINES/CELLS block, in the legacy or the 5.x OFFSETS layout."""
    if cur.peek_word() == "OFFSETS":
        words, _ = cur.next_line()
        offsets = cur.numbers(
            count, words[1] if len(words) > 1 else "vtktypeint64", f"{what} offsets"
        ).astype(np.int64)
        words, _ = cur.next_line() or ([""], 0)
        if words[0].upper() != "CONNECTIVITY":
            raise FileFormatError(
                f"{cur.path}, line {cur.line_no()}: expected CONNECTIVITY after {what} OFFSETS"
            )
        conn = cur.numbers(
            size, words[1] if len(words) > 1 else "vtktypeint64", f"{what} connectivity"
        ).astype(np.int64)
        if len(offsets) and (
            offsets[0] != 0 or offsets[-1] != size or (np.diff(offsets) < 0).any()
        ):
            raise FileFormatError(f"{cur.path}: {what} offsets do not match the connectivity")
        return np.split(conn, offsets[1:-1]) if len(offsets) > 1 else []
    flat = cur.numbers(size, "int", what).astype(np.int64)
    if count == 0:
        return []
    k = int(flat[0])
    if k > 0 and size == count * (k + 1) and np.all(flat[:: k + 1] == k):
        return list(flat.reshape(count, k + 1)[:, 1:])  # all cells equally long
    cells, i = [], 0
    for _ in range(count):  # mixed cell sizes: one step per cell
        if i >= size or flat[i] < 0 or i + 1 + flat[i] > size:
            raise FileFormatError(
                f"{cur.path}: {what} block is inconsistent: cell {len(cells)} overruns the"
                f" declared size {size}"
            )
        cells.append(flat[i + 1 : i + 1 + flat[i]])
        i += 1 + int(flat[i])
    if i != size:
        raise FileFormatError(f"{cur.path}: {what} declares size {size}, the cells use {i}")
    return cells


def _equal_length_groups(cells: list[np.ndarray]) -> list[np.ndarray]:
    """Cells grouped by length, each group a (C, k) int64 array (cell order kept within)."""
    if not cells:
        return []
    lengths = np.fromiter((len(c) for c in cells), dtype=np.int64, count=len(cells))
    groups = []
    for k in np.unique(lengths):
        members = np.flatnonzero(lengths == k)
        groups.append(np.array([cells[i] for i in members], dtype=np.int64).reshape(-1, int(k)))
    return groups


def _grid_width(n: int, faces: list[np.ndarray], strips: list[np.ndarray]) -> int | None:
    """Width W when the face connectivity is a row-major grid of rows of W points, else None.

    Every edge must join points at most one row and one column apart (index difference 1,
    W - 1, W or W + 1 without wrapping around a row end), and both kinds of edge (along a
    row, between rows) must occur.
    """
    pairs = []
    for group in _equal_length_groups(faces):  # (C, k): each row a closed polygon
        if group.shape[1] >= 2:
            pairs.append(np.stack([group, np.roll(group, -1, axis=1)], axis=-1).reshape(-1, 2))
    for group in _equal_length_groups(strips):  # (C, k): each row a triangle strip
        if group.shape[1] >= 3:
            pairs.append(np.stack([group[:, :-1], group[:, 1:]], axis=-1).reshape(-1, 2))
            pairs.append(np.stack([group[:, :-2], group[:, 2:]], axis=-1).reshape(-1, 2))
    if not pairs:
        return None
    edges = np.concatenate(pairs)
    diffs = np.unique(np.abs(edges[:, 0] - edges[:, 1]))
    if len(diffs) > 4:  # a grid has at most 1, W - 1, W and W + 1
        return None
    for width in sorted({int(d) for d in diffs if d > 2} | {int(d) + 1 for d in diffs if d > 1}):
        if n % width or n // width < 2:
            continue
        rows, cols = edges // width, edges % width
        dr = np.abs(rows[:, 0] - rows[:, 1])
        dc = np.abs(cols[:, 0] - cols[:, 1])
        if (dr <= 1).all() and (dc <= 1).all() and (dr + dc > 0).all():
            if ((dr == 0) & (dc == 1)).any() and (dr == 1).any():
                return width
    return None


def read_vtk(path: str | os.PathLike) -> ScanPoints:
    """Read the points of a legacy VTK file (ASCII or BINARY; POLYDATA, UNSTRUCTURED_GRID or
    STRUCTURED_GRID), and its scan lines when the cells reveal them.

    Line ids, in order of preference, from:

    1. poly-line cells (``LINES``, or cell types 3/4) that cover every point exactly once:
       one line per cell;
    2. face cells (``POLYGONS``, ``TRIANGLE_STRIPS``, cell types 5-9) that form a row-major
       grid over the point order (every edge joins neighbours at most one row and one column
       apart; see ``_grid_width``): one line per grid row. A digitizer's range image meshed
       row to row looks like this, e.g. ``fran_cut.vtk``: 45 profiles x 49 points;
    3. ``STRUCTURED_GRID`` dimensions: one line per row of ``nx`` points.

    Otherwise ``line_ids`` is None. ``extra["line_ids_from"]`` says which rule applied.

    Returns
    -------
    ScanPoints
        ``points`` (N, 3) float64, ``line_ids`` (N,) int64 or None.
    """
    path = Path(path)
    data = read_bytes(path)
    if not data or data.isspace():
        raise FileFormatError(f"{path}: the file is empty; expected a legacy VTK file")
    if data.lstrip().startswith(b"<"):
        raise FileFormatError(
            f"{path}: XML VTK files (.vtp/.vtu) are not supported; save as legacy .vtk"
        )
    if not data.startswith(b"# vtk DataFile"):
        _, line1 = line_at(data, 0)
        raise FileFormatError(
            f"{path}, line 1: not a legacy VTK file (it must start with '# vtk DataFile'):"
            f" {quote(line1)}"
        )
    # line 1: version, line 2: title (free text), line 3: ASCII | BINARY
    first = data.find(b"\n")
    second = data.find(b"\n", first + 1)
    third = data.find(b"\n", second + 1)
    if min(first, second, third) < 0:
        raise FileFormatError(f"{path}: truncated VTK header")
    mode = data[second + 1 : third].strip().upper()
    if mode not in (b"ASCII", b"BINARY"):
        raise FileFormatError(f"{path}, line 3: expected ASCII or BINARY, found {quote(mode)}")
    binary = mode == b"BINARY"
    cur = _VtkCursor(path, data, third + 1, binary)
    if not binary:
        check_text(path, data, "an ASCII VTK file")
    got = cur.next_line()
    if not got or got[0][0].upper() != "DATASET" or len(got[0]) < 2:
        raise FileFormatError(f"{path}, line 4: expected 'DATASET <type>'")
    dataset = got[0][1].upper()
    if dataset not in ("POLYDATA", "UNSTRUCTURED_GRID", "STRUCTURED_GRID"):
        raise FileFormatError(
            f"{path}, line {got[1]}: VTK dataset {dataset} holds no point list; supported are"
            " POLYDATA, UNSTRUCTURED_GRID and STRUCTURED_GRID"
        )
    points = None
    lines: list[np.ndarray] = []
    faces: list[np.ndarray] = []
    strips: list[np.ndarray] = []
    cells: list[np.ndarray] = []
    cell_types = None
    dims = None
    while (got := cur.next_line()) is not None:
        words, no = got
        key = words[0].upper()
        try:
            if key == "POINTS":
                n = int(words[1])
                if n <= 0:
                    raise FileFormatError(f"{path}, line {no}: POINTS declares {n} points")
                flat = cur.numbers(3 * n, words[2], f"POINTS ({n} points)")
                points = flat.astype(np.float64).reshape(n, 3)
            elif key in ("VERTICES", "LINES", "POLYGONS", "TRIANGLE_STRIPS", "CELLS"):
                got_cells = _vtk_cells(cur, int(words[1]), int(words[2]), key)
                {
                    "VERTICES": [],
                    "LINES": lines,
                    "POLYGONS": faces,
                    "TRIANGLE_STRIPS": strips,
                    "CELLS": cells,
                }[key].extend(got_cells)
            elif key == "CELL_TYPES":
                cell_types = cur.numbers(int(words[1]), "int", "CELL_TYPES").astype(np.int64)
            elif key == "DIMENSIONS":
                dims = tuple(int(w) for w in words[1:4])
            elif key == "METADATA":
                cur.skip_metadata()
            elif key in ("POINT_DATA", "CELL_DATA", "FIELD"):
                break
            else:
                raise FileFormatError(
                    f"{path}, line {no}: unknown VTK keyword {words[0]!r}: {quote(' '.join(words))}"
                )
        except FileFormatError:
            raise
        except (IndexError, ValueError):
            raise FileFormatError(
                f"{path}, line {no}: malformed VTK line: {quote(' '.join(words))}"
            ) from None
    if points is None:
        raise FileFormatError(f"{path}: VTK file has no POINTS section")
    bad = ~np.isfinite(points)
    if bad.any():
        row, col = np.argwhere(bad)[0]
        raise FileFormatError(
            f"{path}: point {row} has a non-finite {'xyz'[col]}={float(points[row, col])!r}"
        )
    n = len(points)
    if cells:
        if cell_types is None or len(cell_types) != len(cells):
            raise FileFormatError(
                f"{path}: {len(cells)} CELLS need as many CELL_TYPES, found"
                f" {0 if cell_types is None else len(cell_types)}"
            )
        lines += [c for c, t in zip(cells, cell_types, strict=True) if t in _VTK_LINE_TYPES]
        faces += [c for c, t in zip(cells, cell_types, strict=True) if t in (5, 7, 9)]
        strips += [c for c, t in zip(cells, cell_types, strict=True) if t == 6]
        pixels = [c for c, t in zip(cells, cell_types, strict=True) if t == 8]
        if any(len(c) != 4 for c in pixels):
            raise FileFormatError(f"{path}: a VTK_PIXEL cell (type 8) must have 4 points")
        # VTK_PIXEL (8) orders its corners as a 2x2 grid: as a polygon it is 0 1 3 2
        faces += [c[[0, 1, 3, 2]] for c in pixels]
    # empty cells (VTK allows them) say nothing about lines or grids
    lines, faces, strips = ([c for c in group if len(c)] for group in (lines, faces, strips))
    used = np.concatenate([np.asarray(c, dtype=np.int64) for c in lines + faces + strips] or [[]])
    outside = used[(used < 0) | (used >= n)]
    if len(outside):
        raise FileFormatError(
            f"{path}: a cell refers to point {int(outside[0])}, outside 0..{n - 1}"
        )
    extra: dict[str, Any] = {"format": "vtk", "dataset": dataset, "encoding": mode.decode().lower()}
    line_ids = None
    if lines:
        members = np.concatenate([np.asarray(c, dtype=np.int64) for c in lines])
        cell_of = np.repeat(np.arange(len(lines)), [len(c) for c in lines])
        owner = np.full(n, -1, dtype=np.int64)
        owner[members] = cell_of
        if (np.bincount(members, minlength=n) == 1).all():
            line_ids = owner
            extra["line_ids_from"] = f"{len(lines)} poly-line cells"
    width = None
    if line_ids is None and (faces or strips):
        width = _grid_width(n, faces, strips)
        if width is not None:
            extra["line_ids_from"] = (
                f"face connectivity: a grid of {n // width} rows x {width} points"
            )
    if line_ids is None and width is None and dims is not None and dataset == "STRUCTURED_GRID":
        if dims[0] > 0 and n % dims[0] == 0:
            width = dims[0]
            extra["line_ids_from"] = f"STRUCTURED_GRID dimensions {dims}: rows of {width} points"
    grid = None
    if width is not None:  # a row-major grid: each row a line, kept as ScanPoints.grid
        line_ids = np.arange(n, dtype=np.int64) // width
        grid = np.arange(n, dtype=np.int64).reshape(-1, width)
    extra.setdefault("line_ids_from", None)
    return ScanPoints(points=points, line_ids=line_ids, source=path, extra=extra, grid=grid)
