"""``scanmesh compare``: several methods on one scan, judged by their quality and by the
height error against a CAD part (``--truth``) or by the holdout error without one."""

from __future__ import annotations

import argparse
import sys
import time
import warnings
from pathlib import Path
from typing import Any

from scanmesh._context import seed_of
from scanmesh._extras import require
from scanmesh._progress import Stage
from scanmesh.cli._args import _method_options, _read_options, _refuse_stray_flags, _shared
from scanmesh.cli._common import (
    _check_outputs,
    _check_png,
    _Console,
    _dumps,
    _fmt,
    _one_line,
    _quality_row,
)
from scanmesh.cli.reconstruct import _n_lines
from scanmesh.errors import ScanmeshError
from scanmesh.evaluate.holdout import HOLDOUT_MEASURE, holdout_error
from scanmesh.evaluate.truth import DOMAIN_MEASURE, MEASURE, TrueSurface, domain_error, height_error
from scanmesh.measures import SLIVER_ANGLE_DEG
from scanmesh.methods import COMPARED, INITIAL_OPTION, TABLE, default_initial
from scanmesh.present.panels import render_compare
from scanmesh.present.render import auto_view as _auto_view
from scanmesh.reconstruction import reconstruct
from scanmesh.scan.planar import PlanarScan, planar_scan
from scanmesh.stages.grid import is_gridded


def default_methods(scan: PlanarScan) -> list[str]:
    """What ``scanmesh compare`` runs when no method is named: the registry's
    :data:`scanmesh.methods.COMPARED`, those needing a range grid only if ``scan`` has one."""
    return [m for m in COMPARED if not TABLE[m].needs_grid or is_gridded(scan)]


#: Points sampled on each mesh for its height error against --truth.
TRUTH_SAMPLES = 100_000

#: Methods the holdout cannot judge, and why (said under the table and in the JSON): those
#: needing a range grid (the registry's ``needs_grid``), which the kept points no longer form.
NO_HOLDOUT = {
    name: "each withheld point is a hole in the range grid it triangulates, so no face"
    " is left to measure it against"
    for name, spec in TABLE.items()
    if spec.needs_grid
}

#: Share of the points ``scanmesh compare`` withholds without ``--truth`` (the holdout
#: error: the truth-free judge of a method, ``scanmesh.evaluate.holdout.holdout_error``).
HOLDOUT_FRACTION = 0.1


def cmd_compare(args: argparse.Namespace, con: _Console) -> int:
    """Run several methods on the same points; one table (and one picture)."""
    source = Path(args.input)
    picture = Path(args.picture) if args.picture else None
    methods = list(dict.fromkeys(args.methods or COMPARED))
    # --seed also seeds the height error's samples and the holdout's withheld points
    _refuse_stray_flags(args, methods, seeded=True)
    options = {m: _method_options(args, m) for m in methods}
    shared = {m: _shared(args, m, options[m]) for m in methods}
    inputs = [source] + ([Path(args.truth)] if args.truth else [])
    _check_outputs(inputs, [picture])
    _check_png(picture)
    if picture is not None:  # before any work: the picture comes last
        require(
            "matplotlib.figure",
            "plots",
            "compare --picture (the meshes side by side, titled)",
            instead="leave out --picture: the table needs no extra",
        )
    truth = None
    if args.truth:
        truth = TrueSurface(args.truth)
    scan = planar_scan(
        source, plane=args.plane, progress=con.progress, read_options=_read_options(args)
    )
    if not args.methods:
        methods = default_methods(scan)

    rows, surfaces, failed = [], [], {}
    # A method without options of its own (the trimmed Delaunay triangulation) is built
    # once: a row of its own and the start of the methods starting from it (LOP, annealing).
    built: dict[str, tuple[Any, float]] = {}

    def plain(name: str) -> tuple[Any, float]:
        if name not in built:
            t = time.perf_counter()
            made = reconstruct(scan, name, progress=con.progress, **_shared(args, name, {}))
            built[name] = (made, time.perf_counter() - t)
        return built[name]

    for method in methods:
        con.context = method  # its warnings name it
        if con.progress is True:
            con.note(f"{method} ...")
        kwargs = {**shared[method], **options[method]}
        spec = TABLE[method]
        try:
            if not spec.options:
                surface, seconds = plain(method)
            else:
                start = 0.0
                initial = kwargs.get("initial", INITIAL_OPTION.default)
                if initial == INITIAL_OPTION.default:
                    initial = default_initial(scan, kwargs.get("max_edge"))
                if spec.starts and not TABLE[initial].options:
                    kwargs.pop("max_edge", None)
                    kwargs["initial"], start = plain(initial)
                t0 = time.perf_counter()
                surface = reconstruct(scan, method, progress=con.progress, **kwargs)
                seconds = start + time.perf_counter() - t0
        except (ScanmeshError, ImportError) as exc:
            failed[method] = _one_line(exc)
            print(f"scanmesh: {method} failed: {failed[method]}", file=sys.stderr, flush=True)
            continue
        row: dict[str, Any] = {"method": method, "time_s": seconds}
        row.update(_quality_row(surface))
        row["faces"] = int(len(surface.faces))
        if truth is not None:
            # seconds each on a CAD part: said in a log as every other stage
            with Stage(con.progress, "truth", TRUTH_SAMPLES, blocking=True):
                err = height_error(surface, truth, n_samples=TRUTH_SAMPLES, seed=seed_of(args.seed))
                dom = domain_error(surface, truth)
            row.update({k: err[k] for k in ("h_rms", "h_mean", "h_max")})
            row.update({k: dom[k] for k in ("air_share", "missed_share")})
        elif args.holdout > 0:
            row.update(_holdout_row(scan, method, args, options[method], shared[method]))
        rows.append(row)
        surfaces.append(surface)

    con.context = None
    if con.json:
        data: dict[str, Any] = {"input": str(source), "points": int(len(scan.points))}
        data["methods"] = rows
        if truth is not None:
            data["height_error"] = {"measure": MEASURE, "n_samples": TRUTH_SAMPLES}
            data["domain_error"] = {"measure": DOMAIN_MEASURE}
        elif args.holdout > 0:
            data["holdout_error"] = {"measure": HOLDOUT_MEASURE, "fraction": args.holdout}
            unjudged = {m: why for m, why in NO_HOLDOUT.items() if m in methods}
            if unjudged:
                data["holdout_error"]["not_judged"] = unjudged
        if failed:
            data["failed"] = failed
        print(_dumps(data))
    else:
        _print_table(con, source, scan, rows, truth is not None)
    # after the table: whatever happens to the picture, the figures are out
    if picture is not None and surfaces:
        try:
            _picture(picture, source, scan, rows, surfaces, truth is not None)
        except (ScanmeshError, OSError) as exc:
            print(f"scanmesh: error: {picture}: {_one_line(exc)}", file=sys.stderr, flush=True)
            return 1
        con.summary(f"wrote {picture}")
    return 1 if failed else 0


def _picture(picture: Path, source: Path, scan, rows: list[dict], surfaces: list, truth: bool):
    """The meshes side by side, each titled with its method, tac_1, time (and height error)."""
    titles = [
        f"{r['method']}: tac_1 {r['tac_1']:.4g}, {r['time_s']:.2g} s"
        + (f"\nRMS height error {r['h_rms']:.3g}" if truth else "")
        for r in rows
    ]
    ref = surfaces[0]
    render_compare(
        surfaces,
        picture,
        titles=titles,
        suptitle=f"{source.name}: {len(scan.points):,} points",
        **_auto_view(ref.vertices, ref.faces, ref.frame),
    )


def _holdout_row(scan, method: str, args, options: dict, shared: dict) -> dict[str, Any]:
    """The holdout error of ``method`` on ``scan`` (rebuilt from the kept points with the
    same options; the seed of --seed chooses the withheld points)."""
    if method in NO_HOLDOUT:  # said under the table: not a failure
        return {"holdout_rms": None, "holdout_p99": None, "holdout_outside": None}
    given = {k: v for k, v in shared.items() if k not in ("lines", "seed")}
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")  # the full run already warned about this scan
            err = holdout_error(
                scan.points,
                method,
                fraction=args.holdout,
                seed=seed_of(args.seed),
                plane=scan.plane,
                lines=scan.line_ids,
                **given,
                **options,
            )
    except ScanmeshError as exc:  # e.g. too few points left for the method
        print(f"scanmesh: {method} holdout failed: {_one_line(exc)}", file=sys.stderr)
        return {"holdout_rms": None, "holdout_p99": None, "holdout_outside": None}
    return {
        "holdout_rms": err["rms"],
        "holdout_p99": err["p99"],
        "holdout_outside": err["outside"],
    }


def _print_table(con: _Console, source: Path, scan, rows: list[dict], with_truth: bool) -> None:
    n_lines = _n_lines(scan.line_ids)
    lines = f" on {n_lines:,} lines" if n_lines is not None else ""
    con.out(f"{source}: {len(scan.points):,} points{lines}")
    head = (
        f"{'method':<14}{'time s':>9}{'faces':>9}{'tac_1':>11}{'tac_2':>10}{'tac_inf':>9}"
        f"{'min angle':>11}{'slivers':>9}"
    )
    with_holdout = not with_truth and any("holdout_rms" in r for r in rows)
    if with_truth:
        head += f"{'h_rms':>11}{'h_mean':>11}{'h_max':>11}{'air':>8}{'missed':>8}"
    elif with_holdout:
        head += f"{'holdout rms':>13}{'p99':>11}"
    con.out(head)
    for r in rows:
        line = (
            f"{r['method']:<14}{r['time_s']:>9.3f}{r['faces']:>9,}{r['tac_1']:>11.4g}"
            f"{r['tac_2']:>10.4g}{r['tac_inf']:>9.4g}{_fmt(r['min_angle_deg'], '.2f'):>10}°"
            f"{100 * r['sliver_fraction']:>8.2f}%"
        )
        if with_truth:
            line += f"{r['h_rms']:>11.3e}{r['h_mean']:>11.3e}{r['h_max']:>11.3e}"
            line += f"{100 * r['air_share']:>7.2f}%{100 * r['missed_share']:>7.2f}%"
        elif with_holdout:
            line += f"{_fmt(r['holdout_rms'], '.3e'):>13}{_fmt(r['holdout_p99'], '.3e'):>11}"
        con.out(line)
    con.out(
        "tac in radians (smaller is smoother); min angle: smallest 3-D corner angle;"
        " slivers: share of faces with a smallest angle below"
        f" {_sliver_deg():g} deg"
    )
    if with_truth:
        con.out(
            f"h_*: closest-point distance to the truth at {TRUTH_SAMPLES:,} random points on each"
            " mesh's area (model units); air: area the mesh covers outside the truth's"
            " shadow on the plane, missed: shadow area the mesh leaves open (both in % of the"
            " shadow)"
        )
    elif with_holdout:
        con.out(
            "holdout: each method rebuilt without a seeded share of the points (--holdout);"
            " the withheld points' height above or below that mesh along the plane normal"
            " (model units), the error a user without a CAD model can judge by"
        )
        for method, why in NO_HOLDOUT.items():
            if any(r["method"] == method for r in rows):
                con.out(f"{method}: no holdout: {why}")


def _sliver_deg() -> float:
    return float(SLIVER_ANGLE_DEG)
