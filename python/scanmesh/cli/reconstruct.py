"""``scanmesh reconstruct``: one method on one scan file, in this process or on a Dask
cluster, with an optional JSON report and PNG preview."""

from __future__ import annotations

import argparse
import contextlib
import logging
import signal
import threading
import time
import warnings
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import Any

import numpy as np

from scanmesh import __version__
from scanmesh._extras import require
from scanmesh._progress import Stage
from scanmesh.cli._args import (
    _method_options,
    _read_options,
    _refuse_stray_flags,
    _shared,
    chosen_method,
)
from scanmesh.cli._common import (
    _background,
    _check_outputs,
    _check_png,
    _Console,
    _dumps,
    _fmt,
    _plural,
    _seconds,
    _write_text,
)
from scanmesh.distributed import reconstruct_distributed
from scanmesh.distributed._source import source_paths
from scanmesh.errors import ScanmeshWarning
from scanmesh.evaluate.truth import TrueSurface
from scanmesh.formats import MESH_FORMATS as FORMATS
from scanmesh.formats import count_lines
from scanmesh.formats.georef import Georef
from scanmesh.formats.write import TermGuard
from scanmesh.present.render import auto_view as _auto_view
from scanmesh.present.render import render_mesh
from scanmesh.reconstruction import reconstruct
from scanmesh.scan.planar import planar_scan
from scanmesh.surface import check_ending


def cmd_reconstruct(args: argparse.Namespace, con: _Console) -> int:
    """Read scan points, triangulate them, write the mesh (and a report and a preview)."""
    args.method = chosen_method(args, dask=args.dask is not None)
    if args.dask is not None:
        return _reconstruct_on_dask(args, con)
    if args.workers is not None or args.partition_lines is not None:
        flag = "--workers" if args.workers is not None else "--partition-lines"
        args._parser.error(f"{flag} applies with --dask only")
    source, out = Path(args.input), Path(args.output)
    report = Path(args.report) if args.report else None
    preview = Path(args.preview) if args.preview else None
    _refuse_stray_flags(args, [args.method])
    options = _method_options(args, args.method)
    shared = _shared(args, args.method, options)
    truth_path = Path(args.truth) if args.truth else None
    _check_outputs([source, *([truth_path] if truth_path else [])], [out, report, preview])
    if truth_path is not None and out.suffix.lower() != ".ply":
        args._parser.error(f"--truth adds each vertex's error to a .ply output, not to {out}")
    con.report = "--report" if report is not None else "--json output" if con.json else ""
    check_ending(out)
    _check_png(preview)
    if preview is None and (args.view is not None or args.up is not None):
        flag = "--view" if args.view is not None else "--up"
        args._parser.error(f"{flag} sets the --preview camera: give --preview P.png too")

    truth = None if truth_path is None else TrueSurface(truth_path)  # a bad part: before work
    scan = planar_scan(
        source, plane=args.plane, progress=con.progress, read_options=_read_options(args)
    )
    t1 = time.perf_counter()
    surface = reconstruct(scan, args.method, progress=con.progress, **shared, **options)
    elapsed = time.perf_counter() - t1
    if truth is not None:  # measured once, for the PLY and the report
        surface.point_data["error"] = truth.distance(surface.vertices)
    t2 = time.perf_counter()
    # The quality report (tac over every vertex: 4 s of CPU at 10M points) is measured
    # while the mesh is written: both release the GIL, so they overlap.
    measured = _background(lambda: _seconds(lambda: surface.quality)) if args.quality else None
    # a PLY holds the normals, tac, height (and error) and the file's per-point values
    surface.save(out, tac=args.quality, progress=con.progress)  # --no-quality: no tac
    t_write = time.perf_counter() - t2
    t_quality = _wait_quality(measured, con, out, len(surface.faces))
    data = _report(source, out, scan, surface, con, elapsed, t_quality is not None)
    if truth is not None:
        error = surface.point_data["error"][np.unique(surface.faces)]
        data["vertex_error"] = {
            "truth": str(truth_path),
            "rms": float(np.sqrt(np.mean(error**2))),
            "max": float(error.max()),
        }
    data["timings"]["write"] = t_write
    if t_quality is not None:
        data["timings"]["quality"] = t_quality  # beside the write, not after it
    if report is not None:
        _write_text(report, _dumps(data) + "\n")
    if preview is not None:
        with Stage(con.progress, "preview", len(surface.faces), blocking=True):
            camera = _auto_view(surface.vertices, surface.faces, surface.frame)
            if args.view is not None:
                camera["view"] = args.view
            if args.up is not None:
                camera["up"] = args.up
            render_mesh(surface, preview, **camera)
    if con.json:
        print(_dumps(data))
        return 0
    q = data["quality"]
    counts = data["counts"]
    lines = f" on {_plural(counts['lines'], 'line')}" if counts["lines"] else ""
    con.summary(f"{source}: {_plural(counts['points'], 'point')}{lines}")
    con.summary(f"{surface.method}: {_plural(counts['faces'], 'face')} in {elapsed:.2f} s")
    if q is None:
        why = "--no-quality" if not args.quality else "out of memory"
        con.summary(f"  quality not measured ({why})")
    else:
        con.summary(
            f"  tac_1 {q['tac_1']:.4g}  tac_2 {q['tac_2']:.4g}  tac_inf {q['tac_inf']:.4g}"
            f"  smallest angle {_fmt(q['min_angle_deg'], '.2f')} deg"
            f"  slivers {100 * q['sliver_fraction']:.2f} %"
        )
    written = [str(out)] + [str(p) for p in (report, preview) if p is not None]
    con.summary(f"wrote {', '.join(written)}")
    return 0


def _wait_quality(
    measured: Callable[[], float] | None, con: _Console, out: Path, faces: int
) -> float | None:
    """Seconds the background quality measure took; None when not measured (--no-quality)
    or, with a warning, when it ran out of memory: the mesh is written and whole by then,
    so the run succeeds and the report says ``"quality": null``."""
    if measured is None:
        return None
    with Stage(con.progress, "quality", faces, blocking=True):
        try:
            return measured()
        except MemoryError as exc:  # MemoryLimitError too
            what = " ".join(str(exc).split()) or "an allocation failed"
            warnings.warn(
                f"the quality was not measured (out of memory: {what}); {out} is written",
                ScanmeshWarning,
                stacklevel=2,
            )
            return None


@contextlib.contextmanager
def _quiet_distributed() -> Iterator[None]:
    """distributed's own log records ("Compute Failed" with the worker's traceback, workers
    lost while closing) kept from the terminal for the run: the command reports a failure
    or an interrupt in one line."""
    loggers = [logging.getLogger(name) for name in ("distributed", "asyncio")]
    levels = [logger.level for logger in loggers]
    for logger in loggers:
        logger.setLevel(logging.CRITICAL + 1)
    try:
        yield
    finally:
        for logger, level in zip(loggers, levels, strict=True):
            logger.setLevel(level)


def _local_cluster(distributed: Any, workers: int | None) -> Any:
    """A LocalCluster (HTTP on a free port) whose worker processes log nothing and ignore SIGINT:
    Ctrl-C at the terminal reaches the whole process group, and workers that die of it
    print their tracebacks and hold up the closing; this process cancels the work and
    closes them."""
    in_main = threading.current_thread() is threading.main_thread()
    previous = signal.signal(signal.SIGINT, signal.SIG_IGN) if in_main else None
    try:  # ignored signals stay ignored in the processes started meanwhile
        return distributed.LocalCluster(
            n_workers=workers,
            threads_per_worker=1,
            processes=True,
            silence_logs=logging.CRITICAL + 1,
            # the scheduler's HTTP server on a free port: 8787 taken by another cluster
            # gave warnings (and None still tries 8787)
            dashboard_address=":0",
        )
    finally:
        if previous is not None:
            signal.signal(signal.SIGINT, previous)


def _reconstruct_on_dask(args: argparse.Namespace, con: _Console) -> int:
    """``reconstruct --dask``: the scan files (IN may be a glob) on a Dask cluster, the mesh
    written block by block by the workers (:func:`scanmesh.distributed.reconstruct_distributed`)."""
    distributed = require("distributed", "dask", "--dask")
    out = Path(args.output)
    report = Path(args.report) if args.report else None
    given_flags = (
        ("--preview", args.preview),
        ("--view", args.view is not None),
        ("--up", args.up is not None),
        ("--no-quality", not args.quality),
        ("--truth", args.truth),
    )
    for flag, given in (*given_flags, *((f, True) for f in _read_flags(args))):
        if given:
            args._parser.error(f"{flag} cannot be used with --dask")
    if args.dask != "local" and args.workers is not None:
        args._parser.error("--workers applies with --dask local only (a cluster has its own)")
    if out.suffix.lower() not in (".stl", ".ply"):
        args._parser.error(f"--dask writes .stl or .ply (block by block), not {out}")
    _refuse_stray_flags(args, [args.method])
    options = _method_options(args, args.method)
    shared = _shared(args, args.method, options)
    # every file the pattern matches now is an input: none may be an output
    _check_outputs([Path(p) for p in source_paths(args.input)], [out, report])
    progress = con.progress is True and not con.json  # bars only: tasks on workers
    # SIGTERM and SIGHUP close the cluster before the process ends by them
    with TermGuard(), _quiet_distributed():
        if args.dask == "local":
            cluster = _local_cluster(distributed, args.workers)
            client = distributed.Client(cluster)
        else:
            cluster, client = None, distributed.Client(args.dask)
        try:
            result = reconstruct_distributed(
                args.input,
                args.method,
                client=client,
                output=out,
                partition_lines=args.partition_lines,
                plane=args.plane,
                progress=progress,
                **shared,
                **options,
            )
        finally:
            client.close()
            if cluster is not None:
                cluster.close()
    data = {
        "input": args.input,
        "output": str(out),
        "method": result.method,
        "dask": args.dask,
        "options": result.options,
        # at the top level too, as in the one-process report (annealing measures it)
        "noise": result.options.get("noise"),
        "timings": result.timings,
        "quality": result.quality,
        "counts": {"points": result.n_points, "faces": result.n_faces},
    }
    if report is not None:
        _write_text(report, _dumps(data) + "\n")
    if con.json:
        print(_dumps(data))
        return 0
    q = result.quality
    con.summary(f"{args.input}: {result.n_points:,} points")
    elapsed = sum(result.timings.values())
    con.summary(f"{result.method}: {_plural(result.n_faces, 'face')} in {elapsed:.2f} s on Dask")
    con.summary(
        f"  tac_1 {q['tac_1']:.4g}  tac_2 {q['tac_2']:.4g}  tac_inf {q['tac_inf']:.4g}"
        f"  smallest angle {_fmt(q['min_angle_deg'], '.2f')} deg"
        f"  slivers {100 * q['sliver_fraction']:.2f} %"
    )
    con.summary(f"wrote {', '.join(str(p) for p in (out, report) if p is not None)}")
    return 0


def _read_flags(args: argparse.Namespace) -> list[str]:
    """The reader flags given (each file is read as its ending says, with no options)."""
    return ["--" + k for k in _read_options(args)]


def _n_lines(line_ids: np.ndarray | None) -> int | None:
    return None if line_ids is None else int(count_lines(line_ids))


def _georef(georef: Georef, out: Path) -> dict[str, Any]:
    """The scan's georeference for the report, and whether ``out`` holds it (PLY and OBJ
    header comments do; STL, OFF, GLB and HTML have no place for it)."""
    fmt = FORMATS.get(out.suffix.lower())
    return {**georef.as_dict(), "in_output": bool(fmt is not None and fmt.comments)}


def _report(
    source, out, scan, surface, con: _Console, elapsed: float, quality: bool
) -> dict[str, Any]:
    """The command's report; ``quality`` False leaves the mesh unmeasured (``None``)."""
    used = np.zeros(len(surface.vertices), dtype=bool)
    used[surface.faces.ravel()] = True
    data: dict[str, Any] = {
        "scanmesh": __version__,
        "input": str(source),
        "output": str(out),
        "method": surface.method,
        "options": surface.options,
        "plane": {
            "asked": "chosen by the data" if scan.choice else scan.plane,
            "used": scan.plane,
            "normal": scan.frame.normal,
            "choice": scan.choice.as_dict(scan.frame.normal) if scan.choice else None,
        },
        "noise": surface.options.get("noise"),
        "georef": None if scan.georef is None else _georef(scan.georef, out),
        "warnings": con.warnings,
        "time_s": elapsed,
        "timings": {**scan.timings, **surface.timings},
        "quality": surface.quality.as_dict() if quality else None,
        "counts": {
            "points": int(len(surface.vertices)),
            "lines": _n_lines(scan.line_ids),
            "faces": int(len(surface.faces)),
            "used_points": int(used.sum()),
            "unused_points": int((~used).sum()),
            "duplicates": int(len(surface.duplicates)),
        },
    }
    if surface.certified is not None:
        data["certified"] = surface.certified
        data["gap"] = surface.gap
    if surface.trace is not None and "energy" in surface.trace:
        data["counts"]["sweeps_run"] = int(len(surface.trace["energy"]))
    return data
