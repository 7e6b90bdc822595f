"""Several aligned range views fused into one closed mesh that says what it invented.

:func:`merge` builds a depth image per view (:mod:`scanmesh.fusion.depth`), averages their
truncated signed distances in a voxel grid and carves the space their rays crossed
(Curless & Levoy 1996; native, ``fusion/tsdf.rs``), then extracts the zero set as a
closed 2-manifold whose vertices sit on the samples' tangent planes
(``fusion/extract.rs``). Every face is labelled: ``measured`` (within the averaging band
of a sample), ``inferred`` (between space a ray crossed and space no ray entered: closed by
carving) or ``filled`` (closed with no evidence).

Memory grows with the surface, not its box: the grid is stored by blocks of 8³ nodes, 9
bytes per node only in the blocks some view's averaging band, silhouette or carving edge
crosses, 4 bytes per block elsewhere (``max_voxels`` bounds the nodes allocated: 64M,
576 MB). Besides: the extraction's per-surface-cell vertices and one depth image per view
(16 bytes per ray, and 8 for where a ray without a return stopped carving: the extraction
finds walls between the nodes on the rays).
"""

from __future__ import annotations

import math
import time
import warnings
from collections.abc import Sequence
from typing import Any

import numpy as np

from scanmesh import _core
from scanmesh._checks import POSITIVE
from scanmesh._interrupt import interruptible
from scanmesh._progress import Progress, Stage
from scanmesh.errors import ParameterError, ScanmeshWarning
from scanmesh.fusion.depth import depth_image, view_spacing
from scanmesh.fusion.pieces import drop_specks
from scanmesh.fusion.register import refine_poses
from scanmesh.fusion.views import as_views
from scanmesh.scan.axes import AxisSpec
from scanmesh.surface import Surface

#: Grid nodes allocated at most (blocks of 8³ near the surfaces; 9 bytes each), unless
#: ``max_voxels`` says otherwise.
MAX_VOXELS = 64_000_000

#: Nodes along a side of the grid's blocks (the core's ``fusion::blocks::BLOCK``).
BLOCK = 8

#: The default truncation of the signed distance, in voxels.
TRUNCATION_VOXELS = 3.0

#: How far apart two views' samples may be to be paired by ``refine``, in spacings.
REFINE_REACH = 3.0

#: Returns trusted less than this (:func:`scanmesh.fusion.depth.trust`: near a range
#: grid's edge or a depth jump, at grazing angles) count in the fused distance by their
#: weight but place no vertex.
SAMPLE_TRUST = 1e-9

#: A ``voxel`` below this share of the views' ray spacing is warned about: the nodes
#: around a ray then all look up that ray, and a run of rays whose returns were lost on a
#: surface (grazing angles) carves on through the part. On benches/merge.py's parts from
#: six views (docs/benchmarks/merge.md): none off at 0.7 spacing, the fandisk 1.5 % of its
#: area in tunnels at 0.5, and no part better than at one spacing but the blade (4 %).
FINE_VOXEL = 0.7


def _near_samples(points: np.ndarray, origin: np.ndarray, size: float) -> int:
    """Grid nodes in the blocks holding a sample or next to one (26 neighbours): what the
    fusion allocates at least, as it allocates the blocks a surface's band crosses."""
    keys = np.unique(np.floor((points - origin) / (BLOCK * size)).astype(np.int64), axis=0)
    offsets = np.array([[i, j, k] for i in (-1, 0, 1) for j in (-1, 0, 1) for k in (-1, 0, 1)])
    near = np.unique((keys[:, None, :] + offsets[None]).reshape(-1, 3), axis=0)
    return len(near) * BLOCK**3


def merge(
    views: Sequence[Any],
    *,
    poses: Sequence[Any] | None = None,
    toward: AxisSpec = "z",
    voxel: float | None = None,
    truncation: float = TRUNCATION_VOXELS,
    max_voxels: int = MAX_VOXELS,
    refine: bool = False,
    progress: Progress = False,
) -> Surface:
    """One closed mesh from aligned range views, with a label per face.

    Parameters
    ----------
    views : list
        Paths (read with :func:`scanmesh.read`), ``ScanPoints``, :class:`scanmesh.View`s
        (:func:`scanmesh.read_conf` gives them) or ``(points, pose)`` pairs: (N, 3) points
        in scanner coordinates and the (4, 4) scanner-to-world rigid motion.
    poses : list of (4, 4), optional
        The poses of paths and ``ScanPoints`` items (default: the identity, or the ray
        direction a simulated range scan records).
    toward : "z", "-x", ... or (3,)
        Where the scanner sits in each view's own coordinates (its rays run along it).
    voxel : float, optional
        Grid spacing in world units (default: the median spacing of the views, made larger
        when the blocks near the samples would exceed ``max_voxels``); below 0.7 of that
        spacing a warning says that lost returns may carve through the part.
    truncation : float
        How far in front of a view's surface its distance counts, in voxels (>= 1); behind
        it, at most ``_core.BEHIND_VOXELS`` (1.5: a view guesses solid behind what it saw,
        and on a part thinner than a longer band that guess would push the far side out).
    max_voxels : int
        Most grid nodes allocated (blocks of 8³ nodes where the surfaces, silhouettes and
        carving edges pass; the rest of the box costs 4 bytes per block): a ``voxel``
        whose blocks near the samples alone exceed it is refused, the default voxel is
        made larger until they do not, and fusion that would allocate more stops with a
        ``ParameterError``.
    refine : bool
        First refine the poses by point-to-plane ICP between overlapping views
        (:func:`scanmesh.fusion.register.refine_poses`; the first view fixes the world); the
        residual before and after is ``Surface.options["refine_residual"]``.
    progress : bool or callable
        As in :func:`scanmesh.reconstruct`: stages "refine", "integrate", "carve" (views)
        and "extract".

    Returns
    -------
    Surface
        New vertices (not the input points), faces counter-clockwise from outside,
        ``face_labels`` (M,) uint8 codes into ``Surface.LABELS``; the pieces under 1 % of
        the largest one's area are taken off (:mod:`scanmesh.fusion.pieces`), what went
        is ``options["specks_removed"]`` (pieces, faces, area, largest speck's faces).
    """
    timings: dict[str, float] = {}
    start = time.perf_counter()
    checked = as_views(views, poses=poses, toward=toward)
    trunc = POSITIVE.check(truncation, "truncation")
    if trunc < 1.0:
        raise ParameterError(f"truncation must be at least 1 voxel, got {truncation!r}")
    if isinstance(max_voxels, bool) or not isinstance(max_voxels, (int, np.integer)):
        raise ParameterError(f"max_voxels must be an integer, got {max_voxels!r}")
    if not isinstance(refine, bool):
        raise ParameterError(f"refine must be True or False, got {refine!r}")
    spacings = [view_spacing(v.points[:, :2]) for v in checked]
    ray_spacing = float(np.median(spacings))
    residual = None
    if refine:
        t0 = time.perf_counter()
        with Stage(progress, "refine", len(checked), blocking=True):
            own = [
                depth_image(v.points, s, np.array([v.points[:, :2].min(0), v.points[:, :2].max(0)]))
                for v, s in zip(checked, spacings, strict=True)
            ]
            checked, before, after = refine_poses(
                checked,
                [image.normals for image in own],
                [image.kept for image in own],
                reach=REFINE_REACH * ray_spacing,
            )
        residual = {"before": before, "after": after}
        if math.isnan(before):
            warnings.warn(
                "refine: the views share no surface (no samples of two views within"
                f" {REFINE_REACH:g} spacings with agreeing normals); poses left as given",
                ScanmeshWarning,
                stacklevel=2,
            )
        timings["refine"] = time.perf_counter() - t0
    world = [v.world for v in checked]
    lo = np.min([w.min(axis=0) for w in world], axis=0)
    hi = np.max([w.max(axis=0) for w in world], axis=0)
    extent = hi - lo

    def grid_for(size: float) -> tuple[np.ndarray, np.ndarray]:
        # half a voxel more on the low side: the part's extreme faces (and CAD faces on
        # round coordinates) fall between node layers, not on one, where the sign of the
        # distance would be noise and the surface would fold between two layers of cells
        margin = (trunc + 2.0) * size
        dims = np.ceil((extent + 2 * margin) / size).astype(np.int64) + 2
        return lo - margin - 0.5 * size, dims

    samples_world = np.concatenate(world)
    if voxel is None:
        size = ray_spacing
        origin, dims = grid_for(size)
        for _ in range(4):  # the blocks near a surface scale as 1 / voxel²
            need = _near_samples(samples_world, origin, size)
            if need <= max_voxels:
                break
            size *= math.sqrt(need / max_voxels) * 1.01
            origin, dims = grid_for(size)
    else:
        size = POSITIVE.check(voxel, "voxel")
        if size < FINE_VOXEL * ray_spacing:
            warnings.warn(
                f"merge: voxel {voxel:g} is under {FINE_VOXEL:g} of the views' ray spacing"
                f" {ray_spacing:g}: a run of rays whose returns were lost (at"
                " grazing angles) may carve through the part; a voxel of at least the"
                " spacing is safe",
                ScanmeshWarning,
                stacklevel=2,
            )
        origin, dims = grid_for(size)
        need = _near_samples(samples_world, origin, size)
        if need > max_voxels:
            larger = size * math.sqrt(need / max_voxels) * 1.01
            raise ParameterError(
                f"voxel {voxel!r} needs about {need:,} grid nodes near the samples, over"
                f" max_voxels={max_voxels:,}; use voxel of about {larger:.3g} or more"
            )
    volume = _core.FusionVolume(
        tuple(origin), size, tuple(int(d) for d in dims), trunc * size, int(max_voxels)
    )
    corners = origin + np.array([[i, j, k] for i in (0, 1) for j in (0, 1) for k in (0, 1)]) * (
        (dims - 1) * size
    )
    native, samples, normals = [], [], []
    for view, spacing in zip(checked, spacings, strict=True):
        rot, shift = view.pose[:3, :3], view.pose[:3, 3]
        in_view = (corners - shift) @ rot  # the grid's corners in scanner coordinates
        window = np.array([in_view[:, :2].min(axis=0), in_view[:, :2].max(axis=0)])
        image = depth_image(view.points, max(spacing, 0.5 * size), window)
        native.append(
            _core.DepthView(
                view.pose, image.origin, image.step, image.depth, image.cos, image.weight
            )
        )
        # the samples that place the vertices: the trusted returns only
        good = image.weight.reshape(-1)[image.pixels] >= SAMPLE_TRUST
        samples.append(view.points[image.kept[good]] @ rot.T + shift)
        normals.append(image.normals[good] @ rot.T)
    timings["depth images"] = time.perf_counter() - start
    cost = float(np.prod(dims))
    for name, call in (("integrate", volume.integrate), ("carve", volume.carve)):
        t0 = time.perf_counter()
        with Stage(progress, name, len(native)) as stage:
            for k, image_k in enumerate(native):
                interruptible(cost, call, image_k)
                stage.update(k + 1)
        timings[name] = time.perf_counter() - t0
    t0 = time.perf_counter()
    with Stage(progress, "extract", int(cost), blocking=True):
        vertices, faces, labels, repaired = interruptible(
            cost,
            volume.extract,
            np.ascontiguousarray(np.concatenate(samples)),
            np.ascontiguousarray(np.concatenate(normals)),
            native,
        )
    vertices, faces, labels, specks = drop_specks(vertices, faces, labels)
    timings["extract"] = time.perf_counter() - t0
    return Surface(
        vertices=vertices,
        faces=faces,
        method="merge",
        options={
            "views": len(checked),
            "voxel": size,
            "truncation": trunc,
            "behind": min(trunc, _core.BEHIND_VOXELS),
            "grid": tuple(int(d) for d in dims),
            "allocated_voxels": volume.allocated,  # (with distances, with flags alone)
            "repaired_nodes": int(repaired),
            "specks_removed": specks,
            "refine_residual": residual,
            "poses": [v.pose for v in checked],
        },
        timings=timings,
        face_labels=labels,
    )
