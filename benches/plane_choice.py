"""The plane chosen by the data: steep share per part and axis.

Every CAD part in ../shared/data/cad/ (or the folder given) is scanned with
``scanmesh.simulate_scan`` along each of +-x, +-y, +-z at 1/100 of its larger extent across
the scanning direction (simulate_scan's default spacing), then
reconstructed with ``reconstruct(..., "delaunay")`` and the default plane: from the array
(candidates: least-squares plane, x, y, z, principal axes) and from an XYZ file written
with its ``up`` comment and read back (the recorded up is a candidate too). The table
gives the steep share over the chosen plane, the choice, and the steep share over the old
default (the least-squares plane). Goal: under 10 % everywhere.

    .venv/bin/python benches/plane_choice.py [CAD_FOLDER]
"""

from __future__ import annotations

import argparse
import tempfile
import time
import warnings
from pathlib import Path

import numpy as np
import trimesh

import scanmesh
from scanmesh.formats.write import write_points
from scanmesh.scan.axes import parse_axis

#: ../shared/data/cad beside the repository (as the other benches find the shared data)
SHARED_CAD = Path(__file__).resolve().parents[2] / "shared" / "data" / "cad"

UPS = ("+x", "-x", "+y", "-y", "+z", "-z")


def run(source, **kw) -> tuple[float, float, str, float]:
    """(steep share, share of points in no triangle, the choice, seconds) of a default
    Delaunay reconstruct."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        t0 = time.perf_counter()
        surface = scanmesh.reconstruct(source, "delaunay", **kw)
        seconds = time.perf_counter() - t0
    used = np.zeros(len(surface.vertices), dtype=bool)
    used[surface.faces.ravel()] = True
    choice = surface.options.get("plane_choice")
    label = "given" if choice is None else choice["chosen"]
    return float(surface.steep_fraction), 1.0 - float(used.mean()), label, seconds


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("folder", nargs="?", type=Path, default=SHARED_CAD)
    args = parser.parse_args()
    parts = sorted(p for p in Path(args.folder).iterdir() if p.suffix in (".stl", ".ply", ".obj"))
    print(
        "| part | up | points | steep (array) | chosen (array) | steep (file) | chosen (file)"
        " | steep (unused) best-fit, old | choice s (array) | delaunay s (chosen) |"
    )
    print("|---|---|---:|---:|---|---:|---|---:|---:|---:|")
    worst = 0.0
    with tempfile.TemporaryDirectory() as tmp:
        for part in parts:
            mesh = trimesh.load(part, force="mesh")
            for up in UPS:
                along = "y" if up.endswith("x") else "x"
                pts, ids = scanmesh.simulate_scan(mesh, up=up, along=along)
                t0 = time.perf_counter()
                scan = scanmesh.planar_scan(pts)
                t_choice = time.perf_counter() - t0
                steep, _, chosen, t_all = run(scan)
                path = write_points(Path(tmp) / "scan.xyz", pts, ids, up=parse_axis(up, "up"))
                steep_file, _, chosen_file, _ = run(path)
                old, old_unused, _, _ = run(pts, plane="best-fit")
                worst = max(worst, steep, steep_file)
                print(
                    f"| {part.stem} | {up} | {len(pts):,} | {100 * steep:.1f} % | {chosen} |"
                    f" {100 * steep_file:.1f} % | {chosen_file} | {100 * old:.1f} %"
                    f" ({100 * old_unused:.0f} %) | {t_choice:.2f} | {t_all:.2f} |",
                    flush=True,
                )
    print(f"\nworst steep share with the default plane: {100 * worst:.1f} %")


if __name__ == "__main__":
    main()
