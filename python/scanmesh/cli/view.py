"""``scanmesh view``: a mesh in 3-D, as a self-contained HTML page or a GLB file."""

from __future__ import annotations

import argparse
import tempfile
import webbrowser
from pathlib import Path

from scanmesh.cli._common import _check_outputs, _Console
from scanmesh.cli.render import _mesh_file
from scanmesh.errors import ParameterError
from scanmesh.present.view import save_glb, save_html


def cmd_view(args: argparse.Namespace, con: _Console) -> int:
    """A self-contained HTML page (or GLB file) showing a mesh in 3-D, opened in a browser."""


    mesh_path = Path(args.mesh)
    out = Path(args.output) if args.output else None
    if out is not None and out.suffix.lower() not in (".html", ".htm", ".glb"):
        raise ParameterError(f"cannot write {out}: a view is written as .html or .glb")
    _check_outputs([mesh_path], [out])
    mesh = _mesh_file(mesh_path)
    if out is None:  # a fresh folder: nothing of the user's is overwritten
        out = Path(tempfile.mkdtemp(prefix="scanmesh-view-")) / f"{mesh_path.stem}.html"
    colors = {"color_by": args.color, "truth": args.truth, "up": args.up}
    if out.suffix.lower() == ".glb":
        save_glb(mesh, out, **colors)
    else:
        save_html(mesh, out, view=args.view, title=mesh_path.name, **colors)
    con.summary(f"wrote {out}")
    if not args.no_open and out.suffix.lower() != ".glb":
        if not webbrowser.open(out.resolve().as_uri()):
            con.out("no web browser found here: open the file in one")
    return 0
