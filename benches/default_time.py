"""The default method's wall time against LOP's on real scans, interleaved in one process.

    python benches/default_time.py                       # SainteHelens, 2 rounds
    python benches/default_time.py --scan terrain/SainteHelens.dem --rounds 3
    python benches/default_time.py --scan /tmp/turbineblade_1M.npz --plane y --rounds 1

Each round times ``reconstruct(scan, "lop")`` and ``reconstruct(scan)`` (the default) on the
same scan, read once; the figure to read is the ratio within a round (the goal: the default
within 3 x LOP's time on scans of 20,000 points or more). Where the default's time goes:
the judge's builds per candidate on the withheld tenths (``method_choice["seconds"]``,
a candidate's time including the meshes it starts from when it needs them first; their sum
can exceed the judge's wall time, as its two lanes run side by side) and the tenths judged.
Prints the load average before and after.
"""

from __future__ import annotations

import argparse
import os
import time
import warnings
from pathlib import Path

import scanmesh

#: ../shared/data beside the repository, as the other benches find it.
SHARED = Path(__file__).resolve().parents[2] / "shared" / "data"


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--data", type=Path, default=SHARED, help="the shared data folder")
    parser.add_argument("--scan", default="terrain/SainteHelens.dem", help="file under --data")
    parser.add_argument("--rounds", type=int, default=2)
    parser.add_argument("--plane", default=None, help="projection plane for both (default: chosen)")
    args = parser.parse_args()
    warnings.simplefilter("ignore")
    scan = scanmesh.read(args.data / args.scan)  # an absolute --scan is taken as it is
    plane = {} if args.plane is None else {"plane": args.plane}
    print(f"{args.scan}: {len(scan.points):,} points; load {os.getloadavg()}")
    print(
        "| round | LOP (s) | default (s) | default / LOP | judge builds (s): per candidate | tenths"
        " | built | tac_1 LOP | tac_1 default |"
    )
    print("|---:|---:|---:|---:|---|---:|---|---:|---:|")
    for k in range(args.rounds):
        t = time.perf_counter()
        lop = scanmesh.reconstruct(scan, "lop", **plane)
        t_lop = time.perf_counter() - t
        t = time.perf_counter()
        default = scanmesh.reconstruct(scan, **plane)
        t_default = time.perf_counter() - t
        made = default.options["method_choice"]
        judge = sum(made["seconds"].values())
        each = ", ".join(f"{name} {sec:.2f}" for name, sec in made["seconds"].items())
        print(
            f"| {k} | {t_lop:.2f} | {t_default:.2f} | {t_default / t_lop:.2f} |"
            f" {judge:.2f}: {each} | {made['folds']} | {made['built']} |"
            f" {lop.quality.tac_1:.1f} | {default.quality.tac_1:.1f} |",
            flush=True,
        )
    print(f"load {os.getloadavg()}")


if __name__ == "__main__":
    main()
