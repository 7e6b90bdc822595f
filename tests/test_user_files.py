"""The files, pictures and habits users bring: what ``read`` returns composes with the rest,
colours read true, errors name what happened."""

from __future__ import annotations

import re
import traceback
import warnings

import numpy as np
import pytest
import trimesh

import scanmesh
from conftest import DATA
from scanmesh.formats.xyz import up_comment
from scanmesh.present.render import auto_view, face_colors, face_values, render_mesh
from scanmesh.present.view import html_page, save_glb
from test_cli import run


def _heights(tmp_path):
    x = np.linspace(0.0, 3.0, 9)
    y = np.linspace(0.0, 2.0, 7)
    z = np.sin(x)[None, :] * np.cos(y)[:, None] + 5.0
    path = tmp_path / "heights.txt"
    np.savetxt(path, z)
    return path


def test_reconstruct_takes_what_read_returns(tmp_path):
    path = _heights(tmp_path)
    scan = scanmesh.read(path, grid=True)
    got = scanmesh.reconstruct(scan, "delaunay")
    want = scanmesh.reconstruct(scanmesh.planar_scan(path, read_options={"grid": True}), "delaunay")
    assert np.array_equal(got.faces, want.faces)
    assert np.array_equal(got.vertices, scan.points)
    assert got.scan is not None and got.scan.source == path
    # the strip methods use the file's lines
    strips = scanmesh.reconstruct(scan, "shortest-path")
    assert np.array_equal(
        strips.faces, scanmesh.reconstruct(scan.points, "shortest-path", lines=scan.line_ids).faces
    )
    # and the stage functions take it too
    assert np.array_equal(scanmesh.delaunay(scan).faces, got.faces)


def test_reconstruct_of_read_uses_the_recorded_up(tmp_path):
    rng = np.random.default_rng(3)
    u, v = np.meshgrid(np.linspace(0, 2, 12), np.linspace(0, 1, 8))
    pts = np.column_stack([u.ravel(), v.ravel(), 0.05 * rng.standard_normal(u.size)])
    # tilt the sheet: with the recorded up, plane choice must offer the file's direction
    up = np.array([0.0, 0.6, 0.8])
    rot = np.array([[1.0, 0.0, 0.0], [0.0, 0.8, -0.6], [0.0, 0.6, 0.8]])
    pts = pts @ rot.T
    path = tmp_path / "tilted.xyz"
    with open(path, "w") as f:
        f.write(up_comment(up))
        for row in range(8):
            np.savetxt(f, pts[row * 12 : (row + 1) * 12])
            f.write("\n")
    from_path = scanmesh.reconstruct(path, "delaunay")
    from_read = scanmesh.reconstruct(scanmesh.read(path), "delaunay")
    assert np.array_equal(from_read.faces, from_path.faces)
    assert from_read.options["plane_choice"] == from_path.options["plane_choice"]


def _legend(page: str) -> tuple[float, str, float]:
    lo, label, hi = re.search(
        r'<div class="ends"><span>([^<]*)</span><span>([^<]*)</span><span>([^<]*)</span>', page
    ).groups()
    return float(lo), label, float(hi)


@pytest.fixture(scope="module")
def terrain():
    """Mount St. Helens (USGS DEM, UTM metres, elevations 682-2,543 m) as a Delaunay mesh."""
    scan = scanmesh.read(DATA / "terrain" / "SainteHelens.dem")
    return scanmesh.reconstruct(scan.points, "delaunay")


def test_colour_by_height_on_terrain_reads_the_elevations(terrain):
    z = terrain.vertices[terrain.faces].mean(axis=1)[:, 2]
    lo, label, hi = _legend(html_page(terrain, color_by="height"))
    assert label.startswith("height")
    assert lo == pytest.approx(z.min(), rel=1e-3) and hi == pytest.approx(z.max(), rel=1e-3)
    assert 600 < lo < 800 and 2400 < hi < 2600
    _, scale = face_colors(terrain, "height", up="z")
    assert (scale.lo, scale.hi) == (z.min(), z.max())


@pytest.mark.slow
def test_glb_coloured_by_height_on_terrain_follows_the_elevation(tmp_path, terrain):
    # by default, not a tilted mix of elevation and northing along the best-fit normal
    default = save_glb(terrain, tmp_path / "default.glb", color_by="height")
    along_z = save_glb(terrain, tmp_path / "z.glb", color_by="height", up="z")
    assert default.read_bytes() == along_z.read_bytes()


@pytest.mark.slow
def test_scanmesh_render_colours_terrain_by_elevation(tmp_path, terrain):
    mesh = tmp_path / "terrain.ply"
    terrain.save(mesh)
    png = tmp_path / "height.png"
    result = run("render", mesh, "-o", png, "--color", "height", "--size", "200x150", "--no-bar")
    assert result.returncode == 0, result.stderr
    loaded = trimesh.load_mesh(mesh, process=False)
    vertices, faces = np.asarray(loaded.vertices), np.asarray(loaded.faces)
    want = tmp_path / "want.png"
    cam = auto_view(vertices, faces)
    render_mesh((vertices, faces), want, size=(200, 150), color_by="height", height="z", **cam)
    assert png.read_bytes() == want.read_bytes()


def test_colour_by_height_along_a_slanted_direction_starts_at_zero():
    rng = np.random.default_rng(1)
    pts = np.column_stack(
        [5e5 + 100 * rng.random(200), 5e6 + 100 * rng.random(200), 700 + rng.random(200)]
    )
    mesh = scanmesh.delaunay(pts, plane="z")
    _, scale = face_colors(mesh, "height", up=(0.0, 0.6, 0.8))
    assert scale.lo == 0.0
    assert 0 < scale.hi < 100  # the part's own extent along that direction, not 3e6


def test_tac_colours_of_a_flat_part_are_one_colour():
    rng = np.random.default_rng(5)
    uv = rng.random((300, 2)) * 37.0
    # a tilted plane: every corner angle rounds, so the tac is rounding only (~1e-15)
    pts = np.column_stack([uv, 0.3 * uv[:, 0] - 0.7 * uv[:, 1] + 11.0])
    mesh = scanmesh.delaunay(pts, plane="z")
    tac = np.nan_to_num(scanmesh.quality(mesh.vertices, mesh.faces).tac)
    assert 0 < tac.max() < 1e-12  # there is rounding to stretch
    rgb, scale = face_colors(mesh, "tac")
    assert scale.lo == 0.0 and scale.hi >= 1e-9
    coloured = rgb[np.isfinite(face_values(mesh, "tac")[0])]
    assert len(np.unique(coloured, axis=0)) == 1
    # and real curvature is still coloured
    bent = scanmesh.delaunay(np.column_stack([uv, 0.01 * (uv**2).sum(axis=1)]), plane="z")
    rgb, scale = face_colors(bent, "tac")
    assert scale.hi > 1e-6 and len(np.unique(rgb, axis=0)) > 10


@pytest.mark.parametrize("name", ["nope.xyz", "nope.stl", "nope.ply"])
def test_a_missing_input_is_a_file_not_found_error(tmp_path, name):
    path = tmp_path / name
    for call in (scanmesh.read, lambda p: scanmesh.reconstruct(p, "delaunay")):
        with pytest.raises(FileNotFoundError) as caught:
            call(path)
        assert isinstance(caught.value, scanmesh.FileFormatError)  # still a ScanmeshError
        assert caught.value.filename == str(path) and str(path) in str(caught.value)
        assert not str(caught.value).startswith("[Errno")


def test_a_missing_mesh_is_a_file_not_found_error(tmp_path):
    with pytest.raises(FileNotFoundError, match="nothing.stl"):
        scanmesh.simulate_scan(tmp_path / "nothing.stl", up="z", spacing=0.5)


def test_errors_are_shown_by_their_public_names():
    for name in ("ScanmeshError", "DegenerateInputError", "ParameterError", "FileFormatError"):
        cls = getattr(scanmesh, name)
        assert f"{cls.__module__}.{cls.__qualname__}" == f"scanmesh.{name}"
    try:
        scanmesh.delaunay(np.zeros((2, 3)))
    except scanmesh.ScanmeshError as exc:
        shown = "".join(traceback.format_exception_only(type(exc), exc))
    assert shown.startswith("scanmesh.DegenerateInputError: ")
    assert "_core" not in shown


def test_a_nan_reads_nan_in_messages():
    pts = np.array([[0.0, 0.0, 0.0], [1.0, np.nan, 0.0], [0.0, 1.0, 0.0]])
    with pytest.raises(scanmesh.ScanmeshError, match=r"y=nan\b") as caught:
        scanmesh.reconstruct(pts, "delaunay")
    assert "np.float64" not in str(caught.value)
    with pytest.raises(scanmesh.ParameterError, match=r"got nan$") as caught:
        scanmesh.reconstruct(
            np.random.default_rng(0).random((10, 3)), "delaunay", max_edge=np.float64("nan")
        )


@pytest.mark.slow
@pytest.mark.parametrize("plane", [None, "z"])
def test_no_height_field_warning_for_a_smooth_height_field(plane):
    rng = np.random.default_rng(0)
    xy = rng.random((30, 2))
    pts = np.column_stack([xy, np.sin(3 * xy[:, 0]) * np.cos(2 * xy[:, 1])])
    with warnings.catch_warnings():
        warnings.simplefilter("error", scanmesh.NotAHeightFieldWarning)
        surface = scanmesh.reconstruct(pts, "anneal", plane=plane)
    # annealing's own steep slivers, still measured (the sliver rule holds them near 5 %)
    assert surface.steep_fraction > 0.0


def test_a_surface_folded_over_the_plane_still_warns():
    t, h = np.meshgrid(np.linspace(0.2, 2 * np.pi - 0.2, 40), np.linspace(0, 1, 12))
    pts = np.column_stack([np.cos(t).ravel(), h.ravel(), np.sin(t).ravel()])  # a tube's side
    with pytest.warns(scanmesh.NotAHeightFieldWarning):
        scanmesh.reconstruct(pts, "anneal", plane="z", sweeps=5)
