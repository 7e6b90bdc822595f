"""Whole parts from six views: scanmesh.merge against screened Poisson and ball pivoting.

    nice python benches/merge.py                         # every CAD part, Markdown table
    nice python benches/merge.py --parts fandisk --json out.jsonl
    python benches/merge.py --peers "open3d poisson d8" "open3d ball pivoting"   # fewer peers
    python benches/merge.py --spacing-divisor 150        # coarser scans
    python benches/merge.py --tilted                     # 14 views: 8 more at 45°
    python benches/merge.py --voxel 0.7 --peers          # merge alone, voxel 0.7 s
    nice python benches/merge.py --memory 10 1000000     # peak memory, 10 views of 1M points
    nice python benches/merge.py --real                  # the real scans (benches/multiview.py)

Each CAD part in ``../shared/data/cad`` is scanned by the virtual range scanner
(:func:`scanmesh.simulate_range_scan`) from the six axis directions, at a spacing s of its
largest extent / ``--spacing-divisor`` (200), noise sigma = s / 30 along the rays, returns
dropped on faces turned more than ``--grazing`` (75) degrees from the ray. Every method
gets the same points:

- ``scanmesh merge``: the six scans with their ray directions (defaults: voxel = s);
- ``open3d poisson dD`` / ``pymeshlab poisson dD`` (D = 8, 9, 10): screened Poisson on the
  merged points, normals estimated per view (Open3D, 12 neighbours) and oriented towards
  that view's scanner (the line of sight, given to them too); no density trimming;
- ``open3d ball pivoting`` (radii s, 2 s, 4 s) and ``pymeshlab ball pivoting`` (automatic).

Per mesh, distances by Open3D's ``RaycastingScene`` (float32) against the CAD truth:

- closed (every edge on two faces), pieces, Euler characteristic, genus (closed only);
- ``rms``: RMS distance to the truth of 200,000 area-uniform points on the mesh whose
  closest truth point lies within s of a scan sample (sampled surface);
- ``rms crease`` / ``rms away``: the same split by the closest truth point lying within s
  of a truth crease (edges whose faces' normals differ by more than 30 degrees) or not;
- ``normal crease`` / ``normal away``: mean angle (degrees, unoriented) between the mesh's
  face normal at those points and the truth's;
- ``unsampled rms``: RMS distance to the mesh from truth points more than 2 s from every
  scan sample (walls no view saw), and their share of the truth's boundary area (truth
  faces inside the solid, where a file's bodies overlap, are not boundary: left out);
  ``unsampled bias`` (JSON only): their mean distance along the truth's outward normal;
- ``far unlabelled``: share of the mesh's area on faces whose centre is more than 2 s from
  the truth and which carry no ``filled`` label (peers label nothing);
- seconds (one run, 2 cores shared with other work: indicative).
"""

from __future__ import annotations

import argparse
import json
import time
from pathlib import Path

import multiview
import numpy as np
import open3d as o3d
import pymeshlab
import trimesh
from quality import CAD, SHARED
from scipy.spatial import cKDTree

import scanmesh
from scanmesh import shape
from scanmesh.creases import crease_edges
from scanmesh.evaluate.digitizer import axis_views

PARTS = {
    "conrod": "conrod_slevin48_onshape.stl",
    "fandisk": "fandisk.obj",
    "octagonal_pocket": "octagonal_pocket.ply",
    "turbineblade": "turbineblade.ply",
}
N_SAMPLES = 200_000
SEED = 0


def scan(
    mesh: trimesh.Trimesh, spacing: float, grazing: float, tilted: bool = False
) -> list[scanmesh.ScanPoints]:
    """The six axis views; with ``tilted``, eight more from 45° between +-z and +-x or +-y
    (the walls inside pockets and the sides of bores that no axis view samples)."""
    views = axis_views(mesh, spacing, noise=spacing / 30, grazing=grazing, seed=SEED)
    if tilted:
        tilts = [(a, 0, c) for c in (1, -1) for a in (1, -1)]
        tilts += [(0, b, c) for c in (1, -1) for b in (1, -1)]
        for x, y, z in tilts:
            views.append(
                scanmesh.simulate_range_scan(
                    mesh,
                    up=np.array([x, y, z]) / np.sqrt(2.0),
                    along="y" if x else "x",
                    spacing=spacing,
                    noise=spacing / 30,
                    seed=SEED + len(views),
                    grazing=grazing,
                )
            )
    return views


def oriented_cloud(views: list[scanmesh.ScanPoints]) -> o3d.geometry.PointCloud:
    points, normals = [], []
    for view in views:
        pcd = o3d.geometry.PointCloud(o3d.utility.Vector3dVector(view.points))
        pcd.estimate_normals(o3d.geometry.KDTreeSearchParamKNN(knn=12))
        pcd.orient_normals_to_align_with_direction(view.up)
        points.append(view.points)
        normals.append(np.asarray(pcd.normals))
    cloud = o3d.geometry.PointCloud(o3d.utility.Vector3dVector(np.concatenate(points)))
    cloud.normals = o3d.utility.Vector3dVector(np.concatenate(normals))
    return cloud


def o3d_poisson(cloud, depth: int, spacing: float):
    mesh, _ = o3d.geometry.TriangleMesh.create_from_point_cloud_poisson(cloud, depth=depth)
    return np.asarray(mesh.vertices), np.asarray(mesh.triangles, dtype=np.int64)


def pml_poisson(cloud, depth: int, spacing: float):
    ms = pymeshlab.MeshSet()
    ms.add_mesh(
        pymeshlab.Mesh(
            vertex_matrix=np.asarray(cloud.points), v_normals_matrix=np.asarray(cloud.normals)
        )
    )
    ms.generate_surface_reconstruction_screened_poisson(depth=depth)
    m = ms.current_mesh()
    return m.vertex_matrix(), m.face_matrix().astype(np.int64)


def o3d_bpa(cloud, depth: int, spacing: float):
    radii = o3d.utility.DoubleVector([spacing, 2 * spacing, 4 * spacing])
    mesh = o3d.geometry.TriangleMesh.create_from_point_cloud_ball_pivoting(cloud, radii)
    return np.asarray(mesh.vertices), np.asarray(mesh.triangles, dtype=np.int64)


def pml_bpa(cloud, depth: int, spacing: float):
    ms = pymeshlab.MeshSet()
    ms.add_mesh(
        pymeshlab.Mesh(
            vertex_matrix=np.asarray(cloud.points), v_normals_matrix=np.asarray(cloud.normals)
        )
    )
    ms.generate_surface_reconstruction_ball_pivoting()
    m = ms.current_mesh()
    return m.vertex_matrix(), m.face_matrix().astype(np.int64)


PEERS = {
    **{f"open3d poisson d{d}": (o3d_poisson, d) for d in (8, 9, 10)},
    **{f"pymeshlab poisson d{d}": (pml_poisson, d) for d in (8, 9, 10)},
    "open3d ball pivoting": (o3d_bpa, 0),
    "pymeshlab ball pivoting": (pml_bpa, 0),
}


def scene_of(vertices: np.ndarray, faces: np.ndarray) -> o3d.t.geometry.RaycastingScene:
    scene = o3d.t.geometry.RaycastingScene()
    scene.add_triangles(
        o3d.core.Tensor(np.asarray(vertices, dtype=np.float32)),
        o3d.core.Tensor(np.asarray(faces, dtype=np.uint32)),
    )
    return scene


def closest(scene, points: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    ans = scene.compute_closest_points(o3d.core.Tensor(np.asarray(points, dtype=np.float32)))
    return ans["points"].numpy().astype(np.float64), ans["primitive_ids"].numpy().astype(np.int64)


class Judge:
    """The truth of one part and where its scans sampled it."""

    def __init__(self, truth: trimesh.Trimesh, views, spacing: float) -> None:
        self.truth, self.s = truth, spacing
        self.scene = scene_of(truth.vertices, truth.faces)
        self.samples = cKDTree(np.concatenate([v.points for v in views]))
        edges = crease_edges(truth.vertices, truth.faces, 30.0)
        a, b = truth.vertices[edges[:, 0]], truth.vertices[edges[:, 1]]
        steps = np.maximum(np.ceil(np.linalg.norm(b - a, axis=1) / (spacing / 4)), 1).astype(int)
        t = np.concatenate([np.arange(n + 1) / n for n in steps])
        seg = np.repeat(np.arange(len(edges)), steps + 1)
        self.creases = cKDTree(a[seg] + t[:, None] * (b[seg] - a[seg]))
        n_truth = int(min(400_000, max(50_000, truth.area / (spacing / 2) ** 2)))
        pts, tri = trimesh.sample.sample_surface(truth, n_truth, seed=SEED)
        # the part's boundary only: a file of touching bodies (the conrod's beam runs into
        # its rings) has faces inside the solid, which no scan can see and no mesh should
        # have; a truth point whose step out along its normal is inside a body is one
        out = pts + 0.05 * spacing * truth.face_normals[tri]
        inside = np.zeros(len(pts), bool)
        for body in truth.split(only_watertight=False):
            if body.is_watertight:
                scene = scene_of(body.vertices, body.faces)
                occupied = scene.compute_occupancy(o3d.core.Tensor(out.astype(np.float32)))
                inside |= occupied.numpy() > 0
        self.internal_share = float(inside.mean())
        pts, tri = pts[~inside], tri[~inside]
        far = self.samples.query(pts)[0] > 2 * spacing
        self.unsampled, self.unsampled_normals = pts[far], truth.face_normals[tri[far]]
        self.unsampled_share = len(self.unsampled) / len(pts)

    def __call__(self, vertices: np.ndarray, faces: np.ndarray, labels=None) -> dict:
        s = self.s
        row: dict = {"faces": len(faces)}
        if len(faces) == 0:
            return row
        mesh = trimesh.Trimesh(vertices, faces, process=False)
        row["closed"] = shape.is_watertight(faces)
        row["pieces"] = int(
            len(
                trimesh.graph.connected_components(mesh.face_adjacency, nodes=np.arange(len(faces)))
            )
        )
        row["euler"] = shape.euler_characteristic(faces)
        row["genus"] = (2 * row["pieces"] - row["euler"]) / 2 if row["closed"] else None
        pts, face = trimesh.sample.sample_surface(mesh, N_SAMPLES, seed=SEED)
        near, prim = closest(self.scene, pts)
        dist = np.linalg.norm(pts - near, axis=1)
        sampled = self.samples.query(near)[0] <= s
        crease = self.creases.query(near)[0] <= s
        cos = np.abs(np.einsum("ij,ij->i", mesh.face_normals[face], self.truth.face_normals[prim]))
        angle = np.degrees(np.arccos(np.clip(cos, 0, 1)))

        def rms(mask):
            return float(np.sqrt(np.mean(dist[mask] ** 2))) if mask.any() else None

        row["rms"] = rms(sampled)
        row["rms crease"] = rms(sampled & crease)
        row["rms away"] = rms(sampled & ~crease)
        row["normal crease"] = (
            float(angle[sampled & crease].mean()) if (sampled & crease).any() else None
        )
        row["normal away"] = (
            float(angle[sampled & ~crease].mean()) if (sampled & ~crease).any() else None
        )
        if len(self.unsampled):
            back, _ = closest(scene_of(vertices, faces), self.unsampled)
            row["unsampled rms"] = float(
                np.sqrt(np.mean(np.sum((back - self.unsampled) ** 2, axis=1)))
            )
            # along the truth's outward normal: > 0 where the mesh lies outside the part
            off = np.einsum("ij,ij->i", back - self.unsampled, self.unsampled_normals)
            row["unsampled bias"] = float(off.mean())
        centre = mesh.triangles_center
        off = np.linalg.norm(closest(self.scene, centre)[0] - centre, axis=1) > 2 * s
        unlabelled = np.ones(len(faces), bool) if labels is None else labels != 2
        row["far unlabelled"] = float(mesh.area_faces[off & unlabelled].sum() / mesh.area)
        return row


def run_part(
    name: str,
    path: Path,
    divisor: float,
    grazing: float,
    peers: list[str] | None = None,
    tilted: bool = False,
    voxel: float | None = None,
) -> list[dict]:
    truth = trimesh.load(path, force="mesh", process=True)
    spacing = float(truth.extents.max()) / divisor
    views = scan(truth, spacing, grazing, tilted)
    judge = Judge(truth, views, spacing)
    # the genus of the solid: the conrod is three touching closed bodies (two rings and the
    # beam), 2 genus in all, as one piece would have
    bodies = len(truth.split(only_watertight=False))
    truth_genus = (2 * bodies - truth.euler_number) / 2
    head = {
        "part": name,
        "views": len(views),
        "spacing": spacing,
        "points": int(sum(len(v.points) for v in views)),
        "truth genus": truth_genus,
        "unsampled share": judge.unsampled_share,
        "internal share": judge.internal_share,
    }
    rows = []
    t0 = time.perf_counter()
    merged = scanmesh.merge(views, voxel=None if voxel is None else voxel * spacing)
    seconds = time.perf_counter() - t0
    row = {**head, "method": "scanmesh merge", "seconds": seconds}
    row.update(judge(merged.vertices, merged.faces, merged.face_labels))
    row["label areas"] = merged.label_areas
    rows.append(row)
    print(json.dumps(row), flush=True)
    cloud = oriented_cloud(views)
    for method, (fn, depth) in PEERS.items():
        if peers is not None and method not in peers:
            continue
        t0 = time.perf_counter()
        try:
            v, f = fn(cloud, depth, spacing)
        except Exception as exc:  # a peer failing is a row, not the end of the run
            rows.append({**head, "method": method, "error": str(exc)})
            continue
        row = {**head, "method": method, "seconds": time.perf_counter() - t0}
        row.update(judge(v, f))
        rows.append(row)
        print(json.dumps(row), flush=True)
    return rows


def table(rows: list[dict]) -> str:
    cols = [
        ("method", None),
        ("closed", None),
        ("pieces", "d"),
        ("genus", "g"),
        ("rms", ".3g"),
        ("rms crease", ".3g"),
        ("rms away", ".3g"),
        ("normal crease", ".1f"),
        ("normal away", ".1f"),
        ("unsampled rms", ".3g"),
        ("far unlabelled", ".2%"),
        ("seconds", ".1f"),
    ]

    def heading(h: dict) -> str:
        return (
            f"\n**{h['part']}** (s = {h['spacing']:.4g}, {h['points']:,} points, truth genus"
            f" {h['truth genus']:g}, never sampled {h['unsampled share']:.1%} of the boundary"
            + (
                f", {h['internal share']:.1%} of the file's area inside the solid"
                if h.get("internal share")
                else ""
            )
            + ")\n"
        )

    return multiview.markdown(rows, "part", heading, cols)


def memory_run(n_views: int, n_points: int) -> dict:
    """Peak memory and time of ``merge`` on ``n_views`` range scans of about ``n_points``
    each (a sphere seen from directions spread over it, default voxel and grid cap)."""
    import resource

    sphere = trimesh.creation.icosphere(subdivisions=5)
    rng = np.random.default_rng(SEED)
    views = []
    for k in range(n_views):
        up = rng.normal(size=3)
        scan = scanmesh.simulate_range_scan(
            sphere, up=up / np.linalg.norm(up), n_points=n_points, noise=0.0, seed=k
        )
        views.append(scan)
    points = sum(len(v.points) for v in views)
    start = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
    t0 = time.perf_counter()
    surface = scanmesh.merge(views)
    seconds = time.perf_counter() - t0
    peak = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss  # KiB on Linux
    return {
        "views": n_views,
        "points": points,
        "grid": surface.options["grid"],
        "voxel": surface.options["voxel"],
        "faces": len(surface.faces),
        "seconds": seconds,
        "peak RSS GiB (process)": peak / 2**20,
        "peak RSS GiB before merge": start / 2**20,
    }


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--parts", nargs="*", choices=list(PARTS), help="subset of the parts")
    ap.add_argument("--cad", type=Path, default=CAD, help=f"CAD folder (default {CAD})")
    ap.add_argument("--spacing-divisor", type=float, default=200.0)
    ap.add_argument("--grazing", type=float, default=75.0)
    ap.add_argument("--tilted", action="store_true", help="8 more views, 45° between the axes")
    ap.add_argument("--voxel", type=float, help="merge's voxel in spacings s (default: s)")
    ap.add_argument("--peers", nargs="*", choices=list(PEERS), help="subset of the peers")
    ap.add_argument("--json", type=Path, help="also write the rows here (JSON lines)")
    ap.add_argument(
        "--memory",
        nargs=2,
        type=int,
        metavar=("VIEWS", "POINTS"),
        help="instead: peak memory of merge on VIEWS scans of a sphere, POINTS each",
    )
    ap.add_argument("--real", action="store_true", help="instead: the real aligned scans")
    ap.add_argument("--multiview", type=Path, default=SHARED / "multiview", help="their folder")
    ap.add_argument("--sets", nargs="*", help="subset of the real sets")
    ap.add_argument("--methods", nargs="*", help="subset of the methods on the real sets")
    ap.add_argument("--voxel-world", type=float, help="merge's voxel on the real sets (metres)")
    ap.add_argument("--pictures", type=Path, help="write the real sets' pictures here")
    args = ap.parse_args()
    if args.real:
        rows = []
        for name in args.sets or list(multiview.SETS):
            rows += multiview.run_set(
                args.multiview, name, args.methods, args.voxel_world, args.pictures
            )
        if args.json:
            args.json.write_text("".join(json.dumps(r) + "\n" for r in rows))
        print(multiview.table(rows))
        return
    if args.memory:
        print(json.dumps(memory_run(*args.memory)))
        return
    rows = []
    for name, file in PARTS.items():
        if args.parts and name not in args.parts:
            continue
        rows += run_part(
            name,
            args.cad / file,
            args.spacing_divisor,
            args.grazing,
            args.peers,
            args.tilted,
            args.voxel,
        )
    if args.json:
        args.json.write_text("".join(json.dumps(r) + "\n" for r in rows))
    print(table(rows))


if __name__ == "__main__":
    main()
