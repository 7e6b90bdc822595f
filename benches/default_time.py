"""The default method's wall time against LOP's on real scans, interleaved in one process.

    python benches/default_time.py                       # SainteHelens, 2 rounds
    python benches/default_time.py --scan terrain/SainteHelens.dem --rounds 3
    python benches/default_time.py --scan /tmp/turbineblade_1M.npz --plane y --rounds 1
    python benches/default_time.py --scan /tmp/panel/conrod_axis_0.npz --plane y --rounds 1

Each round times ``reconstruct(scan, "lop")`` and ``reconstruct(scan)`` (the default) on the
same scan, read once; the figure to read is the ratio within a round (the goal: the default
within 3 x LOP's time on scans of 20,000 points or more). Where the default's time goes:
the judge's builds per candidate on the withheld tenths (``method_choice["seconds"]``,
a candidate's time including the meshes it starts from when it needs them first; their sum
can exceed the judge's wall time, as its two lanes run side by side) and the tenths judged;
then the method it built, alone with the same keywords (its own build: the default's time
less it is the judge's). An ``.npz`` with ``points`` and ``lines`` (as ``benches/panel.py``
writes its scans) passes the line ids to the default and to a winner that takes them.
The CPU seconds (``time.process_time``: every thread of the process) do not grow with
other processes' load as wall seconds do; on an idle machine the wall time is at most
about the CPU time (less where the judge's two lanes overlap, and on a scan of at most
``methods.AHEAD_POINTS`` points, where the first candidate is built beside the judge, as
little as half of it on two cores). ``--beside`` also times the default with no build
beside the judge (``AHEAD_POINTS`` 0) in each round: the same mesh, the CPU and wall
seconds the build beside the judge costs or saves.
Prints the load average before and after.
"""

from __future__ import annotations

import argparse
import os
import time
import warnings
from pathlib import Path

import numpy as np
from panel import LINES

import scanmesh
from scanmesh import methods

#: ../shared/data beside the repository, as the other benches find it.
SHARED = Path(__file__).resolve().parents[2] / "shared" / "data"


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--data", type=Path, default=SHARED, help="the shared data folder")
    parser.add_argument("--scan", default="terrain/SainteHelens.dem", help="file under --data")
    parser.add_argument("--rounds", type=int, default=2)
    parser.add_argument("--plane", default=None, help="projection plane for both (default: chosen)")
    parser.add_argument(
        "--beside",
        action="store_true",
        help="also the default with no build beside the judge, in each round",
    )
    args = parser.parse_args()
    warnings.simplefilter("ignore")
    path = args.data / args.scan  # an absolute --scan is taken as it is
    scan = scanmesh.read(path)
    plane = {} if args.plane is None else {"plane": args.plane}
    lines = None
    if path.suffix == ".npz":  # panel.py's scans keep their line ids beside the points
        with np.load(path) as saved:
            if "lines" in saved and len(saved["lines"]):
                lines = saved["lines"]
    print(f"{args.scan}: {len(scan.points):,} points; load {os.getloadavg()}")
    beside = " no build beside: wall / CPU (s) |" if args.beside else ""
    print(
        "| round | LOP (s) | default (s) | default / LOP | judge builds (s): per candidate | tenths"
        " | built | built alone (s) | judge (s) | CPU default / built alone (s)"
        f" | tac_1 LOP | tac_1 default |{beside}"
    )
    print("|---:|---:|---:|---:|---|---:|---|---:|---:|---:|---:|---:|" + "---|" * args.beside)
    for k in range(args.rounds):
        t = time.perf_counter()
        lop = scanmesh.reconstruct(scan, "lop", **plane)
        t_lop = time.perf_counter() - t
        t, cpu = time.perf_counter(), time.process_time()
        default = scanmesh.reconstruct(scan, **plane, **_lines("auto", lines))
        t_default, cpu_default = time.perf_counter() - t, time.process_time() - cpu
        made = default.options["method_choice"]
        t, cpu = time.perf_counter(), time.process_time()
        scanmesh.reconstruct(scan, made["built"], **plane, **_lines(made["built"], lines))
        t_built, cpu_built = time.perf_counter() - t, time.process_time() - cpu
        alone = ""
        if args.beside:
            ahead, methods.AHEAD_POINTS = methods.AHEAD_POINTS, 0
            t, cpu = time.perf_counter(), time.process_time()
            after = scanmesh.reconstruct(scan, **plane, **_lines("auto", lines))
            wall, cpu = time.perf_counter() - t, time.process_time() - cpu
            methods.AHEAD_POINTS = ahead
            same = "same" if np.array_equal(after.faces, default.faces) else "OTHER"
            alone = f" {wall:.2f} / {cpu:.2f} ({same} faces) |"
        judge = sum(made["seconds"].values())
        each = ", ".join(f"{name} {sec:.2f}" for name, sec in made["seconds"].items())
        print(
            f"| {k} | {t_lop:.2f} | {t_default:.2f} | {t_default / t_lop:.2f} |"
            f" {judge:.2f}: {each} | {made['folds']} | {made['built']} | {t_built:.2f} |"
            f" {t_default - t_built:.2f} | {cpu_default:.2f} / {cpu_built:.2f} |"
            f" {lop.quality.tac_1:.1f} | {default.quality.tac_1:.1f} |{alone}",
            flush=True,
        )
    print(f"load {os.getloadavg()}")


def _lines(method: str, lines) -> dict:
    """``lines=`` for ``method`` when the scan has them and the method takes them."""
    return {"lines": lines} if lines is not None and method in LINES else {}


if __name__ == "__main__":
    main()
