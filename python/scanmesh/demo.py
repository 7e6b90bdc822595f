"""The embedded demo: a simulated scan of a connecting rod, and the rod's true surface.

The rod is the paper's reference part (Weinert, Mehnen and Prestifilippo, 1997: 14,339
points). The scan was made by :func:`scanmesh.evaluate.digitizer.simulate_scan` without noise, so
every point lies on :func:`demo_truth`; ``benches/make_demo.py`` regenerates it, and
``scanmesh/data/ATTRIBUTION.md`` gives the source, licence and settings.
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

if TYPE_CHECKING:
    import trimesh

#: Files inside the ``scanmesh.data`` package.
SCAN_FILE = "conrod_scan.npz"
TRUTH_FILE = "conrod_slevin48_onshape.stl.gz"
#: SHA-256 of the uncompressed STL (slevin48/3d, conrod.stl, commit 6c52a466).
TRUTH_SHA256 = "245274520eab8ba9b5b93aed6cb5f9ed787537fb9b623c7a1a28b0a9ac2e4754"
#: How the scan was made (see ATTRIBUTION.md).
SCAN_SETTINGS = {"up": "y", "along": "x", "n_points": 14_339, "noise": 0.0, "table": False}


def _read(name: str) -> bytes:
    try:
        return resources.files("scanmesh.data").joinpath(name).read_bytes()
    except FileNotFoundError:
        raise FileFormatError(f"the demo file {name} is missing from this installation") from None


def load_demo() -> tuple[np.ndarray, np.ndarray]:
    """The demo scan of the connecting rod.

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


def demo_truth() -> trimesh.Trimesh:
    """The connecting rod the demo was scanned from (524 vertices, 1,044 faces, inches).

    The known true surface, for height error and normal error of a reconstruction.
    """
    trimesh = import_interruptibly("trimesh")

    raw = gzip.decompress(_read(TRUTH_FILE))
    if hashlib.sha256(raw).hexdigest() != TRUTH_SHA256:
        raise FileFormatError(f"the demo file {TRUTH_FILE} is damaged (SHA-256 mismatch)")
    mesh = trimesh.load_mesh(io.BytesIO(raw), file_type="stl")
    return mesh
