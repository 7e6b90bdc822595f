"""Reconstruction on a Dask cluster, for scans larger than one machine's memory.

``pip install "scanmesh[dask]"``. The scan is a list (or glob) of files, each a run of
consecutive scan lines in scan order, or a dask array with line ids; the workers read it
part by part (:mod:`._source`), solve it (strip methods: partitions of consecutive lines,
:mod:`._strips`; Delaunay, LOP and annealing: tiles of the plane, :mod:`._tiles`) and write
the mesh block by block into one file renamed into place at the end (:mod:`._output`). No
process ever holds the whole scan or the whole mesh. The quality report is added up from
per-block sums (:mod:`._report`).
"""

from __future__ import annotations

import contextlib
import os
import shutil
import time
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from scanmesh._extras import require
from scanmesh.errors import DegenerateInputError, ParameterError
from scanmesh.formats.write import TermGuard, check_not_input
from scanmesh.methods import STRIP_METHODS, TILE_METHODS
from scanmesh.methods import method as find_method
from scanmesh.scan.projection import PlaneSpec

from ._output import StreamedMesh, Written, check_output, scratch_folder
from ._report import combine, report
from ._source import (
    common_georef,
    common_point_data,
    list_parts,
    resolve_plane,
    scan_bounds,
    source_paths,
    store_chunks,
)
from ._strips import strip_blocks
from ._tiles import tile_blocks

__all__ = ["DistributedResult", "reconstruct_distributed", "STRIP_METHODS"]

#: Points of the scan sampled (evenly over the parts) to choose the plane.
PLANE_SAMPLE: int = 200_000


@dataclass(frozen=True)
class DistributedResult:
    """What :func:`reconstruct_distributed` wrote and measured (the mesh is in the file)."""

    #: the mesh file written
    output: Path
    method: str
    n_points: int
    n_faces: int
    #: tac_1, tac_2, tac_inf, n_interior, min_angle_deg, sliver_fraction (as Quality)
    quality: dict[str, float | int]
    #: the method's options, the plane, and what the method reports (for strips: n_lines,
    #: n_strips, partitions, median_step, unused, duplicates, planar_valid, cost; for tiles:
    #: tiles, max_edge, for annealing tie_tolerance and (automatic) noise, for LOP and
    #: annealing initial_tac_1, the tiled Delaunay's; see :func:`._tiles.tile_blocks`)
    options: dict[str, Any] = field(default_factory=dict)
    #: wall seconds per stage (list, solve and write)
    timings: dict[str, float] = field(default_factory=dict)


def reconstruct_distributed(
    source: str | os.PathLike | Sequence[str | os.PathLike] | Any,
    method: str = "shortest-path",
    *,
    client: Any = None,
    output: str | os.PathLike,
    partition_lines: int | None = None,
    plane: PlaneSpec = None,
    progress: bool = False,
    **options: Any,
) -> DistributedResult:
    """Reconstruct a scan on a Dask cluster and write the mesh to ``output``.

    Parameters
    ----------
    source : str, path, list of paths, dask array or (dask array, dask array)
        Files (XYZ/CSV/PLY/NPY/NPZ/LAS, any :func:`scanmesh.read` takes), each a run of
        consecutive scan lines, in scan order: a glob pattern (files sorted by name) or a
        list (kept in its order). Or an (N, 4) dask array (x, y, z, line id), or a pair of
        an (N, 3) dask array and an (N,) dask array of line ids; its chunks are first
        stored by the workers as ``.npz`` files beside ``output``.
    method : str
        "shortest-path" or "lookahead" (strips), or "delaunay", "lop", "anneal" (tiles).
    client : distributed.Client, optional
        The cluster to run on; None starts a ``LocalCluster`` of processes (one thread
        each) for this call and closes it after.
    output : str or path
        ``.stl`` (binary) or ``.ply`` (binary; vertices are every scan point in scan order,
        with the per-point values every file carries (colours, intensity, ...) and the CRS
        and units they record, faces over those indices; no normals, tac or height, which
        :meth:`scanmesh.Surface.save` adds). Its folder must be visible to every worker at
        the same path (a shared filesystem); written atomically: a hidden temporary renamed
        at the end, nothing left behind on failure or Ctrl-C.
    partition_lines : int, optional
        Scan lines per strip partition (each partition starts on the next line that has
        strips on both sides and no lone point); None: one partition per file.
    plane : None, "best-fit", "x", "y", "z" or (3,) float
        Projection plane. None chooses it as :func:`scanmesh.reconstruct` does, on a sample
        of the scan (``PLANE_SAMPLE`` points); "best-fit" is that sample's least-squares
        plane.
    progress : bool
        Show Dask's progress bar on the terminal for every stage.
    **options
        The method's options (:data:`scanmesh.methods.TABLE`).

    Returns
    -------
    DistributedResult

    The strip methods give exactly the faces of ``scanmesh.reconstruct(points, method,
    lines=line_ids, plane=plane)`` on the whole scan (same plane), whatever the
    partitioning, listed partition by partition.
    """
    distributed = require("distributed", "dask", "reconstruct_distributed")
    target = check_output(output)
    # the files a pattern matches now are the inputs: the output may be none of them
    files = None if _is_dask_array(source) else source_paths(source)
    check_not_input(target, files)
    spec = find_method(method)
    if not spec.distributed:
        raise ParameterError(
            f"method {method!r} does not run on Dask; use one of {STRIP_METHODS + TILE_METHODS}"
        )
    if partition_lines is not None and (
        isinstance(partition_lines, bool)
        or not isinstance(partition_lines, int)
        or partition_lines < 1
    ):
        raise ParameterError(f"partition_lines must be an integer >= 1, got {partition_lines!r}")
    if partition_lines is not None and not spec.strips:
        raise ParameterError(
            f"partition_lines applies to the strip methods {STRIP_METHODS}; method {method!r}"
            " runs in tiles of the plane"
        )
    owned = None
    if client is None:
        owned = distributed.LocalCluster(processes=True, threads_per_worker=1)
        client = distributed.Client(owned)
    stored: Path | None = None
    # SIGTERM and SIGHUP, like Ctrl-C: the work cancelled, the temporaries removed
    with TermGuard():
        try:
            t0 = time.perf_counter()
            # the dask array's chunks, and copies of the files costly to read again (each
            # stage reads every part), go beside the output, visible to every worker
            stored = scratch_folder(target)
            if _is_dask_array(source):
                array, ids = source if isinstance(source, tuple) else (source, None)
                paths = store_chunks(client, array, ids, stored)
            else:
                assert files is not None
                paths = files
            parts, summaries = list_parts(client, paths, PLANE_SAMPLE, stored)
            lo, hi = scan_bounds(summaries)
            plane = resolve_plane(plane, summaries)
            t1 = time.perf_counter()
            columns = common_point_data(paths, summaries)
            mesh = StreamedMesh(client, target, parts, columns, common_georef(paths, summaries))
            seams: list[Any] = []
            try:
                if spec.strips:
                    blocks, seams, info = strip_blocks(
                        client,
                        parts,
                        method,
                        options,
                        plane=plane,
                        lo=lo,
                        hi=hi,
                        partition_lines=partition_lines,
                    )
                    for block in blocks:
                        mesh.add(block)
                    del blocks
                else:
                    # the tiles hand each block to the writer as it is submitted
                    _, info = tile_blocks(
                        client,
                        parts,
                        method,
                        options,
                        plane=plane,
                        progress=progress,
                        scratch=mesh.folder,
                        add=mesh.add,
                    )
                if progress:
                    distributed.progress([*mesh.blocks, *seams])
                seam_sums = client.gather(seams)
                t2 = time.perf_counter()
                written = mesh.finish(_turns)
            except BaseException:
                client.cancel([*mesh.blocks, *mesh.vertices, *seams])
                mesh.discard()
                raise
            t3 = time.perf_counter()
        finally:
            if owned is not None:
                client.close()
                owned.close()
            if stored is not None:
                shutil.rmtree(stored, ignore_errors=True)
    total = combine([*(w.sums for w in written), *seam_sums])
    n_faces = int(total.get("faces", 0))
    details = {key: int(total[key]) for key in ("n_strips", "unused", "duplicates") if key in total}
    if "planar_invalid" in total:
        details["planar_valid"] = (
            total["planar_invalid"] == 0 if options.get("check", True) else None
        )
    if "cost" in total:
        details["cost"] = total["cost"]
    if "initial_tac_1" in total:
        details["initial_tac_1"] = total["initial_tac_1"]
    return DistributedResult(
        output=target,
        method=method,
        n_points=sum(p.count for p in parts),
        n_faces=n_faces,
        quality=report(total),
        options={"plane": plane, **info, **details},
        timings={"list": t1 - t0, "solve": t2 - t1, "write": t3 - t2},
    )


def _turns(written: list[Written]) -> list[bool]:
    """Which blocks to turn round: strip blocks whose own orientation (the sign of their
    planar area) differs from the whole scan's. Raises DegenerateInputError, as
    :func:`scanmesh.reconstruct` does, when strip blocks came but no strip was built."""
    strips = [w.sums["signed_area"] for w in written if w.turn_key == "strips"]
    if strips and not sum(w.sums["n_strips"] for w in written if w.turn_key == "strips"):
        raise DegenerateInputError(
            "no strip to build: need two neighbouring scan lines with two points each that"
            " overlap along the scan direction"
        )
    whole_negative = sum(strips) < 0
    return [
        w.turn_key == "strips" and (w.sums["signed_area"] < 0) != whole_negative for w in written
    ]


def _is_dask_array(source: Any) -> bool:
    with contextlib.suppress(ImportError):
        import dask.array as da  # the optional dask extra: absent on a core install

        if isinstance(source, tuple):
            return len(source) == 2 and all(isinstance(a, da.Array) for a in source)
        return isinstance(source, da.Array)
    return False
