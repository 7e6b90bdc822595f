"""The scan as parts read on the workers: files (or a dask array's chunks) of whole lines.

A :class:`Part` names one file of consecutive, ordered scan lines and where its points sit
in the whole scan (global indices ``offset .. offset + count``); :func:`load_part` reads it
on a worker. The client only ever holds per-part and per-line summaries, never points.

Every stage after the listing reads each part again (a worker holds one part at a time, not
the scan), so the listing parses each file once and, unless it is already a ``.npy`` or
``.npz`` file with line ids, keeps its points and line ids as ``.npy`` files in a scratch
folder (:func:`summarize`): the later stages map those instead of parsing text, LAS or PLY
again, or detecting lines again.
"""

from __future__ import annotations

import glob
import os
import uuid
import warnings
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from scanmesh import _core, formats
from scanmesh.errors import FileFormatError, ParameterError, ScanmeshError
from scanmesh.formats.ply import PLY_TYPE_NAMES, ply_column
from scanmesh.formats.points import ScanPoints
from scanmesh.scan.plane_choice import choose_plane
from scanmesh.scan.projection import PlaneSpec, plane_args


@dataclass(frozen=True)
class Part:
    """One part of a scan: a file of consecutive scan lines, in scan order."""

    #: position among the scan's parts (0, 1, ...)
    index: int
    #: the file (any format :func:`scanmesh.read` takes), or None for no points
    path: str | None
    #: global index of its first point (points of earlier parts come first)
    offset: int
    #: number of points
    count: int
    #: folder of the part's points and line ids as .npy files (``points.npy``,
    #: ``line_ids.npy``), written when the file was first read; None: read the file
    cache: str | None = None


#: Line ids detected in a file without a line column, or given by its blank lines, are
#: numbered from ``index * LINE_STRIDE`` (files in order, lines in order: ascending over
#: the whole scan).
LINE_STRIDE: int = 1 << 32


def load_part(part: Part) -> tuple[np.ndarray, np.ndarray]:
    """Read a part on a worker: ``(points (n, 3) float64, line_ids (n,) int64)``.

    Line ids are the file's own (a line column, a PLY range grid, ...); a file without
    them gets its lines detected from its point order in its own least-squares plane
    (:func:`scanmesh.detect_lines`), numbered from ``part.index * LINE_STRIDE``. O(n).

    Raises FileFormatError for a file that is unreadable or whose point count differs from
    ``part.count`` (it changed since the scan was listed).
    """
    if part.path is None:
        return np.empty((0, 3)), np.empty(0, dtype=np.int64)
    if part.cache is not None:
        folder = Path(part.cache)
        return np.load(folder / "points.npy"), np.load(folder / "line_ids.npy")
    points, ids, _, _ = _read(part.path, part.index)
    if len(points) != part.count:
        raise FileFormatError(
            f"{part.path}: has {len(points)} points, {part.count} when the scan was listed"
        )
    return points, ids


def load_point_data(part: Part) -> dict[str, np.ndarray]:
    """A part's per-point values (``ScanPoints.point_data``: colours, intensity, ...) on a
    worker: from its cached copy, else from its file. O(n)."""
    if part.path is None:
        return {}
    if part.cache is not None:
        path = Path(part.cache) / "point_data.npz"
        if not path.exists():
            return {}
        with np.load(path, allow_pickle=False) as stored:
            return {name: stored[name] for name in stored.files}
    return _read(part.path, part.index)[3].point_data


def _read(path: str, index: int) -> tuple[np.ndarray, np.ndarray, bool, ScanPoints]:
    """A file's points and line ids, as :func:`load_part` describes them, whether reading
    them again costs more than mapping a copy (anything but a .npy/.npz file that holds
    its line ids), and what reading it gave (its per-point values, its georeference)."""
    scan = formats.read(path)  # looked up at call time: a worker may wrap it
    points = scan.points
    binary = Path(path).suffix.lower() in (".npy", ".npz")
    if scan.line_ids is not None:
        if scan.extra.get("line_ids_from") == "blank lines":  # numbered from 0 in each file
            return points, scan.line_ids + index * LINE_STRIDE, not binary, scan
        return points, scan.line_ids, not binary, scan
    if len(points) < 3:
        ids = np.full(len(points), index * LINE_STRIDE, dtype=np.int64)
        return points, ids, not binary, scan
    uv, _ = _core.project(points, "best-fit", None)
    ids = _core.detect_lines(uv, _core.DEFAULT_GAP_FACTOR) + index * LINE_STRIDE
    return points, ids, True, scan


@dataclass(frozen=True)
class PartSummary:
    """What the client learns of a part before reconstructing: sizes and bounds."""

    count: int
    #: (3,) lowest and highest coordinates (NaN for an empty part)
    lo: np.ndarray
    hi: np.ndarray
    #: first and last line id (0 for an empty part)
    first_line: int
    last_line: int
    #: whether line ids never decrease inside the part
    ordered: bool
    #: (S, 3) evenly strided points (for choosing the plane)
    sample: np.ndarray
    #: the folder its points and line ids were copied to (:attr:`Part.cache`), or None
    cache: str | None = None
    #: its per-point values' names and the PLY number type each is written in (numpy
    #: type strings, :func:`scanmesh.formats.ply.ply_column`), in the file's order
    point_data: tuple[tuple[str, str], ...] = ()
    #: its CRS and units as header comment lines (:meth:`Georef.comments`), or ()
    georef: tuple[str, ...] = ()


def summarize(path: str, index: int, sample: int, cache: str | None = None) -> PartSummary:
    """Read one file on a worker and summarize it (at most ``sample`` points kept). With a
    ``cache`` folder (shared with every worker), a file that is costly to read again is
    copied there as .npy files under ``part_<index>``. O(n)."""
    points, ids, costly, scan = _read(path, index)
    values = scan.point_data
    n = len(points)
    copy = None
    if cache is not None and costly:
        folder = Path(cache) / f"part_{index:06d}"
        folder.mkdir(exist_ok=True)  # a retried task writes the same bytes again
        np.save(folder / "points.npy", np.ascontiguousarray(points, dtype=np.float64))
        np.save(folder / "line_ids.npy", np.ascontiguousarray(ids, dtype=np.int64))
        if values:
            np.savez(folder / "point_data.npz", **values)
        copy = str(folder)
    step = max(1, -(-n // sample)) if sample > 0 else max(n, 1)
    return PartSummary(
        count=n,
        lo=points.min(axis=0) if n else np.full(3, np.nan),
        hi=points.max(axis=0) if n else np.full(3, np.nan),
        first_line=int(ids[0]) if n else 0,
        last_line=int(ids[-1]) if n else 0,
        ordered=bool(n < 2 or (np.diff(ids) >= 0).all()),
        sample=points[::step].copy(),
        cache=copy,
        point_data=tuple((k, ply_column(v).dtype.str) for k, v in values.items()),
        georef=tuple(scan.georef.comments()) if scan.georef is not None else (),
    )


def source_paths(source: str | os.PathLike | Sequence[str | os.PathLike]) -> list[str]:
    """The files of a source: a glob pattern (sorted), one path, or a list (kept in order)."""
    if isinstance(source, (str, os.PathLike)):
        text = os.fspath(source)
        paths = sorted(glob.glob(text)) if glob.has_magic(text) else [text]
        if not paths:
            raise ParameterError(f"source {text!r} matches no file")
    else:
        paths = [os.fspath(p) for p in source]
        if not paths:
            raise ParameterError("source is an empty list of files")
    missing = [p for p in paths if not Path(p).is_file()]
    if missing:
        raise FileFormatError(f"{missing[0]}: no such file")
    return paths


def list_parts(
    client: Any, paths: list[str], sample: int, cache: Path | None = None
) -> tuple[list[Part], list[PartSummary]]:
    """Summarize every file on the workers and number their points: the scan's parts.
    With a ``cache`` folder, files costly to read again are copied there (see
    :func:`summarize`) and the parts read the copies.

    Refuses line ids that decrease (inside a file, or from one file to the next: files are
    runs of consecutive lines, in order) with a ScanmeshError naming the file.
    """
    per_file = max(1, sample // max(len(paths), 1))
    futures = [
        client.submit(
            summarize,
            p,
            i,
            per_file,
            None if cache is None else str(cache),
            key=f"scanmesh-summary-{i}-{uuid.uuid4().hex}",
        )
        for i, p in enumerate(paths)
    ]
    summaries: list[PartSummary] = client.gather(futures)
    parts, offset, previous = [], 0, None
    for i, (path, s) in enumerate(zip(paths, summaries, strict=True)):
        if not s.ordered:
            raise ScanmeshError(
                f"{path}: line ids decrease inside the file; each file must hold whole scan"
                " lines in scan order"
            )
        if s.count and previous is not None and s.first_line <= previous[1]:
            raise ScanmeshError(
                f"{path}: its first line id ({s.first_line}) does not follow the last of"
                f" {previous[0]} ({previous[1]}): files must be runs of consecutive lines, in"
                " order, and no line may continue into the next file"
            )
        if s.count:
            previous = (path, s.last_line)
        parts.append(Part(i, path, offset, s.count, s.cache))
        offset += s.count
    if offset < 3:
        raise ScanmeshError(f"the scan has {offset} point(s); at least 3 are needed")
    return parts, summaries


def common_point_data(paths: list[str], summaries: list[PartSummary]) -> dict[str, str]:
    """The per-point values every part with points carries, each with the one PLY type
    that holds it in every part (numpy type strings; mixed integer types widen, to double
    when no PLY integer holds them all), in the first part's order. Values only some
    parts carry are left out with a warning naming the first file without them."""
    filled = [(p, s) for p, s in zip(paths, summaries, strict=True) if s.count]
    if not filled:
        return {}
    out: dict[str, str] = {}
    for name, _ in filled[0][1].point_data:
        types = [dict(s.point_data).get(name) for _, s in filled]
        if None in types:
            lacking = filled[types.index(None)][0]
            warnings.warn(
                f"{lacking} has no per-point {name!r} that {filled[0][0]} has: it is left out"
                " of the mesh",
                stacklevel=3,
            )
            continue
        common = np.result_type(*[np.dtype(t) for t in types])
        held = f"{common.kind}{common.itemsize}" in PLY_TYPE_NAMES
        out[name] = common.newbyteorder("<").str if held else "<f8"
    return out


def common_georef(paths: list[str], summaries: list[PartSummary]) -> tuple[str, ...]:
    """The CRS and units (header comment lines) the files with points record, when they all
    record the same; else none, with a warning naming the first file that differs."""
    filled = [(p, s.georef) for p, s in zip(paths, summaries, strict=True) if s.count]
    if not filled:
        return ()
    first = filled[0]
    for path, georef in filled[1:]:
        if georef != first[1]:
            warnings.warn(
                f"{path} records another CRS or units than {first[0]}: the mesh names none",
                stacklevel=3,
            )
            return ()
    return first[1]


def scan_bounds(summaries: list[PartSummary]) -> tuple[np.ndarray, np.ndarray]:
    """The whole scan's (3,) lowest and highest corners."""
    filled = [s for s in summaries if s.count]
    return (
        np.min([s.lo for s in filled], axis=0),
        np.max([s.hi for s in filled], axis=0),
    )


def resolve_plane(plane: PlaneSpec, summaries: list[PartSummary]) -> PlaneSpec:
    """A plane every worker projects onto alike: an axis name or a normal vector.

    None is chosen by the data as :func:`scanmesh.reconstruct` chooses it, on the parts'
    samples; "best-fit" (or that choice) is the least-squares normal of the samples.
    """
    if plane is not None and plane != "best-fit":
        plane_args(plane)  # refuses a bad spec here, with the usual message
        return plane
    sample = np.concatenate([s.sample for s in summaries if len(s.sample)])
    if plane is None:
        plane = choose_plane(sample).spec
        if plane != "best-fit":
            return plane
    _, frame = _core.project(sample, "best-fit", None)
    return tuple(float(x) for x in np.asarray(frame)[3])


def project_as_whole(
    points: np.ndarray, plane: PlaneSpec, lo: np.ndarray, hi: np.ndarray
) -> np.ndarray:
    """Planar coordinates (n, 2) of some of a scan's points, exactly as projecting the whole
    scan gives them: the frame's origin is the centre of the scan's bounding box, so the
    box's two corners are projected along (and dropped). O(n)."""
    name, normal = plane_args(plane)
    uv, _ = _core.project(np.concatenate([points, lo[None], hi[None]]), name, normal)
    return uv[: len(points)]


def store_chunks(client: Any, array: Any, line_ids: Any, folder: Path) -> list[str]:
    """Write a dask array source chunk by chunk, on the workers, as ``.npz`` files in
    ``folder`` (points (n, 3) and line ids (n,)); returns their paths in order.

    ``array`` is an (N, 3) dask array with ``line_ids`` an (N,) dask array, or an (N, 4)
    dask array (x, y, z, line id) with ``line_ids`` None. Chunks must split rows only.
    """
    if line_ids is None:
        if array.ndim != 2 or array.shape[1] != 4:
            raise ParameterError(
                f"a dask array source without line ids must be (N, 4) (x, y, z, line id),"
                f" got shape {array.shape}"
            )
        array = array.rechunk({1: 4})
        blocks = [(b, None) for b in array.to_delayed().ravel()]
    else:
        if array.ndim != 2 or array.shape[1] != 3 or line_ids.shape != (array.shape[0],):
            raise ParameterError(
                f"a dask array source must be (N, 3) points with (N,) line ids, got shapes"
                f" {array.shape} and {line_ids.shape}"
            )
        array = array.rechunk({1: 3})
        line_ids = line_ids.rechunk((array.chunks[0],))
        blocks = list(zip(array.to_delayed().ravel(), line_ids.to_delayed().ravel(), strict=True))
    folder.mkdir(parents=True, exist_ok=True)
    paths = [str(folder / f"chunk_{i:06d}.npz") for i in range(len(blocks))]
    futures = [
        client.compute(_delayed_store(points, ids, path))
        for (points, ids), path in zip(blocks, paths, strict=True)
    ]
    client.gather(futures)
    return paths


def _delayed_store(points: Any, ids: Any, path: str) -> Any:
    import dask  # the optional dask extra: absent on a core install

    return dask.delayed(_store)(points, ids, path)


def _store(points: np.ndarray, ids: np.ndarray | None, path: str) -> None:
    points = np.asarray(points)
    if ids is None:
        ids, points = points[:, 3], points[:, :3]
    ids = np.asarray(ids)
    if ids.dtype.kind == "f":
        if not np.array_equal(ids, np.round(ids)) or np.abs(ids).max(initial=0) >= 2**53:
            raise ScanmeshError(f"line ids must be integers, got {ids[:3]} ... in a chunk")
    with open(path, "wb") as handle:
        np.savez(handle, points=np.asarray(points, dtype=np.float64), line_ids=ids.astype(np.int64))
