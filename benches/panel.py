"""The panel: every method on every scan of a fixed set, judged by its error, tac_1, slivers,
wall time and peak memory.

Scans (from ../shared/data, or the folder given with --data):

- real: fran_cut (Cyberware range scan), SainteHelens (USGS DEM), the Autzen LiDAR first
  returns and its ground (class 2). Error: holdout RMS (10 % of the points withheld) over 3
  seeded splits (seeds 0, 1, 2), each split reconstructed with the same method (mean of the
  three RMS values; ``scanmesh.evaluate.holdout.holdout_error``).
- simulated: every CAD part scanned by ``scanmesh.simulate_scan`` along its height-field
  axis, once as it lies ("axis") and once turned 30 degrees about the scanning axis
  ("oblique": creases cross the scan lines), each at noise sigma = 0, s/30 and s/10 (s the
  spacing); and one scan of the turbine blade with at least 1M points. Error: height RMS
  and mean normal error against the (turned) part (``scanmesh.evaluate.truth``), on
  100,000 samples (seed 0). The connecting rod scanned along its thickness (y: ribs, bores,
  walls at every one) is among them ("conrod_axis_0", "conrod_axis_s/30"); and one part is
  given as plain points, in scan order without line ids ("..._points": methods that need
  lines detect them from the order).

Each (scan, method) runs in a fresh child process (multiprocessing, spawn) that loads the
scan from a temporary .npz, so the memory column is that process's peak resident set size
(``resource.getrusage(RUSAGE_SELF).ru_maxrss``) right after ``reconstruct``: the
interpreter, numpy, the scan and the method together, the figure a user sees (the error
measures run after it and are not counted). Wall time is the main ``reconstruct`` call only;
"x LOP" is it over LOP's on the same scan in the same run; CPU seconds are the same call's
``time.process_time`` (every thread of the process), which other processes' load does not
inflate: on an idle machine the wall time is at most about the CPU time.
A run still going after ``--cap`` seconds is stopped and its cells read "timed out"
(figures already measured are kept: the reconstruction may finish and the holdout not).
With the default among the methods, a summary comes first: per scan the default's error
over the best other method's and strips-anneal's, its slivers and tac_1, and its wall time
over LOP's and its CPU seconds (``summary``).

    python benches/panel.py --quick                       # a few minutes on 2 cores
    python benches/panel.py --out panel.md                # the full panel
    python benches/panel.py --scans fran_cut,autzen_ground --methods lop,anneal
"""

from __future__ import annotations

import argparse
import math
import multiprocessing as mp
import os
import queue
import sys
import tempfile
import time
import warnings
from pathlib import Path

import numpy as np

#: ../shared/data beside the repository (as the other benches find the shared data)
SHARED = Path(__file__).resolve().parents[2] / "shared" / "data"

METHODS = ("delaunay", "lop", "lookahead", "shortest-path", "anneal", "strips-anneal", "auto")

#: Methods that take the scan lines and the seed when the scan has them.
LINES = ("lookahead", "shortest-path", "anneal", "strips-anneal", "auto")
SEEDED = ("anneal", "strips-anneal", "auto")

#: Scans given as plain points (no line ids): (part, up, oblique, noise label).
POINTS_ONLY = (("octagonal_pocket.ply", "z", False, "s/30"),)

#: Per CAD part: the axis its scanned side is a height field along (see the data README).
PARTS = {
    "conrod_slevin48_onshape.stl": "y",
    "octagonal_pocket.ply": "z",
    "fandisk.obj": "y",
    "turbineblade.ply": "y",
}

#: Noise levels as fractions of the spacing, with their labels.
NOISE = ((0.0, "0"), (1 / 30, "s/30"), (1 / 10, "s/10"))

#: Holdout: share withheld and the seeds of the splits.
HOLDOUT_FRACTION, HOLDOUT_SEEDS = 0.1, (0, 1, 2)

#: Samples of the height and normal error.
TRUTH_SAMPLES = 100_000


def _turned(mesh, up: str, degrees: float):
    """The mesh turned by ``degrees`` about the axis ``up`` through its centroid."""
    import trimesh

    axis = np.eye(3)["xyz".index(up)]
    turn = trimesh.transformations.rotation_matrix(math.radians(degrees), axis, mesh.centroid)
    out = mesh.copy()
    out.apply_transform(turn)
    return out


def _scan_part(path: Path, up: str, oblique: bool, cells: int, sigma: float, n_points=None):
    """(points, lines, truth mesh, spacing) of a simulated scan of a part."""
    import trimesh

    import scanmesh

    mesh = trimesh.load(path, force="mesh")
    if oblique:
        mesh = _turned(mesh, up, 30.0)
    along = "x" if up != "x" else "y"
    if n_points is not None:
        pts, lines = scanmesh.simulate_scan(mesh, up=up, along=along, n_points=n_points)
        spacing = float(np.median(np.linalg.norm(np.diff(pts, axis=0), axis=1)))
    else:
        across = [k for k in range(3) if "xyz"[k] != up]
        spacing = float(np.ptp(mesh.bounds[:, across], axis=0).max()) / cells
        pts, lines = scanmesh.simulate_scan(
            mesh, up=up, along=along, spacing=spacing, noise=sigma * spacing, seed=0
        )
    return pts, lines, mesh, spacing


def panel(data: Path, quick: bool) -> list[dict]:
    """The scans: name, kind ("real" / "sim"), and how to make them."""
    scans: list[dict] = [
        {"name": "fran_cut", "kind": "real", "path": data / "scans" / "fran_cut.vtk"},
        {
            "name": "autzen_ground",
            "kind": "real",
            "path": data / "lidar" / "autzen_trim.laz",
            "read": {"classes": 2},
        },
    ]
    if not quick:
        scans += [
            {"name": "SainteHelens", "kind": "real", "path": data / "terrain" / "SainteHelens.dem"},
            {
                "name": "autzen_first",
                "kind": "real",
                "path": data / "lidar" / "autzen_trim.laz",
                "read": {"returns": "first"},
            },
        ]
    parts = ["octagonal_pocket.ply"] if quick else list(PARTS)
    noise = (NOISE[0], NOISE[2]) if quick else NOISE
    cells = 60 if quick else 150
    for part in parts:
        stem = Path(part).stem.split("_")[0]
        for oblique in (False, True):
            for sigma, label in noise:
                scans.append(
                    {
                        "name": f"{stem}_{'oblique' if oblique else 'axis'}_{label}",
                        "kind": "sim",
                        "part": data / "cad" / part,
                        "up": PARTS[part],
                        "oblique": oblique,
                        "sigma": sigma,
                        "cells": cells,
                    }
                )
    for part, up, oblique, label in () if quick else POINTS_ONLY:
        stem = Path(part).stem.split("_")[0]
        scans.append(
            {
                "name": f"{stem}_{'oblique' if oblique else 'axis'}_{label}_points",
                "kind": "sim",
                "part": data / "cad" / part,
                "up": up,
                "oblique": oblique,
                "sigma": dict((b, a) for a, b in NOISE)[label],
                "cells": cells,
                "points_only": True,
            }
        )
    if not quick:
        scans.append(
            {
                "name": "turbineblade_1M",
                "kind": "sim",
                "part": data / "cad" / "turbineblade.ply",
                "up": "y",
                "oblique": False,
                "sigma": 1 / 30,
                "cells": 0,
                "n_points": 1_000_000,
            }
        )
    return scans


def prepare(scan: dict, folder: Path) -> dict:
    """Make the scan once (parent process): points and lines to an .npz, the truth to .ply."""
    import scanmesh

    stem = scan["name"].replace("/", "-")
    out = folder / f"{stem}.npz"
    info = {"npz": str(out)}
    if scan["kind"] == "real":
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            read = scanmesh.read(scan["path"], **scan.get("read", {}))
        pts, lines = read.points, read.line_ids
        info["plane"] = None if read.up is None else [float(x) for x in read.up]
    else:
        n = scan.get("n_points")
        if n:  # the fine scan: the spacing follows from the count, the noise from it
            pts, lines, mesh, s = _scan_part(scan["part"], scan["up"], False, 0, 0.0, n)
            rng = np.random.default_rng(0)
            pts = (
                pts
                + rng.normal(0.0, scan["sigma"] * s, len(pts))[:, None]
                * np.eye(3)["xyz".index(scan["up"])]
            )
        else:
            pts, lines, mesh, s = _scan_part(
                scan["part"], scan["up"], scan["oblique"], scan["cells"], scan["sigma"]
            )
        truth = folder / f"{stem}_truth.ply"
        mesh.export(truth)
        info["truth"], info["spacing"], info["plane"] = str(truth), s, scan["up"]
    if scan.get("points_only"):
        lines = None
    np.savez(out, points=pts, lines=np.asarray(lines) if lines is not None else np.zeros(0))
    info["n"] = len(pts)
    return info


def child(kind: str, info: dict, method: str, out: mp.Queue) -> None:
    """One method on one scan, in its own process; sends figures as they come."""
    import resource

    warnings.simplefilter("ignore")
    import scanmesh
    from scanmesh.evaluate.holdout import holdout_error
    from scanmesh.evaluate.truth import TrueSurface, height_error, normal_error

    data = np.load(info["npz"])
    pts = data["points"]
    lines = data["lines"] if len(data["lines"]) else None
    plane = info.get("plane")
    kw = {"plane": plane} if plane is not None else {}
    if method in LINES and lines is not None:
        kw["lines"] = lines
    if method in SEEDED:
        kw["seed"] = 0
    t0, cpu0 = time.perf_counter(), time.process_time()
    surface = scanmesh.reconstruct(pts, method, **kw)
    wall, cpu = time.perf_counter() - t0, time.process_time() - cpu0
    q = surface.quality
    peak = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024  # KiB -> MiB (Linux)
    figures = {"wall": wall, "cpu": cpu, "tac_1": q.tac_1, "slivers": q.sliver_fraction}
    out.put({**figures, "peak_mb": peak})
    if kind == "sim":
        truth = TrueSurface(info["truth"])
        mesh = (surface.vertices, surface.faces)
        h = height_error(mesh, truth, n_samples=TRUTH_SAMPLES, seed=0)
        n = normal_error(mesh, truth, n_samples=TRUTH_SAMPLES, seed=0)
        out.put({"h_rms": h["h_rms"], "n_mean": n["n_mean_deg"]})
    else:
        rms = []
        for seed in HOLDOUT_SEEDS:
            rest = {k: v for k, v in kw.items() if k != "seed"}  # the split's seed seeds it
            r = holdout_error(pts, method, fraction=HOLDOUT_FRACTION, seed=seed, **rest)
            rms.append(r["rms"])
        out.put({"holdout": float(np.mean(rms))})
    out.put({"done": True})


def run(kind: str, info: dict, method: str, cap: float) -> dict:
    """Figures of one run (``timed_out`` set when the cap stopped it)."""
    ctx = mp.get_context("spawn")
    q: mp.Queue = ctx.Queue()
    p = ctx.Process(target=child, args=(kind, info, method, q), daemon=True)
    p.start()
    got: dict = {}
    deadline = time.monotonic() + cap
    while "done" not in got:
        left = deadline - time.monotonic()
        if left <= 0:
            got["timed_out"] = True
            break
        try:
            got.update(q.get(timeout=min(left, 1.0)))
        except queue.Empty:
            if not p.is_alive() and q.empty():
                got["failed"] = f"exit code {p.exitcode}"
                break
    if p.is_alive():
        p.terminate()
    p.join(5)
    return got


def cell(got: dict, key: str, fmt: str) -> str:
    if key in got:
        return format(got[key], fmt)
    if got.get("timed_out"):
        return "timed out"
    return "failed" if got.get("failed") else ""


def table(rows: list[tuple[dict, dict, str, dict]]) -> str:
    head = (
        "| scan | points | method | error | normal err (deg) | tac_1 | slivers | wall (s)"
        " | x LOP | CPU (s) | peak RSS (MiB) |\n"
        "|---|---:|---|---:|---:|---:|---:|---:|---:|---:|---:|\n"
    )
    lop_wall = {s["name"]: g["wall"] for s, _, m, g in rows if m == "lop" and "wall" in g}
    lines = []
    for scan, info, method, got in rows:
        base = lop_wall.get(scan["name"])
        ratio = f"{got['wall'] / base:.2f}" if base and "wall" in got else ""

        if scan["kind"] == "real":
            err = cell(got, "holdout", ".4g")
            err = f"{err} (holdout)" if "holdout" in got else err
            normal = ""
        else:
            err = cell(got, "h_rms", ".4g")
            err = f"{err} (height)" if "h_rms" in got else err
            normal = cell(got, "n_mean", ".3g")
        slivers = f"{100 * got['slivers']:.2f} %" if "slivers" in got else cell(got, "x", "")
        lines.append(
            f"| {scan['name']} | {info['n']:,} | {method} | {err} | {normal}"
            f" | {cell(got, 'tac_1', '.5g')} | {slivers} | {cell(got, 'wall', '.2f')}"
            f" | {ratio} | {cell(got, 'cpu', '.2f')} | {cell(got, 'peak_mb', '.0f')} |"
        )
    return head + "\n".join(lines) + "\n"


#: The methods the default is compared with ("best other method"): all but the default and
#: the hybrid it usually builds (shown alone in its own column).
OTHERS = ("delaunay", "lop", "lookahead", "shortest-path", "anneal")


def summary(rows: list[tuple[dict, dict, str, dict]]) -> str:
    """Per scan: the default's error against the best other method's (:data:`OTHERS`) and
    strips-anneal's, its slivers and tac_1 (beside the strips' and LOP's) and its wall time
    over LOP's in the same run, and its CPU seconds (every thread of its process: unlike
    wall seconds they do not grow with other processes' load, and on an idle machine the
    wall time is at most about them). Empty without the default's rows."""
    key = {"real": "holdout", "sim": "h_rms"}
    by: dict[str, dict] = {}
    for scan, info, method, got in rows:
        by.setdefault(scan["name"], {"scan": scan, "info": info})[method] = got
    head = (
        "| scan | points | the default's error | best other method | ratio | strips-anneal"
        " alone (ratio) | slivers | tac_1 (strips' / LOP's) | time / LOP | CPU (s) |\n"
        "|---|---:|---:|---|---:|---:|---:|---:|---:|---:|\n"
    )
    lines = []
    for name, got in by.items():
        k = key[got["scan"]["kind"]]
        auto = got.get("auto", {})
        if k not in auto:
            continue
        others = {m: got[m][k] for m in OTHERS if k in got.get(m, {})}
        best = min(others, key=others.__getitem__) if others else None
        ratio = f"**{auto[k] / others[best]:.3f}**" if best else ""
        alone = got.get("strips-anneal", {}).get(k)
        alone = f"{alone / others[best]:.3f}" if best and alone is not None else ""
        lop = got.get("lop", {})
        strips = got.get("shortest-path", {})
        tac = (
            f"{auto['tac_1']:.5g} ({strips.get('tac_1', math.nan):.5g} /"
            f" {lop.get('tac_1', math.nan):.5g})"
        )
        time_ratio = f"{auto['wall'] / lop['wall']:.2f}" if "wall" in lop else ""
        lines.append(
            f"| {name} | {got['info']['n']:,} | {auto[k]:.4g} |"
            f" {best} {others[best]:.4g} | {ratio} | {alone} | {100 * auto['slivers']:.2f} %"
            f" | {tac} | {time_ratio} | {cell(auto, 'cpu', '.2f')} |"
            if best
            else f"| {name} | {got['info']['n']:,} | {auto[k]:.4g} | | | | | | | |"
        )
    return head + "\n".join(lines) + "\n" if lines else ""


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--data", type=Path, default=SHARED, help="the shared data folder")
    parser.add_argument("--scans", help="comma-separated scan names (default: all)")
    parser.add_argument("--methods", default=",".join(METHODS), help="comma-separated")
    parser.add_argument("--quick", action="store_true", help="a reduced panel (minutes)")
    parser.add_argument("--cap", type=float, help="seconds per run (60 quick, 600 full)")
    parser.add_argument("--out", type=Path, help="write the Markdown table here")
    args = parser.parse_args()
    methods = [m for m in args.methods.split(",") if m]
    if unknown := set(methods) - set(METHODS):
        parser.error(f"unknown methods {sorted(unknown)}; choose from {', '.join(METHODS)}")
    scans = panel(args.data, args.quick)
    if args.scans:
        wanted = set(args.scans.split(","))
        full = {s["name"]: s for s in panel(args.data, False)} | {s["name"]: s for s in scans}
        if unknown := wanted - set(full):
            parser.error(f"unknown scans {sorted(unknown)}; choose from {', '.join(full)}")
        scans = [full[name] for name in full if name in wanted]
    cap = args.cap or (60.0 if args.quick else 600.0)
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        for scan in scans:
            info = prepare(scan, Path(tmp))
            for method in methods:
                got = run(scan["kind"], info, method, cap)
                rows.append((scan, info, method, got))
                print(table(rows).splitlines()[-1], file=sys.stderr, flush=True)
    text = table(rows)
    if "auto" in methods:
        text = summary(rows) + "\n" + text
    if args.out:
        args.out.write_text(text)
    else:
        sys.stdout.write(text)


if __name__ == "__main__":
    os.environ.setdefault("PYTHONWARNINGS", "ignore")
    main()
