"""``scanmesh merge``: aligned range views (a Stanford ``.conf``, or scans with a poses file)
fused into one closed mesh with a label per face."""

from __future__ import annotations

import argparse
import dataclasses
import json
import time
from pathlib import Path
from typing import Any

import numpy as np

from scanmesh import shape
from scanmesh._interrupt import interruptible
from scanmesh.cli._common import _check_outputs, _Console, _dumps
from scanmesh.errors import FileFormatError, ParameterError
from scanmesh.formats._source import read_bytes
from scanmesh.fusion import merge
from scanmesh.fusion.conf import conf_poses
from scanmesh.fusion.grid import OPTIONS
from scanmesh.fusion.pieces import Piece, pieces
from scanmesh.fusion.views import check_pose, read_conf
from scanmesh.surface import check_ending


def read_poses(path: Path, scans: list[Path]) -> list[np.ndarray]:
    """The poses of a ``--poses`` JSON file: a list of 4 x 4 matrices, one per scan in the
    order given, or an object from scan file name to its matrix. Each is checked here
    (numbers, shape, finite, rigid), so a bad one is a FileFormatError naming the file,
    the pose and its scan."""
    where = f"--poses {path}"
    try:
        data: Any = json.loads(read_bytes(path).decode("utf-8"))
    except (UnicodeDecodeError, json.JSONDecodeError, RecursionError) as exc:
        reason = "nested too deeply" if isinstance(exc, RecursionError) else str(exc)
        raise FileFormatError(f"{where}: not a JSON file of poses ({reason})") from None
    except FileFormatError as exc:
        raise FileFormatError(f"--poses {exc}") from None
    if isinstance(data, dict):
        missing = [s.name for s in scans if s.name not in data and str(s) not in data]
        if missing:
            raise FileFormatError(f"{where}: no pose for {', '.join(missing)}")
        data = [data.get(str(s), data.get(s.name)) for s in scans]
    if not isinstance(data, list) or len(data) != len(scans):
        count = len(data) if isinstance(data, list) else "no list of"
        raise FileFormatError(
            f"{where}: expected one 4 x 4 pose per scan ({len(scans)}), got {count} poses"
        )
    out = []
    for k, (pose, scan) in enumerate(zip(data, scans, strict=True)):
        try:
            out.append(check_pose(pose, f"{where}, pose {k} ({scan.name})"))
        except ParameterError as exc:
            raise FileFormatError(str(exc)) from None
    return out


def _pieces_text(parts: list[Piece], listed: int = 5) -> str:
    """``1 piece (1 closed, genus 0)`` or ``3 pieces (2 closed, genus 2, 0; 1 not closed, 2
    holes)``: the genus of each closed piece (the first ``listed``), the holes of the rest."""
    closed = [p for p in parts if p.closed]
    open_ = [p for p in parts if not p.closed]
    words = []
    if closed:
        genera = ", ".join(f"{p.genus:g}" for p in closed[:listed])
        more = f" and {len(closed) - listed} more" if len(closed) > listed else ""
        words.append(f"{len(closed)} closed, genus {genera}{more}")
    if open_:
        words.append(f"{len(open_)} not closed, {sum(p.holes for p in open_)} holes")
    count = f"{len(parts)} piece{'s' if len(parts) != 1 else ''}"
    return f"{count} ({'; '.join(words)})" if words else "no faces"


def cmd_merge(args: argparse.Namespace, con: _Console) -> int:
    """Fuse the views, write the mesh, report its pieces (the genus of each closed one, the
    holes of the others), the specks taken off, the area of each label and the creases."""
    inputs = [Path(p) for p in args.inputs]
    out = Path(args.output)
    check_ending(out)
    confs = [p for p in inputs if p.suffix.lower() == ".conf"]
    if confs and len(inputs) > 1:
        raise ParameterError("give one .conf file, or scan files with --poses, not both")
    if confs and args.poses is not None:
        raise ParameterError("--poses is for scan files; a .conf file holds its own poses")
    if args.forward_rotation and not confs:
        raise ParameterError("--forward-rotation is for a .conf file's quaternions")
    # the flags of the options table, checked by it under the flag's name
    options = {
        o.name: o.check(getattr(args, o.name), o.flag)
        for o in OPTIONS
        if getattr(args, o.name) is not None
    }
    scans = [s for s, _ in conf_poses(confs[0])] if confs else inputs
    _check_outputs([*inputs, *scans], [out])  # the scans a .conf lists are inputs too
    t0 = time.perf_counter()
    if confs:
        views: list[Any] = read_conf(confs[0], inverse_rotation=not args.forward_rotation)
        poses = None
    else:
        views = [str(p) for p in inputs]
        poses = read_poses(Path(args.poses), inputs) if args.poses else None
    surface = merge(views, poses=poses, toward=args.toward, progress=con.progress, **options)
    surface.save(out, progress=con.progress)
    elapsed = time.perf_counter() - t0
    # in a worker, which numpy's long calls leave the GIL to: Ctrl-C within the wait's slice
    parts = interruptible(len(surface.faces), pieces, surface.vertices, surface.faces)
    closed = bool(parts) and all(p.closed for p in parts)
    euler = interruptible(len(surface.faces), shape.euler_characteristic, surface.faces)
    areas = surface.label_areas or {}
    row = {
        "inputs": [str(p) for p in inputs],
        "output": str(out),
        "views": surface.options["views"],
        "voxel": surface.options["voxel"],
        "vertices": len(surface.vertices),
        "faces": len(surface.faces),
        "closed": closed,
        "euler_characteristic": euler,
        "pieces": [dataclasses.asdict(p) for p in parts],
        "holes": sum(p.holes for p in parts),
        "specks_removed": surface.options["specks_removed"],
        "thin_handles": surface.options["thin_handles"],
        "short_handles": surface.options["short_handles"],
        "area": areas,
        "creases": len(surface.creases),
        "refine_residual": surface.options["refine_residual"],
        "time_s": elapsed,
    }
    if con.json:
        print(_dumps(row))
        return 0
    total = sum(areas.values()) or 1.0
    share = ", ".join(f"{k} {v:.6g} ({100 * v / total:.1f} %)" for k, v in areas.items())
    shape_text = _pieces_text(parts)
    gone = surface.options["specks_removed"]
    if gone["pieces"]:
        shape_text += (
            f" ({gone['pieces']} specks taken off: {gone['faces']:,} faces, area"
            f" {gone['area']:.3g}, the largest {gone['largest']} faces)"
        )
    thin = surface.options["thin_handles"]
    if thin["handles"]:
        shape_text += (
            f" ({thin['handles']} thin handles taken off: {thin['closed']:,} nodes filled,"
            f" at most {thin['largest']} at once)"
        )
    loops = surface.options["short_handles"]
    if loops:
        shape_text += (
            f" ({len(loops)} short handles cut: loops {min(loops):.3g}-{max(loops):.3g}"
            " voxels long)"
        )
    if row["refine_residual"]:
        res = row["refine_residual"]
        con.summary(f"poses refined: residual {res['before']:.4g} -> {res['after']:.4g}")
    con.summary(
        f"wrote {out}: {len(surface.faces):,} faces from {row['views']} views"
        f" (voxel {row['voxel']:.4g}), {shape_text}; area {share};"
        f" {row['creases']} crease lines ({elapsed:.2f} s)"
    )
    return 0
