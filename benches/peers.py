"""Peers: scanmesh against other triangulators on the same synthetic scans.

    pip install -e ".[bench]"      # triangle, vtk, pyvista (scipy is a core dependency)
    python benches/peers.py                          # 100k, 1M, 10M points
    python benches/peers.py --sizes 100000 1000000 --repeat 3 --out peers-table.md

The scan: benches/large.py's smooth height field (millimetres over a 100 mm square) on
``large.lines_for(N)`` straight scan lines (3,000 at 10M points, about sqrt(N) lines of
sqrt(N) points), positions jittered by up to 5 % of the spacing, seed 0, saved once per size
as ``.npy`` in scanmesh-peers/ in the system's temporary folder. The table is printed;
``--out`` also writes it to a file (docs/benchmarks/peers.md is edited by hand, never
rewritten by a run).

Every run is its own Python process (``--child``): it loads the points, imports its library
and warms it up on a 3,000-point scan, then times the one call that turns the points into
faces, array conversions included; its peak resident size is the child's ``ru_maxrss``
(os.wait4), so it includes the interpreter, numpy, the loaded points (the same for every
peer) and the library's own import. Runs are
interleaved (peer 1, 2, ..., then again) and each peer's time is the median of ``--repeat``
runs; peers listed in ``--once-above`` sizes run once there (slow ones at 10M). Times are
ratios to scanmesh's Delaunay (with trimming) of the same size in the same run; each run
also reports its CPU seconds (user + system over all threads), the measure that survives a
loaded machine.

Peers:

- scanmesh delaunay: ``scanmesh.reconstruct(points, "delaunay")`` (plane choice, projection,
  Delaunay, long-edge and depth-jump trimming, the steep check);
- scanmesh shortest-path / lookahead α=1: ``reconstruct(points, method, lines=ids)``;
  "lookahead α=1, exact walk" the same with the strips' filtered decisions turned off
  (``_core.set_strip_filter(False)``): before and after the filter in one run. Each scanmesh
  row also reports the face hash and the filter's fallbacks / decisions
  (``_core.strip_filter_counts``);
- Triangle: ``triangle.triangulate({"vertices": xy}, "Q")`` (Shewchuk's, plain Delaunay);
- VTK ``vtkRuledSurfaceFilter`` in PointWalk mode (the greedy walk between consecutive
  polylines), from numpy arrays through ``vtk.util.numpy_support``;
- numpy grid: the lines as rows of a grid (every line has the same number of points here),
  each pair of neighbouring points on two lines joined into two triangles;
- scipy ``Delaunay`` (Qhull) on xy;
- PyVista ``PolyData(points).delaunay_2d()`` (vtkDelaunay2D).
"""

from __future__ import annotations

import argparse
import hashlib
import json
import os
import platform
import resource
import statistics
import subprocess
import sys
import tempfile
import time
from collections.abc import Callable
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))
from large import lines_for, surface_z  # noqa: E402

WORK = Path(tempfile.gettempdir()) / "scanmesh-peers"
BASE = "scanmesh delaunay"


def synthetic_scan(n: int, seed: int = 0) -> tuple[np.ndarray, np.ndarray]:
    """About n points (N, 3) on ``lines_for(n)`` jittered scan lines, and their line ids."""
    lines = lines_for(n)
    per = max(n // lines, 3)
    rng = np.random.default_rng(seed)
    step, gap = 100.0 / per, 100.0 / lines
    k = lines * per
    x = np.tile(np.arange(per) * step, lines) + rng.uniform(-0.05, 0.05, k) * step
    y = np.repeat(np.arange(lines) * gap, per) + rng.uniform(-0.05, 0.05, k) * gap
    ids = np.repeat(np.arange(lines), per).astype(np.int64)
    return np.column_stack([x, y, surface_z(x, y)]), ids


def scan_files(n: int) -> tuple[Path, Path]:
    """The size's points and line ids as .npy files, written on first use."""
    points, ids = WORK / f"scan{n}.points.npy", WORK / f"scan{n}.ids.npy"
    if not (points.exists() and ids.exists()):
        WORK.mkdir(parents=True, exist_ok=True)
        p, i = synthetic_scan(n)
        np.save(points, p)
        np.save(ids, i)
    return points, ids


#: The faces of the last scanmesh call, hashed after the timed call.
LAST_FACES: list[np.ndarray] = []


def run_scanmesh(
    method: str, filtered: bool = True, **options: object
) -> Callable[[np.ndarray, np.ndarray], int]:
    """scanmesh's ``reconstruct``; ``filtered=False`` turns the strips' filtered decisions
    off (``_core.set_strip_filter``), the walk as before the filter, for before/after rows."""
    import scanmesh
    from scanmesh import _core

    _core.set_strip_filter(filtered)

    def run(points: np.ndarray, ids: np.ndarray) -> int:
        lines = None if method == "delaunay" else ids
        faces = scanmesh.reconstruct(points, method, lines=lines, **options).faces
        LAST_FACES[:] = [faces]
        return len(faces)

    return run


def run_triangle(points: np.ndarray, ids: np.ndarray) -> int:
    import triangle

    return len(triangle.triangulate({"vertices": points[:, :2]}, "Q")["triangles"])


def run_vtk_ruled(points: np.ndarray, ids: np.ndarray) -> int:
    import vtk
    from vtk.util import numpy_support

    starts = np.flatnonzero(np.r_[True, ids[1:] != ids[:-1]])
    counts = np.diff(np.r_[starts, len(ids)])
    # Legacy cell layout: (count, indices...) per polyline.
    cells = np.insert(np.arange(len(ids), dtype=np.int64), starts, counts)
    vtk_points = vtk.vtkPoints()
    vtk_points.SetData(numpy_support.numpy_to_vtk(points, deep=True))
    polylines = vtk.vtkCellArray()
    polylines.SetCells(len(starts), numpy_support.numpy_to_vtkIdTypeArray(cells, deep=True))
    poly = vtk.vtkPolyData()
    poly.SetPoints(vtk_points)
    poly.SetLines(polylines)
    ruled = vtk.vtkRuledSurfaceFilter()
    ruled.SetInputData(poly)
    ruled.SetRuledModeToPointWalk()
    ruled.Update()
    return ruled.GetOutput().GetNumberOfPolys()


def run_numpy_grid(points: np.ndarray, ids: np.ndarray) -> int:
    lines = int(ids[-1]) + 1
    grid = np.arange(len(ids)).reshape(lines, -1)
    a, b = grid[:-1, :-1].ravel(), grid[:-1, 1:].ravel()
    c, d = grid[1:, :-1].ravel(), grid[1:, 1:].ravel()
    faces = np.concatenate([np.column_stack([a, b, d]), np.column_stack([a, d, c])])
    return len(faces)


def run_scipy(points: np.ndarray, ids: np.ndarray) -> int:
    from scipy.spatial import Delaunay

    return len(Delaunay(points[:, :2]).simplices)


def run_pyvista(points: np.ndarray, ids: np.ndarray) -> int:
    import pyvista

    return pyvista.PolyData(points).delaunay_2d().n_cells


PEERS: dict[str, Callable[[], Callable[[np.ndarray, np.ndarray], int]]] = {
    BASE: lambda: run_scanmesh("delaunay"),
    "scanmesh shortest-path": lambda: run_scanmesh("shortest-path"),
    "scanmesh lookahead α=1": lambda: run_scanmesh("lookahead", alpha=1),
    "scanmesh lookahead α=1, exact walk": lambda: run_scanmesh("lookahead", False, alpha=1),
    "Triangle (`triangle`)": lambda: run_triangle,
    "VTK `vtkRuledSurfaceFilter` (PointWalk)": lambda: run_vtk_ruled,
    "numpy grid of the lines": lambda: run_numpy_grid,
    "scipy `Delaunay` (Qhull)": lambda: run_scipy,
    "PyVista `delaunay_2d`": lambda: run_pyvista,
}
SLOW = ("scipy `Delaunay` (Qhull)", "PyVista `delaunay_2d`")


def child(peer: str, n: int) -> None:
    """Time one peer on size n and print a JSON line (seconds, faces)."""
    import warnings

    points_file, ids_file = scan_files(n)
    points, ids = np.load(points_file), np.load(ids_file)
    run = PEERS[peer]()
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        run(*synthetic_scan(3000, seed=1))  # warm-up: lazy imports are not timed
        filter_counts(reset=True)
        cpu, t = cpu_seconds(), time.perf_counter()
        faces = run(points, ids)
        seconds, cpu = time.perf_counter() - t, cpu_seconds() - cpu
    out = {"seconds": seconds, "cpu": cpu, "faces": faces, "filter": filter_counts()}
    if LAST_FACES:
        out["sha1"] = hashlib.sha1(np.ascontiguousarray(LAST_FACES[0], np.int64)).hexdigest()[:12]
    print(json.dumps(out))


def filter_counts(reset: bool = False) -> list[int] | None:
    """(decisions, fallbacks) of the strips' filtered walk in this process, when scanmesh
    is loaded (``_core.strip_filter_counts``)."""
    core = sys.modules.get("scanmesh._core")
    return None if core is None else list(core.strip_filter_counts(reset))


def cpu_seconds() -> float:
    """User + system CPU time of this process so far (all threads)."""
    usage = resource.getrusage(resource.RUSAGE_SELF)
    return usage.ru_utime + usage.ru_stime


def spawn(peer: str, n: int) -> dict:
    """One child process: its JSON line and its peak resident size (MB)."""
    cmd = [sys.executable, __file__, "--child", peer, str(n)]
    proc = subprocess.Popen(cmd, stdout=subprocess.PIPE, text=True)
    assert proc.stdout is not None
    out = proc.stdout.read()
    _, status, usage = os.wait4(proc.pid, 0)
    proc.returncode = os.waitstatus_to_exitcode(status)
    if proc.returncode != 0:
        return {"error": f"exit {proc.returncode}", "rss_mb": usage.ru_maxrss / 1024}
    return {**json.loads(out.strip().splitlines()[-1]), "rss_mb": usage.ru_maxrss / 1024}


def load() -> str:
    return "load average " + " / ".join(f"{x:.1f}" for x in os.getloadavg())


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--sizes", type=int, nargs="+", default=[100_000, 1_000_000, 10_000_000])
    parser.add_argument("--repeat", type=int, default=3)
    parser.add_argument(
        "--once-above",
        type=int,
        default=5_000_000,
        help="sizes above this run scipy and PyVista once (they take minutes there)",
    )
    parser.add_argument("--peers", nargs="+", default=list(PEERS), choices=list(PEERS))
    parser.add_argument(
        "--out", type=Path, help="also write the table to this file (default: stdout only)"
    )
    parser.add_argument("--child", nargs=2, metavar=("PEER", "N"), help=argparse.SUPPRESS)
    args = parser.parse_args()
    if args.child:
        child(args.child[0], int(args.child[1]))
        return
    peers = [BASE, *(p for p in args.peers if p != BASE)]
    results: dict[int, dict[str, list[dict]]] = {}
    loads = [load()]
    for n in args.sizes:
        scan_files(n)
        results[n] = {p: [] for p in peers}
        for rep in range(args.repeat):
            for peer in peers:
                if rep > 0 and n > args.once_above and peer in SLOW:
                    continue
                r = spawn(peer, n)
                results[n][peer].append(r)
                print(n, rep, peer, r, flush=True)
        loads.append(load())
    table = markdown(results, peers, args, loads)
    if args.out is not None:
        args.out.parent.mkdir(parents=True, exist_ok=True)
        args.out.write_text(table)
    print(table)


def markdown(results: dict, peers: list[str], args: argparse.Namespace, loads: list[str]) -> str:
    sizes = list(results)

    def label(n: int) -> str:
        return f"{n // 1_000_000}M" if n >= 1_000_000 else f"{n // 1000}k"

    head = "| method | " + " | ".join(label(n) for n in sizes)
    head += " | peak memory " + " / ".join(label(n) for n in sizes) + " (MB) |"
    rows = [head, "|---" * (len(sizes) + 2) + "|"]
    for peer in peers:
        cells, memory = [], []
        for n in sizes:
            runs = [r for r in results[n][peer] if "seconds" in r]
            base = [r["seconds"] for r in results[n][BASE] if "seconds" in r]
            if not runs or not base:
                cells.append("failed")
                memory.append("–")
                continue
            s, b = statistics.median(r["seconds"] for r in runs), statistics.median(base)
            cpu = statistics.median(r["cpu"] for r in runs)
            once = ", 1 run" if len(runs) == 1 and args.repeat > 1 else ""
            ratio = "1" if peer == BASE else f"{s / b:.2f}"
            cells.append(f"{ratio} ({s:.2f} s; CPU {cpu:.2f} s{once})")
            memory.append(f"{max(r['rss_mb'] for r in runs):,.0f}")
        rows.append(f"| {peer} | " + " | ".join(cells) + " | " + " / ".join(memory) + " |")
    faces = {
        peer: "/".join(
            str(results[n][peer][0].get("faces", "–")) if results[n][peer] else "–" for n in sizes
        )
        for peer in peers
    }
    lines = [
        "# scanmesh against its peers (benches/peers.py)",
        "",
        f"`python benches/peers.py --sizes {' '.join(map(str, sizes))} --repeat {args.repeat}`"
        f" on {platform.machine()}, {os.cpu_count()} cores, Python {platform.python_version()};"
        f" {time.strftime('%Y-%m-%d %H:%M UTC', time.gmtime())}.",
        "",
        "Time: median of the runs, as a ratio to scanmesh's Delaunay (with trimming) of the"
        " same size and run; in brackets the median wall seconds and the median CPU seconds"
        " of the process during the call (user + system, all threads: on a loaded machine"
        " the fairer measure of work). Peak memory: the largest child ru_maxrss"
        " (interpreter, numpy and the loaded points included).",
        "",
        *rows,
        "",
        "Faces per size: " + "; ".join(f"{p}: {f}" for p, f in faces.items()) + ".",
        "",
        "Face hashes (sha1 of the int64 faces, first run) per size: "
        + "; ".join(
            f"{p}: " + "/".join(str(results[n][p][0].get("sha1", "–")) for n in sizes)
            for p in peers
            if p.startswith("scanmesh")
        )
        + ".",
        "",
        "Filtered decisions of the strips (fallbacks / decisions, the exact evaluation's"
        " share; first run): "
        + "; ".join(
            f"{p}: " + "/".join(fallback_rate(results[n][p]) for n in sizes)
            for p in peers
            if p.startswith("scanmesh") and p != BASE
        )
        + ".",
        "",
        "Machine load (1/5/15 min) at the start and after each size: " + "; ".join(loads) + ".",
        "",
    ]
    return "\n".join(lines)


def fallback_rate(runs: list[dict]) -> str:
    """Fallbacks / decisions (and the rate) of a peer's first run, or "–"."""
    counts = runs[0].get("filter") if runs else None
    if not counts or not counts[0]:
        return "–"
    d, f = counts
    return f"{f:,} / {d:,} ({100 * f / d:.2f} %)"


if __name__ == "__main__":
    main()
