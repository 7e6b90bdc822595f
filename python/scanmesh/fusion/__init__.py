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
from dataclasses import replace
from typing import Any

import numpy as np

from scanmesh import _core
from scanmesh._checks import check_options, power_of_two_exponent
from scanmesh._interrupt import interruptible
from scanmesh._memory import memory_room
from scanmesh._progress import Progress, Stage
from scanmesh.errors import DegenerateInputError, MemoryLimitError, ParameterError, ScanmeshWarning
from scanmesh.fusion.depth import DepthImage, depth_image, view_spacing
from scanmesh.fusion.grid import (
    MAX_VOXELS,
    OPTIONS,
    SIMPLIFY_VOXELS,
    TRUNCATION_VOXELS,
    grid_for,
)
from scanmesh.fusion.handles import HANDLE_LOOP, UNLINED_LOOP, cut_short_handles
from scanmesh.fusion.pieces import drop_specks
from scanmesh.fusion.register import refine_poses, view_residuals
from scanmesh.fusion.views import View, as_views
from scanmesh.scan.axes import AxisSpec
from scanmesh.surface import Surface

#: How far apart two views' samples may be to be paired by ``refine``, in spacings.
REFINE_REACH = 3.0

#: Returns trusted less than this (:func:`scanmesh.fusion.depth.trust`: near a range
#: grid's edge or a depth jump, at grazing angles) count in the fused distance by their
#: weight but place no vertex.
SAMPLE_TRUST = 1e-9

#: A view's margin around its returns (``_margins``), in its alignment residuals: the
#: residual is an RMS over the view's samples (its noise included), and the view's frame
#: is off by up to several times it where it matters, at the silhouettes (the dragon's views:
#: RMS residuals 0.20-0.30 mm, moved by up to 0.9 mm by ``refine_poses``). Measured on the
#: dragon's two series together (docs/benchmarks/merge.md): margins of 2 rays took the
#: holdout RMS from 0.355 to 0.235 mm; on the simulated parts (noise s / 30) the margins
#: round to 0 and nothing changes, where a margin of 2 rays on every view gave the fandisk
#: genus 57 (0 without).
MARGIN_RESIDUALS = 4.0

#: Samples of a view its alignment residual is measured on (a fixed-seed subset).
MARGIN_SAMPLES = 1000

#: A ``voxel`` below this share of the views' ray spacing is warned about: the nodes
#: around a ray then all look up that ray, and a run of rays whose returns were lost on a
#: surface (grazing angles) carves on through the part. On benches/merge.py's parts from
#: six views (docs/benchmarks/merge.md): none off at 0.7 spacing, the fandisk 1.5 % of its
#: area in tunnels at 0.5, and no part better than at one spacing but the blade (4 %).
FINE_VOXEL = 0.7


def _scaled(views: list[View], exponent: int) -> list[View]:
    """The views with points and translations times 2**-exponent (exact: a power of two),
    so that no distance, square or product of the fusion overflows or underflows at
    coordinates of 1e-300 or 1e300."""
    out = []
    for view in views:
        pose = view.pose.copy()
        pose[:3, 3] = np.ldexp(pose[:3, 3], -exponent)
        out.append(replace(view, points=np.ldexp(view.points, -exponent), pose=pose))
    return out


#: A view whose world coordinates are so large that neighbouring floats there are more
#: than this share of its ray spacing apart is refused: its points would be rounded together.
RESOLUTION_SHARE = 0.01


def _own_spacing(view: View) -> float:
    """The view's ray spacing, measured at its own unit scale (the nearest-neighbour
    search squares distances: 1e200 would overflow, 1e-200 underflow)."""
    e = power_of_two_exponent(view.points[:, :2])
    return math.ldexp(view_spacing(np.ldexp(view.points[:, :2], -e), view.source), e)


def _check_resolution(view: View, spacing: float) -> None:
    """Refuse a pose that moves the view where float64 cannot hold its points apart."""
    with np.errstate(over="ignore", invalid="ignore"):
        far = float(np.max(np.abs(view.world)))
    if not math.isfinite(far) or float(np.spacing(far)) > RESOLUTION_SHARE * spacing:
        raise DegenerateInputError(
            f"{view.source}: its pose puts its points {far:.3g} from the origin, where"
            f" neighbouring floats are {float(np.spacing(far)):.3g} apart against its ray"
            f" spacing {spacing:.3g}: the points would be rounded together; give poses in"
            " the part's frame (near the origin)"
        )


def merge(
    views: Sequence[Any],
    *,
    poses: Sequence[Any] | None = None,
    toward: AxisSpec = "z",
    voxel: float | None = None,
    truncation: float = TRUNCATION_VOXELS,
    max_voxels: int = MAX_VOXELS,
    refine: bool = False,
    simplify: float = SIMPLIFY_VOXELS,
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
    simplify : float
        Tolerance in voxels (>= 0) of the extracted mesh's simplification (quadric-error
        edge collapse, ``simplify.rs``): edges are collapsed while every vertex of the
        extracted mesh stays within ``simplify`` voxels of the result, so flat and gently
        curved parts get larger faces; the mesh stays closed and 2-manifold, with its
        genus, and the labels' borders stay. 0: none (a face pair per voxel crossing).
        ``Surface.options["simplified"]`` holds the faces before and after.
    progress : bool or callable
        As in :func:`scanmesh.reconstruct`: stages "refine", "integrate", "carve" (views)
        and "extract".

    Returns
    -------
    Surface
        New vertices (not the input points), faces counter-clockwise from outside,
        ``face_labels`` (M,) uint8 codes into ``Surface.LABELS``; the pieces under 1 % of
        the largest one's area are taken off (:mod:`scanmesh.fusion.pieces`), what went
        is ``options["specks_removed"]`` (pieces, faces, area, largest speck's faces);
        before the extraction, thin tunnels of nodes the views measured poorly are filled
        where that takes a handle off: ``options["thin_handles"]`` (the Euler
        characteristic gained, "handles"; the nodes filled, "closed"; the "largest" group
        filled at once); ``options["vote_margins"]``: per view, the rays around its returns
        within which a nearer surface keeps them from showing space empty (4 times the
        view's alignment residual against the others, in its rays: 0 for views that agree,
        so that a misaligned view's returns beside a silhouette do not cut a thin part off);
        after the simplification, every handle whose shortest non-separating loop is at
        most ``fusion.handles.HANDLE_LOOP`` voxels long is cut along that loop and both
        sides capped (faces ``filled``): ``options["short_handles"]`` lists the loops'
        lengths in voxels.
    """
    # every option checked (and max_voxels honoured) before a file is read or a byte allocated
    params = check_options(
        OPTIONS,
        {
            "voxel": voxel,
            "truncation": truncation,
            "max_voxels": max_voxels,
            "refine": refine,
            "simplify": simplify,
        },
        "merge",
    )
    try:
        return _merge(views, poses, toward, params, progress)
    except MemoryError as exc:  # numpy's or Python's: what the estimates did not foresee
        if isinstance(exc, MemoryLimitError):
            raise
        raise MemoryLimitError(
            f"merge: an allocation failed ({exc or 'out of memory'}); this process may take"
            f" {memory_room().limit}: use a larger voxel or fewer points"
        ) from None


def _merge(
    views: Sequence[Any],
    poses: Sequence[Any] | None,
    toward: AxisSpec,
    params: dict[str, Any],
    progress: Progress,
) -> Surface:
    """:func:`merge` once its options are checked."""
    timings: dict[str, float] = {}
    start = time.perf_counter()
    trunc = params["truncation"]
    given = as_views(views, poses=poses, toward=toward)
    own = [_own_spacing(v) for v in given]
    for view, spacing in zip(given, own, strict=True):
        _check_resolution(view, spacing)
    # work at unit scale: points and translations times a power of two, undone on the result
    # (one less than the largest magnitude's exponent: 2**exponent itself stays finite)
    exponent = (
        power_of_two_exponent(
            np.array([np.abs(a).max() for v in given for a in (v.points, v.pose[:3, 3])])
        )
        - 1
    )
    unit = math.ldexp(1.0, exponent)
    checked = _scaled(given, exponent)
    spacings = [math.ldexp(s, -exponent) for s in own]
    ray_spacing = float(np.median(spacings))
    residual = None
    if params["refine"] and len(checked) < 2:
        raise ParameterError(f"refine=True needs at least two views to align, got {len(checked)}")
    if params["refine"]:
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
        residual = {"before": before * unit, "after": after * unit}
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
    view_size = max(float(np.max(w.max(axis=0) - w.min(axis=0))) for w in world)
    # (np.ldexp: a voxel beyond the float range once scaled is inf, refused as too coarse)
    size_given = None if params["voxel"] is None else float(np.ldexp(params["voxel"], -exponent))
    grid = grid_for(
        lo,
        hi - lo,
        view_size,
        size_given,
        ray_spacing,
        trunc,
        params["max_voxels"],
        unit,
        params["voxel"],
        samples=np.concatenate(world),
    )
    size, dims = grid.voxel, np.array(grid.dims)
    if size_given is not None and size < FINE_VOXEL * ray_spacing:
        warnings.warn(
            f"merge: voxel {params['voxel']:g} is under {FINE_VOXEL:g} of the views' ray"
            f" spacing {ray_spacing * unit:g}: a run of rays whose returns were lost (at"
            " grazing angles) may carve through the part; a voxel of at least the"
            " spacing is safe",
            ScanmeshWarning,
            stacklevel=2,
        )
    volume = _core.FusionVolume(
        tuple(grid.origin), size, grid.dims, trunc * size, int(params["max_voxels"])
    )
    corners = grid.origin + np.array(
        [[i, j, k] for i in (0, 1) for j in (0, 1) for k in (0, 1)]
    ) * ((dims - 1) * size)
    images = []
    for view, spacing in zip(checked, spacings, strict=True):
        rot, shift = view.pose[:3, :3], view.pose[:3, 3]
        in_view = (corners - shift) @ rot  # the grid's corners in scanner coordinates
        window = np.array([in_view[:, :2].min(axis=0), in_view[:, :2].max(axis=0)])
        images.append(depth_image(view.points, max(spacing, 0.5 * size), window))
    margins = _margins(checked, images, REFINE_REACH * ray_spacing)
    native, samples, normals = [], [], []
    for view, image, margin in zip(checked, images, margins, strict=True):
        rot, shift = view.pose[:3, :3], view.pose[:3, 3]
        native.append(
            _core.DepthView(
                view.pose,
                image.origin,
                image.step,
                image.depth,
                image.cos,
                image.weight,
                margin=margin,
            )
        )
        # the samples that place the vertices: the trusted returns only
        good = image.weight.reshape(-1)[image.pixels] >= SAMPLE_TRUST
        samples.append(view.points[image.kept[good]] @ rot.T + shift)
        normals.append(image.normals[good] @ rot.T)
    del images
    timings["depth images"] = time.perf_counter() - start
    cost = float(grid.nodes)
    for name, call in (("integrate", volume.integrate), ("carve", volume.carve)):
        t0 = time.perf_counter()
        with Stage(progress, name, len(native)) as stage:
            for k, image_k in enumerate(native):
                interruptible(cost, call, image_k)
                stage.update(k + 1)
        timings[name] = time.perf_counter() - t0
    t0 = time.perf_counter()
    with Stage(progress, "extract", int(cost)) as stage:
        vertices, faces, labels, repaired, thin = interruptible(
            cost,
            volume.extract,
            np.ascontiguousarray(np.concatenate(samples)),
            np.ascontiguousarray(np.concatenate(normals)),
            native,
            stage.counter,
            watch=stage.follow,
        )
    vertices, faces, labels, specks = interruptible(
        len(faces), drop_specks, vertices, faces, labels
    )
    timings["extract"] = time.perf_counter() - t0
    simplified = None
    if params["simplify"] > 0 and len(faces):
        t0 = time.perf_counter()
        before = len(faces)
        vertices, faces, labels = interruptible(
            float(before),
            _core.simplify,
            np.ascontiguousarray(vertices),
            np.ascontiguousarray(faces, dtype=np.int64),
            np.ascontiguousarray(labels, dtype=np.uint8),
            params["simplify"] * size,
        )
        simplified = {"faces_before": before, "faces_after": len(faces)}
        timings["simplify"] = time.perf_counter() - t0
    t0 = time.perf_counter()
    vertices, faces, labels, loops = interruptible(
        float(len(faces)),
        cut_short_handles,
        vertices,
        faces,
        labels,
        HANDLE_LOOP * size,
        Surface.LABELS.index("filled"),
        np.concatenate(samples),
        UNLINED_LOOP * size,
    )
    timings["short handles"] = time.perf_counter() - t0
    if len(faces) == 0:
        raise DegenerateInputError(
            f"merge: no surface at voxel {size * unit:g}: no node of the"
            f" {' x '.join(map(str, grid.dims))} grid lies inside the views' surfaces; use a"
            f" voxel near the views' ray spacing ({ray_spacing * unit:.4g})"
        )
    return Surface(
        vertices=np.ldexp(vertices, exponent),
        faces=faces,
        method="merge",
        options={
            "views": len(checked),
            "voxel": size * unit,
            "truncation": trunc,
            "behind": min(trunc, _core.BEHIND_VOXELS),
            "grid": grid.dims,
            "allocated_voxels": volume.allocated,  # (with distances, with flags alone)
            "repaired_nodes": int(repaired),
            "thin_handles": thin,
            "vote_margins": margins,
            "short_handles": [round(loop.length / size, 2) for loop in loops],
            "specks_removed": specks,
            "simplified": simplified,
            "refine_residual": residual,
            "poses": [_unscaled(v.pose, exponent) for v in checked],
        },
        timings=timings,
        face_labels=labels,
        inputs=[v.file for v in given if v.file is not None],
    )


def _margins(views: list[View], images: list[DepthImage], reach: float) -> list[int]:
    """Per view, the rays around a return within which a nearer surface keeps that return
    from showing space empty (``_core.DepthView``'s ``margin``): :data:`MARGIN_RESIDUALS`
    times the view's alignment residual against the others
    (:func:`scanmesh.fusion.register.view_residuals`, on :data:`MARGIN_SAMPLES` of its
    samples), in its rays, rounded; 0 for a lone view or one that shares no surface."""
    if len(views) < 2:
        return [0] * len(views)
    residual = view_residuals(
        views,
        [image.normals for image in images],
        [image.kept for image in images],
        reach=reach,
        most=MARGIN_SAMPLES,
    )
    out = []
    for r, image in zip(residual, images, strict=True):
        rays = MARGIN_RESIDUALS * r / image.step if math.isfinite(r) else 0.0
        out.append(int(min(round(rays), _core.MAX_MARGIN)))
    return out


def _unscaled(pose: np.ndarray, exponent: int) -> np.ndarray:
    out = pose.copy()
    out[:3, 3] = np.ldexp(out[:3, 3], exponent)
    return out
