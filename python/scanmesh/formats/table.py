"""Numeric text tables: header lines, then rows of equally many numbers, parsed natively.

The numbers are parsed by the Rust core (``_core.parse_text_table``) in chunks of
``CHUNK_BYTES`` without the GIL, so Ctrl-C is honoured between chunks and progress reported
after each. A refused chunk comes back with the offset of its first bad byte and why, from
which the message names file, line and text: no second parser. The output arrays grow by
what was read (never by what the text implies), see :func:`parse_rows`.
"""

from __future__ import annotations

import bisect
import re
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from scanmesh import _core
from scanmesh._context import QUIET, Context
from scanmesh._progress import Stage
from scanmesh.errors import FileFormatError
from scanmesh.formats._source import check_text, line_at, quote

#: Bytes of text parsed per native call. It bounds the temporary arrays' memory and the
#: time between returns to Python, where Ctrl-C is honoured (2 MB take 0.01-0.02 s).
CHUNK_BYTES: int = 1 << 21

#: How many non-numeric lines may open a text file before it is judged not to be numbers.
MAX_HEADER_LINES: int = 100

# A line whose first token starts like a number is a data line, not a header: digits, or
# a hole or an infinity written as numpy and most tools write them (nan, inf, infinity).
_NUMBER_START = re.compile(rb"\s*[+-]?(\.?\d|(nan|inf(inity)?)([\s,;]|$))", re.IGNORECASE)
_WHITESPACE = b" \t\r\n"


def tokens(text: bytes, delimiter: str | None) -> list[bytes]:
    """The tokens of one line, split at whitespace and the delimiter."""
    if delimiter is not None:
        text = text.replace(delimiter.encode(), b" ")
    return text.split()


def _decimal_hint(text: bytes) -> str:
    """A pointer to ``decimal=","`` for a row that looks written with decimal commas
    (``1,5;2,25`` or ``1,5 2,25``: digits either side of a comma, and a semicolon, tab or
    space between values), else ""."""
    row = text.strip()
    if re.search(rb"\d,\d", row) and re.search(rb"\d[;\t ]+[-+]?\d", row):
        return "; if the file uses decimal commas, read it with decimal=',' (--decimal ,)"
    return ""


def raise_problem(
    path: Path,
    data: bytes,
    start: int,
    problem: _core.TextProblem,
    expected: str,
    delimiter: str | None,
    context: str = "",
) -> None:
    """Raise the FileFormatError for a chunk starting at ``start`` that the native parser
    refused with ``problem`` (its byte offset within the chunk and kind)."""
    offset, kind = problem.offset, problem.kind
    line, text = line_at(data, start + offset)
    if kind == "number":
        end = start + offset
        while end < len(data) and data[end] not in _WHITESPACE and chr(data[end]) != delimiter:
            end += 1
        raise FileFormatError(
            f"{path}, line {line}: {quote(data[start + offset : end])} is not a number"
            f"{context}: {quote(text)}{_decimal_hint(text)}"
        )
    sep = {None: "", ",": "comma-separated ", ";": "semicolon-separated "}.get(
        delimiter, f"{delimiter!r}-separated "
    )
    raise FileFormatError(
        f"{path}, line {line}: expected {expected.format(sep=sep)}, found"
        f" {len(tokens(text, delimiter))}{' (or empty fields)' if delimiter else ''}:"
        f" {quote(text)}{_decimal_hint(text)}"
    )


class RowLines:
    """The 1-based file line of every parsed row, kept per chunk: a chunk whose every line
    is a row keeps two numbers, another its rows' line offsets. So a file without blank
    or comment lines costs no per-row array (the lines are needed only to name a bad row).
    """

    def __init__(self) -> None:
        self._first_rows: list[int] = []  # first row of each chunk
        self._first_lines: list[int] = []  # file line of each chunk's first line
        self._offsets: list[np.ndarray | None] = []  # rows' lines within the chunk, or None
        self._n = 0

    def add(self, rows: int, first_line: int, offsets: np.ndarray | None) -> None:
        """Record ``rows`` rows of a chunk starting at file line ``first_line``: ``offsets``
        (0-based line of each row within the chunk), or None when row k is line k."""
        if rows:
            self._first_rows.append(self._n)
            self._first_lines.append(first_line)
            self._offsets.append(offsets)
            self._n += rows

    def __len__(self) -> int:
        return self._n

    def __getitem__(self, row: int) -> int:
        if not 0 <= row < self._n:
            raise IndexError(f"row {row} of {self._n}")
        k = bisect.bisect_right(self._first_rows, row) - 1
        at = row - self._first_rows[k]
        offsets = self._offsets[k]
        return self._first_lines[k] + (at if offsets is None else int(offsets[at]))


@dataclass
class Rows:
    """Rows parsed from a range of whole lines."""

    values: np.ndarray  # (R, len(split)) float64: the split columns (all columns: (R, C))
    rest: np.ndarray  # (R, C - len(split)) float64: the other columns, in file order
    row_lines: RowLines  # 1-based file line of each row
    block_starts: np.ndarray  # (K,) int64 ascending rows opening a blank-line-separated block
    first_blank: int | None  # 1-based file line of the first blank line, if any
    n_lines: int  # lines in the range


def blocks_of(block_starts: np.ndarray, n_rows: int) -> np.ndarray:
    """(n_rows,) int64 block index of every row, from the rows opening blocks 1, 2, ..."""
    opens = np.zeros(n_rows, dtype=np.int64)
    opens[block_starts] = 1
    return np.cumsum(opens, out=opens)


def _grow(arrays: list[np.ndarray], rows: int) -> None:
    """Resize arrays in place to ``rows`` rows (realloc: no second copy held)."""
    for arr in arrays:
        arr.resize((rows, *arr.shape[1:]), refcheck=False)


def parse_rows(
    path: Path,
    data: bytes,
    start: int,
    stop: int,
    ncols: int,
    delimiter: str | None,
    line_no: int,
    expected: str,
    stage: Stage | None = None,
    context: str = "",
    split: Sequence[int] | None = None,
) -> Rows:
    """Parse ``data[start:stop]`` (whole lines, the first being file line ``line_no``) as
    rows of ``ncols`` numbers, chunk by chunk.

    ``split`` (column indices) puts those columns, in that order, into ``values`` and the
    others into ``rest``, chunk by chunk: a reader gets its (N, 3) points contiguous without
    a copy of the whole table (None: every column in ``values``).

    Memory follows the rows actually parsed: the outputs start at what the first chunk's
    density predicts, grow by half when full, and never beyond what the bytes could hold
    (a row needs at least ``2 * ncols`` bytes); blank lines are kept as the rows where
    blocks open. So neither a long run of blank lines nor a huge first row makes a large
    allocation. ``expected`` describes a row for the message of a wrong count (``{sep}`` is
    replaced by the delimiter's name).
    """
    first = list(range(ncols)) if split is None else list(split)
    chosen = set(first)  # a set: one test per column, linear in the row's width
    others = [c for c in range(ncols) if c not in chosen]
    limit = (stop - start + 1) // (2 * ncols) + 1
    capacity = 0
    values = np.empty((0, len(first)))
    rest = np.empty((0, len(others)))
    row_lines = RowLines()
    opens: list[np.ndarray] = []
    n_rows, blanks_seen, last_blanks = 0, 0, 0
    first_blank = None
    pos = start
    while pos < stop:
        end = min(pos + CHUNK_BYTES, stop)
        if end < stop:
            nl = data.find(b"\n", end - 1, stop)
            end = stop if nl < 0 else nl + 1
        table = _core.parse_text_table(data, pos, end, ncols, delimiter)
        flat, rows, blank, n_lines = table.values, table.row_lines, table.blank_lines, table.n_lines
        problem = table.problem
        if problem is not None:
            raise_problem(path, data, pos, problem, expected, delimiter, context)
        need = n_rows + len(rows)
        if need > capacity:
            # the first chunk's density predicts the rest (a 1/16 margin spares a late grow)
            guess = need * (stop - start) // max(end - start, 1) * 17 // 16 + 1
            if capacity == 0:  # uninitialised: the rows are written over it anyway
                capacity = min(limit, max(need, guess))
                values, rest = np.empty((capacity, len(first))), np.empty((capacity, len(others)))
            else:
                capacity = min(limit, max(need, capacity * 3 // 2))
                _grow([values, rest], capacity)
        if split is None:
            values[n_rows:need] = flat
        else:
            np.take(flat, first, axis=1, out=values[n_rows:need])
            np.take(flat, others, axis=1, out=rest[n_rows:need])
        row_lines.add(len(rows), line_no, None if len(rows) == n_lines else rows)
        if len(rows) and (len(blank) or blanks_seen > last_blanks):
            # a row with a blank line since the previous row opens a block (not the first row)
            at_row = blanks_seen + np.searchsorted(blank, rows)
            opened = at_row > np.concatenate(([last_blanks], at_row[:-1]))
            if n_rows == 0:
                opened[0] = False
            opens.append(n_rows + np.flatnonzero(opened))
            last_blanks = int(at_row[-1])
        if len(blank):
            if first_blank is None:
                first_blank = line_no + int(blank[0])
            blanks_seen += len(blank)
        n_rows = need
        line_no += n_lines
        pos = end
        if stage is not None:
            stage.update(end)
    _grow([values, rest], n_rows)
    block_starts = np.concatenate(opens) if opens else np.empty(0, dtype=np.int64)
    return Rows(values, rest, row_lines, block_starts, first_blank, line_no)


def parse_free(path: Path, data: bytes, start: int, stop: int, context: str) -> np.ndarray:
    """Every number in ``data[start:stop]`` (whitespace-separated, any number per line), as
    one (V,) float64 array; raises naming the first token that is not a number."""
    table = _core.parse_text_table(data, start, stop, 0, None)
    flat, problem = table.values, table.problem
    if problem is not None:
        raise_problem(path, data, start, problem, "numbers", None, context)
    return flat.reshape(-1)


def tokens_per_line(data: bytes, start: int, stop: int) -> np.ndarray:
    """(L,) int64 number of whitespace-separated tokens on each line of ``data[start:stop]``
    (a last line without a line end counts)."""
    u = np.frombuffer(data, dtype=np.uint8, count=stop - start, offset=start)
    ends = np.flatnonzero(u == 10)
    if not len(ends) or ends[-1] != len(u) - 1:
        ends = np.append(ends, len(u))
    sep = np.isin(u, np.frombuffer(_WHITESPACE, dtype=np.uint8))
    first = ~sep
    first[1:] &= sep[:-1]
    return np.diff(np.searchsorted(np.flatnonzero(first), ends), prepend=0)


def skip_lines(path: Path, data: bytes, start: int, count: int, what: str) -> int:
    """The offset after the next ``count`` lines from ``start`` (the last may lack its line
    end), counted chunk by chunk; raises naming ``what`` when the file ends first."""
    pos, left = start, count
    while left > 0:
        end = min(pos + CHUNK_BYTES, len(data))
        here = data.count(b"\n", pos, end)
        if here >= left:
            u = np.frombuffer(data, dtype=np.uint8, count=end - pos, offset=pos)
            return pos + int(np.flatnonzero(u == 10)[left - 1]) + 1
        left -= here
        if end == len(data):
            if left == 1 and data[max(pos, data.rfind(b"\n", pos, end) + 1) : end].strip():
                return end  # a last line without its line end
            line, _ = line_at(data, len(data))
            raise FileFormatError(
                f"{path}, line {line}: truncated: {what} declares {count} lines, the file"
                f" ends after {count - left}"
            )
        pos = end
    return pos


@dataclass
class Head:
    """What opens a numeric text table: header and comment lines, then the first data row."""

    header: list[str]  # the non-numeric lines above the data (comments excluded)
    header_lines: list[int]  # their 1-based line numbers
    comments: list[str]  # the '#' lines above the data, without the '#'
    delimiter: str | None  # ',' or ';' when the first row holds one, else None (whitespace)
    ncols: int  # numbers on the first data row
    start: int  # byte offset of the first data row
    line: int  # its 1-based line number


@dataclass
class Table:
    """A numeric text table: (R, C) values and, per row, its file line and blank-line block."""

    values: np.ndarray  # (R, len(split)) float64, the split columns (all: (R, C))
    rest: np.ndarray  # (R, C - len(split)) float64, the other columns in file order
    row_lines: RowLines  # 1-based line number of each row
    block_starts: np.ndarray  # (K,) int64 rows opening blank-line-separated blocks 1..K
    head: Head

    @property
    def header(self) -> list[str]:
        return self.head.header

    @property
    def comments(self) -> list[str]:
        return self.head.comments

    @property
    def delimiter(self) -> str | None:
        return self.head.delimiter

    def blocks(self) -> np.ndarray:
        """(R,) int64 index of the blank-line-separated block of each row."""
        return blocks_of(self.block_starts, len(self.values))


def read_head(path: Path, data: bytes, what: str) -> Head:
    """The header and comment lines of a numeric text table and its first data row (see
    :func:`read_table`); raises when there is no numeric row in the first lines."""
    check_text(path, data, what)
    if not data or data.isspace():
        raise FileFormatError(f"{path}: the file is empty; expected {what}")
    pos, line_no = (3 if data.startswith(b"\xef\xbb\xbf") else 0), 1
    header: list[str] = []
    header_lines: list[int] = []
    comments: list[str] = []
    n = len(data)
    while True:
        if pos >= n:
            raise FileFormatError(f"{path}: no numeric data found after {line_no - 1} line(s)")
        end = data.find(b"\n", pos)
        end = n if end < 0 else end
        text = data[pos:end]
        stripped = text.strip()
        if stripped.startswith(b"#"):
            comments.append(stripped[1:].decode("utf-8", errors="replace").strip())
        elif stripped:
            if _NUMBER_START.match(text):
                break
            header.append(text.decode("utf-8", errors="replace").strip())
            header_lines.append(line_no)
            if len(header) > MAX_HEADER_LINES:
                _, line1 = line_at(data, 0)
                raise FileFormatError(
                    f"{path}: no numeric data in the first {MAX_HEADER_LINES} lines (line 1 is"
                    f" {quote(line1)}); expected {what}"
                )
        pos, line_no = end + 1, line_no + 1
    delimiter = "," if b"," in text else ";" if b";" in text else None
    ncols = len(tokens(text, delimiter))
    return Head(header, header_lines, comments, delimiter, ncols, pos, line_no)


def read_table(
    path: Path,
    data: bytes,
    what: str,
    context: Context = QUIET,
    head: Head | None = None,
    split: Sequence[int] | None = None,
) -> Table:
    """Parse a numeric text table: optional header lines, then rows of equally many numbers.

    Rows are separated by whitespace, or by commas (semicolons) when the first row holds
    one; ``#`` lines are comments anywhere; blank lines split the rows into blocks (scan
    lines). ``head``: the table's :func:`read_head`, when the caller has read it already;
    ``split``: the columns to put first, as in :func:`parse_rows`.
    """
    head = read_head(path, data, what) if head is None else head
    n = len(data)
    with context.stage("read", n) as stage:
        stage.update(head.start)
        rows = parse_rows(
            path,
            data,
            head.start,
            n,
            head.ncols,
            head.delimiter,
            head.line,
            f"{head.ncols} {{sep}}values as on line {head.line}",
            stage,
            split=split,
        )
    return Table(rows.values, rows.rest, rows.row_lines, rows.block_starts, head)


def row_error(path: Path, data: bytes, table: Table, row: int, message: str) -> FileFormatError:
    """A FileFormatError naming the line (and its text) of table row ``row``."""
    line = table.row_lines[row]
    newlines = np.flatnonzero(np.frombuffer(data, dtype=np.uint8) == 10)
    offset = 0 if line == 1 else int(newlines[line - 2]) + 1
    end = data.find(b"\n", offset)
    text = data[offset : end if end >= 0 else len(data)]
    return FileFormatError(f"{path}, line {line}: {message}: {quote(text)}")
