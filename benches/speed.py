"""Speed against peers, in one run: strips, spade Delaunay and scipy Delaunay from 10k to 10M
points of a synthetic scan, annealing proposals per second, and peak memory.

    python benches/speed.py                          # 10k, 100k, 1M, then annealing
    python benches/speed.py --sizes 10000 100000 1000000 10000000 --timeout 300
    python benches/speed.py --anneal                 # annealing proposals per second only
    python benches/speed.py --no-anneal              # the peers table only

The scan: a smooth height field z = f(x, y) sampled on straight scan lines along x (lines
stacked along y, equal spacing in both directions, positions jittered by up to 5 % of the
spacing as a real line scanner's encoder would), with a line-id column; sqrt(N) lines of
sqrt(N) points. Every configuration (method, size) runs in its own Python process, so peak
memory (``ru_maxrss`` of that process) belongs to it alone; the data are made in the child
before the clock starts, and the baseline resident size after making them is reported too.
Times are the triangulation alone: ``reconstruct(points, "shortest-path", lines=...)``,
``reconstruct(points, "delaunay")`` (spade, trimmed) and ``scipy.spatial.Delaunay`` on the
same projection, trimmed by the same code (``benches/quality.py``'s baseline). Best of
``--repeat`` runs for sizes under 1M, one run from 1M on.
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import resource
import subprocess
import sys
import time
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
METHODS = ("shortest-path", "delaunay", "scipy")
LABELS = {
    "shortest-path": "strips (shortest path)",
    "delaunay": "spade Delaunay",
    "scipy": "scipy Delaunay (Qhull)",
}


def synthetic_scan(n: int, seed: int = 0) -> tuple[np.ndarray, np.ndarray]:
    """(points, line_ids): about n points on round(sqrt(n)) lines over the unit square."""
    lines = max(int(round(np.sqrt(n))), 3)
    per_line = max(n // lines, 3)
    rng = np.random.default_rng(seed)
    step = 1.0 / per_line
    x = np.tile(np.arange(per_line, dtype=np.float64) * step, lines)
    y = np.repeat(np.arange(lines, dtype=np.float64) / lines, per_line)
    x += rng.uniform(-0.05, 0.05, x.size) * step
    y += rng.uniform(-0.05, 0.05, y.size) / lines
    z = 0.2 * np.sin(7 * x) * np.cos(5 * y) + 0.1 * x * x + 0.05 * np.sin(23 * x + 11 * y)
    ids = np.repeat(np.arange(lines, dtype=np.int64), per_line)
    return np.column_stack([x, y, z]), ids


def rss_mb() -> float:
    """Peak resident size of this process so far (MB; Linux reports kB)."""
    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024


def current_rss_mb() -> float:
    with open("/proc/self/statm") as f:
        return int(f.read().split()[1]) * os.sysconf("SC_PAGE_SIZE") / 2**20


def child(method: str, n: int, repeat: int) -> None:
    import scanmesh

    sys.path.insert(0, str(HERE))
    from quality import scipy_delaunay

    points, ids = synthetic_scan(n)
    base = current_rss_mb()
    best, faces, stages = float("inf"), 0, {}
    for _ in range(repeat):
        t0 = time.perf_counter()
        if method == "scipy":
            surface = scipy_delaunay(points, "z")
        else:
            scan = scanmesh.planar_scan(points, plane="z", lines=ids)  # lines travel with it
            surface = scanmesh.reconstruct(scan, method)
        elapsed = time.perf_counter() - t0
        if elapsed < best:
            best, stages = elapsed, dict(surface.timings)
        faces = len(surface.faces)
        del surface
    print(
        json.dumps(
            {
                "method": method,
                "n": len(points),
                "time_s": best,
                "faces": faces,
                "base_mb": base,
                "peak_mb": rss_mb(),
                "stages": stages,
            }
        )
    )


def run_child(method: str, n: int, repeat: int, timeout: float) -> dict:
    cmd = [sys.executable, __file__, "--child", method, str(n), "--repeat", str(repeat)]
    t0 = time.perf_counter()
    try:
        out = subprocess.run(cmd, capture_output=True, text=True, timeout=timeout, check=True)
    except subprocess.TimeoutExpired:
        return {"method": method, "n": n, "error": f"over {timeout:.0f} s"}
    except subprocess.CalledProcessError as exc:
        return {"method": method, "n": n, "error": exc.stderr.strip().splitlines()[-1][:80]}
    row = json.loads(out.stdout.strip().splitlines()[-1])
    row["process_s"] = time.perf_counter() - t0
    return row


def machine() -> str:
    load = os.getloadavg()
    return (
        f"{platform.machine()}, {os.cpu_count()} cores, Python {platform.python_version()},"
        f" load average {load[0]:.1f} / {load[1]:.1f} / {load[2]:.1f}"
    )


def peers(sizes: list[int], repeat: int, repeat_large: int, timeout: float) -> None:
    print(f"machine: {machine()}\n")
    print(
        "| points | method | time (s) | / spade | of which (s) | faces | peak RSS (MB) |"
        " RSS before (MB) |"
    )
    print("|---|---|---|---|---|---|---|---|")
    for n in sizes:
        runs = repeat if n < 1_000_000 else repeat_large
        rows = {m: run_child(m, n, runs, timeout) for m in METHODS}
        spade = rows["delaunay"].get("time_s")
        for m in METHODS:
            r = rows[m]
            if "error" in r:
                print(f"| {n:,} | {LABELS[m]} | {r['error']} | - | - | - | - | - |", flush=True)
                continue
            ratio = f"{r['time_s'] / spade:.2f}" if spade else "-"
            stages = ", ".join(
                f"{k} {v:.2g}" for k, v in r.get("stages", {}).items() if k != "project"
            )
            print(
                f"| {r['n']:,} | {LABELS[m]} | {r['time_s']:.3g} | {ratio} | {stages or '-'} |"
                f" {r['faces']:,} |"
                f" {r['peak_mb']:,.0f} | {r['base_mb']:,.0f} |",
                flush=True,
            )
    print(f"\nmachine after: {machine()}")


def interior_edges(faces: np.ndarray) -> int:
    e = np.sort(faces[:, [0, 1, 1, 2, 2, 0]].reshape(-1, 2), axis=1)
    _, counts = np.unique(e[:, 0] * (int(faces.max()) + 1) + e[:, 1], return_counts=True)
    return int((counts == 2).sum())


def anneal_speed() -> None:
    """Proposals per second of whole annealing runs: one chain on one core, then one chain
    in stripes on every core (``tiles``). Proposals are counted as full sweeps (sweeps run x
    interior edges), which slightly flatters tiled runs: their border edges wait a phase."""
    import scanmesh

    print(f"machine: {machine()}\n")
    print(
        "| scan | points | interior edges | tiles | sweeps run | anneal time (s) | proposals/s |"
        " / one chain |"
    )
    print("|---|---|---|---|---|---|---|---|")
    rod, _ = scanmesh.load_rod()
    cases = [("rod (load_rod), along y", rod, "y", 300, 8)]
    for n in (100_000, 1_000_000):
        pts, _ = synthetic_scan(n)
        cases.append((f"synthetic {n:,}", pts, "z", 30 if n < 1_000_000 else 20, 64))
    for name, pts, plane, sweeps, many in cases:
        start = scanmesh.reconstruct(pts, "delaunay", plane=plane)
        edges = interior_edges(start.faces)
        one_chain = None
        for tiles in (1, many):
            s = scanmesh.reconstruct(
                pts, "anneal", plane=plane, sweeps=sweeps, patience=0, seed=1, tiles=tiles
            )
            done = len(s.trace["energy"])
            rate = done * edges / s.timings["anneal"]
            one_chain = one_chain or rate
            print(
                f"| {name} | {len(pts):,} | {edges:,} | {tiles} | {done} |"
                f" {s.timings['anneal']:.2f} | {rate:,.0f} | {rate / one_chain:.2f} |",
                flush=True,
            )
    print(f"\nmachine after: {machine()}")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--sizes", type=int, nargs="+", default=[10_000, 100_000, 1_000_000])
    parser.add_argument("--repeat", type=int, default=3, help="runs per size under 1M (best)")
    parser.add_argument("--repeat-large", type=int, default=1, help="runs per size from 1M")
    parser.add_argument("--timeout", type=float, default=300.0, help="seconds per process")
    parser.add_argument("--anneal", action="store_true", help="annealing proposals/s only")
    parser.add_argument("--no-anneal", action="store_true", help="the peers table only")
    parser.add_argument("--child", nargs=2, metavar=("METHOD", "N"), help=argparse.SUPPRESS)
    args = parser.parse_args()
    if args.child:
        child(args.child[0], int(args.child[1]), args.repeat)
    elif args.anneal:
        anneal_speed()
    else:
        peers(args.sizes, args.repeat, args.repeat_large, args.timeout)
        if not args.no_anneal:
            print()
            anneal_speed()


if __name__ == "__main__":
    main()
