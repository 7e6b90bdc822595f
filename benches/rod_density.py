"""How annealing's tac_1 against Delaunay's depends on the density of the connecting-rod scan.

    python benches/rod_density.py                              # 7k, 10.5k, 14k and 20k points
    python benches/rod_density.py --points 10500 --seeds 0 1 2

The rod (``../shared/data/cad/conrod_slevin48_onshape.stl``) is scanned by the virtual
digitizer like the embedded rod scan (``simulate_scan(up="y", along="x", n_points=...)``, no
noise; 14,339 gives ``load_rod()`` itself) and triangulated in the y plane by spade Delaunay
(trimmed at 5 x median spacing), ``scipy.spatial.Delaunay`` trimmed by the same code (grid
scans are full of cocircular quadruples, and the Delaunay tie-break changes the denominator
of every ratio), LOP, shortest path, default annealing (one row per seed) and annealing from
the strips (``initial="shortest-path"``). Per mesh: tac_1, tac_1 against both Delaunays,
height RMS against spade Delaunay's (closest-point distance of 100,000 area samples to the
CAD mesh, ``truth.height_error``), sliver share, and tac_1 restricted to the vertices that
are interior in every mesh of the same scan ("common"), against spade Delaunay's on that
set. The trimmed Delaunay domain (and so annealing's, which flips inside it) closes the fans
of a few vertices where the shaft's sides meet the eyes (triangles across the air in those
re-entrant corners, shorter than the trimming length); strips leave them on the boundary. On
the common set every mesh is scored over the same vertices.
"""

from __future__ import annotations

import argparse
import time
from pathlib import Path

import numpy as np

# benches/quality.py: the trimmed scipy baseline, same code as the CAD table
from quality import machine, scipy_delaunay

import scanmesh
from scanmesh.evaluate.truth import TrueSurface, height_error

CAD = Path(__file__).resolve().parents[2] / "shared" / "data" / "cad"
ROD = CAD / "conrod_slevin48_onshape.stl"
SIZES = (7_000, 10_500, 14_339, 20_000)
N_SAMPLES = 100_000


def measure(points, lines, n_points: int, seeds, truth: TrueSurface) -> list[dict]:
    runs = [("spade Delaunay", "delaunay", {}), ("scipy Delaunay", "scipy", {})]
    runs += [("LOP", "lop", {}), ("shortest path", "shortest-path", {})]
    runs += [(f"anneal, seed {s}", "anneal", {"seed": s}) for s in seeds]
    runs += [
        (
            f"anneal from strips, seed {seeds[0]}",
            "anneal",
            {"seed": seeds[0], "initial": "shortest-path"},
        )
    ]
    rows, tacs = [], []
    for label, method, options in runs:
        t0 = time.perf_counter()
        if method == "scipy":
            surface = scipy_delaunay(points, "y")
        else:
            scan = scanmesh.planar_scan(points, plane="y", lines=lines)  # lines travel with it
            surface = scanmesh.reconstruct(scan, method, **options)
        elapsed = time.perf_counter() - t0
        q = surface.quality
        tac = np.nan_to_num(q.tac)
        tacs.append(q.tac)
        h = height_error(surface, truth, n_samples=N_SAMPLES, seed=0)
        rows.append(
            {
                "n_points": n_points,
                "points": len(points),
                "lines": int(lines.max()) + 1,
                "method": label,
                "time_s": elapsed,
                "tac_1": q.tac_1,
                "slivers": q.sliver_fraction,
                "h_rms": h["h_rms"],
                "tac_vertices": int((tac > 1e-9).sum()),
            }
        )
    common = np.logical_and.reduce([~np.isnan(t) for t in tacs])
    for r, t in zip(rows, tacs, strict=True):
        r["tac_common"] = float(np.nan_to_num(t)[common].sum())
        r["n_common"] = int(common.sum())
    spade, scipy_ = rows[0], rows[1]
    for r in rows:
        r["common_vs_spade"] = r["tac_common"] / spade["tac_common"]
        r["vs_spade"] = r["tac_1"] / spade["tac_1"]
        r["vs_scipy"] = r["tac_1"] / scipy_["tac_1"]
        r["h_vs_spade"] = r["h_rms"] / spade["h_rms"]
    return rows


def print_rows(rows: list[dict]) -> None:
    for r in rows:
        print(
            f"| {r['points']:,} ({r['lines']}; {r['n_common']:,}) | {r['method']} |"
            f" {r['tac_1']:.2f} |"
            f" {r['vs_spade']:.3f} | {r['vs_scipy']:.3f} | {r['h_rms']:.3g} |"
            f" {r['tac_common']:.2f} | {r['common_vs_spade']:.3f} |"
            f" {r['h_vs_spade']:.3f} | {100 * r['slivers']:.2f} % | {r['tac_vertices']} |"
            f" {r['time_s']:.2f} |",
            flush=True,
        )


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--points", type=int, nargs="+", default=list(SIZES))
    parser.add_argument("--seeds", type=int, nargs="+", default=[0, 1, 2])
    args = parser.parse_args()
    truth = TrueSurface(ROD)
    print(f"machine: {machine()}\n")
    print(
        "| points (lines; common interior) | method | tac_1 | / spade Del. | / scipy Del. |"
        " h_rms (in) |"
        " tac_1 common | / spade Del. common | h_rms / spade Del. | slivers |"
        " vertices with tac | time (s) |"
    )
    print("|---|---|---|---|---|---|---|---|---|---|---|---|")
    for n in args.points:
        points, lines = scanmesh.simulate_scan(ROD, up="y", along="x", n_points=n)
        print_rows(measure(points, lines, n, args.seeds, truth))
    print(f"\nmachine after the run: {machine()}")


if __name__ == "__main__":
    main()
