"""The embedded data: the demo scan with its part, and the connecting rod's scan with its part.

- The **demo scan** (:func:`load_demo`) is what ``scanmesh demo`` reconstructs: Hoppe's
  fandisk (:func:`demo_part`, a CAD part with creases) turned so that its creases cross
  the scan lines and scanned with seeded noise: a part on which the triangulation decides
  how close the mesh comes to the surface.
- The **rod scan** (:func:`load_rod`) is the paper's reference part (Weinert, Mehnen and
  Prestifilippo, 1997: 14,339 points), made by
  :func:`scanmesh.evaluate.digitizer.simulate_scan` without noise, so every point lies on
  :func:`rod_truth`. Scanned along its thickness it is flat where the scan sees it (every
  tac 0): a test and benchmark input, nothing there for annealing to do.

``benches/make_demo.py`` regenerates both files, and ``scanmesh/data/ATTRIBUTION.md``
gives the sources, licences and settings.
"""

from __future__ import annotations

import gzip
import hashlib
import io
from importlib import resources
from typing import TYPE_CHECKING

import numpy as np

from scanmesh._interrupt import import_interruptibly
from scanmesh.errors import FileFormatError
from scanmesh.evaluate.digitizer import simulate_scan

if TYPE_CHECKING:
    import trimesh

#: Files inside the ``scanmesh.data`` package: the rod's scan and the rod.
SCAN_FILE = "conrod_scan.npz"
TRUTH_FILE = "conrod_slevin48_onshape.stl.gz"
#: SHA-256 of the uncompressed STL (slevin48/3d, conrod.stl, commit 6c52a466).
TRUTH_SHA256 = "245274520eab8ba9b5b93aed6cb5f9ed787537fb9b623c7a1a28b0a9ac2e4754"
#: How the scan was made (see ATTRIBUTION.md).
SCAN_SETTINGS = {"up": "y", "along": "x", "n_points": 14_339, "noise": 0.0, "table": False}

#: The part ``scanmesh demo`` scans: the fandisk (mikedh/trimesh, models/fandisk.obj).
PART_FILE = "fandisk.obj.gz"
#: SHA-256 of the uncompressed OBJ.
PART_SHA256 = "27e201141bf9c869b922ce4f03fdef7b5dfc62b7e721f77b44efae1e2aecdce9"
#: How ``scanmesh demo`` scans it: turned ``turn_deg`` degrees about ``up`` through its
#: centroid (its creases then cross the scan lines), scanned along ``up`` in lines along
#: ``along``, the spacing ``1 / cells`` of its larger extent across ``up``, Gaussian noise
#: of ``noise`` spacings, seeded: about 10,000 points.
PART_SCAN = {"turn_deg": 30.0, "up": "y", "along": "x", "cells": 150, "noise": 1 / 30, "seed": 0}


def _read(name: str) -> bytes:
    try:
        return resources.files("scanmesh.data").joinpath(name).read_bytes()
    except FileNotFoundError:
        raise FileFormatError(f"the demo file {name} is missing from this installation") from None


def load_demo() -> tuple[np.ndarray, np.ndarray]:
    """The demo scan, the one ``scanmesh demo`` reconstructs: :func:`demo_part` (the
    fandisk, turned) scanned along y with seeded noise (:func:`scan_demo_part`).

    Returns
    -------
    points : (N, 3) float64
        About 10,000 points in the part's units, line by line (lines along +x, stacked
        along -z, seen from +y).
    line_ids : (N,) int64
        Scan line of each point, 0..L-1.

    Made when called (deterministic, about a second): :func:`demo_part` is its truth.
    """
    points, line_ids, _ = scan_demo_part()
    return points, line_ids


def load_rod() -> tuple[np.ndarray, np.ndarray]:
    """The embedded scan of the connecting rod (no noise; its truth: :func:`rod_truth`).

    Returns
    -------
    points : (N, 3) float64
        About 14,339 points in inches, line by line (lines along +x, stacked along -z,
        seen from +y); the two bores and the outside are gaps in the lines.
    line_ids : (N,) int64
        Scan line of each point, 0..L-1.
    """
    with np.load(io.BytesIO(_read(SCAN_FILE)), allow_pickle=False) as data:
        points = np.ascontiguousarray(data["points"], dtype=np.float64)
        line_ids = np.ascontiguousarray(data["line_ids"], dtype=np.int64)
    return points, line_ids


def rod_truth() -> trimesh.Trimesh:
    """The connecting rod :func:`load_rod` was scanned from (524 vertices, 1,044 faces, inches).

    The known true surface, for height error and normal error of a reconstruction.
    """
    trimesh = import_interruptibly("trimesh")

    raw = gzip.decompress(_read(TRUTH_FILE))
    if hashlib.sha256(raw).hexdigest() != TRUTH_SHA256:
        raise FileFormatError(f"the demo file {TRUTH_FILE} is damaged (SHA-256 mismatch)")
    mesh = trimesh.load_mesh(io.BytesIO(raw), file_type="stl")
    return mesh


def demo_part() -> trimesh.Trimesh:
    """The demo's part, the fandisk as ``scanmesh demo`` scans it: turned :data:`PART_SCAN`
    ``turn_deg`` degrees about ``up`` through its centroid (2,877 vertices; the true surface
    of :func:`load_demo` and :func:`scan_demo_part`)."""
    trimesh = import_interruptibly("trimesh")

    raw = gzip.decompress(_read(PART_FILE))
    if hashlib.sha256(raw).hexdigest() != PART_SHA256:
        raise FileFormatError(f"the demo file {PART_FILE} is damaged (SHA-256 mismatch)")
    mesh = trimesh.load_mesh(io.BytesIO(raw), file_type="obj")
    axis = np.eye(3)["xyz".index(PART_SCAN["up"])]
    turn = trimesh.transformations.rotation_matrix(
        np.radians(PART_SCAN["turn_deg"]), axis, mesh.centroid
    )
    mesh.apply_transform(turn)
    return mesh


def scan_demo_part(part: trimesh.Trimesh | None = None) -> tuple[np.ndarray, np.ndarray, float]:
    """The demo scan of :func:`demo_part` (or of ``part``, that mesh), made now with
    :data:`PART_SCAN`'s settings: (points (N, 3) float64, line ids (N,) int64, spacing).
    Deterministic (seeded). O(rays x faces hit)."""
    mesh = demo_part() if part is None else part
    up = "xyz".index(PART_SCAN["up"])
    across = [k for k in range(3) if k != up]
    spacing = float(np.ptp(mesh.bounds[:, across], axis=0).max()) / PART_SCAN["cells"]
    points, line_ids = simulate_scan(
        mesh,
        up=PART_SCAN["up"],
        along=PART_SCAN["along"],
        spacing=spacing,
        noise=PART_SCAN["noise"] * spacing,
        seed=PART_SCAN["seed"],
    )
    return points, line_ids, spacing
