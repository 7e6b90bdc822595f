"""The ``scanmesh`` command: reconstruct, compare, simulate, info, render, view and demo.

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
import re
import sys
import threading
import time
import warnings
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Any

import numpy as np

from scanmesh.render import auto_view as _auto_view
from scanmesh.surface import STEEP_ANGLE_DEG

#: Methods ``scanmesh compare`` runs by default: all but the exact one (small inputs only).
COMPARE_METHODS = ("delaunay", "lookahead", "shortest-path", "lop", "anneal")

#: Share of the points ``scanmesh compare`` withholds without ``--truth`` (the holdout
#: error: the truth-free judge of a method, ``scanmesh.truth.holdout_error``).
HOLDOUT_FRACTION = 0.1

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


def _holdout_fraction(text: str) -> float:
    """--holdout: a share in [0, 1)."""
    value = _non_negative(text)
    if value >= 1:
        raise argparse.ArgumentTypeError(f"{text!r} is not a share below 1")
    return value


def _count(text: str) -> int:
    try:
        value = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"{text!r} is not a whole number") from None
    if value < 0:
        raise argparse.ArgumentTypeError(f"{text!r} is negative")
    return value


def _positive_count(text: str) -> int:
    value = _count(text)
    if value == 0:
        raise argparse.ArgumentTypeError(f"{text!r} is not positive")
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
        #: every warning of the run, in the command's words (for --report)
        self.warnings: list[str] = []

    @property
    def progress(self) -> bool:
        """Progress bars: on a terminal, unless --quiet."""
        return not self.quiet and sys.stderr.isatty()

    def out(self, text: str = "") -> None:
        """Human output: the results asked for (nothing with --json)."""
        if not self.json:
            print(text, flush=True)

    def summary(self, text: str) -> None:
        """What was done and written (nothing with --json or --quiet)."""
        if not self.quiet:
            self.out(text)

    def warn(self, message, category, filename, lineno, file=None, line=None) -> None:
        """``warnings.showwarning``: one line on stderr naming flags, kept for --report."""
        text = _speak_flags(" ".join(str(message).split()))
        self.warnings.append(text)
        print(f"scanmesh: warning: {text}", file=sys.stderr, flush=True)

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


def _read_options(args: argparse.Namespace | None) -> dict[str, Any]:
    """The reader flags given (--columns, --returns, --classes, --grid, --cell), as keywords
    of read()."""
    flags = ("columns", "returns", "classes", "grid", "cell")
    return {k: getattr(args, k) for k in flags if getattr(args, k, None) not in (None, False)}


def _read_scan(path: Path, progress: bool = False, args: argparse.Namespace | None = None):
    from scanmesh.readers import read

    return read(path, progress=progress, **_read_options(args))


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


def _seconds(fn: Callable[[], Any]) -> float:
    """Seconds ``fn()`` takes."""
    t0 = time.perf_counter()
    fn()
    return time.perf_counter() - t0


def _method_flags() -> dict[str, tuple[Any, list[str]]]:
    """Every method option the command takes, by name: (the Option, the methods using it).

    Options without a textual form (a weight mapping, an incumbent triangulation) stay
    API-only; ``initial`` is offered by name."""
    from scanmesh.methods import TABLE

    flags: dict[str, tuple[Any, list[str]]] = {}
    for spec in TABLE.values():
        for option in spec.options:
            if option.kind == "any" and option.name != "initial":
                continue
            flags.setdefault(option.name, (option, []))[1].append(spec.name)
    return flags


def _flag_text(kind: str) -> Callable[[str], Any]:
    """argparse type of a flag: the text as a number (range checks come from the table)."""

    def convert(text: str) -> Any:
        try:
            return int(text) if kind == "int" else float(text)
        except ValueError:
            what = "a whole number" if kind == "int" else "a number"
            raise argparse.ArgumentTypeError(f"{text!r} is not {what}") from None

    return convert


#: Options whose None means "no limit" rather than "worked out from the data".
UNLIMITED_BY_NONE = frozenset({"time_limit"})


def _flag_help(name: str, users: list[str]) -> str:
    """Help of the flag of option ``name``: its doc and default, per method where the
    methods using it differ in either (e.g. --time-limit of annealing and of optimal)."""
    from scanmesh.methods import TABLE

    def default(option: Any) -> str:
        if option.default is None:
            return "no limit" if option.name in UNLIMITED_BY_NONE else "automatic"
        return f"{option.default:g}" if isinstance(option.default, float) else str(option.default)

    texts: dict[tuple[str, str], list[str]] = {}
    for user in users:
        option = next(o for o in TABLE[user].options if o.name == name)
        texts.setdefault((option.doc, default(option)), []).append(user)
    return "; ".join(
        f"{doc} ({', '.join(methods)}; default {shown})" for (doc, shown), methods in texts.items()
    )


def _add_method_flags(parser: argparse.ArgumentParser) -> None:
    from scanmesh.methods import INITIALS

    group = parser.add_argument_group("method options (each applies to the methods named)")
    for option, users in _method_flags().values():
        text = _flag_help(option.name, users).replace("%", "%%")
        if option.kind == "bool":
            group.add_argument(
                option.flag, action=argparse.BooleanOptionalAction, default=None, help=text
            )
        elif option.name == "initial":
            group.add_argument(option.flag, choices=INITIALS, default=None, help=text)
        elif option.kind == "choice":
            group.add_argument(option.flag, choices=option.choices, default=None, help=text)
        else:
            group.add_argument(
                option.flag,
                type=_flag_text(option.kind),
                default=None,
                metavar="N" if option.kind == "int" else "X",
                help=text,
            )


def _given_flags(args: argparse.Namespace) -> dict[str, Any]:
    """The method flags on the command line (name -> value)."""
    return {
        name: getattr(args, name)
        for name in _method_flags()
        if getattr(args, name, None) is not None
    }


def _refuse_stray_flags(
    args: argparse.Namespace, methods: Sequence[str], seeded: bool = False
) -> None:
    """A usage error for a flag none of ``methods`` uses (nothing is silently dropped);
    ``seeded``: the command itself uses --seed (compare's error sampling and holdout)."""
    from scanmesh.methods import TABLE

    flags = _method_flags()
    for name in _given_flags(args):
        option, users = flags[name]
        if not set(users) & set(methods):
            args._parser.error(f"{option.flag} applies to --method {', '.join(users)} only")
    for name in ("max_edge",) if seeded else ("max_edge", "seed"):
        if getattr(args, name, None) is not None and not any(
            name in TABLE[m].shared for m in methods
        ):
            users = [m for m, spec in TABLE.items() if name in spec.shared]
            flag = "--" + name.replace("_", "-")
            args._parser.error(f"{flag} applies to --method {', '.join(users)} only")


def _method_options(args: argparse.Namespace, method: str) -> dict[str, Any]:
    """The method flags ``method`` uses, checked by the table with the flag's name."""
    from scanmesh.methods import TABLE

    options = {o.name: o for o in TABLE[method].options}
    return {
        name: options[name].check(value, options[name].flag)
        for name, value in _given_flags(args).items()
        if name in options
    }


def _shared(args: argparse.Namespace, method: str, options: dict[str, Any]) -> dict[str, Any]:
    """--max-edge and --seed for a method that uses them (seed 0 when not given)."""
    from scanmesh.methods import SHARED, used_keywords

    used = used_keywords(method, options)
    shared: dict[str, Any] = {}
    if "max_edge" in used and args.max_edge is not None:
        shared["max_edge"] = SHARED["max_edge"].check(args.max_edge, "--max-edge")
    if "seed" in used:
        shared["seed"] = 0 if args.seed is None else SHARED["seed"].check(args.seed, "--seed")
    return shared


# --------------------------------------------------------------------------- reconstruct


def cmd_reconstruct(args: argparse.Namespace, con: _Console) -> int:
    """Read scan points, triangulate them, write the mesh (and a report and a preview)."""
    from scanmesh._progress import Stage
    from scanmesh.reconstruct import reconstruct
    from scanmesh.scan import planar_scan
    from scanmesh.writers import save_mesh

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
    _check_outputs([source], [out, report, preview])
    _check_mesh_ending(out)
    _check_png(preview)

    scan = planar_scan(
        source, plane=args.plane, progress=con.progress, read_options=_read_options(args)
    )
    t1 = time.perf_counter()
    surface = reconstruct(scan, args.method, progress=con.progress, **shared, **options)
    elapsed = time.perf_counter() - t1
    t2 = time.perf_counter()
    # The quality report (tac over every vertex: 4 s of CPU at 10M points) is measured
    # while the mesh is written: both release the GIL, so they overlap.
    measured = _background(lambda: _seconds(lambda: surface.quality)) if args.quality else None
    save_mesh(out, surface.vertices, surface.faces, protect=[source], progress=con.progress)
    t_write = time.perf_counter() - t2
    if measured is not None:
        with Stage(con.progress, "quality", len(surface.faces), blocking=True):
            t_quality = measured()
    data = _report(source, out, scan, surface, con, elapsed, args.quality)
    data["timings"]["write"] = t_write
    if measured is not None:
        data["timings"]["quality"] = t_quality  # beside the write, not after it
    if report is not None:
        _write_text(report, _dumps(data) + "\n")
    if preview is not None:
        from scanmesh.render import render_mesh

        with Stage(con.progress, "preview", len(surface.faces), blocking=True):
            view = _auto_view(surface.vertices, surface.faces, surface.frame)
            render_mesh(surface, preview, **view)
    if con.json:
        print(_dumps(data))
        return 0
    q = data["quality"]
    counts = data["counts"]
    lines = f" on {counts['lines']:,} lines" if counts["lines"] else ""
    con.summary(f"{source}: {counts['points']:,} points{lines}")
    con.summary(f"{surface.method}: {counts['faces']:,} faces in {elapsed:.2f} s")
    if q is None:
        con.summary("  quality not measured (--no-quality)")
    else:
        con.summary(
            f"  tac_1 {q['tac_1']:.4g}  tac_2 {q['tac_2']:.4g}  tac_inf {q['tac_inf']:.4g}"
            f"  smallest angle {_fmt(q['min_angle_deg'], '.2f')} deg"
            f"  slivers {100 * q['sliver_fraction']:.2f} %"
        )
    written = [str(out)] + [str(p) for p in (report, preview) if p is not None]
    con.summary(f"wrote {', '.join(written)}")
    return 0


def _reconstruct_on_dask(args: argparse.Namespace, con: _Console) -> int:
    """``reconstruct --dask``: the scan files (IN may be a glob) on a Dask cluster, the mesh
    written block by block by the workers (:func:`scanmesh.distributed.reconstruct_distributed`)."""
    from scanmesh._extras import require
    from scanmesh.distributed import reconstruct_distributed

    distributed = require("distributed", "dask", "--dask")
    out = Path(args.output)
    report = Path(args.report) if args.report else None
    given_flags = (("--preview", args.preview), ("--no-quality", not args.quality))
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
    _check_outputs([], [out, report])
    progress = con.progress and not con.json
    if args.dask == "local":
        cluster = distributed.LocalCluster(
            n_workers=args.workers, threads_per_worker=1, processes=True
        )
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
    con.summary(f"{result.method}: {result.n_faces:,} faces in {elapsed:.2f} s on Dask")
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
    from scanmesh.readers import count_lines

    return None if line_ids is None else int(count_lines(line_ids))


def _report(
    source, out, scan, surface, con: _Console, elapsed: float, quality: bool
) -> dict[str, Any]:
    """The command's report; ``quality`` False leaves the mesh unmeasured (``None``)."""
    from scanmesh import __version__

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


# --------------------------------------------------------------------------- compare


def cmd_compare(args: argparse.Namespace, con: _Console) -> int:
    """Run several methods on the same points; one table (and one picture)."""
    from scanmesh.errors import ScanmeshError
    from scanmesh.reconstruct import reconstruct
    from scanmesh.scan import planar_scan

    source = Path(args.input)
    picture = Path(args.picture) if args.picture else None
    methods = list(dict.fromkeys(args.methods or COMPARE_METHODS))
    # --seed also seeds the height error's samples and the holdout's withheld points
    _refuse_stray_flags(args, methods, seeded=True)
    options = {m: _method_options(args, m) for m in methods}
    shared = {m: _shared(args, m, options[m]) for m in methods}
    inputs = [source] + ([Path(args.truth)] if args.truth else [])
    _check_outputs(inputs, [picture])
    _check_png(picture)
    truth = None
    if args.truth:
        from scanmesh.truth import TrueSurface

        truth = TrueSurface(args.truth)
    scan = planar_scan(
        source, plane=args.plane, progress=con.progress, read_options=_read_options(args)
    )

    rows, surfaces, failed = [], [], {}
    # One trimmed Delaunay triangulation: a row of its own and the start of LOP and annealing.
    built: list[tuple[Any, float]] = []

    def delaunay_base() -> tuple[Any, float]:
        if not built:
            t = time.perf_counter()
            base = reconstruct(
                scan, "delaunay", progress=con.progress, **_shared(args, "delaunay", {})
            )
            built.append((base, time.perf_counter() - t))
        return built[0]

    for method in methods:
        if con.progress:
            con.note(f"{method} ...")
        kwargs = {**shared[method], **options[method]}
        try:
            if method == "delaunay":
                surface, seconds = delaunay_base()
            else:
                start = 0.0
                if method in ("lop", "anneal") and kwargs.get("initial", "delaunay") == "delaunay":
                    kwargs.pop("max_edge", None)
                    kwargs["initial"], start = delaunay_base()
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
            from scanmesh.truth import domain_error, height_error

            err = height_error(surface, truth, seed=args.seed or 0)
            row.update({k: err[k] for k in ("h_rms", "h_mean", "h_max")})
            dom = domain_error(surface, truth)
            row.update({k: dom[k] for k in ("air_share", "missed_share")})
        elif args.holdout > 0:
            row.update(_holdout_row(scan, method, args, options[method], shared[method]))
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
        elif args.holdout > 0:
            from scanmesh.truth import HOLDOUT_MEASURE

            data["holdout_error"] = {"measure": HOLDOUT_MEASURE, "fraction": args.holdout}
        if failed:
            data["failed"] = failed
        print(_dumps(data))
    else:
        _print_table(con, source, scan, rows, truth is not None)
        if picture is not None and surfaces:
            con.summary(f"wrote {picture}")
    return 1 if failed else 0


def _holdout_row(scan, method: str, args, options: dict, shared: dict) -> dict[str, Any]:
    """The holdout error of ``method`` on ``scan`` (rebuilt from the kept points with the
    same options; the seed of --seed chooses the withheld points)."""
    from scanmesh.errors import ScanmeshError
    from scanmesh.truth import holdout_error

    given = {k: v for k, v in shared.items() if k not in ("lines", "seed")}
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")  # the full run already warned about this scan
            err = holdout_error(
                scan.points,
                method,
                fraction=args.holdout,
                seed=args.seed or 0,
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
            "h_*: closest-point distance to the truth at 100,000 random points on each"
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
        con.summary(f"wrote {out}: {len(points):,} points on {n_lines:,} lines ({elapsed:.2f} s)")
    return 0


# --------------------------------------------------------------------------- info


def cmd_info(args: argparse.Namespace, con: _Console) -> int:
    """Points, lines, extent, spacing and the share of steep triangles of a scan file."""
    from scanmesh.delaunay import MAX_EDGE_FACTOR, delaunay
    from scanmesh.scan import as_scan

    source = Path(args.input)
    if _is_mesh_file(source):
        return _judge_mesh(source, con)
    scan = _read_scan(source, con.progress, args)  # the reader's details (format, line source)
    pts = scan.points
    # projected once for Delaunay, the lines and the noise estimate, on the plane chosen
    # (with the file's up) for None
    planar = as_scan(pts, plane=args.plane, lines=scan.line_ids, up=scan.up)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # coincident points are counted below
        surface = delaunay(planar)
    # delaunay() trims at MAX_EDGE_FACTOR x the median nearest-neighbour spacing
    spacing = float(surface.options["max_edge"]) / MAX_EDGE_FACTOR
    normal = np.asarray(surface.frame.normal, dtype=np.float64)
    steep = surface.steep_fraction
    lines, lines_from = _lines_info(scan, planar)
    sigma = _noise_or_none(planar)
    lo, hi = pts.min(axis=0), pts.max(axis=0)
    data = {
        "input": str(source),
        "format": scan.extra.get("format"),
        "points": int(len(pts)),
        "lines": lines,
        "lines_from": lines_from,
        "extent": {"min": lo, "max": hi, "size": hi - lo},
        "plane_normal": normal,
        "plane_choice": planar.choice.as_dict(normal) if planar.choice else None,
        "median_spacing": spacing,
        "noise": sigma,
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
    _print_extent(con, lo, hi)
    chosen = f" (chosen: {planar.choice.chosen})" if planar.choice else ""
    con.out(f"  plane normal      {'  '.join(f'{x:.4g}' for x in normal)}{chosen}")
    con.out(f"  median spacing    {spacing:.6g} (nearest neighbour, in the plane)")
    if sigma is not None:
        con.out(
            f"  noise             {sigma:.3g} (sigma along the plane normal; {sigma / spacing:.2g}"
            " x spacing)"
        )
    con.out(f"  coincident        {len(surface.duplicates):,} points (in the plane)")
    con.out(
        f"  steep share       {100 * steep:.2f} % of {len(surface.faces):,} Delaunay triangles"
        f" tilt more than {STEEP_ANGLE_DEG:g} deg from the plane normal"
    )
    return 0


#: Endings that hold a mesh, never scan points: ``scanmesh info`` judges them.
MESH_ENDINGS = (".stl", ".obj", ".off", ".glb")


def _print_extent(con: _Console, lo: np.ndarray, hi: np.ndarray) -> None:
    """The min, max and size rows of ``scanmesh info``."""
    for label, vec in (("min", lo), ("max", hi), ("size", hi - lo)):
        con.out(f"  {label:<18}{'  '.join(f'{x:.6g}' for x in vec)}")


def _is_mesh_file(path: Path) -> bool:
    """A mesh file: a mesh-only ending, or a PLY whose header declares faces."""
    ending = path.suffix.lower()
    if ending in MESH_ENDINGS:
        return True
    if ending != ".ply" or not path.is_file():
        return False
    with open(path, "rb") as f:
        head = f.read(4096)
    header = head.split(b"end_header", 1)[0]
    return any(
        line.split()[:2] == [b"element", b"face"] and line.split()[2:3] != [b"0"]
        for line in header.splitlines()
    )


def _judge_mesh(path: Path, con: _Console) -> int:
    """``scanmesh info MESH``: the same quality figures every method is judged by."""
    from scanmesh.quality import quality

    vertices, faces = _mesh_file(path)
    q = quality(vertices, faces)
    lo, hi = vertices.min(axis=0), vertices.max(axis=0)
    data = {
        "input": str(path),
        "kind": "mesh",
        "vertices": int(len(vertices)),
        "faces": int(len(faces)),
        "extent": {"min": lo, "max": hi, "size": hi - lo},
        "quality": q.as_dict(),
    }
    if con.json:
        print(_dumps(data))
        return 0
    con.out(f"{path} (a mesh)")
    con.out(f"  vertices          {len(vertices):,}")
    con.out(f"  faces             {len(faces):,}")
    _print_extent(con, lo, hi)
    con.out(
        f"  tac_1 / 2 / inf   {q.tac_1:.4g} / {q.tac_2:.4g} / {q.tac_inf:.4g} rad"
        f" over {q.n_interior:,} interior vertices"
    )
    con.out(f"  min angle         {_fmt(q.min_angle_deg, '.2f')} deg")
    con.out(
        f"  slivers           {100 * q.sliver_fraction:.2f} % (smallest angle below"
        f" {_sliver_deg():g} deg)"
    )
    return 0


def _noise_or_none(planar) -> float | None:
    """scanmesh.noise of the scan, or None when too few points allow an estimate."""
    from scanmesh.errors import DegenerateInputError
    from scanmesh.noise import noise

    try:
        return noise(planar)
    except DegenerateInputError:
        return None


def _lines_info(scan, planar) -> tuple[int | None, str]:
    """Scan lines: from the file, else detected from the point order of the PlanarScan."""
    from scanmesh.lines import detect_lines

    if scan.line_ids is not None:
        return int(scan.n_lines), f"from the file: {scan.extra.get('line_ids_from') or 'ids'}"
    ids = detect_lines(planar)
    return int(len(np.unique(ids))), "detected from the point order"


# --------------------------------------------------------------------------- render


def _mesh_file(path: Path) -> tuple[np.ndarray, np.ndarray]:
    """(V, 3) float64 vertices and (F, 3) int64 faces of a mesh file, as trimesh reads it."""
    from scanmesh.digitizer import load_mesh

    mesh = load_mesh(path)
    return np.asarray(mesh.vertices, dtype=np.float64), np.asarray(mesh.faces, dtype=np.int64)


def cmd_render(args: argparse.Namespace, con: _Console) -> int:
    """A flat-shaded PNG picture of a mesh file."""
    from scanmesh.render import render_mesh

    mesh_path, out = Path(args.mesh), Path(args.output)
    _check_outputs([mesh_path], [out])
    _check_png(out)
    vertices, faces = _mesh_file(mesh_path)
    camera = _auto_view(vertices, faces)
    if args.view is not None:
        camera["view"] = args.view
    if args.up is not None:
        camera["up"] = args.up
    colors = {"color_by": args.color, "truth": args.truth}
    render_mesh((vertices, faces), out, size=args.size, wire=args.wire, **colors, **camera)
    con.summary(f"wrote {out}")
    return 0


# --------------------------------------------------------------------------- view


def cmd_view(args: argparse.Namespace, con: _Console) -> int:
    """A self-contained HTML page (or GLB file) showing a mesh in 3-D, opened in a browser."""
    import tempfile
    import webbrowser

    from scanmesh.errors import ParameterError
    from scanmesh.view import save_glb, save_html

    mesh_path = Path(args.mesh)
    out = Path(args.output) if args.output else None
    if out is not None and out.suffix.lower() not in (".html", ".htm", ".glb"):
        raise ParameterError(f"cannot write {out}: a view is written as .html or .glb")
    _check_outputs([mesh_path], [out])
    mesh = _mesh_file(mesh_path)
    if out is None:  # a fresh folder: nothing of the user's is overwritten
        out = Path(tempfile.mkdtemp(prefix="scanmesh-view-")) / f"{mesh_path.stem}.html"
    colors = {"color_by": args.color, "truth": args.truth, "up": args.up}
    if out.suffix.lower() == ".glb":
        save_glb(mesh, out, **colors)
    else:
        save_html(mesh, out, view=args.view, title=mesh_path.name, **colors)
    con.summary(f"wrote {out}")
    if not args.no_open and out.suffix.lower() != ".glb":
        if not webbrowser.open(out.resolve().as_uri()):
            con.out("no web browser found here: open the file in one")
    return 0


# --------------------------------------------------------------------------- demo


def cmd_demo(args: argparse.Namespace, con: _Console) -> int:
    """Anneal the embedded connecting-rod scan; write demo_rod.stl and demo_rod.png."""
    from scanmesh.delaunay import delaunay
    from scanmesh.demo import SCAN_SETTINGS, demo_truth, load_demo
    from scanmesh.errors import ParameterError
    from scanmesh.reconstruct import reconstruct
    from scanmesh.render import render_mesh
    from scanmesh.scan import planar_scan
    from scanmesh.truth import MEASURE, TrueSurface, height_error
    from scanmesh.writers import save_mesh

    folder = Path(args.output_dir)
    parent = folder.parent if str(folder.parent) else Path(".")
    if not parent.is_dir():
        raise ParameterError(f"cannot write into {folder}: folder {parent} does not exist")
    folder.mkdir(exist_ok=True)
    mesh_path, png_path = folder / DEMO_MESH, folder / DEMO_PREVIEW
    points, line_ids = load_demo()
    plane = SCAN_SETTINGS["up"]  # scanned along the rod's thickness axis
    con.out(
        f"demo: a connecting rod scanned along its thickness ({plane}): {len(points):,} points"
        f" on {int(line_ids.max()) + 1} lines"
    )
    # One scan and one Delaunay triangulation: a column of the table and annealing's start.
    t0 = time.perf_counter()
    scan = planar_scan(points, plane=plane, lines=line_ids)
    base = delaunay(scan)
    t_base = time.perf_counter() - t0
    t0 = time.perf_counter()
    surface = reconstruct(scan, "anneal", initial=base, seed=0, progress=con.progress)
    t_anneal = t_base + time.perf_counter() - t0
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
    con.summary(f"wrote {mesh_path} and {png_path}")
    return 0


# --------------------------------------------------------------------------- parser


def build_parser() -> argparse.ArgumentParser:
    """The argument parser of the ``scanmesh`` command."""
    from scanmesh import __version__
    from scanmesh.methods import METHODS

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
        help="projection plane: best-fit, x, y, z or a normal vector nx,ny,nz (default:"
        " chosen by the data, fewest steep triangles among the file's up, best-fit, the"
        " axes and the principal axes)",
    )
    shape.add_argument(
        "--max-edge",
        type=_max_edge,
        default=None,
        metavar="L",
        help="drop Delaunay triangles with a longer planar edge (default 5 x median spacing;"
        " inf keeps the convex hull)",
    )
    shape.add_argument(
        "--seed", type=_count, default=None, metavar="S", help="random seed (anneal; 0)"
    )
    _add_method_flags(shape)

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
    p.add_argument(
        "--no-quality",
        dest="quality",
        action="store_false",
        help="do not measure the mesh (tac norms, smallest angle, slivers: about 4 s of CPU"
        " at 10M points); the report's quality is then null",
    )
    p.add_argument(
        "--dask",
        metavar="ADDRESS",
        help="run on a Dask cluster: 'local' (a local cluster of processes) or a scheduler"
        " address (tcp://host:8786); IN may then be a quoted glob of files, each a run of"
        " consecutive scan lines; OUT (.stl or .ply) must be on a folder every worker sees",
    )
    p.add_argument(
        "--workers", type=_positive_count, metavar="N", help="workers of --dask local (one a core)"
    )
    p.add_argument(
        "--partition-lines",
        type=_positive_count,
        metavar="L",
        help="with --dask: scan lines per strip partition (default: one partition per file)",
    )
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
    p.add_argument(
        "--holdout",
        type=_holdout_fraction,
        default=HOLDOUT_FRACTION,
        metavar="F",
        help="without --truth: withhold this share of the points, rebuild each method from"
        f" the rest and measure the withheld points' height error ({HOLDOUT_FRACTION:g};"
        " 0: off)",
    )
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
        help="describe a scan file, or judge a mesh file",
        description="A scan: points, scan lines, extent, median spacing, noise and the share"
        f" of steep Delaunay triangles (normal more than {STEEP_ANGLE_DEG:g} deg from the"
        " projection normal). A mesh (.stl, .obj, .off, .glb, or a .ply with faces): tac"
        " norms, smallest angle and sliver share, as every method is judged.",
    )
    p.add_argument("input", metavar="IN", help="scan or mesh file")
    _add_read_flags(p)
    p.add_argument(
        "--plane",
        type=_plane,
        default=None,
        metavar="P",
        help="projection plane (best-fit, x, y, z or nx,ny,nz; default: chosen by the data)",
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
    _color_flags(p)
    p.set_defaults(func=cmd_render, _parser=p)

    p = sub.add_parser(
        "view",
        parents=[common],
        help="3-D view of a mesh in the web browser (an offline HTML page)",
        description="Write a self-contained HTML page that shows a mesh in 3-D (drag to"
        " turn, wheel to zoom; no network needed) and open it in the web browser.",
    )
    p.add_argument("mesh", metavar="MESH", help="mesh file")
    p.add_argument(
        "-o",
        "--output",
        metavar="FILE",
        help="page to write (.html), or a .glb file for other viewers (default: a new"
        " temporary folder)",
    )
    p.add_argument("--view", type=_axis, help="first view: direction from the part to the eye")
    p.add_argument("--up", type=_axis, help="model direction shown upwards")
    p.add_argument("--no-open", action="store_true", help="write the page, do not open it")
    _color_flags(p)
    p.set_defaults(func=cmd_view, _parser=p)

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


def _color_flags(p: argparse.ArgumentParser) -> None:
    from scanmesh.render import COLOR_BY

    p.add_argument(
        "--color",
        choices=COLOR_BY,
        default=None,
        help="colour faces by tac, by error (distance to --truth) or by height (along --up"
        " or the surface's normal); default one colour",
    )
    p.add_argument("--truth", metavar="PART", help="true surface (mesh file) for --color error")


# --------------------------------------------------------------------------- main


def _one_line(exc: BaseException) -> str:
    if isinstance(exc, OSError) and exc.strerror:
        text = f"{exc.filename}: {exc.strerror}" if exc.filename else exc.strerror
    else:
        text = str(exc) or type(exc).__name__
    return " ".join(text.split())


#: Python advice in messages, and what the command's user types instead.
_PYTHON_WORDS = (
    (re.compile(r"reconstruct\(method='([\w-]+)'\)"), r"--method \1"),
    (re.compile(r"Surface\.options\['(\w+)'\]"), r"the --report's options.\1"),
    (re.compile(r"Surface\.duplicates"), "the --report's counts.duplicates"),
    (re.compile(r"\bmath\.inf\b"), "inf"),
)


def _speak_flags(text: str) -> str:
    """A library message in the command's words: ``name=`` of an option or a shared
    keyword becomes its flag (``--max-edge``), Python calls become flags."""
    from scanmesh.methods import SHARED

    names = set(_method_flags()) | set(SHARED) | {"plane"}
    for pattern, replacement in _PYTHON_WORDS:
        text = pattern.sub(replacement, text)
    return (
        re.sub(
            r"\b([a-z][a-z_]*)=(?!=)",
            lambda m: (
                "--" + m.group(1).replace("_", "-") + " " if m.group(1) in names else m.group(0)
            ),
            text,
        )
        .replace(" ,", ",")
        .replace(" )", ")")
    )


#: Flags whose value may start with a minus sign (a vector like -1,-1,1).
VECTOR_FLAGS = ("--plane", "--up", "--along", "--view")


def _join_vectors(argv: Sequence[str]) -> list[str]:
    """``--view -1,-1,1`` as ``--view=-1,-1,1``: argparse takes a value starting with '-'
    for a flag unless it looks like one negative number."""
    out: list[str] = []
    items = list(argv)
    k = 0
    while k < len(items):
        item = items[k]
        nxt = items[k + 1] if k + 1 < len(items) else None
        if item in VECTOR_FLAGS and nxt is not None and nxt.startswith("-") and _vector(nxt):
            out.append(f"{item}={nxt}")
            k += 2
            continue
        out.append(item)
        k += 1
    return out


def main(argv: Sequence[str] | None = None) -> int:
    """Run the ``scanmesh`` command; return its exit status."""
    from scanmesh.errors import ScanmeshError

    try:
        parser = build_parser()
        args = parser.parse_args(_join_vectors(sys.argv[1:] if argv is None else argv))
        con = _Console(quiet=getattr(args, "quiet", False), as_json=getattr(args, "json", False))
        run: Callable[[argparse.Namespace, _Console], int] = args.func
        with warnings.catch_warnings():
            warnings.simplefilter("always")  # every warning reaches the report
            warnings.showwarning = con.warn
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
        print(f"scanmesh: error: {_speak_flags(_one_line(exc))}", file=sys.stderr, flush=True)
        return 1


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
