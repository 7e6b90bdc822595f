"""Certified tac optimum against LOP and annealing on small patches.

For random and real-scan patches of 20, 30, 40 and 60 points, triangulated over the whole
convex hull (``max_edge=math.inf``), measures

* the time HiGHS needs to prove the tac_1 optimum (``optimal_surface``), or the gap left
  at the time limit;
* the relative gap of LOP and of annealing with default settings to that optimum:
  ``(tac_1(heuristic) - tac_1(optimum)) / tac_1(optimum)``. Where the optimum is not proven
  the gap is an interval, from the best triangulation known (lower end) to HiGHS's lower
  bound (upper end).

Writes one JSON line per instance to ``out/optimal.jsonl`` and the summary into the section
"## Certified optimum" of docs/benchmarks/optimum.md (the rest of the file is left alone).

Instances:

* ``random``: n points uniform in the unit square, z = 0.3 sin(3x) cos(2y) + N(0, 0.01);
  projected along z.
* ``scan``: a window of consecutive profiles x consecutive points (5x4, 6x5, 8x5, 10x6)
  of the real Cyberware face scan ``../shared/data/scans/fran_cut.vtk`` (45 profiles of 49
  points) at a random position; best-fit plane.

    python benches/optimal.py                       # the full run (about an hour)
    python benches/optimal.py --sizes 20 30 --instances 4 --no-write   # a quick look
    python benches/optimal.py --reuse-milp benches/results/optimal_milp.jsonl  # heuristics only
"""

from __future__ import annotations

import argparse
import json
import math
import os
import platform
import re
import subprocess
import time
import warnings
from pathlib import Path

import numpy as np

import scanmesh
from scanmesh.stages.optimal import optimal_surface

ROOT = Path(__file__).resolve().parents[1]
SCAN = ROOT.parent / "shared" / "data" / "scans" / "fran_cut.vtk"
HEADER = "## Certified optimum"
#: The file that holds the section (BENCHMARKS.md summarizes it).
TARGET = ROOT / "docs" / "benchmarks" / "optimum.md"
#: (profiles, points per profile) of the scan windows, by patch size
WINDOWS = {20: (5, 4), 30: (6, 5), 40: (8, 5), 60: (10, 6)}
#: scan windows tilted more than this against their best-fit plane are skipped (degrees)
MAX_TILT_DEG = 60.0
#: default number of instances per kind, by patch size
DEFAULT_INSTANCES = {20: 10, 30: 20, 40: 6, 60: 4}


def random_patch(n: int, rng: np.random.Generator) -> np.ndarray:
    """(n, 3) random points under a smooth bump with 1 % noise."""
    xy = rng.random((n, 2))
    z = 0.3 * np.sin(3 * xy[:, 0]) * np.cos(2 * xy[:, 1]) + 0.01 * rng.standard_normal(n)
    return np.column_stack([xy, z])


def scan_patch(grid: np.ndarray, n: int, rng: np.random.Generator) -> np.ndarray:
    """(n, 3) window of consecutive profiles x consecutive points of the (45, 49, 3) scan.

    Windows are drawn until one is a height field over its best-fit plane: every grid
    triangle (two per cell) keeps its orientation in the plane and is tilted less than
    MAX_TILT_DEG against it (about 85 % of the 10 x 6 windows qualify, 95 % of the 5 x 4).
    """
    rows, cols = WINDOWS[n]
    while True:
        i = int(rng.integers(0, grid.shape[0] - rows + 1))
        j = int(rng.integers(0, grid.shape[1] - cols + 1))
        window = grid[i : i + rows, j : j + cols]
        if is_height_field(window):
            return window.reshape(-1, 3).copy()


def is_height_field(window: np.ndarray) -> bool:
    """True when the (rows, cols, 3) grid projects onto its best-fit plane without folds."""
    uv, frame = scanmesh.project(window.reshape(-1, 3))
    uv = uv.reshape(window.shape[0], window.shape[1], 2)
    p00, p10, p01, p11 = uv[:-1, :-1], uv[1:, :-1], uv[:-1, 1:], uv[1:, 1:]

    def orient(a: np.ndarray, b: np.ndarray, c: np.ndarray) -> np.ndarray:
        u, v = b - a, c - a
        return np.sign(u[..., 0] * v[..., 1] - u[..., 1] * v[..., 0]).ravel()

    signs = np.concatenate([orient(p00, p10, p01), orient(p10, p11, p01)])
    if abs(signs.sum()) != len(signs):
        return False
    w = window
    normals = np.concatenate(
        [
            np.cross(w[1:, :-1] - w[:-1, :-1], w[:-1, 1:] - w[:-1, :-1]).reshape(-1, 3),
            np.cross(w[1:, 1:] - w[1:, :-1], w[:-1, 1:] - w[1:, :-1]).reshape(-1, 3),
        ]
    )
    cosine = np.abs(normals @ frame.normal) / np.linalg.norm(normals, axis=1)
    return bool(np.degrees(np.arccos(np.clip(cosine, 0, 1))).max() < MAX_TILT_DEG)


def load_scan() -> np.ndarray:
    """The fran_cut scan as (profiles, points, 3)."""
    return scanmesh.formats.read_vtk(SCAN).points.reshape(45, 49, 3)


#: the MILP's columns of a row, reusable when only the heuristics change
MILP_KEYS = (
    "n", "certified", "milp_gap", "optimum_or_incumbent", "lower_bound", "seconds_optimal",
    "seconds_solve", "candidates", "nodes", "proof",
)


def solve_exact(points: np.ndarray, plane, time_limit: float) -> dict:
    """The MILP's optimum (or incumbent and bound) on one patch, with its times."""
    t0 = time.perf_counter()
    exact = optimal_surface(points, plane=plane, time_limit=time_limit)
    return {
        "n": len(points),
        "certified": exact.certified,
        "milp_gap": exact.gap,
        "optimum_or_incumbent": exact.quality.tac_1,
        "lower_bound": exact.options["lower_bound"],
        "seconds_optimal": time.perf_counter() - t0,
        "seconds_solve": exact.timings["solve"],
        "candidates": exact.options["candidate_triangles"],
        "nodes": exact.options["nodes"],
    }


def _option(text: str) -> tuple[str, float | bool]:
    """``name=value`` of ``--anneal``: a number, or true/false."""
    name, _, value = text.partition("=")
    if value.lower() in ("true", "false"):
        return name, value.lower() == "true"
    return name, float(value)


def run_instance(
    points: np.ndarray,
    plane,
    time_limit: float,
    seed: int,
    known: dict | None = None,
    settle: float = 0.0,
    anneal_options: dict | None = None,
) -> dict:
    """Optimum (or ``known``'s MILP columns), LOP and annealing on one patch: tac_1
    values, times and gaps. With ``settle`` > 0 seconds, an instance whose annealing
    verdict (within 1 %) is still open gets a second MILP with annealing's triangulation
    as the incumbent (a cutoff: ``optimal_surface(incumbent=...)``)."""
    if known is not None:
        row = {k: known[k] for k in MILP_KEYS if k in known}
    else:
        row = solve_exact(points, plane, time_limit)
    surfaces = {}
    for method in ("lop", "anneal"):
        t0 = time.perf_counter()
        kwargs = {"seed": seed, **(anneal_options or {})} if method == "anneal" else {}
        with warnings.catch_warnings():
            # Whole-hull slivers along nearly straight profile ends are steep: not a fold.
            warnings.simplefilter("ignore", scanmesh.errors.NotAHeightFieldWarning)
            surface = scanmesh.reconstruct(points, method, plane=plane, max_edge=math.inf, **kwargs)
        row[f"seconds_{method}"] = time.perf_counter() - t0
        row[method] = surface.quality.tac_1
        surfaces[method] = surface
    add_gaps(row)
    if settle > 0 and within(row, "anneal") is None:
        t0 = time.perf_counter()
        second = optimal_surface(
            points, plane=plane, time_limit=settle, incumbent=surfaces["anneal"]
        )
        row["settle_seconds"] = time.perf_counter() - t0
        row["settle_certified"] = second.certified
        row["settle_value"] = second.quality.tac_1
        row["settle_lower_bound"] = second.options["lower_bound"]
        add_gaps(row)
    return row


def add_gaps(row: dict) -> None:
    """Best known value, lower bound and each heuristic's gap interval, from every MILP run."""
    best_known = min(row["optimum_or_incumbent"], row["lop"], row["anneal"])
    lower = row["lower_bound"] if not row["certified"] else row["optimum_or_incumbent"]
    if "settle_value" in row:
        best_known = min(best_known, row["settle_value"])
        lower = row["settle_value"] if row["settle_certified"] else max(
            lower, row["settle_lower_bound"]
        )
    lower = min(lower, best_known)
    row["best_known"] = best_known
    for method in ("lop", "anneal"):
        v = row[method]
        row[f"{method}_gap_low"] = (v - best_known) / best_known if best_known > 0 else 0.0
        row[f"{method}_gap_high"] = (v - lower) / lower if lower > 0 else math.inf


def within(row: dict, method: str, tol: float = 0.01) -> bool | None:
    """True/False when known, None when the interval straddles tol."""
    if row[f"{method}_gap_high"] <= tol:
        return True
    if row[f"{method}_gap_low"] > tol:
        return False
    return None


def pct(x: float) -> str:
    return "inf" if not math.isfinite(x) else f"{100 * x:.1f} %"


def summarize(rows: list[dict]) -> list[str]:
    lines = [
        "| patch | n | instances | proven | time to prove: median / max (s) | MILP gap left"
        " (unproven: median / max) | LOP gap: median / max | annealing gap: median / max |"
        " annealing within 1 % (yes / no / unknown) |",
        "|---|---|---|---|---|---|---|---|---|",
    ]
    for kind in ("random", "scan"):
        for n in sorted({r["n"] for r in rows if r["kind"] == kind}):
            group = [r for r in rows if r["kind"] == kind and r["n"] == n]
            proven = [r for r in group if r["certified"]]
            open_ = [r for r in group if not r["certified"]]
            times = [r["seconds_solve"] for r in proven]
            t_text = f"{np.median(times):.1f} / {max(times):.1f}" if times else "-"
            g_text = (
                f"{pct(np.median([r['milp_gap'] for r in open_]))} /"
                f" {pct(max(r['milp_gap'] for r in open_))}"
                if open_
                else "-"
            )

            def gap_text(method: str, group: list[dict] = group) -> str:
                low = [r[f"{method}_gap_low"] for r in group]
                high = [r[f"{method}_gap_high"] for r in group]
                if all(r["certified"] for r in group):
                    return f"{pct(np.median(low))} / {pct(max(low))}"
                return (
                    f"{pct(np.median(low))}..{pct(np.median(high))} /"
                    f" {pct(max(low))}..{pct(max(high))}"
                )

            verdicts = [within(r, "anneal") for r in group]
            yes = sum(v is True for v in verdicts)
            no = sum(v is False for v in verdicts)
            unknown = sum(v is None for v in verdicts)
            lines.append(
                f"| {kind} | {n} | {len(group)} | {len(proven)} | {t_text} | {g_text} |"
                f" {gap_text('lop')} | {gap_text('anneal')} | {yes} / {no} / {unknown} |"
            )
    return lines


def write_section(text: str, path: Path) -> None:
    """Replace (or append) the HEADER section of ``path``, leaving the rest alone."""
    body = path.read_text() if path.exists() else "# Benchmarks\n"
    pattern = re.compile(rf"^{re.escape(HEADER)}\n.*?(?=^## |\Z)", re.S | re.M)
    section = text.rstrip("\n") + "\n\n"
    if pattern.search(body):
        body = pattern.sub(lambda _: section, body, count=1)
    else:
        body = body.rstrip("\n") + "\n\n" + section
    tmp = path.with_suffix(".md.part")
    tmp.write_text(body.rstrip("\n") + "\n")
    os.replace(tmp, path)


def machine() -> str:
    load = os.getloadavg()[0] if hasattr(os, "getloadavg") else math.nan
    try:
        commit = subprocess.run(
            ["git", "rev-parse", "--short", "HEAD"], capture_output=True, text=True, cwd=ROOT
        ).stdout.strip()
    except OSError:
        commit = "?"
    return (
        f"{platform.processor() or platform.machine()}, {os.cpu_count()} CPUs, load average"
        f" {load:.1f} at the end, Python {platform.python_version()}, scanmesh at {commit}"
    )


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--sizes", type=int, nargs="+", default=[20, 30, 40, 60])
    parser.add_argument("--instances", type=int, help="per kind and size (default: by size)")
    parser.add_argument("--time-limit", type=float, default=120.0, help="seconds per MILP")
    parser.add_argument("--seed", type=int, default=2026)
    parser.add_argument("--kinds", nargs="+", default=["random", "scan"])
    parser.add_argument("--no-write", action="store_true", help="print only, write no file")
    parser.add_argument(
        "--from-log",
        type=Path,
        help="summarize rows of an earlier run (its JSONL) instead of measuring; the other"
        " options should repeat that run's",
    )
    parser.add_argument(
        "--reuse-milp",
        type=Path,
        help="take the MILP columns (optimum, bound, proof time) from this JSONL of an earlier"
        " run with the same --sizes/--kinds/--seed/--time-limit and rerun only LOP and"
        " annealing (after a change to the heuristics)",
    )
    parser.add_argument(
        "--settle",
        type=float,
        default=0.0,
        help="seconds for a second MILP, with annealing's triangulation as incumbent, on"
        " instances of --settle-sizes whose 1 %% verdict is still open (0: none)",
    )
    parser.add_argument("--settle-sizes", type=int, nargs="+", default=[30])
    parser.add_argument(
        "--anneal",
        type=_option,
        action="append",
        default=[],
        metavar="NAME=VALUE",
        help="an annealing option (a number), e.g. sliver_angle=0; repeat for more",
    )
    args = parser.parse_args()
    if args.from_log:
        rows = [json.loads(line) for line in args.from_log.read_text().splitlines() if line]
        # What the logged run measured: the heuristics, the settling MILPs, and the first
        # MILPs unless they were reused from an earlier run.
        elapsed = sum(
            r["seconds_lop"]
            + r["seconds_anneal"]
            + r.get("settle_seconds", 0.0)
            + (0.0 if args.reuse_milp else r["seconds_optimal"])
            for r in rows
        )
    else:
        rows, elapsed = measure(args)
    report(args, rows, elapsed)


def measure(args: argparse.Namespace) -> tuple[list[dict], float]:
    """Run every instance; rows also go to out/optimal.jsonl as they come."""
    grid = load_scan()
    known = {}
    if args.reuse_milp:
        for line in args.reuse_milp.read_text().splitlines():
            if line:
                r = json.loads(line)
                known[(r["kind"], r["n"], r["index"])] = r
    out = ROOT / "out"
    out.mkdir(exist_ok=True)
    rows: list[dict] = []
    started = time.perf_counter()
    with open(out / "optimal.jsonl", "w") as log:
        for n in args.sizes:
            count = args.instances or DEFAULT_INSTANCES.get(n, 4)
            for kind in args.kinds:
                rng = np.random.default_rng([args.seed, n, kind == "scan"])
                for k in range(count):
                    if kind == "random":
                        pts, plane = random_patch(n, rng), "z"
                    else:
                        pts, plane = scan_patch(grid, n, rng), None
                    reuse = known.get((kind, n, k)) if args.reuse_milp else None
                    if args.reuse_milp and reuse is None:
                        raise SystemExit(f"{args.reuse_milp} has no row for {kind} n={n} #{k}")
                    row = {
                        "kind": kind,
                        "index": k,
                        **run_instance(
                            pts,
                            plane,
                            args.time_limit,
                            k,
                            reuse,
                            args.settle if n in args.settle_sizes else 0.0,
                            dict(args.anneal),
                        ),
                    }
                    rows.append(row)
                    log.write(json.dumps(row) + "\n")
                    log.flush()
                    print(
                        f"{kind:6s} n={n} #{k}: proven={row['certified']} solve"
                        f" {row['seconds_solve']:.1f}s opt {row['optimum_or_incumbent']:.4f}"
                        f" LOP {pct(row['lop_gap_low'])} anneal {pct(row['anneal_gap_low'])}"
                        f"..{pct(row['anneal_gap_high'])}",
                        flush=True,
                    )
    return rows, time.perf_counter() - started


def report(args: argparse.Namespace, rows: list[dict], elapsed: float) -> None:
    """Print the summary and, unless --no-write, put it into TARGET."""
    table = summarize(rows)
    thirty = [r for r in rows if r["n"] == 30]
    verdicts = [within(r, "anneal") for r in thirty]
    goal = (
        f"Goal (annealing within 1 % of the optimum on at least 95 % of 30-point instances):"
        f" within on {sum(v is True for v in verdicts)} of {len(thirty)}"
        f" ({pct(sum(v is True for v in verdicts) / max(1, len(thirty)))}), not within on"
        f" {sum(v is False for v in verdicts)}, undecided on {sum(v is None for v in verdicts)}."
        if thirty
        else ""
    )
    above_lop = sum(r["anneal"] > r["lop"] * (1 + 1e-9) for r in rows)
    exact_hits = sum(r["anneal_gap_high"] <= 1e-6 for r in rows)
    facts = (
        f"Annealing found a proven optimum on {exact_hits} of {len(rows)} instances and"
        f" ended above LOP's tac_1 on {above_lop}."
    )
    by_incumbent = [r for r in rows if r.get("proof") == "incumbent"]
    if by_incumbent:
        facts += (
            f" {len(by_incumbent)} optima in the reused MILP columns were proven by an earlier"
            " --settle run (annealing's triangulation as incumbent, 600 s limit; their time to"
            " prove is that run's)."
        )
    settled = [r for r in rows if "settle_certified" in r]
    if settled:
        proved = [r for r in settled if r["settle_certified"]]
        facts += (
            f" Second MILP with annealing's triangulation as incumbent (cutoff), on the"
            f" {len(settled)} instances of {args.settle_sizes} points whose verdict was open"
            f" ({args.settle:g} s limit): optimality proven on {len(proved)}"
            + (
                f" in {min(r['settle_seconds'] for r in proved):.0f}-"
                f"{max(r['settle_seconds'] for r in proved):.0f} s"
                if proved
                else ""
            )
            + "; the table and the goal count these proofs."
        )
    print("\n".join(table))
    print(goal)
    print(facts)
    if args.no_write:
        return
    command = "python benches/optimal.py " + " ".join(
        f"--{k.replace('_', '-')} {' '.join(map(str, v)) if isinstance(v, list) else v}"
        for k, v in vars(args).items()
        if v not in (None, False) and k not in ("no_write", "from_log")
    )
    text = "\n".join(
        [
            HEADER,
            "",
            "Exact tac_1 optimum over all triangulations of the convex hull"
            " (`scanmesh.optimal_surface`: HiGHS MILP over empty triangles, see"
            " `python/scanmesh/stages/optimal.py`), against LOP and annealing with default settings"
            " (`reconstruct(..., max_edge=math.inf)`, annealing seed = instance index).",
            "Gap = (tac_1(method) - tac_1(optimum)) / tac_1(optimum). Where HiGHS stopped at"
            " the time limit the optimum is bracketed: `a..b` runs from the best triangulation"
            " known (MILP incumbent, LOP or annealing) to HiGHS's lower bound. Time to prove is"
            " HiGHS's wall-clock solve time (set-up: empty triangles and matrix, under 0.1 s).",
            "",
            "```",
            command,
            "```",
            "",
            f"Machine: {machine()}; {len(rows)} instances, {elapsed / 60:.0f} min measured; time"
            f" limit {args.time_limit:g} s per MILP. Raw rows: `out/optimal.jsonl`."
            + (
                f" MILP columns (optimum, bound, time to prove) reused from `{args.reuse_milp}`"
                " (an earlier run, same instances); LOP and annealing measured in this run."
                if args.reuse_milp
                else ""
            ),
            "",
            *table,
            "",
            goal,
            facts,
        ]
    )
    write_section(text, TARGET)
    print(f"wrote {HEADER!r} in {TARGET.relative_to(ROOT)}")


if __name__ == "__main__":
    main()
