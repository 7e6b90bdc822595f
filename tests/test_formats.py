"""File formats: the reading bound (regular files, declared counts against the file size,
memory that follows the bytes), the table by ending and content, and odd but valid files.

Peak memory is checked in a child process whose address space is capped a little above
what it already uses: a reader that allocated what a file declares or implies would fail
there with MemoryError instead of the clear FileFormatError (or the result) asserted.
"""

from __future__ import annotations

import math
import os
import struct
import subprocess
import sys
import textwrap
import zipfile
from pathlib import Path

import numpy as np
import pytest

import scanmesh
from conftest import cyberware_range_grid
from scanmesh import FileFormatError, ParameterError
from scanmesh.formats import format_of, read
from scanmesh.formats.write import write_points


def write(path: Path, data: str | bytes) -> Path:
    path.write_bytes(data.encode() if isinstance(data, str) else data)
    return path


def read_capped(path: Path, extra_bytes: int) -> str:
    """In a child limited to its current address space plus ``extra_bytes`` (beyond the
    file's own bytes, which reading holds once), read ``path``; return what happened: the
    number of points, or the exception's class and message."""
    script = f"""
    import resource
    import numpy as np
    import scanmesh
    from scanmesh import _core
    _core.parse_text_table(b"1 2 3\\n" * 100000, 0, 600000, 3)  # start the thread pool
    with open("/proc/self/status") as f:
        vm = next(int(l.split()[1]) * 1024 for l in f if l.startswith("VmSize"))
    limit = vm + {os.path.getsize(path)} + {extra_bytes}
    resource.setrlimit(resource.RLIMIT_AS, (limit, limit))
    try:
        print("points", len(scanmesh.read({str(path)!r})))
    except Exception as exc:
        print(type(exc).__name__, exc)
    """
    out = subprocess.run(
        [sys.executable, "-c", textwrap.dedent(script)], capture_output=True, text=True
    )
    assert out.returncode == 0, out.stderr
    return out.stdout.strip()


# --------------------------------------------------------------------------- the bound


def test_a_huge_first_row_over_blank_lines_is_refused_in_little_memory(tmp_path):
    # 100,000 values on line 1, then 100,000 blank lines: the old reader sized its table
    # by lines x columns (74.5 GiB)
    path = write(tmp_path / "wide.xyz", " ".join(["1"] * 100_000) + "\n" * 100_000)
    got = read_capped(path, 64 << 20)
    assert got.startswith("FileFormatError") and "found 100000" in got, got


@pytest.mark.slow
def test_rows_over_many_empty_lines_allocate_by_what_was_read(tmp_path):
    # three points, then 2**27 empty lines, then one more: 4 GiB by the line count before
    path = tmp_path / "sparse.xyz"
    with open(path, "wb") as handle:
        handle.write(b"0 0 0\n1 0 0\n0 1 0\n")
        handle.write(b"\n" * 2**27)
        handle.write(b"1 1 1\n")
    got = read_capped(path, 96 << 20)
    assert got == "points 4", got
    sp = read(path)
    np.testing.assert_array_equal(sp.line_ids, [0, 0, 0, 1])  # the blank lines split
    path.unlink()


@pytest.mark.parametrize("target", ["/dev/zero", "/dev/null"])
def test_a_device_is_refused_before_reading(tmp_path, target):
    link = tmp_path / "points.xyz"
    link.symlink_to(target)
    with pytest.raises(FileFormatError, match="points.xyz.*device"):
        read(link)
    with pytest.raises(FileFormatError, match="directory"):
        read(tmp_path)


def test_a_fifo_is_read_as_it_comes(tmp_path):
    fifo = tmp_path / "pipe.xyz"
    os.mkfifo(fifo)
    writer = subprocess.Popen(
        [sys.executable, "-c", f"open({str(fifo)!r}, 'w').write('0 0 0\\n1 0 0\\n0 1 0\\n')"]
    )
    sp = read(fifo)
    writer.wait(timeout=30)
    assert len(sp) == 3


def las_bytes(tmp_path: Path) -> bytes:
    laspy = pytest.importorskip("laspy")
    header = laspy.LasHeader(point_format=1, version="1.2")
    las = laspy.LasData(header)
    n = 2000
    las.x, las.y, las.z = np.arange(n) * 0.5, np.arange(n) % 7 * 1.0, np.zeros(n)
    las.return_number = np.ones(n, dtype=np.uint8)
    path = tmp_path / "ok.las"
    las.write(path)
    return path.read_bytes()


@pytest.mark.slow
def test_las_declaring_millions_of_vlrs_or_points_is_refused_at_once(tmp_path):
    data = bytearray(las_bytes(tmp_path))
    assert len(read(write(tmp_path / "ok.las", bytes(data)))) == 2000
    bad = bytearray(data)
    struct.pack_into("<I", bad, 100, 16_000_000)  # number of VLRs: one flipped byte
    path = write(tmp_path / "vlrs.las", bytes(bad))
    with pytest.raises(FileFormatError, match=r"vlrs.las.*16,000,000 variable-length records"):
        read(path)
    assert read_capped(path, 32 << 20).startswith("FileFormatError")
    bad = bytearray(data)
    struct.pack_into("<I", bad, 107, 2_000_000_000)  # legacy point count
    with pytest.raises(FileFormatError, match="2,000,000,000 points"):
        read(write(tmp_path / "points.las", bytes(bad)))


def test_las_filters(tmp_path):
    laspy = pytest.importorskip("laspy")
    las = laspy.LasData(laspy.LasHeader(point_format=1, version="1.2"))
    n = 12
    las.x, las.y, las.z = np.arange(n) * 1.0, np.arange(n) % 3 * 1.0, np.arange(n) * 0.1
    las.return_number = np.array([1, 2, 1, 1, 2, 3, 1, 1, 2, 1, 1, 1], dtype=np.uint8)
    las.number_of_returns = np.array([2, 2, 1, 3, 3, 3, 1, 2, 2, 1, 1, 1], dtype=np.uint8)
    las.classification = np.array([2, 1, 2, 5, 5, 2, 2, 1, 2, 2, 6, 2], dtype=np.uint8)
    path = tmp_path / "f.las"
    las.write(path)
    x = lambda **kw: read(path, **kw).points[:, 0].astype(int).tolist()  # noqa: E731
    assert x() == [0, 2, 3, 6, 7, 9, 10, 11]  # first returns
    assert x(returns="last") == [1, 2, 5, 6, 8, 9, 10, 11]
    assert x(returns=2) == x(returns="2") == [1, 4, 8]
    assert x(returns="all", classes=2) == [0, 2, 5, 6, 8, 9, 11]
    assert x(classes="2,6") == [0, 2, 6, 9, 10, 11]
    with pytest.raises(FileFormatError, match="no points selected.*classes=9"):
        read(path, classes=9)
    for bad in ({"returns": "second"}, {"classes": "ground"}, {"classes": [2.5]}):
        with pytest.raises(ParameterError):
            read(path, **bad)


def test_declared_counts_are_checked_against_the_size(tmp_path):
    head = "ply\nformat binary_little_endian 1.0\nelement vertex {}\n"
    head += "property float x\nproperty float y\nproperty float z\nend_header\n"
    body = np.zeros((3, 3), dtype="<f4").tobytes()
    with pytest.raises(FileFormatError, match=r"line 3.*4,000,000,000 'vertex' items"):
        read(write(tmp_path / "a.ply", head.format(4_000_000_000).encode() + body))
    vtk = "# vtk DataFile Version 3.0\nt\nASCII\nDATASET POLYDATA\nPOINTS 900000000 float\n0 0 0\n"
    with pytest.raises(FileFormatError, match="line 6.*2,700,000,000 values for POINTS"):
        read(write(tmp_path / "a.vtk", vtk))
    # a .npy header declaring far more than the file holds
    header = b"{'descr': '<f8', 'fortran_order': False, 'shape': (10000000000, 3), }"
    header = header.ljust(118) + b"\n"
    npy = b"\x93NUMPY\x01\x00" + struct.pack("<H", len(header)) + header + bytes(24)
    with pytest.raises(FileFormatError, match="30,000,000,000 values"):
        read(write(tmp_path / "a.npy", npy))


def test_npz_with_a_garbage_member(tmp_path):
    path = tmp_path / "g.npz"
    with zipfile.ZipFile(path, "w") as archive:
        with archive.open("points.npy", "w") as member:
            np.lib.format.write_array(member, np.zeros((5, 3)))
        archive.writestr("line_ids.npy", b"this is not an array")
    with pytest.raises(FileFormatError, match="member 'line_ids' is not a .npy array"):
        read(path)
    # a deflated member declaring more than deflate can expand to
    with zipfile.ZipFile(path, "w", zipfile.ZIP_DEFLATED) as archive:
        archive.writestr("points.npy", bytes(1000))
    data = bytearray(path.read_bytes())
    for at in (22, data.rfind(b"PK\x01\x02") + 24):  # local and central uncompressed sizes
        struct.pack_into("<I", data, at, 4_000_000_000)
    with pytest.raises(FileFormatError, match="bytes in member 'points'"):
        read(write(path, bytes(data)))


def test_vtk_with_an_empty_cell(tmp_path):
    pts = " ".join(f"{i % 3} {i // 3} 0" for i in range(9))
    vtk = (
        "# vtk DataFile Version 3.0\nt\nASCII\nDATASET POLYDATA\n"
        f"POINTS 9 float\n{pts}\nLINES 4 13\n3 0 1 2\n0\n3 3 4 5\n3 6 7 8\n"
    )
    sp = read(write(tmp_path / "e.vtk", vtk))
    np.testing.assert_array_equal(sp.line_ids, [0, 0, 0, 1, 1, 1, 2, 2, 2])
    # an empty polygon beside a real one: still the lines of the LINES cells
    vtk = vtk.replace("LINES 4 13\n3 0 1 2\n0\n", "POLYGONS 2 5\n0\n3 0 1 3\nLINES 3 12\n3 0 1 2\n")
    sp = read(write(tmp_path / "f.vtk", vtk))
    np.testing.assert_array_equal(sp.line_ids, [0, 0, 0, 1, 1, 1, 2, 2, 2])


def test_ply_comment_holding_end_header(tmp_path):
    text = (
        "ply\nformat ascii 1.0\ncomment this end_header is only a comment\n"
        "element vertex 2\nproperty float x\nproperty float y\nproperty float z\n"
        "end_header\n1 2 3\n4 5 6\n"
    )
    sp = read(write(tmp_path / "c.ply", text))
    np.testing.assert_array_equal(sp.points, [[1, 2, 3], [4, 5, 6]])


def test_extreme_magnitudes_read_and_triangulate(tmp_path):
    x, y = np.meshgrid(np.arange(6.0), np.arange(5.0))
    base = np.column_stack([x.ravel(), y.ravel(), np.sin(x.ravel()) + 0.1 * y.ravel()])
    ids = np.repeat(np.arange(5), 6)
    for scale in (1e-310, 1e307):  # subnormal, and near the float64 maximum
        path = tmp_path / "s.xyz"
        write_points(path, base * scale, ids)
        sp = read(path)
        np.testing.assert_array_equal(sp.points, base * scale)
        # (below 1e-308 the strips' planar check still rescales by 1 / extent, which
        # overflows: it warns of crossing lines, so the strips are checked at 1e307 only)
        for method in ("delaunay",) if scale < 1e-300 else ("delaunay", "shortest-path"):
            lines = None if method == "delaunay" else sp.line_ids  # delaunay refuses lines=
            surface = scanmesh.reconstruct(sp.points, method, lines=lines, plane="z")
            assert len(surface.faces) == 40, (scale, method)


# --------------------------------------------------------------------------- the table


def test_format_by_content_when_the_ending_says_nothing(tmp_path):
    ply = "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\n"
    ply += "property float z\nend_header\n0 0 0\n1 0 0\n0 1 0\n"
    assert format_of(write(tmp_path / "scan.dat", ply)).name == "ply"
    assert len(read(tmp_path / "scan.dat")) == 3
    np.save(tmp_path / "a.npy", np.eye(3))
    (tmp_path / "a.npy").rename(tmp_path / "a.bin")
    assert len(read(tmp_path / "a.bin")) == 3
    with pytest.raises(FileFormatError, match=r"'\.dat'.*readable endings"):
        read(write(tmp_path / "words.dat", "just words\n"))


def test_an_option_the_format_does_not_take_is_refused(tmp_path):
    path = write(tmp_path / "p.xyz", "0 0 0\n1 0 0\n0 1 0\n")
    with pytest.raises(
        ParameterError, match=r"returns= \(--returns\) does not apply to xyz.*columns="
    ):
        read(path, returns="first")
    with pytest.raises(ParameterError, match="cell="):
        read(path, cell=2.0)


# --------------------------------------------------------------------------- Ctrl-C


@pytest.mark.slow
def test_ctrl_c_while_reading_a_large_ascii_ply(tmp_path):
    from conftest import seconds_to_interrupt

    path = tmp_path / "big.ply"
    script = f"""
    import sys, time
    import scanmesh
    n = 1_500_000
    rows = "".join(
        f"{{i * 1e-3:.6f}} {{i % 997 * 2e-3:.6f}} {{i * 1e-4:.6f}}\\n" for i in range(100_000)
    )
    with open({str(path)!r}, "w") as handle:
        handle.write("ply\\nformat ascii 1.0\\nelement vertex %d\\n" % n)
        handle.write("property float x\\nproperty float y\\nproperty float z\\nend_header\\n")
        for _ in range(15):
            handle.write(rows)
    print("started", flush=True)
    try:
        scanmesh.read({str(path)!r})
    except KeyboardInterrupt:
        print(f"interrupted {{time.monotonic()!r}}", flush=True)
        sys.exit(0)
    print("finished", flush=True)
    """
    assert seconds_to_interrupt(script, 0.1) < 0.5  # early: a fast machine reads it in 0.3 s


# --------------------------------------------------------------------------- columns, grids


def test_line_column_rule_matches_its_definition():
    """The 4th column is a line id exactly when its values are integers below 2**53, each in
    one run of rows, the runs two rows long or more on average (checked in plain Python)."""
    from scanmesh.formats.xyz import _line_ids_or_none

    rng = np.random.default_rng(12)
    for _ in range(400):
        k = int(rng.integers(1, 12))
        ids = np.repeat(rng.integers(-3, 5, k), rng.integers(1, 4, k)).astype(np.float64)
        if rng.random() < 0.2:
            ids[int(rng.integers(len(ids)))] = rng.choice(
                [0.5, np.nan, np.inf, 2.0**53, -(2.0**60)]
            )
        values = ids.tolist()
        runs = [v for i, v in enumerate(values) if i == 0 or v != values[i - 1]]
        integers = all(math.isfinite(v) and v == int(v) and abs(v) < 2**53 for v in values)
        expect = integers and len(runs) == len(set(runs)) and 2 * len(runs) <= len(values)
        got = _line_ids_or_none(ids)
        assert (got is not None) == expect, values
        if expect:
            assert got.dtype == np.int64 and got.tolist() == [int(v) for v in values]


def test_an_intensity_column_is_not_a_line_id(tmp_path):
    rng = np.random.default_rng(5)
    pts = rng.random((300, 3))
    intensity = rng.integers(0, 256, 300)
    body = "".join(
        f"{x!r} {y!r} {z!r} {i}\n" for (x, y, z), i in zip(pts.tolist(), intensity, strict=True)
    )
    sp = read(write(tmp_path / "i.xyz", body))
    np.testing.assert_array_equal(sp.points, pts)
    assert sp.line_ids is None and sp.extra["ignored_columns"] == [3]
    # named, it is what it is called; chosen, it is a line id even if it does not look so
    sp = read(write(tmp_path / "h.xyz", "x y z intensity\n" + body))
    assert sp.line_ids is None and sp.extra["ignored_columns"] == [3]
    sp = read(tmp_path / "i.xyz", columns="x,y,z,line")
    np.testing.assert_array_equal(sp.line_ids, intensity)
    # a 4th column of one run per line is still read as the line id (files we wrote)
    lines = np.repeat(np.arange(30), 10)
    body = "".join(
        f"{x!r} {y!r} {z!r} {i}\n" for (x, y, z), i in zip(pts.tolist(), lines, strict=True)
    )
    np.testing.assert_array_equal(read(write(tmp_path / "l.xyz", body)).line_ids, lines)


@pytest.mark.parametrize("sep", [";", "\t", " ; "])
def test_semicolons_and_tabs(tmp_path, sep):
    pts = np.random.default_rng(2).normal(size=(40, 3))
    ids = np.repeat(np.arange(4), 10)
    rows = [sep.join([*map(repr, p), str(i)]) for p, i in zip(pts.tolist(), ids, strict=True)]
    for name in ("s.csv", "s.txt"):
        sp = read(write(tmp_path / name, "x;y;z;line\n".replace(";", sep) + "\n".join(rows)))
        np.testing.assert_array_equal(sp.points, pts)
        np.testing.assert_array_equal(sp.line_ids, ids)


def test_columns_by_name_or_index(tmp_path):
    rng = np.random.default_rng(3)
    table = rng.random((50, 7))
    table[:, 6] = np.repeat(np.arange(5), 10)
    text = "\n".join(" ".join(repr(v) for v in row) for row in table.tolist())
    path = write(tmp_path / "c.xyz", text)
    with pytest.raises(FileFormatError, match="found 7.*columns="):
        read(path)
    sp = read(path, columns="t,x,y,z,r,g,line")
    np.testing.assert_array_equal(sp.points, table[:, 1:4])
    np.testing.assert_array_equal(sp.line_ids, table[:, 6])
    sp = read(path, columns=[3, 2, 1, 6])
    np.testing.assert_array_equal(sp.points, table[:, [3, 2, 1]])
    np.testing.assert_array_equal(read(path, columns="3,2,1,6").points, sp.points)
    sp = read(path, columns="x y z")  # the first three, the rest ignored
    np.testing.assert_array_equal(sp.points, table[:, :3])
    assert sp.line_ids is None and sp.extra["ignored_columns"] == [3, 4, 5, 6]
    for bad, err in (
        ("x,y", ParameterError),
        ("x,x,y,z", ParameterError),
        ([0, 1, 9], FileFormatError),
        ([0, 1], ParameterError),
        ([0, 1, 1.5], ParameterError),
        ("a,b,c,d,e,f,g,x,y,z", FileFormatError),
    ):
        with pytest.raises(err):
            read(path, columns=bad)


def test_height_grids(tmp_path):
    z = np.random.default_rng(4).random((7, 5))
    z[2, 3] = np.nan  # a hole
    expect_x, expect_y = np.meshgrid(np.arange(5) * 2.0, np.arange(7) * 3.0)
    have = ~np.isnan(z)
    want = np.column_stack([expect_x[have], expect_y[have], z[have]])
    header = ",".join(f"V{j + 1}" for j in range(5))
    text = header + "\n" + "\n".join(",".join(repr(v) for v in row) for row in z.tolist())
    np.save(tmp_path / "z.npy", z)
    for path in (write(tmp_path / "z.csv", text), tmp_path / "z.npy"):
        sp = read(path, grid=True, cell=(2.0, 3.0))
        np.testing.assert_array_equal(sp.points, want)
        np.testing.assert_array_equal(sp.line_ids, np.nonzero(have)[0])
        assert sp.grid.shape == (7, 5) and sp.grid[2, 3] == -1
        np.testing.assert_array_equal(sp.points[sp.grid[4]], want[sp.line_ids == 4])
    with pytest.raises(FileFormatError, match="grid=True"):
        read(tmp_path / "z.npy")
    with pytest.raises(ParameterError, match="cell"):
        read(tmp_path / "z.npy", grid=True, cell=-1)


def test_esri_ascii_grid(tmp_path):
    text = (
        "ncols 4\nnrows 3\nxllcorner 100.0\nyllcorner 200.0\ncellsize 10\nNODATA_value -9999\n"
        "1 2 3 4\n5 -9999 7 8\n9 10 11 12\n"
    )
    sp = read(write(tmp_path / "g.asc", text))
    # cell centres; the first row is the northernmost
    assert sp.extra["format"] == "esri ascii grid" and len(sp) == 11
    np.testing.assert_array_equal(sp.points[0], [105.0, 225.0, 1.0])
    np.testing.assert_array_equal(sp.points[-1], [135.0, 205.0, 12.0])
    np.testing.assert_array_equal(sp.line_ids, [0, 0, 0, 0, 1, 1, 1, 2, 2, 2, 2])
    assert sp.grid[1, 1] == -1
    assert read(tmp_path / "g.asc", cell=1.0).points[1, 0] == 101.5
    with pytest.raises(FileFormatError, match="3 x 4 = 12 heights, the file holds 11"):
        read(write(tmp_path / "short.asc", text.replace(" 12\n", "\n")))
    with pytest.raises(FileFormatError, match="2,000,000,000 grid cells"):
        read(write(tmp_path / "big.asc", text.replace("nrows 3", "nrows 500000000")))
    # an .asc without the header is still XYZ text
    assert read(write(tmp_path / "p.asc", "0 0 0\n1 0 0\n0 1 0\n")).extra["format"] == "xyz"


# --------------------------------------------------------------------------- recorded up


def test_up_is_recorded_and_read_back(tmp_path):
    pts = np.random.default_rng(6).random((20, 3))
    path = write_points(tmp_path / "u.xyz", pts, up=[0, 2, 0])
    assert path.read_text().startswith("# scanmesh up 0 2 0\n")
    sp = read(path)
    np.testing.assert_array_equal(sp.up, [0, 1, 0])
    np.testing.assert_array_equal(sp.points, pts)
    assert read(write_points(tmp_path / "n.xyz", pts)).up is None
    ply = (
        "ply\nformat ascii 1.0\ncomment scanmesh up 1 0 0\nelement vertex 3\nproperty float x\n"
        "property float y\nproperty float z\nend_header\n0 0 0\n1 0 0\n0 1 0\n"
    )
    np.testing.assert_array_equal(read(write(tmp_path / "u.ply", ply)).up, [1, 0, 0])


def test_cyberware_range_grid_lines_are_its_columns(tmp_path):
    # a Cyberware frame is a column: x constant down it, stepping by echo_lgincr along rows
    rows, cols, step = 4, 5, 0.5
    pts, cells = [], []
    for r in range(rows):
        for c in range(cols):
            if (r, c) == (2, 1):  # a hole
                cells.append("0")
                continue
            cells.append(f"1 {len(pts)}")
            pts.append((c * step, r * 0.25, np.sin(c + r)))
    vertices = [f"{x} {y} {z:.6f}" for x, y, z in pts]
    path = write(tmp_path / "cyber.ply", cyberware_range_grid(rows, cols, step, vertices, cells))
    sp = read(path)
    x = np.array(pts)[:, 0]
    np.testing.assert_array_equal(sp.line_ids, np.round(x / step).astype(int))
    assert sp.n_lines == cols and sp.grid.shape == (cols, rows)
    assert sp.grid[1, 2] == -1  # column 1, row 2
    for line, members in enumerate(sp.grid):  # each frame: one x, rows in order
        members = members[members >= 0]
        assert np.all(sp.points[members, 0] == line * step)
        assert np.all(np.diff(sp.points[members, 1]) > 0)
    # other range grids go row by row, or as asked
    assert read(path, lines="rows").n_lines == rows
    plain = write(
        tmp_path / "plain.ply",
        path.read_text()
        .replace("obj_info is_cyberware_data 1\n", "")
        .replace(f"obj_info echo_lgincr {step}\n", ""),
    )
    assert read(plain).n_lines == rows and read(plain, lines="columns").n_lines == cols


@pytest.mark.slow
def test_the_command_reads_columns_and_records_up(tmp_path):
    import json

    def run(*args):
        out = subprocess.run(
            [sys.executable, "-m", "scanmesh", *map(str, args)], capture_output=True, text=True
        )
        assert out.returncode == 0, out.stderr
        return out.stdout

    table = np.column_stack([np.random.default_rng(8).random((40, 3)), np.repeat(np.arange(4), 10)])
    path = tmp_path / "t.xyz"
    np.savetxt(path, table[:, [3, 0, 1, 2]], fmt="%.17g")  # line id first
    info = json.loads(run("info", path, "--columns", "line,x,y,z", "--json"))
    assert info["points"] == 40 and info["lines"] == 4
    info = json.loads(run("info", path, "--columns", "1,2,3,0", "--json"))
    assert info["lines"] == 4
    mesh = tmp_path / "box.stl"
    import trimesh

    trimesh.creation.box(extents=(4, 3, 1)).export(mesh)
    run("simulate", mesh, "-o", tmp_path / "s.xyz", "--up", "y", "--spacing", "0.5")
    np.testing.assert_array_equal(read(tmp_path / "s.xyz").up, [0, 1, 0])


# --------------------------------------------------------------------------- mutations


def valid_files(tmp_path: Path) -> dict[str, bytes]:
    """One small valid file per format (written by independent code or numpy)."""
    rng = np.random.default_rng(9)
    pts = rng.random((12, 3))
    files = {
        "a.xyz": "x y z line\n"
        + "".join(f"{x} {y} {z} {i // 4}\n" for i, (x, y, z) in enumerate(pts.tolist())),
        "a.csv": "x,y,z\n" + "".join(f"{x},{y},{z}\n" for x, y, z in pts.tolist()),
        "a.asc": "ncols 4\nnrows 3\nxllcorner 0\nyllcorner 0\ncellsize 1\nNODATA_value -1\n"
        + "".join(
            " ".join(f"{v:.3f}" for v in row) + "\n" for row in pts.ravel()[:12].reshape(3, 4)
        ),
        "a.ply": "ply\nformat ascii 1.0\nobj_info num_cols 4\nobj_info num_rows 3\n"
        "element vertex 12\nproperty float x\nproperty float y\nproperty float z\n"
        "element range_grid 12\nproperty list uchar int vertex_indices\nend_header\n"
        + "".join(f"{x} {y} {z}\n" for x, y, z in pts.tolist())
        + "".join(f"1 {i}\n" for i in range(12)),
        "a.vtk": "# vtk DataFile Version 3.0\nt\nASCII\nDATASET POLYDATA\nPOINTS 12 float\n"
        + " ".join(f"{v}" for v in pts.ravel().tolist())
        + "\nLINES 3 15\n4 0 1 2 3\n4 4 5 6 7\n4 8 9 10 11\n",
    }
    out = {name: text.encode() for name, text in files.items()}
    head = b"ply\nformat binary_little_endian 1.0\nelement vertex 12\nproperty double x\n"
    head += b"property double y\nproperty double z\nend_header\n"
    out["b.ply"] = head + pts.astype("<f8").tobytes()
    np.save(tmp_path / "a.npy", np.column_stack([pts, np.arange(12) // 4]))
    np.savez(tmp_path / "a.npz", points=pts, line_ids=np.arange(12) // 4)
    out["a.npy"] = (tmp_path / "a.npy").read_bytes()
    out["a.npz"] = (tmp_path / "a.npz").read_bytes()
    return out


#: Mutations per format in the suite (a longer hunt: set it higher and run this test).
TRIALS = 150


@pytest.mark.slow
def test_mutated_files_are_read_or_refused_clearly(tmp_path):
    """Bit flips, byte changes, cuts and repeats of valid files: every outcome is points or
    a ScanmeshError (FileFormatError) naming the file, never another exception."""
    rng = np.random.default_rng(12)
    for name, data in valid_files(tmp_path).items():
        assert len(read(write(tmp_path / name, data))) > 0, name
        for trial in range(TRIALS):
            raw = bytearray(data)
            kind = trial % 4
            at = int(rng.integers(len(raw)))
            if kind == 0:
                raw[at] ^= 1 << int(rng.integers(8))
            elif kind == 1:
                raw[at] = int(rng.choice(list(b"0123456789 -.e\n,;#x\x00\xff")))
            elif kind == 2:
                del raw[at:]
            else:
                raw[at:at] = raw[at : at + int(rng.integers(1, 40))]
            path = write(tmp_path / f"m{trial}{Path(name).suffix}", bytes(raw))
            try:
                read(path)
            except scanmesh.ScanmeshError as exc:
                assert path.name in str(exc), (name, trial, exc)
            path.unlink()
