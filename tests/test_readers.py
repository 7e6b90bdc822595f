"""Readers: every format on the real files in tests/data, synthetic variants, and bad input.

Expectations come from tests/data/ATTRIBUTION.md and from independent reads (trimesh, laspy, a
plain-Python parse), never from the reader under test.
"""

from __future__ import annotations

import random
from pathlib import Path

import numpy as np
import pytest

import scanmesh
from conftest import DATA
from scanmesh import FileFormatError, ScanmeshError
from scanmesh.formats import (
    ScanPoints,
    read,
    read_csv,
    read_dem,
    read_npy,
    read_xyz,
)

DEM = DATA / "terrain" / "SainteHelens.dem"


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
        assert native.problem is None
        ref = numpy_chunk(Path("t"), data, 0, len(data), 4, comma, 1, 1)
        np.testing.assert_array_equal(native.values, ref[0])
        np.testing.assert_array_equal(native.row_lines, ref[1])
        np.testing.assert_array_equal(native.blank_lines, ref[2])
        assert native.n_lines == ref[3]
        # any range of whole lines parses alone like the whole
        cut = data.find(b"\n", len(data) // 2) + 1
        if 0 < cut < len(data):
            head = _core.parse_text_table(data, 0, cut, 4, "," if comma else None)
            tail = _core.parse_text_table(data, cut, len(data), 4, "," if comma else None)
            np.testing.assert_array_equal(np.concatenate([head.values, tail.values]), native.values)


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
    problem = _core.parse_text_table(data, 0, len(data), 4, "," if comma else None).problem
    with pytest.raises(FileFormatError, match=r"t, line 2:") as info:
        numpy_chunk(Path("t"), data, 0, len(data), 4, comma, 1, 1)
    assert problem is not None and problem.line == 1
    line_start = len(data.split(b"\n")[0]) + 1
    if problem.kind == "number" and "is not a number" in str(info.value):
        bad = data[problem.offset :].split(b"\n")[0].replace(b",", b" ").split()[0]
        assert repr(bad.decode()) in str(info.value)  # the token the reference names
    else:  # both refuse the line; which rule trips first may differ ('1;2;3;4')
        assert line_start <= problem.offset < len(data)


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
