"""Curtains: range scans meshed along the scanner's grid, beside the peers, with the truth known.

    python benches/curtains.py                       # panel, sweep, time; Markdown tables
    python benches/curtains.py --only time           # the 1M-point timing alone
    python benches/curtains.py --cad DATA/cad --points 10000
    python benches/curtains.py --only panel --scans "rocker arm z" --noise 0 --grazing 90
    python benches/curtains.py --only hidden         # unstructured, projected off the sight
    python benches/curtains.py --only fran           # fran_cut's curtains per method

The panel: CAD parts (the octagonal pocket, the fandisk, the connecting rod and a rocker
arm built here, benches/depth_jumps.py) each scanned by the virtual range scanner
(:func:`scanmesh.evaluate.digitizer.simulate_range_scan`) from several axis directions,
with Gaussian noise along the ray (``NOISE`` x the spacing) and grazing-angle dropout
(samples on faces turned more than ``GRAZING`` degrees from the ray are lost). Each scan is
meshed by:

- scanmesh ``grid`` (the range-grid triangulation), ``delaunay`` and ``anneal`` (the
  default; on a gridded scan it starts from the grid);
- ``numpy range grid``: every grid cell split along its shorter 3-D diagonal, nothing dropped
  (the plain range-grid triangulation);
- PyVista ``delaunay_2d(alpha=a s)`` for a in ``ALPHAS`` (s the grid spacing), Open3D ball
  pivoting (radii s, 2 s, 4 s) and pymeshlab ball pivoting (automatic radius), normals
  oriented towards the scanner (benchmark-only dependencies; a missing one is skipped).

Per mesh: height RMS against the CAD part (closest-point distance at ``N_SAMPLES`` random
points on the mesh), the faces whose centroid lies farther than 2 s from the part, the
missed share of the part's shadow along the ray (%), the longest edge over s, the curtain
count (faces within 5 degrees of the line of sight, ``scanmesh.measures.curtains``), the
issue's long curtains (those with a longest edge over ``LONG_CURTAIN`` s) and the missed
share when they do not count (likewise the long sheets within ``SHEET_ANGLE``), the air
share (covered where the part casts no shadow) and the wall time. Per scan, the gap to the
best peer with and without its long curtains, and the missed share by the turn from the
ray of the true face seen (``TURN_CLASSES``). The sweep measures the grid rule's θ and k
on the same panel (turn angles and edge lengths of the faces of the plain range grid that
lie on the part and of those that do not). The timing compares the grid triangulation of a
1000 x 1000 range grid with the numpy range-grid triangulation in the same run (best of
``REPEATS``, interleaved).
"""

from __future__ import annotations

import argparse
import dataclasses
import math
import time
import warnings
from pathlib import Path

import numpy as np
from depth_jumps import open3d_ball_pivoting, pymeshlab_ball_pivoting, rocker_arm, to_axis_z
from quality import CAD, machine

import scanmesh
from scanmesh import _core
from scanmesh.evaluate.digitizer import cast_grid, simulate_range_scan
from scanmesh.evaluate.holdout import holdout_error
from scanmesh.evaluate.truth import TrueSurface, domain_error, height_error
from scanmesh.formats.grid import height_grid
from scanmesh.measures import curtains
from scanmesh.methods import DEFAULT_METHOD
from scanmesh.scan.planar import as_scan
from scanmesh.scan.projection import project
from scanmesh.stages.grid import grid_surface
from scanmesh.stages.hidden import hiding_faces

FRAN = Path(__file__).resolve().parents[1] / "tests" / "data" / "scans" / "fran_cut.vtk"
N_POINTS = 12_000
N_SAMPLES = 50_000
N_RAYS = 500_000
NOISE = 0.05  # x the spacing
GRAZING = 80.0  # degrees
ALPHAS = (1.5, 2.0, 3.0, 4.0)
SEED = 0
REPEATS = 5
TURNS = (70.0, 75.0, 80.0, 85.0, 88.0, 90.0)
FACTORS = (3.0, 4.0, 5.0, 6.0, 8.0, math.inf)
# annealing's (and LOP's) curtain rule at other angles than the default (0: off)
OTHER_CURTAIN_ANGLES = (0.0, 5.0)
# the long curtain: within 5 deg of the sight (``curtains``) and a longest edge over
# this many local grid spacings (on a simulated scan the local spacing is s everywhere)
LONG_CURTAIN = 4.0
# the sheets the grid dropped for their turn at θ = 80 deg (its default before 85): within
# 90 - 80 deg of the sight, as long
SHEET_ANGLE = 10.0
# classes of the true surface by its turn from the ray (degrees): < 60, 60-80, 80-88, > 88
TURN_CLASSES = (60.0, 80.0, 88.0)


def panel(cad: Path) -> list[tuple[str, object, str, str]]:
    """(name, CAD mesh or path, up, along) of every scan of the panel."""
    rocker = rocker_arm()
    return [
        ("pocket z", cad / "octagonal_pocket.ply", "z", "x"),
        ("pocket x", cad / "octagonal_pocket.ply", "x", "y"),
        ("fandisk y", cad / "fandisk.obj", "y", "x"),
        ("fandisk z", cad / "fandisk.obj", "z", "x"),
        ("fandisk x", cad / "fandisk.obj", "x", "y"),
        ("conrod y", cad / "conrod_slevin48_onshape.stl", "y", "x"),
        ("conrod z", cad / "conrod_slevin48_onshape.stl", "z", "x"),
        ("rocker arm z", rocker, "z", "x"),
        ("rocker arm y", rocker, "y", "x"),
    ]


def numpy_range_grid(grid: np.ndarray, points: np.ndarray) -> np.ndarray:
    """(M, 3) int64: every cell of ``grid`` split along its shorter 3-D diagonal (one triangle
    where a corner is missing), nothing dropped. The plain range-grid triangulation."""
    a, b = grid[:-1, :-1].ravel(), grid[:-1, 1:].ravel()
    d, e = grid[1:, :-1].ravel(), grid[1:, 1:].ravel()
    ha, hb, hd, he = a >= 0, b >= 0, d >= 0, e >= 0
    full = ha & hb & hd & he
    ae = np.einsum("ij,ij->i", points[e] - points[a], points[e] - points[a])
    bd = np.einsum("ij,ij->i", points[d] - points[b], points[d] - points[b])
    split_ae = full & (ae <= bd)
    split_bd = full & ~(ae <= bd)
    parts = [
        np.column_stack([a, b, e])[split_ae],
        np.column_stack([a, e, d])[split_ae],
        np.column_stack([a, b, d])[split_bd],
        np.column_stack([b, e, d])[split_bd],
        np.column_stack([b, e, d])[~ha & hb & hd & he],
        np.column_stack([a, e, d])[ha & ~hb & hd & he],
        np.column_stack([a, b, e])[ha & hb & ~hd & he],
        np.column_stack([a, b, d])[ha & hb & hd & ~he],
    ]
    return np.concatenate(parts).astype(np.int64)


def pyvista_alpha(points: np.ndarray, axis: str, alpha: float) -> np.ndarray:
    import pyvista as pv

    cloud = pv.PolyData(to_axis_z(points, axis))
    out = cloud.delaunay_2d(alpha=alpha)
    if out.n_points != len(points):
        raise RuntimeError("delaunay_2d changed the points")
    return out.regular_faces.astype(np.int64)


def meshes(sp, axis: str, s: float) -> list[tuple[str, np.ndarray, float]]:
    """Every method's faces on the scan ``sp`` (ScanPoints with a grid), with seconds."""
    out = []
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        for method in ("grid", "delaunay", "anneal", DEFAULT_METHOD):
            t0 = time.perf_counter()
            surface = scanmesh.reconstruct(sp, method)
            name = f"{method} (default)" if method == DEFAULT_METHOD else method
            out.append((f"scanmesh {name}", surface.faces, time.perf_counter() - t0))
        for angle in OTHER_CURTAIN_ANGLES:
            t0 = time.perf_counter()
            surface = scanmesh.reconstruct(sp, "anneal", curtain_angle=angle)
            name = f"scanmesh anneal (curtain_angle={angle:g})"
            out.append((name, surface.faces, time.perf_counter() - t0))
    t0 = time.perf_counter()
    out.append(("numpy range grid", numpy_range_grid(sp.grid, sp.points), time.perf_counter() - t0))
    peers = [(f"pyvista delaunay_2d(alpha={a:g} s)", pyvista_alpha, a * s) for a in ALPHAS]
    peers += [
        ("open3d ball pivoting (s, 2 s, 4 s)", open3d_ball_pivoting, s),
        ("pymeshlab ball pivoting", pymeshlab_ball_pivoting, s),
    ]
    for name, run, arg in peers:
        try:
            t0 = time.perf_counter()
            faces = run(sp.points, axis, arg)
            out.append((name, faces, time.perf_counter() - t0))
        except (ImportError, RuntimeError) as exc:
            print(f"  ({name} skipped: {exc})", flush=True)
    return out


def measure(
    name: str, cad, up: str, along: str, n_points: int, noise: float, grazing: float
) -> tuple[list[dict], dict]:
    """The rows of one scan (noise in spacings, grazing in degrees), and the sweep's raw
    figures of its plain range grid."""
    clean = simulate_range_scan(cad, up=up, along=along, n_points=n_points)
    s = float(clean.extra["spacing"])
    sp = simulate_range_scan(
        cad, up=up, along=along, n_points=n_points, noise=noise * s, seed=SEED, grazing=grazing
    )
    truth = TrueSurface(cad)
    _, frame = project(sp.points, up)
    rays = RayGrid(truth, frame, sp.up)
    rows = []
    for method, faces, seconds in meshes(sp, up, s):
        surface = scanmesh.Surface(vertices=sp.points, faces=faces, frame=frame)
        centroids = sp.points[faces].mean(axis=1)
        off = truth.distance(centroids)
        edges = np.linalg.norm(sp.points[faces] - sp.points[np.roll(faces, 1, axis=1)], axis=2)
        hanging = long_curtains(sp.points, faces, sp.up, s)
        domain = domain_error(surface, truth, n_rays=N_RAYS)
        missed = 100 * domain["missed_share"]
        sheets = long_curtains(sp.points, faces, sp.up, s, SHEET_ANGLE)
        bare, sheetless = missed, missed
        for drop, key in ((hanging, "bare"), (sheets, "sheetless")):
            if drop.any():
                rest = scanmesh.Surface(vertices=sp.points, faces=faces[~drop], frame=frame)
                share = 100 * domain_error(rest, truth, n_rays=N_RAYS)["missed_share"]
                bare, sheetless = (share, sheetless) if key == "bare" else (bare, share)
        rows.append(
            {
                "scan": name,
                "method": method,
                "points": len(sp.points),
                "faces": len(faces),
                "h_rms": height_error(surface, truth, n_samples=N_SAMPLES, seed=SEED)["h_rms"],
                "far": int((off > 2 * s).sum()),
                "missed": missed,
                "air": 100 * domain["air_share"],
                "edge": float(edges.max() / s),
                "curtains": curtains(sp.points, faces, sp.up).count,
                "long curtains": int(hanging.sum()),
                # missed % when the long curtains do not count as covering the part
                "missed bare": bare,
                # ... and when the long faces within SHEET_ANGLE of the sight do not count
                "long sheets": int(sheets.sum()),
                "missed sheetless": sheetless,
                # missed % of the part's shadow per class of TURN_CLASSES (own ray grid),
                # with every face and with the long curtains not counted
                "by turn": rays.missed_by_turn(sp.points, faces),
                "by turn bare": rays.missed_by_turn(sp.points, faces[~hanging]),
                "shadow by turn": rays.shadow_by_turn(),
                "seconds": seconds,
            }
        )
    print(f"  {name}: {len(sp.points):,} points, s = {s:.3g}", flush=True)
    return rows, sweep_figures(sp, truth, s)


def long_curtains(
    points: np.ndarray, faces: np.ndarray, sight: np.ndarray, s: float, within: float = 5.0
) -> np.ndarray:
    """(M,) bool: the faces that are curtains by the issue's definition: within ``within``
    degrees of the line of sight (5: ``curtains``'s angle) and a longest edge over
    LONG_CURTAIN x the local grid spacing ``s``."""
    tri = points[faces]
    longest = np.linalg.norm(tri - np.roll(tri, 1, axis=1), axis=2).max(axis=1)
    normal = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
    twice = np.linalg.norm(normal, axis=1)
    unit = np.asarray(sight, dtype=np.float64) / np.linalg.norm(sight)
    graze = (np.abs(normal @ unit) <= math.sin(math.radians(within)) * twice) & (twice > 0)
    return graze & (longest > LONG_CURTAIN * s)


class RayGrid:
    """Parallel rays along the line of sight over the part's shadow (about N_RAYS), each
    with the turn from the ray (degrees) of the true face the scanner sees there (the
    highest hit towards the scanner; NaN where the part casts no shadow)."""

    def __init__(self, truth: TrueSurface, frame, sight: np.ndarray) -> None:
        self.axes = np.column_stack([frame.u, frame.v])  # (3, 2): 3-D -> planar
        tri = truth.triangles
        uv = tri @ self.axes
        lo, hi = uv.reshape(-1, 2).min(axis=0), uv.reshape(-1, 2).max(axis=0)
        self.step = math.sqrt(float(np.prod(hi - lo)) / N_RAYS)
        self.shape = (int((hi - lo)[0] / self.step) + 1, int((hi - lo)[1] / self.step) + 1)
        self.origin = (float(lo[0]) + self.step / 2, float(lo[1]) + self.step / 2)
        s = np.asarray(sight, dtype=np.float64) / np.linalg.norm(sight)
        _, face = cast_grid(uv, tri @ s, self.origin, (self.step,) * 2, self.shape)
        normal = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
        cos = np.abs(normal @ s) / np.maximum(np.linalg.norm(normal, axis=1), 1e-300)
        turn = np.degrees(np.arccos(np.clip(cos, 0.0, 1.0)))
        #: (rays,) float64 turn of the seen true face, NaN outside the shadow
        self.turn = np.where(face >= 0, turn[np.maximum(face, 0)], np.nan)

    def missed_by_turn(self, points: np.ndarray, faces: np.ndarray) -> list[float]:
        """Missed % of the part's shadow per turn class (len(TURN_CLASSES) + 1 values)."""
        tri = points[faces] @ self.axes
        _, face = cast_grid(tri, np.zeros(tri.shape[:2]), self.origin, (self.step,) * 2, self.shape)
        inside = ~np.isnan(self.turn)
        missed = inside & (face < 0)
        which = np.digitize(self.turn[missed], TURN_CLASSES)
        counts = np.bincount(which, minlength=len(TURN_CLASSES) + 1)
        return list(100 * counts / inside.sum())

    def shadow_by_turn(self) -> list[float]:
        """% of the part's shadow per turn class."""
        turn = self.turn[~np.isnan(self.turn)]
        counts = np.bincount(np.digitize(turn, TURN_CLASSES), minlength=len(TURN_CLASSES) + 1)
        return list(100 * counts / len(turn))


def sweep_figures(sp, truth: TrueSurface, s: float) -> dict:
    """Per face of the plain range grid: its turn angle (degrees from the ray), longest edge
    (in s), area and centroid distance to the part (in s)."""
    faces = numpy_range_grid(sp.grid, sp.points)
    tri = sp.points[faces]
    normal = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
    length = np.linalg.norm(normal, axis=1)
    turn = np.degrees(np.arccos(np.clip(np.abs(normal @ sp.up) / length, 0.0, 1.0)))
    edges = np.linalg.norm(tri - np.roll(tri, 1, axis=1), axis=2).max(axis=1) / s
    off = truth.distance(tri.mean(axis=1)) / s
    return {"turn": turn, "edge": edges, "area": 0.5 * length, "off": off, "s": s}


def sweep(raw: list[dict]) -> str:
    """θ and k over the panel: what the plain range grid's faces measure, and for each rule
    the faces kept more than 2 s off the part, the RMS centroid distance of the kept faces
    (area-weighted, in s) and the area dropped of faces on the part (within 2 s)."""
    turn = np.concatenate([r["turn"] for r in raw])
    edge = np.concatenate([r["edge"] for r in raw])
    area = np.concatenate([r["area"] / r["s"] ** 2 for r in raw])
    off = np.concatenate([r["off"] for r in raw])
    on = off <= 2.0
    out = [
        f"Plain range grid over the panel: {on.sum():,} faces on the part (centroid within"
        f" 2 s), {(~on).sum():,} off it.",
        "",
        "| faces | turn from the ray, deg: p50 / p99 / p99.9 / max | longest edge / s: p50 /"
        " p99 / p99.9 / max |",
        "|---|---|---|",
    ]
    near = off <= 0.25
    for label, m in (
        ("within 0.25 s of the part", near),
        ("0.25 s to 2 s off", on & ~near),
        ("more than 2 s off", ~on),
    ):
        t, e = turn[m], edge[m]
        if len(t) == 0:
            continue
        out.append(
            f"| {label} ({m.sum():,}) | {np.percentile(t, 50):.1f} / {np.percentile(t, 99):.1f}"
            f" / {np.percentile(t, 99.9):.1f} / {t.max():.1f} | {np.percentile(e, 50):.2f} /"
            f" {np.percentile(e, 99):.2f} / {np.percentile(e, 99.9):.2f} / {e.max():.2f} |"
        )
    out += [
        "",
        "| θ (deg) | k | faces > 2 s off kept | RMS centroid distance / s | area on the part"
        " dropped (%) |",
        "|---:|---:|---:|---:|---:|",
    ]
    for theta in TURNS:
        for k in FACTORS:
            if theta not in (80.0, 90.0) and k not in (6.0, math.inf):
                continue
            keep = (turn <= theta) & (edge <= k)
            rms = math.sqrt(float((area[keep] * off[keep] ** 2).sum() / area[keep].sum()))
            out.append(
                f"| {theta:g} | {k:g} | {int((keep & ~on).sum()):,} | {rms:.3f} |"
                f" {100 * area[~keep & on].sum() / area[on].sum():.2f} |"
            )
    return "\n".join(out)


def table(rows: list[dict]) -> str:
    out = [
        "| scan | method | faces | height RMS / s | faces > 2 s off | missed % |"
        " air % | longest edge / s | curtains | long curtains | missed % without them |"
        " seconds |",
        "|---|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|",
    ]
    for r in rows:
        out.append(
            f"| {r['scan']} | {r['method']} | {r['faces']:,} | {r['h_rms'] / r['s']:.3g} |"
            f" {r['far']:,} | {r['missed']:.2f} | {r['air']:.2f} | {r['edge']:.1f} |"
            f" {r['curtains']:,} | {r['long curtains']:,} | {r['missed bare']:.2f} |"
            f" {r['seconds']:.2f} |"
        )
    return "\n".join(out)


def best_peer(rows: list[dict], scan: str, key: str = "missed") -> dict | None:
    """The peer's row (not scanmesh, not the plain range grid) with the least ``key`` on
    ``scan``."""
    peers = [
        r for r in rows if r["scan"] == scan and not r["method"].startswith(("scanmesh", "numpy"))
    ]
    return min(peers, key=lambda r: r[key]) if peers else None


def gaps(rows: list[dict], ours: str = "scanmesh grid") -> str:
    """Per scan: our missed % against the best peer's, with and without its long curtains
    (LONG_CURTAIN), and where the missed area lies by the true surface's turn from the
    ray (TURN_CLASSES; % of the part's shadow, on RayGrid's rays)."""
    edges = (0.0, *TURN_CLASSES, 90.0)
    names = [f"{a:g}-{b:g}°" for a, b in zip(edges, edges[1:], strict=False)]
    out = [
        "| scan | ours missed % | best peer | its missed % | its long curtains (5°) | its missed %"
        " without them | best peer without long curtains: missed % | gap (pp): with / without |"
        " its long sheets (10°) | its missed % without them |",
        "|---|---:|---|---:|---:|---:|---:|---|---:|---:|",
    ]
    where = [
        "| scan | turn of the true face | share of the shadow % | missed by ours | by the best"
        " peer | by the best peer without its long curtains |",
        "|---|---|---:|---:|---:|---:|",
    ]
    for scan in dict.fromkeys(r["scan"] for r in rows):
        mine = next((r for r in rows if r["scan"] == scan and r["method"] == ours), None)
        best, bare = best_peer(rows, scan), best_peer(rows, scan, "missed bare")
        if mine is None or best is None or bare is None:
            continue
        gap = (mine["missed"] - best["missed"], mine["missed"] - bare["missed bare"])
        out.append(
            f"| {scan} | {mine['missed']:.2f} | {best['method']} | {best['missed']:.2f} |"
            f" {best['long curtains']:,} | {best['missed bare']:.2f} |"
            f" {bare['missed bare']:.2f} ({bare['method']}) | {gap[0]:+.2f} / {gap[1]:+.2f} |"
            f" {best['long sheets']:,} | {best['missed sheetless']:.2f} |"
        )
        for k, name in enumerate(names):
            where.append(
                f"| {scan} | {name} | {mine['shadow by turn'][k]:.2f} | {mine['by turn'][k]:.2f} |"
                f" {best['by turn'][k]:.2f} | {best['by turn bare'][k]:.2f} |"
            )
    return "\n".join(out + [""] + where)


def summary(rows: list[dict]) -> str:
    """Per method over the panel: scans with a face > 2 s off, worst and mean missed %, the
    mean height RMS / s, total curtains, the largest longest edge / s, total seconds."""
    methods = list(dict.fromkeys(r["method"] for r in rows))
    scans = list(dict.fromkeys(r["scan"] for r in rows))
    best_peer_missed = {}
    for scan in scans:
        peers = [
            r["missed"]
            for r in rows
            if r["scan"] == scan and not r["method"].startswith(("scanmesh", "numpy"))
        ]
        best_peer_missed[scan] = min(peers) if peers else math.nan
    out = [
        "| method | scans with a face > 2 s off | faces > 2 s off | mean height RMS / s |"
        " mean missed % | worst missed − best peer's (pp) | curtains | longest edge / s |"
        " seconds |",
        "|---|---:|---:|---:|---:|---:|---:|---:|---:|",
    ]
    for m in methods:
        rs = [r for r in rows if r["method"] == m]
        gap = max(r["missed"] - best_peer_missed[r["scan"]] for r in rs)
        out.append(
            f"| {m} | {sum(r['far'] > 0 for r in rs)} / {len(rs)} | {sum(r['far'] for r in rs):,}"
            f" | {np.mean([r['h_rms'] / r['s'] for r in rs]):.3f}"
            f" | {np.mean([r['missed'] for r in rs]):.2f} | {gap:+.2f}"
            f" | {sum(r['curtains'] for r in rs):,} | {max(r['edge'] for r in rs):.1f}"
            f" | {sum(r['seconds'] for r in rs):.1f} |"
        )
    return "\n".join(out)


def tilted(up: str) -> np.ndarray:
    """A plane normal 30 degrees off the axis ``up`` (towards the next axis)."""
    axes = "xyz"
    k = axes.index(up)
    normal = np.zeros(3)
    normal[k] = math.cos(math.radians(30))
    normal[(k + 1) % 3] = math.sin(math.radians(30))
    return normal


def hidden(cad_dir: Path, n_points: int, noise: float, grazing: float) -> str:
    """Unstructured points with a known line of sight projected 30 degrees off it: Delaunay
    of the points alone (no line of sight) against ``reconstruct`` with the recorded ``up``
    (faces that would hide a sample dropped)."""
    out = [
        "| scan | faces hiding a sample, points alone | dropped with `up` | faces > 2 s off:"
        " alone / with `up` | missed %: alone / with `up` |",
        "|---|---:|---:|---|---|",
    ]
    for name, cad, up, along in panel(cad_dir):
        clean = simulate_range_scan(cad, up=up, along=along, n_points=n_points)
        s = float(clean.extra["spacing"])
        sp = simulate_range_scan(
            cad,
            up=up,
            along=along,
            n_points=n_points,
            noise=noise * s,
            seed=SEED,
            grazing=grazing,
        )
        unstructured = dataclasses.replace(sp, grid=None)
        truth = TrueSurface(cad)
        plane = tilted(up)
        _, frame = project(sp.points, up)
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            alone = scanmesh.delaunay(sp.points, plane=plane)
            kept = scanmesh.reconstruct(unstructured, "delaunay", plane=plane)
        cells = []
        for faces in (alone.faces, kept.faces):
            surface = scanmesh.Surface(vertices=sp.points, faces=faces, frame=frame)
            off = truth.distance(sp.points[faces].mean(axis=1))
            missed = 100 * domain_error(surface, truth, n_rays=N_RAYS)["missed_share"]
            cells.append((int((off > 2 * s).sum()), missed))
        hiding = len(hiding_faces(sp.points, alone.faces, sp.up))
        out.append(
            f"| {name} | {hiding:,} | {kept.options['hidden_dropped']:,} |"
            f" {cells[0][0]:,} / {cells[1][0]:,} | {cells[0][1]:.2f} / {cells[1][1]:.2f} |"
        )
        print(f"  {name}: hidden done", flush=True)
    return "\n".join(out)


def fran(path: Path) -> str:
    """fran_cut (a Cyberware scan, a structured VTK grid): curtains (faces within 5 degrees
    of the projection normal; the file records no line of sight) per method, with tac_1 and
    the holdout error (10 % of the points withheld, seed 0; the points alone, so LOP and
    annealing start from Delaunay there), LOP and annealing also at the
    curtain angles OTHER_CURTAIN_ANGLES (0: the rule off)."""
    sp = scanmesh.read(path)
    out = [
        f"{len(sp.points):,} points, grid {sp.grid.shape if sp.grid is not None else None}:",
        "",
        "| method | faces | curtains | curtain area % | longest / median edge | tac_1"
        " | holdout RMS | start |",
        "|---|---:|---:|---:|---:|---:|---:|---|",
    ]
    runs = [(m, {}) for m in ("delaunay", "shortest-path", "grid", "lop", "anneal")]
    runs += [(m, {"curtain_angle": a}) for m in ("lop", "anneal") for a in OTHER_CURTAIN_ANGLES]
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        for method, options in runs:
            s = scanmesh.reconstruct(sp, method, **options)
            edges = np.linalg.norm(sp.points[s.faces] - sp.points[np.roll(s.faces, 1, 1)], axis=2)
            c = s.options["curtains"]
            # the grid has no holdout (withheld samples leave no grid)
            held = holdout_error(sp.points, method, **options) if method != "grid" else None
            name = method + "".join(f" ({k}={v:g})" for k, v in options.items())
            out.append(
                f"| {name} | {len(s.faces):,} | {c['count']:,} | {100 * c['fraction']:.2f} |"
                f" {edges.max() / np.median(edges):.1f} | {s.quality.tac_1:.1f} |"
                f" {held['rms'] if held else math.nan:.4g} | {s.options.get('initial', '')} |"
            )
    return "\n".join(out)


def timing(n: int = 1000) -> str:
    """The grid triangulation of an n x n range grid against the numpy range-grid
    triangulation, same arrays, best of REPEATS interleaved."""
    i, j = np.mgrid[0:n, 0:n] / n
    z = 0.05 * np.sin(8 * i) * np.cos(6 * j) + 0.3 * ((np.abs(i - 0.5) < 0.2) & (j > 0.4))
    z[np.hypot(i - 0.3, j - 0.7) < 0.05] = np.nan  # a bore: no samples
    sp = height_grid(z, cell=1.0 / n)
    scan = as_scan(sp, plane="z")
    sight = np.array([0.0, 0.0, 1.0])
    best = {"numpy": math.inf, "core": math.inf, "stage": math.inf}
    for _ in range(REPEATS):
        t0 = time.perf_counter()
        plain = numpy_range_grid(scan.grid, scan.points)
        best["numpy"] = min(best["numpy"], time.perf_counter() - t0)
        t0 = time.perf_counter()
        core = _core.grid_triangulate(scan.grid, scan.uv, scan.points, sight)
        best["core"] = min(best["core"], time.perf_counter() - t0)
        t0 = time.perf_counter()
        stage = grid_surface(scan)
        best["stage"] = min(best["stage"], time.perf_counter() - t0)
    return "\n".join(
        [
            f"{len(scan.points):,} points ({n} x {n} grid, a bore of missing samples),"
            f" best of {REPEATS}:",
            "",
            "| | seconds | × numpy | faces |",
            "|---|---:|---:|---:|",
            f"| numpy range grid (nothing dropped) | {best['numpy']:.3f} | 1 | {len(plain):,} |",
            f"| `_core.grid_triangulate` | {best['core']:.3f} |"
            f" {best['core'] / best['numpy']:.2f} | {len(core.faces):,} |",
            f"| `grid_surface` (the method, with its Surface) | {best['stage']:.3f} |"
            f" {best['stage'] / best['numpy']:.2f} | {len(stage.faces):,} |",
        ]
    )


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--cad", type=Path, default=CAD, help=f"CAD folder (default {CAD})")
    ap.add_argument("--points", type=int, default=N_POINTS, help="points per scan")
    ap.add_argument("--only", choices=("panel", "time", "hidden", "fran"), help="run one part")
    ap.add_argument("--fran", type=Path, default=FRAN, help="fran_cut.vtk")
    ap.add_argument("--scans", nargs="*", help="subset of the panel's scan names")
    ap.add_argument("--noise", type=float, default=NOISE, help="noise sigma in spacings")
    ap.add_argument("--grazing", type=float, default=GRAZING, help="dropout angle, degrees")
    args = ap.parse_args()
    print(f"machine: {machine()}")
    print(
        f"{args.points:,} points per scan, noise {args.noise:g} s,"
        f" dropout beyond {args.grazing:g} deg"
    )
    if args.only == "hidden":
        print(hidden(args.cad, args.points, args.noise, args.grazing))
        return
    if args.only == "fran":
        print(fran(args.fran))
        return
    if args.only != "time":
        rows, raw = [], []
        for name, cad, up, along in panel(args.cad):
            if args.scans and name not in args.scans:
                continue
            got, figures = measure(name, cad, up, along, args.points, args.noise, args.grazing)
            for r in got:
                r["s"] = figures["s"]
            rows += got
            raw.append(figures)
        print(summary(rows), "\n")
        print(gaps(rows), "\n")
        print(sweep(raw), "\n")
        print(table(rows), "\n")
    if args.only != "panel":
        print(timing())
    print(f"machine after: {machine()}")


if __name__ == "__main__":
    main()
