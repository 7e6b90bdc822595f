"""The virtual digitizer: simulate_scan on meshes whose surface is known exactly."""

from __future__ import annotations

import time

import numpy as np
import pytest
import trimesh

from conftest import DATA
from scanmesh.errors import FileFormatError, InvalidMeshError, ParameterError, ScanmeshError
from scanmesh.evaluate.digitizer import cast_grid, simulate_scan
from scanmesh.scan.axes import scan_frame

CONROD = DATA / "cad" / "conrod_slevin48_onshape.stl"


def surface_distance(mesh: trimesh.Trimesh, points: np.ndarray) -> np.ndarray:
    _, dist, _ = trimesh.proximity.closest_point(mesh, points)
    return dist


@pytest.fixture(scope="module")
def sphere() -> trimesh.Trimesh:
    return trimesh.creation.icosphere(subdivisions=3, radius=1.0)


# --- bad input first -------------------------------------------------------------------


@pytest.mark.parametrize("up", ["w", "", "xy", "+-z", (1, 0), (0, 0, 0), (np.nan, 0, 1), "zz"])
def test_unknown_up_axis_raises(sphere, up):
    with pytest.raises(ParameterError, match="up"):
        simulate_scan(sphere, up=up, spacing=0.1)


def test_unknown_along_axis_raises(sphere):
    with pytest.raises(ParameterError, match="along"):
        simulate_scan(sphere, along="q", spacing=0.1)


@pytest.mark.parametrize(
    ("up", "along"), [("z", "z"), ("z", "-z"), ("y", (0, 2, 0)), ((1, 1, 0), (-1, -1, 0))]
)
def test_up_parallel_to_along_raises(sphere, up, along):
    with pytest.raises(ParameterError, match="parallel"):
        simulate_scan(sphere, up=up, along=along, spacing=0.1)


@pytest.mark.parametrize("bad", [0, -0.1, np.nan, np.inf, "fine"])
def test_non_positive_spacing_raises(sphere, bad):
    with pytest.raises(ParameterError, match="spacing"):
        simulate_scan(sphere, spacing=bad)
    with pytest.raises(ParameterError, match="line_spacing"):
        simulate_scan(sphere, spacing=0.1, line_spacing=bad)


@pytest.mark.parametrize("bad", [0, -5, 2.5, True])
def test_bad_n_points_raises(sphere, bad):
    with pytest.raises(ParameterError, match="n_points"):
        simulate_scan(sphere, n_points=bad)


def test_spacing_and_n_points_together_raise(sphere):
    with pytest.raises(ParameterError, match="not both"):
        simulate_scan(sphere, spacing=0.1, n_points=100)


@pytest.mark.parametrize("bad", [-0.01, np.nan, np.inf, "loud", None])
def test_bad_noise_raises(sphere, bad):
    with pytest.raises(ParameterError, match="noise"):
        simulate_scan(sphere, spacing=0.1, noise=bad)


def test_missing_file_raises(tmp_path):
    path = tmp_path / "nothing.stl"
    with pytest.raises(FileFormatError, match="nothing.stl.*does not exist"):
        simulate_scan(path, spacing=0.1)


def test_empty_file_raises(tmp_path):
    path = tmp_path / "empty.stl"
    path.write_bytes(b"")
    with pytest.raises(FileFormatError, match="empty"):
        simulate_scan(str(path), spacing=0.1)


def test_garbage_file_raises(tmp_path):
    path = tmp_path / "junk.ply"
    path.write_text("this is not a mesh\n")
    with pytest.raises(FileFormatError, match="junk.ply"):
        simulate_scan(path, spacing=0.1)


def test_mesh_without_faces_raises():
    with pytest.raises(InvalidMeshError, match="no triangles"):
        simulate_scan(trimesh.Trimesh(vertices=np.eye(3), faces=np.empty((0, 3), int)))


def test_not_a_mesh_raises():
    with pytest.raises(ParameterError, match="Trimesh"):
        simulate_scan(np.zeros((3, 3)), spacing=0.1)


def test_errors_are_scanmesh_errors(sphere):
    with pytest.raises(ScanmeshError):
        simulate_scan(sphere, up="up")


# --- geometry of the scan ------------------------------------------------------------


def test_box_top_grid_has_exact_spacing_and_line_count():
    box = trimesh.creation.box(extents=(2.0, 1.0, 0.5))
    points, line_ids = simulate_scan(box, spacing=0.1)
    # 21 nodes along x (-1..1), 11 lines along y (-0.5..0.5), all on the top face
    assert points.shape == (21 * 11, 3)
    assert points.dtype == np.float64 and line_ids.dtype == np.int64
    assert np.all(points[:, 2] == 0.25)
    assert np.array_equal(np.bincount(line_ids), np.full(11, 21))
    for line in range(11):
        row = points[line_ids == line]
        np.testing.assert_allclose(np.diff(row[:, 0]), 0.1, rtol=1e-12)
        assert np.ptp(row[:, 1]) == 0.0
    # lines are stacked along up x along = z x x = +y
    np.testing.assert_allclose(np.diff(points[line_ids == 0][:1, 1]), [])
    ys = np.array([points[line_ids == k, 1][0] for k in range(11)])
    np.testing.assert_allclose(np.diff(ys), 0.1, rtol=1e-12)
    np.testing.assert_allclose([points[:, 0].min(), points[:, 0].max()], [-1.0, 1.0])


def test_line_spacing_differs_from_spacing():
    box = trimesh.creation.box(extents=(2.0, 1.0, 0.5))
    points, line_ids = simulate_scan(box, spacing=0.05, line_spacing=0.25)
    assert line_ids.max() + 1 == 5  # y = -0.5, -0.25, 0, 0.25, 0.5
    assert np.all(np.bincount(line_ids) == 41)
    ys = np.unique(points[:, 1])
    np.testing.assert_allclose(np.diff(ys), 0.25, rtol=1e-12)


def test_grid_is_centred_on_the_footprint():
    box = trimesh.creation.box(extents=(1.0, 1.0, 1.0))
    points, _ = simulate_scan(box, spacing=0.3)  # 4 nodes: 0.9 wide, 0.05 margin each side
    np.testing.assert_allclose(np.unique(points[:, 0]), [-0.45, -0.15, 0.15, 0.45], atol=1e-15)


def test_sphere_points_lie_on_surface_in_order(sphere):
    points, line_ids = simulate_scan(sphere, spacing=0.05)
    assert len(points) > 1000
    assert surface_distance(sphere, points).max() < 1e-9
    assert np.all(points[:, 2] > -1e-12)  # seen from +z: only the upper half
    assert np.all(np.diff(line_ids) >= 0) and line_ids[0] == 0
    assert np.array_equal(np.unique(line_ids), np.arange(line_ids.max() + 1))
    for line in np.unique(line_ids):
        row = points[line_ids == line]
        assert np.all(np.diff(row[:, 0]) > 0)  # +along within a line
        assert np.ptp(row[:, 1]) < 1e-12  # one line, one y
    # misses are dropped: only rays inside the sphere's outline (radius ~1) are kept
    assert np.hypot(points[:, 0], points[:, 1]).max() <= 1.0 + 1e-12
    # lines run at y = -1 + k * 0.05 within the outline: 41 lines, minus any empty ones
    assert 39 <= line_ids.max() + 1 <= 41


def test_first_hit_only():
    low = trimesh.creation.box(extents=(1, 1, 0.2))
    high = trimesh.creation.box(extents=(0.5, 0.5, 0.2))
    high.apply_translation((0, 0, 1.0))
    parts = trimesh.util.concatenate([low, high])
    points, _ = simulate_scan(parts, spacing=0.1)
    inner = (np.abs(points[:, 0]) <= 0.25 + 1e-12) & (np.abs(points[:, 1]) <= 0.25 + 1e-12)
    assert np.all(points[inner, 2] == 1.1)
    assert np.all(points[~inner, 2] == 0.1)
    # seen from below, the lower box's bottom face comes first
    below, _ = simulate_scan(parts, up="-z", spacing=0.1)
    assert np.all(below[:, 2] == -0.1)


def test_matches_trimesh_ray_engine_on_an_oblique_direction(sphere):
    from trimesh.ray.ray_triangle import RayMeshIntersector

    up, along = (1.0, 2.0, 3.0), (1.0, 0.0, 0.0)
    table_points, _ = simulate_scan(sphere, up=up, along=along, spacing=0.07, table=True)
    hits, _ = simulate_scan(sphere, up=up, along=along, spacing=0.07)
    frame = scan_frame(up, along)
    origins = table_points + 5.0 * frame[2]
    directions = np.tile(-frame[2], (len(origins), 1))
    locations, index_ray, _ = RayMeshIntersector(sphere).intersects_location(
        origins, directions, multiple_hits=False
    )
    assert len(index_ray) == len(hits)
    order = np.argsort(index_ray)
    np.testing.assert_allclose(locations[order], hits, atol=1e-12)


def test_signed_axis_names_and_vectors_agree(sphere):
    a, la = simulate_scan(sphere, up="-Y", along="+z", spacing=0.1)
    b, lb = simulate_scan(sphere, up=(0, -3, 0), along=(0, 0.5, 7), spacing=0.1)
    np.testing.assert_array_equal(la, lb)
    np.testing.assert_allclose(a, b, atol=1e-14)
    assert np.all(a[:, 1] < 1e-12)  # looking from -y sees the -y half
    frame = scan_frame("-y", "z")
    np.testing.assert_allclose(frame, [[0, 0, 1], [-1, 0, 0], [0, -1, 0]], atol=0)


def test_accepts_a_mesh_file(tmp_path, sphere):
    path = tmp_path / "ball.stl"
    sphere.export(path)
    from_file, ids_file = simulate_scan(path, spacing=0.1)
    direct, ids = simulate_scan(sphere, spacing=0.1)
    np.testing.assert_array_equal(ids_file, ids)
    np.testing.assert_allclose(from_file, direct, atol=1e-6)  # STL stores float32


def test_accepts_a_scene_of_several_parts():
    scene = trimesh.Scene(
        [trimesh.creation.box(extents=(1, 1, 1)), trimesh.creation.box(extents=(1, 1, 2))]
    )
    scene.geometry[list(scene.geometry)[1]].apply_translation((3, 0, 0))
    points, _ = simulate_scan(scene, spacing=0.1)
    assert set(np.round(points[:, 2], 12)) == {0.5, 1.0}
    assert len(points) == 2 * 11 * 11


# --- table ------------------------------------------------------------------------------


def test_table_puts_misses_on_the_plane_under_the_part(sphere):
    points, line_ids = simulate_scan(sphere, spacing=0.1, table=True)
    hits, _ = simulate_scan(sphere, spacing=0.1)
    lowest = sphere.vertices[:, 2].min()
    assert len(points) == 21 * 21  # the whole grid over the bounding box
    assert line_ids.max() + 1 == 21
    on_table = points[:, 2] == lowest
    assert on_table.sum() == len(points) - len(hits)
    assert np.all(np.hypot(points[on_table, 0], points[on_table, 1]) > 0.9)
    np.testing.assert_array_equal(points[~on_table], hits)


# --- noise ------------------------------------------------------------------------------


def test_noise_statistics_along_the_ray():
    box = trimesh.creation.box(extents=(1.0, 1.0, 1.0))
    clean, _ = simulate_scan(box, spacing=0.005)
    noisy, _ = simulate_scan(box, spacing=0.005, noise=0.01, seed=7)
    assert len(noisy) == len(clean) == 201 * 201
    np.testing.assert_array_equal(noisy[:, :2], clean[:, :2])  # only along the ray
    residual = noisy[:, 2] - clean[:, 2]
    n = len(residual)
    assert abs(residual.mean()) < 4 * 0.01 / np.sqrt(n)
    assert abs(residual.std() - 0.01) < 4 * 0.01 / np.sqrt(2 * n)


def test_same_seed_same_points_other_seed_other_points(sphere):
    a, _ = simulate_scan(sphere, spacing=0.1, noise=0.001, seed=3)
    b, _ = simulate_scan(sphere, spacing=0.1, noise=0.001, seed=3)
    c, _ = simulate_scan(sphere, spacing=0.1, noise=0.001, seed=4)
    gen, _ = simulate_scan(sphere, spacing=0.1, noise=0.001, seed=np.random.default_rng(3))
    np.testing.assert_array_equal(a, b)
    np.testing.assert_array_equal(a, gen)
    assert not np.allclose(a, c)


# --- n_points ---------------------------------------------------------------------------


@pytest.mark.parametrize("target", [500, 3000])
def test_n_points_gives_about_that_many_hits(sphere, target):
    points, _ = simulate_scan(sphere, n_points=target)
    # the footprint (a disc) is ~79 % of its bounding box: the first guess alone is 21 % off
    assert abs(len(points) - target) <= 0.01 * target
    assert surface_distance(sphere, points).max() < 1e-9


def test_n_points_with_fixed_line_spacing(sphere):
    points, line_ids = simulate_scan(sphere, n_points=2000, line_spacing=0.2)
    assert abs(len(points) - 2000) <= 0.02 * 2000
    assert line_ids.max() + 1 == 11


def test_conrod_scan_along_its_thickness():
    mesh = trimesh.load_mesh(CONROD)
    points, line_ids = simulate_scan(CONROD, up="y", along="x", n_points=14_339)
    assert abs(len(points) - 14_339) <= 0.01 * 14_339
    assert surface_distance(mesh, points).max() < 1e-9
    # top face and the recessed web: the two heights seen from +y
    np.testing.assert_allclose(np.unique(np.round(points[:, 1], 4)), [0.1969, 0.3937])


# --- the casting core -------------------------------------------------------------------


def test_cast_grid_nodes_on_shared_edges_do_not_fall_through():
    # a unit square split along its diagonal, with nodes exactly on the diagonal
    uv = np.array([[[0, 0], [1, 0], [1, 1]], [[0, 0], [1, 1], [0, 1]]], dtype=float)
    h = np.array([[1.0, 1.0, 1.0], [1.0, 1.0, 1.0]])
    height, face = cast_grid(uv, h, (0.0, 0.0), (0.1, 0.1), (11, 11), tol=1e-12)
    assert np.all(height == 1.0)
    assert np.all(face >= 0)
    # without the grid covering, everything misses
    height, face = cast_grid(uv, h, (2.0, 2.0), (0.1, 0.1), (3, 3))
    assert np.all(np.isneginf(height)) and np.all(face == -1)


def test_large_scan_is_vectorized():
    ball = trimesh.creation.icosphere(subdivisions=6)  # 81,920 faces
    start = time.perf_counter()
    points, _ = simulate_scan(ball, spacing=0.002)  # 1001 x 1001 rays
    elapsed = time.perf_counter() - start
    assert len(points) > 780_000
    # one Python iteration per ray (trimesh's rtree engine) takes minutes here
    assert elapsed < 30.0
