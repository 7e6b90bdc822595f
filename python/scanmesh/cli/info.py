"""``scanmesh info``: what a scan file holds (points, extent, lines, noise, plane), or the
quality of a mesh file."""

from __future__ import annotations

import argparse
import warnings
from pathlib import Path

import numpy as np

from scanmesh import shape
from scanmesh.cli._common import _Console, _dumps, _fmt, _plural, _read_scan
from scanmesh.cli.compare import _sliver_deg
from scanmesh.cli.render import _mesh_file
from scanmesh.errors import DegenerateInputError
from scanmesh.measures import quality
from scanmesh.scan.lines import GAP_FACTOR
from scanmesh.scan.noise import noise
from scanmesh.scan.planar import PlanarScan, as_scan
from scanmesh.scan.spacing import MAX_EDGE_FACTOR
from scanmesh.scan.steep import STEEP_ANGLE_DEG
from scanmesh.stages.delaunay import delaunay


def cmd_info(args: argparse.Namespace, con: _Console) -> int:
    """Points, lines, extent, spacing and the share of steep triangles of a scan file."""
    source = Path(args.input)
    if _is_mesh_file(source):
        return _judge_mesh(source, con)
    scan = _read_scan(source, con.progress, args)  # the reader's details (format, line source)
    pts = scan.points
    # projected once for Delaunay, the lines and the noise estimate, on the plane chosen
    # (with the file's up) for None; the lines are detected once, for both
    planar = as_scan(pts, plane=args.plane, lines=scan.line_ids, up=scan.up)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # coincident points are counted below
        surface = delaunay(planar)
    # delaunay() trims at MAX_EDGE_FACTOR x the median nearest-neighbour spacing
    # (scanmesh.scan.spacing.trim_length): the spacing reported is that length over the factor
    spacing = float(surface.options["max_edge"]) / MAX_EDGE_FACTOR
    normal = np.asarray(surface.frame.normal, dtype=np.float64)
    steep = surface.steep_fraction
    lines, lines_from = _lines_info(scan, planar)
    sigma = _noise_or_none(planar)
    lo, hi = pts.min(axis=0), pts.max(axis=0)
    data = {
        "input": str(source),
        "format": scan.extra.get("format"),
        "points": int(len(pts)),
        "lines": lines,
        "lines_from": lines_from,
        "extent": {"min": lo, "max": hi, "size": hi - lo},
        "plane_normal": normal,
        "plane_choice": planar.choice.as_dict(normal) if planar.choice else None,
        "median_spacing": spacing,
        "noise": sigma,
        "delaunay_faces": int(len(surface.faces)),
        "coincident_points": int(len(surface.duplicates)),
        "steep_share": steep,
        "steep_deg": STEEP_ANGLE_DEG,
        "point_data": {k: str(v.dtype) for k, v in scan.point_data.items()},
        "georef": None if scan.georef is None else scan.georef.as_dict(),
    }
    if con.json:
        print(_dumps(data))
        return 0
    con.out(f"{source}")
    con.out(f"  points            {len(pts):,}")
    con.out(f"  scan lines        {_fmt(lines, ',')} ({lines_from})")
    _print_extent(con, lo, hi)
    chosen = f" (chosen: {planar.choice.chosen})" if planar.choice else ""
    con.out(f"  plane normal      {'  '.join(f'{x:.4g}' for x in normal)}{chosen}")
    con.out(f"  median spacing    {spacing:.6g} (nearest neighbour, in the plane)")
    if sigma is not None:
        con.out(
            f"  noise             {sigma:.3g} (sigma along the plane normal; {sigma / spacing:.2g}"
            " x spacing)"
        )
    con.out(f"  coincident        {len(surface.duplicates):,} points (in the plane)")
    con.out(
        f"  steep share       {100 * steep:.2f} % of {len(surface.faces):,} Delaunay triangles"
        f" tilt more than {STEEP_ANGLE_DEG:g} deg from the plane normal"
    )
    if scan.point_data:
        con.out(f"  per point         {', '.join(scan.point_data)}")
    if scan.georef is not None:
        g = scan.georef
        con.out(f"  crs               {g.crs or 'not recorded'}")
        con.out(
            f"  units             x, y: {g.horizontal_units or 'not recorded'};"
            f" z: {g.vertical_units or 'not recorded'}"
        )
    return 0


#: Endings that hold a mesh, never scan points: ``scanmesh info`` judges them.
MESH_ENDINGS = (".stl", ".obj", ".off", ".glb")


def _print_extent(con: _Console, lo: np.ndarray, hi: np.ndarray) -> None:
    """The min, max and size rows of ``scanmesh info``."""
    for label, vec in (("min", lo), ("max", hi), ("size", hi - lo)):
        con.out(f"  {label:<18}{'  '.join(f'{x:.6g}' for x in vec)}")


def _is_mesh_file(path: Path) -> bool:
    """A mesh file: a mesh-only ending, or a PLY whose header declares faces."""
    ending = path.suffix.lower()
    if ending in MESH_ENDINGS:
        return True
    if ending != ".ply" or not path.is_file():
        return False
    with open(path, "rb") as f:
        head = f.read(4096)
    header = head.split(b"end_header", 1)[0]
    return any(
        line.split()[:2] == [b"element", b"face"] and line.split()[2:3] != [b"0"]
        for line in header.splitlines()
    )


def _judge_mesh(path: Path, con: _Console) -> int:
    """``scanmesh info MESH``: the same quality figures every method is judged by."""
    vertices, faces = _mesh_file(path)
    q = quality(vertices, faces)
    lo, hi = vertices.min(axis=0), vertices.max(axis=0)
    loops = shape.boundary_loops(faces)
    data = {
        "input": str(path),
        "kind": "mesh",
        "vertices": int(len(vertices)),
        "faces": int(len(faces)),
        "extent": {"min": lo, "max": hi, "size": hi - lo},
        "area": shape.area(vertices, faces),
        "watertight": shape.is_watertight(faces),
        "boundary_loops": len(loops),
        "boundary_edges": int(sum(len(loop) for loop in loops)),
        "quality": q.as_dict(),
    }
    if con.json:
        print(_dumps(data))
        return 0
    con.out(f"{path} (a mesh)")
    con.out(f"  vertices          {len(vertices):,}")
    con.out(f"  faces             {len(faces):,}")
    _print_extent(con, lo, hi)
    con.out(f"  area              {data['area']:.6g} (model units squared)")
    closed = "yes (every edge on two faces)" if data["watertight"] else "no"
    con.out(f"  watertight        {closed}")
    con.out(
        f"  boundary          {_plural(len(loops), 'loop')} of"
        f" {_plural(data['boundary_edges'], 'edge')} (outline and holes)"
    )
    con.out(
        f"  tac_1 / 2 / inf   {q.tac_1:.4g} / {q.tac_2:.4g} / {q.tac_inf:.4g} rad"
        f" over {q.n_interior:,} interior vertices"
    )
    con.out(f"  min angle         {_fmt(q.min_angle_deg, '.2f')} deg")
    con.out(
        f"  slivers           {100 * q.sliver_fraction:.2f} % (smallest angle below"
        f" {_sliver_deg():g} deg)"
    )
    return 0


def _noise_or_none(planar: PlanarScan) -> float | None:
    """scanmesh.noise of the scan, or None when too few points allow an estimate."""
    try:
        return noise(planar)
    except DegenerateInputError:
        return None


def _lines_info(scan, planar: PlanarScan) -> tuple[int | None, str]:
    """Scan lines: from the file, else detected from the point order of the PlanarScan
    (kept with it, so the noise estimate reads the same lines)."""
    if scan.line_ids is not None:
        return int(scan.n_lines), f"from the file: {scan.extra.get('line_ids_from') or 'ids'}"
    ids = planar.detected_line_ids(GAP_FACTOR)
    return int(len(np.unique(ids))), "detected from the point order"
