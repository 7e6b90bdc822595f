"""Long fuzz run of the Python API: ``scanmesh.reconstruct`` on the seeded cases of
tests/api_fuzz.py (every method; points, line ids, planes and options of every type and
size), each in a child process with a time limit and a memory limit, so that a hang or a
crash (an abort in Rust) is a finding too, not the end of the run.

    nice -n 10 python benches/api_fuzz.py --examples 100000
    python benches/api_fuzz.py --start 5000 --examples 2000 --timeout 30 --memory-mb 2048
    python benches/api_fuzz.py --case 1427        # print one case's reproducer and run it here

Findings are summarized by class (method and kind of fault) with a count, the first seeds
and a reproducer for the first one; also a count of outcomes (surfaces, refusals by error
type). Exit status 1 when anything was found.
"""

from __future__ import annotations

import argparse
import sys
import time
from collections import Counter
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))

from api_fuzz import reproducer, run_case, run_many  # noqa: E402


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawTextHelpFormatter)
    ap.add_argument("--start", type=int, default=0, help="first seed")
    ap.add_argument("--examples", type=int, default=5000, help="number of seeds")
    ap.add_argument("--timeout", type=float, default=30.0, help="seconds per example")
    ap.add_argument("--memory-mb", type=int, default=2048, help="address space of the child")
    ap.add_argument(
        "--batch", type=int, default=500, help="examples per child process and per progress line"
    )
    ap.add_argument("--case", type=int, help="print the reproducer of one seed and run it here")
    args = ap.parse_args()
    if args.case is not None:
        print(reproducer(args.case))
        print(run_case(args.case))
        return 0
    t0 = time.perf_counter()
    findings: dict[str, list[tuple[int, str]]] = {}
    outcomes: Counter[str] = Counter()
    end = args.start + args.examples
    for first in range(args.start, end, args.batch):
        found, counted = run_many(
            range(first, min(first + args.batch, end)), args.timeout, args.memory_mb * 2**20
        )
        for name, hits in found.items():
            findings.setdefault(name, []).extend(hits)
        outcomes.update(counted)
        print(
            f"{min(first + args.batch, end) - args.start} examples,"
            f" {sum(len(v) for v in findings.values())} finding(s),"
            f" {time.perf_counter() - t0:.0f} s",
            file=sys.stderr,
            flush=True,
        )
    seconds = time.perf_counter() - t0
    print(
        f"{args.examples} examples (seeds {args.start}..{args.start + args.examples - 1})"
        f" in {seconds:.0f} s"
    )
    for outcome, count in outcomes.most_common():
        print(f"  {count:7d} {outcome}")
    print(f"{sum(len(v) for v in findings.values())} finding(s) in {len(findings)} class(es)")
    for name, hits in sorted(findings.items(), key=lambda kv: -len(kv[1])):
        seeds = ", ".join(str(seed) for seed, _ in hits[:8])
        print(f"\n== {name}: {len(hits)} (seeds {seeds}{', ...' if len(hits) > 8 else ''})")
        print(f"   {hits[0][1]}")
        print("   " + reproducer(hits[0][0]).replace("\n", "\n   "))
    return 1 if findings else 0


if __name__ == "__main__":
    sys.exit(main())
