"""Reading scan points from files: one function per format, each returning :class:`ScanPoints`.

Formats (chosen by :func:`read` from the file ending):

- ``.xyz``, ``.txt``, ``.asc`` - :func:`read_xyz`: text, whitespace- or comma-separated;
- ``.csv`` - :func:`read_csv`: comma-separated text with an optional header row;
- ``.ply`` - :func:`read_ply`: ASCII or binary PLY, with Stanford ``range_grid`` rows as lines;
- ``.npy``, ``.npz`` - :func:`read_npy`: numpy arrays, never unpickled;
- ``.vtk`` - :func:`read_vtk`: legacy VTK POLYDATA, UNSTRUCTURED_GRID or STRUCTURED_GRID;
- ``.dem`` - :func:`read_dem`: USGS ASCII DEM, one scan line per profile;
- ``.las``, ``.laz`` - :func:`read_las`: LiDAR through laspy (``pip install scanmesh[las]``).

Every problem with a file is a :class:`~scanmesh.errors.FileFormatError` whose message names
the file and, for text, the line number and the offending text. XYZ and CSV rows are parsed
by the Rust core (``_core.parse_text_table``) chunk by chunk; the other text formats, and the
location of any bad line, by vectorised numpy (``np.fromstring`` on large chunks, structure
checks on the raw bytes): never a Python loop per point.
"""

from __future__ import annotations

import os
import re
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from scanmesh import _core
from scanmesh._progress import Progress, Stage
from scanmesh.errors import FileFormatError, ParameterError, ScanmeshError

#: Bytes of text parsed per step (one native call for XYZ/CSV rows, one vectorised numpy
#: pass elsewhere). It bounds the temporary arrays' memory and the time between returns to
#: Python, where Ctrl-C is honoured: 2 MB take about 0.08 s through numpy and 0.01-0.02 s
#: natively; with numpy, smaller chunks were also faster than 16 MB ones (cache): 1.05 s
#: against 1.62 s per million XYZ points.
CHUNK_BYTES: int = 1 << 21

#: How many non-numeric lines may open a text file before it is judged not to be numbers.
MAX_HEADER_LINES: int = 100

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

#: Elevation that marks a void (no data) in USGS DEM profiles.
DEM_VOID: int = -32767


def count_lines(ids: np.ndarray) -> int:
    """Number of distinct ids in (N,) integer ``ids``: O(N) when they never decrease (files
    list their lines in order), a sort otherwise."""
    if len(ids) < 2:
        return len(ids)
    steps = np.diff(ids)
    if (steps >= 0).all():
        return int(np.count_nonzero(steps)) + 1
    return int(len(np.unique(ids)))


@dataclass(frozen=True, eq=False)
class ScanPoints:
    """Points read from a file, in file order, with their scan lines when the file gives them."""

    #: (N, 3) float64 point coordinates in the file's units
    points: np.ndarray
    #: (N,) int64 scan-line id per point, or None; points with one id form one line, in order
    line_ids: np.ndarray | None
    #: the file the points came from
    source: Path
    #: format details: format name, units, where the line ids came from, ...
    extra: dict[str, Any] = field(default_factory=dict)

    def __post_init__(self) -> None:
        pts = np.asarray(self.points)
        if pts.ndim != 2 or pts.shape[1] != 3 or not np.issubdtype(pts.dtype, np.number):
            raise ScanmeshError(
                f"{self.source}: points must be an (N, 3) numeric array,"
                f" got {pts.dtype} {pts.shape}"
            )
        pts = np.ascontiguousarray(pts, dtype=np.float64)
        bad = ~np.isfinite(pts)
        if bad.any():
            row, col = np.argwhere(bad)[0]
            raise ScanmeshError(
                f"{self.source}: point {row} has a non-finite {'xyz'[col]}={float(pts[row, col])!r}"
            )
        object.__setattr__(self, "points", pts)
        if self.line_ids is not None:
            ids = np.asarray(self.line_ids)
            if ids.ndim != 1 or len(ids) != len(pts):
                raise ScanmeshError(
                    f"{self.source}: {len(ids) if ids.ndim == 1 else ids.shape} line ids"
                    f" do not match {len(pts)} points"
                )
            if ids.size and not np.issubdtype(ids.dtype, np.integer):
                raise ScanmeshError(f"{self.source}: line ids must be integers, got {ids.dtype}")
            object.__setattr__(self, "line_ids", np.ascontiguousarray(ids, dtype=np.int64))
        object.__setattr__(self, "source", Path(self.source))

    def __len__(self) -> int:
        return len(self.points)

    @property
    def n_lines(self) -> int:
        """Number of distinct scan lines (0 when the file gives none)."""
        return 0 if self.line_ids is None else count_lines(self.line_ids)

    def lines(self) -> list[np.ndarray]:
        """Point indices of each scan line, lines ordered by first appearance, points in file order.

        Returns
        -------
        list of (k,) int64
            Empty when the file gives no line ids.
        """
        if self.line_ids is None or not len(self.line_ids):
            return []
        ids = self.line_ids
        _, first, inverse = np.unique(ids, return_index=True, return_inverse=True)
        rank = np.empty(len(first), dtype=np.int64)
        rank[np.argsort(first, kind="stable")] = np.arange(len(first))
        order = np.argsort(rank[inverse], kind="stable")
        bounds = np.cumsum(np.bincount(rank[inverse], minlength=len(first)))[:-1]
        return np.split(order.astype(np.int64), bounds)

    def __repr__(self) -> str:
        return (
            f"ScanPoints(source={str(self.source)!r}, points={len(self.points)},"
            f" lines={self.n_lines if self.line_ids is not None else None})"
        )


# --------------------------------------------------------------------------- dispatch


def read(path: str | os.PathLike, *, progress: Progress = False, **kwargs: Any) -> ScanPoints:
    """Read scan points, choosing the reader by the file ending (case does not matter).

    Parameters
    ----------
    path : str or PathLike
        The file.
    progress : bool or callable
        True shows a progress bar; a callable taking ``stage=`` is called as
        ``progress(bytes_done, bytes_total, None, stage="read")`` (see ``reconstruct``). Text
        files report after every chunk, other formats once at the start and once at the end.
    **kwargs
        Passed to the reader (e.g. ``select="ground"`` for :func:`read_las`).

    Returns
    -------
    ScanPoints
    """
    target = Path(path)
    reader = READERS.get(target.suffix.lower())
    if reader is None:
        raise FileFormatError(
            f"{target}: unknown file ending {target.suffix!r}; readable endings are"
            f" {', '.join(sorted(READERS))}"
        )
    if reader in (read_xyz, read_csv):
        return reader(target, progress=progress, **kwargs)
    try:
        size = target.stat().st_size
    except OSError:
        size = 0  # the reader reports the missing file
    with Stage(progress, "read", size, blocking=True):
        return reader(target, **kwargs)


def _read_bytes(path: Path) -> bytes:
    """The file's content, with an unreadable file reported as a FileFormatError."""
    try:
        return path.read_bytes()
    except OSError as exc:
        raise FileFormatError(f"{path}: cannot read the file: {exc.strerror or exc}") from exc


def _check_file(path: Path) -> None:
    """Report a missing or unreadable path like the readers that read bytes do."""
    try:
        with open(path, "rb"):
            pass
    except OSError as exc:
        raise FileFormatError(f"{path}: cannot read the file: {exc.strerror or exc}") from exc


def _quote(text: bytes | str, limit: int = 80) -> str:
    """Offending text for a message: decoded, stripped, shortened."""
    if isinstance(text, bytes):
        text = text.decode("utf-8", errors="replace")
    text = text.strip()
    return repr(text if len(text) <= limit else text[: limit - 3] + "...")


def _line_at(data: bytes, offset: int) -> tuple[int, bytes]:
    """1-based line number and text of the line holding byte ``offset``."""
    offset = max(0, min(offset, len(data)))
    start = data.rfind(b"\n", 0, offset) + 1
    end = data.find(b"\n", offset)
    return data.count(b"\n", 0, offset) + 1, data[start : end if end >= 0 else len(data)]


def _check_text(path: Path, data: bytes, what: str, start: int = 0) -> None:
    """Reject binary content (a NUL byte at or after ``start``) in a file that must be text."""
    nul = data.find(b"\x00", start)
    if nul >= 0:
        line, _ = _line_at(data, nul)
        raise FileFormatError(
            f"{path}, line {line}: binary data (byte 0x00 at offset {nul}); {what} must be text"
        )


# --------------------------------------------------------------------------- text numbers

# A token that numpy's text parser and ours accept as one number.
_NUMBER = re.compile(
    rb"[+-]?(?:(?:\d+\.?\d*|\.\d+)(?:[eE][+-]?\d+)?|nan|inf|infinity)", re.IGNORECASE
)
# A line whose first token starts like a number is a data line, not a header.
_NUMBER_START = re.compile(rb"\s*[+-]?\.?\d")
_TOKEN = re.compile(rb"[^\s,]+")
_COMMA_TO_SPACE = bytes.maketrans(b",", b" ")
# Byte -> is a separator: space, tab, CR, LF (and, in the second table, comma).
_WHITE = np.zeros(256, dtype=bool)
_WHITE[[9, 10, 13, 32]] = True
_WHITE_COMMA = _WHITE.copy()
_WHITE_COMMA[44] = True


def _separators(u: np.ndarray, comma: bool = False) -> np.ndarray:
    """(n,) bool: which bytes of ``u`` separate tokens (one table lookup per byte)."""
    return (_WHITE_COMMA if comma else _WHITE)[u]


def _locate_bad_number(
    path: Path, data: bytes, start: int, stop: int, context: str = "", buf: bytes | None = None
) -> None:
    """Raise naming the first token in ``data[start:stop]`` that is not a number.

    ``buf``, when given, stands for ``data[start:stop]`` (same length, comment lines blanked).
    """
    scan, base = (data, 0) if buf is None else (buf, start)
    lo, hi = (start, stop) if buf is None else (0, len(buf))
    for match in _TOKEN.finditer(scan, lo, hi):
        if not _NUMBER.fullmatch(match.group()):
            line, text = _line_at(data, base + match.start())
            raise FileFormatError(
                f"{path}, line {line}: {_quote(match.group())} is not a number{context}:"
                f" {_quote(text)}"
            )
    line, _ = _line_at(data, start)
    raise FileFormatError(f"{path}, line {line}: the numbers from here on cannot be parsed")


def _floats(
    path: Path,
    data: bytes,
    start: int,
    stop: int,
    expect: int,
    context: str = "",
    buf: bytes | None = None,
) -> np.ndarray:
    """Parse ``data[start:stop]`` (whitespace/comma separated) into exactly ``expect`` float64.

    ``buf`` may stand in for ``data[start:stop]`` (same offsets; comment lines blanked). The
    fast path is one ``np.fromstring`` call; any failure is located token by token.
    """
    text = data[start:stop] if buf is None else buf
    if b"," in text:
        text = text.translate(_COMMA_TO_SPACE)
    try:
        values = np.fromstring(text, dtype=np.float64, sep=" ")
    except ValueError:
        values = None
    if values is None or values.size != expect:
        _locate_bad_number(path, data, start, stop, context, buf)
    return values


@dataclass
class _Table:
    """A numeric text table: (R, C) values and, per row, its file line and blank-line block."""

    values: np.ndarray  # (R, C) float64
    row_lines: np.ndarray  # (R,) int64 1-based line number of each row
    blocks: np.ndarray  # (R,) int64 index of the blank-line-separated block of each row
    header: list[str]  # the non-numeric lines above the data (comments excluded)
    header_lines: list[int]  # their 1-based line numbers
    comma: bool  # comma-separated


def _token_counts(
    u: np.ndarray, ends: np.ndarray, sep: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """Token start offsets and tokens per line for a chunk of whole lines."""
    start_mask = ~sep
    start_mask[1:] &= sep[:-1]
    tok = np.flatnonzero(start_mask)
    counts = np.diff(np.searchsorted(tok, ends), prepend=0)
    return tok, counts


def _numpy_chunk(
    path: Path,
    data: bytes,
    start: int,
    stop: int,
    ncols: int,
    comma: bool,
    line_no: int,
    first_line: int,
) -> tuple[np.ndarray, np.ndarray, np.ndarray, int]:
    """Parse ``data[start:stop]`` (whole lines starting at file line ``line_no``) with numpy.

    The reference for ``_core.parse_text_table`` (same rules, same results) and the error
    reporter: it raises naming the file, the line and the offending text. Returns (values
    (R, ncols), row line indices (R,), blank line indices (B,), number of lines), line
    indices 0-based within the chunk.
    """
    u = np.frombuffer(data, dtype=np.uint8, count=stop - start, offset=start)
    ends = np.flatnonzero(u == 10)
    if not len(ends) or ends[-1] != len(u) - 1:
        ends = np.append(ends, len(u))
    sep = _separators(u, comma)
    tok, counts = _token_counts(u, ends, sep)
    first_tok = np.cumsum(counts) - counts
    has = counts > 0
    comment = np.zeros(len(ends), dtype=bool)
    comment[has] = u[tok[first_tok[has]]] == 35
    chunk = data[start:stop]
    if comment.any():
        # blank out comment lines (offsets, and so line numbers, stay the same)
        line_starts = np.concatenate(([0], ends[:-1] + 1))
        mark = np.zeros(len(u) + 1, dtype=np.int8)
        np.add.at(mark, line_starts[comment], 1)
        np.add.at(mark, ends[comment], -1)
        arr = np.frombuffer(chunk, dtype=np.uint8).copy()
        arr[np.cumsum(mark[:-1]) > 0] = 32
        chunk = arr.tobytes()
        counts = np.where(comment, 0, counts)
    is_data = counts > 0
    bad = is_data & (counts != ncols)
    if comma:
        commas = np.diff(np.searchsorted(np.flatnonzero(u == 44), ends), prepend=0)
        bad |= is_data & (commas != ncols - 1)
        bad |= ~is_data & ~comment & (commas > 0)
    if bad.any():
        i = int(np.flatnonzero(bad)[0])
        line_start = 0 if i == 0 else int(ends[i - 1]) + 1
        text = data[start + line_start : start + int(ends[i])]
        found = len(_TOKEN.findall(text))
        raise FileFormatError(
            f"{path}, line {line_no + i}: expected {ncols} "
            f"{'comma-separated ' if comma else ''}values as on line {first_line},"
            f" found {found}{' (or empty fields)' if comma else ''}: {_quote(text)}"
        )
    flat = _floats(path, data, start, stop, int(counts.sum()), buf=chunk)
    return (
        flat.reshape(-1, ncols),
        np.flatnonzero(is_data),
        np.flatnonzero(~is_data & ~comment),
        len(ends),
    )


def _read_table(path: Path, data: bytes, what: str, progress: Progress = False) -> _Table:
    """Parse a numeric text table: optional header lines, then rows of equally many numbers.

    Rows are whitespace- or comma-separated (comma when the first row holds one); ``#`` lines
    are comments anywhere; blank lines split the rows into blocks (scan lines).
    """
    _check_text(path, data, what)
    if not data or data.isspace():
        raise FileFormatError(f"{path}: the file is empty; expected {what}")
    # header: lines before the first line that starts with a number
    pos, line_no, header, header_lines = (3 if data.startswith(b"\xef\xbb\xbf") else 0), 1, [], []
    n = len(data)
    while True:
        if pos >= n:
            raise FileFormatError(f"{path}: no numeric data found after {line_no - 1} line(s)")
        end = data.find(b"\n", pos)
        end = n if end < 0 else end
        text = data[pos:end]
        stripped = text.strip()
        if stripped and not stripped.startswith(b"#"):
            if _NUMBER_START.match(text):
                break
            header.append(text.decode("utf-8", errors="replace").strip())
            header_lines.append(line_no)
            if len(header) > MAX_HEADER_LINES:
                _, line1 = _line_at(data, 0)
                raise FileFormatError(
                    f"{path}: no numeric data in the first {MAX_HEADER_LINES} lines (line 1 is"
                    f" {_quote(line1)}); expected {what}"
                )
        pos, line_no = end + 1, line_no + 1
    comma = b"," in text
    ncols = len(_TOKEN.findall(text))
    first_line = line_no

    # One allocation per output, filled chunk by chunk (pages are touched only as rows
    # arrive): no list of chunks to concatenate, which would double the peak memory.
    capacity = data.count(b"\n", pos) + 1
    values = np.empty((capacity, ncols))
    row_lines = np.empty(capacity, dtype=np.int64)
    blocks = np.empty(capacity, dtype=np.int64)
    n_rows = 0
    blanks_seen = 0  # blank lines before the current position (after the first data line)
    last_blanks = 0  # blank count at the previous data row
    block = 0
    start = pos
    with Stage(progress, "read", n) as stage:
        stage.update(start)
        while start < n:
            stop = min(start + CHUNK_BYTES, n)
            if stop < n:
                nl = data.find(b"\n", stop - 1)
                stop = n if nl < 0 else nl + 1
            # the native parser, without the GIL; a line it refuses is located (and the
            # message written) by the numpy reference path
            parsed = _core.parse_text_table(data, start, stop, ncols, comma)
            if parsed is None:
                parsed = _numpy_chunk(path, data, start, stop, ncols, comma, line_no, first_line)
            flat, rows, blank_lines, n_lines = parsed
            end = n_rows + len(rows)
            values[n_rows:end] = flat
            row_lines[n_rows:end] = line_no + rows
            # blocks: a data row preceded by a blank line (since the last row) opens a new block
            at_row = blanks_seen + np.searchsorted(blank_lines, rows)
            prev = np.concatenate(([last_blanks], at_row[:-1]))
            opens = at_row > prev
            if start == pos and len(opens):
                opens[0] = False
            blocks[n_rows:end] = block + np.cumsum(opens)
            if len(rows):
                block = int(blocks[end - 1])
                last_blanks = int(at_row[-1])
            n_rows = end
            blanks_seen += len(blank_lines)
            line_no += n_lines
            start = stop
            stage.update(stop)
    return _Table(
        values=values[:n_rows],
        row_lines=row_lines[:n_rows],
        blocks=blocks[:n_rows],
        header=header,
        header_lines=header_lines,
        comma=comma,
    )


def _row_error(path: Path, data: bytes, table: _Table, row: int, message: str) -> FileFormatError:
    """A FileFormatError naming the line (and its text) of table row ``row``."""
    line = int(table.row_lines[row])
    newlines = np.flatnonzero(np.frombuffer(data, dtype=np.uint8) == 10)
    offset = 0 if line == 1 else int(newlines[line - 2]) + 1
    end = data.find(b"\n", offset)
    text = data[offset : end if end >= 0 else len(data)]
    return FileFormatError(f"{path}, line {line}: {message}: {_quote(text)}")


def _finite_rows(path: Path, data: bytes, table: _Table, cols: list[int], names: list[str]) -> None:
    """Raise on the first row with a NaN or infinite value in the given columns."""
    if np.isfinite(table.values).all():  # the usual case: one pass, no column copy
        return
    sub = table.values if cols == list(range(table.values.shape[1])) else table.values[:, cols]
    bad = ~np.isfinite(sub)
    if bad.any():
        row, col = np.argwhere(bad)[0]
        raise _row_error(
            path, data, table, int(row), f"non-finite {names[col]}={float(sub[row, col])!r}"
        )


def _line_column(path: Path, data: bytes, table: _Table, col: int) -> np.ndarray:
    """The line-id column as int64, raising on the first value that is not an integer."""
    ids = table.values[:, col]
    # the int64 cast is needed anyway; a value it does not give back exactly is a fraction,
    # NaN or infinite (their casts are garbage, hence errstate): one pass fewer than round()
    with np.errstate(invalid="ignore"):
        as_int = ids.astype(np.int64)
    bad = (as_int != ids) | (np.abs(ids) >= 2**53)
    if bad.any():
        row = int(np.flatnonzero(bad)[0])
        what = "is not below 2**53" if np.abs(ids[row]) >= 2**53 else "is not an integer"
        raise _row_error(
            path, data, table, row, f"line id {float(ids[row])!r} in column {col + 1} {what}"
        )
    return as_int


def _named_columns(header: str, comma: bool, ncols: int) -> dict[str, int] | None:
    """Column indices of x, y, z (and line) named in a header row, or None if it names none."""
    names = [
        name.strip().strip("\"'").strip().lower()
        for name in (header.split(",") if comma else header.split())
    ]
    if len(names) != ncols or not {"x", "y", "z"} <= set(names):
        return None
    found = {key: names.index(key) for key in ("x", "y", "z")}
    for name in LINE_COLUMN_NAMES:
        if name in names:
            found["line"] = names.index(name)
            break
    return found


def _table_points(
    path: Path, data: bytes, table: _Table, columns: dict[str, int], fmt: str
) -> ScanPoints:
    """ScanPoints from a parsed table and the columns holding x, y, z and the line id."""
    cols = [columns["x"], columns["y"], columns["z"]]
    _finite_rows(path, data, table, cols, ["x", "y", "z"])
    if cols == [0, 1, 2] and table.values.shape[1] == 3:
        points = table.values  # already (N, 3) C-contiguous: no copy
    elif cols == [0, 1, 2]:
        points = np.ascontiguousarray(table.values[:, :3])  # a view, then one copy
    else:
        points = np.ascontiguousarray(table.values[:, cols])
    extra: dict[str, Any] = {"format": fmt, "header": table.header, "columns": columns}
    if "line" in columns:
        line_ids = _line_column(path, data, table, columns["line"])
        extra["line_ids_from"] = f"column {columns['line'] + 1}"
    elif len(table.blocks) and table.blocks[-1] > 0:
        line_ids = table.blocks
        extra["line_ids_from"] = "blank lines"
    else:
        line_ids = None
        extra["line_ids_from"] = None
    return ScanPoints(points=points, line_ids=line_ids, source=path, extra=extra)


def read_xyz(path: str | os.PathLike, *, progress: Progress = False) -> ScanPoints:
    """Read an XYZ text file (also ``.txt``, ``.asc``).

    One point per line: ``x y z`` or ``x y z line_id``, separated by whitespace or commas.
    Non-numeric lines at the top are a header; a header row naming ``x``, ``y``, ``z`` (and
    ``line``) in as many fields as the data places the columns by name, so extra columns
    are then allowed. ``#`` lines are comments anywhere. Without a line-id column, blank lines
    separate scan lines. Numbers are parsed natively (``_core.parse_text_table``) in chunks of
    ``CHUNK_BYTES``, so Ctrl-C is honoured between chunks; ``progress`` as in :func:`read`.

    Returns
    -------
    ScanPoints
        ``points`` (N, 3) float64; ``line_ids`` (N,) int64 from the 4th column or from the
        blank-line blocks (0, 1, ...), or None when neither is present.
    """
    path = Path(path)
    data = _read_bytes(path)
    table = _read_table(path, data, "x y z rows", progress)
    ncols = table.values.shape[1]
    columns = _named_columns(table.header[-1], table.comma, ncols) if table.header else None
    if columns is None:
        if ncols not in (3, 4):
            raise _row_error(
                path,
                data,
                table,
                0,
                f"expected 3 values (x y z) or 4 (x y z line_id), found {ncols}",
            )
        columns = {"x": 0, "y": 1, "z": 2} | ({"line": 3} if ncols == 4 else {})
    return _table_points(path, data, table, columns, "xyz")


def read_csv(path: str | os.PathLike, *, progress: Progress = False) -> ScanPoints:
    """Read a CSV file of points: ``x,y,z`` or ``x,y,z,line`` per row.

    A header row, when present, must name the columns ``x``, ``y``, ``z`` and optionally a
    line id (``line``, ``line_id``, ``scan_line``, ...); other named columns are ignored.
    Without a header the columns are taken in order and there must be 3 or 4. Blank lines
    separate scan lines when there is no line-id column. Parsed like :func:`read_xyz`
    (natively, in chunks); ``progress`` as in :func:`read`.

    Returns
    -------
    ScanPoints
        ``points`` (N, 3) float64; ``line_ids`` (N,) int64 or None.
    """
    path = Path(path)
    data = _read_bytes(path)
    table = _read_table(path, data, "comma-separated x,y,z rows", progress)
    ncols = table.values.shape[1]
    if table.header:
        columns = _named_columns(table.header[-1], table.comma, ncols)
        if columns is None:
            raise FileFormatError(
                f"{path}, line {table.header_lines[-1]}: the header"
                f" {_quote(table.header[-1])} must name columns x, y and z in {ncols} fields"
                f" (as many as the data on line {int(table.row_lines[0])})"
            )
    else:
        if ncols not in (3, 4):
            raise _row_error(
                path,
                data,
                table,
                0,
                f"expected 3 columns (x,y,z) or 4 (x,y,z,line), found {ncols}",
            )
        columns = {"x": 0, "y": 1, "z": 2} | ({"line": 3} if ncols == 4 else {})
    return _table_points(path, data, table, columns, "csv")


# --------------------------------------------------------------------------- PLY

_PLY_TYPES = {
    "char": "i1",
    "int8": "i1",
    "uchar": "u1",
    "uint8": "u1",
    "short": "i2",
    "int16": "i2",
    "ushort": "u2",
    "uint16": "u2",
    "int": "i4",
    "int32": "i4",
    "uint": "u4",
    "uint32": "u4",
    "float": "f4",
    "float32": "f4",
    "double": "f8",
    "float64": "f8",
}


@dataclass
class _PlyElement:
    name: str
    count: int
    # (name, dtype) for scalars; (name, count dtype, item dtype) for lists
    props: list[tuple[str, ...]]
    line: int  # header line of the element

    @property
    def scalar_only(self) -> bool:
        return all(len(p) == 2 for p in self.props)


def _ply_header(path: Path, data: bytes) -> tuple[str, list[_PlyElement], dict[str, str], int]:
    """Parse a PLY header: format, elements, obj_info and the offset of the body."""
    if not data.startswith(b"ply"):
        raise FileFormatError(f"{path}, line 1: not a PLY file (it must start with 'ply')")
    end = data.find(b"end_header")
    if end < 0:
        raise FileFormatError(f"{path}: PLY header has no 'end_header' line (truncated?)")
    body = data.find(b"\n", end)
    body = len(data) if body < 0 else body + 1
    try:
        lines = data[:end].decode("ascii").splitlines()
    except UnicodeDecodeError as exc:
        line, _ = _line_at(data, exc.start)
        raise FileFormatError(f"{path}, line {line}: PLY header holds non-ASCII bytes") from None
    fmt, elements, info = None, [], {}
    for no, raw in enumerate(lines[1:], start=2):
        words = raw.split()
        if not words or words[0] in ("comment",):
            continue
        key = words[0]
        try:
            if key == "format":
                fmt = words[1]
                if fmt not in ("ascii", "binary_little_endian", "binary_big_endian"):
                    raise ValueError(f"unknown format {fmt!r}")
            elif key == "obj_info":
                if len(words) >= 3:
                    info[words[1]] = words[2]
            elif key == "element":
                elements.append(_PlyElement(words[1], int(words[2]), [], no))
                if elements[-1].count < 0:
                    raise ValueError("negative count")
            elif key == "property":
                if not elements:
                    raise ValueError("property before any element")
                if words[1] == "list":
                    elements[-1].props.append(
                        (words[4], _PLY_TYPES[words[2]], _PLY_TYPES[words[3]])
                    )
                else:
                    elements[-1].props.append((words[2], _PLY_TYPES[words[1]]))
            else:
                raise ValueError(f"unknown keyword {key!r}")
        except (IndexError, KeyError, ValueError) as exc:
            raise FileFormatError(
                f"{path}, line {no}: bad PLY header line ({exc}): {_quote(raw)}"
            ) from None
    if fmt is None:
        raise FileFormatError(f"{path}: PLY header has no 'format' line")
    return fmt, elements, info, body


def _ply_binary_element(
    path: Path, data: bytes, pos: int, el: _PlyElement, order: str
) -> tuple[np.ndarray | list[np.ndarray], int]:
    """Read one binary element at ``pos``: a structured array, or for a single-list element a
    list of (k,) arrays. Returns it and the offset after it."""

    def short(need: int, have: int) -> FileFormatError:
        return FileFormatError(
            f"{path}: truncated PLY: element {el.name!r} ({el.count} items) needs {need} bytes"
            f" at offset {pos}, only {have} remain"
        )

    if el.scalar_only:
        dtype = np.dtype([(name, order + t) for name, t in el.props])
        need = dtype.itemsize * el.count
        if len(data) - pos < need:
            raise short(need, len(data) - pos)
        return np.frombuffer(data, dtype=dtype, count=el.count, offset=pos), pos + need
    if len(el.props) != 1:
        raise FileFormatError(
            f"{path}, line {el.line}: PLY element {el.name!r} mixes list and scalar properties;"
            " only pure-list elements (faces, range_grid) are supported"
        )
    _, ctype, itype = el.props[0]
    cdt, idt = np.dtype(order + ctype), np.dtype(order + itype)
    if el.count == 0:
        return [], pos
    if len(data) - pos < cdt.itemsize:
        raise short(cdt.itemsize, len(data) - pos)
    k = int(np.frombuffer(data, dtype=cdt, count=1, offset=pos)[0])
    # fast path: every item has the same length k (triangle faces)
    fixed = np.dtype([("n", cdt), ("v", idt, (k,))]) if k > 0 else None
    if fixed is not None and len(data) - pos >= fixed.itemsize * el.count:
        block = np.frombuffer(data, dtype=fixed, count=el.count, offset=pos)
        if np.all(block["n"] == k):
            return list(block["v"]), pos + fixed.itemsize * el.count
    items = []
    for _ in range(el.count):  # variable-length lists (range grids): one step per item
        if len(data) - pos < cdt.itemsize:
            raise short(cdt.itemsize, len(data) - pos)
        k = int(np.frombuffer(data, dtype=cdt, count=1, offset=pos)[0])
        pos += cdt.itemsize
        if len(data) - pos < k * idt.itemsize:
            raise short(k * idt.itemsize, len(data) - pos)
        items.append(np.frombuffer(data, dtype=idt, count=k, offset=pos))
        pos += k * idt.itemsize
    return items, pos


def _ply_ascii_lines(
    path: Path, data: bytes, pos: int, count: int, el: _PlyElement
) -> tuple[int, int]:
    """Byte range [pos, stop) of the next ``count`` lines, raising if the file ends first."""
    if count == 0:
        return pos, pos
    u = np.frombuffer(data, dtype=np.uint8, offset=pos)
    nl = np.flatnonzero(u == 10)
    if len(nl) >= count:
        return pos, pos + int(nl[count - 1]) + 1
    if len(nl) == count - 1 and pos + (int(nl[-1]) + 1 if len(nl) else 0) < len(data):
        return pos, len(data)
    line, _ = _line_at(data, len(data))
    raise FileFormatError(
        f"{path}, line {line}: truncated PLY: element {el.name!r} declares {count} lines,"
        f" the file ends after {len(nl)}"
    )


def read_ply(path: str | os.PathLike) -> ScanPoints:
    """Read the vertices of a PLY file (ASCII, binary little- or big-endian).

    A Stanford range image (``obj_info num_cols``/``num_rows`` and an element ``range_grid``
    of ``num_rows * num_cols`` lists holding 0 or 1 vertex index each, row by row) gives
    the scan lines: a vertex's line id is its grid row. Faces are not used, but every element
    is walked so that a file cut short anywhere is reported.

    Returns
    -------
    ScanPoints
        ``points`` (N, 3) float64 from the vertex ``x``, ``y``, ``z`` properties;
        ``line_ids`` (N,) int64 grid rows, or None without a range grid.
    """
    path = Path(path)
    data = _read_bytes(path)
    if not data:
        raise FileFormatError(f"{path}: the file is empty; expected a PLY file")
    fmt, elements, info, pos = _ply_header(path, data)
    names = [el.name for el in elements]
    if "vertex" not in names:
        raise FileFormatError(f"{path}: PLY file has no 'vertex' element")
    vertex_el = elements[names.index("vertex")]
    if vertex_el.count == 0:
        raise FileFormatError(f"{path}, line {vertex_el.line}: the PLY file holds no vertices")
    prop_names = [p[0] for p in vertex_el.props]
    missing = [c for c in "xyz" if c not in prop_names]
    if missing:
        raise FileFormatError(
            f"{path}, line {vertex_el.line}: PLY vertex element has no {'/'.join(missing)}"
            f" property (has {', '.join(prop_names)})"
        )
    vertices, grid = None, None
    # every element is walked, not only the vertices: truncation anywhere is an error
    if fmt == "ascii":
        _check_text(path, data, "an ASCII PLY body", start=pos)
        for el in elements:
            a, b = _ply_ascii_lines(path, data, pos, el.count, el)
            if el.name == "vertex":
                if not el.scalar_only:
                    raise FileFormatError(
                        f"{path}, line {el.line}: list properties in the vertex element are not"
                        " supported"
                    )
                nprops = len(el.props)
                flat = _floats(path, data, a, b, el.count * nprops, " in a PLY vertex")
                # the right count could still be spread unevenly over the lines
                u = np.frombuffer(data, dtype=np.uint8, count=b - a, offset=a)
                ends = np.flatnonzero(u == 10)
                if not len(ends) or ends[-1] != len(u) - 1:
                    ends = np.append(ends, len(u))
                sep = _separators(u)
                _, counts = _token_counts(u, ends, sep)
                uneven = np.flatnonzero(counts != nprops)
                if len(uneven):
                    lno, text = _line_at(
                        data, a + (int(ends[uneven[0] - 1]) + 1 if uneven[0] else 0)
                    )
                    raise FileFormatError(
                        f"{path}, line {lno}: expected {nprops} vertex values, found"
                        f" {int(counts[uneven[0]])}: {_quote(text)}"
                    )
                vertices = flat.reshape(-1, nprops)
            elif el.name == "range_grid":
                grid = _ascii_lists(path, data, a, b, el)
            pos = b
        cols = [prop_names.index(c) for c in "xyz"]
        points = vertices[:, cols] if vertices is not None else np.empty((0, 3))
    else:
        order = "<" if fmt == "binary_little_endian" else ">"
        for el in elements:
            got, pos = _ply_binary_element(path, data, pos, el, order)
            if el.name == "vertex":
                vertices = got
            elif el.name == "range_grid":
                grid = got
        points = np.column_stack([vertices[c].astype(np.float64) for c in "xyz"])
    bad = ~np.isfinite(points)
    if bad.any():
        row, col = np.argwhere(bad)[0]
        raise FileFormatError(
            f"{path}: vertex {row} has a non-finite {'xyz'[col]}={float(points[row, col])!r}"
        )
    extra: dict[str, Any] = {"format": "ply", "encoding": fmt, "obj_info": info}
    line_ids = None
    if grid is not None:
        line_ids = _range_grid_rows(path, grid, info, len(points))
        extra["line_ids_from"] = "range_grid rows"
    else:
        extra["line_ids_from"] = None
    return ScanPoints(points=points, line_ids=line_ids, source=path, extra=extra)


def _ascii_lists(path: Path, data: bytes, a: int, b: int, el: _PlyElement) -> list[np.ndarray]:
    """An ASCII single-list element (one ``count i0 i1 ...`` line per item) as arrays."""
    if len(el.props) != 1 or len(el.props[0]) != 3:
        raise FileFormatError(
            f"{path}, line {el.line}: PLY element {el.name!r} must hold one list property"
        )
    u = np.frombuffer(data, dtype=np.uint8, count=b - a, offset=a)
    ends = np.flatnonzero(u == 10)
    if not len(ends) or ends[-1] != len(u) - 1:
        ends = np.append(ends, len(u))
    sep = _separators(u)
    _, counts = _token_counts(u, ends, sep)
    flat = _floats(path, data, a, b, int(counts.sum()), f" in PLY element {el.name!r}")
    first = np.cumsum(counts) - counts
    declared = np.where(counts > 0, flat[np.minimum(first, max(len(flat) - 1, 0))], -1)
    bad = np.flatnonzero((counts == 0) | (declared != counts - 1))
    if len(bad):
        i = int(bad[0])
        lno, text = _line_at(data, a + (int(ends[i - 1]) + 1 if i else 0))
        raise FileFormatError(
            f"{path}, line {lno}: a {el.name!r} list must start with its length: {_quote(text)}"
        )
    rest = np.delete(flat, first).astype(np.int64)
    return np.split(rest, np.cumsum(counts - 1)[:-1])


def _range_grid_rows(
    path: Path, grid: list[np.ndarray], info: dict[str, str], n: int
) -> np.ndarray:
    """Line id (grid row) of each vertex from a Stanford range grid."""
    try:
        cols, rows = int(info["num_cols"]), int(info["num_rows"])
    except (KeyError, ValueError):
        raise FileFormatError(
            f"{path}: PLY range_grid needs 'obj_info num_cols' and 'obj_info num_rows'"
            f" in the header (found {info})"
        ) from None
    if len(grid) != rows * cols:
        raise FileFormatError(
            f"{path}: PLY range_grid has {len(grid)} entries, not num_rows x num_cols ="
            f" {rows} x {cols} = {rows * cols}"
        )
    sizes = np.fromiter((len(g) for g in grid), dtype=np.int64, count=len(grid))
    if sizes.size and sizes.max() > 1:
        cell = int(np.argmax(sizes > 1))
        raise FileFormatError(
            f"{path}: PLY range_grid cell {cell} lists {sizes[cell]} vertices; at most 1 allowed"
        )
    cells = np.flatnonzero(sizes == 1)
    index = np.concatenate([grid[c] for c in cells]).astype(np.int64) if len(cells) else cells
    out_of_range = np.flatnonzero((index < 0) | (index >= n))
    if len(out_of_range):
        c = int(cells[out_of_range[0]])
        raise FileFormatError(
            f"{path}: PLY range_grid cell {c} points to vertex {index[out_of_range[0]]},"
            f" outside 0..{n - 1}"
        )
    line_ids = np.full(n, -1, dtype=np.int64)
    line_ids[index] = cells // cols
    seen = np.bincount(index, minlength=n)
    if (seen != 1).any():
        v = int(np.flatnonzero(seen != 1)[0])
        raise FileFormatError(
            f"{path}: PLY range_grid names vertex {v} {int(seen[v])} times (every vertex must"
            f" appear exactly once; {int((seen == 0).sum())} vertices are missing)"
        )
    return line_ids


# --------------------------------------------------------------------------- NPY


def read_npy(path: str | os.PathLike) -> ScanPoints:
    """Read points from a ``.npy`` array or an ``.npz`` archive, never unpickling objects.

    ``.npy``: an (N, 3) array (x, y, z) or (N, 4) (x, y, z, line id), any real dtype, or a
    structured array with fields ``x``, ``y``, ``z`` (and ``line``). ``.npz``: arrays
    ``points`` (N, 3) and optionally ``line_ids`` (N,).

    Returns
    -------
    ScanPoints
        ``points`` (N, 3) float64, ``line_ids`` (N,) int64 or None.
    """
    path = Path(path)
    _check_file(path)
    try:
        loaded = np.load(path, allow_pickle=False)
        if isinstance(loaded, np.lib.npyio.NpzFile):
            with loaded:
                arrays = {key: loaded[key] for key in loaded.files}
        else:
            arrays = {"": loaded}
    except ValueError as exc:
        if "allow_pickle" in str(exc):
            raise FileFormatError(
                f"{path}: the array holds Python objects, which are never unpickled; save"
                " numbers (float or int arrays) instead"
            ) from None
        raise FileFormatError(f"{path}: not a readable .npy/.npz file: {exc}") from None
    except Exception as exc:  # truncated or corrupt: EOFError, OSError, zipfile errors, ...
        raise FileFormatError(f"{path}: not a readable .npy/.npz file: {exc}") from None

    def numeric(arr: np.ndarray, name: str) -> np.ndarray:
        if arr.dtype.kind not in "iuf":
            raise FileFormatError(f"{path}: {name} must hold real numbers, got dtype {arr.dtype}")
        return arr

    line_ids = None
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
                raise FileFormatError(
                    f"{path}: expected an (N, 3) or (N, 4) array, got shape {arr.shape}"
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
    bad = ~np.isfinite(points)
    if bad.any():
        row, col = np.argwhere(bad)[0]
        raise FileFormatError(
            f"{path}: row {row} has a non-finite {'xyz'[col]}={float(points[row, col])!r}"
        )
    if line_ids is not None:
        ids = np.asarray(line_ids)
        if ids.dtype.kind == "f":
            wrong = ~np.isfinite(ids) | (ids != np.round(ids))
            if wrong.any():
                row = int(np.flatnonzero(wrong)[0])
                raise FileFormatError(
                    f"{path}: row {row} has line id {float(ids[row])!r}, which is not an integer"
                )
        line_ids = ids.astype(np.int64)
    return ScanPoints(
        points=points,
        line_ids=line_ids,
        source=path,
        extra={"format": "npz" if "" not in arrays else "npy"},
    )


# --------------------------------------------------------------------------- VTK

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
_VTK_FACE_TYPES = {5, 6, 7, 8, 9}


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
        u = np.frombuffer(self.data, dtype=np.uint8, offset=self.pos)
        sep = _separators(u)
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
        values = _floats(self.path, self.data, a, b, count, f" ({what})")
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
    data = _read_bytes(path)
    if not data or data.isspace():
        raise FileFormatError(f"{path}: the file is empty; expected a legacy VTK file")
    if data.lstrip().startswith(b"<"):
        raise FileFormatError(
            f"{path}: XML VTK files (.vtp/.vtu) are not supported; save as legacy .vtk"
        )
    if not data.startswith(b"# vtk DataFile"):
        _, line1 = _line_at(data, 0)
        raise FileFormatError(
            f"{path}, line 1: not a legacy VTK file (it must start with '# vtk DataFile'):"
            f" {_quote(line1)}"
        )
    # line 1: version, line 2: title (free text), line 3: ASCII | BINARY
    first = data.find(b"\n")
    second = data.find(b"\n", first + 1)
    third = data.find(b"\n", second + 1)
    if min(first, second, third) < 0:
        raise FileFormatError(f"{path}: truncated VTK header")
    mode = data[second + 1 : third].strip().upper()
    if mode not in (b"ASCII", b"BINARY"):
        raise FileFormatError(f"{path}, line 3: expected ASCII or BINARY, found {_quote(mode)}")
    binary = mode == b"BINARY"
    cur = _VtkCursor(path, data, third + 1, binary)
    if not binary:
        _check_text(path, data, "an ASCII VTK file")
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
                    f"{path}, line {no}: unknown VTK keyword {words[0]!r}:"
                    f" {_quote(' '.join(words))}"
                )
        except FileFormatError:
            raise
        except (IndexError, ValueError):
            raise FileFormatError(
                f"{path}, line {no}: malformed VTK line: {_quote(' '.join(words))}"
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
        # VTK_PIXEL (8) orders its corners as a 2x2 grid: as a polygon it is 0 1 3 2
        faces += [c[[0, 1, 3, 2]] for c, t in zip(cells, cell_types, strict=True) if t == 8]
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
    if line_ids is None and (faces or strips):
        width = _grid_width(n, faces, strips)
        if width is not None:
            line_ids = np.arange(n, dtype=np.int64) // width
            extra["line_ids_from"] = (
                f"face connectivity: a grid of {n // width} rows x {width} points"
            )
    if line_ids is None and dims is not None and dataset == "STRUCTURED_GRID":
        nx = dims[0]
        if nx > 0 and n % nx == 0:
            line_ids = np.arange(n, dtype=np.int64) // nx
            extra["line_ids_from"] = f"STRUCTURED_GRID dimensions {dims}: rows of {nx} points"
    extra.setdefault("line_ids_from", None)
    return ScanPoints(points=points, line_ids=line_ids, source=path, extra=extra)


# --------------------------------------------------------------------------- USGS DEM

# A record fields, 0-based [start, stop) byte offsets (1024-byte logical record).
_DEM_A = {
    "level": (144, 150),
    "pattern": (150, 156),
    "reference_system": (156, 162),
    "zone": (162, 168),
    "planimetric_units": (528, 534),
    "elevation_units": (534, 540),
    "sides": (540, 546),
    "corners": (546, 738),
    "elevation_range": (738, 786),
    "resolution": (816, 852),
    "rows_columns": (852, 864),
}
_DEM_UNITS = {0: "radians", 1: "feet", 2: "metres", 3: "arc-seconds"}


def _fortran_floats(path: Path, raw: bytes, width: int, what: str, offset: int) -> list[float]:
    """Fixed-width Fortran reals (``D`` or ``E`` exponents)."""
    out = []
    for i in range(0, len(raw), width):
        field_ = raw[i : i + width].strip().replace(b"D", b"E").replace(b"d", b"e")
        try:
            out.append(float(field_))
        except ValueError:
            raise FileFormatError(
                f"{path}: {what} at bytes {offset + i + 1}-{offset + i + width} is"
                f" {_quote(raw[i : i + width])}, not a number (is this a USGS DEM?)"
            ) from None
    return out


def _fortran_ints(path: Path, raw: bytes, what: str, offset: int) -> list[int]:
    """Fixed-width (I6) integers."""
    out = []
    for i in range(0, len(raw), 6):
        try:
            out.append(int(raw[i : i + 6]))
        except ValueError:
            raise FileFormatError(
                f"{path}: {what} at bytes {offset + i + 1}-{offset + i + 6} is"
                f" {_quote(raw[i : i + 6])}, not an integer (is this a USGS DEM?)"
            ) from None
    return out


def read_dem(path: str | os.PathLike) -> ScanPoints:
    """Read a USGS ASCII DEM: every profile (B record) is one scan line.

    The A record (1,024 bytes) gives the spatial resolution (dx, dy, dz) and the number of
    profiles; each B record gives its first point's ground coordinates (x0, y0), the local
    datum elevation and m elevations. Point k of a profile is
    ``(x0, y0 + k * dy, elevation_k * dz + datum)``; voids (-32767) are skipped.

    Returns
    -------
    ScanPoints
        ``points`` (N, 3) float64 in ground units (x, y) and elevation units (z);
        ``line_ids`` (N,) int64, the profile index (0 = first, westmost, profile).
    """
    path = Path(path)
    data = _read_bytes(path)
    if len(data) < 1024:
        raise FileFormatError(
            f"{path}: {len(data)} bytes is too short for a USGS DEM (its A record alone is 1024)"
        )
    _check_text(path, data, "a USGS ASCII DEM")
    # record length: 1024 bytes, or 1024 plus a line end that some copies carry
    record = 1024
    for tail in (b"\r\n", b"\n"):
        if data[1024 : 1024 + len(tail)] == tail:
            record += len(tail)
            break
    a = data[:1024]

    def ints(key: str) -> list[int]:
        s, e = _DEM_A[key]
        return _fortran_ints(path, a[s:e], f"A record '{key}'", s)

    def reals(key: str, width: int) -> list[float]:
        s, e = _DEM_A[key]
        return _fortran_floats(path, a[s:e], width, f"A record '{key}'", s)

    (level,) = ints("level")
    (refsys,) = ints("reference_system")
    (zone,) = ints("zone")
    (plan_units,) = ints("planimetric_units")
    (elev_units,) = ints("elevation_units")
    dx, dy, dz = reals("resolution", 12)
    n_rows, n_profiles = ints("rows_columns")
    corners = np.array(reals("corners", 24)).reshape(4, 2)
    emin, emax = reals("elevation_range", 24)
    if not (dx > 0 and dy > 0 and dz > 0) or n_profiles <= 0:
        raise FileFormatError(
            f"{path}: A record gives resolution ({dx}, {dy}, {dz}) and {n_profiles} profiles;"
            " not a valid USGS DEM"
        )
    xs, ys, zs, ids = [], [], [], []
    pos = record
    for profile in range(n_profiles):
        if pos + 144 > len(data):
            raise FileFormatError(
                f"{path}: truncated DEM: profile {profile + 1} of {n_profiles} should start at"
                f" byte {pos}, the file has {len(data)}"
            )
        head = data[pos : pos + 144]
        _, _, m, n = _fortran_ints(path, head[:24], f"B record {profile + 1} header", pos)
        x0, y0, datum, _, _ = _fortran_floats(
            path, head[24:144], 24, f"B record {profile + 1} header", pos + 24
        )
        if n != 1 or m < 0:
            raise FileFormatError(
                f"{path}: B record {profile + 1} at byte {pos} has {m} x {n} elevations;"
                " only single-column profiles (n = 1) are supported"
            )
        # elevations: 146 in the first 1024-byte block after the header, then 170 per block
        fields, start, left, room = [], pos + 144, m, 146
        while left > 0:
            take = min(left, room)
            chunk = data[start : start + 6 * take]
            if len(chunk) < 6 * take:
                raise FileFormatError(
                    f"{path}: truncated DEM: profile {profile + 1} of {n_profiles} needs {m}"
                    f" elevations, the file ends at byte {len(data)}"
                )
            fields.append(chunk)
            left -= take
            if left:
                pos += record
                start, room = pos, 170
        pos += record
        raw = b"".join(fields)
        try:
            elev = np.frombuffer(raw, dtype="S6").astype(np.int64)
        except ValueError:
            bad = next(
                i for i in range(m) if not raw[6 * i : 6 * i + 6].strip().lstrip(b"-").isdigit()
            )
            raise FileFormatError(
                f"{path}: profile {profile + 1}, elevation {bad + 1}:"
                f" {_quote(raw[6 * bad : 6 * bad + 6])} is not an integer"
            ) from None
        k = np.flatnonzero(elev != DEM_VOID)
        xs.append(np.full(len(k), x0))
        ys.append(y0 + k * dy)
        zs.append(elev[k] * dz + datum)
        ids.append(np.full(len(k), profile, dtype=np.int64))
    points = np.column_stack([np.concatenate(xs), np.concatenate(ys), np.concatenate(zs)])
    if not len(points):
        raise FileFormatError(f"{path}: every elevation in the DEM is void ({DEM_VOID})")
    extra = {
        "format": "usgs-dem",
        "level": level,
        "reference_system": {0: "geographic", 1: "UTM", 2: "state plane"}.get(refsys, refsys),
        "zone": zone,
        "planimetric_units": _DEM_UNITS.get(plan_units, plan_units),
        "elevation_units": {1: "feet", 2: "metres"}.get(elev_units, elev_units),
        "resolution": (dx, dy, dz),
        "corners": corners,
        "elevation_range": (emin, emax),
        "profiles": n_profiles,
        "line_ids_from": "profiles (B records)",
    }
    return ScanPoints(points=points, line_ids=np.concatenate(ids), source=path, extra=extra)


# --------------------------------------------------------------------------- LAS / LAZ


def read_las(path: str | os.PathLike, *, select: str = "first") -> ScanPoints:
    """Read LAS or LAZ LiDAR points through laspy (``pip install scanmesh[las]``).

    Parameters
    ----------
    path : str or PathLike
        A ``.las`` or ``.laz`` file.
    select : {"first", "ground", "all"}
        ``"first"``: first returns (``return_number == 1``), the top surface, default;
        ``"ground"``: points of ASPRS class 2 (ground); ``"all"``: every point.

    Scan lines are the scanner's sweeps: a new sweep starts wherever
    ``scan_direction_flag`` changes between consecutive points of the whole file. Sweeps are
    numbered before selecting, so a sweep keeps its id whatever is selected. When the flag
    never changes the file gives no lines (``line_ids`` None).

    Returns
    -------
    ScanPoints
        ``points`` (N, 3) float64 scaled coordinates; ``line_ids`` (N,) int64 sweep index.
    """
    path = Path(path)
    if select not in ("first", "ground", "all"):
        raise ParameterError(f"select must be 'first', 'ground' or 'all', got {select!r}")
    try:
        import laspy
    except ImportError:
        raise FileFormatError(
            f"{path}: reading LAS/LAZ files needs laspy; install it with"
            " `pip install scanmesh[las]`"
        ) from None
    _check_file(path)
    try:
        las = laspy.read(path)
        xyz = np.column_stack([np.asarray(las.x), np.asarray(las.y), np.asarray(las.z)])
        flag = np.asarray(las.scan_direction_flag).astype(np.int8)
        returns = np.asarray(las.return_number)
        classes = np.asarray(las.classification)
        header = las.header
        declared = int(header.point_count)
    except Exception as exc:  # laspy, lazrs and numpy all raise their own kinds
        hint = ""
        if "LazBackend" in type(exc).__name__ or "laz" in str(exc).lower():
            hint = " (LAZ needs a backend: `pip install scanmesh[las]` installs lazrs)"
        raise FileFormatError(
            f"{path}: not a readable LAS/LAZ file: {type(exc).__name__}: {exc}{hint}"
        ) from None
    if len(xyz) != declared:
        raise FileFormatError(
            f"{path}: truncated LAS: the header declares {declared} points, {len(xyz)} were read"
        )
    sweeps = np.concatenate(([0], np.cumsum(flag[1:] != flag[:-1]))).astype(np.int64)
    keep = {
        "first": returns == 1,
        "ground": classes == 2,
        "all": np.ones(len(xyz), dtype=bool),
    }[select]
    points = xyz[keep]
    if not len(points):
        raise FileFormatError(
            f"{path}: no points selected by select={select!r} ({len(xyz)} points in the file)"
        )
    bad = ~np.isfinite(points)
    if bad.any():
        row, col = np.argwhere(bad)[0]
        raise FileFormatError(f"{path}: point {row} has a non-finite {'xyz'[col]}")
    has_sweeps = bool(len(flag)) and sweeps[-1] > 0
    extra = {
        "format": "laz" if path.suffix.lower() == ".laz" else "las",
        "version": str(header.version),
        "point_format": int(header.point_format.id),
        "select": select,
        "points_in_file": len(xyz),
        "sweeps_in_file": int(sweeps[-1]) + 1 if len(sweeps) else 0,
        "scale": tuple(float(s) for s in header.scales),
        "line_ids_from": "scan_direction_flag changes" if has_sweeps else None,
    }
    return ScanPoints(
        points=points,
        line_ids=sweeps[keep] if has_sweeps else None,
        source=path,
        extra=extra,
    )


#: File ending (lower case) -> reader.
READERS: dict[str, Callable[..., ScanPoints]] = {
    ".xyz": read_xyz,
    ".txt": read_xyz,
    ".asc": read_xyz,
    ".csv": read_csv,
    ".ply": read_ply,
    ".npy": read_npy,
    ".npz": read_npy,
    ".vtk": read_vtk,
    ".dem": read_dem,
    ".las": read_las,
    ".laz": read_las,
}

__all__ = [
    "ScanPoints",
    "read",
    "read_xyz",
    "read_csv",
    "read_ply",
    "read_npy",
    "read_vtk",
    "read_dem",
    "read_las",
    "READERS",
]
