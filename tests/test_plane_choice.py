"""The projection plane chosen by the data for ``plane=None``."""

from __future__ import annotations

import json
import math
import subprocess
import sys
import warnings

import numpy as np
import pytest
import trimesh
from scipy.spatial import Delaunay

import scanmesh
from conftest import DATA
from scanmesh.errors import NotAHeightFieldWarning, ParameterError
from scanmesh.formats.write import write_points
from scanmesh.scan.axes import parse_axis
from scanmesh.scan.plane_choice import SAMPLE, TIE, choose_plane, quick_faces, score
from scanmesh.scan.steep import STEEP_ANGLE_DEG, STEEP_WARN_FRACTION

CAD = DATA / "cad"


@pytest.fixture(scope="module")
def conrod() -> trimesh.Trimesh:
    return trimesh.load(CAD / "conrod_slevin48_onshape.stl", force="mesh")


@pytest.fixture(scope="module")
def pocket() -> trimesh.Trimesh:
    return trimesh.load(CAD / "octagonal_pocket.ply", force="mesh")


def scan(mesh: trimesh.Trimesh, up: str, div: float = 50.0):
    """A scan along ``up`` at 1/div of the part's larger extent across it."""
    along = "y" if up.endswith("x") else "x"
    across = np.delete(mesh.extents, "xyz".index(up[-1]))
    spacing = float(np.max(across)) / div
    return scanmesh.simulate_scan(mesh, up=up, along=along, spacing=spacing)


def delaunay_quiet(source, **kw):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return scanmesh.reconstruct(source, "delaunay", **kw)


@pytest.mark.parametrize("part", ["conrod", "pocket"])
@pytest.mark.parametrize("up", ["x", "y", "z"])
def test_default_plane_makes_a_height_field(part, up, request):
    mesh = request.getfixturevalue(part)
    pts, _ = scan(mesh, up)
    surface = delaunay_quiet(pts)
    choice = surface.options["plane_choice"]
    assert surface.steep_fraction < STEEP_WARN_FRACTION, choice
    np.testing.assert_allclose(choice["normal"], surface.frame.normal)
    # the chosen candidate scored (steep + unused) within TIE of the lowest
    totals = [s + choice["unused"][k] for k, s in choice["steep"].items() if s is not None]
    chosen = choice["chosen"]
    assert choice["steep"][chosen] + choice["unused"][chosen] <= min(totals) + TIE
    # every stage worked on the chosen plane: the scan's uv is that projection
    uv, _ = scanmesh.project(pts, surface.scan.plane)
    np.testing.assert_array_equal(uv, surface.scan.uv)


def test_the_old_default_was_steep_where_the_choice_is_not(pocket):
    """The pocket plate scanned along x (edge-on to its pockets): the least-squares plane
    (the old default) leaves most triangles steep."""
    pts, _ = scan(pocket, "x")
    chosen = delaunay_quiet(pts)
    with pytest.warns(NotAHeightFieldWarning):
        old = scanmesh.reconstruct(pts, "delaunay", plane="best-fit")
    assert old.steep_fraction > STEEP_WARN_FRACTION > chosen.steep_fraction
    assert chosen.options["plane_choice"]["chosen"] != "best-fit"


@pytest.mark.parametrize("up", ["x", "-y", "-z"])
def test_a_simulated_file_is_reconstructed_along_its_up(tmp_path, pocket, up):
    pts, ids = scan(pocket, up)
    direction = parse_axis(up, "up")
    path = write_points(tmp_path / "scan.xyz", pts, ids, up=direction)
    assert np.allclose(scanmesh.read(path).up, direction)
    surface = delaunay_quiet(path)
    choice = surface.options["plane_choice"]
    assert choice["chosen"] == "up"
    # along up, not the opposite: the mesh faces the digitizer
    np.testing.assert_allclose(surface.frame.normal, direction, atol=1e-12)
    assert surface.steep_fraction < STEEP_WARN_FRACTION


def test_the_command_reports_the_choice(tmp_path, pocket):
    pts, ids = scan(pocket, "-y")
    path = write_points(tmp_path / "scan.xyz", pts, ids, up=(0.0, -1.0, 0.0))
    out, report = tmp_path / "m.ply", tmp_path / "r.json"
    done = subprocess.run(
        [sys.executable, "-m", "scanmesh", "reconstruct", path, "-o", out, "--method", "delaunay"]
        + ["--report", report],
        capture_output=True,
        text=True,
        timeout=300,
    )
    assert done.returncode == 0, done.stderr
    plane = json.loads(report.read_text())["plane"]
    assert plane["choice"]["chosen"] == "up"
    np.testing.assert_allclose(plane["normal"], [0.0, -1.0, 0.0], atol=1e-12)
    # up scores under TIE: no other candidate can win, none is measured
    assert plane["choice"]["steep"]["up"] + plane["choice"]["unused"]["up"] <= TIE
    assert set(plane["choice"]["steep"]) == {"up"}


@pytest.mark.parametrize("plane", ["best-fit", "x", (0.0, 1.0, 1.0)])
def test_an_explicit_plane_is_obeyed(conrod, plane):
    pts, _ = scan(conrod, "x")
    surface = delaunay_quiet(pts, plane=plane)
    assert "plane_choice" not in surface.options
    assert surface.scan.choice is None
    _, frame = scanmesh.project(pts, plane)
    np.testing.assert_array_equal(surface.frame.normal, frame.normal)


def test_a_planar_scan_keeps_its_chosen_plane(conrod):
    pts, _ = scan(conrod, "x")
    chosen = scanmesh.planar_scan(pts)
    assert chosen.choice is not None and chosen.choice.chosen != "best-fit"
    # reused as it is, with the plane it was chosen on; another plane is refused
    assert scanmesh.reconstruct(chosen, "delaunay").scan is chosen
    assert scanmesh.reconstruct(chosen, "delaunay", plane=chosen.plane).scan is chosen
    with pytest.raises(ParameterError, match="differs from the plane"):
        scanmesh.reconstruct(chosen, "delaunay", plane="best-fit")


def test_the_choice_is_seeded():
    """More points than SAMPLE: the subsample is seeded, so the choice repeats exactly."""
    gen = np.random.default_rng(5)
    n = SAMPLE + 5_000
    xy = gen.uniform(-1.0, 1.0, size=(n, 2))
    z = 0.3 * np.sin(3 * xy[:, 0]) * np.cos(2 * xy[:, 1])
    # a tilted bumpy sheet: a height field over its least-squares plane and over z
    rot = trimesh.transformations.rotation_matrix(0.5, [1.0, 1.0, 0.0])[:3, :3]
    pts = np.column_stack([xy, z]) @ rot.T
    first, second = choose_plane(pts), choose_plane(pts.copy())
    assert first == second
    assert first.sampled == SAMPLE
    a, b = scanmesh.planar_scan(pts), scanmesh.planar_scan(pts)
    np.testing.assert_array_equal(a.uv, b.uv)
    assert a.choice.chosen == first.chosen in ("best-fit", "z") and a.plane == first.chosen


def test_skipped_candidates_could_not_have_won(conrod, pocket, monkeypatch):
    """Measuring every candidate chooses the same plane as stopping once settled."""
    import scanmesh.scan.plane_choice as pc

    cases = [(conrod, "x"), (conrod, "z"), (pocket, "x"), (pocket, "-z"), (pocket, "y")]
    quick = {}
    for mesh, up in cases:
        pts, _ = scan(mesh, up, div=30)
        for recorded in (None, parse_axis(up, "up")):
            quick[(id(mesh), up, recorded is None)] = (pts, recorded, choose_plane(pts, recorded))
    monkeypatch.setattr(pc, "settled", lambda measured: False)
    for pts, recorded, fast in quick.values():
        full = choose_plane(pts, recorded)
        assert fast.chosen == full.chosen
        assert set(fast.steep) <= set(full.steep)


def test_a_triangle_is_a_height_field_over_the_chosen_plane():
    # x comes first and the triangle is 48 degrees from facing it: no need to look further
    pts = np.array([[0.0, 0.0, 0.0], [1.0, 0.0, 1.0], [0.0, 1.0, 0.5]])
    choice = choose_plane(pts)
    assert choice.chosen == "x" and list(choice.steep) == ["x"]
    assert choice.steep["x"] == 0.0 and choice.unused["x"] == 0.0
    assert len(scanmesh.reconstruct(pts, "delaunay").faces) == 1


def test_collinear_points_are_still_refused():
    for line in (
        np.column_stack([np.arange(5.0), 2 * np.arange(5.0), np.zeros(5)]),
        np.outer(np.arange(10.0), [1.0, 2.0, 3.0]),  # rounds off the line in some planes
    ):
        assert choose_plane(line).steep == {}
        with pytest.raises(scanmesh.ScanmeshError, match="[Cc]ollinear"):
            scanmesh.planar_scan(line)


def test_steep_share_matches_scipy_and_numpy():
    """The measure itself, against an independent Delaunay (scipy) and numpy normals, on a
    jittered grid with a wall: the quick triangulation is scipy's less a few trimmed hull
    slivers, and its steep share is numpy's."""
    gen = np.random.default_rng(2)
    g = np.stack(np.meshgrid(np.arange(30.0), np.arange(30.0)), axis=-1).reshape(-1, 2)
    xy = g + gen.uniform(-0.2, 0.2, size=g.shape)
    z = np.where(xy[:, 0] > 14.5, 20.0, 0.0) + 0.1 * xy[:, 1]
    pts = np.column_stack([xy, z])
    normal = np.array([0.0, 0.0, 1.0])
    faces = quick_faces(pts, normal)
    reference = {tuple(sorted(t)) for t in Delaunay(xy).simplices.tolist()}
    assert {tuple(sorted(t)) for t in faces.tolist()} <= reference
    assert len(faces) >= 0.95 * len(reference)
    a, b, c = pts[faces[:, 0]], pts[faces[:, 1]], pts[faces[:, 2]]
    n = np.cross(b - a, c - a)
    cos = (n @ normal) / np.linalg.norm(n, axis=1)
    expected = float(np.mean(cos < math.cos(math.radians(STEEP_ANGLE_DEG))))
    assert 0.0 < expected < 0.2
    used = np.zeros(len(pts), dtype=bool)
    used[faces.ravel()] = True
    assert score(pts, normal) == pytest.approx((expected, 1.0 - used.mean()), abs=1e-12)


def test_huge_and_tiny_coordinates_choose_the_same_plane(pocket):
    """The choice is scale-free and never overflows (1e308-sized coordinates)."""
    pts, _ = scan(pocket, "x", div=30)
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # no overflow RuntimeWarning
        choices = [choose_plane(pts * k) for k in (1.0, 1e300, 1e-300)]
    assert len({c.chosen for c in choices}) == 1
    assert choices[0].chosen == "x"
