"""Long run of the hull property: random inputs with near-duplicates through ``delaunay``,
``lop`` and ``anneal`` untrimmed (``max_edge=math.inf``), every face checked in exact
arithmetic to lie in and cover the convex hull (tests/hull_fuzz.py, the property that
tests/test_hull_coverage.py checks on 60 hypothesis examples).

    python benches/hull_fuzz.py --cases 20000            # seeds 0..19999, a summary
    python benches/hull_fuzz.py --start 20000 --cases 1000
    python benches/hull_fuzz.py --case 1427              # one case, its faults per method

A case is one seed: its points (``hull_fuzz.case_of``: 4-40 random points, 1-8 of them
copied 1e-12..1e-7 of the extent away, at the origin or 1e6 off it) run through each
method. A method that refuses the input with a ScanmeshError (too few distinct points, all
collinear) is counted, not a finding; any other exception is.
"""

from __future__ import annotations

import argparse
import collections
import sys
import time
import warnings
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))

from quality import machine  # noqa: E402

import scanmesh  # noqa: E402
from hull_fuzz import OPTIONS, case_of, faults_of, with_near_duplicates  # noqa: E402


def run_case(seed: int) -> dict[str, list[str] | str | None]:
    """Per method: its faults (empty: the hull exactly), "refused: ..." or "raised: ..."."""
    points = with_near_duplicates(**case_of(seed))
    out: dict[str, list[str] | str | None] = {}
    for method in sorted(OPTIONS):
        try:
            out[method] = faults_of(points, method)
        except scanmesh.ScanmeshError as exc:
            out[method] = f"refused: {type(exc).__name__}"
        except Exception as exc:  # noqa: BLE001 - a finding, reported with its seed
            out[method] = f"raised: {type(exc).__name__}: {exc}"
    return out


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--start", type=int, default=0, help="first seed")
    ap.add_argument("--cases", type=int, default=1000, help="number of seeds")
    ap.add_argument("--case", type=int, help="run this one seed and print its result")
    args = ap.parse_args()
    warnings.simplefilter("ignore")
    if args.case is not None:
        print(case_of(args.case))
        print(run_case(args.case))
        return
    print(f"machine: {machine()}", flush=True)
    t0 = time.perf_counter()
    runs, refused = collections.Counter(), collections.Counter()
    findings: dict[str, list[int]] = collections.defaultdict(list)
    for k, seed in enumerate(range(args.start, args.start + args.cases)):
        for method, result in run_case(seed).items():
            if isinstance(result, str) and result.startswith("refused"):
                refused[method] += 1
                continue
            runs[method] += 1
            faults = [result] if isinstance(result, str) else result or []
            for fault in faults:
                findings[f"{method}: {fault.split(':')[0]}"].append(seed)
        if (k + 1) % 1000 == 0:
            print(f"  {k + 1:,} cases, {time.perf_counter() - t0:.0f} s", flush=True)
    print(
        f"seeds {args.start}..{args.start + args.cases - 1}: {args.cases:,} inputs in"
        f" {time.perf_counter() - t0:.0f} s"
    )
    for method in sorted(OPTIONS):
        print(f"  {method}: {runs[method]:,} meshes checked, {refused[method]:,} inputs refused")
    if not findings:
        print("findings: none (every untrimmed mesh covers its hull exactly)")
    for what, seeds in sorted(findings.items()):
        print(f"finding: {what}: {len(seeds)} seeds, first {seeds[:10]}")
    print(f"machine after: {machine()}")


if __name__ == "__main__":
    main()
