"""Strips of a scan too large for one process, on a 2-worker LocalCluster.

A synthetic scan (a wavy surface with noise, zig-zag lines of ``--cols`` points) is written
to disk in files of ``--lines-per-file`` lines (.npz: points and line ids), then meshed by
``scanmesh.distributed.reconstruct_distributed`` with shortest paths into one binary STL
written by the workers. Reported: wall time (cluster start excluded), peak resident memory
of each worker process (polled every 0.2 s), faces. With ``--single`` the same files are
also meshed in this process (read, ``scanmesh.reconstruct``, its quality, ``Surface.save``),
alternating with the Dask run, and the two STL files are compared byte for byte.

    python benches/dask_strips.py --points 10_000_000 --single --repeat 2
    python benches/dask_strips.py --points 100_000_000

Large data goes under --scratch (default: scanmesh-dask in the system's temporary folder)
and is deleted at the end. On a loaded Linux machine with autogroup scheduling the workers
and the single process share one autogroup's CPU time, so the ratio then measures the Dask
run's extra work, not its parallelism.
"""

from __future__ import annotations

import argparse
import filecmp
import os
import shutil
import sys
import tempfile
import threading
import time
from pathlib import Path

# Run as a script, this file's folder comes first on sys.path, and this file would then be
# imported as the `distributed` package.
sys.path[:] = [p for p in sys.path if Path(p or ".").resolve() != Path(__file__).parent.resolve()]

import numpy as np  # noqa: E402
import psutil  # noqa: E402

import scanmesh  # noqa: E402
from scanmesh.distributed import reconstruct_distributed  # noqa: E402


def write_scan(folder: Path, n_points: int, cols: int, lines_per_file: int) -> list[str]:
    """Zig-zag lines of ``cols`` points over z = sin(0.4 x) cos(0.3 y) + noise, written
    file by file (never whole in memory). Returns the files in scan order."""
    rows = max(2, n_points // cols)
    rng = np.random.default_rng(0)
    paths = []
    for first in range(0, rows, lines_per_file):
        r = np.arange(first, min(rows, first + lines_per_file))
        c = np.arange(cols, dtype=float)
        col = np.where((r % 2)[:, None] == 1, c[::-1][None, :], c[None, :])
        x = col * 0.5 + rng.normal(0, 0.02, col.shape)
        y = r[:, None] * 0.7 + rng.normal(0, 0.02, col.shape)
        z = np.sin(0.04 * x) * np.cos(0.03 * y) + rng.normal(0, 0.005, col.shape)
        path = folder / f"scan_{first // lines_per_file:05d}.npz"
        np.savez(
            path,
            points=np.column_stack([x.ravel(), y.ravel(), z.ravel()]),
            line_ids=np.repeat(r, cols).astype(np.int64),
        )
        paths.append(str(path))
    return paths


class PeakMemory:
    """Peak resident memory of each worker process, polled in a thread."""

    def __init__(self, pids: list[int]) -> None:
        self.peak = dict.fromkeys(pids, 0)
        self.stop = threading.Event()
        self.thread = threading.Thread(target=self.poll, daemon=True)
        self.thread.start()

    def poll(self) -> None:
        while not self.stop.is_set():
            for pid in self.peak:
                try:
                    self.peak[pid] = max(self.peak[pid], psutil.Process(pid).memory_info().rss)
                except psutil.NoSuchProcess:
                    pass
            time.sleep(0.2)

    def done(self) -> dict[int, int]:
        self.stop.set()
        self.thread.join()
        return self.peak


def single_process(paths: list[str], out: Path) -> tuple[float, int]:
    t0 = time.perf_counter()
    loaded = [np.load(p) for p in paths]
    points = np.concatenate([a["points"] for a in loaded])
    ids = np.concatenate([a["line_ids"] for a in loaded])
    del loaded
    surface = scanmesh.reconstruct(points, "shortest-path", lines=ids, plane="z")
    _ = surface.quality  # the Dask run reports it too (as `scanmesh reconstruct` does)
    surface.save(out)
    return time.perf_counter() - t0, len(surface.faces)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--points", type=lambda s: int(s.replace("_", "")), default=10_000_000)
    parser.add_argument("--cols", type=int, default=5000, help="points per line")
    parser.add_argument("--lines-per-file", type=int, default=200)
    parser.add_argument("--workers", type=int, default=2)
    parser.add_argument("--single", action="store_true", help="also run in one process")
    parser.add_argument("--repeat", type=int, default=1)
    parser.add_argument("--scratch", default=str(Path(tempfile.gettempdir()) / "scanmesh-dask"))
    args = parser.parse_args()

    from distributed import Client, LocalCluster

    folder = Path(args.scratch) / f"bench_{args.points}"
    shutil.rmtree(folder, ignore_errors=True)
    folder.mkdir(parents=True)
    try:
        t0 = time.perf_counter()
        paths = write_scan(folder, args.points, args.cols, args.lines_per_file)
        n = args.points // args.cols * args.cols
        print(f"wrote {n:,} points in {len(paths)} files in {time.perf_counter() - t0:.1f} s")
        print(f"load: {os.getloadavg()}")
        with (
            LocalCluster(
                n_workers=args.workers,
                threads_per_worker=1,
                processes=True,
                memory_limit="3GB",
                dashboard_address=None,
            ) as cluster,
            Client(cluster) as client,
        ):
            pids = list(client.run(os.getpid).values())
            for k in range(args.repeat):
                if args.single:
                    t, faces = single_process(paths, folder / "single.stl")
                    print(f"single process: {t:.1f} s, {faces:,} faces")
                    (folder / "single.stl").rename(folder / "single_kept.stl")
                watch = PeakMemory(pids)
                t1 = time.perf_counter()
                result = reconstruct_distributed(
                    paths, "shortest-path", client=client, output=folder / "dask.stl", plane="z"
                )
                wall = time.perf_counter() - t1
                peak = watch.done()
                print(
                    f"dask ({args.workers} workers): {wall:.1f} s, {result.n_faces:,} faces,"
                    f" stages {', '.join(f'{k} {v:.1f} s' for k, v in result.timings.items())},"
                    f" peak RSS per worker {', '.join(f'{v / 2**30:.2f}' for v in peak.values())}"
                    f" GiB; tac_1 {result.quality['tac_1']:.6g}"
                )
                if args.single:
                    same = filecmp.cmp(folder / "single_kept.stl", folder / "dask.stl", False)
                    print(f"  STL files identical: {same}; ratio dask/single {wall / t:.2f}")
                    (folder / "single_kept.stl").unlink()
                (folder / "dask.stl").unlink()
                print(f"load: {os.getloadavg()}")
    finally:
        shutil.rmtree(folder, ignore_errors=True)


if __name__ == "__main__":
    main()
