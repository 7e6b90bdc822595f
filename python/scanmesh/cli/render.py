"""``scanmesh render``: a flat-shaded PNG picture of a mesh file."""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np

from scanmesh._extras import require
from scanmesh.cli._common import _check_outputs, _check_png, _Console
from scanmesh.formats.mesh import load_mesh
from scanmesh.present.panels import render_panels
from scanmesh.present.render import auto_view as _auto_view
from scanmesh.present.render import height_axis, render_mesh


def _mesh_file(path: Path) -> tuple[np.ndarray, np.ndarray]:
    """(V, 3) float64 vertices and (F, 3) int64 faces of a mesh file, as trimesh reads it."""
    mesh = load_mesh(path)
    return np.asarray(mesh.vertices, dtype=np.float64), np.asarray(mesh.faces, dtype=np.int64)


def cmd_render(args: argparse.Namespace, con: _Console) -> int:
    """A flat-shaded PNG picture of a mesh file; with --color, the mesh at --size with a
    title and a colour bar beside it (unless --no-bar)."""
    mesh_path, out = Path(args.mesh), Path(args.output)
    _check_outputs([mesh_path], [out])
    _check_png(out)
    if args.color is not None and args.bar:  # before reading: say now what is missing
        require(
            "matplotlib.figure",
            "plots",
            "render --color (the title and colour bar beside the picture)",
            instead="give --no-bar: the coloured picture alone needs no extra",
        )
    vertices, faces = _mesh_file(mesh_path)
    camera = _auto_view(vertices, faces)
    if args.view is not None:
        camera["view"] = args.view
    if args.up is not None:
        camera["up"] = args.up
    height = height_axis(camera["up"]) if args.up is None else args.up
    colors = {"color_by": args.color, "truth": args.truth, "height": height}
    if args.color is not None and args.bar:  # the colours' meaning beside them
        render_panels(
            [(vertices, faces)],
            out,
            titles=[mesh_path.name],
            size=args.size,
            wire=args.wire,
            **colors,
            **camera,
        )
    else:
        render_mesh((vertices, faces), out, size=args.size, wire=args.wire, **colors, **camera)
    con.summary(f"wrote {out}")
    return 0
