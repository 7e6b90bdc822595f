"""Strips on real geometry: depth jumps and crossing lines (issue 17, items 1 and 2).

    python benches/strips_geometry.py            # Markdown table on stdout

Each CAD part of ../shared/data/cad is scanned by the virtual digitizer from six directions
(about 8,000 points each, no noise) and fran_cut.vtk is read as it is; both strip methods
stitch every scan with the defaults (plane chosen by the data) and, as the strips were
before depth jumps and the repair, with ``jump_factor=inf, check=False``. Per mesh: faces,
triangles dropped at depth jumps and where lines cross, edges in more than two faces,
whether it is a valid planar triangulation (``_core.validate`` in its own plane), the
longest 3-D edge of any face over the median edge, and points in no face.
"""

from __future__ import annotations

import os
import warnings
from pathlib import Path

import numpy as np

import scanmesh
from scanmesh import _core
from scanmesh.readers import read_vtk
from scanmesh.strips import strip_surface

SHARED = Path(__file__).resolve().parents[2] / "shared" / "data"
CAD = SHARED / "cad"
PARTS = ("conrod_slevin48_onshape.stl", "octagonal_pocket.ply", "fandisk.obj", "turbineblade.ply")
VIEWS = (("z", "x"), ("-z", "x"), ("y", "x"), ("-y", "z"), ("x", "y"), ("-x", "z"))
N_POINTS = 8_000


def scans():
    for part in PARTS:
        for up, along in VIEWS:
            points, lines = scanmesh.simulate_scan(
                CAD / part, up=up, along=along, n_points=N_POINTS
            )
            yield f"{part.split('.')[0].split('_')[0]} up {up}", points, lines
    fran = read_vtk(SHARED / "scans" / "fran_cut.vtk")
    yield "fran_cut", fran.points, fran.line_ids


def row(surface: scanmesh.Surface) -> dict:
    faces = surface.faces
    edges = np.sort(faces[:, [0, 1, 1, 2, 2, 0]].reshape(-1, 2), axis=1)
    _, counts = np.unique(edges, axis=0, return_counts=True)
    lengths = np.linalg.norm(surface.vertices[edges[:, 0]] - surface.vertices[edges[:, 1]], axis=1)
    per_face = lengths.reshape(-1, 3).max(axis=1)
    try:
        _core.validate(surface.scan.uv, faces)
        valid = "yes"
    except scanmesh.ScanmeshError:
        valid = "no"
    o = surface.options
    return {
        "faces": len(faces),
        "jumps": o.get("dropped_jumps", 0),
        "overlaps": o.get("dropped_overlaps", 0),
        "non-manifold edges": int(np.count_nonzero(counts > 2)),
        "valid": valid,
        "longest / median edge": float(per_face.max() / np.median(lengths)),
        "unused": len(o["unused"]),
    }


def main() -> None:
    print(f"load average {os.getloadavg()[0]:.1f}\n")
    keys = ["faces", "jumps", "overlaps", "non-manifold edges", "valid", "longest / median edge"]
    keys.append("unused")
    print("| scan | method | strips | " + " | ".join(keys) + " |")
    print("|---" * (len(keys) + 3) + "|")
    for name, points, lines in scans():
        for method in ("shortest-path", "lookahead"):
            for label, options in (
                ("before", {"jump_factor": np.inf, "check": False}),
                ("now", {}),
            ):
                with warnings.catch_warnings():
                    warnings.simplefilter("ignore")
                    s = strip_surface(points, lines=lines, method=method, **options)
                r = row(s)
                cells = [f"{r[k]:.3g}" if isinstance(r[k], float) else str(r[k]) for k in keys]
                print(f"| {name} | {method} | {label} | " + " | ".join(cells) + " |", flush=True)


if __name__ == "__main__":
    main()
