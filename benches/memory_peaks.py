"""The address space each stage needs, per point: the smallest ``RLIMIT_AS`` room (above
what the process holds once the scan is made) under which a stage still finishes, found by
bisection, each try in its own process. The core's per-point estimates (checked before a
stage allocates) are set a margin above these slopes; see docs/benchmarks/memory.md.

    nice python benches/memory_peaks.py                  # Delaunay, strips, LOP at 200k, 800k
    nice python benches/memory_peaks.py --points 100000 --methods delaunay
"""

from __future__ import annotations

import argparse
import subprocess
import sys

CHILD = r"""
import resource, sys
import numpy as np
import scanmesh
method, n, room = sys.argv[1], int(sys.argv[2]), int(sys.argv[3])
side = int(n ** 0.5)
g = np.stack(np.meshgrid(np.arange(side), np.arange(side)), -1).reshape(-1, 2) * 1.0
g += np.random.default_rng(0).uniform(-0.2, 0.2, g.shape)
scan = scanmesh.planar_scan(np.c_[g, np.sin(g[:, 0] / 7) * 3], plane="z")
np.ones((512, 512)) @ np.ones((512, 512))
size = next(int(l.split()[1]) * 1024 for l in open("/proc/self/status") if l.startswith("VmSize:"))
resource.setrlimit(resource.RLIMIT_AS, (size + room, resource.RLIM_INFINITY))
scanmesh.reconstruct(scan, method)
print("built")
"""


def finishes(method: str, n: int, room: int) -> bool:
    """Whether `method` on about `n` points finishes with `room` bytes of address space."""
    r = subprocess.run(
        [sys.executable, "-c", CHILD, method, str(n), str(room)], capture_output=True, text=True
    )
    return r.stdout.strip() == "built"


def smallest_room(method: str, n: int, step: int = 10_000_000) -> int:
    """The smallest room (bytes, to `step`) under which `method` on `n` points finishes."""
    lo, hi = 0, 1 << 31
    while hi - lo > step:
        mid = (lo + hi) // 2
        lo, hi = (lo, mid) if finishes(method, n, mid) else (mid, hi)
    return hi


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--points", type=int, nargs="+", default=[200_000, 800_000])
    ap.add_argument("--methods", nargs="+", default=["delaunay", "shortest-path", "lop"])
    args = ap.parse_args()
    print("method          points    room MB  bytes/point")
    rooms = {}
    for method in args.methods:
        for n in args.points:
            room = rooms[method, n] = smallest_room(method, n)
            print(f"{method:14s} {n:8d} {room / 1e6:9.0f} {room / n:11.0f}", flush=True)
        if len(args.points) > 1:
            a, b = args.points[0], args.points[-1]
            slope = (rooms[method, b] - rooms[method, a]) / (b - a)
            print(f"{method:14s} slope {slope:.0f} bytes/point", flush=True)


if __name__ == "__main__":
    main()
