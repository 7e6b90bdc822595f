"""Long fuzz run of the native flip optimizers: Delaunay, then LOP or annealing, on the seeded
cases of tests/fuzz_core.py, each in a child process with a time limit, so that a hang or
a crash (an abort in Rust) is a finding too, not the end of the run.

    python benches/fuzz_core.py --cases 5000            # seeds 0..4999, a summary
    python benches/fuzz_core.py --start 10000 --cases 100000 --timeout 60
    python benches/fuzz_core.py --case 1427             # rerun one case in this process

Findings are grouped by stage and kind of fault, with the first seeds of each. With
``--caller-plane`` a Delaunay face degenerate in the caller's planar coordinates (though
not in the unit square the core computes in) counts too.
"""

from __future__ import annotations

import argparse
import collections
import json
import os
import re
import selectors
import subprocess
import sys
import time
import warnings
from pathlib import Path

TESTS = Path(__file__).resolve().parents[1] / "tests"
sys.path.insert(0, str(TESTS))

from fuzz_core import make_case, run_case  # noqa: E402


def worker(caller_plane: bool) -> None:
    """Reads seeds from stdin, writes one JSON line per case: the seed and its finding."""
    warnings.simplefilter("ignore")
    for line in sys.stdin:
        seed = int(line)
        finding = run_case(seed, caller_plane)
        print(json.dumps({"seed": seed, "finding": finding}), flush=True)


class Child:
    """A worker process fed one seed at a time."""

    def __init__(self, caller_plane: bool) -> None:
        args = [sys.executable, __file__, "--worker"] + (["--caller-plane"] if caller_plane else [])
        self.proc = subprocess.Popen(
            args, stdin=subprocess.PIPE, stdout=subprocess.PIPE, text=True, bufsize=1
        )
        self.sel = selectors.DefaultSelector()
        assert self.proc.stdout is not None
        self.sel.register(self.proc.stdout, selectors.EVENT_READ)

    def run(self, seed: int, timeout: float) -> str | None:
        """The case's finding; raises TimeoutError or EOFError (the worker died)."""
        assert self.proc.stdin is not None and self.proc.stdout is not None
        self.proc.stdin.write(f"{seed}\n")
        self.proc.stdin.flush()
        if not self.sel.select(timeout):
            raise TimeoutError
        line = self.proc.stdout.readline()
        if not line:
            raise EOFError(self.proc.wait())
        return json.loads(line)["finding"]

    def close(self) -> None:
        self.proc.kill()
        self.proc.wait()


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawTextHelpFormatter)
    ap.add_argument("--start", type=int, default=0, help="first seed")
    ap.add_argument("--cases", type=int, default=5000, help="number of seeds")
    ap.add_argument("--timeout", type=float, default=60.0, help="seconds per case")
    ap.add_argument("--caller-plane", action="store_true", help="see the module docstring")
    ap.add_argument("--case", type=int, help="rerun one seed here and print its case")
    ap.add_argument("--worker", action="store_true", help=argparse.SUPPRESS)
    args = ap.parse_args()
    if args.worker:
        worker(args.caller_plane)
        return
    if args.case is not None:
        case = make_case(args.case)
        print(case["kind"], len(case["points"]), case["options"])
        print(run_case(args.case, args.caller_plane) or "no finding")
        return
    t0 = time.monotonic()
    groups: dict[str, list[int]] = collections.defaultdict(list)
    kinds: collections.Counter[str] = collections.Counter()
    child = Child(args.caller_plane)
    for seed in range(args.start, args.start + args.cases):
        kinds[make_case(seed)["options"]["method"]] += 1
        try:
            finding = child.run(seed, args.timeout)
        except TimeoutError:
            finding = f"no end within {args.timeout:.0f} s"
            child.close()
            child = Child(args.caller_plane)
        except EOFError as exc:
            finding = f"the process died (exit {exc.args[0]})"
            child = Child(args.caller_plane)
        if finding:
            # Group by the message without its numbers (face and vertex ids).
            groups[re.sub(r"[\d.]+", "#", finding)].append(seed)
    child.close()
    elapsed = time.monotonic() - t0
    print(
        f"{args.cases} cases (seeds {args.start}..{args.start + args.cases - 1}; "
        f"{dict(kinds)}) in {elapsed:.0f} s, load {os.getloadavg()[0]:.1f}"
    )
    if not groups:
        print("no findings")
    for what, seeds in sorted(groups.items(), key=lambda g: -len(g[1])):
        print(f"{len(seeds):6d}  {what}  (seeds {seeds[:5]})")


if __name__ == "__main__":
    main()
