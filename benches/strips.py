"""Strip reconstruction: quality of every weight, and time against Delaunay, in one run.

    python benches/strips.py [--sizes 10000 100000 1000000] [--repeat 3]

Prints Markdown tables:

1. quality: tac_1, tac_inf, smallest 3-D angle and sliver share of every weight, by
   shortest path and by alpha-look-ahead (alpha = 3), on fran_cut (45 x 49 real profiles),
   the embedded connecting-rod scan (14,340 points) and Sainte Helens (148,885 points), with
   Delaunay for reference;
2. time: ``strip_surface`` (default weight, banded shortest path, planar check) against
   ``scanmesh.delaunay`` (spade plus trimming) on the same simulated rod scans of about 10k,
   100k and 1M points, and the cores alone (``_core.strip_mesh`` with and without the
   check, ``_core.delaunay``), best of ``--repeat`` runs.
"""

from __future__ import annotations

import argparse
import os
import platform
import time
import warnings
from collections.abc import Callable
from pathlib import Path

import scanmesh
import scanmesh.stages.strips
from scanmesh import _core
from scanmesh.formats import read_dem, read_vtk
from scanmesh.stages.strips import CRITERIA, DEFAULT_WEIGHT, weight_coefficients

DATA = Path(__file__).resolve().parents[1].parent / "shared" / "data"
ROD = DATA / "cad" / "conrod_slevin48_onshape.stl"


def best_time(run: Callable[[], object], repeat: int) -> tuple[float, object]:
    """Smallest wall time of ``repeat`` runs (seconds) and the last result."""
    times, result = [], None
    for _ in range(repeat):
        t = time.perf_counter()
        result = run()
        times.append(time.perf_counter() - t)
    return min(times), result


def quality_table(repeat: int) -> None:
    fran = read_vtk(DATA / "scans" / "fran_cut.vtk")
    dem = read_dem(DATA / "terrain" / "SainteHelens.dem")
    rod = scanmesh.load_rod()
    scans = {
        "fran_cut": (fran.points, fran.line_ids, None),
        "rod (load_rod)": (rod[0], rod[1], "y"),
        "Sainte Helens": (dem.points, dem.line_ids, None),
    }
    weights: list[str | dict[str, float]] = [*CRITERIA, DEFAULT_WEIGHT]
    print("| scan | method | weight | tac_1 | tac_inf | min angle (deg) | slivers < 5 deg | s |")
    print("|---|---|---|---:|---:|---:|---:|---:|")
    for name, (points, line_ids, plane) in scans.items():
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            seconds, d = best_time(
                lambda p=points, pl=plane: scanmesh.delaunay(p, plane=pl), repeat
            )
        q = d.quality
        print(
            f"| {name} | delaunay | - | {q.tac_1:.2f} | {q.tac_inf:.3f} | {q.min_angle_deg:.2f} |"
            f" {100 * q.sliver_fraction:.2f} % | {seconds:.3f} |"
        )
        for method in ("shortest-path", "lookahead"):
            for weight in weights:
                with warnings.catch_warnings():
                    warnings.simplefilter("ignore")  # fran_cut folds in every plane

                    def run(p=points, ids=line_ids, pl=plane, m=method, w=weight):
                        return scanmesh.stages.strips.strip_surface(
                            p, lines=ids, plane=pl, method=m, weight=w, alpha=3
                        )

                    seconds, s = best_time(run, repeat)
                q = s.quality
                label = weight if isinstance(weight, str) else "default " + str(weight)
                shown = "shortest path" if method == "shortest-path" else "look-ahead a=3"
                print(
                    f"| {name} | {shown} | {label} | {q.tac_1:.2f} | {q.tac_inf:.3f} |"
                    f" {q.min_angle_deg:.2f} | {100 * q.sliver_fraction:.2f} % | {seconds:.3f} |"
                )


def time_table(sizes: list[int], repeat: int) -> None:
    weight = dict(zip(CRITERIA, weight_coefficients(DEFAULT_WEIGHT), strict=True))
    print("| points | lines | strip_surface | scanmesh.delaunay | ratio |", end="")
    print(" core strips (check) | core strips (no check) | core delaunay | core ratio |")
    print("|---:|---:|---:|---:|---:|---:|---:|---:|---:|")
    for n in sizes:
        points, line_ids = scanmesh.simulate_scan(ROD, up="y", along="x", n_points=n)
        r = 1 if n >= 500_000 else repeat
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            t_strips, s = best_time(
                lambda p=points, ids=line_ids: scanmesh.stages.strips.strip_surface(
                    p, lines=ids, plane="y"
                ),
                r,
            )
            t_delaunay, _ = best_time(lambda p=points: scanmesh.delaunay(p, plane="y"), r)
        assert s.options["planar_valid"] and len(s.options["unused"]) == 0
        uv, _ = scanmesh.project(points, "y")

        def core(check: bool, p=points, uv=uv, ids=line_ids):
            params = _core.StripParams("shortest-path", weight=weight, check=check)
            return _core.strip_mesh(p, uv, ids, params, 4.0)

        c_checked, _ = best_time(lambda: core(True), r)
        c_bare, _ = best_time(lambda: core(False), r)
        c_delaunay, _ = best_time(lambda uv=uv: _core.delaunay(uv), r)
        print(
            f"| {len(points):,} | {s.options['n_lines']} | {t_strips:.3f} s | {t_delaunay:.3f} s |"
            f" {t_strips / t_delaunay:.2f} | {c_checked:.3f} s | {c_bare:.3f} s |"
            f" {c_delaunay:.3f} s | {c_bare / c_delaunay:.2f} |"
        )


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--sizes", type=int, nargs="*", default=[10_000, 100_000, 1_000_000])
    parser.add_argument("--repeat", type=int, default=3)
    parser.add_argument("--skip-quality", action="store_true")
    args = parser.parse_args()
    print(
        f"machine: {platform.machine()}, {os.cpu_count()} cores, {platform.python_version()},"
        f" load average {os.getloadavg()[0]:.1f} at start"
    )
    if not args.skip_quality:
        quality_table(args.repeat)
        print()
    time_table(args.sizes, args.repeat)
    print(f"load average {os.getloadavg()[0]:.1f} at the end")


if __name__ == "__main__":
    main()
