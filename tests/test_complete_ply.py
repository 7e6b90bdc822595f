"""A PLY that carries what scanmesh knows: vertex normals, tac, height above the scan plane,
error against a truth, the scan's colours and values, its CRS and units; colours in GLB.
Each figure is checked against an independent computation (trimesh, numpy by hand), and
each file is parsed both by trimesh and by a plain header-driven parser written here."""

from __future__ import annotations

import json

import numpy as np
import pytest
import trimesh

import scanmesh
from conftest import DATA
from scanmesh.errors import ParameterError
from scanmesh.formats.georef import Georef, from_comments
from test_cli import run

_TYPES = {"double": "<f8", "float": "<f4", "uchar": "u1", "ushort": "<u2", "int": "<i4"}


def parse_ply(path) -> tuple[list[str], np.ndarray, np.ndarray]:
    """A binary little-endian PLY read from its header alone, as plyfile does: (comments,
    vertex records, (M, 3) faces). Independent of scanmesh's and trimesh's readers."""
    data = path.read_bytes()
    end = data.index(b"end_header\n") + len(b"end_header\n")
    lines = data[:end].decode("ascii").splitlines()
    assert lines[:2] == ["ply", "format binary_little_endian 1.0"]
    comments = [line[len("comment ") :] for line in lines if line.startswith("comment ")]
    fields, counts, element = [], {}, None
    for line in lines:
        words = line.split()
        if words[0] == "element":
            element = words[1]
            counts[element] = int(words[2])
        elif words[0] == "property" and element == "vertex":
            fields.append((words[2], _TYPES[words[1]]))
    vertices = np.frombuffer(data, np.dtype(fields), counts["vertex"], end)
    face = np.dtype([("n", "u1"), ("v", "<i4", (3,))])
    offset = end + vertices.nbytes
    faces = np.frombuffer(data, face, counts["face"], offset)
    assert (faces["n"] == 3).all() and offset + faces.nbytes == len(data)
    return comments, vertices, faces["v"].astype(np.int64)


def _bumps(n=400, seed=1):
    rng = np.random.default_rng(seed)
    pts = rng.random((n, 3))
    pts[:, 2] = 0.3 * np.sin(3 * pts[:, 0]) * np.cos(2 * pts[:, 1])
    return pts


def test_the_ply_holds_normals_tac_and_height_as_trimesh_measures_them(tmp_path):
    surface = scanmesh.reconstruct(_bumps(), "delaunay")
    path = surface.save(tmp_path / "m.ply")
    _, v, faces = parse_ply(path)
    assert list(v.dtype.names) == ["x", "y", "z", "nx", "ny", "nz", "tac", "height"]
    assert np.array_equal(faces, surface.faces)
    mesh = trimesh.Trimesh(surface.vertices, surface.faces, process=False)
    # normals: the area-weighted mean of the face normals, from trimesh's own pieces
    summed = mesh.faces_sparse.dot(mesh.face_normals * mesh.area_faces[:, None])
    used = np.unique(surface.faces)
    want = summed[used] / np.linalg.norm(summed[used], axis=1, keepdims=True)
    normals = np.column_stack([v["nx"], v["ny"], v["nz"]])
    np.testing.assert_allclose(normals[used], want, atol=1e-12)
    unused = np.setdiff1d(np.arange(len(v)), used)
    assert not normals[unused].any()  # a trimmed point has no normal: zero
    # and close to trimesh's angle-weighted ones on this smooth surface (the weights
    # differ most at the boundary, where slivers meet)
    cosines = (normals[used] * mesh.vertex_normals[used]).sum(axis=1)
    degrees = np.degrees(np.arccos(np.clip(cosines, -1, 1)))
    assert np.median(degrees) < 1.5 and np.percentile(degrees, 90) < 5
    # tac: the absolute angle defect at interior vertices (trimesh's signed defect), NaN
    # on the boundary
    boundary = np.ones(len(v), bool)  # unused points count as boundary: no tac
    boundary[used] = False
    boundary[np.concatenate(surface.boundary_loops())] = True
    defect = trimesh.curvature.discrete_gaussian_curvature_measure(mesh, mesh.vertices, 0.0)
    np.testing.assert_allclose(v["tac"][~boundary], np.abs(defect[~boundary]), atol=1e-9)
    assert np.isnan(v["tac"][boundary]).all()
    # height: signed distance from the projection plane, along its normal
    frame = surface.frame
    assert frame is not None
    np.testing.assert_allclose(
        v["height"], (surface.vertices - frame.origin) @ frame.normal, atol=1e-12
    )
    # trimesh reads the same file, properties included
    back = trimesh.load(path, process=False)
    raw = back.metadata["_ply_raw"]["vertex"]["data"]
    np.testing.assert_array_equal(raw["tac"], v["tac"])
    np.testing.assert_allclose(back.vertex_normals, normals, atol=1e-12)


def test_a_mesh_of_its_own_ply_gets_fresh_measures(tmp_path):
    first = scanmesh.reconstruct(_bumps(), "delaunay")
    first.save(tmp_path / "a.ply")
    scan = scanmesh.read(tmp_path / "a.ply")
    assert {"nx", "tac", "height"} <= set(scan.point_data)  # carried from the file
    again = scanmesh.reconstruct(scan, "lop")
    again.save(tmp_path / "b.ply")
    _, v, _ = parse_ply(tmp_path / "b.ply")
    assert list(v.dtype.names).count("tac") == 1
    np.testing.assert_array_equal(v["tac"], again.quality.tac)  # this mesh's, not the file's
    np.testing.assert_allclose(np.column_stack([v["nx"], v["ny"], v["nz"]]), again.normals)


def test_error_against_a_truth_is_the_closest_point_distance(tmp_path):
    part = trimesh.creation.icosphere(subdivisions=3, radius=1.0)
    points, _ = scanmesh.simulate_scan(part, up="z", spacing=0.15, noise=0.01, seed=1)
    surface = scanmesh.reconstruct(points, "delaunay")
    surface.save(tmp_path / "e.ply", truth=part)
    _, v, _ = parse_ply(tmp_path / "e.ply")
    _, distance, _ = trimesh.proximity.closest_point(part, surface.vertices)
    np.testing.assert_allclose(v["error"], distance, atol=1e-9)
    assert 0.002 < np.median(v["error"]) < 0.02  # the noise (sigma 0.01) off the part
    with pytest.raises(ParameterError, match="PLY"):
        surface.save(tmp_path / "e.stl", truth=part)


@pytest.mark.slow
def test_las_colours_intensity_and_crs_reach_the_ply_glb_and_report(tmp_path):
    pytest.importorskip("laspy")
    laz = DATA / "lidar" / "autzen_trim.laz"
    scan = scanmesh.read(laz)
    assert scan.georef == Georef(
        crs="NAD_1983_HARN_Lambert_Conformal_Conic",
        wkt=scan.georef.wkt,
        horizontal_units="foot",  # GeoKey 3076 = 9002 and the WKT's UNIT["foot", ...]
        vertical_units=None,  # the file does not say
    )
    assert scan.georef.wkt.startswith('PROJCS["NAD_1983_HARN_Lambert_Conformal_Conic"')
    import laspy

    las = laspy.read(laz)
    first = np.asarray(las.return_number) == 1
    for name in ("red", "green", "blue", "intensity", "classification"):
        np.testing.assert_array_equal(scan.point_data[name], np.asarray(las[name])[first])
    out, report = tmp_path / "a.ply", tmp_path / "a.json"
    result = run("reconstruct", laz, "-o", out, "--method", "delaunay", "--report", report, "-q")
    assert result.returncode == 0, result.stderr
    comments, v, _ = parse_ply(out)
    assert from_comments(comments) == Georef(
        crs=scan.georef.crs, wkt=scan.georef.wkt, horizontal_units="foot"
    )
    for name in ("red", "green", "blue", "intensity"):
        np.testing.assert_array_equal(v[name], scan.point_data[name])
    again = scanmesh.read(out)
    assert again.georef == from_comments(comments)
    data = json.loads(report.read_text())
    assert data["georef"]["crs"] == scan.georef.crs and data["georef"]["in_output"] is True
    # colours in GLB: every corner its point's colour, as trimesh reads it back
    surface = scanmesh.reconstruct(scan, "delaunay")
    surface.save(tmp_path / "a.glb")
    glb = trimesh.load(tmp_path / "a.glb", process=False)
    (flat,) = glb.geometry.values()
    want = surface.colors[surface.faces.ravel()]
    np.testing.assert_array_equal(flat.visual.vertex_colors[:, :3], want)
    # an STL has no place for the CRS: the report says so
    result = run(
        "reconstruct",
        laz,
        "-o",
        tmp_path / "a.stl",
        "--method",
        "delaunay",
        "--report",
        report,
        "-q",
    )
    assert result.returncode == 0, result.stderr
    assert json.loads(report.read_text())["georef"]["in_output"] is False


def test_dem_crs_and_units_are_kept():
    scan = scanmesh.read(DATA / "terrain" / "SainteHelens.dem")
    # A record: reference system 1 (UTM), zone 10, units 2 (metres) and 2; no datum field
    assert scan.georef == Georef(
        crs="UTM zone 10, datum not recorded", horizontal_units="metre", vertical_units="metre"
    )


def test_dem_with_a_recorded_datum_names_its_epsg_code(tmp_path):
    data = bytearray((DATA / "terrain" / "SainteHelens.dem").read_bytes())
    data[890:892] = b" 4"  # NAD83
    (tmp_path / "d.dem").write_bytes(bytes(data))
    assert scanmesh.read(tmp_path / "d.dem").georef.crs == "EPSG:26910"


@pytest.mark.slow
def test_reconstruct_truth_writes_the_error_and_reports_it(tmp_path):
    part = trimesh.creation.icosphere(subdivisions=3, radius=1.0)
    part.export(tmp_path / "part.stl")
    points, lines = scanmesh.simulate_scan(part, up="z", spacing=0.2)
    scanmesh.formats.write.write_points(tmp_path / "s.xyz", points, lines)
    out, report = tmp_path / "m.ply", tmp_path / "r.json"
    result = run(
        "reconstruct", tmp_path / "s.xyz", "-o", out, "--method", "delaunay", "--truth",
        tmp_path / "part.stl", "--report", report, "-q",
    )  # fmt: skip
    assert result.returncode == 0, result.stderr
    _, v, faces = parse_ply(out)
    part_read = trimesh.load(tmp_path / "part.stl")
    points = np.column_stack([v["x"], v["y"], v["z"]])
    _, distance, _ = trimesh.proximity.closest_point(part_read, points)
    np.testing.assert_allclose(v["error"], distance, atol=1e-6)  # STL stores float32
    used = np.unique(faces)
    got = json.loads(report.read_text())["vertex_error"]
    assert got["max"] == pytest.approx(distance[used].max(), abs=1e-6)
    assert got["rms"] == pytest.approx(np.sqrt(np.mean(distance[used] ** 2)), abs=1e-6)
    refused = run(
        "reconstruct",
        tmp_path / "s.xyz",
        "-o",
        tmp_path / "m.stl",
        "--truth",
        tmp_path / "part.stl",
    )
    assert refused.returncode == 2 and "--truth" in refused.stderr


@pytest.mark.slow
def test_info_names_the_values_and_crs_a_file_carries():
    pytest.importorskip("laspy")
    result = run("info", DATA / "lidar" / "autzen_trim.laz", "--json")
    assert result.returncode == 0, result.stderr
    data = json.loads(result.stdout)
    assert data["point_data"] == {
        "intensity": "uint16",
        "classification": "uint8",
        "red": "uint16",
        "green": "uint16",
        "blue": "uint16",
    }
    assert data["georef"]["crs"] == "NAD_1983_HARN_Lambert_Conformal_Conic"
    assert data["georef"]["horizontal_units"] == "foot"


def test_no_tac_asked_measures_nothing(tmp_path):
    first = scanmesh.reconstruct(_bumps(), "delaunay")
    first.save(tmp_path / "a.ply")  # holds a tac a re-mesh must not pass on as its own
    again = scanmesh.reconstruct(scanmesh.read(tmp_path / "a.ply"), "delaunay")
    again.save(tmp_path / "b.ply", tac=False)
    assert "quality" not in again.__dict__  # the cached measurement never ran
    _, v, _ = parse_ply(tmp_path / "b.ply")
    assert list(v.dtype.names) == ["x", "y", "z", "nx", "ny", "nz", "height"]
    result = run("reconstruct", tmp_path / "a.ply", "-o", tmp_path / "c.ply", "--no-quality")
    assert result.returncode == 0, result.stderr
    _, w, _ = parse_ply(tmp_path / "c.ply")
    assert "tac" not in w.dtype.names and "height" in w.dtype.names
