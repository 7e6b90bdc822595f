"""A file being read: its bytes under one bound, and places in it named for messages.

The bound, used by every reader: a regular file is read up to its size, a pipe or FIFO
(``/dev/stdin`` in a pipeline) as it comes, chunk by chunk, and anything else (a device
such as ``/dev/zero``, a directory) is refused before a byte is read; and any count a file
declares (points, elements, records, cells, VLRs) is checked with :func:`check_declared`
against the bytes that are left before anything is allocated for it. Allocation so
follows bytes actually present, and the peak memory of a refused file stays a small
multiple of its size.
"""

from __future__ import annotations

import os
import re
import stat
import zlib
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from scanmesh._memory import memory_room
from scanmesh.errors import FileFormatError, MissingFileError

#: Bytes read from a pipe per call.
PIPE_CHUNK: int = 1 << 20


@dataclass(frozen=True)
class InputFile:
    """A file read as input, as it was when read: its absolute path (a later ``os.chdir``
    does not move it) and its (device, inode), None when it did not exist. Writers refuse
    to replace it by any alias (:func:`scanmesh.formats.write.check_not_input`)."""

    path: Path
    key: tuple[int, int] | None = None


def input_file(path: str | os.PathLike, record: bool = True) -> InputFile:
    """The :class:`InputFile` of ``path`` now (``record`` False: the path only)."""
    absolute = Path(os.path.abspath(path))
    if not record:
        return InputFile(absolute)
    try:
        info = os.stat(absolute)
    except OSError:
        return InputFile(absolute)
    return InputFile(absolute, (info.st_dev, info.st_ino))


def missing_file(path: Path) -> MissingFileError:
    """The error for an input ``path`` that does not exist (``filename`` set)."""
    error = MissingFileError(f"{path}: cannot read the file: No such file or directory")
    error.filename = str(path)
    return error


def check_regular(path: Path, pipes: bool = False) -> int:
    """The size of ``path`` in bytes (-1 for a pipe or FIFO when ``pipes``), or a
    FileFormatError when it is missing, unreadable or not a regular file (symbolic links
    are followed)."""
    try:
        info = os.stat(path)
    except FileNotFoundError as exc:
        raise missing_file(path) from exc
    except OSError as exc:
        raise FileFormatError(f"{path}: cannot read the file: {exc.strerror or exc}") from exc
    if pipes and stat.S_ISFIFO(info.st_mode):
        return -1
    if not stat.S_ISREG(info.st_mode):
        kind = (
            "a directory"
            if stat.S_ISDIR(info.st_mode)
            else "a FIFO"
            if stat.S_ISFIFO(info.st_mode)
            else "a device"
            if stat.S_ISCHR(info.st_mode) or stat.S_ISBLK(info.st_mode)
            else "not a regular file"
        )
        raise FileFormatError(
            f"{path}: cannot read the file: it is {kind}; scanmesh reads regular files only"
        )
    if not os.access(path, os.R_OK):
        raise FileFormatError(f"{path}: cannot read the file: permission denied")
    return info.st_size


#: The first bytes of a gzip stream.
GZIP_MAGIC: bytes = b"\x1f\x8b"

#: A byte other than NUL (gzip members may be followed by zero padding).
_NOT_NUL = re.compile(rb"[^\x00]")


def read_bytes(path: Path) -> bytes:
    """The content of the regular file, pipe or FIFO ``path`` (see :func:`check_regular`),
    decompressed when it is gzip-compressed (:func:`gunzip`)."""
    size = check_regular(path, pipes=True)
    try:
        with open(path, "rb") as handle:
            if size >= 0:
                data = handle.read(size)  # a file growing meanwhile is read up to its size
            else:
                chunks = []  # a pipe: memory follows what arrives
                while chunk := handle.read(PIPE_CHUNK):
                    chunks.append(chunk)
                data = b"".join(chunks)
    except OSError as exc:
        raise FileFormatError(f"{path}: cannot read the file: {exc.strerror or exc}") from exc
    return gunzip(path, data) if data.startswith(GZIP_MAGIC) else data


def inflate_limit() -> tuple[int, str]:
    """How many bytes a gzip file may decompress to, and why: half the memory this process
    may still take (:func:`scanmesh._memory.memory_room`: the physical memory, or what
    ``ulimit -v``, ``ulimit -d`` or a cgroup leave), since the pieces and their joined copy
    are held together."""
    room = memory_room()
    return room.bytes // 2, f"half of {room.limit}"


def gunzip(path: Path, data: bytes, limit: int | None = None) -> bytes:
    """The decompressed content of gzip ``data`` (every member, as ``gzip -d`` does), in
    chunks, refused (FileFormatError naming the file and the limit) when corrupt, truncated
    or larger than ``limit`` bytes (default :func:`inflate_limit`), so a compression bomb is
    refused as soon as it passes the limit instead of exhausting memory. O(output)."""
    why = "the limit given"
    if limit is None:
        limit, why = inflate_limit()
    out: list[bytes] = []
    # the input is fed PIPE_CHUNK bytes at a time: given all the rest, each call copied the
    # rest it left (its unconsumed_tail), quadratic (a 121 MB file: 27 s, 3 s in one call)
    view, start, total = memoryview(data), 0, 0
    try:
        while data.startswith(GZIP_MAGIC, start):
            inflate = zlib.decompressobj(wbits=31)
            fed = start
            pending = view[fed : fed + PIPE_CHUNK]
            fed += len(pending)
            while True:
                piece = inflate.decompress(pending, PIPE_CHUNK)
                total += len(piece)
                if total > limit:
                    raise FileFormatError(
                        f"{path}: the gzip-compressed file decompresses to more than"
                        f" {limit:,} bytes ({why}); decompress it first, or give the process"
                        " more memory"
                    )
                out.append(piece)
                pending = inflate.unconsumed_tail
                if inflate.eof:
                    break
                if not pending:
                    pending = view[fed : fed + PIPE_CHUNK]
                    fed += len(pending)
                    if not piece and not pending:
                        break
            if not inflate.eof:
                raise FileFormatError(
                    f"{path}: truncated gzip file (the stream ends after {len(data):,} bytes"
                    f" without its end marker)"
                )
            after = _NOT_NUL.search(data, fed - len(inflate.unused_data))  # zero padding
            start = len(data) if after is None else after.start()
    except zlib.error as exc:
        raise FileFormatError(f"{path}: corrupt gzip file: {exc}") from None
    if start < len(data):
        raise FileFormatError(f"{path}: trailing bytes after the gzip data (corrupt?)")
    return b"".join(out)


def is_gzip(path: Path) -> bool:
    """True when the regular file ``path`` starts with the gzip magic bytes."""
    try:
        with open(path, "rb") as handle:
            return handle.read(2) == GZIP_MAGIC
    except OSError:
        return False


def check_declared(
    path: Path, count: int, min_bytes: int, available: int, what: str, where: str = ""
) -> None:
    """Refuse a declared ``count`` of items of at least ``min_bytes`` bytes each when the
    ``available`` bytes cannot hold them (the one rule every reader applies before it
    allocates for a count read from the file). ``where`` (e.g. ", line 4") follows the path."""
    if count < 0:
        raise FileFormatError(f"{path}{where}: the file declares {count} {what}")
    if count * min_bytes > available:
        raise FileFormatError(
            f"{path}{where}: the file declares {count:,} {what}, which need at least"
            f" {count * min_bytes:,} bytes, but only {available:,} remain (truncated or"
            " corrupt?)"
        )


def quote(text: bytes | str, limit: int = 80) -> str:
    """Offending text for a message: decoded, stripped, shortened."""
    if isinstance(text, bytes):
        text = text.decode("utf-8", errors="replace")
    text = text.strip()
    return repr(text if len(text) <= limit else text[: limit - 3] + "...")


def line_at(data: bytes, offset: int) -> tuple[int, bytes]:
    """1-based line number and text of the line holding byte ``offset``."""
    offset = max(0, min(offset, len(data)))
    start = data.rfind(b"\n", 0, offset) + 1
    end = data.find(b"\n", offset)
    return data.count(b"\n", 0, offset) + 1, data[start : end if end >= 0 else len(data)]


def check_text(path: Path, data: bytes, what: str, start: int = 0) -> None:
    """Reject binary content (a NUL byte at or after ``start``) in a file that must be text."""
    nul = data.find(b"\x00", start)
    if nul >= 0:
        line, _ = line_at(data, nul)
        raise FileFormatError(
            f"{path}, line {line}: binary data (byte 0x00 at offset {nul}); {what} must be text"
        )


def check_finite(path: Path, points: np.ndarray, what: str = "point") -> None:
    """Raise naming the first non-finite coordinate of (N, 3) ``points``."""
    bad = ~np.isfinite(points)
    if bad.any():
        row, col = np.argwhere(bad)[0]
        raise FileFormatError(
            f"{path}: {what} {row} has a non-finite {'xyz'[col]}={float(points[row, col])!r}"
        )
