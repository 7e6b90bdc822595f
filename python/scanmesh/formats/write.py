"""Writing meshes and points without ever leaving a half-written file where one was.

The one writer rule (:func:`write_atomic`): a regular file (new or existing) is written to
a hidden temporary ``.<name>.*.part`` beside it and renamed over it, so a failure, Ctrl-C
or SIGTERM leaves neither a partial file nor a damaged old one (the temporary is removed);
a symbolic link to a regular file keeps being a link (the file it names is replaced); a
device, FIFO, socket or ``/proc`` file descriptor link (``/dev/null``, ``/dev/stdout``, a
named pipe) is written directly, never replaced by a regular file. The formats' encoders
live in :mod:`scanmesh.formats`.
"""

from __future__ import annotations

import os
import signal
import stat
import tempfile
import threading
from collections.abc import Iterable, Iterator
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import ArrayLike

from scanmesh._progress import Progress, Stage
from scanmesh.errors import ParameterError
from scanmesh.formats import MESH_FORMATS
from scanmesh.formats.xyz import xyz_rows

#: File endings we write meshes to, mapped to their format.
FORMATS = MESH_FORMATS

#: Points per block when formatting XYZ text (bounds the temporary strings' memory).
POINTS_PER_BLOCK: int = 1 << 16

#: Line ids must be below this in magnitude: text readers parse numbers as float64.
MAX_LINE_ID: int = 2**53

PathSpec = str | os.PathLike


def _same_file(a: Path, b: Path) -> bool:
    """True when two paths name one file (existing or not)."""
    try:
        return os.path.samefile(a, b)
    except OSError:
        return a.resolve() == b.resolve()


def _check_protected(target: Path, protect: PathSpec | Iterable[PathSpec] | None) -> None:
    """Refuse to write over any path in ``protect`` (the input files)."""
    if protect is None:
        return
    paths = [protect] if isinstance(protect, str | os.PathLike) else list(protect)
    for guarded in paths:
        if _same_file(target, Path(guarded)):
            raise ParameterError(
                f"refusing to write {target}: it is the input file {guarded}; choose another"
                " output path"
            )


def _umask() -> int:
    mask = os.umask(0)
    os.umask(mask)
    return mask


#: Permissions of new files: what ``open()`` would give (0o666 less the process umask);
#: ``mkstemp`` alone would leave every output readable by its owner only.
FILE_MODE = 0o666 & ~_umask()


class _Terminated(BaseException):
    """SIGTERM arrived while a temporary file was being written."""


class _TermGuard:
    """Within the block, SIGTERM raises ``_Terminated`` (so the temporary is removed) when
    the process would otherwise die at once (default handler, main thread); on leaving by
    ``_Terminated`` the default action is taken again, so the process still ends by SIGTERM."""

    def __enter__(self) -> _TermGuard:
        self.active = (
            threading.current_thread() is threading.main_thread()
            and signal.getsignal(signal.SIGTERM) is signal.SIG_DFL
        )
        if self.active:
            signal.signal(signal.SIGTERM, self._raise)
        return self

    @staticmethod
    def _raise(signum: int, frame: Any) -> None:
        raise _Terminated

    def __exit__(self, kind: type | None, *rest: object) -> None:
        if self.active:
            signal.signal(signal.SIGTERM, signal.SIG_DFL)
            if kind is _Terminated:
                os.kill(os.getpid(), signal.SIGTERM)


def _direct_target(target: Path) -> bool:
    """True when ``target`` must be written in place: it exists and is not a regular file
    (device, FIFO, socket), or it is a link into ``/proc`` (``/dev/stdout``)."""
    try:
        info = os.stat(target)
    except OSError:
        return False  # a new file (or a dangling link: replaced like a new file)
    if not stat.S_ISREG(info.st_mode):
        if stat.S_ISDIR(info.st_mode):
            raise ParameterError(f"cannot write {target}: it is a folder")
        return True
    hop = target
    for _ in range(40):  # the chain of links, hop by hop (resolve() would skip /proc)
        if not hop.is_symlink():
            return False
        hop = hop.parent / os.readlink(hop)
        if os.path.normpath(hop).startswith("/proc/"):
            return True  # /dev/stdout -> /proc/self/fd/1: the descriptor's own file
    return False


def write_atomic(path: PathSpec, chunks: Iterable[bytes | memoryview]) -> Path:
    """Write byte chunks to ``path`` by the writer rule of this module (atomic replace for
    regular files, in place for devices, FIFOs and pipes).

    Chunks may be any C-contiguous buffer (bytes, a memoryview of a numpy array), written
    as they are, without a copy.

    Returns
    -------
    Path
        ``path``.
    """
    target = Path(path)
    if _direct_target(target):
        with open(target, "wb") as handle:
            for chunk in chunks:
                handle.write(chunk)
        return target
    final = target.resolve() if target.is_symlink() and target.exists() else target
    folder = final.parent if str(final.parent) else Path(".")
    with _TermGuard():
        fd, tmp = tempfile.mkstemp(prefix=f".{final.name}.", suffix=".part", dir=folder)
        try:
            os.chmod(tmp, FILE_MODE)
            with os.fdopen(fd, "wb") as handle:
                for chunk in chunks:
                    handle.write(chunk)
                handle.flush()
                os.fsync(handle.fileno())
            os.replace(tmp, final)
        except BaseException:
            Path(tmp).unlink(missing_ok=True)
            raise
    return target


def vertex_normals(vertices: np.ndarray, faces: np.ndarray) -> np.ndarray:
    """(N, 3) unit vertex normals: the area-weighted sum of the adjacent faces' normals
    (faces counter-clockwise seen from the side they face); zero for an unused vertex.
    O(N + M)."""
    tri = vertices[faces]
    face_n = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])  # length: twice the area
    out = np.zeros_like(vertices)
    for k in range(3):
        np.add.at(out, faces[:, k], face_n)
    length = np.linalg.norm(out, axis=1, keepdims=True)
    np.divide(out, length, out=out, where=length > 0)
    return out


def save_mesh(
    path: PathSpec,
    vertices: np.ndarray,
    faces: np.ndarray,
    *,
    normals: bool | ArrayLike = False,
    protect: PathSpec | Iterable[PathSpec] | None = None,
    progress: Progress = False,
) -> Path:
    """Write a triangle mesh in the format of the file ending (.stl binary, .ply binary,
    .obj, .off), by the writer rule of :func:`write_atomic`, block by block (memory bounded
    whatever the mesh size; progress and Ctrl-C answer between blocks).

    Parameters
    ----------
    path : str or PathLike
        The output file.
    vertices : (N, 3) float
        Vertex positions (written with full float64 precision, except STL's float32).
    faces : (M, 3) int
        Triangles as vertex indices; vertex order and indices are kept.
    normals : bool or (N, 3) float
        Vertex normals to store (PLY, OBJ, OFF): True computes them
        (:func:`vertex_normals`), an array gives them.
    protect : path or iterable of paths, optional
        Files that must not be overwritten (the input): writing to one of them raises
        ``ParameterError`` before anything is written.
    progress : bool or callable
        True shows a progress bar; a callable taking ``stage=`` is called as
        ``progress(faces_done, faces_total, None, stage="write")`` (see ``reconstruct``).

    Returns
    -------
    Path
        ``path``.
    """
    target = Path(path)
    fmt = FORMATS.get(target.suffix.lower())
    if fmt is None:
        raise ParameterError(
            f"cannot write {target}: unknown ending {target.suffix!r}; use one of {sorted(FORMATS)}"
        )
    _check_protected(target, protect)
    verts = np.asarray(vertices, dtype=np.float64)
    tris = np.asarray(faces)
    if verts.ndim != 2 or verts.shape[1] != 3 or tris.ndim != 2 or tris.shape[1] != 3:
        raise ParameterError(
            f"need (N, 3) vertices and (M, 3) faces, got {verts.shape} and {tris.shape}"
        )
    if tris.size and (tris.dtype.kind not in "iu" or tris.min() < 0 or tris.max() >= len(verts)):
        raise ParameterError(f"faces must be integer indices into the {len(verts)} vertices")
    vn = None
    if normals is not False and normals is not None:
        if not fmt.normals:
            raise ParameterError(
                f"cannot store vertex normals in {target.suffix} files; use .ply, .obj or .off"
            )
        vn = (
            vertex_normals(verts, tris.astype(np.int64))
            if normals is True
            else np.asarray(normals, dtype=np.float64)
        )
        if vn.shape != verts.shape or not np.isfinite(vn).all():
            raise ParameterError(
                f"normals must be finite and shaped like the vertices {verts.shape}"
            )
    assert fmt.writer is not None
    with Stage(progress, "write", len(tris)) as stage:
        return write_atomic(target, fmt.writer(verts, tris, vn, stage))


def write_points(
    path: PathSpec,
    points: ArrayLike,
    line_ids: ArrayLike | None = None,
    *,
    up: ArrayLike | None = None,
    protect: PathSpec | Iterable[PathSpec] | None = None,
) -> Path:
    """Write points as XYZ text: a header row naming the columns (``x y z`` or
    ``x y z line``), then one row per point, by the writer rule of :func:`write_atomic`.

    Coordinates are written with 17 significant digits, so :func:`scanmesh.read` reads
    back exactly the same float64 values.

    Parameters
    ----------
    path : str or PathLike
        The output file (any ending; ``.xyz`` is conventional).
    points : (N, 3) float
        The points.
    line_ids : (N,) int, optional
        Scan-line id per point, written as a 4th column.
    up : (3,) float, optional
        The digitizer's up direction, recorded as a ``# scanmesh up x y z`` comment.
    protect : path or iterable of paths, optional
        Files that must not be overwritten (see :func:`save_mesh`).

    Returns
    -------
    Path
        ``path``.
    """
    target = Path(path)
    pts = np.asarray(points)
    if pts.ndim != 2 or pts.shape[1] != 3 or pts.dtype.kind not in "iuf":
        raise ParameterError(f"points must be an (N, 3) real array, got {pts.dtype} {pts.shape}")
    pts = pts.astype(np.float64)
    if not np.isfinite(pts).all():
        row = int(np.flatnonzero(~np.isfinite(pts).all(axis=1))[0])
        raise ParameterError(f"points[{row}] = {pts[row].tolist()} is not finite")
    ids = None
    if line_ids is not None:
        ids = np.asarray(line_ids)
        if ids.shape != (len(pts),) or (ids.size and ids.dtype.kind not in "iu"):
            raise ParameterError(
                f"line_ids must be ({len(pts)},) integers, one per point; got {ids.dtype}"
                f" {ids.shape}"
            )
        if ids.size and ids.dtype.kind == "u" and int(ids.max()) >= MAX_LINE_ID:
            raise ParameterError(f"line ids must be below 2**53, got {int(ids.max())}")
        ids = ids.astype(np.int64)
        if ids.size and int(np.abs(ids).max()) >= MAX_LINE_ID:
            raise ParameterError(
                f"line ids must be below 2**53 in magnitude to be read back exactly, got"
                f" {ids.min()}..{ids.max()}"
            )
    direction = None
    if up is not None:
        direction = np.asarray(up, dtype=np.float64)
        if direction.shape != (3,) or not np.isfinite(direction).all() or not direction.any():
            raise ParameterError(f"up must be a non-zero finite 3-vector, got {up!r}")
    _check_protected(target, protect)
    blocks: Iterator[bytes] = xyz_rows(pts, ids, POINTS_PER_BLOCK, direction)
    return write_atomic(target, blocks)
