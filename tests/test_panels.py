"""render_panels: meshes side by side, lit, on one colour scale with one bar; the render
command's colour bar and the reconstruct command's --preview camera."""

from __future__ import annotations

import subprocess
import sys

import numpy as np
import pytest
from PIL import Image

import scanmesh
from conftest import DATA
from scanmesh import ParameterError
from scanmesh.present.panels import render_panels
from scanmesh.present.render import VIRIDIS, auto_view, render_mesh

CONROD = DATA / "cad" / "conrod_slevin48_onshape.stl"


def run(*args) -> subprocess.CompletedProcess:
    return subprocess.run(
        [sys.executable, "-m", "scanmesh", *map(str, args)],
        capture_output=True,
        text=True,
        timeout=300,
    )


def _square(z: float, n: int = 6):
    """A flat n x n grid at height z, triangulated."""
    x, y = np.meshgrid(np.linspace(0, 1, n), np.linspace(0, 1, n))
    pts = np.column_stack([x.ravel(), y.ravel(), np.full(n * n, z)])
    return scanmesh.reconstruct(pts, "delaunay", plane="z")


def _pixels(path):
    return np.asarray(Image.open(path).convert("RGB")).astype(int)


def test_panels_share_one_height_scale_and_draw_its_bar(tmp_path):
    low, high = _square(0.0), _square(1.0)
    path = render_panels(
        [low, high],
        tmp_path / "p.png",
        titles=["low", "high"],
        color_by="height",
        height="z",
        view="z",
        up="y",
        size=(200, 160),
    )
    image = _pixels(path)
    h, w, _ = image.shape
    assert w > 2 * 200 and h > 160  # two panels, the bar to their right, titles above
    # each panel's middle: the low square is the scale's bottom (viridis dark blue-purple,
    # blue above green), the high one its top (yellow, red and green above blue)
    left = image[h // 2, 100]
    right = image[h // 2, 300]
    assert left[2] > left[1] and right[0] > right[2] and right[1] > right[2]
    # the bar holds both ends of the scale, unlit (viridis' end colours, give or take the
    # half pixel at each end)
    bar = image[:, 2 * 200 :].reshape(-1, 3)
    for end in (VIRIDIS[0], VIRIDIS[-1]):
        want = np.rint(np.asarray(end) * 255)
        assert (np.abs(bar - want).max(axis=1) <= 25).any(), end


def test_one_scale_for_all_panels_is_not_each_panels_own(tmp_path):
    # alone, each square is one colour at the bottom of its own scale; side by side the
    # high one must differ from the low one
    alone = [
        _pixels(
            render_panels(
                [m],
                tmp_path / f"{k}.png",
                color_by="height",
                height="z",
                view="z",
                up="y",
                size=(120, 100),
            )
        )
        for k, m in enumerate((_square(0.0), _square(1.0)))
    ]
    assert np.array_equal(alone[0][:, :120], alone[1][:, :120])  # the panels; the bars differ
    together = _pixels(
        render_panels(
            [_square(0.0), _square(1.0)],
            tmp_path / "t.png",
            color_by="height",
            height="z",
            view="z",
            up="y",
            size=(120, 100),
        )
    )
    h = together.shape[0]
    assert not np.array_equal(together[h // 2, 60], together[h // 2, 180])


def test_lit_panels_show_shape_and_tac_colours_a_bent_surface(tmp_path):
    rng = np.random.default_rng(2)
    pts = rng.random((400, 3))
    pts[:, 2] = 0.3 * np.sin(4 * pts[:, 0])
    bent = scanmesh.reconstruct(pts, "delaunay")
    flat = scanmesh.reconstruct(np.column_stack([pts[:, :2], np.zeros(400)]), "delaunay")
    plain = _pixels(render_panels([bent], tmp_path / "b.png", size=(200, 160)))
    painted = plain[(plain.sum(-1) < 765)]
    assert len(np.unique(painted.sum(-1))) > 20  # the light shades the bends
    tac = _pixels(
        render_panels(
            [flat, bent],
            tmp_path / "t.png",
            color_by="tac",
            titles=["flat", "bent"],
            size=(200, 160),
        )
    )
    h = tac.shape[0]
    flat_half, bent_half = tac[:, :200], tac[:, 200:400]
    hues = [
        len({tuple(c) for c in half[half.sum(-1) < 765] // 32}) for half in (flat_half, bent_half)
    ]
    assert hues[1] > hues[0] and h > 160


def test_render_panels_refuses_what_it_cannot_draw(tmp_path):
    sq = _square(0.0)
    with pytest.raises(ParameterError, match="2 meshes but 1 titles"):
        render_panels([sq, sq], tmp_path / "x.png", titles=["one"])
    with pytest.raises(ParameterError, match="at least one mesh"):
        render_panels([], tmp_path / "x.png")
    with pytest.raises(ParameterError, match="only to colour by error"):
        render_panels([sq], tmp_path / "x.png", truth=CONROD)
    with pytest.raises(ParameterError, match="PNG"):
        render_panels([sq], tmp_path / "x.jpg")


@pytest.mark.slow
def test_render_command_draws_a_bar_with_colours_and_no_bar_on_request(tmp_path):
    bar, bare = tmp_path / "bar.png", tmp_path / "bare.png"
    assert run("render", CONROD, "-o", bar, "--color", "tac", "--size", "200x150").returncode == 0
    result = run("render", CONROD, "-o", bare, "--color", "tac", "--size", "200x150", "--no-bar")
    assert result.returncode == 0, result.stderr
    assert Image.open(bare).size == (200, 150)
    width, height = Image.open(bar).size
    assert width > 250 and height > 150


@pytest.mark.slow
def test_reconstruct_preview_takes_the_camera(tmp_path):
    scan = tmp_path / "scan.xyz"
    rng = np.random.default_rng(0)
    pts = rng.random((300, 3))
    pts[:, 2] = 0.2 * np.sin(3 * pts[:, 0])
    scanmesh.formats.write.write_points(scan, pts)
    default, top = tmp_path / "d.png", tmp_path / "top.png"
    args = ("reconstruct", scan, "-o", tmp_path / "m.ply", "--method", "delaunay")
    assert run(*args, "--preview", default).returncode == 0
    result = run(*args, "--preview", top, "--view", "z", "--up", "y")
    assert result.returncode == 0, result.stderr
    mesh = scanmesh.reconstruct(scan, "delaunay")
    want = render_mesh(mesh, tmp_path / "want.png", view="z", up="y")
    assert top.read_bytes() == want.read_bytes()
    cam = auto_view(mesh.vertices, mesh.faces, mesh.frame)
    assert default.read_bytes() == render_mesh(mesh, tmp_path / "w2.png", **cam).read_bytes()
    result = run(*args, "--view", "z")
    assert result.returncode == 2 and "--view sets the --preview camera" in result.stderr
