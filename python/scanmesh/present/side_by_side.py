"""Meshes side by side in one picture: one camera, one scale, and, when coloured, one colour
scale with its bar, so that what differs between the pictures is the meshes alone.

Drawn with numpy alone, so ``scanmesh demo`` needs no extra; with matplotlib (the ``plots``
extra), :mod:`scanmesh.present.panels` draws the same with titles and a labelled bar.
"""

from __future__ import annotations

import os
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np

from scanmesh.errors import ParameterError
from scanmesh.formats.write import inputs_of, write_atomic
from scanmesh.present.render import (
    COLOR,
    ColorScale,
    _mesh_arrays,
    _png_path,
    _used,
    camera,
    color_scale,
    colormap,
    drawn_values,
    face_values,
    png_bytes,
    shade_mesh,
)
from scanmesh.scan.axes import AxisSpec

#: White columns between two pictures, and the colour bar's width, in pixels.
GAP = 12
BAR = 18


def shared_scale(meshes: Sequence[Any], by: str) -> ColorScale:
    """One colour scale for every mesh coloured by ``by`` ("tac" or "height"), by the rule
    of :func:`scanmesh.present.render.color_scale`. O(total faces)."""
    if by not in ("tac", "height"):
        raise ParameterError(f"side-by-side pictures colour by 'tac' or 'height', not {by!r}")
    values = [drawn_values(face_values(mesh, by)[0], by) for mesh in meshes]
    return color_scale(values, by, "rad" if by == "tac" else "")


def side_by_side(
    meshes: Sequence[Any],
    *,
    size: tuple[int, int] = (640, 480),
    view: AxisSpec = (1.0, 1.0, 1.0),
    up: AxisSpec = "z",
    wire: bool = False,
    color_by: str | None = None,
) -> tuple[np.ndarray, ColorScale | None]:
    """(height, width, 3) uint8 picture of ``meshes`` (Surfaces, trimesh meshes or
    (vertices, faces)) left to right, each ``size`` pixels, seen from ``view`` with ``up``
    upwards, all fitted to one screen box (one scale); coloured by ``color_by`` on the
    :func:`shared_scale`, with a bar at the right running from its low (bottom) to its high
    (top) colour, or plain. Returns the picture and the scale (None when plain).
    O(pixels + faces)."""
    if not meshes:
        raise ParameterError("side_by_side needs at least one mesh")
    frame = camera(view, up)
    boxes = []
    for mesh in meshes:
        vertices, faces = _mesh_arrays(mesh)
        seen = (vertices[_used(faces, len(vertices))] @ frame.T)[:, :2]
        boxes.append((seen.min(axis=0), seen.max(axis=0)))
    bounds = (np.min([b[0] for b in boxes], axis=0), np.max([b[1] for b in boxes], axis=0))
    scale = None if color_by is None else shared_scale(meshes, color_by)
    pictures = []
    for mesh in meshes:
        if scale is None:
            color: Any = COLOR
        else:
            values = drawn_values(face_values(mesh, scale.by)[0], scale.by)
            color = colormap(values, scale.lo, scale.hi)
        pictures.append(
            shade_mesh(mesh, size=size, view=view, up=up, wire=wire, color=color, bounds=bounds)
        )
    height = pictures[0].shape[0]
    gap = np.full((height, GAP, 3), 255, dtype=np.uint8)
    parts: list[np.ndarray] = []
    for k, picture in enumerate(pictures):
        parts += [gap, picture] if k else [picture]
    if scale is not None:
        ramp = colormap(np.linspace(scale.hi, scale.lo, height), scale.lo, scale.hi)
        bar = np.repeat(np.rint(ramp * 255).astype(np.uint8)[:, None, :], BAR, axis=1)
        parts += [gap, bar, gap[:, : GAP // 2]]
    return np.concatenate(parts, axis=1), scale


def render_side_by_side(
    meshes: Sequence[Any], path: str | os.PathLike, **options: Any
) -> tuple[Path, ColorScale | None]:
    """Write :func:`side_by_side` of ``meshes`` to the PNG file ``path`` (written whole, never
    over an input of the meshes); ``options`` as :func:`side_by_side`. Returns the path
    and the colour scale."""
    target = _png_path(path)
    image, scale = side_by_side(meshes, **options)
    protect = [p for mesh in meshes for p in inputs_of(mesh)]
    return write_atomic(target, [png_bytes(image)], protect=protect), scale
