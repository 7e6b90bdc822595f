"""Looking at a mesh in 3-D: a self-contained HTML page, a GLB file, notebook display and
an interactive window.

The HTML page carries the mesh and a small WebGL 2 viewer written here (no library, no
network): it opens from disk in any current browser, offline, and shows the mesh as the
PNG pictures of :mod:`scanmesh.present.render` do: flat-shaded facets, lit from the same fixed
light, seen first from the same camera, optionally coloured by tac, error or height.
Drag turns it, the wheel zooms, a double click goes back to the first view.

Each face is sent as its own three corners (float32, centred and scaled to a unit ball, so
coordinates in UTM metres keep their precision), about 45 bytes per face: a 28,000-face
scan makes a 1.7 MB page. The interactive window needs PyVista or trimesh's viewer.
"""

from __future__ import annotations

import base64
import html
import importlib.util
import json
import os
from pathlib import Path
from typing import Any

import numpy as np

from scanmesh._interrupt import import_interruptibly
from scanmesh.errors import InvalidMeshError, MissingExtraError, ParameterError
from scanmesh.formats.write import inputs_of, write_atomic
from scanmesh.present.decimate import cluster
from scanmesh.present.render import (
    AMBIENT,
    COLOR,
    LIGHT,
    MARGIN,
    VIRIDIS,
    ColorScale,
    _mesh_arrays,
    _used,
    auto_view,
    camera,
    face_colors,
    height_axis,
)
from scanmesh.scan.axes import AxisSpec

#: Most faces ``Surface._repr_html_`` puts in a notebook (about 60 bytes a face: 4.5 MB);
#: a larger mesh is shown decimated (:func:`scanmesh.present.decimate.cluster`), and the
#: view says so. ``to_html`` always writes every face.
NOTEBOOK_FACES: int = 75_000

_PAGE = """<!DOCTYPE html>
<html lang="en">
<head>
<meta charset="utf-8">
<meta name="viewport" content="width=device-width, initial-scale=1">
<title>%(title)s</title>
<style>
html, body { margin: 0; height: 100%%; background: #fff; overflow: hidden;
  font: 13px/1.4 system-ui, sans-serif; color: #222; }
#view { position: absolute; inset: 0; width: 100%%; height: 100%%; display: block;
  touch-action: none; cursor: grab; }
#note { position: absolute; left: 10px; top: 8px; pointer-events: none; }
#legend { position: absolute; left: 10px; bottom: 10px; width: 240px; pointer-events: none; }
#legend .bar { height: 10px; background: linear-gradient(to right, %(gradient)s); }
#legend .ends { display: flex; justify-content: space-between; }
</style>
</head>
<body>
<canvas id="view"></canvas>
<div id="note">%(title)s &middot; %(faces)s faces &middot; drag: turn &middot;
wheel: zoom &middot; double click: first view</div>
%(legend)s
<script>
(function () {
"use strict";
const D = %(data)s;
function bytes(text) {
  const raw = atob(text), out = new Uint8Array(raw.length);
  for (let i = 0; i < raw.length; i++) out[i] = raw.charCodeAt(i);
  return out;
}
const canvas = document.getElementById("view");
const gl = canvas.getContext("webgl2", {antialias: true, preserveDrawingBuffer: true});
if (!gl) {
  document.getElementById("note").textContent =
    "This browser cannot draw WebGL 2, which this page needs.";
  return;
}
function shader(kind, source) {
  const s = gl.createShader(kind);
  gl.shaderSource(s, source);
  gl.compileShader(s);
  if (!gl.getShaderParameter(s, gl.COMPILE_STATUS)) throw new Error(gl.getShaderInfoLog(s));
  return s;
}
const program = gl.createProgram();
gl.attachShader(program, shader(gl.VERTEX_SHADER, `#version 300 es
in vec3 p; in vec3 c; uniform mat3 R; uniform vec2 S; uniform vec2 P;
out vec3 q; out vec3 k;
void main() { q = R * p; k = c; gl_Position = vec4((q.xy - P) * S, -0.5 * q.z, 1.0); }`));
gl.attachShader(program, shader(gl.FRAGMENT_SHADER, `#version 300 es
precision highp float;
in vec3 q; in vec3 k; uniform vec3 L; uniform float A; out vec4 o;
void main() {
  vec3 n = cross(dFdx(q), dFdy(q)); float l = length(n);
  float i = l > 0.0 ? A + (1.0 - A) * abs(dot(n / l, L)) : 1.0;
  o = vec4(k * i, 1.0);
}`));
gl.linkProgram(program);
if (!gl.getProgramParameter(program, gl.LINK_STATUS)) {
  throw new Error(gl.getProgramInfoLog(program));
}
gl.useProgram(program);
function attribute(name, data, type, normalized) {
  gl.bindBuffer(gl.ARRAY_BUFFER, gl.createBuffer());
  gl.bufferData(gl.ARRAY_BUFFER, data, gl.STATIC_DRAW);
  const at = gl.getAttribLocation(program, name);
  gl.enableVertexAttribArray(at);
  gl.vertexAttribPointer(at, 3, type, normalized, 0, 0);
}
attribute("p", new Float32Array(bytes(D.positions).buffer), gl.FLOAT, false);
attribute("c", bytes(D.colors), gl.UNSIGNED_BYTE, true);
const u = (name) => gl.getUniformLocation(program, name);
let turn = D.frame.slice(), zoom = 1, queued = false;
function times(a, b) {
  const r = [];
  for (let i = 0; i < 3; i++)
    for (let j = 0; j < 3; j++)
      r.push(a[3 * i] * b[j] + a[3 * i + 1] * b[3 + j] + a[3 * i + 2] * b[6 + j]);
  return r;
}
function about(axis, t) {
  const c = Math.cos(t), s = Math.sin(t);
  return axis === 0 ? [1, 0, 0, 0, c, -s, 0, s, c] : [c, 0, s, 0, 1, 0, -s, 0, c];
}
function draw() {
  queued = false;
  const ratio = window.devicePixelRatio || 1;
  const w = Math.max(1, Math.round(canvas.clientWidth * ratio));
  const h = Math.max(1, Math.round(canvas.clientHeight * ratio));
  if (canvas.width !== w || canvas.height !== h) { canvas.width = w; canvas.height = h; }
  gl.viewport(0, 0, w, h);
  const fill = 1 - 2 * D.margin;
  const pixels = Math.min(w * fill / D.extent[0], h * fill / D.extent[1]) * zoom;
  gl.uniformMatrix3fv(u("R"), true, turn);
  gl.uniform2f(u("S"), 2 * pixels / w, 2 * pixels / h);
  gl.uniform2f(u("P"), D.centre[0], D.centre[1]);
  gl.uniform3fv(u("L"), D.light);
  gl.uniform1f(u("A"), D.ambient);
  gl.clearColor(1, 1, 1, 1);
  gl.enable(gl.DEPTH_TEST);
  gl.clear(gl.COLOR_BUFFER_BIT | gl.DEPTH_BUFFER_BIT);
  gl.drawArrays(gl.TRIANGLES, 0, 3 * D.faces);
}
function redraw() { if (!queued) { queued = true; requestAnimationFrame(draw); } }
let last = null;
canvas.addEventListener("pointerdown", (e) => { last = [e.clientX, e.clientY];
  canvas.setPointerCapture(e.pointerId); });
canvas.addEventListener("pointerup", () => { last = null; });
canvas.addEventListener("pointermove", (e) => {
  if (!last) return;
  const dx = e.clientX - last[0], dy = e.clientY - last[1];
  last = [e.clientX, e.clientY];
  turn = times(about(1, 0.01 * dx), times(about(0, 0.01 * dy), turn));
  redraw();
});
canvas.addEventListener("wheel", (e) => { e.preventDefault();
  zoom *= Math.exp(-0.001 * e.deltaY); redraw(); }, {passive: false});
canvas.addEventListener("dblclick", () => { turn = D.frame.slice(); zoom = 1; redraw(); });
window.addEventListener("resize", redraw);
draw();
})();
</script>
</body>
</html>
"""


def _legend(scale: ColorScale | None) -> str:
    if scale is None:
        return ""
    unit = f" {scale.unit}" if scale.unit else ""
    return (
        '<div id="legend"><div class="bar"></div><div class="ends">'
        f"<span>{scale.lo:.4g}</span><span>{html.escape(scale.by)}{html.escape(unit)}</span>"
        f"<span>{scale.hi:.4g}</span></div></div>"
    )


def _camera_of(mesh: Any, vertices: np.ndarray, faces: np.ndarray, view, up) -> dict:
    """The camera :mod:`scanmesh.present.render` would pick, with ``view``/``up`` overriding."""
    chosen = auto_view(vertices, faces, getattr(mesh, "frame", None))
    if view is not None:
        chosen["view"] = view
    if up is not None:
        chosen["up"] = up
    return chosen


def html_page(
    mesh: Any,
    *,
    color_by: str | None = None,
    truth: Any = None,
    view: AxisSpec | None = None,
    up: AxisSpec | None = None,
    title: str = "scanmesh",
) -> str:
    """The text of a self-contained HTML page that shows ``mesh`` in 3-D (WebGL 2).

    Parameters
    ----------
    mesh : Surface, trimesh.Trimesh or (vertices, faces)
        What to show; faces are lit from both sides.
    color_by : "tac", "error" or "height", optional
        Colour each face by that figure (:func:`scanmesh.present.render.face_colors`; "error" needs
        ``truth``, "height" is measured along ``up``, by default along the coordinate axis
        nearest the surface's normal: :func:`scanmesh.present.render.height_axis`), with a
        legend; default one colour.
    view, up : axis name or (3,) float, optional
        The first view: direction from the part to the eye and the model direction shown
        upwards; by default the camera of ``scanmesh render`` (three-quarter, from the side
        the surface faces; ``up`` its normal).

    Returns the page (str); O(M) in size and time for M faces.
    """
    vertices, faces = _mesh_arrays(mesh)
    cam = _camera_of(mesh, vertices, faces, view, up)
    height = height_axis(cam["up"]) if up is None else up
    rgb, scale = face_colors((vertices, faces), color_by, truth=truth, up=height)
    used = vertices[_used(faces, len(vertices))]
    middle = 0.5 * (used.min(axis=0) + used.max(axis=0))
    radius = float(np.max(np.linalg.norm(used - middle, axis=1))) or 1.0
    unit = (vertices - middle) / radius  # the turning centre at 0, every vertex in the unit ball
    frame = camera(cam["view"], cam["up"])
    screen = (unit[_used(faces, len(vertices))] @ frame.T)[:, :2]
    lo, hi = screen.min(axis=0), screen.max(axis=0)
    corners = unit[faces].astype("<f4")  # (M, 3, 3)
    colors = np.repeat(np.clip(np.rint(np.asarray(rgb) * 255), 0, 255).astype(np.uint8), 3, 0)
    light = np.asarray(LIGHT) / np.linalg.norm(LIGHT)
    data = {
        "faces": len(faces),
        "positions": base64.b64encode(corners.tobytes()).decode("ascii"),
        "colors": base64.b64encode(colors.tobytes()).decode("ascii"),
        "frame": [round(float(x), 12) for x in frame.ravel()],
        "centre": [float(x) for x in 0.5 * (lo + hi)],
        "extent": [max(float(x), 1e-9) for x in hi - lo],
        "light": [float(x) for x in light],
        "ambient": AMBIENT,
        "margin": MARGIN,
    }
    gradient = ", ".join(
        f"rgb({round(255 * r)}, {round(255 * g)}, {round(255 * b)})" for r, g, b in VIRIDIS
    )
    return _PAGE % {
        "title": html.escape(str(title)),
        "faces": f"{len(faces):,}",
        "gradient": gradient,
        "legend": _legend(scale),
        "data": json.dumps(data, separators=(",", ":")),
    }


def save_html(mesh: Any, path: str | os.PathLike, **options: Any) -> Path:
    """Write :func:`html_page` of ``mesh`` to ``path`` (ending in .html or .htm), atomically;
    ``options`` as for :func:`html_page`. Returns the path."""
    target = Path(path)
    if target.suffix.lower() not in (".html", ".htm"):
        raise ParameterError(f"an HTML view is written to .html: {target} ends otherwise")
    options.setdefault("title", Path(target).stem)
    return write_atomic(
        target, [html_page(mesh, **options).encode("utf-8")], protect=inputs_of(mesh)
    )


def save_glb(
    mesh: Any,
    path: str | os.PathLike,
    *,
    color_by: str | None = None,
    truth: Any = None,
    up: AxisSpec | None = None,
) -> Path:
    """Write ``mesh`` as binary glTF (.glb) through trimesh, atomically.

    Each face gets its own three vertices with the face's normal, so every viewer shows
    the facets flat-shaded as scanmesh's pictures do; ``color_by`` ("tac", "error" with
    ``truth``, "height" along ``up``, by default the coordinate axis nearest the surface's
    normal as in :func:`scanmesh.present.render.height_axis`) stores the face colours as
    vertex colours; without ``color_by``, a mesh whose scan carried colours (its
    ``colors``: LAS, PLY, PTS, PCD, E57 RGB) keeps them, each corner its point's colour.
    """
    trimesh = import_interruptibly("trimesh")

    target = Path(path)
    if target.suffix.lower() != ".glb":
        raise ParameterError(f"a GLB file is written to .glb: {target} ends otherwise")
    vertices, faces = _mesh_arrays(mesh)
    if up is None:
        up = height_axis(auto_view(vertices, faces, getattr(mesh, "frame", None))["up"])
    corners = vertices[faces].reshape(-1, 3)
    flat = trimesh.Trimesh(corners, np.arange(len(corners)).reshape(-1, 3), process=False)
    rgba = np.full((len(corners), 4), 255, dtype=np.uint8)
    carried = getattr(mesh, "colors", None) if color_by is None and truth is None else None
    if carried is not None:
        rgba[:, : carried.shape[1]] = carried[faces.ravel()]
    else:
        rgb = face_colors((vertices, faces), color_by, truth=truth, up=up)[0]
        rgba[:, :3] = np.repeat(np.clip(np.rint(np.asarray(rgb) * 255), 0, 255), 3, axis=0)
    flat.visual.vertex_colors = rgba
    data = trimesh.exchange.gltf.export_glb(flat, include_normals=True)
    return write_atomic(target, [data], protect=inputs_of(mesh))


def notebook_html(mesh: Any, **options: Any) -> str | None:
    """An ``<iframe>`` holding :func:`html_page` of ``mesh``, for notebooks (None for no
    faces: the notebook then shows the text repr). Above ``NOTEBOOK_FACES`` faces the page
    shows the mesh decimated for display, seen by the mesh's own camera, and its title says
    how many faces of how many are shown, so a notebook stays small (5 MB at most)."""
    try:
        vertices, faces = _mesh_arrays(mesh)
    except InvalidMeshError:
        return None
    if len(faces) > NOTEBOOK_FACES:
        cam = _camera_of(mesh, vertices, faces, options.pop("view", None), options.pop("up", None))
        shown = cluster(vertices, faces, NOTEBOOK_FACES)
        title = options.pop("title", "scanmesh")
        options["title"] = (
            f"{title} (decimated for display: {len(shown[1]):,} of {len(faces):,} faces)"
        )
        mesh = shown
        options.update(cam)
    page = html.escape(html_page(mesh, **options), quote=True)
    return f'<iframe srcdoc="{page}" style="width: 100%; height: 480px; border: 0"></iframe>'


def show(mesh: Any, *, color_by: str | None = None, truth: Any = None, up: AxisSpec = "z") -> None:
    """Open an interactive window on ``mesh`` (blocks until it is closed).

    Uses PyVista when installed, else trimesh's viewer (it needs ``pyglet<2``); with
    neither, raises :class:`scanmesh.MissingExtraError` saying what to install, and that
    :func:`save_html` works without either.
    """
    vertices, faces = _mesh_arrays(mesh)
    rgb = (
        None
        if color_by is None and truth is None
        else face_colors(mesh, color_by, truth=truth, up=up)[0]
    )
    if importlib.util.find_spec("pyvista") is not None:
        import pyvista  # optional, never required: used only when installed

        cells = np.column_stack([np.full(len(faces), 3), faces]).ravel()
        poly = pyvista.PolyData(vertices, cells)
        plotter = pyvista.Plotter()
        if rgb is None:
            plotter.add_mesh(poly, color=COLOR, flat_shading=True)
        else:
            poly.cell_data["color"] = np.rint(rgb * 255).astype(np.uint8)
            plotter.add_mesh(poly, scalars="color", rgb=True, flat_shading=True)
        plotter.show()
        return
    if importlib.util.find_spec("pyglet") is not None:
        trimesh = import_interruptibly("trimesh")

        shown = trimesh.Trimesh(vertices, faces, process=False)
        if rgb is not None:
            shown.visual.face_colors = np.rint(rgb * 255).astype(np.uint8)
        shown.show()
        return
    raise MissingExtraError(
        "an interactive window needs PyVista (pip install pyvista) or trimesh's viewer"
        ' (pip install "pyglet<2"); without either, Surface.to_html("mesh.html") or'
        " `scanmesh view mesh.stl` writes a page any browser opens"
    )
