"""Real aligned range scans: scanmesh.merge against screened Poisson and ball pivoting.

    nice python benches/merge.py --real                       # the four real sets
    nice python benches/merge.py --real --sets "dragon stand" --voxel-world 0.001 \\
        --methods "open3d poisson d8" --pictures benches/figures

The Stanford scans in ``../shared/data/multiview`` (Cyberware 3030MS, aligned by their
``.conf``; read with :func:`scanmesh.read_conf`): the dragon's stand series (15 views),
its side series (15), both together (30, one frame) and the happy Buddha (15). Every
method gets the same points: 10 % of each view's points (a fixed-seed draw) are withheld;
``holdout rms`` is the RMS distance (metres) to the mesh from those on a scanned surface
(an input return within 2 spacings, 30 within 6), ``holdout rms all`` from all of them
(the scanner's outliers included: a handful of points can carry most of it).

- ``scanmesh merge``: the views with their poses (defaults, or ``--voxel-world``);
- ``open3d poisson dD`` (D = 8, 9, 10): Open3D's screened Poisson on the merged points,
  normals estimated per view (12 neighbours) and turned towards that view's scanner, then
  the vertices of the lowest 1 % of the density estimate removed (Open3D's tutorial);
- ``pymeshlab poisson dD``: pymeshlab's screened Poisson on the same oriented points;
- ``open3d ball pivoting`` (radii s, 2 s, 4 s; s the views' median spacing).

Per mesh: faces, pieces, closed, the genus of the closed pieces (summed), the boundary
loops of the open ones, the holdout RMS, seconds and the peak resident memory of the
process that built it (each method runs in a fresh spawned process).
"""

from __future__ import annotations

import json
import multiprocessing
import os
import resource
import time
from pathlib import Path

import numpy as np
import open3d as o3d
from scipy.spatial import cKDTree

import scanmesh
from scanmesh.fusion.depth import view_spacing
from scanmesh.fusion.pieces import pieces
from scanmesh.fusion.views import View

SETS = {
    "dragon stand": ["dragon_stand/dragonStandRight.conf"],
    "dragon side": ["dragon_side/dragonSideRight.conf"],
    "dragon both": ["dragon_stand/dragonStandRight.conf", "dragon_side/dragonSideRight.conf"],
    "buddha": ["happy_side/happySideRight.conf"],
}
HOLDOUT = 0.1
SEED = 0
DENSITY_QUANTILE = 0.01

#: Input returns within 6 spacings of a held-out return that make it one on a surface
#: (a surface scanned at the spacing has about 110 per view there).
SURFACE_RETURNS = 30


def load(folder: Path, name: str) -> tuple[list[View], np.ndarray]:
    """The set's views with 10 % of each view's points withheld, and those points (world)."""
    rng = np.random.default_rng(SEED)
    views, held = [], []
    for conf in SETS[name]:
        for view in scanmesh.read_conf(folder / conf):
            out = rng.random(len(view.points)) < HOLDOUT
            held.append(view.world[out])
            views.append(View(view.points[~out], view.pose, view.source))
    return views, np.concatenate(held)


def oriented_cloud(views: list[View]) -> o3d.geometry.PointCloud:
    points, normals = [], []
    for view in views:
        world = view.world
        pcd = o3d.geometry.PointCloud(o3d.utility.Vector3dVector(world))
        pcd.estimate_normals(o3d.geometry.KDTreeSearchParamKNN(knn=12))
        pcd.orient_normals_to_align_with_direction(view.pose[:3, 2])  # towards the scanner
        points.append(world)
        normals.append(np.asarray(pcd.normals))
    cloud = o3d.geometry.PointCloud(o3d.utility.Vector3dVector(np.concatenate(points)))
    cloud.normals = o3d.utility.Vector3dVector(np.concatenate(normals))
    return cloud


def o3d_poisson(views, depth: int, spacing: float, voxel):
    cloud = oriented_cloud(views)
    mesh, density = o3d.geometry.TriangleMesh.create_from_point_cloud_poisson(cloud, depth=depth)
    density = np.asarray(density)
    mesh.remove_vertices_by_mask(density < np.quantile(density, DENSITY_QUANTILE))
    return np.asarray(mesh.vertices), np.asarray(mesh.triangles, dtype=np.int64)


def pml_poisson(views, depth: int, spacing: float, voxel):
    import merge

    return merge.pml_poisson(oriented_cloud(views), depth, spacing)


def o3d_bpa(views, depth: int, spacing: float, voxel):
    cloud = oriented_cloud(views)
    radii = o3d.utility.DoubleVector([spacing, 2 * spacing, 4 * spacing])
    mesh = o3d.geometry.TriangleMesh.create_from_point_cloud_ball_pivoting(cloud, radii)
    return np.asarray(mesh.vertices), np.asarray(mesh.triangles, dtype=np.int64)


def ours(views, depth: int, spacing: float, voxel):
    surface = scanmesh.merge(views, voxel=voxel)
    return surface.vertices, surface.faces


METHODS = {
    "scanmesh merge": (ours, 0),
    **{f"open3d poisson d{d}": (o3d_poisson, d) for d in (8, 9, 10)},
    **{f"pymeshlab poisson d{d}": (pml_poisson, d) for d in (8, 9, 10)},
    "open3d ball pivoting": (o3d_bpa, 0),
}


def measured(fn, *args) -> tuple[object, float]:
    """``fn(*args)`` (an exception is returned, not raised) and this process's peak RSS."""
    try:
        result = fn(*args)
    except Exception as exc:  # a method failing is a row, not the end of the run
        result = exc
    return result, resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 2**20


def in_child(fn, *args) -> tuple[object, float, float]:
    """``fn(*args)`` in a fresh (spawned) process: its result, wall seconds (the start of
    the process and the transfer of the views included) and peak RSS (GiB)."""
    t0 = time.perf_counter()
    with multiprocessing.get_context("spawn").Pool(1) as pool:
        result, peak = pool.apply(measured, (fn, *args))
    return result, time.perf_counter() - t0, peak


def judge(vertices: np.ndarray, faces: np.ndarray, held: np.ndarray, near: np.ndarray) -> dict:
    row: dict = {"faces": len(faces)}
    if len(faces) == 0:
        return row
    parts = pieces(vertices, faces)
    row["pieces"] = len(parts)
    row["closed"] = all(p.closed for p in parts)
    row["genus"] = sum(p.genus for p in parts if p.genus is not None)
    row["largest genus"] = parts[0].genus
    row["holes"] = sum(p.holes for p in parts)
    row["small pieces"] = sum(1 for p in parts if p.faces <= 20)
    scene = o3d.t.geometry.RaycastingScene()
    scene.add_triangles(
        o3d.core.Tensor(np.asarray(vertices, dtype=np.float32)),
        o3d.core.Tensor(np.asarray(faces, dtype=np.uint32)),
    )
    dist = scene.compute_distance(o3d.core.Tensor(held.astype(np.float32))).numpy()
    dist = dist.astype(np.float64)
    row["holdout rms"] = float(np.sqrt(np.mean(dist[near] ** 2)))
    row["holdout rms all"] = float(np.sqrt(np.mean(dist**2)))
    row["holdout median"] = float(np.median(dist))
    return row


def picture(vertices, faces, path: Path, up: str) -> None:
    import trimesh

    from scanmesh.present.render import render_mesh

    render_mesh(
        trimesh.Trimesh(vertices, faces, process=False),
        path,
        size=(700, 560),
        view=(0.2, 0.25, 1.0),
        up=up,
    )


def side_by_side(paths: list[Path], labels: list[str], out: Path) -> None:
    from PIL import Image, ImageDraw

    tiles = [Image.open(p).convert("RGB") for p in paths]
    w, h = tiles[0].size
    sheet = Image.new("RGB", (w * len(tiles), h + 24), "white")
    draw = ImageDraw.Draw(sheet)
    for k, (tile, label) in enumerate(zip(tiles, labels, strict=True)):
        sheet.paste(tile, (k * w, 24))
        draw.text((k * w + 8, 4), label, fill="black")
    sheet.save(out)


def run_set(
    folder: Path, name: str, methods: list[str] | None, voxel, pictures: Path | None
) -> list[dict]:
    views, held = load(folder, name)
    spacing = float(np.median([view_spacing(v.points[:, :2]) for v in views]))
    # the held-out returns on a scanned surface: an input return within 2 spacings and at
    # least SURFACE_RETURNS within 6 (the rest are the scanner's outliers, blobs of a few
    # returns off the part, whatever the method: one, 13 returns 79 mm off the dragon,
    # carried 83 % of the squared distance of the held-out points to merge's mesh)
    tree = cKDTree(np.concatenate([v.world for v in views]))
    near = tree.query(held)[0] <= 2 * spacing
    near[near] = tree.query_ball_point(held[near], 6 * spacing, return_length=True) >= (
        SURFACE_RETURNS
    )
    head = {
        "set": name,
        "views": len(views),
        "points": int(sum(len(v.points) for v in views)),
        "held out": len(held),
        "spacing": spacing,
        "held out on a surface": float(near.mean()),
        "load": os.getloadavg()[0],
    }
    rows, shots = [], []
    for method, (fn, depth) in METHODS.items():
        if methods is not None and method not in methods:
            continue
        result, seconds, peak = in_child(fn, views, depth, spacing, voxel)
        row = {**head, "method": method, "seconds": seconds, "peak GiB": peak}
        if isinstance(result, Exception):
            row["error"] = str(result)
        else:
            v, f = result
            row.update(judge(v, f, held, near))
            if pictures is not None:
                shot = pictures / f"merge_{name.replace(' ', '_')}_{method.replace(' ', '_')}.png"
                picture(v, f, shot, "y")
                shots.append((shot, method))
        rows.append(row)
        print(json.dumps(row), flush=True)
    if pictures is not None and shots:
        side_by_side(
            [p for p, _ in shots],
            [m for _, m in shots],
            pictures / f"merge_{name.replace(' ', '_')}.png",
        )
        for p, _ in shots:
            p.unlink()
    return rows


def cell(value, spec: str | None) -> str:
    """One table cell: "-" for none, yes/no, else formatted by ``spec``."""
    if value is None:
        return "-"
    if isinstance(value, bool):
        return "yes" if value else "no"
    return str(value) if spec is None else format(value, spec)


def markdown(rows: list[dict], group: str, heading, cols: list[tuple[str, str | None]]) -> str:
    """Markdown tables of ``rows``, one per value of ``group``, each under ``heading(its
    first row)``."""
    out = []
    for name in dict.fromkeys(r[group] for r in rows):
        mine = [r for r in rows if r[group] == name]
        out.append(heading(mine[0]))
        out.append("| " + " | ".join(c for c, _ in cols) + " |")
        out.append("|" + "---|" * len(cols))
        for r in mine:
            out.append("| " + " | ".join(cell(r.get(c), spec) for c, spec in cols) + " |")
    return "\n".join(out)


#: The real sets' table: (column, format).
COLUMNS = [("method", None), ("faces", ",d"), ("pieces", "d"), ("small pieces", "d")]
COLUMNS += [("closed", None), ("genus", "g"), ("holes", "d"), ("holdout rms", ".4g")]
COLUMNS += [("holdout rms all", ".4g"), ("seconds", ".1f"), ("peak GiB", ".2f")]


def table(rows: list[dict]) -> str:

    def heading(h: dict) -> str:
        return (
            f"\n**{h['set']}** ({h['views']} views, {h['points']:,} points, {h['held out']:,}"
            f" held out, {h['held out on a surface']:.2%} of them on a scanned surface; spacing"
            f" {1000 * h['spacing']:.3f} mm, load {h['load']:.1f})\n"
        )

    return markdown(rows, "set", heading, COLUMNS)
