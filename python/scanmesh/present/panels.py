"""Figures of several meshes side by side: one camera, one scale, titles, one colour bar.

:func:`render_panels` is the picture to show people: each mesh lit from one light
(flat-shaded, so the facets and the shape show), all seen by one camera at one scale, and
when coloured by a figure (height, tac, error against a truth) all on one colour scale
with its bar beside them, so equal colours mean equal values across the panels. One mesh
with ``color_by`` gives a single coloured picture with its bar. :func:`render_compare`
is the uncoloured comparison. Titles and the bar are drawn by matplotlib without pyplot
(the "plots" extra).
"""

from __future__ import annotations

import math
import os
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np

from scanmesh._extras import require
from scanmesh.errors import ParameterError
from scanmesh.formats.write import inputs_of
from scanmesh.present.render import (
    COLOR,
    DEFAULT_VIEW,
    VIRIDIS,
    ColorScale,
    _mesh_arrays,
    _png_path,
    _used,
    auto_view,
    camera,
    color_scale,
    colormap,
    drawn_values,
    face_values,
    height_axis,
    new_figure,
    save_figure,
    shade_mesh,
)
from scanmesh.scan.axes import AxisSpec

#: Inches above each panel for its title, and above all of them for the figure's title.
TITLE_INCHES: float = 0.45
SUPTITLE_INCHES: float = 0.5
#: Inches to the right of the panels for the colour bar, its ticks and its label.
BAR_INCHES: float = 1.1
#: Figure resolution (dots per inch): panel sizes are in these pixels.
DPI: int = 100


def _bar_label(scale: ColorScale) -> str:
    """The colour bar's label: the figure and its unit."""
    names = {"tac": "tac per face", "error": "distance to the truth", "height": "height"}
    name = names.get(scale.by, scale.by)
    return f"{name} ({scale.unit})" if scale.unit else name


def render_panels(
    meshes: Sequence[Any],
    path: str | os.PathLike,
    *,
    titles: Sequence[str] | None = None,
    color_by: str | None = None,
    truth: Any = None,
    view: AxisSpec | None = None,
    up: AxisSpec | None = None,
    height: AxisSpec | None = None,
    size: tuple[int, int] = (560, 420),
    columns: int | None = None,
    wire: bool = False,
    suptitle: str | None = None,
) -> Path:
    """Write meshes side by side to a PNG: lit, one camera, one scale, a title over each,
    and with ``color_by`` one colour scale and its bar.

    Parameters
    ----------
    meshes : sequence of Surface, trimesh.Trimesh or (vertices, faces)
        The panels, left to right then top to bottom (one mesh is one picture).
    path : str or PathLike
        The PNG to write (atomically; never over a mesh's scan file).
    titles : sequence of str, optional
        One per mesh (method and figures, say); default "mesh 1", "mesh 2", ...
    color_by : "tac", "height" or "error", optional
        Colour each face by that figure (:func:`scanmesh.present.render.face_values`; "error"
        needs ``truth``), every panel on one scale (tac: 0 to the 99th percentile of all
        panels' faces; others: their smallest to largest), with a colour bar. Default: one
        colour, no bar.
    truth : path, trimesh.Trimesh or TrueSurface, optional
        The true surface, for ``color_by="error"``.
    view, up : axis name or (3,) float, optional
        Direction from the parts to the eye and the model direction shown upwards; by
        default the camera :func:`scanmesh.present.render.auto_view` picks for the first
        mesh (three-quarter, from the side it faces).
    height : axis name or (3,) float, optional
        The direction of ``color_by="height"``; default the coordinate axis nearest ``up``
        (:func:`scanmesh.present.render.height_axis`): elevation on terrain.
    size : (width, height) int
        Pixels of each panel's picture.
    columns : int, optional
        Panels per row (default: all in one row up to 3, then rows of 3).
    wire : bool
        Draw the triangle edges too.
    suptitle : str, optional
        A title over the whole figure.

    Returns
    -------
    Path
        ``path``. O(total faces + pixels); needs matplotlib (the "plots" extra).

    Example: the Delaunay and the annealed mesh of one scan, lit, then coloured by tac::

        render_panels([delaunay, annealed], "side.png", titles=["Delaunay", "annealed"])
        render_panels([delaunay, annealed], "tac.png", titles=["Delaunay", "annealed"],
                      color_by="tac")
    """
    target = _png_path(path)
    if len(meshes) == 0:
        raise ParameterError("render_panels needs at least one mesh")
    if titles is None:
        titles = [f"mesh {k + 1}" for k in range(len(meshes))]
    if len(titles) != len(meshes):
        raise ParameterError(f"got {len(meshes)} meshes but {len(titles)} titles")
    cols = int(columns) if columns else min(len(meshes), 3)
    if cols < 1:
        raise ParameterError(f"columns must be at least 1, got {columns}")
    if truth is not None and color_by != "error":
        raise ParameterError("a truth is used only to colour by error (color_by='error')")
    arrays = [_mesh_arrays(m) for m in meshes]
    cam = auto_view(*arrays[0], getattr(meshes[0], "frame", None))
    cam = {"view": cam["view"] if view is None else view, "up": cam["up"] if up is None else up}
    scale = None
    colors: list[Any] = [COLOR] * len(arrays)
    if color_by is not None:
        along = height_axis(cam["up"]) if height is None else height
        figures = [face_values(a, color_by, truth=truth, up=along) for a in arrays]
        values = [drawn_values(v, color_by) for v, _ in figures]
        scale = color_scale(values, color_by, figures[0][1])
        colors = [colormap(v, scale.lo, scale.hi) for v in values]
    frame = camera(cam["view"], cam["up"])
    # one screen box for all, so equal sizes look equal
    xy = np.concatenate([(v[_used(f, len(v))] @ frame.T)[:, :2] for v, f in arrays])
    bounds = (xy.min(axis=0), xy.max(axis=0))
    images = [
        shade_mesh(a, size=size, wire=wire, color=c, bounds=bounds, **cam)
        for a, c in zip(arrays, colors, strict=True)
    ]
    rows = math.ceil(len(images) / cols)
    pic_w, pic_h = size[0] / DPI, size[1] / DPI
    top = SUPTITLE_INCHES if suptitle else 0.0
    right = BAR_INCHES if scale is not None else 0.0
    fig_w, fig_h = cols * pic_w + right, rows * (pic_h + TITLE_INCHES) + top
    fig = new_figure(fig_w, fig_h, DPI)
    for k, (image, title) in enumerate(zip(images, titles, strict=True)):
        r, c = divmod(k, cols)
        bottom = fig_h - top - (r + 1) * (pic_h + TITLE_INCHES)
        ax = fig.add_axes((c * pic_w / fig_w, bottom / fig_h, pic_w / fig_w, pic_h / fig_h))
        ax.imshow(image, interpolation="nearest")
        ax.set_axis_off()
        ax.set_title(str(title), fontsize=11, pad=6)
    if scale is not None:
        _colorbar(fig, scale, (cols * pic_w + 0.15) / fig_w, fig_w, fig_h, top)
    if suptitle:
        fig.suptitle(suptitle, fontsize=13, y=1 - 0.15 / fig_h)
    protect = [f for m in meshes for f in inputs_of(m)]
    return save_figure(fig, target, DPI, protect=protect)


def _colorbar(fig: Any, scale: ColorScale, left: float, fig_w: float, fig_h: float, top: float):
    """The viridis bar of ``scale`` in a slim axes at ``left`` (a share of the width)."""
    colors = require("matplotlib.colors", "plots", "colour bars")
    cm = require("matplotlib.cm", "plots", "colour bars")
    ramp = colors.LinearSegmentedColormap.from_list("scanmesh-viridis", list(VIRIDIS))
    lo, hi = scale.lo, scale.hi if scale.hi > scale.lo else scale.lo + 1.0
    mappable = cm.ScalarMappable(norm=colors.Normalize(lo, hi), cmap=ramp)
    span = fig_h - top - 2 * TITLE_INCHES
    ax = fig.add_axes((left, TITLE_INCHES / fig_h, 0.22 / fig_w, max(span, 0.5) / fig_h))
    bar = fig.colorbar(mappable, cax=ax)
    # every tick its own number (no "1e-9" offset above the bar: a flat part's tac scale)
    bar.formatter = require("matplotlib.ticker", "plots", "colour bars").FormatStrFormatter("%.3g")
    bar.update_ticks()
    bar.set_label(_bar_label(scale), fontsize=10)
    bar.ax.tick_params(labelsize=9)


def render_compare(
    meshes: Sequence[Any],
    path: str | os.PathLike,
    *,
    titles: Sequence[str] | None = None,
    size: tuple[int, int] = (560, 420),
    columns: int | None = None,
    view: AxisSpec = DEFAULT_VIEW,
    up: AxisSpec = "z",
    wire: bool = False,
    suptitle: str | None = None,
) -> Path:
    """Write several meshes side by side in one colour with titles, seen by one camera at
    one scale (:func:`render_panels` without colours; the default camera is the fixed
    three-quarter view from +z, as the benchmarks' pictures use)."""
    return render_panels(
        meshes,
        path,
        titles=titles,
        size=size,
        columns=columns,
        view=view,
        up=up,
        wire=wire,
        suptitle=suptitle,
    )
