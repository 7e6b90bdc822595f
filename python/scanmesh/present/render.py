"""Pictures: flat-shaded meshes, side-by-side comparisons and annealing convergence plots.

Faces are drawn in one colour or coloured by a figure of each face (:func:`face_colors`:
its tac, its distance to a true surface, or its height), on the viridis scale.

Meshes are drawn by a small orthographic z-buffer in numpy (the grid caster of
:mod:`scanmesh.evaluate.digitizer`, one ray per pixel), which renders a million triangles in about
a second where matplotlib's polygon painter takes far longer (docs/benchmarks/speed.md,
"Rendering"). Flat shading shows every facet, so a rough triangulation looks rough: the
pictures are meant to judge smoothness, as in the 1997 paper's figures 1 and 2.
PNG files are written here (:func:`png_bytes`); titles and plots are drawn by matplotlib
without pyplot (the "plots" extra), so nothing needs a display.
"""

from __future__ import annotations

import io
import math
import os
import struct
import warnings
import zlib
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any, NamedTuple

import numpy as np
from numpy.typing import ArrayLike

from scanmesh._extras import require
from scanmesh.errors import InvalidMeshError, ParameterError, WireZoomWarning
from scanmesh.evaluate.digitizer import cast_grid
from scanmesh.evaluate.truth import TrueSurface
from scanmesh.formats.write import inputs_of, write_atomic
from scanmesh.measures import quality
from scanmesh.scan.axes import AxisSpec, parse_axis

#: Default direction from the part to the eye: a three-quarter view from above (+z up).
DEFAULT_VIEW = (-0.55, -1.0, 0.9)
#: Light direction in camera coordinates (right, up, toward the eye): upper left, in front.
LIGHT = (-0.4, 0.55, 0.75)
#: Share of the light that reaches faces turned away from it.
AMBIENT = 0.25
#: Surface colour (RGB in 0..1): a light steel blue.
COLOR = (0.64, 0.74, 0.88)
#: Wire (triangle edge) colour.
WIRE = (0.12, 0.16, 0.24)

#: With ``wire``, a picture whose triangles would cover fewer output pixels than this on
#: average (their edges would merge into one dark area) is zoomed on the mesh's middle
#: until they cover this many, and says so (a ``WireZoomWarning``).
WIRE_PIXELS: float = 60.0
#: Empty border around the part, as a share of the picture.
MARGIN = 0.04

#: What ``color_by=`` (``--color``) can colour faces by.
COLOR_BY = ("tac", "error", "height")
#: A face tac (radians) at most this is rounding of the corner angles, not curvature: drawn
#: as zero, and the top of every tac scale (angles round at about 1e-16 rad each, the sum
#: of a vertex's corners at about 1e-15; the annealer's energy ties are 1e-10).
TAC_ROUNDING = 1e-9
#: A default height direction within this angle (degrees) of a coordinate axis is that axis
#: (:func:`height_axis`).
HEIGHT_AXIS_DEG = 20.0
#: Colour of faces with no figure (tac of a face with no interior corner).
NO_VALUE = (0.75, 0.75, 0.75)
#: The viridis scale (matplotlib's), sampled at 9 even steps from low to high: dark blue
#: to yellow, even in lightness, readable by the colour-blind and in grey print.
VIRIDIS = (
    (0.2670, 0.0049, 0.3294),
    (0.2788, 0.1755, 0.4834),
    (0.2297, 0.3224, 0.5457),
    (0.1727, 0.4488, 0.5579),
    (0.1276, 0.5669, 0.5506),
    (0.1579, 0.6838, 0.5017),
    (0.3692, 0.7889, 0.3829),
    (0.6785, 0.8637, 0.1895),
    (0.9932, 0.9062, 0.1439),
)

#: The keys plot_convergence draws, with the names it also accepts for them.
TRACE_KEYS = {
    "temperature": ("temperature", "temp", "T"),
    "energy": ("energy", "E"),
    "best": ("best", "best_energy"),
    "acceptance": ("acceptance", "acceptance_rate", "accept_rate", "accepted"),
}


def _mesh_arrays(mesh: Any) -> tuple[np.ndarray, np.ndarray]:
    """(V, 3) float64 vertices and (F, 3) int64 faces of a Surface, a Trimesh or a pair."""
    if isinstance(mesh, tuple) and len(mesh) == 2:
        vertices, faces = mesh
    elif hasattr(mesh, "vertices") and hasattr(mesh, "faces"):
        vertices, faces = mesh.vertices, mesh.faces
    else:
        raise ParameterError(
            "a mesh must be a scanmesh Surface, a trimesh.Trimesh or a (vertices, faces) pair,"
            f" got {type(mesh).__name__}"
        )
    v = np.asarray(vertices, dtype=np.float64)
    f = np.asarray(faces)
    if v.ndim != 2 or v.shape[1] != 3:
        raise InvalidMeshError(f"vertices must have shape (N, 3), got {v.shape}")
    if f.ndim != 2 or f.shape[1] != 3 or len(f) == 0:
        raise InvalidMeshError(f"faces must have shape (M, 3) with M > 0, got {f.shape}")
    f = f.astype(np.int64)
    if f.min() < 0 or f.max() >= len(v):
        raise InvalidMeshError(f"faces refer to vertices outside 0..{len(v) - 1}")
    if not np.all(np.isfinite(v[_used(f, len(v))])):
        raise InvalidMeshError("the mesh has non-finite vertex coordinates")
    return v, f


def _used(faces: np.ndarray, n_vertices: int) -> np.ndarray:
    """(V,) bool: the vertices some face uses (a mask: np.unique is slow on 3M indices)."""
    mask = np.zeros(n_vertices, dtype=bool)
    mask[faces.ravel()] = True
    return mask


def auto_view(vertices: np.ndarray, faces: np.ndarray, frame: Any = None) -> dict[str, Any]:
    """Camera for a scan: three-quarter view from the side the surface faces, tilted across
    its shorter planar extent (so a long part is seen from the side, not end-on).

    ``frame`` (a :class:`scanmesh.Frame`) gives the plane; without one, the principal axes
    of the used vertices do, the normal turned to the side the faces are wound towards.
    Returns ``{"view": (3,) tuple, "up": (3,) tuple}`` for :func:`shade_mesh`. O(N + M).
    """
    used = np.zeros(len(vertices), dtype=bool)
    used[faces.ravel()] = True
    pts = vertices[used]
    if frame is not None:
        u, v, n = (np.asarray(a, dtype=np.float64) for a in (frame.u, frame.v, frame.normal))
    else:
        centred = pts - pts.mean(axis=0)
        _, _, axes = np.linalg.svd(centred, full_matrices=False)
        u, v, n = axes[0], axes[1], axes[2]
        tri = vertices[faces]
        area = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0]).sum(axis=0)
        if float(np.dot(area, n)) < 0:
            n, v = -n, -v
    rel = pts - pts.mean(axis=0)
    if np.ptp(rel @ u) < np.ptp(rel @ v):
        short, long_ = u, v
    else:
        short, long_ = v, u
    view = 0.9 * n - 1.0 * short - 0.3 * long_
    return {"view": tuple(float(x) for x in view), "up": tuple(float(x) for x in n)}


def height_axis(normal: AxisSpec) -> np.ndarray:
    """(3,) float64 direction heights are measured along by default: the signed coordinate
    axis nearest ``normal`` (a surface's normal) when within ``HEIGHT_AXIS_DEG`` of it,
    else ``normal``: terrain's best-fit normal leans a degree or two, and its height is
    then its elevation, not a tilted mix of elevation and easting."""
    n = parse_axis(normal, "up")
    k = int(np.argmax(np.abs(n)))
    if abs(float(n[k])) >= math.cos(math.radians(HEIGHT_AXIS_DEG)):
        axis = np.zeros(3)
        axis[k] = math.copysign(1.0, float(n[k]))
        return axis
    return n


class ColorScale(NamedTuple):
    """What the face colours of :func:`face_colors` mean: ``lo`` is the darkest (viridis
    blue), ``hi`` the brightest (yellow); values beyond are drawn as the end colours."""

    by: str
    lo: float
    hi: float
    unit: str

    def describe(self) -> str:
        """One line for people: ``"tac 0 (dark) to 0.12 rad (yellow)"``."""
        return f"{self.by} {self.lo:.4g} (dark) to {self.hi:.4g} {self.unit} (yellow)".rstrip()


def face_values(
    mesh: Any, by: str, *, truth: Any = None, up: AxisSpec = "z"
) -> tuple[np.ndarray, str]:
    """One figure per face of a mesh, and its unit.

    by : "tac"
        the mean tac (radians) of the face's interior corners (NaN when it has none): where
        the surface bends, or the triangulation zig-zags.
    by : "error"
        the closest-point distance (model units) from the face's centroid to ``truth`` (a
        CAD part: path, trimesh.Trimesh or :class:`scanmesh.evaluate.truth.TrueSurface`): where the
        mesh leaves the part.
    by : "height"
        the centroid's coordinate along ``up`` (model units) when ``up`` is a coordinate
        axis, else its height along ``up`` above the lowest face's.

    Returns ((M,) float64, unit). O(N + M), plus the truth's distance queries for "error".
    """
    vertices, faces = _mesh_arrays(mesh)
    if by == "tac":
        tac = quality(vertices, faces).tac[faces]  # (M, 3), NaN on boundary corners
        counted = np.isfinite(tac).sum(axis=1)
        total = np.where(np.isfinite(tac), tac, 0.0).sum(axis=1)
        with np.errstate(invalid="ignore", divide="ignore"):
            return np.where(counted > 0, total / counted, np.nan), "rad"
    if truth is not None and by != "error":
        raise ParameterError(f"a truth is used only to colour by error, not by {by!r} (--color)")
    centroid = vertices[faces].mean(axis=1)
    if by == "error":
        if truth is None:
            raise ParameterError("colouring by error needs the true surface (truth=, --truth)")
        surface = truth if isinstance(truth, TrueSurface) else TrueSurface(truth)
        return surface.distance(centroid), ""
    if by == "height":
        direction = parse_axis(up, "up")
        axes = np.flatnonzero(direction)
        if len(axes) == 1:  # a coordinate axis: the coordinate itself (elevation on terrain)
            return centroid[:, axes[0]] * direction[axes[0]], ""
        # another direction: dotted with georeferenced coordinates it would read a number
        # of no meaning (-1.5e5 for heights of 700-2,500 m): measured from the lowest face
        height = (centroid - centroid.mean(axis=0)) @ direction
        return height - height.min(), ""
    raise ParameterError(f"color_by must be one of {', '.join(COLOR_BY)}, got {by!r}")


def colormap(values: ArrayLike, lo: float, hi: float) -> np.ndarray:
    """(K, 3) float64 RGB in 0..1 of ``values`` on the viridis scale from ``lo`` to ``hi``
    (clipped); NaN values get ``NO_VALUE``."""
    x = np.asarray(values, dtype=np.float64)
    t = np.clip((x - lo) / (hi - lo if hi > lo else 1.0), 0.0, 1.0)
    stops = np.linspace(0.0, 1.0, len(VIRIDIS))
    rgb = np.column_stack([np.interp(t, stops, channel) for channel in np.transpose(VIRIDIS)])
    rgb[~np.isfinite(x)] = NO_VALUE
    return rgb


def face_colors(
    mesh: Any, by: str | None, *, truth: Any = None, up: AxisSpec = "z"
) -> tuple[np.ndarray, ColorScale | None]:
    """(M, 3) float64 RGB per face coloured by :func:`face_values`, and its scale; for
    ``by=None`` the one colour ``COLOR`` and no scale.

    The scale runs from the smallest to the largest figure, except tac, which runs from 0
    to its 99th percentile: a few spikes (bores, creases) would otherwise leave the rest
    of the surface one colour. A tac of at most ``TAC_ROUNDING`` is drawn as zero and the
    tac scale reaches at least ``TAC_ROUNDING``, so a flat part is one colour, not its
    rounding stretched into hot spots.
    """
    if by is None:
        if truth is not None:
            raise ParameterError(
                "a truth is used only to colour by error (color_by='error', --color error)"
            )
        return np.broadcast_to(
            np.asarray(COLOR, dtype=np.float64), (len(_mesh_arrays(mesh)[1]), 3)
        ), None
    values, unit = face_values(mesh, by, truth=truth, up=up)
    values = drawn_values(values, by)
    scale = color_scale([values], by, unit)
    return colormap(values, scale.lo, scale.hi), scale


def drawn_values(values: np.ndarray, by: str) -> np.ndarray:
    """Face figures as drawn: a tac of at most ``TAC_ROUNDING`` (rounding of the corner
    angles, no curvature) as zero; other figures as they are."""
    return np.where(values <= TAC_ROUNDING, 0.0, values) if by == "tac" else values


def color_scale(values: Sequence[np.ndarray], by: str, unit: str) -> ColorScale:
    """The one scale of several meshes' :func:`drawn_values` (one array per mesh): the
    smallest to the largest figure, except tac, from 0 to its 99th percentile and at least
    ``TAC_ROUNDING`` (see :func:`face_colors`). O(total faces)."""
    every = np.concatenate([np.asarray(v, dtype=np.float64).ravel() for v in values])
    finite = every[np.isfinite(every)]
    if len(finite) == 0:
        lo = hi = 0.0
    elif by == "tac":
        lo, hi = 0.0, max(float(np.percentile(finite, 99)), TAC_ROUNDING)
    else:
        lo, hi = float(finite.min()), float(finite.max())
    return ColorScale(by, lo, hi, unit)


def camera(view: AxisSpec = DEFAULT_VIEW, up: AxisSpec = "z") -> np.ndarray:
    """A (3, 3) float64 camera frame, rows (right, screen up, toward the eye).

    ``view`` points from the part to the eye; ``up`` is the model direction that should
    point up on the screen (any other when it is parallel to ``view``).
    """
    back = parse_axis(view, "view")
    hint = parse_axis(up, "up")
    if abs(float(np.dot(hint, back))) > 1 - 1e-9:
        hint = np.array([0.0, 1.0, 0.0]) if abs(back[1]) < 0.9 else np.array([0.0, 0.0, 1.0])
    right = np.cross(hint, back)
    right /= np.linalg.norm(right)
    return np.array([right, np.cross(back, right), back])


def _fit(
    xy_lo: np.ndarray, xy_hi: np.ndarray, width: int, height: int
) -> tuple[float, float, float]:
    """Pixel size and the centre of pixel (0, 0) (bottom left) so a box fills the picture."""
    extent = np.maximum(xy_hi - xy_lo, 1e-300)
    pixel = max(extent[0] / (width * (1 - 2 * MARGIN)), extent[1] / (height * (1 - 2 * MARGIN)))
    centre = 0.5 * (xy_lo + xy_hi)
    x0 = centre[0] - pixel * (width - 1) / 2
    y0 = centre[1] - pixel * (height - 1) / 2
    return pixel, x0, y0


def _wire_window(
    tri: np.ndarray, used: np.ndarray, lo: np.ndarray, hi: np.ndarray, width: int, height: int
) -> tuple[np.ndarray, np.ndarray]:
    """The screen box a wireframe shows: the whole mesh (``lo``, ``hi``) when its triangles
    cover ``WIRE_PIXELS`` output pixels on average, else a box around the median vertex
    ``zoom`` times smaller, so that they do (with a WireZoomWarning). O(M)."""
    pixel = _fit(lo, hi, width, height)[0]
    e1, e2 = tri[:, 1, :2] - tri[:, 0, :2], tri[:, 2, :2] - tri[:, 0, :2]
    area = 0.5 * np.abs(e1[:, 0] * e2[:, 1] - e1[:, 1] * e2[:, 0]).mean() / pixel**2
    if not len(tri) or area >= WIRE_PIXELS:
        return lo, hi
    zoom = math.sqrt(WIRE_PIXELS / max(area, 1e-12))
    middle = np.median(used[:, :2], axis=0)
    half = 0.5 * (hi - lo) / zoom
    warnings.warn(
        f"the wireframe's {len(tri):,} triangles would cover {area:.2g} pixels each: the"
        f" picture shows the middle of the mesh, {zoom:.3g} times closer, where they cover"
        f" {WIRE_PIXELS:g}",
        WireZoomWarning,
        stacklevel=4,
    )
    return middle - half, middle + half


def shade_mesh(
    mesh: Any,
    *,
    size: tuple[int, int] = (800, 600),
    view: AxisSpec = DEFAULT_VIEW,
    up: AxisSpec = "z",
    wire: bool = False,
    color: ArrayLike = COLOR,
    background: Sequence[float] = (1.0, 1.0, 1.0),
    supersample: int = 2,
    bounds: tuple[ArrayLike, ArrayLike] | None = None,
) -> np.ndarray:
    """Render a mesh flat-shaded from a fixed light, orthographic, into an RGB array.

    Parameters
    ----------
    mesh : Surface, trimesh.Trimesh or (vertices, faces)
        What to draw; faces are lit from both sides (scans are open sheets).
    size : (width, height) int
        Picture size in pixels.
    view, up : axis name or (3,) float
        Direction from the part to the eye, and the model direction shown upwards.
    wire : bool
        Draw the visible triangle edges. When the triangles would cover fewer than
        ``WIRE_PIXELS`` output pixels on average, the picture shows the middle of the mesh
        (around the median vertex) at the scale where they cover that many: the real
        triangles, readable, not a decimation; a ``WireZoomWarning`` says by how much.
    color : (3,) or (M, 3) float
        RGB in 0..1: one colour for the whole mesh, or one per face (:func:`face_colors`).
    supersample : int
        Render this many times larger and average down (anti-aliasing).
    bounds : ((2,), (2,)) float, optional
        Screen-space box (right, up) to fit instead of the mesh's own: pictures rendered
        with the same camera and bounds share one scale.

    Returns
    -------
    (height, width, 3) uint8
    """
    vertices, faces = _mesh_arrays(mesh)
    width, height = (int(s) for s in size)
    ss = int(supersample)
    if width < 1 or height < 1 or ss < 1:
        raise ParameterError(f"size and supersample must be positive, got {size}, {supersample}")
    rgb = np.asarray(color, dtype=np.float64)
    if rgb.shape not in ((3,), (len(faces), 3)):
        raise ParameterError(
            f"color must be one RGB triple or one per face ({len(faces)}, 3), got {rgb.shape}"
        )
    rgb = np.broadcast_to(rgb, (len(faces), 3))
    frame = camera(view, up)
    local = vertices @ frame.T  # (V, 3) right, up, toward the eye
    tri = local[faces]  # (F, 3, 3)
    if bounds is None:
        used = local[_used(faces, len(local))]
        lo, hi = used[:, :2].min(axis=0), used[:, :2].max(axis=0)
        if wire:
            lo, hi = _wire_window(tri, used, lo, hi, width, height)
    else:
        lo, hi = (np.asarray(b, dtype=np.float64) for b in bounds)
    w, h = width * ss, height * ss
    pixel, x0, y0 = _fit(lo, hi, w, h)
    depth, face = cast_grid(
        tri[..., :2], tri[..., 2], (x0, y0), (pixel, pixel), (w, h), 1e-9 * pixel
    )
    face = face.reshape(h, w)[::-1]  # image rows run top to bottom
    drawn = face >= 0
    # Lambert shading of the visible faces, two-sided, light fixed to the camera
    seen = np.flatnonzero(np.bincount(face[drawn], minlength=len(faces)))
    t = tri[seen]
    normal = np.cross(t[:, 1] - t[:, 0], t[:, 2] - t[:, 0])
    length = np.linalg.norm(normal, axis=1)
    normal /= np.where(length > 0, length, 1.0)[:, None]
    light = np.asarray(LIGHT) / np.linalg.norm(LIGHT)
    face_rgb = np.zeros((len(faces), 3))
    intensity = AMBIENT + (1 - AMBIENT) * np.abs(normal @ light)
    face_rgb[seen] = intensity[:, None] * rgb[seen]
    image = np.empty((h, w, 3))
    image[:] = np.asarray(background, dtype=np.float64)
    image[drawn] = face_rgb[face[drawn]]
    if wire:
        # a pixel beside a pixel of another face (or of the background) is on an edge;
        # when supersampling, both sides are marked so the averaged line stays dark
        across = face[:, 1:] != face[:, :-1]
        down = face[1:, :] != face[:-1, :]
        edge = np.zeros((h, w), dtype=bool)
        edge[:, :-1] |= across
        edge[:-1, :] |= down
        if ss > 1:
            edge[:, 1:] |= across
            edge[1:, :] |= down
        image[edge] = WIRE
    if ss > 1:
        image = sum(image[a::ss, b::ss] for a in range(ss) for b in range(ss)) / (ss * ss)
    return np.clip(np.rint(image * 255), 0, 255).astype(np.uint8)


def _png_path(path: str | os.PathLike) -> Path:
    target = Path(path)
    if target.suffix.lower() != ".png":
        raise ParameterError(f"pictures are written as PNG: {target} should end in .png")
    return target


def render_mesh(
    mesh: Any,
    path: str | os.PathLike,
    *,
    size: tuple[int, int] = (800, 600),
    view: AxisSpec = DEFAULT_VIEW,
    up: AxisSpec = "z",
    wire: bool = False,
    supersample: int = 2,
    color_by: str | None = None,
    truth: Any = None,
    height: AxisSpec | None = None,
) -> Path:
    """Write a flat-shaded picture of a mesh to a PNG file (see :func:`shade_mesh`).

    ``color_by`` ("tac", "error" with ``truth``, or "height" along ``height``, by default
    ``up``) colours each face by that figure (:func:`face_colors`); default: one colour.
    """
    target = _png_path(path)
    color = face_colors(mesh, color_by, truth=truth, up=up if height is None else height)[0]
    image = shade_mesh(
        mesh, size=size, view=view, up=up, wire=wire, color=color, supersample=supersample
    )
    return write_atomic(target, [png_bytes(image)], protect=inputs_of(mesh))


def png_bytes(image: np.ndarray) -> bytes:
    """A PNG file (8-bit RGB, no filter, zlib level 6) of an (H, W, 3) uint8 image.

    Written here so flat-shaded pictures need no imaging library. O(H W).
    """
    if image.dtype != np.uint8 or image.ndim != 3 or image.shape[2] != 3:
        raise ParameterError(f"an image must be (H, W, 3) uint8, got {image.shape} {image.dtype}")
    height, width = image.shape[:2]

    def chunk(kind: bytes, data: bytes) -> bytes:
        body = kind + data
        return struct.pack(">I", len(data)) + body + struct.pack(">I", zlib.crc32(body))

    rows = np.zeros((height, 1 + 3 * width), dtype=np.uint8)  # filter byte 0 on each row
    rows[:, 1:] = image.reshape(height, 3 * width)
    header = struct.pack(">IIBBBBB", width, height, 8, 2, 0, 0, 0)  # 8 bits, RGB
    return (
        b"\x89PNG\r\n\x1a\n"
        + chunk(b"IHDR", header)
        + chunk(b"IDAT", zlib.compress(rows.tobytes(), 6))
        + chunk(b"IEND", b"")
    )


def new_figure(width_in: float, height_in: float, dpi: int = 100) -> Any:
    """A matplotlib Figure of that size in inches, made without pyplot (no display needed);
    MissingExtraError naming the "plots" extra when matplotlib is missing."""
    figure = require("matplotlib.figure", "plots", "pictures with titles and plots")
    return figure.Figure(figsize=(width_in, height_in), dpi=dpi)


def save_figure(fig: Any, path: Path, dpi: int = 100, protect: Any = None) -> Path:
    """Write ``fig`` to the PNG ``path`` atomically (never over ``protect``, the inputs)."""
    buf = io.BytesIO()
    fig.savefig(buf, format="png", dpi=dpi, facecolor="white")
    return write_atomic(path, [buf.getvalue()], protect=protect)


def _trace_series(trace: Mapping[str, ArrayLike]) -> tuple[np.ndarray, dict[str, np.ndarray]]:
    if not isinstance(trace, Mapping):
        raise ParameterError(
            f"trace must be a mapping of name to array, got {type(trace).__name__}"
        )
    found: dict[str, np.ndarray] = {}
    for key, names in TRACE_KEYS.items():
        for name in names:
            if name in trace:
                found[key] = np.asarray(trace[name], dtype=np.float64).ravel()
                break
    if "energy" not in found and "best" not in found:
        raise ParameterError(
            f"trace needs an 'energy' or 'best' series, got keys {sorted(map(str, trace))}"
        )
    lengths = {k: len(v) for k, v in found.items()}
    if "sweep" in trace:
        sweep = np.asarray(trace["sweep"], dtype=np.float64).ravel()
        lengths["sweep"] = len(sweep)
    else:
        sweep = np.arange(next(iter(lengths.values())), dtype=np.float64)
    if len(set(lengths.values())) != 1:
        raise ParameterError(f"trace series must have equal lengths, got {lengths}")
    if len(sweep) == 0:
        raise ParameterError("trace series are empty")
    return sweep, found


def plot_convergence(
    trace: Mapping[str, ArrayLike],
    path: str | os.PathLike,
    *,
    title: str | None = None,
    size: tuple[float, float] = (8.0, 7.0),
) -> Path:
    """Write a convergence plot of an annealing run to a PNG file.

    Parameters
    ----------
    trace : mapping of str to (S,) float
        Per sweep: ``energy`` (current tac energy), ``best`` (best so far),
        ``temperature`` and ``acceptance`` (accepted share of proposals, 0..1); optional
        ``sweep`` (x values). ``energy`` or ``best`` is required, the others are drawn
        when present.
    size : (width, height) float
        Inches (at 100 dpi).
    """
    target = _png_path(path)
    sweep, series = _trace_series(trace)
    panels = ["energy"]
    panels += [k for k in ("temperature", "acceptance") if k in series]
    fig = new_figure(*size)
    axes = fig.subplots(len(panels), 1, sharex=True, squeeze=False)[:, 0]
    for ax, panel in zip(axes, panels, strict=True):
        if panel == "energy":
            for key, style in (("energy", dict(color="0.55", lw=1.0)), ("best", dict(lw=1.8))):
                if key in series:
                    ax.plot(sweep, series[key], label=key, **style)
            values = np.concatenate([series[k] for k in ("energy", "best") if k in series])
            _maybe_log(ax, values)
            ax.set_ylabel("tac energy")
            ax.legend(loc="upper right", frameon=False)
        elif panel == "temperature":
            ax.plot(sweep, series["temperature"], color="tab:red", lw=1.5)
            _maybe_log(ax, series["temperature"])
            ax.set_ylabel("temperature")
        else:
            ax.plot(sweep, series["acceptance"], color="tab:green", lw=1.2)
            ax.set_ylim(-0.02, 1.02)
            ax.set_ylabel("acceptance rate")
        ax.grid(True, alpha=0.3)
    axes[-1].set_xlabel("sweep")
    if title:
        axes[0].set_title(title)
    fig.tight_layout()
    return save_figure(fig, target)


def _maybe_log(ax, values: np.ndarray) -> None:
    """Log scale for positive data spanning more than a decade."""
    finite = values[np.isfinite(values)]
    if len(finite) and finite.min() > 0 and finite.max() / finite.min() > 10:
        ax.set_yscale("log")
