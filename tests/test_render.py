"""Pictures: shaded meshes, side-by-side comparisons and convergence plots are real PNGs."""

from __future__ import annotations

import warnings

import numpy as np
import pytest
import trimesh
from PIL import Image

from scanmesh.errors import InvalidMeshError, ParameterError, WireZoomWarning
from scanmesh.present.panels import render_compare
from scanmesh.present.render import (
    NO_VALUE,
    VIRIDIS,
    WIRE,
    colormap,
    face_colors,
    face_values,
    plot_convergence,
    render_mesh,
    shade_mesh,
)

WHITE = np.array([255, 255, 255])


def read_png(path) -> np.ndarray:
    with Image.open(path) as image:
        assert image.format == "PNG"
        return np.asarray(image.convert("RGB"))


def not_background(image: np.ndarray) -> np.ndarray:
    return np.any(image != WHITE, axis=-1)


@pytest.fixture(scope="module")
def ball() -> trimesh.Trimesh:
    return trimesh.creation.icosphere(subdivisions=3)


def trace(n: int = 200) -> dict[str, np.ndarray]:
    sweep = np.arange(n)
    energy = 40 + 20 * np.exp(-sweep / 40) + np.sin(sweep)
    return {
        "temperature": 1.5 * 0.97**sweep,
        "energy": energy,
        "best": np.minimum.accumulate(energy),
        "acceptance": 0.8 * np.exp(-sweep / 50),
    }


# --- bad input first -------------------------------------------------------------------


def test_not_a_mesh_raises(tmp_path):
    with pytest.raises(ParameterError, match="Trimesh"):
        render_mesh("ball.stl", tmp_path / "a.png")


def test_mesh_without_faces_raises(tmp_path):
    with pytest.raises(InvalidMeshError, match="faces"):
        render_mesh((np.eye(3), np.empty((0, 3), int)), tmp_path / "a.png")


def test_faces_out_of_range_raise(tmp_path):
    with pytest.raises(InvalidMeshError, match="outside"):
        render_mesh((np.eye(3), [[0, 1, 3]]), tmp_path / "a.png")


def test_not_png_raises(tmp_path, ball):
    with pytest.raises(ParameterError, match="PNG"):
        render_mesh(ball, tmp_path / "a.jpg")
    with pytest.raises(ParameterError, match="PNG"):
        plot_convergence(trace(), tmp_path / "a.svg")


@pytest.mark.parametrize("size", [(0, 10), (10, -1)])
def test_bad_size_raises(ball, size):
    with pytest.raises(ParameterError, match="size"):
        shade_mesh(ball, size=size)


def test_bad_view_raises(ball):
    with pytest.raises(ParameterError, match="view"):
        shade_mesh(ball, view=(0, 0, 0))


def test_compare_title_count_must_match(tmp_path, ball):
    with pytest.raises(ParameterError, match="titles"):
        render_compare([ball, ball], tmp_path / "c.png", titles=["one"])
    with pytest.raises(ParameterError, match="at least one"):
        render_compare([], tmp_path / "c.png")


def test_trace_must_have_energy_and_equal_lengths(tmp_path):
    with pytest.raises(ParameterError, match="energy"):
        plot_convergence({"temperature": [1, 0.5]}, tmp_path / "t.png")
    bad = trace()
    bad["acceptance"] = bad["acceptance"][:-1]
    with pytest.raises(ParameterError, match="equal lengths"):
        plot_convergence(bad, tmp_path / "t.png")
    with pytest.raises(ParameterError, match="empty"):
        plot_convergence({"energy": []}, tmp_path / "t.png")
    with pytest.raises(ParameterError, match="mapping"):
        plot_convergence([1, 2, 3], tmp_path / "t.png")
    assert not (tmp_path / "t.png").exists()


# --- the shaded mesh ------------------------------------------------------------------


def test_render_writes_a_real_picture(tmp_path, ball):
    path = render_mesh(ball, tmp_path / "ball.png", size=(320, 240))
    assert path == tmp_path / "ball.png"
    image = read_png(path)
    assert image.shape == (240, 320, 3)
    assert np.all(image[0, 0] == WHITE) and np.all(image[-1, -1] == WHITE)
    part = not_background(image)
    assert 0.2 < part.mean() < 0.9  # the ball fills the picture but not all of it
    # flat shading: many distinct shades over the ball, dark and light
    grey = image[part].mean(axis=1)
    assert len(np.unique(image[part], axis=0)) > 50
    assert grey.max() - grey.min() > 80
    assert not list(tmp_path.glob(".*.part"))  # written atomically


def test_orthographic_view_is_not_mirrored():
    # one triangle in the quadrant x < 0, y > 0, seen from above (+z) with y up the screen
    tri = (np.array([[-1.0, 0.2, 0], [-0.2, 0.2, 0], [-1.0, 1.0, 0]]), [[0, 1, 2]])
    box = ((-1.0, -1.0), (1.0, 1.0))  # screen box: right = +x, up = +y
    image = shade_mesh(tri, size=(200, 200), view="z", up="y", supersample=1, bounds=box)
    part = not_background(image)
    top, bottom = part[:100], part[100:]
    assert top[:, :100].sum() > 1000  # upper left
    assert top[:, 100:].sum() == 0 and bottom.sum() == 0
    # seen from below (-z) with y still up, x runs right to left: the triangle moves right
    below = shade_mesh(tri, size=(200, 200), view="-z", up="y", supersample=1, bounds=box)
    part = not_background(below)
    assert part[:100, 100:].sum() > 1000 and part[:, :100].sum() == 0


def test_z_buffer_keeps_the_nearest_face():
    # a level square below a tilted square: from above only the tilted one's shade shows
    level = np.array([[-1.0, -1, 0], [1, -1, 0], [1, 1, 0], [-1, 1, 0]])
    tilted = np.array([[-0.5, -0.5, 1.0], [0.5, -0.5, 1.5], [0.5, 0.5, 1.5], [-0.5, 0.5, 1.0]])
    quads = [[0, 1, 2], [0, 2, 3]]
    near_first = (np.vstack([tilted, level]), np.array(quads + [[4, 5, 6], [4, 6, 7]]))
    far_first = (np.vstack([level, tilted]), np.array(quads + [[4, 5, 6], [4, 6, 7]]))
    a = shade_mesh(near_first, size=(100, 100), view="z", up="y", supersample=1)
    b = shade_mesh(far_first, size=(100, 100), view="z", up="y", supersample=1)
    np.testing.assert_array_equal(a, b)  # drawing order does not matter
    centre, rim = a[50, 50], a[5, 50]
    assert not np.array_equal(centre, rim)  # tilted and level faces shade differently
    tilted_only = shade_mesh((tilted, np.array(quads)), size=(100, 100), view="z", up="y")
    assert tilted_only[50, 50].tolist() != [255, 255, 255]


def test_wire_draws_edges(ball):
    plain = shade_mesh(ball, size=(300, 300))
    wired = shade_mesh(ball, size=(300, 300), wire=True)
    assert plain.shape == wired.shape
    dark = np.asarray(WIRE) * 255 + 40
    n_plain = np.all(plain < dark, axis=-1).sum()
    n_wired = np.all(wired < dark, axis=-1).sum()
    assert n_wired > n_plain + 1000


def test_supersampling_keeps_the_size_and_softens_edges(ball):
    sharp = shade_mesh(ball, size=(160, 120), supersample=1)
    smooth = shade_mesh(ball, size=(160, 120), supersample=3)
    assert sharp.shape == smooth.shape == (120, 160, 3)
    assert len(np.unique(smooth.reshape(-1, 3), axis=0)) > len(
        np.unique(sharp.reshape(-1, 3), axis=0)
    )


def test_renders_a_scanmesh_surface(tmp_path):
    from scanmesh import delaunay, simulate_scan

    points, _ = simulate_scan(trimesh.creation.icosphere(subdivisions=2), spacing=0.1)
    surface = delaunay(points, plane="z")
    image = read_png(render_mesh(surface, tmp_path / "s.png", size=(200, 150), view="z"))
    assert image.shape == (150, 200, 3)
    assert not_background(image).mean() > 0.3


# --- comparison and convergence ---------------------------------------------------------


def test_compare_puts_panels_side_by_side_at_one_scale(tmp_path):
    big = trimesh.creation.box(extents=(2, 2, 2))
    small = trimesh.creation.box(extents=(1, 1, 1))
    path = render_compare(
        [big, small], tmp_path / "c.png", titles=["big", "small"], size=(300, 200)
    )
    image = read_png(path)
    assert image.shape[1] == 600 and image.shape[0] > 200  # two panels plus titles
    left, right = not_background(image[:, :300]), not_background(image[:, 300:])
    # the small box covers about a quarter of the big one's area (titles add a little)
    assert 0.15 < right.sum() / left.sum() < 0.4


def test_compare_wraps_into_rows(tmp_path, ball):
    path = render_compare([ball] * 4, tmp_path / "c.png", size=(100, 80), columns=2)
    image = read_png(path)
    assert image.shape[1] == 200 and image.shape[0] > 160


def test_convergence_plot_is_a_real_picture(tmp_path):
    path = plot_convergence(trace(), tmp_path / "conv.png", title="run", size=(6, 5))
    image = read_png(path)
    assert image.shape == (500, 600, 3)
    # the temperature line is red (tab:red), the acceptance line green (tab:green)
    red = (image[..., 0] > 180) & (image[..., 1] < 80) & (image[..., 2] < 80)
    green = (image[..., 1] > 130) & (image[..., 0] < 80) & (image[..., 2] < 80)
    assert red.sum() > 100 and green.sum() > 100
    assert not_background(image).mean() > 0.02


def test_convergence_plot_with_energy_only(tmp_path):
    n = 50
    path = plot_convergence(
        {"energy": np.linspace(10, 1, n), "sweep": np.arange(n) * 10}, tmp_path / "e.png"
    )
    assert read_png(path).shape == (700, 800, 3)


# --------------------------------------------------------------------------- colour by


def tilted_sheet(n: int = 12) -> tuple[np.ndarray, np.ndarray]:
    """A bumpy height field over the unit square: (vertices, faces), every inner vertex
    interior."""
    x, y = np.meshgrid(np.linspace(0, 1, n), np.linspace(0, 1, n))
    z = 0.5 * x + 0.1 * np.sin(5 * x) * np.cos(4 * y)
    vertices = np.column_stack([x.ravel(), y.ravel(), z.ravel()])
    k = np.arange(n * n).reshape(n, n)[:-1, :-1].ravel()
    faces = np.concatenate(
        [np.column_stack([k, k + 1, k + n]), np.column_stack([k + 1, k + n + 1, k + n])]
    )
    return vertices, faces


def test_tac_of_a_face_is_the_mean_defect_of_its_interior_corners():
    vertices, faces = tilted_sheet()
    values, unit = face_values((vertices, faces), "tac")
    assert unit == "rad" and values.shape == (len(faces),)
    # independent: trimesh's signed angle defect, absolute, on vertices not on the border
    mesh = trimesh.Trimesh(vertices, faces, process=False)
    defect = np.abs(mesh.vertex_defects)
    border = np.zeros(len(vertices), dtype=bool)
    border[
        np.unique(mesh.edges[trimesh.grouping.group_rows(mesh.edges_sorted, require_count=1)])
    ] = True
    for f, value in zip(faces, values, strict=True):
        inner = [v for v in f if not border[v]]
        if inner:
            assert value == pytest.approx(np.mean(defect[inner]), abs=1e-9)
        else:
            assert np.isnan(value)


def test_height_and_error_of_a_face():
    vertices, faces = tilted_sheet()
    height, _ = face_values((vertices, faces), "height", up=(0, 0, 2))
    np.testing.assert_allclose(height, vertices[faces].mean(axis=1)[:, 2], atol=1e-12)
    tilted, _ = face_values((vertices, faces), "height", up=(1, 0, 1))
    along = vertices[faces].mean(axis=1) @ [0.5**0.5, 0, 0.5**0.5]
    np.testing.assert_allclose(tilted, along - along.min(), atol=1e-12)  # above the lowest face
    # the sheet lifted by 0.01 against itself: every centroid is about 0.01 off the truth
    truth = trimesh.Trimesh(vertices, faces, process=False)
    lifted = vertices + [0, 0, 0.01]
    error, _ = face_values((lifted, faces), "error", truth=truth)
    ref = trimesh.proximity.closest_point(truth, lifted[faces].mean(axis=1))[1]
    np.testing.assert_allclose(error, ref, atol=1e-9)
    assert 0.005 < error.min() and error.max() <= 0.01 + 1e-12


def test_colour_scale_ends_and_missing_values():
    rgb = colormap([0.0, 1.0, 2.0, np.nan, -5.0, 9.0], 0.0, 2.0)
    np.testing.assert_allclose(rgb[[0, 4]], [VIRIDIS[0]] * 2)
    np.testing.assert_allclose(rgb[[2, 5]], [VIRIDIS[-1]] * 2)
    np.testing.assert_allclose(rgb[1], VIRIDIS[len(VIRIDIS) // 2])
    np.testing.assert_allclose(rgb[3], NO_VALUE)
    vertices, faces = tilted_sheet()
    colors, scale = face_colors((vertices, faces), "height")
    z = vertices[faces].mean(axis=1)[:, 2]
    assert (scale.lo, scale.hi) == (z.min(), z.max()) and "height" in scale.describe()
    np.testing.assert_allclose(colors[np.argmin(z)], VIRIDIS[0])
    np.testing.assert_allclose(colors[np.argmax(z)], VIRIDIS[-1])
    one, none = face_colors((vertices, faces), None)
    assert none is None and one.shape == (len(faces), 3)


def test_colour_by_bad_input(tmp_path):
    vertices, faces = tilted_sheet()
    with pytest.raises(ParameterError, match="tac, error, height"):
        face_colors((vertices, faces), "curvature")
    with pytest.raises(ParameterError, match="truth"):
        face_colors((vertices, faces), "error")
    with pytest.raises(ParameterError, match="only to colour by error"):
        face_colors((vertices, faces), "height", truth=(vertices, faces))
    with pytest.raises(ParameterError, match="only to colour by error"):
        render_mesh((vertices, faces), tmp_path / "x.png", truth=(vertices, faces))
    with pytest.raises(ParameterError, match="one per face"):
        shade_mesh((vertices, faces), color=np.ones((3, 3)))
    assert not list(tmp_path.iterdir())


def test_faces_are_drawn_in_their_own_colours(tmp_path):
    """Two faces side by side, seen from above: the left red, the right blue."""
    vertices = np.array([[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0]], dtype=float)
    faces = np.array([[0, 1, 3], [1, 2, 3]])
    image = shade_mesh(
        (vertices, faces), size=(60, 60), view="z", up="y", color=[[1, 0, 0], [0, 0, 1]]
    )
    assert image[50, 8, 0] > 150 and image[50, 8, 2] == 0  # lower left: face 0
    assert image[8, 50, 2] > 150 and image[8, 50, 0] == 0  # upper right: face 1


def test_render_by_height_shows_the_scale(tmp_path):
    vertices, faces = tilted_sheet()
    out = render_mesh(
        (vertices, faces),
        tmp_path / "h.png",
        size=(120, 90),
        view=(0, -1, 1),
        up="z",
        color_by="height",
        supersample=1,
    )
    image = read_png(out).astype(float)
    drawn = not_background(image.astype(int))
    # low (x = 0, left) is viridis blue-purple, high (x = 1, right) yellow-green
    cols = np.flatnonzero(drawn.any(axis=0))
    left = image[:, cols[:5]][drawn[:, cols[:5]]]
    right = image[:, cols[-5:]][drawn[:, cols[-5:]]]
    assert np.all(left[:, 2] > left[:, 1]) and np.all(right[:, 1] > right[:, 2])


def _grid_mesh(n: int) -> tuple[np.ndarray, np.ndarray]:
    x, y = np.meshgrid(np.linspace(0, 1, n), np.linspace(0, 1, n))
    v = np.column_stack([x.ravel(), y.ravel(), 0.1 * np.sin(6 * x.ravel())])
    i = np.arange(n * n).reshape(n, n)
    a, b, c, d = i[:-1, :-1].ravel(), i[:-1, 1:].ravel(), i[1:, :-1].ravel(), i[1:, 1:].ravel()
    return v, np.concatenate([np.column_stack([a, b, d]), np.column_stack([a, d, c])])


@pytest.mark.slow
def test_a_wireframe_of_many_triangles_zooms_until_they_are_readable():
    mesh = _grid_mesh(300)  # 178,802 triangles: 1.7 pixels each in 800 x 600
    edge = np.asarray(WIRE) * 255

    def dark_share(image: np.ndarray) -> float:  # of the pixels the mesh covers
        drawn = np.abs(image.astype(int) - 255).sum(axis=2) > 30
        return float((np.abs(image - edge).sum(axis=2) < 60)[drawn].mean())

    lo, hi = np.array([-0.1, -0.1]), np.array([1.1, 1.1])  # the whole mesh: no zoom
    whole = shade_mesh(mesh, wire=True, view="z", up="y", bounds=(lo, hi))
    assert dark_share(whole) > 0.6  # edges everywhere: one dark area
    with pytest.warns(
        WireZoomWarning,
        match=r"178,802 triangles would cover 1.7 pixels each.*times closer, where they cover 60",
    ):
        zoomed = shade_mesh(mesh, wire=True, view="z", up="y")
    assert 0.03 < dark_share(zoomed) < 0.3  # edges apart, faces between them
    # a mesh whose triangles are large enough is drawn whole, without a warning
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        small = shade_mesh(_grid_mesh(12), wire=True, view="z", up="y")
    assert (np.abs(small.astype(int) - 255).sum(axis=2) > 30).mean() > 0.3
