"""Readers: every format on the real files in tests/data, synthetic variants, and bad input.

Expectations come from tests/data/ATTRIBUTION.md and from independent reads (trimesh, laspy, a
plain-Python parse), never from the reader under test.
"""

from __future__ import annotations

import random
import struct
import sys
from pathlib import Path

import numpy as np
import pytest
import trimesh

import scanmesh
from conftest import DATA
from scanmesh import FileFormatError, ScanmeshError
from scanmesh.readers import (
    ScanPoints,
    read,
    read_csv,
    read_dem,
    read_las,
    read_npy,
    read_ply,
    read_vtk,
    read_xyz,
)

FRAN = DATA / "scans" / "fran_cut.vtk"
DEM = DATA / "terrain" / "SainteHelens.dem"
LAZ = DATA / "lidar" / "autzen_trim.laz"


def write(path: Path, text: str | bytes) -> Path:
    path.write_bytes(text.encode() if isinstance(text, str) else text)
    return path


def raises_naming(exc_type, path: Path, *fragments: str):
    """Context: the call raises exc_type whose message names the file and every fragment."""

    class _Check:
        def __enter__(self):
            self.ctx = pytest.raises(exc_type)
            self.info = self.ctx.__enter__()
            return self.info

        def __exit__(self, *exc):
            handled = self.ctx.__exit__(*exc)
            message = str(self.info.value)
            assert path.name in message, message
            for fragment in fragments:
                assert fragment in message, f"{fragment!r} not in {message!r}"
            return handled

    return _Check()


# --------------------------------------------------------------------------- error cases first


@pytest.mark.parametrize("name", ["e.xyz", "e.csv", "e.ply", "e.vtk", "e.dem", "e.npy"])
def test_empty_file_is_a_file_format_error(tmp_path, name):
    path = write(tmp_path / name, b"")
    with raises_naming(FileFormatError, path):
        read(path)


@pytest.mark.parametrize("name", ["blank.xyz", "blank.csv"])
def test_whitespace_only_text_is_empty(tmp_path, name):
    path = write(tmp_path / name, "\n  \n\t\n")
    with raises_naming(FileFormatError, path, "empty"):
        read(path)


def test_binary_junk_names_the_line(tmp_path):
    junk = random.Random(0).randbytes(4000)
    path = write(tmp_path / "junk.xyz", b"1 2 3\n4 5 6\n" + junk)
    with raises_naming(FileFormatError, path, "line "):
        read_xyz(path)


@pytest.mark.parametrize(
    "name",
    [
        "junk.xyz",
        "junk.csv",
        "junk.ply",
        "junk.vtk",
        "junk.dem",
        "junk.npy",
        "junk.npz",
        "junk.las",
        "junk.laz",
    ],
)
def test_binary_junk_in_every_format(tmp_path, name):
    path = write(tmp_path / name, random.Random(1).randbytes(5000))
    with raises_naming(FileFormatError, path):
        read(path)


def test_wrong_column_count_names_line_and_text(tmp_path):
    path = write(tmp_path / "cols.xyz", "1 2 3\n4 5 6\n7 8\n9 10 11\n")
    with raises_naming(FileFormatError, path, "line 3", "'7 8'", "found 2"):
        read_xyz(path)


def test_too_many_columns_without_header(tmp_path):
    path = write(tmp_path / "five.xyz", "1 2 3 4 5\n6 7 8 9 10\n")
    with raises_naming(FileFormatError, path, "line 1", "found 5"):
        read_xyz(path)


def test_text_in_a_numeric_column(tmp_path):
    path = write(tmp_path / "text.xyz", "1 2 3\n4 abc 6\n7 8 9\n")
    with raises_naming(FileFormatError, path, "line 2", "'abc'"):
        read_xyz(path)


def test_text_after_many_good_lines_is_found(tmp_path):
    rows = [f"{i} {i + 1} {i + 2}" for i in range(50_000)]
    rows[41_234] = "1 2 3x"
    path = write(tmp_path / "late.xyz", "\n".join(rows))
    with raises_naming(FileFormatError, path, "line 41235", "'3x'"):
        read_xyz(path)


@pytest.mark.parametrize("bad", ["nan", "inf", "-inf", "NaN"])
def test_non_finite_values_are_refused(tmp_path, bad):
    path = write(tmp_path / "nan.xyz", f"1 2 3\n4 5 6\n7 {bad} 9\n")
    with raises_naming(FileFormatError, path, "line 3", "non-finite y"):
        read_xyz(path)


def test_fractional_line_id(tmp_path):
    path = write(tmp_path / "ids.xyz", "x y z line\n1 2 3 0\n4 5 6 0.5\n")
    with raises_naming(FileFormatError, path, "line 3", "0.5"):
        read_xyz(path)


def test_line_id_too_large_for_exact_reading(tmp_path):
    path = write(tmp_path / "big.xyz", "1 2 3 0\n4 5 6 9007199254740993\n")
    with raises_naming(FileFormatError, path, "line 2", "below 2**53"):
        read_xyz(path, columns="x,y,z,line")
    path = write(tmp_path / "big.xyz", "x y z line\n1 2 3 0\n4 5 6 9007199254740993\n")
    with raises_naming(FileFormatError, path, "line 3", "below 2**53"):
        read_xyz(path)


def test_csv_empty_field(tmp_path):
    path = write(tmp_path / "gap.csv", "x,y,z\n1,2,3\n4,,6,7\n")
    with raises_naming(FileFormatError, path, "line 3", "'4,,6,7'"):
        read_csv(path)


def test_csv_header_without_xyz(tmp_path):
    path = write(tmp_path / "names.csv", "a,b,c\n1,2,3\n")
    with raises_naming(FileFormatError, path, "line 1", "x, y and z"):
        read_csv(path)
    path = write(tmp_path / "names.csv", "a,b,c\n# units: mm\n\n1,2,3\n")
    with raises_naming(FileFormatError, path, "line 1", "'a,b,c'", "line 4"):
        read_csv(path)


def test_zero_points(tmp_path):
    path = write(
        tmp_path / "z.ply",
        "ply\nformat ascii 1.0\nelement vertex 0\n"
        "property float x\nproperty float y\nproperty float z\nend_header\n",
    )
    with raises_naming(FileFormatError, path, "no vertices"):
        read(path)
    np.save(tmp_path / "z.npy", np.zeros((0, 3)))
    with raises_naming(FileFormatError, tmp_path / "z.npy", "no points"):
        read(tmp_path / "z.npy")
    path = write(
        tmp_path / "z.vtk",
        "# vtk DataFile Version 3.0\nt\nASCII\nDATASET POLYDATA\nPOINTS 0 float\n",
    )
    with raises_naming(FileFormatError, path, "line 5", "0 points"):
        read(path)


def test_header_only(tmp_path):
    path = write(tmp_path / "head.csv", "x,y,z\n")
    with raises_naming(FileFormatError, path, "no numeric data"):
        read_csv(path)


def test_prose_is_not_points(tmp_path):
    path = write(tmp_path / "prose.txt", "this is\nnot a point cloud\n" * 80)
    with raises_naming(FileFormatError, path, "no numeric data"):
        read_xyz(path)


def test_missing_file_and_unknown_ending(tmp_path):
    with raises_naming(FileFormatError, tmp_path / "nope.xyz", "cannot read"):
        read(tmp_path / "nope.xyz")
    path = write(tmp_path / "points.foo", "1 2 3\n")
    with raises_naming(FileFormatError, path, "'.foo'"):
        read(path)


def test_npy_holding_objects(tmp_path):
    path = tmp_path / "obj.npy"
    np.save(path, np.array([[1.0, 2.0, 3.0], "x"], dtype=object), allow_pickle=True)
    with raises_naming(FileFormatError, path, "objects"):
        read_npy(path)


@pytest.mark.parametrize(
    ("array", "fragment"),
    [
        (np.zeros((5, 2)), "(5, 2)"),
        (np.zeros(6), "(6,)"),
        (np.array([["1", "2", "3"]]), "dtype"),
        (np.zeros((4, 3), dtype=complex), "complex"),
        (np.array([[1.0, 2.0, 3.0], [np.inf, 0, 0]]), "row 1"),
        (np.array([[1.0, 2.0, 3.0, 0.5]]), "line id 0.5"),
    ],
)
def test_npy_bad_arrays(tmp_path, array, fragment):
    path = tmp_path / "bad.npy"
    np.save(path, array)
    with raises_naming(FileFormatError, path, fragment):
        read_npy(path)


def test_npz_line_ids_that_do_not_match_the_points(tmp_path):
    path = tmp_path / "mismatch.npz"
    np.savez(path, points=np.zeros((10, 3)), line_ids=np.zeros(9, dtype=int))
    with raises_naming(FileFormatError, path, "10 points", "(9,)"):
        read_npy(path)
    np.savez(path, coords=np.zeros((10, 3)))
    with raises_naming(FileFormatError, path, "'points'"):
        read_npy(path)


def test_truncated_npy(tmp_path):
    path = tmp_path / "cut.npy"
    np.save(path, np.arange(300.0).reshape(100, 3))
    path.write_bytes(path.read_bytes()[:500])
    with raises_naming(FileFormatError, path):
        read_npy(path)


def test_scan_points_refuses_mismatched_line_ids():
    with pytest.raises(ScanmeshError, match=r"3 line ids do not match 4 points"):
        ScanPoints(np.zeros((4, 3)), np.zeros(3, dtype=int), Path("x.xyz"))
    with pytest.raises(ScanmeshError, match="x.xyz"):
        ScanPoints(np.array([[0.0, 0.0, np.nan]]), None, Path("x.xyz"))


# --------------------------------------------------------------------------- XYZ / CSV


def test_xyz_plain_and_blank_line_blocks(tmp_path):
    text = "# scanned 2026\nX Y Z\n\n1 2 3\n4 5 6\n\n\n7 8 9\n  \n10 11 12\n13 14 15\n\n"
    sp = read_xyz(write(tmp_path / "blocks.xyz", text))
    np.testing.assert_array_equal(sp.points, np.arange(1, 16, dtype=float).reshape(5, 3))
    np.testing.assert_array_equal(sp.line_ids, [0, 0, 1, 2, 2])
    assert [ix.tolist() for ix in sp.lines()] == [[0, 1], [2], [3, 4]]
    assert sp.source == tmp_path / "blocks.xyz"


def test_xyz_without_blank_lines_has_no_line_ids(tmp_path):
    sp = read_xyz(write(tmp_path / "p.xyz", "\n\n1 2 3\n4 5 6\n"))
    assert sp.line_ids is None and len(sp) == 2 and sp.n_lines == 0


def test_xyz_fourth_column_and_comma_and_crlf(tmp_path):
    text = "x, y, z, line\r\n1.5, -2, 3e2, 7\r\n# a comment\r\n4, 5, 6, 7\r\n0.25,1,1,3\r\n"
    sp = read(write(tmp_path / "c.txt", text))
    np.testing.assert_array_equal(sp.points, [[1.5, -2, 300], [4, 5, 6], [0.25, 1, 1]])
    np.testing.assert_array_equal(sp.line_ids, [7, 7, 3])
    assert sp.line_ids.dtype == np.int64 and sp.points.dtype == np.float64
    assert [ix.tolist() for ix in sp.lines()] == [[0, 1], [2]]


def test_xyz_named_columns_in_any_order(tmp_path):
    text = "intensity z y x line\n9 3 2 1 0\n8 6 5 4 1\n"
    sp = read(write(tmp_path / "named.asc", text))
    np.testing.assert_array_equal(sp.points, [[1, 2, 3], [4, 5, 6]])
    np.testing.assert_array_equal(sp.line_ids, [0, 1])


def test_csv_with_and_without_header(tmp_path):
    rng = np.random.default_rng(3)
    pts = rng.normal(size=(500, 3)) * 100
    ids = np.repeat(np.arange(50), 10)
    body = "\n".join(
        f"{a!r},{b!r},{c!r},{i}" for (a, b, c), i in zip(pts.tolist(), ids, strict=True)
    )
    for header in ("", "X,Y,Z,Scan_Line\n", "z,y,x,line\n"):
        sp = read_csv(write(tmp_path / "p.csv", header + body))
        expect = pts[:, ::-1] if header.startswith("z") else pts
        np.testing.assert_array_equal(sp.points, expect)
        np.testing.assert_array_equal(sp.line_ids, ids)


def test_csv_named_extra_columns_are_ignored(tmp_path):
    sp = read_csv(write(tmp_path / "extra.csv", "id,x,y,z,red\n0,1,2,3,255\n1,4,5,6,0\n"))
    np.testing.assert_array_equal(sp.points, [[1, 2, 3], [4, 5, 6]])
    assert sp.line_ids is None


def test_text_across_chunks_matches_a_plain_parse(tmp_path, monkeypatch):
    """Small chunks force every chunk boundary case; the plain-Python parse is the truth."""
    from scanmesh.formats import table

    rng = np.random.default_rng(7)
    lines, expect_pts, expect_ids, block = [], [], [], 0
    for _ in range(3000):
        if rng.random() < 0.05 and expect_pts:
            lines.extend([""] * int(rng.integers(1, 3)))
            block += 1
        if rng.random() < 0.02:
            lines.append("# note")
        p = rng.normal(size=3).round(int(rng.integers(0, 9))) * 10.0 ** int(rng.integers(-3, 6))
        lines.append("  ".join(repr(float(v)) for v in p))
        expect_pts.append(p)
        expect_ids.append(block)
    path = write(tmp_path / "chunks.xyz", "\n".join(lines) + "\n")
    monkeypatch.setattr(table, "CHUNK_BYTES", 997)
    sp = read_xyz(path)
    np.testing.assert_array_equal(sp.points, np.array(expect_pts))
    np.testing.assert_array_equal(sp.line_ids, expect_ids)


def test_blocks_and_row_lines_at_every_chunk_boundary(tmp_path, monkeypatch):
    """Every chunk size, so a chunk can end on blank lines that open the next chunk's first
    block: the blank-line line ids and the line named for a bad row do not change."""
    from scanmesh.formats import table

    text = "x y z\n1 0 0\n2 0 0\n\n3 0 0\n\n\n4 0 0\n# c\n\n5 0 0\n6 0 0\n\n"
    good = write(tmp_path / "good.xyz", text)
    bad = write(tmp_path / "bad.xyz", text.replace("5 0 0", "5 0 nan"))
    for chunk in range(1, len(text) + 2):
        monkeypatch.setattr(table, "CHUNK_BYTES", chunk)
        sp = read_xyz(good)
        assert sp.line_ids.tolist() == [0, 0, 1, 2, 3, 3], chunk
        assert sp.points[:, 0].tolist() == [1, 2, 3, 4, 5, 6], chunk
        with raises_naming(FileFormatError, bad, "line 11", "non-finite z"):
            read_xyz(bad)


def random_table_text(rng, comma: bool, ncols: int = 4, rows: int = 400) -> bytes:
    """Rows of ncols numbers in many spellings, with comments, blank and CRLF lines."""
    spell = [
        lambda v: repr(v),
        lambda v: f"{v:.3e}",
        lambda v: f"{v:+.2f}",
        lambda v: f"{v:E}",
        lambda v: str(int(v)),
        lambda v: f"{v:.17g}",
        lambda v: f"{abs(v):.4f}".lstrip("0") or "0",
    ]
    lines = []
    for _ in range(rows):
        r = rng.random()
        if r < 0.05:
            lines.append(rng.choice(["", "   ", "\t", "\r"]))
        elif r < 0.08:
            lines.append(rng.choice(["# note", "  #x, y, z", "#"]))
        else:
            scale = 10.0 ** int(rng.integers(-5, 8))
            vals = [
                spell[int(rng.integers(len(spell)))](float(v))
                for v in rng.normal(size=ncols) * scale
            ]
            sep = rng.choice([",", ", ", " ,"]) if comma else rng.choice([" ", "\t", "   "])
            lines.append(sep.join(vals) + rng.choice(["", " ", "\r"]))
    return ("\n".join(lines) + rng.choice(["", "\n"])).encode()


@pytest.mark.parametrize("comma", [False, True])
def test_native_chunk_parser_matches_the_numpy_reference(comma):
    """_core.parse_text_table and the numpy reference give the same table, bit for bit."""
    from numpy_text_reference import numpy_chunk
    from scanmesh import _core

    rng = np.random.default_rng(11)
    for _ in range(20):
        data = random_table_text(rng, comma)
        native = _core.parse_text_table(data, 0, len(data), 4, "," if comma else None)
        assert native[4] is None
        ref = numpy_chunk(Path("t"), data, 0, len(data), 4, comma, 1, 1)
        np.testing.assert_array_equal(native[0], ref[0])
        np.testing.assert_array_equal(native[1], ref[1])
        np.testing.assert_array_equal(native[2], ref[2])
        assert native[3] == ref[3]
        # any range of whole lines parses alone like the whole
        cut = data.find(b"\n", len(data) // 2) + 1
        if 0 < cut < len(data):
            head = _core.parse_text_table(data, 0, cut, 4, "," if comma else None)
            tail = _core.parse_text_table(data, cut, len(data), 4, "," if comma else None)
            np.testing.assert_array_equal(np.concatenate([head[0], tail[0]]), native[0])


@pytest.mark.parametrize(
    ("line", "comma"),
    [
        ("1 2 x 4", False),
        ("1 2 3", False),
        ("1 2 3 4 5", False),
        ("1 2 3 4e", False),
        ("1,2,,3,4", True),
        (",,,", True),
        ("1;2;3;4", False),
        ("0x1 2 3 4", False),
    ],
)
def test_native_chunk_parser_refuses_what_the_reference_refuses(line, comma):
    """The native parser refuses the line the reference refuses, at the same place: the
    start of the first token that is not a number, or of the line with a wrong count."""
    from numpy_text_reference import numpy_chunk
    from scanmesh import _core

    sep = "," if comma else " "
    data = f"1{sep}2{sep}3{sep}4\n{line}\n".encode()
    *_, problem = _core.parse_text_table(data, 0, len(data), 4, "," if comma else None)
    with pytest.raises(FileFormatError, match=r"t, line 2:") as info:
        numpy_chunk(Path("t"), data, 0, len(data), 4, comma, 1, 1)
    assert problem is not None and problem[0] == 1
    line_start = len(data.split(b"\n")[0]) + 1
    if problem[2] == "number" and "is not a number" in str(info.value):
        bad = data[problem[1] :].split(b"\n")[0].replace(b",", b" ").split()[0]
        assert repr(bad.decode()) in str(info.value)  # the token the reference names
    else:  # both refuse the line; which rule trips first may differ ('1;2;3;4')
        assert line_start <= problem[1] < len(data)


def test_native_chunk_parser_checks_its_range():
    from scanmesh import _core

    for args in ((b"1 2", 2, 1, 1), (b"1 2", 0, 9, 1)):
        with pytest.raises(ScanmeshError, match="start"):
            _core.parse_text_table(*args)
    for delimiter in ("#", ".", "x", " "):
        with pytest.raises(ScanmeshError, match="delimiter"):
            _core.parse_text_table(b"1 2", 0, 3, 1, delimiter)


def test_read_reports_progress_in_bytes(tmp_path, monkeypatch):
    from scanmesh.formats import table

    rows = "\n".join(f"{i} {i % 7} {i * 0.5} {i // 100}" for i in range(2000))
    path = write(tmp_path / "p.xyz", "x y z line\n" + rows + "\n")
    monkeypatch.setattr(table, "CHUNK_BYTES", 4096)
    seen = []
    sp = read(path, progress=lambda done, total, value, stage: seen.append((stage, done, total)))
    assert len(sp) == 2000
    size = path.stat().st_size
    assert {s for s, _, _ in seen} == {"read"} and all(t == size for _, _, t in seen)
    done = [d for _, d, _ in seen]
    assert done == sorted(done) and done[-1] == size and len(done) > 5
    # a callback without stage= is the annealing-only convention: not called while reading
    calls = []
    read(path, progress=lambda done, total, energy: calls.append(done))
    assert calls == []


@pytest.mark.parametrize("chunk", [1000, 1 << 24])
def test_parse_error_line_numbers_after_header_comments_and_chunks(tmp_path, monkeypatch, chunk):
    from scanmesh.formats import table

    rows = ["1.5 2 3"] * 3000
    rows[10] = "# a comment, with words"
    rows[2500] = "4 5 6e"
    rows[2600] = "7 8 9"
    path = write(tmp_path / "late.xyz", "title line\nx y z\n" + "\n".join(rows) + "\n")
    monkeypatch.setattr(table, "CHUNK_BYTES", chunk)
    with raises_naming(FileFormatError, path, "line 2503", "'6e'"):
        read_xyz(path)
    rows[2500] = "4 5 nan"
    path = write(tmp_path / "late.xyz", "title line\nx y z\n" + "\n".join(rows) + "\n")
    with raises_naming(FileFormatError, path, "line 2503", "non-finite z", "'4 5 nan'"):
        read_xyz(path)


def test_text_error_line_numbers_across_chunks(tmp_path, monkeypatch):
    from scanmesh.formats import table

    rows = ["1 2 3"] * 2000
    rows[1500] = "1 2 3 4"
    path = write(tmp_path / "late.xyz", "x y z\n" + "\n".join(rows))
    monkeypatch.setattr(table, "CHUNK_BYTES", 1000)
    with raises_naming(FileFormatError, path, "line 1502", "'1 2 3 4'"):
        read_xyz(path)


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


# --------------------------------------------------------------------------- dispatch


def test_read_is_exported_and_dispatches_case_insensitively(tmp_path):
    assert scanmesh.read is read and scanmesh.ScanPoints is ScanPoints
    sp = scanmesh.read(write(tmp_path / "UP.XYZ", "1 2 3\n"))
    assert sp.extra["format"] == "xyz" and len(sp) == 1
    assert "UP.XYZ" in repr(sp)


def test_dem_declared_counts_are_checked_against_the_size(tmp_path):
    data = bytearray(DEM.read_bytes())
    profiles = bytearray(data)
    profiles[858:864] = b"999999"  # the A record's number of profiles
    with raises_naming(FileFormatError, tmp_path / "p.dem", "999,999 profiles"):
        read_dem(write(tmp_path / "p.dem", bytes(profiles)))
    elevations = bytearray(data)
    elevations[1024 + 12 : 1024 + 18] = b"999999"  # profile 1's number of elevations
    with raises_naming(FileFormatError, tmp_path / "e.dem", "999,999 elevations in profile 1"):
        read_dem(write(tmp_path / "e.dem", bytes(elevations)))
