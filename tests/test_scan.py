"""PlanarScan: one check and one projection per call, shared by every stage."""

from __future__ import annotations

import math

import numpy as np
import pytest

import scanmesh
from conftest import DATA, bumpy_patch
from scanmesh import ParameterError, ScanmeshError, planar_scan


@pytest.fixture
def spy(monkeypatch):
    """Record the planar coordinates each native stage receives."""
    from scanmesh import _core

    seen: dict[str, list[np.ndarray]] = {}

    def wrap(name, position):
        real = getattr(_core, name)

        def call(*args, **kwargs):
            seen.setdefault(name, []).append(np.array(args[position], copy=True))
            return real(*args, **kwargs)

        monkeypatch.setattr(_core, name, call)

    wrap("delaunay", 0)
    wrap("trim_long_edges", 0)
    wrap("delaunay_trimmed", 0)
    wrap("lop", 1)
    wrap("Annealer", 1)
    wrap("project", 0)
    return seen


#: Column order that makes each plane's axis the height of the bumpy patch.
HEIGHT_ALONG = {"x": [2, 0, 1], "y": [0, 2, 1], "z": [0, 1, 2]}


@pytest.mark.parametrize("plane", [None, "x", "y", "z", (0.1, 0.2, 1.0)])
@pytest.mark.parametrize("method", ["lop", "anneal"])
def test_flips_use_the_very_coordinates_delaunay_was_built_on(spy, method, plane):
    pts = bumpy_patch(150, 3)[:, HEIGHT_ALONG.get(plane, [0, 1, 2])]
    options = {"sweeps": 5} if method == "anneal" else {}
    scanmesh.reconstruct(pts, method, plane=plane, **options)
    assert len(spy["project"]) == 1, "the points are projected once per call"
    flips = spy["Annealer" if method == "anneal" else "lop"][0]
    # delaunay() triangulates and trims in one native call; for plane=None, plane_choice
    # triangulates and trims its candidates first (the separate calls)
    assert flips.tobytes() == spy["delaunay_trimmed"][-1].tobytes()


def test_surface_frame_is_the_frame_of_the_coordinates():
    pts = bumpy_patch(120, 5)[:, HEIGHT_ALONG["y"]]
    s = scanmesh.reconstruct(pts, "anneal", plane="y", sweeps=5)
    scan = s.scan
    assert s.frame is scan.frame
    # uv really is ((p - origin) . u, (p - origin) . v) in that frame
    rel = pts - scan.frame.origin
    np.testing.assert_allclose(scan.uv[:, 0], rel @ scan.frame.u, atol=1e-12)
    np.testing.assert_allclose(scan.uv[:, 1], rel @ scan.frame.v, atol=1e-12)
    assert not scan.uv.flags.writeable


def test_one_scan_serves_every_method_without_projecting_again(spy):
    pts = bumpy_patch(100, 7)
    scan = planar_scan(pts, plane="z")
    base = scanmesh.reconstruct(scan, "delaunay")
    lop = scanmesh.reconstruct(scan, "lop", initial=base)
    annealed = scanmesh.reconstruct(scan, "anneal", initial=base, sweeps=5)
    assert len(spy["project"]) == 1 and len(spy["delaunay_trimmed"]) == 1
    assert lop.scan is scan and annealed.scan is scan and base.scan is scan
    # the same faces as separate calls from the points
    again = scanmesh.reconstruct(pts, "anneal", plane="z", sweeps=5)
    np.testing.assert_array_equal(again.faces, annealed.faces)


def test_a_scan_refuses_another_plane_or_other_lines():
    pts = bumpy_patch(60, 1)
    scan = planar_scan(pts, plane="z")
    assert scanmesh.delaunay(scan, plane="Z").scan is scan  # the same plane, named alike
    with pytest.raises(ParameterError, match="differs from the plane"):
        scanmesh.delaunay(scan, plane="x")
    with pytest.raises(ParameterError, match="lines= differs"):
        scanmesh.reconstruct(scan, "shortest-path", lines=np.zeros(len(pts), dtype=int))
    other = scanmesh.delaunay(pts, plane="z")
    with pytest.raises(ParameterError, match="another scan"):
        scanmesh.reconstruct(scan, "anneal", initial=other)


@pytest.mark.parametrize(
    "ids, match",
    [
        (np.full(40, 1e300), "lines\\[0\\] = 1e\\+300"),
        (np.r_[np.zeros(20), np.full(20, 2.0**60)], "lines\\[20\\]"),
        (np.r_[np.zeros(39), np.nan], "lines\\[39\\] = nan"),
        (np.r_[np.zeros(20), np.full(20, 0.5)], "non-integral"),
        (np.r_[np.zeros(20, np.uint64), np.full(20, 2**63, np.uint64)], "signed 64-bit"),
        (np.array([True] * 40), "integer line ids"),
        (np.array(["a"] * 40), "integer line ids"),
        (np.zeros(39, dtype=int), "one id per point"),
    ],
)
def test_line_ids_are_never_cast(ids, match):
    pts = bumpy_patch(40, 2)
    for method in ("shortest-path", "lookahead"):
        with pytest.raises(ScanmeshError, match=match):
            scanmesh.reconstruct(pts, method, lines=ids)
    with pytest.raises(ScanmeshError, match=match):
        planar_scan(pts, lines=ids)


def test_whole_float_and_unsigned_ids_are_the_integers_they_name():
    pts = bumpy_patch(40, 2)
    ids = np.repeat(np.arange(4), 10)
    scan = planar_scan(pts, lines=ids.astype(np.float64) * 2.0**40)
    np.testing.assert_array_equal(scan.line_ids, ids * 2**40)
    assert planar_scan(pts, lines=ids.astype(np.uint64)).line_ids.dtype == np.int64


def test_save_refuses_to_replace_the_scan_it_was_made_from(tmp_path):
    pts = bumpy_patch(80, 4)
    scan_file = tmp_path / "scan.ply"  # a point cloud in a format meshes are written in
    header = f"ply\nformat ascii 1.0\nelement vertex {len(pts)}\n"
    header += "property double x\nproperty double y\nproperty double z\nend_header\n"
    scan_file.write_text(header + "".join(f"{x!r} {y!r} {z!r}\n" for x, y, z in pts.tolist()))
    before = scan_file.read_bytes()
    surface = scanmesh.reconstruct(scan_file, "delaunay")
    assert surface.scan.source == scan_file
    (tmp_path / "sub").mkdir()
    for name in ("scan.ply", "./sub/../scan.ply"):
        with pytest.raises(ParameterError, match="input file"):
            surface.save(tmp_path / name)
    assert scan_file.read_bytes() == before
    written = surface.save(tmp_path / "mesh.ply")
    assert written.stat().st_size > 0
    # a surface from an array has no file to protect
    assert scanmesh.delaunay(pts).scan.source is None


def test_quality_of_a_scan_measures_the_same():
    pts = bumpy_patch(90, 6)
    s = scanmesh.delaunay(pts)
    direct = scanmesh.quality(pts, s.faces)
    assert s.quality.tac_1 == direct.tac_1
    assert scanmesh.quality(s.scan, s.faces).tac_2 == direct.tac_2
    with pytest.raises(TypeError):
        scanmesh.quality(pts, s.faces, plane="z")  # no keyword accepted and ignored


def test_projection_rejects_non_vectors():
    pts = bumpy_patch(30, 1)
    for plane in ({"a": 1}, b"z", 1j, [1j, 0, 1], ["a", "b", "c"], 3.0, [math.inf, 0, 1]):
        with pytest.raises(ParameterError, match="plane"):
            planar_scan(pts, plane=plane)


def _small_input(rng: np.random.Generator, k: int) -> np.ndarray:
    """Random points, exact integer height grids and nearly planar tilted patches."""
    n = int(rng.integers(5, 61))
    if k % 3 == 0:
        return rng.random((n, 3))
    if k % 3 == 1:
        side = int(math.sqrt(n)) + 1
        x, y = np.meshgrid(np.arange(side), np.arange(side))
        return np.column_stack([x.ravel(), y.ravel(), (x * y % 3).ravel()]).astype(float)[:n]
    pts = rng.random((n, 3))
    pts[:, 2] = 0.3 * pts[:, 0] + 1e-3 * rng.random(n)
    return pts


@pytest.mark.slow
@pytest.mark.filterwarnings("ignore::scanmesh.ScanmeshWarning")
def test_flips_accept_every_triangulation_delaunay_returns():
    """LOP and annealing used to re-project along the frame normal and then found Delaunay's
    own faces "not counter-clockwise" (InvalidMeshError on 28 of 400 such inputs)."""
    rng = np.random.default_rng(0)
    for k in range(160):
        pts = _small_input(rng, k)
        plane = [None, "z", "x", (0.2, 0.1, 1.0)][k % 4]
        scan = planar_scan(pts, plane=plane)
        base = scanmesh.delaunay(scan, max_edge=math.inf)
        for method, options in (("lop", {}), ("anneal", {"sweeps": 3, "patience": 0})):
            s = scanmesh.reconstruct(scan, method, initial=base, **options)
            assert len(s.faces) == len(base.faces), (k, method)


def test_a_flat_grid_is_flipped_not_refused():
    x, y = np.meshgrid(np.arange(10.0), np.arange(10.0))
    flat = np.column_stack([x.ravel(), y.ravel(), np.zeros(100)])
    base = scanmesh.delaunay(flat, max_edge=math.inf)
    for method in ("lop", "anneal"):
        s = scanmesh.reconstruct(flat, method, max_edge=math.inf)
        assert len(s.faces) == len(base.faces)
        assert s.quality.tac_1 == pytest.approx(0.0, abs=1e-9)


def test_what_read_returns_is_the_scan_its_file_is():
    path = DATA / "scans" / "steps_range_grid.ply"
    from_file = planar_scan(path)
    from_read = planar_scan(scanmesh.read(path))
    for name in ("points", "uv", "line_ids", "grid", "up"):
        assert np.array_equal(getattr(from_read, name), getattr(from_file, name)), name
    assert from_read.plane == from_file.plane and from_read.source == from_file.source
    assert from_read.source_file == from_file.source_file  # the same file, so no writer replaces it
    same = scanmesh.reconstruct(scanmesh.read(path), "delaunay")
    assert np.array_equal(same.faces, scanmesh.reconstruct(path, "delaunay").faces)
