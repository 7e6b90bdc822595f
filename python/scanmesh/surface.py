"""The result type: a triangulated surface over the caller's points, with its quality."""

from __future__ import annotations

import os
from dataclasses import dataclass, field
from functools import cached_property
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from scanmesh import shape
from scanmesh._extras import require
from scanmesh._interrupt import import_interruptibly
from scanmesh._progress import Progress
from scanmesh.creases import creases as crease_lines
from scanmesh.errors import ParameterError, ScanmeshError
from scanmesh.evaluate.truth import TrueSurface
from scanmesh.formats import write
from scanmesh.formats._source import InputFile
from scanmesh.formats.georef import Georef
from scanmesh.formats.points import checked_point_data, colors_of
from scanmesh.measures import Quality, quality
from scanmesh.present import view
from scanmesh.scan.planar import PlanarScan
from scanmesh.scan.projection import Frame
from scanmesh.scan.steep import steep_fraction

if TYPE_CHECKING:
    import open3d
    import pyvista
    import trimesh


#: Endings :meth:`Surface.save` writes besides the mesh formats (``write.FORMATS``): a 3-D
#: view page (:meth:`Surface.to_html`) and binary glTF (``present.view.save_glb``).
VIEW_ENDINGS: tuple[str, ...] = (".glb", ".htm", ".html")


def check_ending(path: str | os.PathLike) -> str:
    """The lower-case ending of ``path`` when :meth:`Surface.save` writes it; otherwise a
    ParameterError that lists every ending it writes (the writers' and :data:`VIEW_ENDINGS`)."""
    suffix = Path(path).suffix.lower()
    endings = sorted((*write.FORMATS, *VIEW_ENDINGS))
    if suffix not in endings:
        raise ParameterError(
            f"cannot write {path}: unknown ending {Path(path).suffix!r}; use one of"
            f" {', '.join(endings)}"
        )
    return suffix


@dataclass(eq=False)
class Surface:
    """A triangle mesh whose vertices are the input points, in input order.

    ``faces`` index the caller's own array, so per-point data lines up without remapping.
    Points that no face uses (coincident duplicates, trimmed outliers) stay in ``vertices``.
    A surface fused from several views (:func:`scanmesh.merge`) has new vertices instead,
    and :attr:`face_labels`.
    """

    #: (N, 3) float64 the input points
    vertices: np.ndarray
    #: (M, 3) int64 triangles, counter-clockwise seen against the projection normal
    faces: np.ndarray
    #: name of the method that produced the faces
    method: str = "delaunay"
    #: the options the method ran with
    options: dict[str, Any] = field(default_factory=dict)
    #: the projection plane, for planar methods (the scan's frame when ``scan`` is given)
    frame: Frame | None = None
    #: (K, 2) int64 pairs (unused point, the coincident point standing for it)
    duplicates: np.ndarray = field(default_factory=lambda: np.empty((0, 2), dtype=np.int64))
    #: seconds per stage
    timings: dict[str, float] = field(default_factory=dict)
    #: annealing trace, per sweep: "temperature", "energy", "best", "acceptance" (S,) arrays
    trace: dict[str, np.ndarray] | None = None
    #: (N,) int64 scan line of each point, when known
    line_ids: np.ndarray | None = None
    #: exact methods: True when optimality was proven, False when a limit stopped the search;
    #: None for heuristics
    certified: bool | None = None
    #: exact methods: remaining relative gap (objective - lower bound) / objective, 0 when
    #: proven; None for heuristics
    gap: float | None = None
    #: the checked, projected points the faces were built on (planar methods), with the
    #: file they were read from
    scan: PlanarScan | None = None
    #: per-vertex values by name, each (N,): what the scan file carried (colours as uint8
    #: ``red``, ``green``, ``blue``; ``intensity``, ...; the scan's ``point_data`` when not
    #: given); :meth:`save` writes them to PLY
    point_data: dict[str, np.ndarray] = field(default_factory=dict)
    #: merged surfaces (:func:`scanmesh.merge`): (M,) uint8 per face, an index into
    #: :attr:`LABELS`; written to PLY as the face property ``label``; None otherwise
    face_labels: np.ndarray | None = None
    #: the files the surface was made from besides :attr:`scan`'s (a merge's views), as
    #: they were when read: :meth:`save` refuses to replace any of them
    inputs: list[InputFile] = field(default_factory=list)

    #: What each code of :attr:`face_labels` means: ``measured`` (within the truncation of
    #: a sample), ``inferred`` (between space seen empty and space no ray entered),
    #: ``filled`` (closed with no evidence).
    LABELS = ("measured", "inferred", "filled")

    def __post_init__(self) -> None:
        if self.scan is not None:
            if self.frame is not None and self.frame is not self.scan.frame:
                raise ParameterError("a Surface's frame must be its scan's frame")
            self.frame = self.scan.frame
            if not self.point_data:
                self.point_data = dict(self.scan.point_data)
        try:
            self.point_data = checked_point_data(self.point_data, len(self.vertices))
        except ScanmeshError as exc:
            raise ParameterError(str(exc)) from None
        if self.face_labels is not None:
            labels = np.asarray(self.face_labels)
            if labels.shape != (len(self.faces),) or (
                len(labels) and (labels.dtype.kind not in "iu" or labels.max() >= len(self.LABELS))
            ):
                raise ParameterError(
                    f"face_labels must be ({len(self.faces)},) codes below {len(self.LABELS)},"
                    f" got {labels.dtype} {labels.shape}"
                )
            self.face_labels = labels.astype(np.uint8)

    @property
    def colors(self) -> np.ndarray | None:
        """(N, 3) or (N, 4) uint8 vertex colours from :attr:`point_data` (``red``, ``green``,
        ``blue``, ``alpha``; 16-bit and 0..1 float channels scaled), or None without them."""
        return colors_of(self.point_data)

    @property
    def georef(self) -> Georef | None:
        """The coordinate reference system and units of the scan file, when it records
        them (:class:`scanmesh.formats.georef.Georef`; LAS/LAZ, USGS DEM), else None."""
        return None if self.scan is None else self.scan.georef

    @cached_property
    def quality(self) -> Quality:
        """tac norms, smallest angle and sliver share of this mesh (computed once)."""
        return quality(self.vertices if self.scan is None else self.scan, self.faces)

    @cached_property
    def steep_fraction(self) -> float | None:
        """Share of triangles steeper than ``STEEP_ANGLE_DEG`` over the projection plane
        (None without a plane). Above ``STEEP_WARN_FRACTION``, ``reconstruct`` warns that the
        surface is probably not a height field over the plane."""
        if self.frame is None:
            return None
        return steep_fraction(self.vertices, self.faces, self.frame.normal)

    def to_trimesh(self) -> trimesh.Trimesh:
        """A ``trimesh.Trimesh`` sharing vertex indices (``process=False``), with the vertex
        colours of :attr:`colors` when the scan carried them."""
        trimesh = import_interruptibly("trimesh")

        return trimesh.Trimesh(
            vertices=self.vertices, faces=self.faces, vertex_colors=self.colors, process=False
        )

    def to_pyvista(self) -> pyvista.PolyData:
        """A ``pyvista.PolyData`` of the triangles over the same vertex indices, with every
        :attr:`point_data` array as point data and :attr:`colors` as ``"RGB"``/``"RGBA"``
        (plot with ``rgb=True``). O(N + M). Needs PyVista (``pip install
        "scanmesh[pyvista]"``; MissingExtraError otherwise)."""
        pyvista = require("pyvista", "pyvista", "Surface.to_pyvista()")
        cells = np.empty((len(self.faces), 4), dtype=np.int64)
        cells[:, 0] = 3
        cells[:, 1:] = self.faces
        mesh = pyvista.PolyData(np.array(self.vertices), cells.ravel())
        for name, values in self.point_data.items():
            mesh.point_data[name] = values
        colors = self.colors
        if colors is not None:
            mesh.point_data["RGB" if colors.shape[1] == 3 else "RGBA"] = colors
        return mesh

    def to_open3d(self) -> open3d.geometry.TriangleMesh:
        """An ``open3d.geometry.TriangleMesh`` over the same vertex indices, with
        :attr:`normals` as vertex normals and :attr:`colors` (RGB, 0..1) as vertex colours
        when the scan carried them (Open3D keeps no other per-vertex values). O(N + M).
        Needs Open3D (``pip install "scanmesh[open3d]"``; MissingExtraError otherwise)."""
        o3d = require("open3d", "open3d", "Surface.to_open3d()")
        vectors = o3d.utility
        mesh = o3d.geometry.TriangleMesh(
            vectors.Vector3dVector(np.ascontiguousarray(self.vertices, dtype=np.float64)),
            vectors.Vector3iVector(np.ascontiguousarray(self.faces, dtype=np.int32)),
        )
        mesh.vertex_normals = vectors.Vector3dVector(np.ascontiguousarray(self.normals))
        colors = self.colors
        if colors is not None:
            rgb = np.ascontiguousarray(colors[:, :3], dtype=np.float64) / 255.0
            mesh.vertex_colors = vectors.Vector3dVector(rgb)
        return mesh

    def vertex_measures(self, *, truth: Any = None, tac: bool = True) -> dict[str, np.ndarray]:
        """What scanmesh measured at each vertex, each (N,) float64, as :meth:`save` writes
        them to PLY: ``tac`` (radians, :attr:`quality`'s; NaN on boundary and unused
        vertices, which have none), ``height`` (model units: the signed distance from the
        projection plane, along its normal, as in :attr:`frame`; only with a frame) and,
        given ``truth`` (the true part: a mesh path, ``trimesh.Trimesh`` or
        :class:`scanmesh.evaluate.truth.TrueSurface`), ``error`` (model units: each
        vertex's unsigned closest-point distance to it). ``tac=False`` leaves tac out (its
        measurement is the costly part: :attr:`quality`). O(N + M) plus the truth's
        distance queries."""
        out = {"tac": self.quality.tac} if tac else {}
        if self.frame is not None:
            out["height"] = (self.vertices - self.frame.origin) @ self.frame.normal
        if truth is not None:
            part = truth if isinstance(truth, TrueSurface) else TrueSurface(truth)
            out["error"] = part.distance(self.vertices)
        return out

    def save(
        self,
        path: str | os.PathLike,
        *,
        truth: Any = None,
        tac: bool = True,
        progress: Progress = False,
    ) -> Path:
        """Write the mesh by file ending (.stl binary, .ply, .obj, .off; .html and .glb
        through :meth:`to_html` and :func:`scanmesh.present.view.save_glb`), atomically;
        ``progress`` as in :func:`scanmesh.formats.write.save_mesh` (stage "write").

        A PLY holds everything known per vertex: the vertex normals ``nx``, ``ny``, ``nz``
        (:attr:`normals`), :meth:`vertex_measures` (``tac``, ``height``, and ``error``
        against ``truth`` when given; ``tac=False``: no tac, so nothing is measured, as
        ``reconstruct --no-quality`` asks) and :attr:`point_data` (colours, intensity, ...;
        a carried value named like a measure or a normal is replaced by the measure). The
        scan's coordinate reference system and units (:attr:`georef`) go to PLY and OBJ
        header comments (STL, OFF and GLB have no place for them). ``truth`` is refused for
        the other endings.

        Refuses (ParameterError, before writing) to replace the scan file the surface was
        reconstructed from, or any file of :attr:`inputs` (a merge's views)."""
        suffix = check_ending(path)
        inputs = write.inputs_of(self)  # recorded when read: a later os.chdir cannot fool it
        write.check_not_input(path, inputs)
        if truth is not None and suffix != ".ply":
            raise ParameterError(
                f"truth= adds each vertex's error to a PLY file; {Path(path).name} is not one"
            )
        if suffix in (".html", ".htm"):
            return self.to_html(path)
        if suffix == ".glb":
            return view.save_glb(self, path)
        fmt = write.FORMATS.get(suffix)
        notes = self.georef.comments() if self.georef and fmt and fmt.comments else ()
        values: dict[str, Any] = {}
        if fmt is not None and fmt.point_data:
            measured = self.vertex_measures(truth=truth, tac=tac)
            carried = {
                k: v
                for k, v in self.point_data.items()
                if k not in measured and k not in ("nx", "ny", "nz", "tac")
            }
            values = {"normals": self.normals, "point_data": {**measured, **carried}}
            if self.face_labels is not None:
                values["face_data"] = {"label": self.face_labels}
        return write.save_mesh(
            path,
            self.vertices,
            self.faces,
            comments=notes,
            protect=inputs,
            progress=progress,
            **values,
        )

    def to_html(self, path: str | os.PathLike, **options: Any) -> Path:
        """Write a self-contained HTML page showing this mesh in 3-D (opens offline in any
        browser); ``options`` (``color_by``, ``truth``, ``view``, ``up``, ``title``) as in
        :func:`scanmesh.present.view.html_page`."""
        return view.save_html(self, path, **options)

    def show(self, **options: Any) -> None:
        """Open an interactive 3-D window (PyVista or trimesh's viewer, when installed);
        ``options`` as in :func:`scanmesh.present.view.show`."""
        view.show(self, **options)

    def _repr_html_(self) -> str | None:
        """Notebook display: the 3-D view of :meth:`to_html`, decimated for display above
        ``present.view.NOTEBOOK_FACES`` faces (the view says so)."""
        return view.notebook_html(self)

    @cached_property
    def normals(self) -> np.ndarray:
        """(N, 3) float64 unit vertex normals: the area-weighted mean of each vertex's face
        normals, by the faces' winding (zero for a point no face uses)."""
        return shape.vertex_normals(self.vertices, self.faces)

    @cached_property
    def face_normals(self) -> np.ndarray:
        """(M, 3) float64 unit face normals, by the faces' winding."""
        return shape.face_normals(self.vertices, self.faces)

    @cached_property
    def area(self) -> float:
        """Total area of the faces (model units squared)."""
        return shape.area(self.vertices, self.faces)

    @cached_property
    def label_areas(self) -> dict[str, float] | None:
        """Area (model units squared) of the faces of each label of :attr:`LABELS`, or None
        for a surface without :attr:`face_labels`."""
        if self.face_labels is None:
            return None
        tri = self.vertices[self.faces]
        each = 0.5 * np.linalg.norm(np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0]), axis=1)
        sums = np.bincount(self.face_labels, weights=each, minlength=len(self.LABELS))
        return {name: float(sums[k]) for k, name in enumerate(self.LABELS)}

    @cached_property
    def creases(self) -> list[np.ndarray]:
        """The crease polylines (vertex index arrays; a closed one ends on its first vertex):
        chains of edges whose two faces' normals differ by more than
        ``creases.CREASE_ANGLE_DEG`` degrees (:func:`scanmesh.creases.creases` takes
        another angle). O(M log M)."""
        return crease_lines(self.vertices, self.faces)

    def boundary_loops(self) -> list[np.ndarray]:
        """The outline and every hole as a closed loop of point indices (see
        :func:`scanmesh.shape.boundary_loops`)."""
        return shape.boundary_loops(self.faces)

    def __repr__(self) -> str:
        return (
            f"Surface(method={self.method!r}, vertices={len(self.vertices)}, "
            f"faces={len(self.faces)})"
        )
