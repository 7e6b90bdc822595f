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

import contextlib
import hashlib
import os
import re
import secrets
import signal
import stat
import threading
import time
from collections.abc import Iterable, Iterator, Mapping, Sequence
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import ArrayLike

from scanmesh import shape
from scanmesh._progress import Progress, Stage
from scanmesh.errors import ParameterError, ScanmeshError
from scanmesh.formats import MESH_FORMATS
from scanmesh.formats._source import InputFile, input_file
from scanmesh.formats.points import checked_point_data
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


def _names_input(target: Path, guarded: PathSpec | InputFile) -> bool:
    """True when ``target`` names the input ``guarded`` by any alias: the same absolute
    path, the same path once links are resolved, or (both existing) the same device and
    inode, now or as recorded when the input was read (a hard link, a moved file)."""
    given = guarded if isinstance(guarded, InputFile) else input_file(guarded, record=False)
    if Path(os.path.abspath(target)) == given.path:
        return True
    if Path(os.path.realpath(target)) == Path(os.path.realpath(given.path)):
        return True
    try:
        info = os.stat(target)
    except OSError:
        return False
    if given.key is not None and (info.st_dev, info.st_ino) == given.key:
        return True
    return _same_file(target, given.path)


def check_not_input(
    target: PathSpec, inputs: PathSpec | InputFile | Iterable[PathSpec | InputFile] | None
) -> None:
    """The one rule of every writer: refuse (ParameterError, before anything is written)
    an output that is one of the ``inputs`` by any alias (see :func:`_names_input`).
    Inputs are paths, or :class:`InputFile` records made when they were read (so a later
    ``os.chdir`` cannot make a relative output path miss them)."""
    if inputs is None:
        return
    single = isinstance(inputs, str | os.PathLike | InputFile)
    guarded_all = [inputs] if single else list(inputs)  # type: ignore[list-item]
    out = Path(target)
    for guarded in guarded_all:
        if _names_input(out, guarded):
            shown = guarded.path if isinstance(guarded, InputFile) else guarded
            raise ParameterError(
                f"refusing to write {out}: it is the input file {shown}; choose another output path"
            )


def inputs_of(mesh: Any) -> list[InputFile]:
    """The files a mesh was made from (a Surface's scan file, a merge's views), for
    :func:`check_not_input`."""
    made_from = list(getattr(mesh, "inputs", None) or [])
    scan = getattr(mesh, "scan", None)
    recorded = getattr(scan, "source_file", None)
    if isinstance(recorded, InputFile):
        return [recorded, *made_from]
    source = getattr(scan, "source", None)
    return made_from if source is None else [input_file(source), *made_from]


def refuse_remote(text: PathSpec, flag: str) -> None:
    """Refuse a remote URL (``s3://bucket/x.stl``) given for ``flag``: outputs are files."""
    if _URL.match(os.fspath(text)):
        raise ParameterError(
            f"{flag} {os.fspath(text)!r}: remote URLs are not supported; give a local path"
            " (or one on a mounted filesystem) and copy the file after"
        )


_URL = re.compile(r"^[A-Za-z][A-Za-z0-9+.-]*://")


class _Terminated(BaseException):
    """SIGTERM or SIGHUP arrived while a temporary file was being written."""

    def __init__(self, signum: int) -> None:
        super().__init__(signum)
        self.signum = signum


#: Signals that end the process by default and that a writer turns into cleanup first.
TERMINATING: tuple[signal.Signals, ...] = tuple(
    getattr(signal, name) for name in ("SIGTERM", "SIGHUP") if hasattr(signal, name)
)


class TermGuard:
    """Within the block, SIGTERM and SIGHUP raise ``_Terminated`` (so temporaries are
    removed) when the process would otherwise die at once (default handler, main thread);
    on leaving by ``_Terminated`` the default action is taken again, so the process still
    ends by that signal."""

    def __enter__(self) -> TermGuard:
        self.active: list[signal.Signals] = []
        if threading.current_thread() is threading.main_thread():
            self.active = [s for s in TERMINATING if signal.getsignal(s) is signal.SIG_DFL]
        for signum in self.active:
            signal.signal(signum, self._raise)
        return self

    @staticmethod
    def _raise(signum: int, frame: Any) -> None:
        raise _Terminated(signum)

    def __exit__(self, kind: type | None, error: BaseException | None, *rest: object) -> None:
        for signum in self.active:
            signal.signal(signum, signal.SIG_DFL)
        if isinstance(error, _Terminated):
            os.kill(os.getpid(), error.signum)


#: Bytes a temporary's name adds to its stem: ``.<pid>-<12 hex>.part`` and a margin.
TEMP_RESERVE: int = 32

#: When this module was imported: a temporary last written before then is no writer's of
#: this process.
_STARTED: float = time.time()

_TEMP_MIDDLE = re.compile(r"^[A-Za-z0-9_-]+$")


def _name_max(folder: Path) -> int:
    try:
        return int(os.pathconf(folder, "PC_NAME_MAX"))
    except (OSError, ValueError):
        return 255


def temporary_stem(final: Path) -> str:
    """What every temporary of ``final`` starts with: ``.<name>``, or, when a temporary
    name would exceed the folder's NAME_MAX, ``.<start of name>~<hash of name>``."""
    folder = final.parent if str(final.parent) else Path(".")
    raw = os.fsencode(final.name)
    limit = _name_max(folder) - TEMP_RESERVE
    if len(raw) + 1 <= limit:
        return f".{final.name}"
    digest = hashlib.sha256(raw).hexdigest()[:16]
    head = raw[: max(limit - len(digest) - 2, 0)].decode("utf-8", "ignore")
    return f".{head}~{digest}"


def temporary_name(final: Path) -> Path:
    """A new temporary's path beside ``final``: ``<stem>.<pid>-<random>.part``."""
    return final.parent / f"{temporary_stem(final)}.{os.getpid()}-{secrets.token_hex(6)}.part"


def create_temporary(final: Path) -> tuple[int, Path]:
    """Create a temporary for ``final`` (its descriptor, open for writing, and path).

    A new output gets what ``open()`` would give (0o666 less the umask current now: the
    kernel applies it, the process umask is never touched); a replaced file's mode, and
    its owner and group where permitted, are copied onto the temporary."""
    flags = os.O_WRONLY | os.O_CREAT | os.O_EXCL | getattr(os, "O_CLOEXEC", 0)
    for _ in range(100):
        tmp = temporary_name(final)
        try:
            fd = os.open(tmp, flags, 0o666)
            break
        except FileExistsError:
            continue
    else:
        raise FileExistsError(f"cannot create a temporary beside {final}")
    try:
        _keep_attributes(fd, final)
    except BaseException:
        os.close(fd)
        tmp.unlink(missing_ok=True)
        raise
    return fd, tmp


def _keep_attributes(fd: int, final: Path) -> None:
    """Give the temporary ``fd`` the mode, owner and group of the file it will replace."""
    try:
        old = os.stat(final)
    except OSError:
        return
    if not stat.S_ISREG(old.st_mode):
        return
    mine = os.fstat(fd)
    if (mine.st_uid, mine.st_gid) != (old.st_uid, old.st_gid):
        try:  # root can give the file back to its owner; others keep the group if theirs
            os.fchown(fd, old.st_uid, old.st_gid)
        except PermissionError:
            with contextlib.suppress(PermissionError):
                os.fchown(fd, -1, old.st_gid)
    os.fchmod(fd, stat.S_IMODE(old.st_mode))  # after chown, which may clear set-id bits


def remove_stale_temporaries(final: Path) -> None:
    """Remove temporaries of ``final`` (named as :func:`temporary_name` names them, or as
    earlier versions did: ``.<name>.<one word>.part``) last written before this process
    started and not held by a live process of this host: left by a killed writer."""
    folder = final.parent if str(final.parent) else Path(".")
    stem = temporary_stem(final) + "."
    try:
        entries = list(os.scandir(folder))
    except OSError:
        return
    for entry in entries:
        name = entry.name
        if not (name.startswith(stem) and name.endswith(".part")):
            continue
        middle = name[len(stem) : -len(".part")]
        if not _TEMP_MIDDLE.match(middle):
            continue  # another output's temporary (``a.ply`` against ``a.ply.b.ply``)
        with contextlib.suppress(OSError):
            if not entry.is_file(follow_symlinks=False) or entry.stat().st_mtime >= _STARTED:
                continue
            pid = middle.split("-", 1)[0]
            if "-" in middle and pid.isdigit() and _alive(int(pid)):
                continue
            os.unlink(entry.path)


def _alive(pid: int) -> bool:
    """True when another process ``pid`` runs on this host (or may: not ours to signal);
    False for this process's pid (a temporary written before it started: a reused pid)."""
    if pid == os.getpid():
        return False
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except (PermissionError, OverflowError):
        return True
    return True


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


def write_atomic(
    path: PathSpec,
    chunks: Iterable[bytes | memoryview],
    *,
    protect: PathSpec | InputFile | Iterable[PathSpec | InputFile] | None = None,
) -> Path:
    """Write byte chunks to ``path`` by the writer rule of this module (atomic replace for
    regular files, in place for devices, FIFOs and pipes).

    Chunks may be any C-contiguous buffer (bytes, a memoryview of a numpy array), written
    as they are, without a copy. ``protect``: the inputs ``path`` must not be
    (:func:`check_not_input`). A replaced file keeps its mode (and owner where permitted);
    stale temporaries of ``path`` are removed (:func:`remove_stale_temporaries`).

    Returns
    -------
    Path
        ``path``.
    """
    target = Path(path)
    check_not_input(target, protect)
    if _direct_target(target):
        with open(target, "wb") as handle:
            for chunk in chunks:
                handle.write(chunk)
        return target
    final = target.resolve() if target.is_symlink() and target.exists() else target
    with TermGuard():
        fd, tmp = create_temporary(final)
        try:
            with os.fdopen(fd, "wb") as handle:
                for chunk in chunks:
                    handle.write(chunk)
                handle.flush()
                os.fsync(handle.fileno())
            os.replace(tmp, final)
        except BaseException:
            tmp.unlink(missing_ok=True)
            raise
    remove_stale_temporaries(final)
    return target


def save_mesh(
    path: PathSpec,
    vertices: np.ndarray,
    faces: np.ndarray,
    *,
    normals: bool | ArrayLike = False,
    point_data: Mapping[str, ArrayLike] | None = None,
    comments: Sequence[str] = (),
    face_data: Mapping[str, ArrayLike] | None = None,
    protect: PathSpec | InputFile | Iterable[PathSpec | InputFile] | None = None,
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
        (:func:`scanmesh.shape.vertex_normals`, area-weighted), an array gives them.
    point_data : dict of name -> (N,) numbers, optional
        Per-vertex values to store as PLY vertex properties in their own number type
        (colours as uint8 ``red``, ``green``, ``blue``; scalars such as ``intensity``);
        PLY only.
    comments : sequence of str
        One-line ASCII header comments (PLY ``comment`` lines, OBJ ``#`` lines; such as
        :meth:`scanmesh.formats.georef.Georef.comments`); PLY and OBJ only.
    face_data : dict of name -> (M,) numbers, optional
        Per-face values to store as PLY face properties after ``vertex_indices`` (a
        surface's ``label``, say); PLY only.
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
    check_not_input(target, protect)
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
            shape.vertex_normals(verts, tris)
            if normals is True
            else np.asarray(normals, dtype=np.float64)
        )
        if vn.shape != verts.shape or not np.isfinite(vn).all():
            raise ParameterError(
                f"normals must be finite and shaped like the vertices {verts.shape}"
            )
    extra: dict[str, Any] = {}
    if point_data:
        if not fmt.point_data:
            raise ParameterError(
                f"cannot store per-vertex values in {target.suffix} files; use .ply"
            )
        try:
            columns = checked_point_data(point_data, len(verts))
        except ScanmeshError as exc:
            raise ParameterError(str(exc)) from None
        taken = {"x", "y", "z"} | ({"nx", "ny", "nz"} if vn is not None else set())
        if taken & set(columns):
            raise ParameterError(
                f"point_data names {sorted(taken & set(columns))} are the vertex coordinates"
                " or normals; rename them"
            )
        extra["point_data"] = columns
    if comments:
        if not fmt.comments:
            raise ParameterError(
                f"cannot store header comments in {target.suffix} files; use .ply or .obj"
            )
        bad = [c for c in comments if not c.isascii() or "\n" in c or "\r" in c]
        if bad:
            raise ParameterError(f"comments must be one-line ASCII texts, got {bad[0]!r}")
        extra["comments"] = list(comments)
    if face_data:
        if not fmt.point_data:
            raise ParameterError(f"cannot store per-face values in {target.suffix} files; use .ply")
        try:
            face_columns = checked_point_data(face_data, len(tris))
        except ScanmeshError as exc:
            raise ParameterError(
                str(exc).replace("point_data", "face_data").replace("per point", "per face")
            ) from None
        if "vertex_indices" in face_columns:
            raise ParameterError("face_data may not be named 'vertex_indices' (the faces)")
        extra["face_data"] = face_columns
    assert fmt.writer is not None
    with Stage(progress, "write", len(tris)) as stage:
        return write_atomic(target, fmt.writer(verts, tris, vn, stage, **extra))


def write_points(
    path: PathSpec,
    points: ArrayLike,
    line_ids: ArrayLike | None = None,
    *,
    up: ArrayLike | None = None,
    protect: PathSpec | InputFile | Iterable[PathSpec | InputFile] | None = None,
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
    check_not_input(target, protect)
    blocks: Iterator[bytes] = xyz_rows(pts, ids, POINTS_PER_BLOCK, direction)
    return write_atomic(target, blocks)
