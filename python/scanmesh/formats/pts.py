"""PTS (Leica, CloudCompare): text rows ``x y z [intensity] [r g b]`` under a point count.

A PTS file holds one or more scans, each a line with its point count followed by that many
rows; a file without the count line is one scan. Rows hold 3 (x y z), 4 (x y z intensity),
6 (x y z r g b) or 7 (x y z intensity r g b) numbers, the same in every scan. Intensity is
kept as ``point_data["intensity"]`` (float32), colours as uint8 ``red``, ``green``,
``blue`` (0..255 integers, else refused). PTS gives no scan lines: they are detected.
"""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np

from scanmesh._context import QUIET, Context
from scanmesh.errors import FileFormatError
from scanmesh.formats._source import check_finite, check_text, line_at, quote, read_bytes
from scanmesh.formats.points import ScanPoints
from scanmesh.formats.table import parse_rows, skip_lines

#: Row widths a PTS file may have -> the names of the columns after x, y, z.
COLUMNS: dict[int, tuple[str, ...]] = {
    3: (),
    4: ("intensity",),
    6: ("red", "green", "blue"),
    7: ("intensity", "red", "green", "blue"),
}


def _next_line(data: bytes, pos: int) -> tuple[int, int]:
    """The start of the first non-blank line at or after ``pos`` and its end (exclusive of
    the line end); ``(len(data), len(data))`` when none is left."""
    while pos < len(data):
        end = data.find(b"\n", pos)
        end = len(data) if end < 0 else end
        if data[pos:end].strip():
            return pos, end
        pos = end + 1
    return len(data), len(data)


def read_pts(path: str | os.PathLike, *, context: Context = QUIET) -> ScanPoints:
    """Read a PTS point file (gzip-compressed too), every scan in it, in file order.

    O(file size); the rows are parsed natively (:mod:`scanmesh.formats.table`).

    Returns
    -------
    ScanPoints
        ``points`` (N, 3) float64; ``line_ids`` None; ``point_data`` with ``intensity``
        and ``red``/``green``/``blue`` when the rows hold them; ``extra["scan_starts"]``:
        the index of each scan's first point.
    """
    path = Path(path)
    data = read_bytes(path)
    check_text(path, data, "a PTS file")
    blocks: list[np.ndarray] = []
    starts: list[int] = []
    width = None
    pos, n = 0, 0
    with context.stage("read", len(data)) as stage:
        while True:
            pos, end = _next_line(data, pos)
            if pos >= len(data):
                break
            line_no, text = line_at(data, pos)
            words = text.split()
            if len(words) == 1:  # a scan's point count
                try:
                    count = int(words[0])
                except ValueError:
                    count = -1
                if count < 0:
                    raise FileFormatError(
                        f"{path}, line {line_no}: expected a point count or a row of 3, 4, 6"
                        f" or 7 numbers: {quote(text)}"
                    )
                pos, line_no = min(end + 1, len(data)), line_no + 1
                stop = skip_lines(path, data, pos, count, f"the point count on line {line_no - 1}")
            else:  # no count: the rest of the file is one scan
                stop = len(data)
            first, first_end = pos, data.find(b"\n", pos)
            row = data[first : len(data) if first_end < 0 else first_end].split()
            if stop == pos:
                continue  # a scan of 0 points
            if width is None:
                width = len(row)
                if width not in COLUMNS:
                    raise FileFormatError(
                        f"{path}, line {line_no}: a PTS row holds 3 (x y z), 4 (x y z"
                        f" intensity), 6 (x y z r g b) or 7 (x y z intensity r g b) numbers,"
                        f" found {width}: {quote(data[first:first_end])}"
                    )
            rows = parse_rows(path, data, pos, stop, width, None, line_no, f"{width} values", stage)
            starts.append(n)
            n += len(rows.values)
            blocks.append(rows.values)
            pos = stop
    if not n or width is None:
        raise FileFormatError(f"{path}: the PTS file holds no points")
    table = np.concatenate(blocks) if len(blocks) > 1 else blocks[0]
    check_finite(path, table[:, :3])
    point_data: dict[str, np.ndarray] = {}
    for k, name in enumerate(COLUMNS[width], start=3):
        column = table[:, k]
        if name == "intensity":
            point_data[name] = column.astype(np.float32)
            continue
        bad = np.flatnonzero((column < 0) | (column > 255) | (column != np.rint(column)))
        if len(bad):
            raise FileFormatError(
                f"{path}: point {int(bad[0])} has {name}={float(column[bad[0]])!r}; PTS colours are"
                " integers 0..255"
            )
        point_data[name] = column.astype(np.uint8)
    return ScanPoints(
        points=np.ascontiguousarray(table[:, :3]),
        line_ids=None,
        source=path,
        extra={"format": "pts", "scan_starts": starts, "line_ids_from": None},
        point_data=point_data,
    )
