"""Delaunay and annealing in tiles on a 2-worker Dask LocalCluster (scanmesh.distributed).

Two scans, written to disk in parts of consecutive lines (.npy, x y z line id; about 1M
points per part); the cluster triangulates and anneals them in tiles; the client never
holds the scan.

- ``--scan wave``: a developable wave surface, z = 3 sin((x + y) / 5), sampled on lines
  0.5 apart with points 0.125 apart along them (plane z, default trimming): Delaunay's
  edges cut across the wave's rulings, annealing can follow them.
- ``--scan rod``: the connecting rod (``../shared/data/cad/conrod_slevin48_onshape.stl``)
  scanned along its thickness, as ``benches/large_anneal.py`` scans it (plane y), and
  triangulated with ``max_edge=inf``: the curtains between its two levels and across its
  holes stay, the mesh on which annealing earns a large factor (0.013 x Delaunay's tac_1
  at 1M points in one process). The scan is simulated once per size (spacing scaled from
  the 1M scan's, so one ray cast) and cached under ``--scratch``.

Prints wall times, the tac_1 of each result (summed from the tiles), and each worker's
peak resident memory; with --compare also the single-process results (small sizes only).
The annealing run sums the tiled Delaunay's tac_1 too (``initial_tac_1``), so "annealed /
Delaunay" needs no separate Delaunay run (``--methods anneal``).

    python benches/dask_tiles.py --points 1000000 --sweeps 100 --compare
    python benches/dask_tiles.py --scan rod --points 1000000 --tile-points 250000
    python benches/dask_tiles.py --scan rod --points 30000000 --methods anneal \
        --tie-tolerance 1e-10
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


ROD = Path(__file__).resolve().parents[2] / "shared" / "data" / "cad"
ROD = ROD / "conrod_slevin48_onshape.stl"

#: Step of the rod's 1M-point scan (``simulate_scan(..., n_points=1_000_000)``); other
#: sizes scale it by sqrt(1M / points), which the density of a ray grid follows.
ROD_SPACING_1M = 0.0020353408512345794


def write_rod(points: int, per_part: int, folder: Path) -> tuple[list[Part], int]:
    """The rod scanned with about ``points`` points, in parts of about ``per_part`` points
    of whole lines (cached in ``folder``: written once per size)."""
    done = folder / "parts.txt"
    if not done.exists():
        from scanmesh.evaluate.digitizer import simulate_scan

        folder.mkdir(parents=True, exist_ok=True)
        spacing = ROD_SPACING_1M * math.sqrt(1_000_000 / points)
        pts, ids = simulate_scan(ROD, up="y", along="x", spacing=spacing)
        starts = np.flatnonzero(np.r_[True, ids[1:] != ids[:-1]])
        cuts = starts[np.searchsorted(starts, np.arange(per_part, len(pts), per_part))]
        names = []
        for i, (a, b) in enumerate(zip(np.r_[0, cuts], np.r_[cuts, len(pts)], strict=True)):
            if a < b:
                names.append(f"part{i}.npy")
                np.save(folder / names[-1], np.column_stack([pts[a:b], ids[a:b].astype(float)]))
        del pts, ids
        done.write_text("\n".join(names))
    out, offset = [], 0
    for i, name in enumerate(done.read_text().split()):
        count = int(np.load(folder / name, mmap_mode="r").shape[0])
        out.append(Part(i, str(folder / name), offset, count))
        offset += count
    return out, offset


def peak_rss_mb() -> float:
    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024


def block_sums(block: _tiles.FaceBlock) -> dict[str, float]:
    """A block's quality sums (on the worker holding it)."""
    return block.sums


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--scan", choices=["wave", "rod"], default="wave")
    ap.add_argument("--points", type=int, default=30_000_000)
    ap.add_argument("--parts", type=int, default=0, help="files (default: 1 per million)")
    ap.add_argument("--sweeps", type=int, default=0, help="0: annealing's default")
    ap.add_argument("--memory", default="4GB", help="memory limit per worker")
    ap.add_argument(
        "--tie-tolerance",
        type=float,
        help="annealing's tie tolerance (default: automatic, from the tiles' noise estimate)",
    )
    ap.add_argument("--compare", action="store_true", help="also run one process")
    ap.add_argument(
        "--scratch",
        default=str(Path(tempfile.gettempdir()) / "scanmesh-dask"),
        help="where the rod scans are cached (default: scanmesh-dask in the temporary folder)",
    )
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
        if args.scan == "rod":
            folder = Path(args.scratch) / f"rod_{args.points}_{parts_count}"
            parts, total = write_rod(args.points, args.points // parts_count, folder)
            plane, shared = "y", {"max_edge": math.inf}
        else:
            parts, total = write_scan(args.points, parts_count, Path(tmp))
            plane, shared = "z", {}
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
            sweeps = {"sweeps": args.sweeps} if args.sweeps else {}
            if args.tie_tolerance is not None:
                sweeps["tie_tolerance"] = args.tie_tolerance
            runs = {"delaunay": shared, "anneal": {**shared, **sweeps, "seed": 0}}
            for method in args.methods.split(","):
                options = runs[method]
                t0 = time.perf_counter()
                # each block's sums taken on its worker as it comes (the faces never come
                # to one process, nor wait in a worker's memory for the others)
                futures, info = _tiles.tile_blocks(
                    client,
                    parts,
                    method,
                    options,
                    plane=plane,
                    progress=False,
                    scratch=Path(tmp),
                    add=lambda block: client.submit(block_sums, block, pure=False),
                )
                each = client.gather(futures)
                sums = {k: sum(s[k] for s in each) for k in each[0]}
                seconds = time.perf_counter() - t0
                results[method] = sums
                print(
                    f"{method}: {seconds:.1f} s, {len(futures)} tiles, {sums['faces']:,.0f}"
                    f" faces, tac_1 {sums['tac_1']:.6g}, uncertified"
                    f" {sums['uncertified']:.0f}, {info}",
                    flush=True,
                )
                del futures
            rss = client.run(peak_rss_mb)
            print("worker peak RSS (MB):", {k: round(v) for k, v in rss.items()})
            print(f"client peak RSS (MB): {peak_rss_mb():.0f}")
            if "anneal" in results:
                # the anneal run sums the tiled Delaunay's tac_1 before optimizing: the same
                # figure the "delaunay" run reports, so that run can be skipped
                a = results["anneal"]
                print(
                    f"tac_1 annealed / Delaunay: {a['tac_1'] / a['initial_tac_1']:.4f}"
                    f" (Delaunay's tac_1 {a['initial_tac_1']:.6g})"
                )
        if args.compare:
            pts = np.concatenate([np.load(p.path)[:, :3] for p in parts])
            t0 = time.perf_counter()
            one = scanmesh.reconstruct(pts, "anneal", plane=plane, **runs["anneal"])
            print(
                f"one process anneal: {time.perf_counter() - t0:.1f} s, tac_1"
                f" {one.quality.tac_1:.6g}; distributed / one process:"
                f" {results['anneal']['tac_1'] / one.quality.tac_1:.3f}"
            )


if __name__ == "__main__":
    main()
