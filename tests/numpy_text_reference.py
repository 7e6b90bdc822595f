"""The numpy text-table parser, kept as the tests' reference for ``_core.parse_text_table``.

It was the readers' parser before the native one reported where a chunk goes wrong; now
only the tests use it, to check the native parser value for value and refusal for refusal
(same rules: see rust/scanmesh-core/src/text.rs).
"""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np

from scanmesh.errors import FileFormatError
from scanmesh.formats._source import line_at as _line_at
from scanmesh.formats._source import quote as _quote

# A token that numpy's text parser and ours accept as one number.
_NUMBER = re.compile(
    rb"[+-]?(?:(?:\d+\.?\d*|\.\d+)(?:[eE][+-]?\d+)?|nan|inf|infinity)", re.IGNORECASE
)
# A line whose first token starts like a number is a data line, not a header.
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


def _token_counts(
    u: np.ndarray, ends: np.ndarray, sep: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """Token start offsets and tokens per line for a chunk of whole lines."""
    start_mask = ~sep
    start_mask[1:] &= sep[:-1]
    tok = np.flatnonzero(start_mask)
    counts = np.diff(np.searchsorted(tok, ends), prepend=0)
    return tok, counts


def numpy_chunk(
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
