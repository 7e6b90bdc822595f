"""Real geometry: depth jumps, gaps and crossing lines.

    python benches/strips_geometry.py                      # Markdown table on stdout
    python benches/strips_geometry.py --json rows.json     # and the rows as JSON

Each CAD part of ../shared/data/cad is scanned by the virtual digitizer from six directions
(about 8,000 points each, no noise) and fran_cut.vtk is read as it is; both strip methods
stitch every scan with the defaults (plane chosen by the data) and, as the strips were
before depth jumps and the repair, with ``jump_factor=inf, check=False``; Delaunay and
annealing (seed 0) run with the defaults. Per mesh: faces, triangles dropped at depth jumps
and gaps and where lines cross (strips), edges in more than two faces, whether it is a
valid planar triangulation (``_core.validate`` in its own plane), the longest 3-D edge of
any face over the median edge, how many faces exceed 8 x the median edge ("long") and how
many of those are off the CAD surface (centroid farther than half a median edge from it:
bridges, not sparsely sampled real surface), the 3-D area, the missed shadow (% of the
part's shadow along the mesh's plane, ``truth.domain_error`` with 250,000 rays; "now" rows
of CAD parts only) and points in no face. The goal counts meshes that are
manifold with "longest / median edge" at most 8.
"""

from __future__ import annotations

import argparse
import json
import os
import warnings
from pathlib import Path

import numpy as np

import scanmesh
from scanmesh import _core
from scanmesh.evaluate.truth import TrueSurface, domain_error
from scanmesh.formats import read_vtk
from scanmesh.stages.strips import strip_surface

SHARED = Path(__file__).resolve().parents[2] / "shared" / "data"
CAD = SHARED / "cad"
PARTS = ("conrod_slevin48_onshape.stl", "octagonal_pocket.ply", "fandisk.obj", "turbineblade.ply")
VIEWS = (("z", "x"), ("-z", "x"), ("y", "x"), ("-y", "z"), ("x", "y"), ("-x", "z"))
N_POINTS = 8_000
#: The goal: no face's longest 3-D edge above this many median edges.
LONG = 8.0
#: A long face whose centroid is farther than this many median edges from the CAD surface
#: bridges air.
OFF_TRUTH = 0.5
DOMAIN_RAYS = 250_000


def scans():
    """(name, points, line ids, CAD path or None) of every scan."""
    for part in PARTS:
        for up, along in VIEWS:
            points, lines = scanmesh.simulate_scan(
                CAD / part, up=up, along=along, n_points=N_POINTS
            )
            yield f"{part.split('.')[0].split('_')[0]} up {up}", points, lines, CAD / part
    fran = read_vtk(SHARED / "scans" / "fran_cut.vtk")
    yield "fran_cut", fran.points, fran.line_ids, None


def row(surface: scanmesh.Surface, truth: TrueSurface | None, shadow: bool) -> dict:
    faces, points = surface.faces, surface.vertices
    edges = np.sort(faces[:, [0, 1, 1, 2, 2, 0]].reshape(-1, 2), axis=1)
    _, counts = np.unique(edges, axis=0, return_counts=True)
    lengths = np.linalg.norm(points[edges[:, 0]] - points[edges[:, 1]], axis=1)
    per_face = lengths.reshape(-1, 3).max(axis=1)
    median = float(np.median(lengths))
    long = np.flatnonzero(per_face > LONG * median)
    off = "-"
    if truth is not None:
        centroids = points[faces[long]].mean(axis=1)
        off = int(np.count_nonzero(truth.distance(centroids) > OFF_TRUTH * median))
    corners = points[faces]
    area = 0.5 * np.linalg.norm(
        np.cross(corners[:, 1] - corners[:, 0], corners[:, 2] - corners[:, 0]), axis=1
    )
    missed: str | float = "-"
    if truth is not None and shadow:
        missed = 100 * domain_error(surface, truth, n_rays=DOMAIN_RAYS)["missed_share"]
    try:
        _core.validate(surface.scan.uv, faces)
        valid = "yes"
    except scanmesh.ScanmeshError:
        valid = "no"
    o = surface.options
    return {
        "faces": len(faces),
        "jumps": o.get("dropped_jumps", "-"),
        "overlaps": o.get("dropped_overlaps", "-"),
        "non-manifold edges": int(np.count_nonzero(counts > 2)),
        "valid": valid,
        "longest / median edge": float(per_face.max() / median),
        "long": len(long),
        "long off truth": off,
        "area": float(area.sum()),
        "missed %": missed,
        "unused": len(o.get("unused", o.get("trimmed", []))),
    }


RUNS = (
    ("shortest-path", "before", {"jump_factor": np.inf, "check": False}),
    ("shortest-path", "now", {}),
    ("lookahead", "before", {"jump_factor": np.inf, "check": False}),
    ("lookahead", "now", {}),
    ("delaunay", "now", {}),
    ("anneal", "now", {"seed": 0}),
)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--json", type=str, help="also write the rows to this JSON file")
    args = ap.parse_args()
    print(f"load average {os.getloadavg()[0]:.1f}\n")
    keys = ["faces", "jumps", "overlaps", "non-manifold edges", "valid", "longest / median edge"]
    keys += ["long", "long off truth", "area", "missed %", "unused"]
    print("| scan | method | run | " + " | ".join(keys) + " |")
    print("|---" * (len(keys) + 3) + "|")
    rows = []
    truths: dict[str, TrueSurface] = {}
    for name, points, lines, cad in scans():
        truth = None
        if cad is not None:
            truth = truths.setdefault(str(cad), TrueSurface(cad))
        for method, label, options in RUNS:
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")
                if method in ("shortest-path", "lookahead"):
                    s = strip_surface(points, lines=lines, method=method, **options)
                else:
                    s = scanmesh.reconstruct(points, method, **options)
            r = row(s, truth, shadow=label == "now")
            rows.append({"scan": name, "method": method, "run": label, **r})
            cells = [f"{r[k]:.3g}" if isinstance(r[k], float) else str(r[k]) for k in keys]
            print(f"| {name} | {method} | {label} | " + " | ".join(cells) + " |", flush=True)
    print()
    for method in dict.fromkeys(m for m, _, _ in RUNS):
        now = [r for r in rows if r["method"] == method and r["run"] == "now"]
        met = [r for r in now if r["non-manifold edges"] == 0]
        short = sum(r["longest / median edge"] <= LONG for r in met)
        no_bridge = sum(r["long"] == 0 or r["long off truth"] == 0 for r in met)
        print(
            f"{method}: {len(met)} of {len(now)} manifold; longest edge <= {LONG:g} x median"
            f" on {short}; no long face off the truth on {no_bridge}"
        )
    print(f"load average {os.getloadavg()[0]:.1f}")
    if args.json:
        with open(args.json, "w") as out:
            json.dump(rows, out, indent=1)


if __name__ == "__main__":
    main()
