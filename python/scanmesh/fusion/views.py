"""Range views for :func:`scanmesh.merge`: points in scanner coordinates with their pose.

A view's scanner looks down its own -z: it sits towards +z of its coordinates, and each
point is the first return of a ray parallel to z (the digitizers and range scanners
scanmesh reads: Cyberware range grids, the simulated digitizer). ``toward`` names another
direction; the points are then turned so that it becomes +z, and the pose with them.

The pose is a 4 × 4 matrix from scanner to world coordinates, ``world = R @ p + t`` with
``R`` a rotation (orthonormal, determinant +1; checked to 1e-6) and the last row 0 0 0 1.
"""

from __future__ import annotations

import os
import warnings
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from scanmesh.errors import ParameterError, ScanmeshWarning
from scanmesh.formats import read
from scanmesh.formats._source import InputFile, input_file
from scanmesh.formats.points import ScanPoints
from scanmesh.fusion.conf import conf_poses
from scanmesh.fusion.depth import view_spacing
from scanmesh.scan.axes import AxisSpec, parse_axis, scan_frame

#: Largest entry of ``RᵀR − I`` a pose's rotation may have.
RIGID_TOL = 1e-6

#: A view of a ``.conf`` with less than this share of its points near another view's
#: overlaps none: measured on the three Stanford sets in ../shared/data/multiview, aligned
#: views have 87-99 % of their points within 2 spacings of another view's, the same files
#: read with the other rotation convention a median of 1-11 %.
MIN_OVERLAP = 0.2

#: How near (in the views' median spacing) a point of another view counts as overlap.
OVERLAP_SPACINGS = 2.0

#: Points per view tested for overlap (a fixed-seed sample of larger views).
OVERLAP_SAMPLE = 2_000


@dataclass(frozen=True)
class View:
    """One range view: points as the scanner saw them and where the scanner stood."""

    #: (N, 3) float64 points in scanner coordinates, the scanner towards +z
    points: np.ndarray
    #: (4, 4) float64 scanner-to-world rigid motion
    pose: np.ndarray
    #: where the points came from (a file, or a description)
    source: str = "array"
    #: the file read for it, as it was when read (writers refuse to replace it), or None
    file: InputFile | None = None

    @property
    def world(self) -> np.ndarray:
        """(N, 3) float64 the points in world coordinates."""
        return self.points @ self.pose[:3, :3].T + self.pose[:3, 3]


def check_pose(pose: Any, where: str) -> np.ndarray:
    """``pose`` as a (4, 4) float64 rigid motion; ParameterError naming ``where`` and what is
    wrong (shape, non-finite entry, last row, scale, shear or reflection) otherwise."""
    try:
        m = np.asarray(pose, dtype=np.float64)
    except (TypeError, ValueError, OverflowError):
        raise ParameterError(f"{where}: a pose must be a 4 x 4 matrix of numbers") from None
    if m.shape != (4, 4):
        raise ParameterError(f"{where}: a pose must be a 4 x 4 matrix, got shape {m.shape}")
    if not np.isfinite(m).all():
        row, col = np.argwhere(~np.isfinite(m))[0]
        raise ParameterError(f"{where}: pose entry [{row}, {col}] is {float(m[row, col])}")
    if not np.allclose(m[3], [0.0, 0.0, 0.0, 1.0], rtol=0.0, atol=RIGID_TOL):
        raise ParameterError(f"{where}: a pose's last row must be 0 0 0 1, got {m[3].tolist()}")
    r = m[:3, :3]
    off = float(np.abs(r.T @ r - np.eye(3)).max())
    det = float(np.linalg.det(r))
    if off > RIGID_TOL or det <= 0.0:
        raise ParameterError(
            f"{where}: a pose must be rigid (a rotation and a translation); its 3 x 3 part has"
            f" |R^T R - I| = {off:.3g} and determinant {det:.6g}"
        )
    m[3] = (0.0, 0.0, 0.0, 1.0)
    return m


def toward_frame(toward: AxisSpec) -> np.ndarray:
    """(3, 3) rotation whose rows are scanner axes with ``toward`` as the last (+z) row."""
    up = parse_axis(toward, "toward")
    return scan_frame(up, "y" if abs(up[0]) > 0.9 else "x")


def _from_scan(
    scan: ScanPoints, pose: np.ndarray | None, turn: np.ndarray, where: str, file: InputFile | None
) -> View:
    if pose is None and scan.up is not None:
        # a scan that records its ray direction is in world coordinates already
        frame = scan_frame(scan.up, "y" if abs(scan.up[0]) > 0.9 else "x")
        motion = np.eye(4)
        motion[:3, :3] = frame.T
        return View(scan.points @ frame.T, motion, where, file)
    return _from_array(scan.points, np.eye(4) if pose is None else pose, turn, where, file)


def _from_array(
    points: Any, pose: Any, turn: np.ndarray, where: str, file: InputFile | None = None
) -> View:
    pts = np.asarray(points, dtype=np.float64)
    if pts.ndim != 2 or pts.shape[1] != 3:
        raise ParameterError(f"{where}: points must be an (N, 3) array, got shape {pts.shape}")
    if len(pts) == 0:
        raise ParameterError(f"{where}: a view needs points, got none")
    if not np.isfinite(pts).all():
        row = int(np.argwhere(~np.isfinite(pts))[0, 0])
        raise ParameterError(f"{where}: point {row} is not finite ({pts[row].tolist()})")
    m = check_pose(pose, where)
    # turn the scanner's direction onto +z: p' = T p, and the pose follows (world = M T⁻¹ p')
    back = np.eye(4)
    back[:3, :3] = turn.T
    return View(np.ascontiguousarray(pts @ turn.T), m @ back, where, file)


def as_views(
    items: Sequence[Any],
    *,
    poses: Sequence[Any] | None = None,
    toward: AxisSpec = "z",
) -> list[View]:
    """The views :func:`scanmesh.merge` takes, each checked.

    ``items`` holds paths (read with :func:`scanmesh.read`), ``ScanPoints``, ``View``s or
    ``(points, pose)`` pairs; ``poses`` (one 4 × 4 per item, or None) gives the poses of
    paths and ``ScanPoints`` (default: the identity, or the ray direction a simulated scan
    records). ``toward`` is the direction of the scanner in each view's own coordinates.
    """
    if isinstance(items, (str, os.PathLike, ScanPoints)) or not isinstance(items, Sequence):
        raise ParameterError("views must be a list of views (paths, ScanPoints or (points, pose))")
    if not items:
        raise ParameterError("merge needs at least one view, got none")
    if poses is not None and len(poses) != len(items):
        raise ParameterError(f"{len(poses)} poses given for {len(items)} views; give one per view")
    turn = toward_frame(toward)
    out = []
    for k, item in enumerate(items):
        pose = None if poses is None else poses[k]
        where = f"view {k}"
        if isinstance(item, View):
            chosen = item.pose if pose is None else pose
            out.append(_from_array(item.points, chosen, turn, where, item.file))
        elif isinstance(item, (str, os.PathLike)):
            file = input_file(item)  # recorded before the read: a later os.chdir cannot move it
            out.append(_from_scan(read(item), pose, turn, str(Path(item)), file))
        elif isinstance(item, ScanPoints):
            file = input_file(item.source) if item.source is not None else None
            out.append(_from_scan(item, pose, turn, f"{where} ({item.source})", file))
        elif isinstance(item, tuple) and len(item) == 2:
            if pose is not None:
                raise ParameterError(f"{where}: has its own pose; give poses for paths only")
            out.append(_from_array(item[0], item[1], turn, where))
        else:
            raise ParameterError(
                f"{where}: expected a path, ScanPoints or (points, pose), got {type(item).__name__}"
            )
    return out


def read_conf(path: str | os.PathLike, *, inverse_rotation: bool = True) -> list[View]:
    """The range scans a Stanford ``.conf`` file lists, read and posed (see
    :mod:`scanmesh.fusion.conf` for the format and the rotation convention: ``world =
    R(q)ᵀ p + t`` unless ``inverse_rotation=False``), ready for :func:`scanmesh.merge`. Each
    scan's scanner sits towards its +z. A view that overlaps no other (under
    :data:`MIN_OVERLAP` of its points near another view's: a wrong convention or a wrong
    pose) is warned about by name with its figure (:func:`overlaps`)."""
    views = [
        _from_array(read(scan).points, pose, np.eye(3), str(scan), input_file(scan))
        for scan, pose in conf_poses(path, inverse_rotation=inverse_rotation)
    ]
    if len(views) > 1:
        shares = overlaps(views)
        alone = [(v.source, share) for v, share in zip(views, shares, strict=True)]
        alone = [(name, share) for name, share in alone if share < MIN_OVERLAP]
        if alone:
            listed = ", ".join(f"{Path(name).name} {share:.0%}" for name, share in alone)
            warnings.warn(
                f"{path}: {len(alone)} of {len(views)} views overlap no other view (share of"
                f" their points within {OVERLAP_SPACINGS:g} spacings of another view's:"
                f" {listed}; aligned, the Stanford sets' views share 87-99 %): a wrong pose,"
                " or a file written as R(q) p + t (inverse_rotation=False reads it so)",
                ScanmeshWarning,
                stacklevel=2,
            )
    return views


def overlaps(views: Sequence[View], seed: int = 0) -> list[float]:
    """Per view, the share of (a sample of :data:`OVERLAP_SAMPLE` of) its world points
    within :data:`OVERLAP_SPACINGS` times the views' median spacing of another view's
    points. O(V² · OVERLAP_SAMPLE · log N)."""
    from scipy.spatial import cKDTree

    rng = np.random.default_rng(seed)
    reach = OVERLAP_SPACINGS * float(np.median([view_spacing(v.points[:, :2]) for v in views]))
    worlds = [v.world for v in views]
    trees = [cKDTree(w) for w in worlds]
    out = []
    for k, w in enumerate(worlds):
        probe = w if len(w) <= OVERLAP_SAMPLE else w[rng.choice(len(w), OVERLAP_SAMPLE, False)]
        near = np.zeros(len(probe), dtype=bool)
        for j, tree in enumerate(trees):
            if j != k:
                near |= tree.query(probe, distance_upper_bound=reach)[0] <= reach
        out.append(float(near.mean()))
    return out
