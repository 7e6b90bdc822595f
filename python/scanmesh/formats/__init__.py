"""File formats: one module per format, and the table that picks one by ending or content.

Readers (each returns :class:`ScanPoints`):

- ``.xyz``, ``.txt``, ``.asc`` - :mod:`.xyz`: text rows, whitespace-, comma- or
  semicolon-separated, columns by header, by ``columns=`` or by position; an ``.asc``
  whose header starts with ``ncols`` is an ESRI ASCII grid (:mod:`.grid`);
- ``.csv`` - :mod:`.csv`: comma-separated rows with an optional header;
- ``.ply`` - :mod:`.ply`: ASCII or binary PLY, a ``range_grid``'s frames as scan lines;
- ``.npy``, ``.npz`` - :mod:`.npy`: numpy arrays, never unpickled;
- ``.vtk`` - :mod:`.vtk`: legacy VTK POLYDATA, UNSTRUCTURED_GRID or STRUCTURED_GRID;
- ``.dem`` - :mod:`.dem`: USGS ASCII DEM, one scan line per profile;
- ``.pts`` - :mod:`.pts`: Leica/CloudCompare PTS text, intensity and colours kept;
- ``.pcd`` - :mod:`.pcd`: PCL point clouds, ASCII or binary, an organized cloud's rows as
  scan lines;
- ``.las``, ``.laz`` - :mod:`.las`: LiDAR through laspy (``pip install scanmesh[las]``);
- ``.e57`` - :mod:`.e57`: laser scans through pye57 (``pip install scanmesh[e57]``);
- ``.stl``, ``.obj``, ``.off`` - :mod:`.mesh_points`: a mesh's distinct vertices, its faces
  ignored (a PLY mesh's vertices are read by :mod:`.ply`);
- any text or ``.npy`` matrix of heights with ``grid=True`` (:mod:`.grid`).

Text, PLY, VTK, DEM, PTS and PCD files may be gzip-compressed (``scan.ply.gz``): they are
decompressed as read. Per-point values a file carries (PLY vertex properties, PTS and PCD
intensity and colours) come as ``ScanPoints.point_data`` and are written to PLY meshes.

A file with an unknown ending is recognised by its first bytes (PLY, VTK, NPY, NPZ, LAS,
ESRI grid, PCD). Mesh writers (each a generator of byte chunks for
:func:`scanmesh.formats.write.write_atomic`): ``.stl`` binary (:mod:`.stl`), ``.ply`` binary
(:mod:`.ply`), ``.obj`` (:mod:`.obj`), ``.off`` (:mod:`.off`).

Every problem with a file is a :class:`~scanmesh.errors.FileFormatError` naming the file
and, for text, the line; every reader reads regular files only and checks what a file
declares against its size before allocating (:mod:`._source`).
"""

from __future__ import annotations

import gzip
import os
import zlib
from collections.abc import Callable, Iterator
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from scanmesh._context import Context
from scanmesh._progress import Progress
from scanmesh.errors import FileFormatError, ParameterError
from scanmesh.formats._source import GZIP_MAGIC, check_regular, is_gzip
from scanmesh.formats.csv import read_csv
from scanmesh.formats.dem import read_dem
from scanmesh.formats.e57 import E57_MAGIC, read_e57
from scanmesh.formats.grid import Cell, height_grid, is_esri_ascii, read_esri_ascii, read_matrix
from scanmesh.formats.las import read_las
from scanmesh.formats.mesh_points import read_mesh_points
from scanmesh.formats.npy import read_npy
from scanmesh.formats.obj import obj_chunks
from scanmesh.formats.off import off_chunks
from scanmesh.formats.pcd import read_pcd
from scanmesh.formats.ply import ply_chunks, read_ply
from scanmesh.formats.points import ScanPoints, count_lines
from scanmesh.formats.pts import read_pts
from scanmesh.formats.stl import stl_chunks
from scanmesh.formats.vtk import read_vtk
from scanmesh.formats.xyz import Columns, read_xyz

#: A mesh writer: (vertices, faces, vertex normals or None, stage) -> byte chunks.
MeshWriter = Callable[..., Iterator[Any]]


@dataclass(frozen=True)
class Format:
    """One file format: its endings, how to recognise its content, its reader and writer."""

    name: str
    endings: tuple[str, ...]
    #: the first bytes of such a file, when they identify it
    magic: bytes | None
    #: reads scan points (None: a mesh-only format)
    reader: Callable[..., ScanPoints] | None
    #: reader keywords besides ``context`` (the call's progress, given through ``read``)
    options: tuple[str, ...]
    #: writes meshes (None: points only)
    writer: MeshWriter | None
    #: the writer stores vertex normals
    normals: bool = False
    #: the writer stores per-vertex values (``point_data=``: colours, scalars)
    point_data: bool = False
    #: the writer stores header comments (``comments=``: the georeference)
    comments: bool = False


#: Every format, in the order the content check tries them.
FORMATS: tuple[Format, ...] = (
    Format("ply", (".ply",), b"ply", read_ply, ("lines",), ply_chunks, True, True, True),
    Format("vtk", (".vtk",), b"# vtk DataFile", read_vtk, (), None),
    Format("npy", (".npy", ".npz"), b"\x93NUMPY", read_npy, (), None),
    Format("npz", (), b"PK\x03\x04", read_npy, (), None),
    Format("las", (".las", ".laz"), b"LASF", read_las, ("returns", "classes"), None),
    Format("xyz", (".xyz", ".txt", ".asc"), None, read_xyz, ("columns", "decimal"), None),
    Format("csv", (".csv",), None, read_csv, ("columns", "decimal"), None),
    Format("dem", (".dem",), None, read_dem, (), None),
    Format("pts", (".pts",), None, read_pts, (), None),
    Format("pcd", (".pcd",), b"# .PCD", read_pcd, (), None),
    Format("e57", (".e57",), E57_MAGIC, read_e57, (), None),
    Format("stl", (".stl",), None, read_mesh_points, (), stl_chunks),
    Format("obj", (".obj",), None, read_mesh_points, (), obj_chunks, True, comments=True),
    Format("off", (".off",), None, read_mesh_points, (), off_chunks, True),
)

_ESRI = Format("esri ascii grid", (), None, read_esri_ascii, ("cell",), None)

#: File ending (lower case) -> reader.
READERS: dict[str, Callable[..., ScanPoints]] = {
    e: f.reader for f in FORMATS if f.reader is not None for e in f.endings
}

#: File ending (lower case) -> format of the meshes written there.
MESH_FORMATS: dict[str, Format] = {e: f for f in FORMATS if f.writer is not None for e in f.endings}

_TAKES_CONTEXT = (read_xyz, read_csv, read_ply, read_pts, read_pcd, read_e57)


#: Formats whose readers decompress a gzip-compressed file (those reading it as bytes).
GZIP_READABLE: frozenset[str] = frozenset(
    {"ply", "vtk", "xyz", "csv", "dem", "pts", "pcd", "esri ascii grid"}
)


def _by_content(path: Path) -> Format | None:
    """The format whose magic bytes open ``path`` (or an ESRI grid header; the first
    decompressed bytes of a gzip file), else None."""
    with open(path, "rb") as handle:
        head = handle.read(64)
        if head.startswith(GZIP_MAGIC):
            handle.seek(0)
            try:
                with gzip.GzipFile(fileobj=handle) as inner:
                    head = inner.read(64)
            except (OSError, EOFError, zlib.error):
                return None  # the reader reports the corrupt stream
    for fmt in FORMATS:
        if fmt.magic is not None and head.startswith(fmt.magic):
            return fmt
    return _ESRI if is_esri_ascii(head) else None


def format_of(path: str | os.PathLike) -> Format:
    """The format ``read`` uses for ``path``: by ending, then (for ``.asc`` and unknown
    endings) by content."""
    target = Path(path)
    fmt = _format_of(target)
    if fmt.name not in GZIP_READABLE and (
        target.suffix.lower() == ".gz" or (target.is_file() and is_gzip(target))
    ):
        raise FileFormatError(
            f"{target}: a gzip-compressed {fmt.name} file cannot be read; decompress it first"
            f" (gzip-compressed {', '.join(sorted(GZIP_READABLE))} files are read as they are)"
        )
    return fmt


def _format_of(target: Path) -> Format:
    """:func:`format_of` before the gzip check: ``name.ext.gz`` is judged as ``name.ext``."""
    ending = target.suffix.lower()
    if ending == ".gz":
        ending = Path(target.stem).suffix.lower()
    known = [f for f in FORMATS if ending in f.endings and f.reader is not None]
    if known and ending != ".asc":
        return known[0]
    # a pipe cannot be looked into and read again: its ending decides
    found = _by_content(target) if check_regular(target, pipes=True) >= 0 else None
    if found is not None and (not known or found is _ESRI):
        return found
    if known:
        return known[0]
    raise FileFormatError(
        f"{target}: unknown file ending {target.suffix!r} and content; readable endings are"
        f" {', '.join(sorted(READERS))} (and those of text and PLY files with .gz added)"
    )


def read(
    path: str | os.PathLike,
    *,
    progress: Progress = False,
    grid: bool = False,
    cell: Cell = None,
    **options: Any,
) -> ScanPoints:
    """Read scan points, choosing the reader by the file ending (any case) or content.

    Parameters
    ----------
    path : str or PathLike
        The file.
    progress : bool or callable
        True shows a progress bar; a callable taking ``stage=`` is called as
        ``progress(bytes_done, bytes_total, None, stage="read")`` (see ``reconstruct``). Text
        files report after every chunk, other formats once at the start and once at the end.
    grid : bool
        Read a text, CSV or ``.npy`` matrix of heights, each row a scan line
        (:mod:`scanmesh.formats.grid`); ESRI ASCII grids are recognised without it.
    cell : float or (dx, dy), optional
        Cell size of a height grid (default 1, or an ESRI grid's ``cellsize``).
    **options
        The format's own options: ``columns=`` for text point files (e.g. ``"x,y,z,line"``
        or ``(0, 1, 2, 5)``) and ``decimal=","`` for their decimal commas, ``returns=`` /
        ``classes=`` for LAS, ``lines=`` for a PLY range grid. An option the format does
        not take is refused.

    Returns
    -------
    ScanPoints
    """
    target = Path(path)
    context = Context.of(progress)
    if grid:
        if options:
            raise ParameterError(
                f"grid=True reads a matrix of heights and takes only cell=, not"
                f" {', '.join(f'{k}=' for k in sorted(options))}"
            )
        return read_matrix(target, cell=cell, context=context)
    fmt = format_of(target)
    taken = set(fmt.options)
    unknown = sorted(set(options) - taken)
    if cell is not None and fmt is not _ESRI:
        unknown.append("cell")
    if unknown:
        raise ParameterError(
            f"{', '.join(f'{k}= (--{k})' for k in unknown)} does not apply to {fmt.name}"
            f" files ({target.name}); {fmt.name} takes"
            f" {', '.join(f'{k}= (--{k})' for k in fmt.options) or 'no options'}"
            + (" (grid=True reads a matrix of heights)" if "cell" in unknown else "")
        )
    if fmt is _ESRI:
        options["cell"] = cell
    assert fmt.reader is not None
    if fmt.reader in _TAKES_CONTEXT:
        return fmt.reader(target, context=context, **options)
    try:
        size = target.stat().st_size
    except OSError:
        size = 0  # the reader reports the missing file
    with context.stage("read", size, blocking=True):
        return fmt.reader(target, **options)


__all__ = [
    "ScanPoints",
    "count_lines",
    "read",
    "format_of",
    "height_grid",
    "read_xyz",
    "read_csv",
    "read_ply",
    "read_npy",
    "read_vtk",
    "read_dem",
    "read_las",
    "read_esri_ascii",
    "read_pts",
    "read_pcd",
    "read_e57",
    "read_mesh_points",
    "read_matrix",
    "Columns",
    "Format",
    "FORMATS",
    "READERS",
    "MESH_FORMATS",
]
