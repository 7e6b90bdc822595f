"""Annealing quality: schedule study, guard on/off, and the paper's 3,000-sweep experiment.

    python benches/anneal_quality.py schedule   # choose defaults: rod and fandisk scans
    python benches/anneal_quality.py guard      # sliver guard on/off, with height error
    python benches/anneal_quality.py paper      # shortest path vs 3,000 sweeps on the rod

Prints Markdown tables (for docs/benchmarks/quality.md). Every run is seeded; times are wall
seconds on whatever machine runs it (the table says which).
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
    from scanmesh.demo import rod_truth

    rod, _ = scanmesh.load_rod()
    fandisk, _ = scanmesh.simulate_scan(FANDISK, up="y", along="x", n_points=17_000)
    import trimesh

    return {
        "rod (load_rod, 14,340 pts)": (rod, "y", rod_truth()),
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
            print(
                f"| {name} | {label} | {a.quality.tac_1 / base:.3f} | "
                f"{lop.quality.tac_1 / base:.3f} | {len(a.trace['energy'])} | {t:.1f} |",
                flush=True,
            )


def guard() -> None:
    from scanmesh.evaluate.truth import height_error

    print(f"machine: {machine()}\n")
    print("| scan | method | tac_1 | tac_1 / Delaunay | sliver share | h_rms | h_max | time (s) |")
    print("|---|---|---|---|---|---|---|---|")
    for name, (pts, plane, truth) in scans().items():
        rows = [
            ("delaunay", {}),
            ("lop", {}),
            ("anneal, guard on", {"seed": 1}),
            ("anneal, guard off", {"seed": 1, "sliver_guard": False}),
        ]
        base = None
        for label, opts in rows:
            method = label.split(",")[0]
            s, t = timed(pts, method, plane, **opts)
            q = s.quality
            base = base or q.tac_1
            h = height_error(s, truth)
            print(
                f"| {name} | {label} | {q.tac_1:.2f} | {q.tac_1 / base:.3f} | "
                f"{q.sliver_fraction:.3f} | {h['h_rms']:.3g} | {h['h_max']:.3g} | {t:.1f} |",
                flush=True,
            )


FIGURES = Path(__file__).resolve().parent / "figures"

#: The part of the rod shown with its edges, (x from, x to), (z from, z to) in inches: where
#: the shaft meets the small eye and the two flat levels meet in a step.
SEGMENT = ((0.35, 1.05), (-0.05, 0.55))


def _segment(surface, box=SEGMENT):
    """(vertices, faces) of the faces whose centroid lies in ``box`` (x and z ranges)."""
    (x0, x1), (z0, z1) = box
    c = surface.vertices[surface.faces].mean(axis=1)
    keep = (c[:, 0] > x0) & (c[:, 0] < x1) & (c[:, 2] > z0) & (c[:, 2] < z1)
    return surface.vertices, surface.faces[keep]


def paper(picture: Path | None, tiles: int) -> None:
    """The paper's experiment: shortest path against 3,000 sweeps of annealing on the rod.

    Weinert et al. (1997): 14,339 points, annealing with 3,000 iterations 156 min, shortest
    path 15 s. An "iteration" is read as a sweep (one proposal per interior edge), the
    reading that asks the most of us; the early stop is off so all 3,000 sweeps run. Run once
    as one sequential chain and once in ``tiles`` stripes on the cores (``tiles=``).
    Writes ``<picture>`` (both meshes shaded, side by side, like the paper's figures 1 and 2),
    ``<picture>_segment.png`` (a segment with its edges) and ``<picture>_trace.png``.
    """
    from scanmesh.demo import rod_truth
    from scanmesh.evaluate.truth import TrueSurface, height_error, normal_error
    from scanmesh.present.panels import render_compare
    from scanmesh.present.render import auto_view as _auto_view
    from scanmesh.present.render import plot_convergence

    pts, lines = scanmesh.load_rod()
    print(f"machine: {machine()}, load average {os.getloadavg()[0]:.1f} at the start\n")
    cpu = {}
    for key, method, opts in [
        ("sp", "shortest-path", {"lines": lines}),
        ("an", "anneal", {"sweeps": 3000, "patience": 0, "seed": 1}),
        ("at", "anneal", {"sweeps": 3000, "patience": 0, "seed": 1, "tiles": tiles}),
        ("d", "delaunay", {}),
    ]:
        c0 = time.process_time()
        cpu[key] = (*timed(pts, method, "y", **opts), time.process_time() - c0)
    (sp, t_sp, c_sp), (an, t_an, c_an), (d, t_d, c_d) = cpu["sp"], cpu["an"], cpu["d"]
    at, t_at, c_at = cpu["at"]
    truth = TrueSurface(rod_truth())
    print(
        "| method | wall (s) | CPU (s) | 1997 time | speed-up (wall) | tac_1 | tac_2 | tac_inf |"
        " min angle (°) | sliver share | h_rms | h_max | normal mean (°) |"
    )
    print("|---|---|---|---|---|---|---|---|---|---|---|---|---|")
    rows = [
        ("Delaunay (spade)", d, t_d, c_d, "-", None),
        ("shortest path", sp, t_sp, c_sp, "15 s", 15.0),
        ("annealing, 3,000 sweeps", an, t_an, c_an, "156 min", 156 * 60.0),
        (f"annealing, 3,000 sweeps, {tiles} tiles", at, t_at, c_at, "156 min", 156 * 60.0),
    ]
    titles = []
    for label, s, t, c, then, then_s in rows:
        q = s.quality
        h = height_error(s, truth)
        n = normal_error(s, truth)
        gain = f"{then_s / t:,.0f}x" if then_s else "-"
        print(
            f"| {label} | {t:.2f} | {c:.2f} | {then} | {gain} | {q.tac_1:.2f} | {q.tac_2:.3f} |"
            f" {q.tac_inf:.3f} | {q.min_angle_deg:.2f} | {100 * q.sliver_fraction:.2f} % |"
            f" {h['h_rms']:.3g} | {h['h_max']:.3g} | {n['n_mean_deg']:.2f} |",
            flush=True,
        )
        titles.append(
            f"{label}: {t:.1f} s (1997: {then})\ntac_1 {q.tac_1:.1f}, RMS {h['h_rms']:.2g} in"
        )
    sweeps = len(an.trace["energy"])
    print(f"\nannealing ran {sweeps:,} sweeps; load average {os.getloadavg()[0]:.1f} at the end")
    if picture:
        picture.parent.mkdir(parents=True, exist_ok=True)
        view = _auto_view(d.vertices, d.faces, d.frame)
        render_compare([sp, an], picture, titles=titles[1:3], size=(640, 420), **view)
        segment = picture.with_name(picture.stem + "_segment.png")
        render_compare(
            [_segment(sp), _segment(an)],
            segment,
            titles=["shortest path (segment, edges drawn)", "annealing, 3,000 sweeps (segment)"],
            size=(640, 420),
            wire=True,
            **view,
        )
        trace = picture.with_name(picture.stem + "_trace.png")
        plot_convergence(an.trace, trace, title="annealing the rod: 3,000 sweeps")
        for path in (picture, segment, trace):
            print(f"wrote {path} ({path.stat().st_size / 1024:.0f} KB)")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("study", choices=["schedule", "guard", "paper"])
    parser.add_argument(
        "--tiles", type=int, default=8, help="paper: stripes of the tiled run (default 8)"
    )
    parser.add_argument(
        "--picture",
        type=Path,
        default=FIGURES / "paper_rod.png",
        help="paper: PNG to write (default benches/figures/paper_rod.png)",
    )
    args = parser.parse_args()
    if args.study == "paper":
        paper(args.picture, args.tiles)
    else:
        {"schedule": schedule, "guard": guard}[args.study]()


if __name__ == "__main__":
    main()
