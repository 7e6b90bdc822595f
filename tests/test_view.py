"""3-D views: the offline HTML page (drawn by a headless Chromium and compared with the PNG
renderer), the GLB file, notebook display, the interactive window and ``scanmesh view``."""

from __future__ import annotations

import base64
import html
import importlib.machinery
import json
import shutil
import subprocess
import sys
import types
from pathlib import Path

import numpy as np
import pytest
import trimesh
from PIL import Image

import scanmesh
from conftest import DATA
from scanmesh import MissingExtraError, ParameterError
from scanmesh.present import view as view_module
from scanmesh.present.render import auto_view, face_colors, shade_mesh
from scanmesh.present.view import html_page, notebook_html, save_glb, save_html, show
from test_render import tilted_sheet

CONROD = DATA / "cad" / "conrod_slevin48_onshape.stl"
CHROMIUM = next(
    (p for p in map(shutil.which, ("chromium", "chromium-browser", "google-chrome")) if p), None
)
needs_chromium = pytest.mark.skipif(CHROMIUM is None, reason="needs a chromium browser")
SIZE = (400, 300)
#: Rows at the top hold the page's note (two lines of text over the drawing).
NOTE_ROWS = 45


@pytest.fixture(scope="module")
def rod() -> scanmesh.Surface:
    points, _ = scanmesh.load_rod()
    return scanmesh.delaunay(points, plane="y")


def page_data(text: str) -> dict:
    start = text.index("const D = ") + len("const D = ")
    return json.loads(text[start : text.index(";\n", start)])


def screenshot(page: Path, out: Path) -> np.ndarray:
    """The page as a headless Chromium draws it (software WebGL), with every host name
    unresolvable and a dead proxy: a page that needed the network would stay blank."""
    result = subprocess.run(
        [
            CHROMIUM,
            "--headless",
            "--no-sandbox",
            "--use-angle=swiftshader",
            "--enable-unsafe-swiftshader",
            "--force-device-scale-factor=1",
            "--hide-scrollbars",
            "--host-resolver-rules=MAP * ~NOTFOUND",
            "--proxy-server=127.0.0.1:9",
            f"--user-data-dir={out.parent / 'chromium-profile'}",
            f"--window-size={SIZE[0]},{SIZE[1]}",
            f"--screenshot={out}",
            page.resolve().as_uri(),
        ],
        capture_output=True,
        text=True,
        timeout=180,
    )
    assert out.is_file(), result.stderr[-2000:]
    with Image.open(out) as image:
        return np.asarray(image.convert("RGB"))[:, :, :3]


def drawn(image: np.ndarray) -> np.ndarray:
    mask = np.any(image < 250, axis=-1)
    mask[:NOTE_ROWS] = False
    return mask


@needs_chromium
def test_the_page_draws_in_a_browser_as_the_png_renderer_does(tmp_path, rod):
    page = save_html(rod, tmp_path / "rod.html")
    shot = screenshot(page, tmp_path / "shot.png")
    assert shot.shape[:2] == (SIZE[1], SIZE[0])
    seen = drawn(shot)
    assert seen.mean() > 0.05, "the page is blank"
    ref = drawn(
        shade_mesh(rod, size=SIZE, supersample=1, **auto_view(rod.vertices, rod.faces, rod.frame))
    )
    overlap = (seen & ref).sum() / (seen | ref).sum()
    assert overlap > 0.9, overlap
    # shaded, not a flat silhouette: the facets' brightness varies
    assert np.ptp(shot[seen].astype(int).sum(axis=1)) > 60


@needs_chromium
def test_colours_and_light_in_the_browser_match_the_png(tmp_path):
    vertices, faces = tilted_sheet()
    camera = {"view": (-0.3, -1.0, 0.8), "up": "z"}
    page = save_html((vertices, faces), tmp_path / "sheet.html", color_by="height", **camera)
    shot = screenshot(page, tmp_path / "shot.png").astype(int)
    colors, _ = face_colors((vertices, faces), "height", up="z")
    ref = shade_mesh((vertices, faces), size=SIZE, supersample=1, color=colors, **camera).astype(
        int
    )
    both = drawn(shot) & drawn(ref)
    both[-40:, :260] = False  # the legend
    assert both.sum() > 0.2 * both.size
    # away from facet edges the two renderers agree on every colour channel
    diff = np.abs(shot - ref)[both].max(axis=1)
    assert np.median(diff) <= 6 and np.mean(diff <= 12) > 0.9, np.percentile(diff, [50, 90])


def test_the_page_is_self_contained_and_carries_the_mesh(tmp_path, rod):
    text = html_page(rod, color_by="tac", title="a <rod>")
    lower = text.lower()
    for outside in ("http:", "https:", "//cdn", " src=", "<link", "@import", "url("):
        assert outside not in lower, outside
    assert "<title>a &lt;rod&gt;</title>" in text and f"{len(rod.faces):,} faces" in text
    data = page_data(text)
    assert data["faces"] == len(rod.faces)
    corners = np.frombuffer(base64.b64decode(data["positions"]), "<f4").reshape(-1, 3, 3)
    # the page holds each face's corners, centred and scaled by one factor
    true = rod.vertices[rod.faces]
    scale = np.ptp(true.reshape(-1, 3), axis=0) / np.ptp(corners.reshape(-1, 3), axis=0)
    np.testing.assert_allclose(scale, scale[0], rtol=1e-5)
    shifted = true / scale[0]
    offset = (shifted - corners).reshape(-1, 3).mean(axis=0)
    np.testing.assert_allclose(corners + offset, shifted, atol=1e-5)
    assert np.abs(corners).max() <= 1 + 1e-6
    colors = np.frombuffer(base64.b64decode(data["colors"]), np.uint8).reshape(-1, 3, 3)
    rgb, scale_ = face_colors(rod, "tac", up=auto_view(rod.vertices, rod.faces, rod.frame)["up"])
    np.testing.assert_array_equal(colors[:, 0], np.rint(rgb * 255))
    assert f"{scale_.hi:.4g}" in text  # the legend's upper end


def test_html_and_glb_through_surface(tmp_path, rod):
    assert rod.save(tmp_path / "r.html") == tmp_path / "r.html"
    assert page_data((tmp_path / "r.html").read_text())["faces"] == len(rod.faces)
    rod.to_html(tmp_path / "t.html", color_by="height", title="T")
    assert "<title>T</title>" in (tmp_path / "t.html").read_text()
    rod.save(tmp_path / "r.glb")
    scene = trimesh.load(tmp_path / "r.glb")
    (mesh,) = scene.geometry.values()
    assert len(mesh.faces) == len(rod.faces)
    # glTF is y-up: compare coordinates as sets of face centroids, any axis order
    got = np.sort(np.abs(mesh.triangles_center).sum(axis=1))
    want = np.sort(np.abs(rod.vertices[rod.faces].mean(axis=1)).sum(axis=1))
    np.testing.assert_allclose(got, want, rtol=1e-5, atol=1e-6)
    raw = (tmp_path / "r.glb").read_bytes()
    length = int.from_bytes(raw[12:16], "little")
    gltf = json.loads(raw[20 : 20 + length])
    attributes = gltf["meshes"][0]["primitives"][0]["attributes"]
    assert {"POSITION", "NORMAL", "COLOR_0"} <= set(attributes)


def test_glb_colours_each_face(tmp_path):
    vertices, faces = tilted_sheet(6)
    save_glb((vertices, faces), tmp_path / "s.glb", color_by="height", up="z")
    (mesh,) = trimesh.load(tmp_path / "s.glb").geometry.values()
    want = np.rint(face_colors((vertices, faces), "height", up="z")[0] * 255)
    got = mesh.visual.vertex_colors[:, :3].reshape(-1, 3, 3)
    assert np.all(got == got[:, :1])  # one colour per face
    np.testing.assert_array_equal(np.sort(got[:, 0], axis=0), np.sort(want, axis=0))


def test_bad_requests(tmp_path, rod):
    with pytest.raises(ParameterError, match=r"\.html"):
        save_html(rod, tmp_path / "x.png")
    with pytest.raises(ParameterError, match=r"\.glb"):
        save_glb(rod, tmp_path / "x.gltf")
    with pytest.raises(ParameterError, match="truth"):
        html_page(rod, color_by="error")
    with pytest.raises(ParameterError, match="only to colour by error"):
        save_html(rod, tmp_path / "x.html", truth=CONROD)
    assert not list(tmp_path.iterdir())


def test_notebook_display(monkeypatch, rod):
    shown = rod._repr_html_()
    assert shown.startswith("<iframe srcdoc=") and "<script" not in shown
    inner = html.unescape(shown[len('<iframe srcdoc="') : shown.index('" style=')])
    assert page_data(inner)["faces"] == len(rod.faces)
    monkeypatch.setattr(view_module, "NOTEBOOK_FACES", len(rod.faces) // 4)
    coarse = html.unescape(rod._repr_html_())
    assert f"of {len(rod.faces):,} faces)" in coarse and "decimated for display" in coarse
    assert 0 < page_data(coarse[coarse.index("<!DOCTYPE") :])["faces"] <= len(rod.faces) // 4
    assert notebook_html((rod.vertices, rod.faces[:0])) is None


def fake_module(name: str, **attrs) -> types.ModuleType:
    module = types.ModuleType(name)
    module.__spec__ = importlib.machinery.ModuleSpec(name, None)
    module.__dict__.update(attrs)
    return module


def test_show_uses_pyvista_when_installed(monkeypatch, rod):
    calls = {}

    class PolyData:
        def __init__(self, points, cells):
            calls["points"], calls["cells"] = points, cells
            self.cell_data = {}

    class Plotter:
        def add_mesh(self, mesh, **kw):
            calls["mesh"], calls["kw"] = mesh, kw

        def show(self):
            calls["shown"] = True

    monkeypatch.setitem(
        sys.modules, "pyvista", fake_module("pyvista", PolyData=PolyData, Plotter=Plotter)
    )
    rod.show(color_by="height")
    assert calls["shown"] and calls["points"] is not None
    cells = calls["cells"].reshape(-1, 4)
    assert np.all(cells[:, 0] == 3)
    np.testing.assert_array_equal(cells[:, 1:], rod.faces)
    assert calls["kw"]["rgb"] and calls["mesh"].cell_data["color"].shape == (len(rod.faces), 3)


def test_show_without_a_viewer_says_what_to_install(monkeypatch, rod):
    monkeypatch.setitem(sys.modules, "pyvista", None)
    monkeypatch.setitem(sys.modules, "pyglet", None)
    with pytest.raises(MissingExtraError, match="pyvista.*pyglet.*to_html"):
        show(rod)


def run(*args) -> subprocess.CompletedProcess:
    return subprocess.run(
        [sys.executable, "-m", "scanmesh", *map(str, args)],
        capture_output=True,
        text=True,
        timeout=300,
    )


@pytest.mark.slow
def test_view_command_writes_the_page(tmp_path):
    out = tmp_path / "rod.html"
    result = run("view", CONROD, "-o", out, "--no-open", "--color", "tac")
    assert result.returncode == 0, result.stderr
    assert f"wrote {out}" in result.stdout
    mesh = trimesh.load(CONROD)
    assert page_data(out.read_text())["faces"] == len(mesh.faces)
    result = run("view", CONROD, "-o", tmp_path / "rod.glb", "--color", "height")
    assert result.returncode == 0, result.stderr
    assert len(next(iter(trimesh.load(tmp_path / "rod.glb").geometry.values())).faces) == len(
        mesh.faces
    )


@pytest.mark.slow
def test_view_command_default_goes_to_a_new_folder(tmp_path):
    result = subprocess.run(
        [sys.executable, "-m", "scanmesh", "view", str(CONROD), "--no-open"],
        capture_output=True,
        text=True,
        cwd=tmp_path,
        timeout=300,
    )
    assert result.returncode == 0, result.stderr
    written = Path(result.stdout.split("wrote ", 1)[1].strip())
    assert written.name == "conrod_slevin48_onshape.html" and written.parent != tmp_path
    assert written.is_file() and not list(tmp_path.iterdir())
    shutil.rmtree(written.parent)


@pytest.mark.slow
def test_view_and_render_command_errors(tmp_path):
    for args, fragment in (
        (("view", CONROD, "-o", tmp_path / "x.png", "--no-open"), ".html or .glb"),
        (("view", CONROD, "-o", tmp_path / "no" / "x.html", "--no-open"), "does not exist"),
        (("view", CONROD, "--color", "error", "--no-open"), "--truth"),
        (("render", CONROD, "-o", tmp_path / "x.png", "--truth", CONROD), "--color error"),
    ):
        result = run(*args)
        assert result.returncode == 1 and fragment in result.stderr, (args, result.stderr)
        assert "Traceback" not in result.stderr
    result = run("render", CONROD, "-o", tmp_path / "x.png", "--color", "curvature")
    assert result.returncode == 2 and "invalid choice" in result.stderr


@pytest.mark.slow
def test_render_command_colours_by_error_against_the_truth(tmp_path):
    """The rod against itself shifted: coloured pictures differ from the plain one."""
    mesh = trimesh.load(CONROD)
    bent = mesh.copy()
    bent.vertices[:, 1] += 0.05 * np.sin(3 * bent.vertices[:, 0])
    bent_path = tmp_path / "bent.stl"
    bent.export(bent_path)
    plain, error = tmp_path / "plain.png", tmp_path / "error.png"
    assert run("render", bent_path, "-o", plain, "--size", "160x120").returncode == 0
    flags = ("--size", "160x120", "--color", "error", "--truth", CONROD, "--no-bar")
    result = run("render", bent_path, "-o", error, *flags)
    assert result.returncode == 0, result.stderr
    a, b = (np.asarray(Image.open(p).convert("RGB")).astype(int) for p in (plain, error))
    assert np.array_equal(a.sum(-1) == 765, b.sum(-1) == 765)  # same silhouette
    hues = {tuple(c) for c in (b[b.sum(-1) < 765] // 32)}
    assert len(hues) > len({tuple(c) for c in (a[a.sum(-1) < 765] // 32)}) + 3
