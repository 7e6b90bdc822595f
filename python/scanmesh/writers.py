"""Writing meshes and points to disk atomically: a temporary file in the target folder, then a
rename, so a failure or an interruption never leaves a half-written file."""

from __future__ import annotations

import os
import struct
import tempfile
from collections.abc import Iterable, Iterator
from pathlib import Path

import numpy as np
from numpy.typing import ArrayLike

from scanmesh import _core
from scanmesh._progress import Progress, Stage
from scanmesh.errors import ParameterError

#: File endings we write, mapped to trimesh's export type.
FORMATS = {".stl": "stl", ".ply": "ply", ".obj": "obj", ".off": "off"}

#: Points per block when formatting XYZ text (bounds the temporary strings' memory).
POINTS_PER_BLOCK: int = 1 << 18

#: Triangles per block of a binary STL: each block's 50-byte records (26 MB) are encoded
#: natively and written before the next, so memory stays bounded however large the mesh
#: (20 million triangles would be 1 GB at once) and progress and Ctrl-C answer per block.
STL_FACES_PER_BLOCK: int = 1 << 19

#: One binary STL record: normal, three corners (float32, little-endian), attribute count.
STL_RECORD = np.dtype(
    [("normal", "<f4", (3,)), ("corners", "<f4", (3, 3)), ("attribute", "<u2")]
)

#: The 80-byte binary STL header (it must not start with "solid", the ASCII STL keyword).
STL_HEADER: bytes = b"binary STL written by scanmesh".ljust(80, b" ")

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
    """Refuse to write over any path in ``protect`` (the command's input files)."""
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


def write_atomic(path: str | os.PathLike, chunks: Iterable[bytes | memoryview]) -> Path:
    """Write byte chunks to a temporary file beside ``path``, then rename it over ``path``.

    Chunks may be any C-contiguous buffer (bytes, a memoryview of a numpy array), written
    as they are, without a copy.

    A failure or an interruption leaves neither a partial file nor a damaged old one.
    """
    target = Path(path)
    folder = target.parent if str(target.parent) else Path(".")
    fd, tmp = tempfile.mkstemp(prefix=f".{target.name}.", suffix=".part", dir=folder)
    try:
        os.chmod(tmp, FILE_MODE)
        with os.fdopen(fd, "wb") as handle:
            for chunk in chunks:
                handle.write(chunk)
            handle.flush()
            os.fsync(handle.fileno())
        os.replace(tmp, target)
    except BaseException:
        Path(tmp).unlink(missing_ok=True)
        raise
    return target


def _stl_blocks(vertices: np.ndarray, faces: np.ndarray, stage: Stage) -> Iterator[memoryview]:
    """Binary STL, block by block: header and count, then ``STL_FACES_PER_BLOCK`` records at
    a time, each block one native byte array written as it is (no per-face Python step).

    Normals are unit normals of the float64 triangles (zero for a degenerate one), as
    trimesh writes them; corners are rounded to float32 as STL stores them.
    """
    yield memoryview(STL_HEADER + struct.pack("<I", len(faces)))
    points = np.ascontiguousarray(vertices, dtype=np.float64)
    for start in range(0, len(faces), STL_FACES_PER_BLOCK):
        block = np.ascontiguousarray(faces[start : start + STL_FACES_PER_BLOCK], dtype=np.int64)
        # native: gather, float64 normal, float32 rounding in parallel without the GIL
        # (numpy took ~15 s for 20M faces, more than writing the 1 GB)
        yield memoryview(_core.stl_records(points, block))
        stage.update(start + len(block))


def save_mesh(
    path: PathSpec,
    vertices: np.ndarray,
    faces: np.ndarray,
    *,
    protect: PathSpec | Iterable[PathSpec] | None = None,
    progress: Progress = False,
) -> Path:
    """Write a triangle mesh in the format of the file ending (.stl binary, .ply, .obj, .off).

    Binary STL is written straight from numpy in blocks (memory bounded by
    ``STL_FACES_PER_BLOCK`` whatever the mesh size, no trimesh object); the other formats
    through trimesh. Either way atomically (:func:`write_atomic`).

    Parameters
    ----------
    path : str or PathLike
        The output file.
    vertices : (N, 3) float
        Vertex positions.
    faces : (M, 3) int
        Triangles as vertex indices; vertex order and indices are kept (``process=False``).
    protect : path or iterable of paths, optional
        Files that must not be overwritten (the command's input): writing to one of them
        raises ``ParameterError`` before anything is written.
    progress : bool or callable
        True shows a progress bar; a callable taking ``stage=`` is called as
        ``progress(faces_done, faces_total, None, stage="write")`` (see ``reconstruct``).

    Returns
    -------
    Path
        ``path``.
    """
    target = Path(path)
    kind = FORMATS.get(target.suffix.lower())
    if kind is None:
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
    with Stage(progress, "write", len(tris), blocking=kind != "stl") as stage:
        if kind == "stl":
            return write_atomic(target, _stl_blocks(verts, tris, stage))
        import trimesh

        mesh = trimesh.Trimesh(vertices=verts, faces=tris, process=False)
        data = mesh.export(file_type=kind)
        if isinstance(data, str):
            data = data.encode()
        return write_atomic(target, [data])


def write_points(
    path: PathSpec,
    points: ArrayLike,
    line_ids: ArrayLike | None = None,
    *,
    protect: PathSpec | Iterable[PathSpec] | None = None,
) -> Path:
    """Write points as XYZ text, one ``x y z`` (or ``x y z line_id``) row per point, atomically.

    Coordinates are written with 17 significant digits, so :func:`scanmesh.readers.read_xyz`
    reads back exactly the same float64 values.

    Parameters
    ----------
    path : str or PathLike
        The output file (any ending; ``.xyz`` is conventional).
    points : (N, 3) float
        The points.
    line_ids : (N,) int, optional
        Scan-line id per point, written as a 4th column.
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
        ids = ids.astype(np.int64)
        if ids.size and int(np.abs(ids).max()) >= MAX_LINE_ID:
            raise ParameterError(
                f"line ids must be below 2**53 in magnitude to be read back exactly, got"
                f" {ids.min()}..{ids.max()}"
            )
    _check_protected(target, protect)

    def blocks() -> Iterable[bytes]:
        row = "%.17g %.17g %.17g" + (" %d" if ids is not None else "") + "\n"
        for start in range(0, len(pts), POINTS_PER_BLOCK):
            block = pts[start : start + POINTS_PER_BLOCK]
            if ids is None:
                values = block.ravel().tolist()
            else:  # '%d' of a float holding an integer below 2**53 is exact
                line = ids[start : start + POINTS_PER_BLOCK].astype(np.float64)
                values = np.column_stack([block, line]).ravel().tolist()
            yield ((row * len(block)) % tuple(values)).encode("ascii")

    return write_atomic(target, blocks())
