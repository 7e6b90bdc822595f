"""XYZ and CSV point files: rows of x, y, z and maybe a line id or other columns.

Which columns hold what, in order of preference:

1. ``columns=`` (``--columns``): a string naming the file's columns in order, e.g.
   ``"x,y,z,line"`` or ``"x y z intensity"`` (names other than x, y, z and a line-id name
   are columns to skip), or 3-4 integers: the 0-based columns of x, y, z and the line id;
2. a header row naming ``x``, ``y``, ``z`` (and a line id, see ``LINE_COLUMN_NAMES``) in as
   many fields as the data: the columns by name, others ignored;
3. otherwise the first three columns are x, y, z. A 4th is the line id only when it is one
   (integers below 2**53, each value in one run of consecutive rows, as scan lines are
   written, two or more rows per value on average); anything else there (an intensity, a
   time) is ignored and recorded in ``extra["ignored_columns"]``. Five or more unnamed
   columns are refused: name them.

Without a line-id column, blank lines separate scan lines. A comment ``# scanmesh up x y z``
above the data records the digitizer's up direction (``ScanPoints.up``).
"""

from __future__ import annotations

import os
import re
from collections.abc import Iterator, Sequence
from pathlib import Path
from typing import Any

import numpy as np

from scanmesh._context import QUIET, Context
from scanmesh.errors import FileFormatError, ParameterError
from scanmesh.formats._source import quote, read_bytes
from scanmesh.formats.points import ScanPoints
from scanmesh.formats.table import Table, read_head, read_table, row_error

#: Header names accepted for the line-id column of text files (lower case).
LINE_COLUMN_NAMES = (
    "line",
    "line_id",
    "lineid",
    "line_ids",
    "scan_line",
    "scanline",
    "scan_line_id",
)

#: Columns given as ``columns=``: a string of names in file order, or integer positions.
Columns = str | Sequence[int] | None

_UP = re.compile(r"scanmesh\s+up\s+(\S+)\s+(\S+)\s+(\S+)\s*$", re.IGNORECASE)


def up_comment(up: np.ndarray) -> str:
    """The comment line (with its ``#`` and line end) that records a digitizer's ``up``."""
    return "# scanmesh up {:.17g} {:.17g} {:.17g}\n".format(*np.asarray(up, dtype=float))


def parse_up(path: Path, comments: list[str]) -> np.ndarray | None:
    """The ``up`` vector of a ``scanmesh up x y z`` comment, or None."""
    for text in comments:
        match = _UP.match(text)
        if match:
            try:
                up = np.array([float(v) for v in match.groups()])
            except ValueError:
                up = np.zeros(3)
            if not np.isfinite(up).all() or not up.any():
                raise FileFormatError(f"{path}: bad up direction in the comment {quote(text)}")
            return up
    return None


def _given_columns(path: Path, columns: Columns, ncols: int) -> dict[str, int]:
    """Roles from ``columns=`` (see the module doc), checked against ``ncols`` columns."""
    if isinstance(columns, str) and re.fullmatch(r"[\d,;\s]+", columns):
        columns = [int(c) for c in re.split(r"[,;\s]+", columns.strip())]  # "0,1,2,4"
    if isinstance(columns, str):
        names = [w.strip().lower() for w in re.split(r"[,;\s]+", columns.strip()) if w.strip()]
        if len(names) > ncols:
            raise FileFormatError(
                f"{path}: columns={columns!r} names {len(names)} columns, the file has {ncols}"
            )
        found: dict[str, int] = {}
        for i, name in enumerate(names):
            role = "line" if name in LINE_COLUMN_NAMES else name
            if role in ("x", "y", "z", "line"):
                if role in found:
                    raise ParameterError(f"columns={columns!r} names {role!r} twice")
                found[role] = i
        if not {"x", "y", "z"} <= set(found):
            raise ParameterError(
                f"columns={columns!r} must name x, y and z (and may name line), in file order"
            )
        return found
    try:
        idx = [int(c) for c in columns]  # type: ignore[union-attr]
        ok = all(int(c) == c and not isinstance(c, bool) for c in columns)  # type: ignore[union-attr]
    except (TypeError, ValueError):
        idx, ok = [], False
    if not ok or len(idx) not in (3, 4) or len(set(idx)) != len(idx):
        raise ParameterError(
            f"columns must be a string of names in file order (e.g. 'x,y,z,line') or 3-4"
            f" distinct column indices for x, y, z[, line], got {columns!r}"
        )
    if min(idx) < 0 or max(idx) >= ncols:
        raise FileFormatError(
            f"{path}: columns={list(idx)} refers to a column outside 0..{ncols - 1}"
        )
    return dict(zip(("x", "y", "z", "line"), idx, strict=False))


def _named_columns(header: str, delimiter: str | None, ncols: int) -> dict[str, int] | None:
    """Column indices of x, y, z (and line) named in a header row, or None if it names none."""
    fields = header.split(delimiter) if delimiter else header.split()
    names = [name.strip().strip("\"'").strip().lower() for name in fields]
    if len(names) != ncols or not {"x", "y", "z"} <= set(names):
        return None
    found = {key: names.index(key) for key in ("x", "y", "z")}
    for name in LINE_COLUMN_NAMES:
        if name in names:
            found["line"] = names.index(name)
            break
    return found


def _integer_ids(ids: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(N,) float ``ids`` cast to int64, and the mask of the values that are not integers
    below 2**53 in magnitude (a value the cast does not give back exactly is a fraction,
    NaN or infinite: their casts are garbage, hence errstate; one pass fewer than round())."""
    with np.errstate(invalid="ignore"):
        as_int = ids.astype(np.int64)
    bad = (as_int != ids) | (as_int >= 2**53) | (as_int <= -(2**53))
    return as_int, bad


def _line_ids_or_none(ids: np.ndarray) -> np.ndarray | None:
    """``ids`` as int64 when they look like scan-line ids (integers below 2**53, each value
    in one run of rows, the runs two rows long or more on average), else None. O(N): only
    the runs' values are sorted to count the distinct ones."""
    if not len(ids):
        return None
    as_int, bad = _integer_ids(ids)
    if bad.any():
        return None
    opens = np.flatnonzero(as_int[1:] != as_int[:-1]) + 1
    runs = 1 + len(opens)
    distinct = len(np.unique(np.concatenate((as_int[:1], as_int[opens]))))
    return as_int if runs == distinct and 2 * runs <= len(ids) else None


def _line_column(path: Path, data: bytes, table: Table, ids: np.ndarray, col: int) -> np.ndarray:
    """The line-id column ``ids`` (file column ``col``) as int64, raising on the first value
    that is not an integer."""
    as_int, bad = _integer_ids(ids)
    if bad.any():
        row = int(np.flatnonzero(bad)[0])
        what = "is not below 2**53" if np.abs(ids[row]) >= 2**53 else "is not an integer"
        raise row_error(
            path, data, table, row, f"line id {float(ids[row])!r} in column {col + 1} {what}"
        )
    return as_int


def _points(
    path: Path,
    data: bytes,
    table: Table,
    columns: dict[str, int],
    extra: dict,
    line_ids: np.ndarray | None = None,
) -> ScanPoints:
    """ScanPoints from a table parsed with x, y, z as its ``values`` and the other columns as
    its ``rest``, the columns holding x, y, z and the line id, and the line ids when they
    were found already."""
    points = table.values
    if not np.isfinite(points).all():
        bad = ~np.isfinite(points)
        row, col = np.argwhere(bad)[0]
        raise row_error(
            path, data, table, int(row), f"non-finite {'xyz'[col]}={float(points[row, col])!r}"
        )
    extra |= {"header": table.header, "columns": columns}
    if "line" in columns:
        if line_ids is None:
            col = columns["line"]
            others = sorted(set(range(table.head.ncols)) - {columns[k] for k in "xyz"})
            line_ids = _line_column(path, data, table, table.rest[:, others.index(col)], col)
        extra["line_ids_from"] = f"column {columns['line'] + 1}"
    elif len(table.block_starts):
        line_ids = table.blocks()
        extra["line_ids_from"] = "blank lines"
    else:
        extra["line_ids_from"] = None
    return ScanPoints(
        points=points,
        line_ids=line_ids,
        source=path,
        extra=extra,
        up=parse_up(path, table.comments),
    )


def read_points_table(
    path: str | os.PathLike,
    fmt: str,
    *,
    columns: Columns = None,
    decimal: str = ".",
    context: Context = QUIET,
) -> ScanPoints:
    """Read a text file of points (``fmt`` "xyz" or "csv"; see the module doc for columns;
    ``decimal``: the decimal mark, "." or ",").

    The columns are chosen from the head (``columns=``, a header naming them, or the first
    three) before the rows are parsed, so x, y, z go straight into the (N, 3) points."""
    if decimal not in (".", ","):
        raise ParameterError(f"decimal must be '.' or ',' (--decimal), got {decimal!r}")
    path = Path(path)
    data = read_bytes(path)
    if decimal == ",":
        data = _decimal_commas(path, data)
    what = "x y z rows" if fmt == "xyz" else "comma-separated x,y,z rows"
    head = read_head(path, data, what)
    ncols = head.ncols
    extra: dict[str, Any] = {"format": fmt, "delimiter": head.delimiter}
    named = _named_columns(head.header[-1], head.delimiter, ncols) if head.header else None
    chosen: dict[str, int] | None = None
    if columns is not None:
        chosen = _given_columns(path, columns, ncols)
    elif named is not None:
        chosen = named
    elif ncols in (3, 4) and not (head.header and fmt == "csv"):
        chosen = {"x": 0, "y": 1, "z": 2}
    split = None if chosen is None else [chosen["x"], chosen["y"], chosen["z"]]
    table = read_table(path, data, what, context, head, split)
    if chosen is None and head.header and fmt == "csv":
        raise FileFormatError(
            f"{path}, line {head.header_lines[-1]}: the header"
            f" {quote(head.header[-1])} must name columns x, y and z in {ncols} fields"
            f" (as many as the data on line {table.row_lines[0]}), or choose them with"
            " columns= (e.g. columns='x,y,z,line')"
        )
    if chosen is None:
        raise row_error(
            path,
            data,
            table,
            0,
            f"expected 3 values (x y z) or 4 (x y z line_id), found {ncols}; name the columns"
            " with columns= (e.g. 'x,y,z,intensity') or a header row, or read a matrix of"
            " heights with grid=True",
        )
    line_ids = None
    if columns is None and named is None and ncols == 4:
        line_ids = _line_ids_or_none(table.rest[:, 0])
        if line_ids is not None:
            chosen["line"] = 3
        else:
            extra["ignored_columns"] = [3]
    if "ignored_columns" not in extra:
        extra["ignored_columns"] = sorted(set(range(ncols)) - set(chosen.values()))
    return _points(path, data, table, chosen, extra, line_ids)


def _decimal_commas(path: Path, data: bytes) -> bytes:
    """``data`` with its decimal commas as points; refused (FileFormatError naming the
    line) when commas also separate the values: the first row of numbers holding a comma
    must also have a semicolon, tab or space between numbers (``x,y,z`` rows are comma-separated,
    not decimal commas). O(size)."""
    pos, no = 0, 1
    while pos < len(data):
        end = data.find(b"\n", pos)
        end = len(data) if end < 0 else end
        line = data[pos:end]
        text = line.strip()
        if b"," in text and text[:1] in b"+-.0123456789":  # a row of numbers
            if not re.search(rb"\d[;\t ]+[-+.,\d]", text):
                raise FileFormatError(
                    f"{path}, line {no}: {quote(line)} has commas but no other separator:"
                    " with decimal=',' (--decimal ,) values must be separated by semicolons,"
                    " tabs or spaces"
                )
            break  # the first such line decides; the parser checks every row
        pos, no = end + 1, no + 1
    return data.replace(b",", b".")


def read_xyz(
    path: str | os.PathLike,
    *,
    columns: Columns = None,
    decimal: str = ".",
    context: Context = QUIET,
) -> ScanPoints:
    """Read an XYZ text file (also ``.txt``, ``.asc`` without a grid header).

    One point per line, separated by whitespace, commas or semicolons; columns as in the
    module doc; ``decimal=","`` reads decimal commas (``1,5`` is 1.5; the values then
    separated by semicolons, tabs or spaces). Non-numeric lines at the top are a header;
    ``#`` lines are comments anywhere. Numbers are parsed natively in chunks, so Ctrl-C is
    honoured between chunks; ``context``: the call's progress (:func:`scanmesh.read`).

    Returns
    -------
    ScanPoints
        ``points`` (N, 3) float64; ``line_ids`` (N,) int64 from a line-id column or from
        the blank-line blocks (0, 1, ...), or None when neither is present.
    """
    return read_points_table(path, "xyz", columns=columns, decimal=decimal, context=context)


def xyz_rows(
    points: np.ndarray, line_ids: np.ndarray | None, block: int, up: np.ndarray | None = None
) -> Iterator[bytes]:
    """XYZ text in blocks of ``block`` rows: a header row naming the columns (and an ``up``
    comment), then ``x y z [line]`` rows with 17 significant digits (read back exactly)."""
    head = "x y z" + (" line" if line_ids is not None else "") + "\n"
    yield ((up_comment(up) if up is not None else "") + head).encode("ascii")
    row = "%.17g %.17g %.17g" + (" %d" if line_ids is not None else "") + "\n"
    for start in range(0, len(points), block):
        chunk = points[start : start + block]
        if line_ids is None:
            values = chunk.ravel().tolist()
        else:  # '%d' of a float holding an integer below 2**53 is exact
            line = line_ids[start : start + block].astype(np.float64)
            values = np.column_stack([chunk, line]).ravel().tolist()
        yield ((row * len(chunk)) % tuple(values)).encode("ascii")
