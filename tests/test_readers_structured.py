"""Reading the structured and binary scan formats: PLY (range grids, binary and ASCII), NPY,
VTK (poly lines, triangle strips, grids), USGS DEM and LAS/LAZ, each against an independent
reference (trimesh, a plain parse, laspy) and with its bad inputs named."""

from __future__ import annotations

import struct
import sys
from pathlib import Path

import numpy as np
import pytest
import trimesh

import scanmesh
from conftest import DATA
from scanmesh import FileFormatError
from scanmesh.formats import (
    read,
    read_dem,
    read_las,
    read_ply,
    read_vtk,
    read_xyz,
)
from test_readers import raises_naming, write

FRAN = DATA / "scans" / "fran_cut.vtk"
DEM = DATA / "terrain" / "SainteHelens.dem"
LAZ = DATA / "lidar" / "autzen_trim.laz"


# --------------------------------------------------------------------------- PLY


def ply_bytes(points, fmt="ascii", grid=None, faces=None, extra_prop=False):
    """An independent PLY writer (struct and str formatting), optionally with a range grid."""
    n = len(points)
    head = ["ply", f"format {fmt} 1.0", "comment made by the test"]
    if grid is not None:
        rows, cols, cells = grid
        head += [f"obj_info num_cols {cols}", f"obj_info num_rows {rows}"]
    head += [f"element vertex {n}", "property float x", "property double y", "property float z"]
    if extra_prop:
        head += ["property uchar red"]
    if faces is not None:
        head += [f"element face {len(faces)}", "property list uchar int vertex_indices"]
    if grid is not None:
        head += [f"element range_grid {len(cells)}", "property list uchar int vertex_indices"]
    head += ["end_header"]
    out = ("\n".join(head) + "\n").encode()
    if fmt == "ascii":
        body = [
            f"{x!r} {y!r} {z!r}" + (" 7" if extra_prop else "")
            for x, y, z in np.asarray(points).tolist()
        ]
        body += [" ".join(map(str, [len(f), *f])) for f in faces or []]
        body += [" ".join(map(str, [len(c), *c])) for c in (grid[2] if grid else [])]
        return out + ("\n".join(body) + "\n").encode()
    e = "<" if fmt == "binary_little_endian" else ">"
    for x, y, z in points:
        out += struct.pack(e + "fdf", x, y, z) + (struct.pack("B", 7) if extra_prop else b"")
    for f in faces or []:
        out += struct.pack(e + "B" + "i" * len(f), len(f), *f)
    for c in grid[2] if grid else []:
        out += struct.pack(e + "B" + "i" * len(c), len(c), *c)
    return out


def grid_scan(rows=4, cols=5, holes=((1, 2), (3, 0))):
    """A range image with holes: vertices row by row, and the grid cells naming them."""
    pts, cells, row_of = [], [], []
    for r in range(rows):
        for c in range(cols):
            if (r, c) in holes:
                cells.append([])
                continue
            cells.append([len(pts)])
            pts.append((float(c), float(r) * 0.5, float(r * c) / 4))
            row_of.append(r)
    return np.array(pts), (rows, cols, cells), np.array(row_of)


@pytest.mark.parametrize("fmt", ["ascii", "binary_little_endian", "binary_big_endian"])
def test_ply_range_grid_rows_are_lines(tmp_path, fmt):
    pts, grid, rows = grid_scan()
    path = write(
        tmp_path / "range.ply", ply_bytes(pts, fmt, grid=grid, faces=[[0, 1, 5]], extra_prop=True)
    )
    sp = read_ply(path)
    np.testing.assert_allclose(sp.points, pts)
    np.testing.assert_array_equal(sp.line_ids, rows)
    assert sp.n_lines == 4 and sp.extra["line_ids_from"] == "range_grid rows"


@pytest.mark.parametrize("fmt", ["ascii", "binary_little_endian", "binary_big_endian"])
def test_ply_matches_trimesh(tmp_path, fmt):
    rng = np.random.default_rng(11)
    pts = rng.normal(size=(40, 3)).astype(np.float32).astype(float)
    faces = rng.integers(0, 40, size=(20, 3)).tolist()
    path = write(tmp_path / "m.ply", ply_bytes(pts, fmt, faces=faces))
    sp = read_ply(path)
    ref = trimesh.load(path, process=False)
    np.testing.assert_array_equal(sp.points, np.asarray(ref.vertices, dtype=float))
    assert sp.line_ids is None


@pytest.mark.parametrize("name", ["cad/octagonal_pocket.ply", "cad/turbineblade_cut.ply"])
def test_real_ply_files_match_trimesh(name):
    path = DATA / name
    sp = read(path)
    ref = trimesh.load(path, process=False)
    np.testing.assert_array_equal(sp.points, np.asarray(ref.vertices, dtype=float))
    if name.endswith("turbineblade_cut.ply"):
        assert len(sp) == 2_000  # tests/data/ATTRIBUTION.md


def test_ply_truncated_binary(tmp_path):
    pts = np.arange(300.0).reshape(100, 3)
    data = ply_bytes(pts, "binary_little_endian")
    path = write(tmp_path / "cut.ply", data[: len(data) - 700])
    with raises_naming(FileFormatError, path, "truncated", "'vertex'"):
        read_ply(path)


def test_ply_truncated_in_the_faces(tmp_path):
    pts = np.arange(30.0).reshape(10, 3)
    faces = [[0, 1, 2], [2, 3, 4], [4, 5, 6, 7], [7, 8, 9]]
    for fmt in ("binary_big_endian", "ascii"):
        data = ply_bytes(pts, fmt, faces=faces)
        assert len(read_ply(write(tmp_path / "whole.ply", data))) == 10
        path = write(tmp_path / "cut.ply", data[:-12])
        with raises_naming(FileFormatError, path, "truncated", "'face'"):
            read_ply(path)


def test_text_with_byte_order_mark(tmp_path):
    sp = read_xyz(write(tmp_path / "bom.xyz", b"\xef\xbb\xbf1 2 3\n4 5 6\n"))
    np.testing.assert_array_equal(sp.points, [[1, 2, 3], [4, 5, 6]])


def test_ply_truncated_ascii(tmp_path):
    data = ply_bytes(np.arange(300.0).reshape(100, 3), "ascii")
    path = write(tmp_path / "cut.ply", data[: len(data) // 2])
    with raises_naming(FileFormatError, path, "line "):
        read_ply(path)


def test_ply_header_problems(tmp_path):
    path = write(tmp_path / "h.ply", "ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\n")
    with raises_naming(FileFormatError, path, "end_header"):
        read_ply(path)
    path = write(
        tmp_path / "h.ply",
        "ply\nformat ascii 1.0\nelement vertex 1\n"
        "property float x\nproperty float y\nend_header\n1 2\n",
    )
    with raises_naming(FileFormatError, path, "line 3", "no z"):
        read_ply(path)
    path = write(
        tmp_path / "h.ply",
        "ply\nformat ascii 1.0\nelement vertex 1\nproperty quaternion x\nend_header\n",
    )
    with raises_naming(FileFormatError, path, "line 4", "quaternion"):
        read_ply(path)


def test_ply_ascii_text_and_nan(tmp_path):
    data = ply_bytes([(1.0, 2.0, 3.0), (4.0, 5.0, 6.0)], "ascii").replace(b"5.0", b"five")
    path = write(tmp_path / "t.ply", data)
    with raises_naming(FileFormatError, path, "line 10", "'five'"):
        read_ply(path)
    path = write(
        tmp_path / "n.ply", ply_bytes([(1.0, 2.0, 3.0), (4.0, np.nan, 6.0)], "binary_little_endian")
    )
    with raises_naming(FileFormatError, path, "vertex 1", "non-finite y"):
        read_ply(path)


def test_ply_range_grid_that_does_not_match_the_points(tmp_path):
    pts, (rows, cols, cells), _ = grid_scan()
    wrong = (rows, cols, cells[:-1])  # one cell short of rows x cols
    path = write(tmp_path / "g.ply", ply_bytes(pts, "ascii", grid=wrong))
    with raises_naming(FileFormatError, path, "range_grid", "4 x 5"):
        read_ply(path)
    bad = (rows, cols, [[c[0] + 100] if c else [] for c in cells])
    path = write(tmp_path / "g.ply", ply_bytes(pts, "binary_little_endian", grid=bad))
    with raises_naming(FileFormatError, path, "outside"):
        read_ply(path)
    twice = (rows, cols, [[0] if c else [] for c in cells])
    path = write(tmp_path / "g.ply", ply_bytes(pts, "ascii", grid=twice))
    with raises_naming(FileFormatError, path, "vertex 0"):
        read_ply(path)


# --------------------------------------------------------------------------- NPY


def test_npy_variants(tmp_path):
    pts = np.arange(30, dtype=np.float32).reshape(10, 3)
    np.save(tmp_path / "a.npy", pts)
    sp = read(tmp_path / "a.npy")
    np.testing.assert_array_equal(sp.points, pts)
    assert sp.line_ids is None and sp.points.dtype == np.float64
    np.save(tmp_path / "b.npy", np.column_stack([pts, np.arange(10) // 4]))
    np.testing.assert_array_equal(read(tmp_path / "b.npy").line_ids, np.arange(10) // 4)
    rec = np.zeros(3, dtype=[("x", "f8"), ("y", "f8"), ("z", "f4"), ("line", "i4")])
    rec["x"], rec["line"] = [1, 2, 3], [5, 5, 6]
    np.save(tmp_path / "c.npy", rec)
    sp = read(tmp_path / "c.npy")
    np.testing.assert_array_equal(sp.points[:, 0], [1, 2, 3])
    np.testing.assert_array_equal(sp.line_ids, [5, 5, 6])
    np.savez(tmp_path / "d.npz", points=pts.astype(int), line_ids=np.arange(10))
    sp = read(tmp_path / "d.npz")
    np.testing.assert_array_equal(sp.points, pts)
    assert sp.n_lines == 10


# --------------------------------------------------------------------------- VTK


def plain_vtk_points(path: Path) -> np.ndarray:
    """The POINTS block by plain Python splitting: an independent read of an ASCII VTK."""
    words = path.read_text().split()
    i = words.index("POINTS")
    n = int(words[i + 1])
    return np.array([float(w) for w in words[i + 3 : i + 3 + 3 * n]]).reshape(n, 3)


def test_fran_cut_profiles():
    path = FRAN
    sp = read(path)
    np.testing.assert_array_equal(sp.points, plain_vtk_points(path))
    # README: 2,205 points = 45 profiles x 49 points, stored profile by profile
    assert len(sp) == 2205
    lines = sp.lines()
    assert len(lines) == 45 and {len(ix) for ix in lines} == {49}
    assert [int(ix[0]) for ix in lines] == list(range(0, 2205, 49))
    # each profile is a vertical scan line: y from -0.2048 to -0.0512 in 0.0032 steps
    for ix in lines:
        np.testing.assert_allclose(sp.points[ix, 1], -0.2048 + 0.0032 * np.arange(49), atol=1e-6)
    assert "connectivity" in sp.extra["line_ids_from"]


def test_fran_cut_without_cells_gives_no_lines(tmp_path):
    """The lines come from the cells, not from knowing the file: drop them and they are gone."""
    text = FRAN.read_text()
    path = write(tmp_path / "bare.vtk", text[: text.index("POLYGONS")])
    sp = read_vtk(path)
    assert len(sp) == 2205 and sp.line_ids is None


def test_vtk_random_triangulation_is_not_a_grid(tmp_path):
    scipy_spatial = pytest.importorskip("scipy.spatial")
    rng = np.random.default_rng(2)
    pts = np.column_stack([rng.random((60, 2)), np.zeros(60)])
    tri = scipy_spatial.Delaunay(pts[:, :2]).simplices
    path = write(tmp_path / "rand.vtk", vtk_text(pts, polys=tri))
    assert read_vtk(path).line_ids is None


def vtk_text(points, lines=None, polys=None, header="POLYDATA", strips=None):
    out = [
        "# vtk DataFile Version 3.0",
        "test",
        "ASCII",
        f"DATASET {header}",
        f"POINTS {len(points)} double",
    ]
    out += [" ".join(repr(float(v)) for v in p) for p in points]
    for key, cells in (("LINES", lines), ("POLYGONS", polys), ("TRIANGLE_STRIPS", strips)):
        if cells is not None:
            out.append(f"{key} {len(cells)} {sum(len(c) + 1 for c in cells)}")
            out += [" ".join(map(str, [len(c), *c])) for c in cells]
    return "\n".join(out) + "\n"


def scan_lines(n_lines=3, per_line=4):
    pts = np.array([(i, j * 0.5, i * j) for i in range(n_lines) for j in range(per_line)], float)
    cells = [list(range(i * per_line, (i + 1) * per_line)) for i in range(n_lines)]
    return pts, cells


def test_vtk_triangle_strips_between_rows(tmp_path):
    rows, width = 5, 7
    pts = np.array([(c, r, np.sin(c + r)) for r in range(rows) for c in range(width)], float)
    strips = [
        [v for c in range(width) for v in (r * width + c, (r + 1) * width + c)]
        for r in range(rows - 1)
    ]
    sp = read_vtk(write(tmp_path / "strips.vtk", vtk_text(pts, strips=strips)))
    np.testing.assert_array_equal(sp.line_ids, np.repeat(np.arange(rows), width))
    # the same grid stored column by column, meshed with quads: the lines follow the storage
    quads = [
        [r * width + c, r * width + c + 1, (r + 1) * width + c + 1, (r + 1) * width + c]
        for r in range(rows - 1)
        for c in range(width - 1)
    ]
    order = np.arange(rows * width).reshape(rows, width).T.ravel()  # new index -> old
    new_of_old = np.argsort(order)
    shuffled = [[int(new_of_old[v]) for v in q] for q in quads]
    sp = read_vtk(write(tmp_path / "cols.vtk", vtk_text(pts[order], polys=shuffled)))
    np.testing.assert_array_equal(sp.line_ids, np.repeat(np.arange(width), rows))


def test_vtk_ascii_poly_lines(tmp_path):
    pts, cells = scan_lines()
    cells = [cells[2], cells[0], cells[1]]  # cell order decides the ids
    sp = read_vtk(write(tmp_path / "l.vtk", vtk_text(pts, lines=cells)))
    np.testing.assert_array_equal(sp.points, pts)
    np.testing.assert_array_equal(sp.line_ids, [1] * 4 + [2] * 4 + [0] * 4)
    # chained 2-point segments share points: not one cell per line, so no line ids
    segments = [[i, i + 1] for i in range(11)]
    assert read_vtk(write(tmp_path / "seg.vtk", vtk_text(pts, lines=segments))).line_ids is None
    # poly-lines that leave points out do not define lines for every point either
    assert read_vtk(write(tmp_path / "part.vtk", vtk_text(pts, lines=cells[:2]))).line_ids is None


def test_vtk_binary_unstructured_grid(tmp_path):
    pts, cells = scan_lines(4, 5)
    head = (
        b"# vtk DataFile Version 3.0\nbinary test\nBINARY\nDATASET UNSTRUCTURED_GRID\n"
        + f"POINTS {len(pts)} float\n".encode()
    )
    body = pts.astype(">f4").tobytes() + b"\n"
    flat = np.concatenate([[len(c), *c] for c in cells]).astype(">i4")
    body += f"CELLS {len(cells)} {len(flat)}\n".encode() + flat.tobytes() + b"\n"
    body += f"CELL_TYPES {len(cells)}\n".encode() + np.full(len(cells), 4, ">i4").tobytes()
    body += b"\nPOINT_DATA 20\nSCALARS s float 1\nLOOKUP_TABLE default\n" + b"\x00" * 80
    sp = read_vtk(write(tmp_path / "b.vtk", head + body))
    np.testing.assert_array_equal(sp.points, pts)
    np.testing.assert_array_equal(sp.line_ids, np.repeat(np.arange(4), 5))
    assert sp.extra["encoding"] == "binary"


def test_vtk_5_offsets_layout(tmp_path):
    pts, cells = scan_lines(2, 3)
    text = "\n".join(
        [
            "# vtk DataFile Version 5.1",
            "vtk output",
            "ASCII",
            "DATASET POLYDATA",
            "POINTS 6 float",
            " ".join(repr(float(v)) for v in pts.ravel()),
            "METADATA",
            "INFORMATION 0",
            "",
            "LINES 3 6",
            "OFFSETS vtktypeint64",
            "0 3 6",
            "CONNECTIVITY vtktypeint64",
            "3 4 5 0 1 2",
            "",
        ]
    )
    sp = read_vtk(write(tmp_path / "v5.vtk", text))
    np.testing.assert_array_equal(sp.line_ids, [1, 1, 1, 0, 0, 0])


def test_vtk_structured_grid_rows(tmp_path):
    pts = np.array([(i, j, 0.0) for j in range(3) for i in range(4)])
    text = vtk_text(pts, header="STRUCTURED_GRID").replace("POINTS", "DIMENSIONS 4 3 1\nPOINTS")
    sp = read_vtk(write(tmp_path / "sg.vtk", text))
    np.testing.assert_array_equal(sp.line_ids, np.repeat(np.arange(3), 4))
    np.testing.assert_array_equal(sp.points[sp.grid][..., 1], np.repeat([[0], [1], [2]], 4, 1))


def test_vtk_bad_input(tmp_path):
    pts, cells = scan_lines()
    good = vtk_text(pts, lines=cells)
    path = write(tmp_path / "cut.vtk", good[: good.index("LINES") - 30])
    with raises_naming(FileFormatError, path, "truncated", "POINTS"):
        read_vtk(path)
    path = write(tmp_path / "text.vtk", good.replace("0.5 ", "half ", 1))
    with raises_naming(FileFormatError, path, "line 7", "'half'"):
        read_vtk(path)
    path = write(tmp_path / "nan.vtk", good.replace("0.5 ", "nan ", 1))
    with raises_naming(FileFormatError, path, "point 1", "non-finite"):
        read_vtk(path)
    path = write(tmp_path / "short.vtk", good.replace("POINTS 12", "POINTS 13"))
    with raises_naming(FileFormatError, path, "'LINES'"):
        read_vtk(path)
    path = write(tmp_path / "cellref.vtk", vtk_text(pts, lines=[[0, 1, 99]]))
    with raises_naming(FileFormatError, path, "point 99"):
        read_vtk(path)
    path = write(tmp_path / "grid.vtk", good.replace("POLYDATA", "STRUCTURED_POINTS"))
    with raises_naming(FileFormatError, path, "STRUCTURED_POINTS"):
        read_vtk(path)
    path = write(tmp_path / "xml.vtk", '<?xml version="1.0"?>\n<VTKFile type="PolyData">\n')
    with raises_naming(FileFormatError, path, "XML"):
        read_vtk(path)
    head = b"# vtk DataFile Version 3.0\nx\nBINARY\nDATASET POLYDATA\nPOINTS 10 float\n"
    path = write(tmp_path / "bincut.vtk", head + b"\x3f" * 50)
    with raises_naming(FileFormatError, path, "truncated", "120 bytes"):
        read_vtk(path)


# --------------------------------------------------------------------------- USGS DEM


def test_sainte_helens_dem():
    path = DEM
    sp = read(path)
    # README: 327 south->north profiles of 8 to 464 points, 148,885 points, heights 682-2,543 m
    assert len(sp) == 148_885
    lines = sp.lines()
    assert len(lines) == 327
    sizes = [len(ix) for ix in lines]
    assert min(sizes) == 8 and max(sizes) == 464
    assert sp.points[:, 2].min() == pytest.approx(682)
    assert sp.points[:, 2].max() == pytest.approx(2543)
    for ix in lines:
        xy = sp.points[ix, :2]
        assert np.ptp(xy[:, 0]) == 0  # one profile, one easting
        np.testing.assert_allclose(np.diff(xy[:, 1]), 30.0)  # 30 m spacing, south -> north
    x0 = [sp.points[ix[0], 0] for ix in lines]
    np.testing.assert_allclose(np.diff(x0), 30.0)  # profiles 30 m apart, west -> east
    # the first profile's origin as written in its B record (bytes 25-72, Fortran D reals)
    raw = path.read_bytes()[1024 + 24 : 1024 + 72].replace(b"D", b"E")
    assert tuple(sp.points[lines[0][0], :2]) == (float(raw[:24]), float(raw[24:]))
    assert sp.extra["elevation_units"] == "metres" and sp.extra["zone"] == 10


def test_dem_voids_are_skipped(tmp_path):
    data = bytearray(DEM.read_bytes())
    # profile 2 starts at byte 2048; its first three elevations follow the 144-byte header
    first = data[2048 + 144 : 2048 + 162]
    assert first.split()[0].decode().isdigit()
    data[2048 + 144 : 2048 + 162] = b"-32767" * 3
    sp = read_dem(write(tmp_path / "void.dem", bytes(data)))
    assert len(sp) == 148_885 - 3
    second = sp.lines()[1]
    ref = read_dem(DEM).lines()[1]
    assert len(second) == len(ref) - 3
    np.testing.assert_array_equal(sp.points[second], read_dem(DEM).points[ref[3:]])


def test_dem_bad_input(tmp_path):
    data = DEM.read_bytes()
    path = write(tmp_path / "cut.dem", data[:50_000])
    with raises_naming(FileFormatError, path, "truncated"):
        read_dem(path)
    path = write(tmp_path / "short.dem", data[:500])
    with raises_naming(FileFormatError, path, "1024"):
        read_dem(path)
    bad = bytearray(data)
    bad[816:828] = b"thirty metre"
    path = write(tmp_path / "res.dem", bytes(bad))
    with raises_naming(FileFormatError, path, "resolution", "817-828"):
        read_dem(path)
    bad = bytearray(data)
    bad[1024 + 144 : 1024 + 150] = b"  12x4"
    path = write(tmp_path / "elev.dem", bytes(bad))
    with raises_naming(FileFormatError, path, "profile 1", "12x4"):
        read_dem(path)


# --------------------------------------------------------------------------- LAS / LAZ


def las_reference(path):
    laspy_ = pytest.importorskip("laspy")
    las = laspy_.read(path)
    xyz = np.column_stack([las.x, las.y, las.z]).astype(float)
    return las, xyz


def test_autzen_all_returns():
    path = LAZ
    las, xyz = las_reference(path)
    sp = read_las(path, returns="all")
    np.testing.assert_array_equal(sp.points, xyz)
    # README: 110,000 points, scan_direction_flag flips 680 times = 681 sweeps, median 151
    assert len(sp) == 110_000
    lines = sp.lines()
    assert len(lines) == 681
    assert np.median([len(ix) for ix in lines]) == 151
    for ix in lines[:50]:
        assert len(np.unique(np.asarray(las.scan_direction_flag)[ix])) == 1


def test_autzen_first_returns_and_ground():
    path = LAZ
    las, xyz = las_reference(path)
    first = np.asarray(las.return_number) == 1
    sp = read(path)  # first returns by default
    np.testing.assert_array_equal(sp.points, xyz[first])
    # every sweep ids a contiguous run of the file: first returns keep their sweep's id
    full = read_las(path, returns="all")
    np.testing.assert_array_equal(sp.line_ids, full.line_ids[first])
    flag = np.asarray(las.scan_direction_flag).astype(int)
    sweep = np.concatenate([[0], np.cumsum(np.diff(flag) != 0)])  # README: 681 sweeps
    assert sweep[-1] + 1 == 681
    assert len(sp) == int(first.sum())
    assert sp.n_lines == len(np.unique(sweep[first]))
    ground = np.asarray(las.classification) == 2
    gp = read_las(path, returns="all", classes=2)
    np.testing.assert_array_equal(gp.points, xyz[ground])
    np.testing.assert_array_equal(gp.line_ids, full.line_ids[ground])
    assert np.all(np.diff(gp.line_ids) >= 0)


def test_synthetic_las_sweeps(tmp_path):
    laspy_ = pytest.importorskip("laspy")
    header = laspy_.LasHeader(point_format=1, version="1.2")
    header.scales = [0.001, 0.001, 0.001]
    las = laspy_.LasData(header)
    n = 12
    las.x = np.arange(n) * 1.0
    las.y = np.zeros(n)
    las.z = np.arange(n) * 0.5
    las.scan_direction_flag = np.array([1, 1, 1, 0, 0, 1, 1, 1, 1, 0, 0, 0], dtype=np.uint8)
    las.return_number = np.array([1, 2, 1, 1, 1, 1, 1, 2, 1, 1, 1, 1], dtype=np.uint8)
    las.number_of_returns = np.full(n, 2, dtype=np.uint8)
    path = tmp_path / "s.las"
    las.write(path)
    sp = read(path, returns="all")
    np.testing.assert_array_equal(sp.line_ids, [0, 0, 0, 1, 1, 2, 2, 2, 2, 3, 3, 3])
    np.testing.assert_allclose(sp.points[:, 2], np.arange(n) * 0.5)
    first = read(path)
    np.testing.assert_array_equal(first.line_ids, [0, 0, 1, 1, 2, 2, 2, 3, 3, 3])
    las.scan_direction_flag = np.zeros(n, dtype=np.uint8)
    las.write(path)
    assert read(path, returns="all").line_ids is None


def test_las_bad_input(tmp_path, monkeypatch):
    pytest.importorskip("laspy")
    data = LAZ.read_bytes()
    path = write(tmp_path / "cut.laz", data[:200_000])
    with raises_naming(FileFormatError, path):
        read_las(path)
    path = write(tmp_path / "head.las", data[:100])
    with raises_naming(FileFormatError, path):
        read(path)
    with pytest.raises(scanmesh.ParameterError, match="returns"):
        read_las(LAZ, returns="second")


def test_las_without_laspy_says_how_to_install(tmp_path, monkeypatch):
    monkeypatch.setitem(sys.modules, "laspy", None)  # import laspy now raises ImportError
    path = write(tmp_path / "x.laz", b"LASF")
    with raises_naming(scanmesh.MissingExtraError, path, 'pip install "scanmesh[las]"'):
        read(path)
