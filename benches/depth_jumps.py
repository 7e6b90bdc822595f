"""Depth jumps: parts with bores, walls and steps scanned along their axis.

    python benches/depth_jumps.py                  # every part, every method, Markdown table
    python benches/depth_jumps.py --parts "rocker arm"   # one part
    python benches/depth_jumps.py --cad DATA/cad   # data elsewhere

Each part is scanned by the virtual digitizer (:func:`scanmesh.simulate_scan`, about
15,000 points, no noise) along the axis it is machined from: the octagonal pocket along z,
the fandisk along y, and a rocker-arm-like part made here with trimesh (manifold booleans:
two bosses of different heights with through bores, a taller pivot boss with a blind bore,
a slot pocket and two small oil holes) along z. Rows:

- ``delaunay, planar trim only``: today's Delaunay before depth-jump trimming (planar
  trimming at the default length, ``jump_factor=inf``), the reference of the ratios;
- ``delaunay`` and ``anneal``: default ``reconstruct`` (depth-jump, gap and hole trimming on);
- ``pyvista delaunay_2d``: ``delaunay_2d(alpha=2.5 s)`` (s the median spacing);
- ``pymeshlab ball pivoting`` (automatic radius) and ``open3d ball pivoting`` (radii s,
  2 s, 4 s, normals estimated and oriented towards the scanner).

Per mesh: height RMS against the CAD truth (closest-point distance at 100,000 random points
on the mesh's area, :func:`scanmesh.evaluate.truth.height_error`), its ratio to the reference, the
RMS on the area the mesh and the reference both cover (samples on the mesh whose ray along
the axis hits the reference too) and its ratio, air and missed shadow in % of the part's
shadow (:func:`scanmesh.evaluate.truth.domain_error`), the sliver share (smallest angle below
``scanmesh.measures.SLIVER_ANGLE_DEG``) and the longest 3-D edge over the median edge.
The peers are optional (benchmark-only dependencies): a missing one is skipped.
"""

from __future__ import annotations

import argparse
import math
import time
import warnings
from pathlib import Path

import numpy as np
import trimesh
from quality import CAD, machine

import scanmesh
from scanmesh import _core
from scanmesh.evaluate.digitizer import cast_grid
from scanmesh.evaluate.truth import TrueSurface, domain_error, height_error
from scanmesh.measures import quality
from scanmesh.scan.projection import project
from scanmesh.stages.options import MAX_EDGE_FACTOR

N_POINTS = 15_000
N_SAMPLES = 100_000
SEED = 0
#: Rays of the coverage grids (domain error and the common area).
N_RAYS = 2_000_000


def rocker_arm() -> trimesh.Trimesh:
    """A rocker-arm-like part (mm): an arm between two bosses of different heights with
    through bores, a taller pivot boss with a blind bore, a slot pocket and two oil holes."""

    def cyl(r: float, z0: float, z1: float, x: float) -> trimesh.Trimesh:
        c = trimesh.creation.cylinder(radius=r, height=z1 - z0, sections=96)
        c.apply_translation([x, 0.0, (z0 + z1) / 2])
        return c

    def cube(x0: float, x1: float, y0: float, y1: float, z0: float, z1: float) -> trimesh.Trimesh:
        b = trimesh.creation.box(extents=[x1 - x0, y1 - y0, z1 - z0])
        b.apply_translation([(x0 + x1) / 2, (y0 + y1) / 2, (z0 + z1) / 2])
        return b

    body = trimesh.boolean.union(
        [cube(-30, 30, -7, 7, 0, 8), cyl(11, 0, 16, -30), cyl(9, 0, 12, 30), cyl(8, 0, 14, 0)],
        engine="manifold",
    )
    cuts = [
        cyl(5.5, -1, 17, -30),
        cyl(4, -1, 13, 30),
        cyl(3, 5, 15, 0),
        cube(8, 20, -3, 3, 4, 9),
        cyl(0.7, -1, 9, -15),
        cyl(0.7, -1, 9, 15),
    ]
    return trimesh.boolean.difference([body, *cuts], engine="manifold")


def parts(cad: Path) -> dict[str, tuple[object, str]]:
    """part -> (CAD mesh or path, scanning axis), the CAD files read from ``cad``."""
    return {
        "octagonal_pocket": (cad / "octagonal_pocket.ply", "z"),
        "fandisk": (cad / "fandisk.obj", "y"),
        "rocker arm": (rocker_arm(), "z"),
    }


def to_axis_z(points: np.ndarray, axis: str) -> np.ndarray:
    """Points rotated so that the scanning axis is +z (peers triangulate over xy)."""
    order = {"x": [1, 2, 0], "y": [2, 0, 1], "z": [0, 1, 2]}[axis]
    return points[:, order]


def pyvista_delaunay(points: np.ndarray, axis: str, spacing: float) -> np.ndarray:
    import pyvista as pv

    cloud = pv.PolyData(to_axis_z(points, axis))
    out = cloud.delaunay_2d(alpha=2.5 * spacing)
    if out.n_points != len(points) or not np.array_equal(out.points, cloud.points):
        raise RuntimeError("delaunay_2d reordered the points")
    return out.regular_faces.astype(np.int64)


def scanner_normals(points: np.ndarray, axis: str) -> np.ndarray:
    import open3d as o3d

    pcd = o3d.geometry.PointCloud(o3d.utility.Vector3dVector(to_axis_z(points, axis)))
    pcd.estimate_normals(o3d.geometry.KDTreeSearchParamKNN(knn=12))
    pcd.orient_normals_to_align_with_direction(np.array([0.0, 0.0, 1.0]))
    return pcd


def open3d_ball_pivoting(points: np.ndarray, axis: str, spacing: float) -> np.ndarray:
    import open3d as o3d

    pcd = scanner_normals(points, axis)
    radii = o3d.utility.DoubleVector([spacing, 2 * spacing, 4 * spacing])
    mesh = o3d.geometry.TriangleMesh.create_from_point_cloud_ball_pivoting(pcd, radii)
    if len(mesh.vertices) != len(points):
        raise RuntimeError("ball pivoting changed the points")
    return np.asarray(mesh.triangles, dtype=np.int64)


def pymeshlab_ball_pivoting(points: np.ndarray, axis: str, spacing: float) -> np.ndarray:
    import pymeshlab

    pcd = scanner_normals(points, axis)
    ms = pymeshlab.MeshSet()
    ms.add_mesh(
        pymeshlab.Mesh(
            vertex_matrix=to_axis_z(points, axis), v_normals_matrix=np.asarray(pcd.normals)
        )
    )
    ms.generate_surface_reconstruction_ball_pivoting()
    m = ms.current_mesh()
    if m.vertex_number() != len(points):
        raise RuntimeError("ball pivoting changed the points")
    return m.face_matrix().astype(np.int64)


PEERS = {
    "pyvista delaunay_2d(alpha=2.5 s)": pyvista_delaunay,
    "pymeshlab ball pivoting": pymeshlab_ball_pivoting,
    "open3d ball pivoting (s, 2 s, 4 s)": open3d_ball_pivoting,
}


def coverage(points: np.ndarray, faces: np.ndarray, frame, box, step: float) -> np.ndarray:
    """(ni, nj) bool: grid rays along the frame normal that hit a face."""
    tri = points[faces] @ np.column_stack([frame.u, frame.v])
    lo, hi = box
    shape = (int((hi[0] - lo[0]) / step) + 1, int((hi[1] - lo[1]) / step) + 1)
    _, face = cast_grid(tri, np.zeros(tri.shape[:2]), (lo[0], lo[1]), (step, step), shape)
    # rays are numbered along the first axis fastest (ray = i + j * ni)
    return (face >= 0).reshape(shape[1], shape[0]).T


def common_rms(points, faces, ref_cover, frame, box, step, truth) -> float:
    """Height RMS over samples of the mesh whose ray also hits the reference mesh."""
    mesh = trimesh.Trimesh(points, faces, process=False)
    samples, _ = trimesh.sample.sample_surface(mesh, N_SAMPLES, seed=SEED)
    uv = np.column_stack([samples @ frame.u, samples @ frame.v])
    ij = np.floor((uv - box[0]) / step + 0.5).astype(np.int64)
    ij = np.clip(ij, 0, np.array(ref_cover.shape) - 1)
    inside = ref_cover[ij[:, 0], ij[:, 1]]
    d = truth.distance(samples[inside])
    return float(np.sqrt(np.mean(d * d))) if len(d) else math.nan


def measure(part: str, cad, axis: str) -> list[dict]:
    points, _ = scanmesh.simulate_scan(
        cad, up=axis, along="x" if axis != "x" else "y", n_points=N_POINTS
    )
    truth = TrueSurface(cad)
    uv, frame = project(points, axis)
    default = scanmesh.delaunay(points, plane=axis)
    limit = default.options["max_edge"]
    spacing = limit / MAX_EDGE_FACTOR
    hull, _ = _core.delaunay(uv)
    meshes: list[tuple[str, np.ndarray, float]] = []
    meshes.append(("delaunay, planar trim only", _core.trim_long_edges(uv, hull, limit), 0.0))
    # Delaunay and annealing from it take no lines (a method refuses a keyword it ignores).
    for method, extra in (("delaunay", {}), ("anneal", {"seed": SEED})):
        t0 = time.perf_counter()
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            s = scanmesh.reconstruct(points, method, plane=axis, **extra)
        meshes.append((method, s.faces, time.perf_counter() - t0))
    for name, run in PEERS.items():
        try:
            t0 = time.perf_counter()
            meshes.append((name, run(points, axis, spacing), time.perf_counter() - t0))
        except ImportError as exc:
            print(f"({name} skipped: {exc})")
    lo, hi = uv.min(axis=0) - 2 * spacing, uv.max(axis=0) + 2 * spacing
    step = math.sqrt(float(np.prod(hi - lo)) / N_RAYS)
    box = (lo, hi)
    ref_cover = coverage(points, meshes[0][1], frame, box, step)
    rows = []
    for name, faces, seconds in meshes:
        surface = scanmesh.Surface(vertices=points, faces=faces, frame=frame)
        h = height_error(surface, truth, n_samples=N_SAMPLES, seed=SEED)["h_rms"]
        d = domain_error(surface, truth, n_rays=N_RAYS)
        q = quality(points, faces)
        edges = np.linalg.norm(points[faces] - points[np.roll(faces, 1, axis=1)], axis=2)
        rows.append(
            {
                "part": part,
                "method": name,
                "faces": len(faces),
                "seconds": seconds,
                "h_rms": h,
                "common": common_rms(points, faces, ref_cover, frame, box, step, truth),
                "air": 100 * d["air_share"],
                "missed": 100 * d["missed_share"],
                "slivers": 100 * q.sliver_fraction,
                "edge_ratio": float(edges.max() / np.median(edges)),
            }
        )
        print(f"  {part}: {name} done", flush=True)
    ref = rows[0]
    for r in rows:
        r["ratio"] = r["h_rms"] / ref["h_rms"]
        r["common_ratio"] = r["common"] / ref["common"]
    return rows


def table(rows: list[dict]) -> str:
    out = [
        "| part | method | faces | height RMS | × ref | RMS on common area | × ref |"
        " air % | missed % | slivers % | longest / median edge |",
        "|---|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|",
    ]
    for r in rows:
        out.append(
            f"| {r['part']} | {r['method']} | {r['faces']:,} | {r['h_rms']:.3g} |"
            f" {r['ratio']:.3f} | {r['common']:.3g} | {r['common_ratio']:.3f} |"
            f" {r['air']:.3f} | {r['missed']:.2f} | {r['slivers']:.1f} | {r['edge_ratio']:.1f} |"
        )
    return "\n".join(out)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--parts", nargs="*", help="subset of: octagonal_pocket fandisk 'rocker arm'")
    ap.add_argument("--cad", type=Path, default=CAD, help=f"CAD folder (default {CAD})")
    args = ap.parse_args()
    print(f"machine: {machine()}")
    rows = []
    for part, (cad, axis) in parts(args.cad).items():
        if args.parts and part not in args.parts:
            continue
        rows += measure(part, cad, axis)
    print(table(rows))
    print(f"machine after: {machine()}")


if __name__ == "__main__":
    main()
