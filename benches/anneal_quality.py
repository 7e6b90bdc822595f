"""Annealing quality: schedule study, guard on/off, and the paper's 3,000-sweep experiment.

    python benches/anneal_quality.py schedule   # choose defaults: rod and fandisk scans
    python benches/anneal_quality.py guard      # sliver guard on/off, with height error
    python benches/anneal_quality.py paper      # shortest path vs 3,000 sweeps on the rod

Prints Markdown tables (for BENCHMARKS.md). Every run is seeded; times are wall seconds on
whatever machine runs it (the table says which).
"""

from __future__ import annotations

import argparse
import os
import platform
import time
from pathlib import Path

import numpy as np

import scanmesh

SHARED = Path(__file__).resolve().parents[2] / "shared" / "data"
FANDISK = SHARED / "cad" / "fandisk.obj"


def machine() -> str:
    return f"{platform.machine()}, {os.cpu_count()} cores, Python {platform.python_version()}"


def scans() -> dict[str, tuple[np.ndarray, str, object]]:
    """name -> (points, plane, truth mesh)."""
    from scanmesh.demo import demo_truth

    rod, _ = scanmesh.load_demo()
    fandisk, _ = scanmesh.simulate_scan(FANDISK, up="y", along="x", n_points=17_000)
    import trimesh

    return {
        "rod (demo, 14,340 pts)": (rod, "y", demo_truth()),
        f"fandisk ({len(fandisk):,} pts)": (fandisk, "y", trimesh.load(FANDISK, force="mesh")),
    }


def timed(points, method, plane, **options):
    t0 = time.perf_counter()
    s = scanmesh.reconstruct(points, method, plane=plane, **options)
    return s, time.perf_counter() - t0


def schedule() -> None:
    variants = [
        ("default", {}),
        ("T0 at 10% acceptance", {"initial_acceptance": 0.1}),
        ("T0 at 60% acceptance", {"initial_acceptance": 0.6}),
        ("final T ratio 1e-2", {"final_temperature_ratio": 1e-2}),
        ("final T ratio 1e-6", {"final_temperature_ratio": 1e-6}),
        ("300 sweeps", {"sweeps": 300}),
        ("no early stop", {"patience": 0}),
    ]
    print(f"machine: {machine()}\n")
    print("| scan | setting | tac_1 / Delaunay | LOP / Delaunay | sweeps run | time (s) |")
    print("|---|---|---|---|---|---|")
    for name, (pts, plane, _) in scans().items():
        d, _ = timed(pts, "delaunay", plane)
        lop, _ = timed(pts, "lop", plane)
        base = d.quality.tac_1
        for label, opts in variants:
            a, t = timed(pts, "anneal", plane, seed=1, **opts)
            print(f"| {name} | {label} | {a.quality.tac_1 / base:.3f} | "
                  f"{lop.quality.tac_1 / base:.3f} | {len(a.trace['energy'])} | {t:.1f} |",
                  flush=True)


def guard() -> None:
    from scanmesh.truth import height_error

    print(f"machine: {machine()}\n")
    print("| scan | method | tac_1 | tac_1 / Delaunay | sliver share | h_rms | h_max | time (s) |")
    print("|---|---|---|---|---|---|---|---|")
    for name, (pts, plane, truth) in scans().items():
        rows = [("delaunay", {}), ("lop", {}), ("anneal, guard on", {"seed": 1}),
                ("anneal, guard off", {"seed": 1, "sliver_guard": False})]
        base = None
        for label, opts in rows:
            method = label.split(",")[0]
            s, t = timed(pts, method, plane, **opts)
            q = s.quality
            base = base or q.tac_1
            h = height_error(s, truth)
            print(f"| {name} | {label} | {q.tac_1:.2f} | {q.tac_1 / base:.3f} | "
                  f"{q.sliver_fraction:.3f} | {h['h_rms']:.3g} | {h['h_max']:.3g} | {t:.1f} |",
                  flush=True)


def paper(picture: Path | None) -> None:
    from scanmesh.render import plot_convergence, render_compare

    pts, _ = scanmesh.load_demo()
    print(f"machine: {machine()}\n")
    sp, t_sp = timed(scanmesh.load_demo()[0], "shortest-path", "y",
                     lines=scanmesh.load_demo()[1])
    an, t_an = timed(pts, "anneal", "y", sweeps=3000, patience=0, seed=1)
    d, t_d = timed(pts, "delaunay", "y")
    print("| method | time (s) | 1997 time | tac_1 | tac_2 | tac_inf | sliver share |")
    print("|---|---|---|---|---|---|---|")
    for label, s, t, then in [("Delaunay", d, t_d, "-"), ("shortest path", sp, t_sp, "15 s"),
                              ("annealing, 3,000 sweeps", an, t_an, "156 min")]:
        q = s.quality
        print(f"| {label} | {t:.1f} | {then} | {q.tac_1:.2f} | {q.tac_2:.3f} | {q.tac_inf:.3f} | "
              f"{q.sliver_fraction:.3f} |")
    print(f"\nannealing speed-up over 1997: {156 * 60 / t_an:,.0f}x")
    if picture:
        render_compare([sp, an], picture, titles=["shortest path", "annealing, 3,000 sweeps"],
                       up="y")
        plot_convergence(an.trace, picture.with_name(picture.stem + "_trace.png"),
                         title="annealing the rod: 3,000 sweeps")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("study", choices=["schedule", "guard", "paper"])
    parser.add_argument("--picture", type=Path, default=None, help="paper: PNG to write")
    args = parser.parse_args()
    {"schedule": schedule, "guard": guard}.get(args.study, lambda: paper(args.picture))()


if __name__ == "__main__":
    main()
