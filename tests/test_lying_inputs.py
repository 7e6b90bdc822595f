"""Files that lie or surprise: range grids whose header does not add up, holes where a
header might be, a compression bomb under a memory limit, a one-line grid, a closed part
with every face turned inwards. Each is refused by name or read for what it is."""

from __future__ import annotations

import subprocess
import sys
import textwrap
import warnings
import zlib
from pathlib import Path

import numpy as np
import pytest
import trimesh

import scanmesh


def range_grid_ply(path: Path, rows: int, cols: int, cells: list[list[int]], n: int = 4) -> Path:
    head = (
        "ply\nformat ascii 1.0\n"
        f"obj_info num_cols {cols}\nobj_info num_rows {rows}\n"
        f"element vertex {n}\nproperty float x\nproperty float y\nproperty float z\n"
        f"element range_grid {len(cells)}\nproperty list uchar int vertex_indices\nend_header\n"
    )
    body = "".join(f"{i} {i % 2} {0.1 * i}\n" for i in range(n))
    body += "".join(" ".join(map(str, [len(c), *c])) + "\n" for c in cells)
    path.write_text(head + body)
    return path


@pytest.mark.parametrize(
    ("rows", "cols", "cells"),
    [
        (-2, -2, [[0], [1], [2], [3]]),  # the product matches: a ValueError from reshape
        (-1, -4, [[0], [1], [2], [3]]),
        (0, 4, [[0], [1], [2], [3]]),
        (0, 5, []),  # an empty element: an IndexError
    ],
)
def test_a_range_grid_header_that_lies_is_a_file_format_error(tmp_path, rows, cols, cells):
    path = range_grid_ply(tmp_path / "grid.ply", rows, cols, cells)
    with pytest.raises(scanmesh.FileFormatError, match=f"{path.name}: PLY range_grid declares"):
        scanmesh.read(path)


def test_a_one_line_range_grid_is_named_by_method_grid(tmp_path):
    """The message denied that the file had a range grid."""
    path = range_grid_ply(tmp_path / "line.ply", 1, 8, [[i] for i in range(8)], n=8)
    assert scanmesh.read(path).grid is not None
    with pytest.raises(scanmesh.DegenerateInputError, match="range grid is 1 x 8"):
        scanmesh.reconstruct(str(path), "grid")


@pytest.mark.parametrize(("name", "delimiter"), [("g.txt", " "), ("g.csv", ",")])
def test_holes_in_the_first_column_are_cells_not_a_header(tmp_path, name, delimiter):
    """Rows starting with nan were taken for header lines and dropped silently."""
    z = np.add.outer(np.arange(6.0), np.arange(7.0)) * 0.1
    z[0, 0] = z[1, 0] = np.nan
    np.savetxt(tmp_path / name, z, delimiter=delimiter)
    scan = scanmesh.read(tmp_path / name, grid=True)
    assert scan.grid.shape == (6, 7)
    assert len(scan.points) == 40
    np.testing.assert_allclose(np.sort(scan.points[:, 2]), np.sort(z[np.isfinite(z)]))


BOMB = textwrap.dedent(
    """
    import resource, sys, time
    import scanmesh
    size = next(int(l.split()[1]) * 1024 for l in open("/proc/self/status")
                if l.startswith("VmSize:"))
    resource.setrlimit(resource.RLIMIT_AS, (size + int(sys.argv[2]), resource.RLIM_INFINITY))
    t0 = time.perf_counter()
    try:
        scanmesh.read(sys.argv[1])
        print("read")
    except scanmesh.FileFormatError as e:
        print(f"refused in {time.perf_counter() - t0:.1f} s:", e)
    """
)


def test_a_gzip_bomb_is_refused_early_naming_the_file_and_the_limit(tmp_path):
    """1 GiB of NUL under 300 MB of address space: the bound was half the machine's memory
    (a bare MemoryError after inflating what fit); it is now half of what RLIMIT_AS
    leaves."""
    member = zlib.compressobj(1, zlib.DEFLATED, 31)
    one = member.compress(bytes(64 << 20)) + member.flush()  # 64 MiB of NUL, ~64 KB
    bomb = tmp_path / "bomb.xyz.gz"
    bomb.write_bytes(one * 16)  # gzip members one after another: 1 GiB
    r = subprocess.run(
        [sys.executable, "-c", BOMB, str(bomb), str(300 << 20)],
        capture_output=True,
        text=True,
        timeout=120,
    )
    assert r.returncode == 0, r.stderr[-800:]
    assert r.stdout.startswith("refused in"), r.stdout
    assert str(bomb) in r.stdout and "RLIMIT_AS (ulimit -v)" in r.stdout, r.stdout


def test_a_closed_box_with_every_face_inverted_is_scanned_as_a_solid(tmp_path):
    """It was read as its 8 vertices (trimesh's is_volume wants a positive volume)."""
    box = trimesh.creation.box((2.0, 3.0, 1.0))
    box.export(tmp_path / "box.stl")
    box.invert()
    box.export(tmp_path / "inverted.stl")
    with warnings.catch_warnings(record=True):
        warnings.simplefilter("always")
        upright = scanmesh.reconstruct(str(tmp_path / "box.stl"), "delaunay")
        inverted = scanmesh.reconstruct(str(tmp_path / "inverted.stl"), "delaunay")
    assert len(inverted.vertices) == len(upright.vertices) > 1000
    np.testing.assert_allclose(inverted.vertices, upright.vertices)
