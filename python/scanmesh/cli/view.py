"""``scanmesh view``: a mesh in 3-D, as a self-contained HTML page or a GLB file."""

from __future__ import annotations

import argparse
import contextlib
import os
import stat
import tempfile
import time
import webbrowser
from pathlib import Path

from scanmesh.cli._common import _check_outputs, _Console
from scanmesh.cli.render import _mesh_file
from scanmesh.errors import ParameterError
from scanmesh.present.view import save_glb, save_html

#: Views older than this (seconds) are removed from the view folder when another is written.
VIEW_KEEP_SECONDS = 24 * 3600


def _view_folder() -> Path:
    """The one folder in the temporary directory where views without ``-o`` go (private to
    the user, reused: the command leaves no folder per run behind); views older than a
    day are removed from it. A fresh folder when that one is not safely ours."""
    uid = os.getuid() if hasattr(os, "getuid") else 0
    folder = Path(tempfile.gettempdir()) / f"scanmesh-view-{uid}"
    try:
        folder.mkdir(mode=0o700, exist_ok=True)
        info = os.lstat(folder)
        if not stat.S_ISDIR(info.st_mode) or (hasattr(os, "getuid") and info.st_uid != uid):
            raise PermissionError(folder)  # a file, a link or someone else's: not ours
    except OSError:
        return Path(tempfile.mkdtemp(prefix="scanmesh-view-"))
    now = time.time()
    for old in folder.glob("*.htm*"):
        with contextlib.suppress(OSError):
            if now - old.stat().st_mtime > VIEW_KEEP_SECONDS:
                old.unlink()
    return folder


def cmd_view(args: argparse.Namespace, con: _Console) -> int:
    """A self-contained HTML page (or GLB file) showing a mesh in 3-D, opened in a browser."""

    mesh_path = Path(args.mesh)
    out = Path(args.output) if args.output else None
    if out is not None and out.suffix.lower() not in (".html", ".htm", ".glb"):
        raise ParameterError(f"cannot write {out}: a view is written as .html or .glb")
    _check_outputs([mesh_path], [out])
    mesh = _mesh_file(mesh_path)
    if out is None:  # scanmesh's own folder: nothing of the user's is overwritten
        out = _view_folder() / f"{mesh_path.stem}.html"
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
