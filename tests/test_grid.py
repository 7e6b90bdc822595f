"""The triangulation along a range grid, the "grid" start of LOP and annealing, simulated
range scans, and the curtain report."""

from __future__ import annotations

import dataclasses
import json
import math
import warnings

import numpy as np
import pytest
import trimesh
from scipy.spatial import ConvexHull

import scanmesh
from conftest import DATA, cyberware_range_grid
from scanmesh import _core
from scanmesh.cli import main
from scanmesh.errors import CurtainsWarning, ParameterError
from scanmesh.evaluate.digitizer import simulate_range_scan
from scanmesh.formats.grid import height_grid
from scanmesh.measures import CURTAIN_ANGLE_DEG, curtains
from scanmesh.methods import default_initial
from scanmesh.scan.planar import planar_scan

STEPS = DATA / "scans" / "steps_range_grid.ply"
POCKET = DATA / "cad" / "octagonal_pocket.ply"


def steps_range_grid() -> str:
    """The text of tests/data/scans/steps_range_grid.ply: a Cyberware-style range grid (24
    frames of 20 samples, 0.5 apart, seen along z) of a block 10 high on a gentle slope,
    with a 3 x 3 hole the scanner did not see."""
    cols, rows, step = 24, 20, 0.5
    cells, pts = [], []
    for r in range(rows):
        for c in range(cols):
            x, y = c * step, r * step
            if 4 <= r <= 6 and 17 <= c <= 19:
                cells.append("0")
                continue
            z = 10.0 if 8 <= c <= 15 and 5 <= r <= 14 else 0.02 * x
            cells.append(f"1 {len(pts)}")
            pts.append((x, y, z))
    vertices = [f"{x:g} {y:g} {z:g}" for x, y, z in pts]
    comment = "synthetic range grid: a block on a slope, seen along z"
    return cyberware_range_grid(rows, cols, step, vertices, cells, comment)


def test_the_test_file_is_what_its_generator_writes():
    assert STEPS.read_text() == steps_range_grid()


LEDGE = DATA / "scans" / "ledge_range_grid.ply"


def ledge_range_grid() -> str:
    """The text of tests/data/scans/ledge_range_grid.ply: a Cyberware-style range grid (16
    frames of 20 samples, 0.5 apart, seen along z) of a floor and a ledge 3.5 above it whose
    face the scanner grazes: the two samples either side of it are 0.2 apart across, so a
    face between them stands 3.3 degrees off the rays. Seen along z it is a curtain; over
    the plane the points choose (tilted from z) it is not steep."""
    cols, rows, step = 16, 20, 0.5
    cells, pts = [], []
    for r in range(rows):
        for c in range(cols):
            y = r * step if r < 10 else 4.7 + (r - 10) * step
            cells.append(f"1 {len(pts)}")
            pts.append((c * step, y, 0.0 if r < 10 else 3.5))
    vertices = [f"{x:g} {y:g} {z:g}" for x, y, z in pts]
    comment = "synthetic range grid: a ledge grazed by the rays, seen along z"
    return cyberware_range_grid(rows, cols, step, vertices, cells, comment)


def test_the_ledge_file_is_what_its_generator_writes():
    assert LEDGE.read_text() == ledge_range_grid()


def _long_curtains(points: np.ndarray, faces: np.ndarray, sight) -> int:
    """Faces within 5 degrees of ``sight`` whose longest edge exceeds 4 x the median edge
    (the real-scan curtain), counted face by face."""
    edges = np.linalg.norm(points[faces] - points[np.roll(faces, 1, axis=1)], axis=2)
    long = edges.max(axis=1) > 4.0 * np.median(edges)
    return int((long & (_angles_to_sight(points, faces, sight) <= 5.0)).sum())


def test_a_range_grid_is_seen_along_its_z_axis(tmp_path):
    np.testing.assert_array_equal(scanmesh.read(LEDGE).up, [0.0, 0.0, 1.0])
    # a recorded up wins over the range image's axis
    up_y = tmp_path / "up_y.ply"
    head = "format ascii 1.0\n"
    up_y.write_text(ledge_range_grid().replace(head, head + "comment scanmesh up 0 1 0\n"))
    np.testing.assert_array_equal(scanmesh.read(up_y).up, [0.0, 1.0, 0.0])


@pytest.mark.parametrize("method", ["auto", "grid", "lop", "anneal"])
def test_no_curtain_along_the_scanners_rays_whatever_the_plane(method):
    # the plane the points choose (best-fit, 7 degrees off z) and one tilted 40 degrees:
    # the rule judges faces against the rays (z), not the plane's normal, so the face across
    # the ledge goes and the report counts along z (it kept 30 and reported 0)
    tilted = (0.0, -math.sin(math.radians(40.0)), math.cos(math.radians(40.0)))
    for plane in (None, tilted):
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            s = scanmesh.reconstruct(LEDGE, method, plane=plane)
        assert _long_curtains(s.vertices, s.faces, (0.0, 0.0, 1.0)) == 0
        at_5 = _angles_to_sight(s.vertices, s.faces, (0.0, 0.0, 1.0)) <= CURTAIN_ANGLE_DEG
        assert s.options["curtains"]["count"] == int(at_5.sum())
        # both levels are kept: only the faces across the ledge went
        assert np.isin(np.flatnonzero(s.vertices[:, 2] > 1.0), s.faces).all()
        assert np.isin(np.flatnonzero(s.vertices[:, 2] < 1.0), s.faces).all()


def _angles_to_sight(points: np.ndarray, faces: np.ndarray, sight) -> np.ndarray:
    """Degrees between each face's plane and the line of sight, face by face (brute force)."""
    s = np.asarray(sight, dtype=float) / np.linalg.norm(sight)
    out = []
    for f in faces:
        a, b, c = points[f]
        n = np.cross(b - a, c - a)
        out.append(math.degrees(math.asin(min(1.0, abs(n @ s) / np.linalg.norm(n)))))
    return np.array(out)


def test_grid_drops_the_curtains_of_a_range_grid_ply_and_keeps_both_levels():
    sp = scanmesh.read(STEPS)
    assert sp.grid.shape == (24, 20)
    with warnings.catch_warnings():
        warnings.simplefilter("error", CurtainsWarning)
        s = scanmesh.reconstruct(sp, "grid")
    pts = sp.points
    # every face is seen by the scanner: its normal within max_turn of the line of sight
    # (the range image's z, recorded as up), its edges short
    normal_tilt = 90 - _angles_to_sight(pts, s.faces, s.scan.sight)
    assert normal_tilt.max() <= s.options["max_turn"]
    edges = np.linalg.norm(pts[s.faces] - pts[np.roll(s.faces, 1, axis=1)], axis=2)
    assert edges.max() <= s.options["edge_factor"] * 0.5 * 1.0001
    assert s.options["dropped_turned"] > 0 and s.options["curtains"]["count"] == 0
    # the block's top and the slope around it are both there; the hole stays open
    top = np.flatnonzero(np.isclose(pts[:, 2], 10.0))
    assert np.isin(top, s.faces).all()
    on_top = np.isin(s.faces, top)
    assert np.all(on_top.all(axis=1) | ~on_top.any(axis=1))  # no face hangs from the block
    _core.validate(s.scan.uv, s.faces)
    # Delaunay of the whole hull hangs sheets from the block: the report names them
    with pytest.warns(CurtainsWarning, match="within 5 deg of the line of sight"):
        hull = scanmesh.reconstruct(sp, "delaunay", max_edge=math.inf)
    assert hull.options["curtains"]["count"] > 0


def test_a_flat_height_grid_gives_two_triangles_per_cell():
    z = np.fromfunction(lambda i, j: 0.1 * i + 0.05 * j, (6, 7))
    s = scanmesh.reconstruct(height_grid(z, cell=2.0), "grid")
    assert len(s.faces) == 2 * 5 * 6
    assert s.options["spacing"] == pytest.approx(2.0, rel=1e-2)
    assert len(s.options["trimmed"]) == 0


def test_edge_factor_and_max_turn_are_obeyed():
    sp = scanmesh.read(STEPS)
    with pytest.warns(CurtainsWarning):
        loose = scanmesh.reconstruct(sp, "grid", max_turn=90.0, edge_factor=math.inf)
    strict = scanmesh.reconstruct(sp, "grid", max_turn=90.0, edge_factor=4.0)
    assert len(loose.faces) > len(strict.faces)  # the sheets (20 spacings tall) go at k = 4
    assert strict.options["dropped_long"] > 0 and loose.options["dropped_long"] == 0
    for bad in ({"max_turn": 0.0}, {"max_turn": 91.0}, {"edge_factor": -1.0}):
        with pytest.raises(ParameterError):
            scanmesh.reconstruct(sp, "grid", **bad)


def test_grid_needs_a_grid():
    pts = np.random.default_rng(0).random((50, 3))
    with pytest.raises(ParameterError, match="range grid"):
        scanmesh.reconstruct(pts, "grid", plane="z")


def test_simulated_range_scans_keep_simulate_scans_points_and_know_their_grid():
    sp = simulate_range_scan(POCKET, up="z", n_points=3000, noise=1e-4, seed=3)
    pts, ids = scanmesh.simulate_scan(POCKET, up="z", n_points=3000, noise=1e-4, seed=3)
    np.testing.assert_array_equal(sp.points, pts)
    np.testing.assert_array_equal(sp.line_ids, ids)
    np.testing.assert_array_equal(sp.up, [0, 0, 1])
    # each row of the grid is one line, in order along x
    for line, row in enumerate(sp.grid):
        members = row[row >= 0]
        assert np.all(ids[members] == line) and np.all(np.diff(pts[members, 0]) > 0)
    assert (sp.grid >= 0).sum() == len(pts)
    rod = DATA / "cad" / "conrod_slevin48_onshape.stl"  # round bosses, seen from the side
    whole = simulate_range_scan(rod, up="x", along="y", n_points=3000)
    dropped = simulate_range_scan(rod, up="x", along="y", n_points=3000, grazing=60.0)
    assert 0.5 * len(whole.points) < len(dropped.points) < len(whole.points)
    assert np.isin(dropped.points, whole.points).all()
    with pytest.raises(ParameterError, match="grazing"):
        simulate_range_scan(POCKET, up="z", n_points=3000, grazing=0.0)


@pytest.mark.slow
def test_grid_faces_lie_on_the_part_where_delaunay_bridges_its_walls():
    sp = simulate_range_scan(POCKET, up="z", n_points=6000)
    truth = trimesh.load(POCKET, force="mesh")
    s = scanmesh.reconstruct(sp, "grid")
    hull = scanmesh.delaunay(sp, max_edge=math.inf)
    spacing = s.options["spacing"]

    def off(faces):
        centroids = sp.points[faces].mean(axis=1)
        return np.abs(trimesh.proximity.closest_point(truth, centroids)[1])

    assert off(s.faces).max() <= 2 * spacing
    assert off(hull.faces).max() > 2 * spacing  # the check can fail


def test_ears_fill_a_convex_outlines_notches_but_never_cut_across_a_bore_rim():
    # a plate with a round outline and a bore: the cells leave a staircase along both
    # circles; ears across the notches cover more of the plate along the outline (convex
    # seen from the mesh), but along the bore's rim (concave) an ear's chord would leave
    # the plate, so the rim keeps its staircase (docs/benchmarks/curtains.md, "Notch ears")
    i, j = np.indices((41, 41), dtype=float)
    r = np.hypot(i - 20, j - 20)
    r_out, r_in = 18.7, 6.3
    z = np.where((r <= r_out) & (r >= r_in), 0.01 * i, np.nan)
    s = scanmesh.reconstruct(height_grid(z), "grid")
    _core.validate(s.scan.uv, s.faces)
    cells = np.argwhere(~np.isnan(z))  # (N, 2) row, column of each point
    span = np.ptp(cells[s.faces], axis=1).max(axis=1)
    corners = s.scan.points[s.faces][:, :, :2]  # (M, 3, 2) x = column, y = row
    ears = corners[span > 1]
    radius = np.hypot(ears[..., 0] - 20, ears[..., 1] - 20)
    assert len(ears) > 0 and (radius.min(axis=1) > 12).all()  # on the outer circle only
    # against the truth: no point of a face lies in the bore (nor outside the plate)
    w = np.array([[1, 1, 1], [2, 1, 1], [1, 2, 1], [1, 1, 2], [1, 1, 0], [0, 1, 1], [1, 0, 1]])
    inner = np.einsum("kj,mjd->mkd", w / w.sum(axis=1, keepdims=True), corners)
    rho = np.hypot(inner[..., 0] - 20, inner[..., 1] - 20)
    assert rho.min() >= r_in - 1e-9 and rho.max() <= r_out + 1e-9
    # no position without a sample lies inside a face
    holes = np.argwhere(np.isnan(z))[:, ::-1].astype(float)  # (H, 2) x, y
    inside = np.ones((len(corners), len(holes)), dtype=bool)
    for k in range(3):
        a, b = corners[:, k], corners[:, (k + 1) % 3]
        side = (b[:, None, 0] - a[:, None, 0]) * (holes[None, :, 1] - a[:, None, 1]) - (
            b[:, None, 1] - a[:, None, 1]
        ) * (holes[None, :, 0] - a[:, None, 0])
        inside &= side >= 0
    assert not inside.any()


def test_ears_straighten_a_slanted_straight_outline():
    # samples on and below the line row = (column + 2) / 3 of a flat plate: the cells leave
    # a staircase of notches (zero net turn), and the ears fill it to within a cell of the
    # samples' hull (239 cells; the full and half cells alone cover 228)
    z = np.zeros((13, 37))
    i, j = np.indices(z.shape)
    z[3 * i > j + 2] = np.nan
    s = scanmesh.reconstruct(height_grid(z), "grid")
    _core.validate(s.scan.uv, s.faces)
    tri = s.scan.points[s.faces][:, :, :2]
    e, f = tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0]
    area = 0.5 * np.abs(e[:, 0] * f[:, 1] - e[:, 1] * f[:, 0])
    cells = np.argwhere(~np.isnan(z))
    in_cell = np.ptp(cells[s.faces], axis=1).max(axis=1) <= 1
    hull = ConvexHull(s.scan.points[:, :2]).volume
    assert hull == pytest.approx(239.0)
    assert area[in_cell].sum() < hull - 10 and area.sum() >= hull - 2


def test_lop_and_annealing_start_from_the_grid_of_a_gridded_scan():
    sp = simulate_range_scan(POCKET, up="z", n_points=3000)
    scan = planar_scan(sp.points, plane="z")
    assert default_initial(scan) == "delaunay"
    gridded = scanmesh.scan.planar.as_scan(sp.points, plane="z")
    assert gridded.grid is None
    start = scanmesh.reconstruct(sp, "grid")
    assert default_initial(start.scan) == "grid"
    for method, extra in (("lop", {}), ("anneal", {"sweeps": 5})):
        s = scanmesh.reconstruct(sp, method, **extra)
        assert s.options["initial"] == "grid"
        _core.validate(s.scan.uv, s.faces)
        # flips stay inside the start's domain: the same outline and holes
        loops = {frozenset(loop.tolist()) for loop in s.boundary_loops()}
        assert loops == {frozenset(loop.tolist()) for loop in start.boundary_loops()}
    explicit = scanmesh.reconstruct(sp, "lop", initial="delaunay")
    assert explicit.options["initial"] == "delaunay"
    arrays = scanmesh.reconstruct(sp.points, "lop", plane="z")
    assert arrays.options["initial"] == "delaunay"


def test_curtains_agree_with_a_brute_force_count():
    rng = np.random.default_rng(7)
    pts = rng.normal(size=(60, 3))
    faces = np.array([rng.choice(60, 3, replace=False) for _ in range(200)])
    sight = np.array([0.3, -0.2, 1.0])
    found = curtains(pts, faces, sight)
    angles = _angles_to_sight(pts, faces, sight)
    graze = angles <= CURTAIN_ANGLE_DEG
    area = 0.5 * np.linalg.norm(
        np.cross(pts[faces[:, 1]] - pts[faces[:, 0]], pts[faces[:, 2]] - pts[faces[:, 0]]), axis=1
    )
    assert found.count == graze.sum() > 0
    assert found.area == pytest.approx(area[graze].sum())
    assert found.fraction == pytest.approx(area[graze].sum() / area.sum())
    assert set(found.faces.tolist()) == set(np.flatnonzero(graze).tolist())


def test_the_command_reports_curtains(tmp_path):
    report = tmp_path / "r.json"
    args = ["reconstruct", str(STEPS), "-o", str(tmp_path / "m.stl"), "--report", str(report)]
    assert main([*args, "--method", "grid", "-q"]) == 0
    data = json.loads(report.read_text())
    assert data["options"]["curtains"]["count"] == 0
    assert data["options"]["curtains"]["sight"] == "recorded up"  # the range image's z
    assert main([*args, "--method", "delaunay", "--max-edge", "inf", "-q"]) == 0
    data = json.loads(report.read_text())
    assert data["options"]["curtains"]["count"] > 0
    assert any("line of sight" in w for w in data["warnings"])


def _turns(surface) -> np.ndarray:
    """Degrees between each face's normal and z (atan2, apart from the core's facing)."""
    p = surface.vertices[surface.faces]
    n = np.cross(p[:, 1] - p[:, 0], p[:, 2] - p[:, 0])
    return np.degrees(np.arctan2(np.hypot(n[:, 0], n[:, 1]), np.abs(n[:, 2])))


def _dome(n: int = 40):
    """A noisy dome seen from above as a height grid: steep at its rim."""
    rng = np.random.default_rng(3)
    i, j = np.mgrid[0:n, 0:n] / (n - 1) * 2 - 1
    r2 = i * i + j * j
    z = np.sqrt(np.clip(1.02 - r2, 0, None)) + 0.01 * rng.standard_normal(i.shape)
    z[r2 > 1] = np.nan
    return height_grid(z, cell=2 / (n - 1))


@pytest.mark.slow
@pytest.mark.parametrize("method", ["lop", "anneal"])
def test_flips_from_the_grid_never_turn_a_face_past_the_curtain_angle(method):
    sp = _dome()
    start = _turns(scanmesh.reconstruct(sp, "grid")).max()
    free = _turns(scanmesh.reconstruct(sp, method, curtain_angle=0.0)).max()
    # without the rule tac's flips stand faces steeper than any of the grid's
    assert free > start + 1.0
    for angle in (10.0, 20.0, 30.0):
        s = scanmesh.reconstruct(sp, method, curtain_angle=angle)
        assert s.options["curtain_angle"] == angle
        # a flip may not make a face steeper than 90 - angle and than the faces it replaces
        assert _turns(s).max() <= max(start, 90.0 - angle) + 1e-9


def test_the_curtain_rule_needs_a_known_line_of_sight():
    dome = _dome()
    # the dome's points alone (no grid, no recorded up): the projection normal is no line
    # of sight, and the rule is off whatever the angle
    alone = [scanmesh.reconstruct(dome.points, "lop", curtain_angle=a) for a in (0.0, 30.0)]
    assert np.array_equal(alone[0].faces, alone[1].faces)
    # the same points with the scanner's up recorded: the rule holds flips back
    seen = dataclasses.replace(dome, grid=None, up=np.array([0.0, 0.0, 1.0]))
    up = [scanmesh.reconstruct(seen, "lop", curtain_angle=a) for a in (0.0, 30.0)]
    assert up[0].options["initial"] == up[1].options["initial"] == "delaunay"
    assert not np.array_equal(up[0].faces, up[1].faces)
    with pytest.raises(ParameterError, match="curtain_angle"):
        scanmesh.reconstruct(dome.points, "lop", curtain_angle=90.0)


def test_a_plane_the_scan_folds_over_is_named_as_such():
    """plane="best-fit" on the steps: the block's 10-unit height gives z more variance than
    y, so the least-squares plane stands along y, the grid's columns stack up in it and
    trimming keeps nothing. The error says so (with the spacings that show it) and names
    the way out; plane=None meshes the same scan."""
    with pytest.raises(scanmesh.DegenerateInputError) as caught:
        scanmesh.reconstruct(STEPS, "delaunay", plane="best-fit")
    text = str(caught.value)
    assert "folds onto itself over plane='best-fit'" in text and "plane=None" in text
    # the spacings it quotes, measured apart (brute force): 0.5 in 3-D, far less in the plane
    scan = planar_scan(scanmesh.read(STEPS).points, plane="best-fit")
    for coords, quoted in ((scan.points, "0.5 apart in 3-D"), (scan.uv, None)):
        d = np.sqrt(((coords[:, None] - coords[None]) ** 2).sum(-1))
        np.fill_diagonal(d, np.inf)
        nearest = np.median(d.min(axis=1))
        if quoted:
            assert quoted in text and math.isclose(nearest, 0.5)
        else:
            assert f"{nearest:.3g} apart in the plane" in text and nearest < 0.05
    assert len(scanmesh.reconstruct(STEPS, "delaunay").faces) > 0
    # a plane it does not fold over, trimmed too short: the other cause
    with pytest.raises(scanmesh.DegenerateInputError, match="too sparse"):
        scanmesh.reconstruct(STEPS, "delaunay", plane="z", max_edge=0.1)


def _stepped_part(step: float, wall_x: float = 1.013) -> trimesh.Trimesh:
    """A block 2 x 1 with a step: its top at 1 + ``step`` for x < ``wall_x``, at 1 beyond,
    the wall between them at x = ``wall_x``, off the scanner's columns."""
    upper = trimesh.creation.box(bounds=[[0.0, 0.0, 0.0], [wall_x, 1.0, 1.0 + step]])
    lower = trimesh.creation.box(bounds=[[wall_x, 0.0, 0.0], [2.0, 1.0, 1.0]])
    return trimesh.util.concatenate([upper, lower])


def _covered(points: np.ndarray, faces: np.ndarray, probes: np.ndarray) -> np.ndarray:
    """(P,) bool: which (P, 2) plan positions lie inside a face's xy projection."""
    tri = points[faces][:, :, :2]
    inside = np.ones((len(tri), len(probes)), dtype=bool)
    e, f = tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0]
    sign = np.sign(e[:, 0] * f[:, 1] - e[:, 1] * f[:, 0])[:, None]
    for k in range(3):
        a, b = tri[:, k], tri[:, (k + 1) % 3]
        side = (b[:, None, 0] - a[:, None, 0]) * (probes[None, :, 1] - a[:, None, 1]) - (
            b[:, None, 1] - a[:, None, 1]
        ) * (probes[None, :, 0] - a[:, None, 0])
        inside &= sign * side >= 0
    return inside.any(axis=0)


def test_the_default_turn_covers_a_wall_a_few_spacings_high_without_curtains():
    # a step 7 spacings high seen from above (the pocket along z of docs/benchmarks/
    # curtains.md): no sample on the wall, the cells across it turn atan(7) = 82 deg from
    # the rays with edges near 7.1 spacings. θ = 85 and k = 8 (the defaults) keep them, so
    # the wall's band of the plan is covered, by faces within 2 spacings of the wall and at
    # least 5 deg from the sight (no curtain); θ = 80 (the earlier default) leaves it open
    s, wall_x = 0.05, 1.013
    part = _stepped_part(7 * s, wall_x)
    sp = simulate_range_scan(part, up="z", spacing=s, noise=0.05 * s, seed=0, grazing=80.0)
    probes = np.column_stack([np.full(15, wall_x), np.linspace(0.15, 0.85, 15)])
    kept = scanmesh.reconstruct(sp, "grid")
    assert kept.options["max_turn"] == 85.0 and kept.options["edge_factor"] == 8.0
    p = sp.points[kept.faces]
    high = p[..., 2] > 1.0 + 3.5 * s
    across = high.any(axis=1) & ~high.all(axis=1)
    assert across.sum() >= 2 * 15 and _covered(sp.points, kept.faces, probes).all()
    off = np.abs(trimesh.proximity.closest_point(part, p.mean(axis=1))[1])
    assert off.max() <= 2 * s
    assert np.abs(p[across].mean(axis=1)[:, 0] - wall_x).max() <= 2 * s
    assert kept.options["curtains"]["count"] == 0
    assert _angles_to_sight(sp.points, kept.faces, sp.up).min() >= CURTAIN_ANGLE_DEG
    for rules in ({"max_turn": 80.0}, {"max_turn": 80.0, "edge_factor": 6.0}):
        narrow = scanmesh.reconstruct(sp, "grid", **rules)
        assert not _covered(sp.points, narrow.faces, probes).any()
    # k = 6 drops the same sheets by their length
    short = scanmesh.reconstruct(sp, "grid", edge_factor=6.0)
    assert not _covered(sp.points, short.faces, probes).any()
