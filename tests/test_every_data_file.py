"""Every kind of file in the shared data, as its small copy here: one command gives a mesh,
a picture and a complete PLY (normals, tac, height, the file's own per-point values and
its CRS where it records them)."""

from __future__ import annotations

import json

import numpy as np
import pytest
import trimesh
from PIL import Image

import scanmesh
from conftest import DATA
from test_cli import run
from test_complete_ply import parse_ply

#: the small copies in tests/data of the benchmark data files (tests/data/ATTRIBUTION.md), and
#: what each must carry
FILES = {
    "cad/conrod_slevin48_onshape.stl": ("closed",),
    "cad/fandisk.obj": ("closed",),
    "cad/octagonal_pocket.ply": ("closed",),
    "cad/turbineblade_cut.ply": (),
    "scans/fran_cut.vtk": (),
    "terrain/SainteHelens.dem": ("crs", "horizontal_units", "vertical_units"),
    "lidar/autzen_trim.laz": ("crs", "crs_wkt", "horizontal_units", "red", "intensity"),
}


@pytest.mark.slow
@pytest.mark.parametrize("name", sorted(FILES))
def test_one_command_gives_a_mesh_a_picture_and_a_complete_ply(tmp_path, name):
    if name.endswith(".laz"):
        pytest.importorskip("laspy")
    source = DATA / name
    out, picture, report = tmp_path / "m.ply", tmp_path / "m.png", tmp_path / "r.json"
    result = run("reconstruct", source, "-o", out, "--preview", picture, "--report", report)
    assert result.returncode == 0, result.stderr
    scan = scanmesh.read(source)
    comments, v, faces = parse_ply(out)
    xyz = np.column_stack([v["x"], v["y"], v["z"]])
    if "closed" in FILES[name]:
        # a solid's surface is scanned, not meshed vertex by vertex: the vertices are a
        # scan of about 20,000 points lying on the part, and the command says so
        part = trimesh.load_mesh(source)
        assert part.is_volume and "is a closed mesh" in result.stderr
        assert 15_000 < len(v) < 25_000 and len(faces) > len(v)
        _, distance, _ = trimesh.proximity.closest_point(part, xyz)
        # trimesh's search misses the nearest triangle for a few points (0.5 % on the
        # pocket, each checked to lie inside the triangle its ray hit): 99 %, not all
        assert np.quantile(distance, 0.99) < 1e-9 * part.scale
        assert distance.max() < 1e-3 * part.scale
        assert json.loads(report.read_text())["quality"]["sliver_fraction"] < 0.05
    else:
        # the mesh: every point a vertex, in file order, and faces over them
        assert len(v) == len(scan) and len(faces) > len(scan) // 4
        np.testing.assert_array_equal(xyz, scan.points)
    # complete: normals (unit where a face uses the point), tac, height, carried values
    names = set(v.dtype.names)
    assert {"nx", "ny", "nz", "tac", "height"} <= names
    used = np.unique(faces)
    lengths = np.linalg.norm(np.column_stack([v["nx"], v["ny"], v["nz"]])[used], axis=1)
    np.testing.assert_allclose(lengths, 1.0, atol=1e-9)
    for key in set(FILES[name]) - {"closed"}:
        if key in scan.point_data:
            np.testing.assert_array_equal(v[key], scan.point_data[key])
        else:
            assert any(c.startswith(f"{key} ") for c in comments), (key, comments)
    data = json.loads(report.read_text())
    assert data["counts"]["faces"] == len(faces)
    assert np.isfinite(v["tac"]).sum() == data["quality"]["n_interior"] > 0
    assert np.nansum(v["tac"]) == pytest.approx(data["quality"]["tac_1"], rel=1e-9)
    if scan.georef is not None:
        assert data["georef"]["crs"] == scan.georef.crs
    # the picture: the mesh lit (shades, not one flat colour), framed (nothing cut at the edges) and
    # filling a good part of the frame
    image = np.asarray(Image.open(picture).convert("RGB")).astype(int)
    drawn = np.abs(image - image[0, 0]).sum(axis=2) > 30
    assert not (drawn[0].any() or drawn[-1].any() or drawn[:, 0].any() or drawn[:, -1].any())
    rows, cols = np.nonzero(drawn)
    assert max(np.ptp(rows) / image.shape[0], np.ptp(cols) / image.shape[1]) > 0.4
    assert len(np.unique(image[drawn].sum(axis=1) // 16)) > 2  # a plated part: few shades
