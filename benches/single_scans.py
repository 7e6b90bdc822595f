"""Single real range scans: curtains and the silhouette fringe on the 45 Stanford scans.

    nice python benches/single_scans.py                          # all 45, the default
    nice python benches/single_scans.py --methods auto grid lop anneal
    nice python benches/single_scans.py --truth                  # + the fringe against the truth
    nice python benches/single_scans.py --without-up             # as read before up = +z
    nice python benches/single_scans.py --picture happySideRight_120 benches/figures/x.png

Every ``.ply`` / ``.ply.gz`` range grid under ``../shared/data/multiview`` (the dragon's stand
and side series and the happy Buddha, 15 Cyberware 3030MS scans each, in their scanner's
frame) is meshed by ``scanmesh.reconstruct(path, method)`` with defaults. Per mesh, against
the scanner's line of sight (+z of the range image, what the reader records as ``up``) and,
for comparison, against the normal of the plane the points were projected on:

- ``long curtains``: the issue's curtains, faces within 5 degrees of the sight whose longest
  edge exceeds 4 x the mesh's median edge;
- ``curtains``: faces within 5 degrees of the sight at any length (the report's count);
- ``fringe %``: the share of the mesh's area within 10 degrees of the sight (the silhouette
  fringe: surface the scanner saw edge-on);
- ``rim fringe %``, ``spike fringe %``, ``fringe inside %``: the share of the faces on the
  mesh's outline in the fringe, of the spikes (faces with two boundary edges, the sawteeth
  of a ragged outline) in it, and of the fringe's faces off the outline;
- ``others fringe`` / ``others rest``: the median distance (in the scan's spacing s) from the
  centroids of the fringe faces / of the other faces to the nearest point of the other scans
  of the same object (the 14 or 29 others, posed by their ``.conf``), which see most of that
  surface face-on: a fringe hanging off the surface stands farther from them than the rest;
- ``far fringe %`` / ``far rest %``: the share of those faces more than 3 s from every other
  scan's point;
- ``holdout fringe`` / ``holdout rest``: RMS distance (in s) from 10 % of the scan's points,
  withheld by a seeded draw, to the plane of the nearest face (by centroid) of the mesh of
  the rest, split by that face's class.
"""

from __future__ import annotations

import argparse
import dataclasses
import math
import time
import warnings
from pathlib import Path

import numpy as np
from quality import SHARED, machine
from scipy.spatial import cKDTree

import scanmesh

DATA = SHARED / "multiview"
CURTAIN_DEG = 5.0
FRINGE_DEG = 10.0
LONG_FACTOR = 4.0
HOLDOUT = 0.1
SEED = 0
#: the picture's direction from the part to the eye (scanner frame): oblique to the rays
VIEW = (1.0, 0.3, 0.4)


def scans(folder: Path, names: list[str] | None) -> list[Path]:
    """The range-grid PLYs under ``folder``, by name (without .ply/.ply.gz) if given."""
    found = sorted([*folder.rglob("*.ply"), *folder.rglob("*.ply.gz")])
    if names:
        found = [p for p in found if p.name.split(".")[0] in names]
    return found


def within(vertices: np.ndarray, faces: np.ndarray, sight: np.ndarray, deg: float):
    """(M,) bool faces within ``deg`` of the line ``sight``, and (M,) face areas."""
    tri = vertices[faces]
    normal = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
    twice = np.linalg.norm(normal, axis=1)
    unit = sight / np.linalg.norm(sight)
    near = (np.abs(normal @ unit) <= math.sin(math.radians(deg)) * twice) & (twice > 0)
    return near, 0.5 * twice


def long_curtains(vertices: np.ndarray, faces: np.ndarray, sight: np.ndarray) -> np.ndarray:
    """(M,) bool: within CURTAIN_DEG of ``sight``, longest edge over LONG_FACTOR x median."""
    tri = vertices[faces]
    edges = np.linalg.norm(tri - np.roll(tri, 1, axis=1), axis=2)
    near, _ = within(vertices, faces, sight, CURTAIN_DEG)
    return near & (edges.max(axis=1) > LONG_FACTOR * np.median(edges))


def posed(folder: Path) -> dict[str, tuple[np.ndarray, np.ndarray]]:
    """Scan name -> (its points in the world, its (4, 4) pose), from every ``.conf``."""
    out = {}
    for conf in sorted(folder.rglob("*.conf")):
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            views = scanmesh.read_conf(conf)
        for view in views:
            out[Path(str(view.source)).name.split(".")[0]] = (view.world, view.pose)
    return out


def others_tree(world: dict, name: str) -> cKDTree | None:
    """KD-tree of the world points of the other scans of ``name``'s object (the dragon's two
    series are one object in one frame)."""
    kin = [k for k in world if k != name and k[:5] == name[:5]]
    return cKDTree(np.concatenate([world[k][0] for k in kin])) if kin else None


def fringe_faces(vertices: np.ndarray, faces: np.ndarray, sight: np.ndarray) -> np.ndarray:
    """(M,) bool faces within FRINGE_DEG of the sight."""
    return within(vertices, faces, sight, FRINGE_DEG)[0]


def holdout(sp, sight: np.ndarray, method: str, s: float) -> tuple[float, float]:
    """RMS distance (in ``s``) from HOLDOUT of the scan ``sp``'s points to the plane of the
    nearest face (by centroid) of the mesh of the rest (a range grid with their cells
    emptied), on the fringe faces and on the others."""
    points = sp.points
    out = np.random.default_rng(SEED).random(len(points)) < HOLDOUT
    index = np.full(len(points) + 1, -1, dtype=np.int64)  # index[-1]: an empty cell stays -1
    index[np.flatnonzero(~out)] = np.arange(int((~out).sum()))
    rest = scanmesh.ScanPoints(
        points=points[~out],
        line_ids=sp.line_ids[~out],
        source="holdout",
        grid=index[sp.grid],
        up=sp.up,
    )
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        mesh = scanmesh.reconstruct(rest, method)
    tri = mesh.vertices[mesh.faces]
    _, nearest = cKDTree(tri.mean(axis=1)).query(points[out])
    normal = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
    normal /= np.maximum(np.linalg.norm(normal, axis=1), 1e-300)[:, None]
    gap = np.einsum("ij,ij->i", points[out] - tri[nearest, 0], normal[nearest]) / s
    edge_on = fringe_faces(mesh.vertices, mesh.faces, sight)[nearest]
    rms = [np.sqrt(np.mean(gap[m] ** 2)) if m.any() else math.nan for m in (edge_on, ~edge_on)]
    return float(rms[0]), float(rms[1])


def read(path: Path, without_up: bool):
    """The scan at ``path``, its recorded ``up`` dropped if ``without_up``."""
    sp = scanmesh.read(path)
    return dataclasses.replace(sp, up=None) if without_up else sp


def picture(path: Path, out: Path, radius: float = 0.012) -> None:
    """Side by side: the default mesh of ``path`` without and with its recorded ``up``, the
    faces within ``radius`` (metres) of its long curtains without it, seen obliquely."""
    from scanmesh.present.render import png_bytes, shade_mesh

    sight, centre, images = np.array([0.0, 0.0, 1.0]), None, []
    for without_up in (True, False):
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            surface = scanmesh.reconstruct(read(path, without_up))
        v, f = surface.vertices, surface.faces
        hanging = long_curtains(v, f, sight)
        centroids = v[f].mean(axis=1)
        if centre is None:
            centre = np.median(centroids[hanging], axis=0) if hanging.any() else v.mean(axis=0)
        near = np.linalg.norm(centroids - centre, axis=1) < radius
        color = np.tile([0.8, 0.8, 0.8], (len(f), 1))
        color[fringe_faces(v, f, sight)] = (0.95, 0.7, 0.2)
        color[hanging] = (0.9, 0.0, 0.0)
        mesh = (v, f[near])
        images.append(shade_mesh(mesh, size=(600, 600), view=VIEW, up="y", color=color[near]))
        said = "without" if without_up else "with"
        print(f"{path.name}: {said} up: {hanging.sum()} long curtains")
    gap = np.zeros((600, 8, 3), dtype=images[0].dtype)
    out.write_bytes(png_bytes(np.concatenate([images[0], gap, images[1]], axis=1)))


def outline(faces: np.ndarray, fringe: np.ndarray) -> dict:
    """Where the fringe lies against the mesh's outline: % of the boundary faces (one edge or
    more on the boundary) in the fringe, % of the spikes (two boundary edges: the sawteeth of
    a ragged outline) in it, and % of the fringe faces off the boundary."""
    edges = np.sort(faces[:, [0, 1, 1, 2, 2, 0]].reshape(-1, 2), axis=1)
    _, inverse, counts = np.unique(edges, axis=0, return_inverse=True, return_counts=True)
    open_edges = (counts[inverse.ravel()] == 1).reshape(-1, 3).sum(axis=1)
    rim, spike = open_edges > 0, open_edges >= 2
    return {
        "rim fringe %": 100.0 * float(fringe[rim].mean()) if rim.any() else math.nan,
        "spike fringe %": 100.0 * float(fringe[spike].mean()) if spike.any() else math.nan,
        "fringe inside %": 100.0 * float((~rim[fringe]).mean()) if fringe.any() else math.nan,
    }


def measure(path: Path, method: str, world: dict | None = None, without_up: bool = False) -> dict:
    """One row: the mesh of ``path`` by ``method`` measured as the module doc says."""
    sp = read(path, without_up)
    sight = np.asarray(sp.up if sp.up is not None else (0.0, 0.0, 1.0), dtype=np.float64)
    t0 = time.perf_counter()
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        surface = scanmesh.reconstruct(sp, method)
    seconds = time.perf_counter() - t0
    v, f = surface.vertices, surface.faces
    choice = surface.options.get("method_choice", {})
    fringe, area = within(v, f, sight, FRINGE_DEG)
    normal = np.asarray(surface.frame.normal)
    row = {
        "scan": path.name.split(".")[0],
        "method": method,
        "built": choice.get("built", choice.get("chosen", method)),
        "points": len(sp.points),
        "faces": len(f),
        "plane tilt": math.degrees(math.acos(min(1.0, abs(float(normal @ sight))))),
        "long curtains": int(long_curtains(v, f, sight).sum()),
        "long curtains (plane)": int(long_curtains(v, f, normal).sum()),
        "curtains": int(within(v, f, sight, CURTAIN_DEG)[0].sum()),
        "fringe %": 100.0 * float(area[fringe].sum() / area.sum()),
        **outline(f, fringe),
        "seconds": seconds,
    }
    name = row["scan"]
    if world is not None and name in world:
        tri = v[f]
        s = float(np.median(np.linalg.norm(tri[:, 1] - tri[:, 0], axis=1)))
        pose = world[name][1]
        centroids = tri.mean(axis=1) @ pose[:3, :3].T + pose[:3, 3]
        tree = others_tree(world, name)
        gap = tree.query(centroids)[0] / s if tree is not None else np.full(len(f), np.nan)
        for key, m in (("fringe", fringe), ("rest", ~fringe)):
            row[f"others {key}"] = float(np.median(gap[m])) if m.any() else math.nan
            row[f"far {key} %"] = 100.0 * float((gap[m] > 3.0).mean()) if m.any() else math.nan
        row["holdout fringe"], row["holdout rest"] = holdout(sp, sight, method, s)
    return row


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--data", type=Path, default=DATA, help=f"folder of scans ({DATA})")
    ap.add_argument("--methods", nargs="*", default=["auto"], help="methods (default: auto)")
    ap.add_argument("--scans", nargs="*", help="scan names (e.g. happySideRight_120)")
    ap.add_argument("--truth", action="store_true", help="distances to the other scans, holdout")
    ap.add_argument("--without-up", action="store_true", help="drop the range grid's up")
    ap.add_argument("--picture", nargs=2, metavar=("SCAN", "PNG"), help="draw one scan")
    args = ap.parse_args()
    if args.picture:
        picture(scans(args.data, [args.picture[0]])[0], Path(args.picture[1]))
        return
    print(f"machine: {machine()}")
    world = posed(args.data) if args.truth else None
    rows = []
    for path in scans(args.data, args.scans):
        for method in args.methods:
            row = measure(path, method, world, args.without_up)
            rows.append(row)
            print(" | ".join(f"{v:.3g}" if isinstance(v, float) else str(v) for v in row.values()))
    print(table(rows))


def table(rows: list[dict]) -> str:
    """Markdown: per method, the scans with long curtains and the fringe's spread; with
    ``--truth``, the fringe against the other scans and the holdout, per method."""
    out = [
        "| method | scans | with long curtains | long curtains | curtains | fringe % mean"
        " (min-max) | plane tilt > 5 deg | seconds |",
        "|---|---:|---:|---:|---:|---|---:|---:|",
    ]
    methods = list(dict.fromkeys(r["method"] for r in rows))
    for method in methods:
        rs = [r for r in rows if r["method"] == method]
        fr = [r["fringe %"] for r in rs]
        out.append(
            f"| {method} | {len(rs)} | {sum(r['long curtains'] > 0 for r in rs)} |"
            f" {sum(r['long curtains'] for r in rs)} | {sum(r['curtains'] for r in rs)} |"
            f" {np.mean(fr):.2f} ({min(fr):.2f}-{max(fr):.2f}) |"
            f" {sum(r['plane tilt'] > 5 for r in rs)} | {sum(r['seconds'] for r in rs):.0f} |"
        )
    truth = [r for r in rows if "others fringe" in r]
    if truth:
        keys = ["rim fringe %", "spike fringe %", "fringe inside %"]
        keys += ["others fringe", "others rest", "far fringe %", "far rest %"]
        keys += ["holdout fringe", "holdout rest"]
        out += ["", "| method | " + " | ".join(keys) + " |", "|---|" + "---|" * len(keys)]
        for method in methods:
            rs = [r for r in truth if r["method"] == method]
            cells = []
            for key in keys:
                v = np.array([r[key] for r in rs], dtype=float)
                cells.append(f"{np.nanmedian(v):.3g} ({np.nanmin(v):.3g}-{np.nanmax(v):.3g})")
            out.append(f"| {method} | " + " | ".join(cells) + " |")
    return "\n".join(out)


if __name__ == "__main__":
    main()
