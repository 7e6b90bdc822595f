"""Annealing on large scans: wall time, memory and quality against the goals.

    python benches/large_anneal.py rod                    # the embedded rod, default settings
    python benches/large_anneal.py paper                  # 3,000 sweeps on the rod with curtains
    python benches/large_anneal.py million                # 1M points: defaults and a reference
    python benches/large_anneal.py million --points 10000000 --no-reference   # 10M points
    python benches/large_anneal.py ... --old-python /path/to/python   # alternate with a build

Scans: the connecting rod (``../shared/data/cad/conrod_slevin48_onshape.stl``) scanned along
its thickness (``simulate_scan(up="y", along="x", n_points=N)``, no noise, cached as .npz
in scanmesh-large-anneal/ in the temporary folder). Two triangulations of each: the
default (trimmed at the default ``max_edge``, with depth-jump trimming: flat faces only)
and ``max_edge=inf`` (the whole domain, with the curtains between the rod's two levels, as
the paper triangulated it: the mesh on which annealing has work to do).

Every measurement runs in its own Python process (``--old-python`` runs the same case
under another interpreter, for example one with the annealer that proposed every edge installed,
alternating with this one), which reports its wall times, peak resident size
(``ru_maxrss``), the annealer's proposals, and per stage (Delaunay, the annealing stages
noise / calibrate / anneal / polish, the quality report) its wall time and peak resident
size, printed as a comment under the row. "End to end" is
``scanmesh.reconstruct(points, "anneal", plane="y", ...)`` plus the quality report, from
points in memory (the scan's simulation and the .npz load are not counted). The machine's
load average is printed with every row; the figures go to docs/benchmarks/large-scans.md
by hand, with the command.
"""

from __future__ import annotations

import argparse
import json
import math
import os
import resource
import subprocess
import sys
import tempfile
import time
from pathlib import Path

SHARED = Path(__file__).resolve().parents[2] / "shared" / "data"
ROD = SHARED / "cad" / "conrod_slevin48_onshape.stl"
CACHE = Path(tempfile.gettempdir()) / "scanmesh-large-anneal"


def load() -> str:
    return "load {:.1f} {:.1f} {:.1f}".format(*os.getloadavg())


def rod_scan(n: int):
    """(points, line_ids) of the rod scanned along y with about n points (cached)."""
    import numpy as np

    from scanmesh.evaluate.digitizer import simulate_scan

    path = CACHE / f"rod{n}.npz"
    if not path.exists():
        CACHE.mkdir(parents=True, exist_ok=True)
        pts, ids = simulate_scan(ROD, up="y", along="x", n_points=n)
        np.savez(path, points=pts, line_ids=ids)
    z = np.load(path)
    return z["points"], z["line_ids"]


class Stages:
    """Wall seconds and peak resident size (MB) of each stage of this process: a thread
    reads VmRSS every 20 ms (peaks shorter than that can be missed; ``ru_maxrss`` is the
    exact peak of the whole process)."""

    def __init__(self) -> None:
        import threading

        self.current, self.t = "start", time.perf_counter()
        self.table: dict[str, list[float]] = {}
        threading.Thread(target=self._sample, daemon=True).start()

    @staticmethod
    def rss_mb() -> float:
        with open("/proc/self/status") as f:
            for line in f:
                if line.startswith("VmRSS:"):
                    return int(line.split()[1]) / 1024
        return 0.0

    def _sample(self) -> None:
        while True:
            row = self.table.setdefault(self.current, [0.0, 0.0])
            row[1] = max(row[1], self.rss_mb())
            time.sleep(0.02)

    def enter(self, name: str) -> None:
        now = time.perf_counter()
        self.table.setdefault(self.current, [0.0, 0.0])[0] += now - self.t
        self.current, self.t = name, now
        row = self.table.setdefault(name, [0.0, 0.0])
        row[1] = max(row[1], self.rss_mb())

    def progress(self, done: int, total: int, value: object, stage: str = "", **_: object) -> None:
        """A stage-aware progress callable: annealing's stages."""
        if stage and stage != self.current:
            self.enter(stage)


def child(spec: dict) -> dict:
    """One measurement in this process: see the module doc."""
    import scanmesh
    from scanmesh.stages.anneal import anneal_surface

    stages = Stages()
    if spec["points"] == "rod":
        pts, _ = scanmesh.load_rod()
    else:
        pts, _ = rod_scan(int(spec["points"]))
    trim = {} if spec["trim"] else {"max_edge": math.inf}
    stages.enter("delaunay")
    t0 = time.perf_counter()
    d = scanmesh.reconstruct(pts, "delaunay", plane="y", **trim)
    t1 = time.perf_counter()
    a = anneal_surface(d, seed=0, progress=stages.progress, **spec["options"])
    t2 = time.perf_counter()
    stages.enter("quality")
    qa, qd = a.quality, d.quality
    t3 = time.perf_counter()
    stages.enter("end")
    sweeps = len(a.trace["energy"])
    return {
        "delaunay_s": t1 - t0,
        "anneal_s": t2 - t1,
        "end_to_end_s": t3 - t0,
        "tac_delaunay": qd.tac_1,
        "tac": qa.tac_1,
        "energy": a.options["energy"],
        "initial_energy": a.options["initial_energy"],
        "sweeps": sweeps,
        # The annealer that proposed every edge did not count: one proposal per interior edge and
        # sweep (an upper bound with tiles, whose border edges wait).
        "proposals": (
            a.options["proposals"] if "proposals" in a.options else sweeps * interior_edges(d.faces)
        ),
        "faces": len(a.faces),
        "peak_mb": resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024,
        "stopped": a.options["stopped"],
        "stages": {k: [round(v[0], 2), round(v[1])] for k, v in stages.table.items()},
    }


def interior_edges(faces) -> int:
    """Edges shared by two triangles. O(m log m)."""
    import numpy as np

    e = np.sort(faces[:, [0, 1, 1, 2, 2, 0]].reshape(-1, 2), axis=1)
    _, counts = np.unique(e, axis=0, return_counts=True)
    return int((counts == 2).sum())


def run(python: str, spec: dict) -> dict:
    """The measurement `spec` in a fresh process of `python`; its result with the load."""
    before = load()
    out = subprocess.run(
        [python, __file__, "_child", json.dumps(spec)],
        check=True,
        capture_output=True,
        text=True,
    ).stdout
    result = json.loads(out.strip().splitlines()[-1])
    result["load"] = before
    return result


def row(label: str, r: dict) -> str:
    ratio = r["tac"] / r["tac_delaunay"]
    return (
        f"| {label} | {r['end_to_end_s']:.1f} | {r['anneal_s']:.2f} | {ratio:.4g}"
        f" | {r['tac']:.6g} | {r['sweeps']} | {r['proposals']:,} | {r['peak_mb']:,.0f}"
        f" | {r['load']} |"
    )


HEADER = (
    "| run | end to end (s) | annealing (s) | tac_1 / Delaunay's | tac_1 | sweeps | proposals"
    " | peak (MB) | load before |\n|---|---|---|---|---|---|---|---|---|"
)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("case", choices=["rod", "paper", "million", "_child"])
    parser.add_argument("spec", nargs="?", help=argparse.SUPPRESS)
    parser.add_argument("--points", type=int, default=1_000_000)
    parser.add_argument("--old-python", help="also run every case under this interpreter")
    parser.add_argument("--repeat", type=int, default=2, help="alternating runs per build")
    parser.add_argument(
        "--no-reference", action="store_true", help="skip the 3,000-sweep tiled reference"
    )
    parser.add_argument("--only", help="run only the cases whose label contains this text")
    args = parser.parse_args()
    if args.case == "_child":
        print(json.dumps(child(json.loads(args.spec))))
        return
    builds = [("this build", sys.executable)]
    if args.old_python:
        builds.append(("old build", args.old_python))
    cases: list[tuple[str, dict]] = []
    if args.case == "rod":
        cases = [("embedded rod, defaults", {"points": "rod", "trim": True, "options": {}})]
    elif args.case == "paper":
        # the paper's annealing: from Delaunay itself, every flip judged by tac alone
        paper = {"sweeps": 3000, "patience": 0, "descend": False, "sliver_angle": 0.0}
        cases = [
            (
                "rod with curtains, 3,000 sweeps",
                {"points": "rod", "trim": False, "options": paper},
            ),
            (
                "rod with curtains, 3,000 sweeps, 8 tiles",
                {"points": "rod", "trim": False, "options": {**paper, "tiles": 8}},
            ),
        ]
    else:
        n = args.points
        cases = [
            (f"{n:,} points, defaults", {"points": n, "trim": True, "options": {}}),
            (f"{n:,} points with curtains, defaults", {"points": n, "trim": False, "options": {}}),
        ]
        if not args.no_reference:
            ref = {"sweeps": 3000, "patience": 0, "tiles": 8, "descend": False, "sliver_angle": 0.0}
            cases.append(
                (
                    f"{n:,} points with curtains, 3,000 sweeps, 8 tiles",
                    {"points": n, "trim": False, "options": ref},
                )
            )
        rod_scan(n)  # simulated once, outside every measurement
    if args.only:
        cases = [(label, spec) for label, spec in cases if args.only in label]
    print(HEADER)
    for label, spec in cases:
        for _ in range(args.repeat if args.old_python else 1):
            for build, python in builds:
                r = run(python, spec)
                print(row(f"{label} ({build})", r), flush=True)
                stages = ", ".join(f"{k} {t:.1f} s {mb:,} MB" for k, (t, mb) in r["stages"].items())
                print(f"<!-- stopped: {r['stopped']}; stages (wall, peak RSS): {stages} -->")


if __name__ == "__main__":
    main()
