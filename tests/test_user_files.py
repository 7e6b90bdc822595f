"""The files, pictures and habits users bring: what ``read`` returns composes with the rest,
colours read true, errors name what happened."""

from __future__ import annotations

import numpy as np

import scanmesh
from scanmesh.formats.xyz import up_comment


def _heights(tmp_path):
    x = np.linspace(0.0, 3.0, 9)
    y = np.linspace(0.0, 2.0, 7)
    z = np.sin(x)[None, :] * np.cos(y)[:, None] + 5.0
    path = tmp_path / "heights.txt"
    np.savetxt(path, z)
    return path


def test_reconstruct_takes_what_read_returns(tmp_path):
    path = _heights(tmp_path)
    scan = scanmesh.read(path, grid=True)
    got = scanmesh.reconstruct(scan, "delaunay")
    want = scanmesh.reconstruct(scanmesh.planar_scan(path, read_options={"grid": True}), "delaunay")
    assert np.array_equal(got.faces, want.faces)
    assert np.array_equal(got.vertices, scan.points)
    assert got.scan is not None and got.scan.source == path
    # the strip methods use the file's lines
    strips = scanmesh.reconstruct(scan, "shortest-path")
    assert np.array_equal(
        strips.faces, scanmesh.reconstruct(scan.points, "shortest-path", lines=scan.line_ids).faces
    )
    # and the stage functions take it too
    assert np.array_equal(scanmesh.delaunay(scan).faces, got.faces)


def test_reconstruct_of_read_uses_the_recorded_up(tmp_path):
    rng = np.random.default_rng(3)
    u, v = np.meshgrid(np.linspace(0, 2, 12), np.linspace(0, 1, 8))
    pts = np.column_stack([u.ravel(), v.ravel(), 0.05 * rng.standard_normal(u.size)])
    # tilt the sheet: with the recorded up, plane choice must offer the file's direction
    up = np.array([0.0, 0.6, 0.8])
    rot = np.array([[1.0, 0.0, 0.0], [0.0, 0.8, -0.6], [0.0, 0.6, 0.8]])
    pts = pts @ rot.T
    path = tmp_path / "tilted.xyz"
    with open(path, "w") as f:
        f.write(up_comment(up))
        for row in range(8):
            np.savetxt(f, pts[row * 12 : (row + 1) * 12])
            f.write("\n")
    from_path = scanmesh.reconstruct(path, "delaunay")
    from_read = scanmesh.reconstruct(scanmesh.read(path), "delaunay")
    assert np.array_equal(from_read.faces, from_path.faces)
    assert from_read.options["plane_choice"] == from_path.options["plane_choice"]
