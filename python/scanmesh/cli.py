"""The ``scanmesh`` command: reconstruct, compare, simulate, info, render and demo.

Exit status: 0 on success, 2 for a usage error (argparse), 1 for bad input (a scanmesh
error or a file that cannot be read or written) with one line on stderr, 130 on Ctrl-C.
Every file is written atomically (a temporary file beside it, then a rename), so an error
or an interruption never leaves a partial output file, and no command writes over its input.
"""

from __future__ import annotations

import argparse
import json
import math
import os
import sys
import threading
import time
import warnings
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Any

import numpy as np

from scanmesh.surface import STEEP_ANGLE_DEG

#: Methods ``scanmesh compare`` runs by default: all but the exact one (small inputs only).
COMPARE_METHODS = ("delaunay", "lookahead", "shortest-path", "lop", "anneal")

#: File endings ``scanmesh simulate`` writes (XYZ text, read back by ``scanmesh.read``).
POINT_ENDINGS = (".xyz", ".txt", ".asc")

#: File names ``scanmesh demo`` writes.
DEMO_MESH = "demo_rod.stl"
DEMO_PREVIEW = "demo_rod.png"


# --------------------------------------------------------------------------- argument types


def _plane(text: str) -> str | tuple[float, float, float]:
    """--plane: best-fit, x, y, z or a normal vector "nx,ny,nz"."""
    name = text.strip().lower()
    if name in ("best-fit", "x", "y", "z"):
        return name
    parts = _vector(name)
    if parts is None:
        raise argparse.ArgumentTypeError(
            f"{text!r} is not best-fit, x, y, z or a non-zero vector like 0,0,1"
        )
    return parts


def _vector(text: str) -> tuple[float, float, float] | None:
    """A finite non-zero 3-vector written "x,y,z" (or space separated), else None."""
    try:
        parts = tuple(float(t) for t in text.replace(" ", ",").split(",") if t)
    except ValueError:
        return None
    if len(parts) != 3 or not all(map(math.isfinite, parts)) or not any(parts):
        return None
    return parts  # type: ignore[return-value]


def _axis(text: str) -> str | tuple[float, float, float]:
    """--up, --along, --view: an axis name (x, -y, +z) or a vector "x,y,z"."""
    name = text.strip().lower()
    if name.lstrip("+-") in ("x", "y", "z") and len(name) <= 2:
        return name
    parts = _vector(name)
    if parts is None:
        raise argparse.ArgumentTypeError(
            f"{text!r} is not an axis (x, -y, +z, ...) or a non-zero vector like 0,0,1"
        )
    return parts


def _positive(text: str) -> float:
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"{text!r} is not a number") from None
    if not (value > 0) or not math.isfinite(value):
        raise argparse.ArgumentTypeError(f"{text!r} is not a positive number")
    return value


def _max_edge(text: str) -> float:
    if text.strip().lower() in ("inf", "infinity", "none"):
        return math.inf
    return _positive(text)


def _non_negative(text: str) -> float:
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"{text!r} is not a number") from None
    if not (value >= 0) or not math.isfinite(value):
        raise argparse.ArgumentTypeError(f"{text!r} is not a number >= 0")
    return value


def _count(text: str) -> int:
    try:
        value = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"{text!r} is not a whole number") from None
    if value < 0:
        raise argparse.ArgumentTypeError(f"{text!r} is negative")
    return value


def _size(text: str) -> tuple[int, int]:
    try:
        w, h = (int(t) for t in text.lower().split("x"))
    except ValueError:
        raise argparse.ArgumentTypeError(f"{text!r} is not a size like 800x600") from None
    if not (16 <= w <= 8000 and 16 <= h <= 8000):
        raise argparse.ArgumentTypeError(f"{text!r}: width and height must be 16..8000")
    return w, h


# --------------------------------------------------------------------------- helpers


def _json_safe(value: Any) -> Any:
    """Plain JSON types: numpy values unwrapped, paths as text, NaN and infinities as null."""
    if isinstance(value, dict):
        return {str(k): _json_safe(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [_json_safe(v) for v in value]
    if isinstance(value, np.ndarray):
        return _json_safe(value.tolist())
    if isinstance(value, np.generic):
        value = value.item()
    if isinstance(value, float):
        return value if math.isfinite(value) else None
    if value is None or isinstance(value, (bool, int, str)):
        return value
    return str(value)


def _dumps(data: Any) -> str:
    return json.dumps(_json_safe(data), indent=2, allow_nan=False)


def _write_text(path: Path, text: str) -> None:
    from scanmesh.writers import write_atomic

    write_atomic(path, [text.encode("utf-8")])


def _check_outputs(inputs: Sequence[Path], outputs: Sequence[Path | None]) -> None:
    """Refuse, before any work, outputs that name an input or each other, or a missing folder."""
    from scanmesh.errors import ParameterError
    from scanmesh.writers import _check_protected, _same_file

    given = [p for p in outputs if p is not None]
    for k, out in enumerate(given):
        _check_protected(out, inputs)
        for other in given[:k]:
            if _same_file(out, other):
                raise ParameterError(f"{out} is named for two outputs; give each its own file")
        folder = out.parent if str(out.parent) else Path(".")
        if not folder.is_dir():
            raise ParameterError(f"cannot write {out}: folder {folder} does not exist")


def _check_mesh_ending(path: Path) -> None:
    from scanmesh.errors import ParameterError
    from scanmesh.writers import FORMATS

    if path.suffix.lower() not in FORMATS:
        raise ParameterError(
            f"cannot write {path}: unknown ending {path.suffix!r}; use one of"
            f" {', '.join(sorted(FORMATS))}"
        )


def _check_png(path: Path | None) -> None:
    from scanmesh.errors import ParameterError

    if path is not None and path.suffix.lower() != ".png":
        raise ParameterError(f"pictures are written as PNG: {path} should end in .png")


def _auto_view(vertices: np.ndarray, faces: np.ndarray, frame: Any = None) -> dict[str, Any]:
    """Camera for a scan: three-quarter view from the side the surface faces, tilted across
    its shorter planar extent (so a long part is seen from the side, not end-on)."""
    used = np.zeros(len(vertices), dtype=bool)
    used[faces.ravel()] = True
    pts = vertices[used]
    if frame is not None:
        u, v, n = (np.asarray(a, dtype=np.float64) for a in (frame.u, frame.v, frame.normal))
    else:
        centred = pts - pts.mean(axis=0)
        _, _, axes = np.linalg.svd(centred, full_matrices=False)
        u, v, n = axes[0], axes[1], axes[2]
        tri = vertices[faces]
        area = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0]).sum(axis=0)
        if float(np.dot(area, n)) < 0:
            n, v = -n, -v
    rel = pts - pts.mean(axis=0)
    if np.ptp(rel @ u) < np.ptp(rel @ v):
        short, long_ = u, v
    else:
        short, long_ = v, u
    view = 0.9 * n - 1.0 * short - 0.3 * long_
    return {"view": tuple(float(x) for x in view), "up": tuple(float(x) for x in n)}


def _quality_row(surface: Any) -> dict[str, Any]:
    q = surface.quality.as_dict()
    return {k: q[k] for k in ("tac_1", "tac_2", "tac_inf", "min_angle_deg", "sliver_fraction")}


def _fmt(value: Any, spec: str) -> str:
    if value is None or (isinstance(value, float) and not math.isfinite(value)):
        return "-"
    return format(value, spec)


class _Console:
    """Where the command talks: results to stdout, notes and warnings to stderr."""

    def __init__(self, quiet: bool, as_json: bool) -> None:
        self.quiet = quiet
        self.json = as_json

    @property
    def progress(self) -> bool:
        """Progress bars: on a terminal, unless --quiet."""
        return not self.quiet and sys.stderr.isatty()

    def out(self, text: str = "") -> None:
        """Human output (nothing with --json)."""
        if not self.json:
            print(text, flush=True)

    def note(self, text: str) -> None:
        """A remark on stderr (nothing with --quiet)."""
        if not self.quiet:
            print(f"scanmesh: {text}", file=sys.stderr, flush=True)


def _add_read_flags(p: argparse.ArgumentParser) -> None:
    """Flags that choose what is read from a scan file (see scanmesh.formats)."""
    p.add_argument(
        "--columns",
        metavar="COLS",
        help="columns of x, y, z (and line) in file"
        " order, e.g. x,y,z,intensity,line, or their indices, e.g. 0,1,2,4",
    )
    p.add_argument(
        "--returns",
        metavar="WHICH",
        help="LAS/LAZ: first (default), last, all or return numbers, e.g. 1,2",
    )
    p.add_argument("--classes", metavar="C", help="LAS/LAZ: ASPRS classes to keep, e.g. 2")
    p.add_argument(
        "--grid",
        action="store_true",
        help="read a matrix of heights (text, CSV, .npy), each row a scan line",
    )
    p.add_argument("--cell", type=float, metavar="SIZE", help="cell size of a height grid")


def _read_scan(path: Path, progress: bool = False, args: argparse.Namespace | None = None):
    from scanmesh.readers import read

    flags = ("columns", "returns", "classes", "grid", "cell")
    options = {k: getattr(args, k) for k in flags if getattr(args, k, None) not in (None, False)}
    return read(path, progress=progress, **options)


def _background(fn: Callable[[], Any]) -> Callable[[], Any]:
    """Start ``fn()`` in a daemon thread; return a function that waits for its result (or
    raises its exception). Waiting stays interruptible by Ctrl-C, and a daemon thread does
    not hold up the exit of an interrupted command (a pool's worker would be joined)."""
    box: dict[str, Any] = {}

    def work() -> None:
        try:
            box["result"] = fn()
        except BaseException as exc:  # noqa: BLE001 - handed to the waiting caller
            box["error"] = exc

    worker = threading.Thread(target=work, name="scanmesh-background", daemon=True)
    worker.start()

    def result() -> Any:
        while worker.is_alive():
            worker.join(0.05)
        if "error" in box:
            raise box["error"]
        return box["result"]

    return result


#: Command-line options that go to the annealer (each is refused for other methods).
ANNEAL_FLAGS = ("sweeps", "tiles")


def _method_options(args: argparse.Namespace, method: str) -> dict[str, Any]:
    options: dict[str, Any] = {}
    for name in ANNEAL_FLAGS:
        if method == "anneal" and getattr(args, name, None) is not None:
            options[name] = getattr(args, name)
    return options


# --------------------------------------------------------------------------- reconstruct


def cmd_reconstruct(args: argparse.Namespace, con: _Console) -> int:
    """Read scan points, triangulate them, write the mesh (and a report and a preview)."""
    from scanmesh._progress import Stage
    from scanmesh.reconstruct import reconstruct
    from scanmesh.writers import save_mesh

    source, out = Path(args.input), Path(args.output)
    report = Path(args.report) if args.report else None
    preview = Path(args.preview) if args.preview else None
    for name in ANNEAL_FLAGS:
        if getattr(args, name) is not None and args.method != "anneal":
            args._parser.error(f"--{name} applies to --method anneal only")
    _check_outputs([source], [out, report, preview])
    _check_mesh_ending(out)
    _check_png(preview)

    t0 = time.perf_counter()
    scan = _read_scan(source, con.progress, args)
    t_read = time.perf_counter() - t0
    t1 = time.perf_counter()
    surface = reconstruct(
        scan.points,
        args.method,
        lines=scan.line_ids,
        plane=args.plane,
        max_edge=args.max_edge,
        seed=args.seed,
        progress=con.progress,
        **_method_options(args, args.method),
    )
    elapsed = time.perf_counter() - t1
    t2 = time.perf_counter()
    # The quality report (tac over every vertex: about as long as the strips at 10M points)
    # is measured while the mesh is written: both release the GIL, so they overlap.
    measured = _background(lambda: surface.quality)
    save_mesh(out, surface.vertices, surface.faces, protect=[source], progress=con.progress)
    t_write = time.perf_counter() - t2
    with Stage(con.progress, "quality", len(surface.faces), blocking=True):
        measured()
    data = _report(source, out, scan, surface, t_read, elapsed)
    data["timings"]["write"] = t_write
    if report is not None:
        _write_text(report, _dumps(data) + "\n")
    if preview is not None:
        from scanmesh.render import render_mesh

        render_mesh(surface, preview, **_auto_view(surface.vertices, surface.faces, surface.frame))
    if con.json:
        print(_dumps(data))
        return 0
    q = data["quality"]
    counts = data["counts"]
    lines = f" on {counts['lines']:,} lines" if counts["lines"] else ""
    con.out(f"{source}: {counts['points']:,} points{lines}")
    con.out(f"{surface.method}: {counts['faces']:,} faces in {elapsed:.2f} s")
    con.out(
        f"  tac_1 {q['tac_1']:.4g}  tac_2 {q['tac_2']:.4g}  tac_inf {q['tac_inf']:.4g}"
        f"  smallest angle {_fmt(q['min_angle_deg'], '.2f')} deg"
        f"  slivers {100 * q['sliver_fraction']:.2f} %"
    )
    written = [str(out)] + [str(p) for p in (report, preview) if p is not None]
    con.out(f"wrote {', '.join(written)}")
    return 0


def _report(source, out, scan, surface, t_read: float, elapsed: float) -> dict[str, Any]:
    used = np.zeros(len(surface.vertices), dtype=bool)
    used[surface.faces.ravel()] = True
    data: dict[str, Any] = {
        "input": str(source),
        "output": str(out),
        "method": surface.method,
        "options": surface.options,
        "time_s": elapsed,
        "timings": {"read": t_read, **surface.timings},
        "quality": surface.quality.as_dict(),
        "counts": {
            "points": int(len(surface.vertices)),
            "lines": int(scan.n_lines) if scan.line_ids is not None else None,
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


# --------------------------------------------------------------------------- compare


def cmd_compare(args: argparse.Namespace, con: _Console) -> int:
    """Run several methods on the same points; one table (and one picture)."""
    from scanmesh.errors import ScanmeshError
    from scanmesh.reconstruct import reconstruct

    source = Path(args.input)
    picture = Path(args.picture) if args.picture else None
    methods = list(dict.fromkeys(args.methods or COMPARE_METHODS))
    for name in ANNEAL_FLAGS:
        if getattr(args, name, None) is not None and "anneal" not in methods:
            args._parser.error(f"--{name} applies to the anneal method only")
    inputs = [source] + ([Path(args.truth)] if args.truth else [])
    _check_outputs(inputs, [picture])
    _check_png(picture)
    truth = None
    if args.truth:
        from scanmesh.truth import TrueSurface

        truth = TrueSurface(args.truth)
    scan = _read_scan(source, con.progress, args)

    rows, surfaces, failed = [], [], {}
    for method in methods:
        if con.progress:
            con.note(f"{method} ...")
        t0 = time.perf_counter()
        try:
            surface = reconstruct(
                scan.points,
                method,
                lines=scan.line_ids,
                plane=args.plane,
                max_edge=args.max_edge,
                seed=args.seed,
                progress=con.progress,
                **_method_options(args, method),
            )
        except (ScanmeshError, ImportError) as exc:
            failed[method] = _one_line(exc)
            print(f"scanmesh: {method} failed: {failed[method]}", file=sys.stderr, flush=True)
            continue
        row: dict[str, Any] = {"method": method, "time_s": time.perf_counter() - t0}
        row.update(_quality_row(surface))
        row["faces"] = int(len(surface.faces))
        if truth is not None:
            from scanmesh.truth import domain_error, height_error

            err = height_error(surface, truth, seed=args.seed or 0)
            row.update({k: err[k] for k in ("h_rms", "h_mean", "h_max")})
            dom = domain_error(surface, truth)
            row.update({k: dom[k] for k in ("air_share", "missed_share")})
        rows.append(row)
        surfaces.append(surface)

    if picture is not None and surfaces:
        from scanmesh.render import render_compare

        titles = [
            f"{r['method']}: tac_1 {r['tac_1']:.4g}, {r['time_s']:.2g} s"
            + (f"\nRMS height error {r['h_rms']:.3g}" if truth is not None else "")
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
    if con.json:
        data: dict[str, Any] = {"input": str(source), "points": int(len(scan.points))}
        data["methods"] = rows
        if truth is not None:
            from scanmesh.truth import DOMAIN_MEASURE, MEASURE

            data["height_error"] = {"measure": MEASURE, "n_samples": 100_000}
            data["domain_error"] = {"measure": DOMAIN_MEASURE}
        if failed:
            data["failed"] = failed
        print(_dumps(data))
    else:
        _print_table(con, source, scan, rows, truth is not None)
        if picture is not None and surfaces:
            con.out(f"wrote {picture}")
    return 1 if failed else 0


def _print_table(con: _Console, source: Path, scan, rows: list[dict], with_truth: bool) -> None:
    lines = f" on {scan.n_lines:,} lines" if scan.line_ids is not None else ""
    con.out(f"{source}: {len(scan.points):,} points{lines}")
    head = (
        f"{'method':<14}{'time s':>9}{'faces':>9}{'tac_1':>11}{'tac_2':>10}{'tac_inf':>9}"
        f"{'min angle':>11}{'slivers':>9}"
    )
    if with_truth:
        head += f"{'h_rms':>11}{'h_mean':>11}{'h_max':>11}{'air':>8}{'missed':>8}"
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
        con.out(line)
    con.out(
        "tac in radians (smaller is smoother); min angle: smallest 3-D corner angle;"
        " slivers: share of faces with a smallest angle below"
        f" {_sliver_deg():g} deg"
    )
    if with_truth:
        con.out(
            "h_*: closest-point distance to the truth at 100,000 random points on each"
            " mesh's area (model units); air: area the mesh covers outside the truth's"
            " shadow on the plane, missed: shadow area the mesh leaves open (both in % of the"
            " shadow)"
        )


def _sliver_deg() -> float:
    from scanmesh.quality import SLIVER_ANGLE_DEG

    return float(SLIVER_ANGLE_DEG)


# --------------------------------------------------------------------------- simulate


def cmd_simulate(args: argparse.Namespace, con: _Console) -> int:
    """Scan a mesh with the virtual line digitizer; write the points as XYZ text."""
    from scanmesh.digitizer import simulate_scan
    from scanmesh.errors import ParameterError
    from scanmesh.writers import write_points

    mesh, out = Path(args.mesh), Path(args.output)
    if out.suffix.lower() not in POINT_ENDINGS:
        raise ParameterError(
            f"cannot write {out}: points are written as XYZ text; use an ending in"
            f" {', '.join(POINT_ENDINGS)}"
        )
    _check_outputs([mesh], [out])
    t0 = time.perf_counter()
    points, line_ids = simulate_scan(
        mesh,
        up=args.up,
        along=args.along,
        spacing=args.spacing,
        line_spacing=args.line_spacing,
        n_points=args.n_points,
        noise=args.noise,
        table=args.table,
        seed=args.seed,
    )
    elapsed = time.perf_counter() - t0
    if len(points) == 0:
        raise ParameterError(f"no ray hit {mesh}; check --up and the spacing")
    from scanmesh.digitizer import parse_axis

    write_points(out, points, line_ids, up=parse_axis(args.up, "up"), protect=[mesh])
    n_lines = int(line_ids.max()) + 1 if len(line_ids) else 0
    if con.json:
        print(
            _dumps(
                {
                    "mesh": str(mesh),
                    "output": str(out),
                    "points": len(points),
                    "lines": n_lines,
                    "time_s": elapsed,
                }
            )
        )
    else:
        con.out(f"wrote {out}: {len(points):,} points on {n_lines:,} lines ({elapsed:.2f} s)")
    return 0


# --------------------------------------------------------------------------- info


def cmd_info(args: argparse.Namespace, con: _Console) -> int:
    """Points, lines, extent, spacing and the share of steep triangles of a scan file."""
    from scanmesh.delaunay import MAX_EDGE_FACTOR, delaunay

    source = Path(args.input)
    scan = _read_scan(source, con.progress, args)
    pts = scan.points
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # coincident points are counted below
        surface = delaunay(pts, plane=args.plane)
    # delaunay() trims at MAX_EDGE_FACTOR x the median nearest-neighbour spacing
    spacing = float(surface.options["max_edge"]) / MAX_EDGE_FACTOR
    normal = np.asarray(surface.frame.normal, dtype=np.float64)
    steep = surface.steep_fraction
    lines, lines_from = _lines_info(scan, args.plane)
    lo, hi = pts.min(axis=0), pts.max(axis=0)
    data = {
        "input": str(source),
        "format": scan.extra.get("format"),
        "points": int(len(pts)),
        "lines": lines,
        "lines_from": lines_from,
        "extent": {"min": lo, "max": hi, "size": hi - lo},
        "plane_normal": normal,
        "median_spacing": spacing,
        "delaunay_faces": int(len(surface.faces)),
        "coincident_points": int(len(surface.duplicates)),
        "steep_share": steep,
        "steep_deg": STEEP_ANGLE_DEG,
    }
    if con.json:
        print(_dumps(data))
        return 0
    con.out(f"{source}")
    con.out(f"  points            {len(pts):,}")
    con.out(f"  scan lines        {_fmt(lines, ',')} ({lines_from})")
    for label, vec in (("min", lo), ("max", hi), ("size", hi - lo)):
        con.out(f"  {label:<18}{'  '.join(f'{x:.6g}' for x in vec)}")
    con.out(f"  plane normal      {'  '.join(f'{x:.4g}' for x in normal)}")
    con.out(f"  median spacing    {spacing:.6g} (nearest neighbour, in the plane)")
    con.out(f"  coincident        {len(surface.duplicates):,} points (in the plane)")
    con.out(
        f"  steep share       {100 * steep:.2f} % of {len(surface.faces):,} Delaunay triangles"
        f" tilt more than {STEEP_ANGLE_DEG:g} deg from the plane normal"
    )
    return 0


def _lines_info(scan, plane) -> tuple[int | None, str]:
    """Scan lines: from the file, else detected from the point order (when available)."""
    if scan.line_ids is not None:
        return int(scan.n_lines), f"from the file: {scan.extra.get('line_ids_from') or 'ids'}"
    try:
        from scanmesh.lines import detect_lines
    except ImportError:
        return None, "not in the file"
    ids = detect_lines(scan.points, plane=plane)
    return int(len(np.unique(ids))), "detected from the point order"


# --------------------------------------------------------------------------- render


def cmd_render(args: argparse.Namespace, con: _Console) -> int:
    """A flat-shaded PNG picture of a mesh file."""
    from scanmesh.digitizer import load_mesh
    from scanmesh.render import render_mesh

    mesh_path, out = Path(args.mesh), Path(args.output)
    _check_outputs([mesh_path], [out])
    _check_png(out)
    mesh = load_mesh(mesh_path)
    vertices = np.asarray(mesh.vertices, dtype=np.float64)
    faces = np.asarray(mesh.faces, dtype=np.int64)
    camera = _auto_view(vertices, faces)
    if args.view is not None:
        camera["view"] = args.view
    if args.up is not None:
        camera["up"] = args.up
    render_mesh((vertices, faces), out, size=args.size, wire=args.wire, **camera)
    con.out(f"wrote {out}")
    return 0


# --------------------------------------------------------------------------- demo


def cmd_demo(args: argparse.Namespace, con: _Console) -> int:
    """Anneal the embedded connecting-rod scan; write demo_rod.stl and demo_rod.png."""
    from scanmesh.delaunay import delaunay
    from scanmesh.demo import SCAN_SETTINGS, demo_truth, load_demo
    from scanmesh.reconstruct import reconstruct
    from scanmesh.render import render_mesh
    from scanmesh.truth import MEASURE, TrueSurface, height_error
    from scanmesh.writers import save_mesh

    folder = Path(args.output_dir)
    folder.mkdir(parents=True, exist_ok=True)
    mesh_path, png_path = folder / DEMO_MESH, folder / DEMO_PREVIEW
    points, line_ids = load_demo()
    plane = SCAN_SETTINGS["up"]  # scanned along the rod's thickness axis
    con.out(
        f"demo: a connecting rod scanned along its thickness ({plane}): {len(points):,} points"
        f" on {int(line_ids.max()) + 1} lines"
    )
    t0 = time.perf_counter()
    base = delaunay(points, plane=plane)
    t_base = time.perf_counter() - t0
    t0 = time.perf_counter()
    surface = reconstruct(
        points, "anneal", lines=line_ids, plane=plane, seed=0, progress=con.progress
    )
    t_anneal = time.perf_counter() - t0
    save_mesh(mesh_path, surface.vertices, surface.faces)
    render_mesh(surface, png_path, **_auto_view(surface.vertices, surface.faces, surface.frame))
    truth = TrueSurface(demo_truth())
    results = {}
    for name, surf, seconds in (("delaunay", base, t_base), ("anneal", surface, t_anneal)):
        row = {"time_s": seconds, "faces": int(len(surf.faces)), **_quality_row(surf)}
        err = height_error(surf, truth, seed=0)
        row.update({k: err[k] for k in ("h_rms", "h_max")})
        results[name] = row
    if con.json:
        print(
            _dumps(
                {
                    "points": len(points),
                    "lines": int(line_ids.max()) + 1,
                    "plane": plane,
                    "seed": 0,
                    "methods": results,
                    "height_error": MEASURE,
                    "files": [str(mesh_path), str(png_path)],
                }
            )
        )
        return 0
    d, a = results["delaunay"], results["anneal"]
    rows = [
        ("faces", "{:,}", "faces"),
        ("tac_1 (rad)", "{:.4g}", "tac_1"),
        ("tac_2 (rad)", "{:.4g}", "tac_2"),
        ("tac_inf (rad)", "{:.4g}", "tac_inf"),
        ("smallest angle (deg)", "{:.2f}", "min_angle_deg"),
        ("slivers (%)", "{:.2f}", "sliver_fraction"),
        ("RMS height error (in)", "{:.3e}", "h_rms"),
        ("max height error (in)", "{:.3e}", "h_max"),
        ("time (s)", "{:.2f}", "time_s"),
    ]
    con.out(f"{'':<24}{'Delaunay':>12}{'annealed':>12}")
    for label, spec, key in rows:
        scale = 100 if key == "sliver_fraction" else 1
        con.out(f"{label:<24}{spec.format(d[key] * scale):>12}{spec.format(a[key] * scale):>12}")
    limit = int(surface.options["sweeps"])
    ran = len(surface.trace["energy"]) if surface.trace else limit
    sweeps = f"{ran:,} sweeps" if ran == limit else f"{ran:,} of up to {limit:,} sweeps"
    con.out(f"annealing ({sweeps}, seed 0) made tac_1 {d['tac_1'] / a['tac_1']:.1f} times smaller")
    con.out(
        "height error: closest-point distance to the CAD model at 100,000 random points on"
        " each mesh"
    )
    con.out(f"wrote {mesh_path} and {png_path}")
    return 0


# --------------------------------------------------------------------------- parser


def build_parser() -> argparse.ArgumentParser:
    """The argument parser of the ``scanmesh`` command."""
    from scanmesh import __version__
    from scanmesh.reconstruct import METHODS

    common = argparse.ArgumentParser(add_help=False)
    common.add_argument(
        "-q",
        "--quiet",
        action="store_true",
        default=argparse.SUPPRESS,
        help="no progress bars or remarks (bars show only on a terminal anyway)",
    )
    with_json = argparse.ArgumentParser(add_help=False)
    with_json.add_argument(
        "--json", action="store_true", help="print the results as JSON and nothing else"
    )
    shape = argparse.ArgumentParser(add_help=False)
    shape.add_argument(
        "--plane",
        type=_plane,
        default=None,
        metavar="P",
        help="projection plane: best-fit (default), x, y, z or a normal vector nx,ny,nz",
    )
    shape.add_argument(
        "--max-edge",
        type=_max_edge,
        default=None,
        metavar="L",
        help="drop Delaunay triangles with a longer planar edge (default 5 x median spacing;"
        " inf keeps the convex hull)",
    )
    shape.add_argument("--seed", type=_count, default=0, metavar="S", help="random seed (0)")
    shape.add_argument(
        "--sweeps",
        type=_count,
        default=None,
        metavar="N",
        help="annealing sweeps (default 1000; a sweep proposes one flip per interior edge)",
    )
    shape.add_argument(
        "--tiles",
        type=_count,
        default=None,
        metavar="K",
        help="anneal in K stripes of the plane at once, on the cores (default 1; results"
        " depend on K, not on the core count)",
    )

    parser = argparse.ArgumentParser(
        prog="scanmesh",
        parents=[common],
        description="Smooth, honest triangle meshes from digitized scan-line points.",
        epilog="Exit status: 0 done, 1 bad input, 2 usage error, 130 interrupted.",
    )
    parser.add_argument("--version", action="version", version=f"scanmesh {__version__}")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND")
    sub.required = True

    p = sub.add_parser(
        "reconstruct",
        parents=[common, with_json, shape],
        help="triangulate a scan file and write the mesh",
        description="Read scan points (XYZ, CSV, PLY, NPY, VTK, DEM, LAS), triangulate them and"
        " write the mesh by its file ending (.stl, .ply, .obj, .off).",
    )
    p.add_argument("input", metavar="IN", help="scan file")
    _add_read_flags(p)
    p.add_argument("-o", "--output", required=True, metavar="OUT", help="mesh file to write")
    p.add_argument("--method", choices=METHODS, default="anneal", help="method (anneal)")
    p.add_argument("--report", metavar="R.json", help="also write a JSON report")
    p.add_argument("--preview", metavar="P.png", help="also write a shaded picture")
    p.set_defaults(func=cmd_reconstruct, _parser=p)

    p = sub.add_parser(
        "compare",
        parents=[common, with_json, shape],
        help="run several methods on one scan; print one table",
        description="Run each method on the same points and print time and quality side by"
        " side; with --truth also the distance of each mesh to the true surface (closest-point"
        " distance at 100,000 random points on the mesh's area).",
    )
    p.add_argument("input", metavar="IN", help="scan file")
    _add_read_flags(p)
    p.add_argument("--truth", metavar="MESH", help="the true surface (a CAD mesh file)")
    p.add_argument(
        "--methods",
        nargs="+",
        choices=METHODS,
        metavar="M",
        help=f"methods to run (default: {' '.join(COMPARE_METHODS)}; choices:"
        f" {', '.join(METHODS)})",
    )
    p.add_argument("--picture", metavar="P.png", help="write the meshes side by side")
    p.set_defaults(func=cmd_compare, _parser=p)

    p = sub.add_parser(
        "simulate",
        parents=[common, with_json],
        help="scan a mesh with a virtual line digitizer",
        description="Cast parallel lines of rays onto a mesh (first hits, like a line"
        " digitizer) and write the points as XYZ text with the scan line as 4th column.",
    )
    p.add_argument("mesh", metavar="MESH", help="the part (STL, PLY, OBJ, OFF, ...)")
    p.add_argument("-o", "--output", required=True, metavar="SCAN.xyz", help="points to write")
    p.add_argument("--up", type=_axis, default="z", help="direction the digitizer looks from (z)")
    p.add_argument("--along", type=_axis, default="x", help="direction lines run (x)")
    group = p.add_mutually_exclusive_group()
    group.add_argument("--spacing", type=_positive, metavar="S", help="step along a line")
    group.add_argument(
        "--n-points", type=_count, metavar="N", help="pick the spacing for about N points"
    )
    p.add_argument("--line-spacing", type=_positive, metavar="L", help="distance between lines")
    p.add_argument(
        "--noise",
        type=_non_negative,
        default=0.0,
        metavar="SIGMA",
        help="Gaussian noise along the rays (model units, 0)",
    )
    p.add_argument("--table", action="store_true", help="rays that miss hit the table")
    p.add_argument("--seed", type=_count, default=0, metavar="S", help="noise seed (0)")
    p.set_defaults(func=cmd_simulate, _parser=p)

    p = sub.add_parser(
        "info",
        parents=[common, with_json],
        help="describe a scan file",
        description="Points, scan lines, extent, median spacing and the share of steep"
        f" Delaunay triangles (normal more than {STEEP_ANGLE_DEG:g} deg from the projection"
        " normal).",
    )
    p.add_argument("input", metavar="IN", help="scan file")
    _add_read_flags(p)
    p.add_argument(
        "--plane",
        type=_plane,
        default=None,
        metavar="P",
        help="projection plane (best-fit, x, y, z or nx,ny,nz)",
    )
    p.set_defaults(func=cmd_info, _parser=p)

    p = sub.add_parser(
        "render",
        parents=[common],
        help="flat-shaded PNG picture of a mesh",
        description="Draw a mesh flat-shaded (each facet visible), seen from the side it faces.",
    )
    p.add_argument("mesh", metavar="MESH", help="mesh file")
    p.add_argument("-o", "--output", required=True, metavar="PNG", help="picture to write")
    p.add_argument("--view", type=_axis, help="direction from the part to the eye")
    p.add_argument("--up", type=_axis, help="model direction shown upwards")
    p.add_argument("--size", type=_size, default=(800, 600), metavar="WxH", help="(800x600)")
    p.add_argument("--wire", action="store_true", help="draw the triangle edges")
    p.set_defaults(func=cmd_render, _parser=p)

    p = sub.add_parser(
        "demo",
        parents=[common, with_json],
        help="anneal the embedded connecting-rod scan",
        description=f"Anneal the embedded scan of a connecting rod (seed 0), write {DEMO_MESH}"
        f" and {DEMO_PREVIEW}, and print its quality next to Delaunay's.",
    )
    p.add_argument(
        "-o",
        "--output-dir",
        default=".",
        metavar="OUTDIR",
        help="folder for the files (default: here)",
    )
    p.set_defaults(func=cmd_demo, _parser=p)
    return parser


# --------------------------------------------------------------------------- main


def _one_line(exc: BaseException) -> str:
    if isinstance(exc, OSError) and exc.strerror:
        text = f"{exc.filename}: {exc.strerror}" if exc.filename else exc.strerror
    else:
        text = str(exc) or type(exc).__name__
    return " ".join(text.split())


def _show_warning(message, category, filename, lineno, file=None, line=None) -> None:
    print(f"scanmesh: warning: {' '.join(str(message).split())}", file=sys.stderr, flush=True)


def main(argv: Sequence[str] | None = None) -> int:
    """Run the ``scanmesh`` command; return its exit status."""
    from scanmesh.errors import ScanmeshError

    try:
        parser = build_parser()
        args = parser.parse_args(argv)
        con = _Console(quiet=getattr(args, "quiet", False), as_json=getattr(args, "json", False))
        run: Callable[[argparse.Namespace, _Console], int] = args.func
        with warnings.catch_warnings():
            warnings.showwarning = _show_warning
            return run(args, con)
    except KeyboardInterrupt:
        print("scanmesh: interrupted", file=sys.stderr, flush=True)
        return 130
    except BrokenPipeError:
        # the reader of stdout went away (``scanmesh info x --json | head``): stop quietly,
        # and keep Python from reporting the pipe again when it flushes stdout at exit
        os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())
        return 1
    except (ScanmeshError, FileNotFoundError, OSError) as exc:
        print(f"scanmesh: error: {_one_line(exc)}", file=sys.stderr, flush=True)
        return 1


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
