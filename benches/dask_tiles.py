"""Delaunay and annealing in tiles on a 2-worker Dask LocalCluster (scanmesh.distributed).

A synthetic scan (a developable wave surface, z = 3 sin((x + y) / 5), sampled on lines
0.5 apart with points 0.125 apart along them: Delaunay's edges cut across the wave's
rulings, annealing can follow them) is written to disk in parts of consecutive lines
(.npy); the cluster triangulates and anneals it in tiles; the client never holds the scan.
Prints wall times, the tac_1 of both results (summed from the tiles), and each worker's
peak resident memory; with --compare also the single-process results (small sizes only).

    python benches/dask_tiles.py --points 1000000 --sweeps 100 --compare
"""

from __future__ import annotations

import argparse
import math
import resource
import tempfile
import time
from pathlib import Path

import numpy as np

import scanmesh
from scanmesh.distributed import _tiles
from scanmesh.distributed._source import Part

DX, DY = 0.125, 0.5


def wave(x: np.ndarray, y: np.ndarray) -> np.ndarray:
    return 3.0 * np.sin((x + y) / 5.0)


def write_scan(points: int, parts: int, folder: Path) -> tuple[list[Part], int]:
    """About ``points`` points on a square patch, in ``parts`` files of whole lines."""
    per_line = int(math.sqrt(points * DY / DX))
    lines = max(2, points // per_line)
    x = DX * np.arange(per_line)
    out, offset = [], 0
    for i, chunk in enumerate(np.array_split(np.arange(lines), parts)):
        y = DY * chunk
        xx, yy = np.meshgrid(x, y)
        pts = np.column_stack([xx.ravel(), yy.ravel(), wave(xx, yy).ravel()])
        path = folder / f"part{i}.npy"
        np.save(path, np.column_stack([pts, np.repeat(chunk.astype(np.float64), per_line)]))
        out.append(Part(i, str(path), offset, len(pts)))
        offset += len(pts)
    return out, offset


def peak_rss_mb() -> float:
    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--points", type=int, default=30_000_000)
    ap.add_argument("--parts", type=int, default=0, help="files (default: 1 per million)")
    ap.add_argument("--sweeps", type=int, default=100)
    ap.add_argument("--memory", default="4GB", help="memory limit per worker")
    ap.add_argument("--compare", action="store_true", help="also run one process")
    ap.add_argument("--methods", default="delaunay,anneal", help="comma-separated")
    ap.add_argument(
        "--tile-points",
        type=int,
        default=_tiles.TILE_POINTS,
        help="points per tile the grid aims at",
    )
    args = ap.parse_args()
    from distributed import Client, LocalCluster

    _tiles.TILE_POINTS = args.tile_points  # read by the driver, on this process
    parts_count = args.parts or max(2, args.points // 1_000_000)
    with tempfile.TemporaryDirectory() as tmp:
        t0 = time.perf_counter()
        parts, total = write_scan(args.points, parts_count, Path(tmp))
        print(
            f"scan: {total:,} points in {len(parts)} parts, written in"
            f" {time.perf_counter() - t0:.1f} s",
            flush=True,
        )
        with (
            LocalCluster(
                n_workers=2,
                threads_per_worker=1,
                processes=True,
                memory_limit=args.memory,
                dashboard_address=None,
            ) as cluster,
            Client(cluster) as client,
        ):
            results = {}
            runs = {"delaunay": {}, "anneal": {"sweeps": args.sweeps, "seed": 0}}
            for method in args.methods.split(","):
                options = runs[method]
                t0 = time.perf_counter()
                futures = _tiles.tile_blocks(
                    client, parts, method, options, plane="z", progress=False
                )
                # each block's sums on its worker: the faces never come to one process
                each = client.gather(client.map(lambda b: b.sums, futures, pure=False))
                sums = {k: sum(s[k] for s in each) for k in each[0]}
                seconds = time.perf_counter() - t0
                results[method] = sums
                print(
                    f"{method}: {seconds:.1f} s, {len(futures)} tiles, {sums['faces']:,.0f}"
                    f" faces, tac_1 {sums['tac_1']:.6g}, uncertified"
                    f" {sums['uncertified']:.0f}",
                    flush=True,
                )
                del futures
            rss = client.run(peak_rss_mb)
            print("worker peak RSS (MB):", {k: round(v) for k, v in rss.items()})
            print(f"client peak RSS (MB): {peak_rss_mb():.0f}")
            if len(results) == 2:
                ratio = results["anneal"]["tac_1"] / results["delaunay"]["tac_1"]
                print(f"tac_1 annealed / Delaunay: {ratio:.3f}")
        if args.compare:
            pts = np.concatenate([np.load(p.path) for p in parts])
            t0 = time.perf_counter()
            one = scanmesh.reconstruct(pts, "anneal", plane="z", seed=0, sweeps=args.sweeps)
            print(
                f"one process anneal: {time.perf_counter() - t0:.1f} s, tac_1"
                f" {one.quality.tac_1:.6g}; distributed / one process:"
                f" {results['anneal']['tac_1'] / one.quality.tac_1:.3f}"
            )


if __name__ == "__main__":
    main()
