"""Writers: meshes through trimesh (STL binary, PLY, OBJ, OFF), XYZ points, atomic writes and
the guard that keeps a command from overwriting its own input."""

from __future__ import annotations

import os
import signal
import stat
import struct
import subprocess
import sys
import textwrap
from pathlib import Path

import numpy as np
import pytest
import trimesh

from scanmesh import ParameterError, ScanmeshError
from scanmesh.formats import read, read_xyz
from scanmesh.formats.write import save_mesh, write_atomic, write_points


def grid_mesh(nx=6, ny=5):
    """A small height-field mesh: vertices on a grid, two triangles per cell."""
    x, y = np.meshgrid(np.linspace(0, 1, nx), np.linspace(0, 2, ny))
    verts = np.column_stack([x.ravel(), y.ravel(), np.sin(x.ravel()) * np.cos(y.ravel())])
    faces = []
    for j in range(ny - 1):
        for i in range(nx - 1):
            a = j * nx + i
            faces += [[a, a + 1, a + nx + 1], [a, a + nx + 1, a + nx]]
    return verts, np.array(faces)


# --------------------------------------------------------------------------- error cases first


def test_refuses_to_overwrite_the_input(tmp_path):
    verts, faces = grid_mesh()
    source = tmp_path / "scan.ply"
    source.write_bytes(b"original input")
    with pytest.raises(ParameterError, match="refusing to write .*scan.ply.*input file"):
        save_mesh(source, verts, faces, protect=source)
    assert source.read_bytes() == b"original input"
    # another spelling of the same file, and a list of inputs
    other = tmp_path / "sub" / ".." / "scan.ply"
    (tmp_path / "sub").mkdir()
    with pytest.raises(ParameterError):
        save_mesh(other, verts, faces, protect=[tmp_path / "a.xyz", str(source)])
    link = tmp_path / "link.ply"
    link.symlink_to(source)
    with pytest.raises(ParameterError):
        save_mesh(link, verts, faces, protect=source)
    with pytest.raises(ParameterError, match="input file"):
        write_points(source, verts, protect=source)
    assert source.read_bytes() == b"original input"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["link.ply", "scan.ply", "sub"]


def test_protect_allows_other_paths(tmp_path):
    verts, faces = grid_mesh()
    source = tmp_path / "scan.xyz"
    source.write_text("1 2 3\n")
    out = save_mesh(tmp_path / "scan.stl", verts, faces, protect=source)
    assert out.exists() and source.read_text() == "1 2 3\n"


def test_unknown_mesh_ending(tmp_path):
    verts, faces = grid_mesh()
    with pytest.raises(ParameterError, match="'.dxf'"):
        save_mesh(tmp_path / "m.dxf", verts, faces)
    assert not list(tmp_path.iterdir())


def test_failed_write_leaves_the_old_file_and_no_debris(tmp_path, monkeypatch):
    verts, faces = grid_mesh()
    target = tmp_path / "m.obj"
    target.write_text("old")

    def broken_replace(src, dst):
        raise OSError("disk full")

    monkeypatch.setattr(os, "replace", broken_replace)
    with pytest.raises(OSError, match="disk full"):
        save_mesh(target, verts, faces)
    with pytest.raises(OSError, match="disk full"):
        write_points(tmp_path / "p.xyz", verts)
    assert target.read_text() == "old"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["m.obj"]


@pytest.mark.parametrize(
    ("points", "line_ids", "fragment"),
    [
        (np.zeros((4, 2)), None, r"\(4, 2\)"),
        (np.array([[0, 0, np.nan]]), None, "points\\[0\\]"),
        (np.array([["a", "b", "c"]]), None, "real"),
        (np.zeros((4, 3)), np.zeros(3, dtype=int), r"\(3,\)"),
        (np.zeros((4, 3)), np.full(4, 0.5), "integers"),
    ],
)
def test_write_points_bad_input(tmp_path, points, line_ids, fragment):
    with pytest.raises(ScanmeshError, match=fragment):
        write_points(tmp_path / "p.xyz", points, line_ids)
    assert not list(tmp_path.iterdir())


# --------------------------------------------------------------------------- round trips


@pytest.mark.parametrize("ending", [".stl", ".ply", ".obj", ".off"])
def test_mesh_round_trip_through_trimesh(tmp_path, ending):
    verts, faces = grid_mesh()
    path = save_mesh(tmp_path / f"m{ending}", verts, faces)
    assert path == tmp_path / f"m{ending}"
    back = trimesh.load(path, process=False, force="mesh")
    if ending == ".stl":
        # STL stores float32 triangle corners: compare triangles, not indices
        np.testing.assert_allclose(back.triangles, verts[faces], rtol=1e-6, atol=1e-6)
    else:
        np.testing.assert_allclose(back.vertices, verts, rtol=1e-6, atol=1e-7)
        np.testing.assert_array_equal(back.faces, faces)


def test_stl_is_binary(tmp_path):
    verts, faces = grid_mesh()
    path = save_mesh(tmp_path / "m.STL", verts, faces)
    data = path.read_bytes()
    # binary STL: 80-byte header, uint32 count, 50 bytes per triangle
    assert struct.unpack("<I", data[80:84])[0] == len(faces)
    assert len(data) == 84 + 50 * len(faces)


def test_surface_save_still_works(tmp_path):
    from scanmesh import delaunay

    rng = np.random.default_rng(0)
    pts = np.column_stack([rng.random((50, 2)), rng.random(50) * 0.1])
    surf = delaunay(pts)
    out = surf.save(tmp_path / "d.ply")
    back = trimesh.load(out, process=False)
    assert len(back.faces) == len(surf.faces)


def test_write_points_round_trip_exact(tmp_path):
    rng = np.random.default_rng(4)
    pts = rng.normal(size=(2000, 3)) * 10.0 ** rng.integers(-8, 9, size=(2000, 1))
    pts[0] = [0.1, -0.0, 1e300]
    ids = np.repeat(np.arange(40), 50)[::-1].copy()
    path = write_points(tmp_path / "p.xyz", pts, ids)
    sp = read_xyz(path)
    np.testing.assert_array_equal(sp.points, pts)  # 17 significant digits: exact
    np.testing.assert_array_equal(sp.line_ids, ids)
    single = pts[1:].astype(np.float32)
    sp = read(write_points(tmp_path / "q.xyz", single))
    np.testing.assert_array_equal(sp.points, single.astype(float))
    assert sp.line_ids is None


def test_write_points_line_ids_below_2_53_are_exact(tmp_path):
    ids = np.array([2**53 - 1, -(2**53) + 1, 0])
    sp = read(write_points(tmp_path / "h.xyz", np.zeros((3, 3)), ids))
    np.testing.assert_array_equal(sp.line_ids, ids)
    with pytest.raises(ParameterError, match="2\\*\\*53"):
        write_points(tmp_path / "g.xyz", np.zeros((1, 3)), [2**53])
    assert not (tmp_path / "g.xyz").exists()


def test_write_points_overwrites_atomically(tmp_path):
    path = tmp_path / "p.xyz"
    path.write_text("old\n")
    write_points(path, [[1, 2, 3]], [5])
    assert path.read_text() == "x y z line\n1 2 3 5\n"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["p.xyz"]


def test_write_points_in_blocks(tmp_path, monkeypatch):
    from scanmesh.formats import write as writers

    monkeypatch.setattr(writers, "POINTS_PER_BLOCK", 7)
    pts = np.arange(150.0).reshape(50, 3) / 7
    path = write_points(tmp_path / "b.xyz", pts, np.arange(50) // 10)
    assert path.read_text().count("\n") == 51  # the header row and 50 points
    sp = read(Path(path))
    np.testing.assert_array_equal(sp.points, pts)
    np.testing.assert_array_equal(sp.line_ids, np.arange(50) // 10)


def test_stl_from_numpy_matches_trimesh_in_blocks(tmp_path, monkeypatch):
    """The numpy STL writer gives trimesh's records (normals, float32 corners), block size
    does not matter, and a degenerate triangle gets a zero normal."""
    from scanmesh.formats import stl

    verts, faces = grid_mesh(9, 7)
    faces = np.vstack([faces, [[0, 1, 0]]])  # a repeated corner: zero area
    expect = trimesh.Trimesh(vertices=verts, faces=faces, process=False).export(file_type="stl")
    record = np.dtype([("normal", "<f4", (3,)), ("corners", "<f4", (3, 3)), ("attribute", "<u2")])
    want = np.frombuffer(expect, dtype=record, offset=84)
    for block in (1, 7, 1 << 19):
        monkeypatch.setattr(stl, "STL_FACES_PER_BLOCK", block)
        data = save_mesh(tmp_path / f"b{block}.stl", verts, faces).read_bytes()
        assert len(data) == 84 + 50 * len(faces)
        assert not data.startswith(b"solid")
        got = np.frombuffer(data, dtype=record, offset=84)
        np.testing.assert_array_equal(got["corners"], want["corners"])
        np.testing.assert_allclose(got["normal"], want["normal"], atol=1e-6)
        np.testing.assert_array_equal(got["normal"][-1], 0.0)
        assert (got["attribute"] == 0).all()


def test_stl_bad_faces_are_refused_before_writing(tmp_path):
    verts, faces = grid_mesh()
    with pytest.raises(ParameterError, match="indices"):
        save_mesh(tmp_path / "m.stl", verts, faces + len(verts))
    with pytest.raises(ParameterError, match=r"\(M, 3\)"):
        save_mesh(tmp_path / "m.stl", verts, faces[:, :2])
    assert not list(tmp_path.iterdir())


def test_interrupted_stl_leaves_no_file(tmp_path, monkeypatch):
    from scanmesh.formats import stl

    verts, faces = grid_mesh()
    monkeypatch.setattr(stl, "STL_FACES_PER_BLOCK", 4)

    def stop(done, total, value, stage):
        if done >= 8:
            raise KeyboardInterrupt

    with pytest.raises(KeyboardInterrupt):
        save_mesh(tmp_path / "m.stl", verts, faces, progress=stop)
    assert not list(tmp_path.iterdir())


def test_write_progress_counts_faces(tmp_path, monkeypatch):
    from scanmesh.formats import obj, ply, stl

    verts, faces = grid_mesh(9, 7)
    monkeypatch.setattr(stl, "STL_FACES_PER_BLOCK", 10)
    monkeypatch.setattr(ply, "FACES_PER_BLOCK", 10)
    monkeypatch.setattr(obj, "ROWS_PER_BLOCK", 10)
    for ending in (".stl", ".ply", ".obj", ".off"):
        seen: list[tuple[str, int, int]] = []

        def record(d, t, v, stage, seen=seen):
            seen.append((stage, d, t))

        save_mesh(tmp_path / f"m{ending}", verts, faces, progress=record)
        assert {s for s, _, _ in seen} == {"write"}
        done = [d for _, d, _ in seen]
        assert done == sorted(done) and done[-1] == len(faces) and seen[0][1] == 0


# --------------------------------------------------------------------------- the writer rule


def test_a_device_is_written_in_place_never_replaced(tmp_path):
    verts, faces = grid_mesh()
    null = Path("/dev/null")
    before = os.stat(null)
    write_points(null, verts)
    write_atomic(null, [b"a report\n"])
    after = os.stat(null)
    assert stat.S_ISCHR(after.st_mode) and after.st_rdev == before.st_rdev
    # a link to a device (like /dev/stdout) stays a link to it
    link = tmp_path / "out.stl"
    link.symlink_to(null)
    save_mesh(link, verts, faces)
    assert link.is_symlink() and os.readlink(link) == str(null)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["out.stl"]


def test_a_descriptor_link_writes_into_the_open_file(tmp_path):
    # /dev/stdout redirected to a file: /dev/stdout -> /proc/self/fd/1 -> the file
    out = tmp_path / "redirected.txt"
    with open(out, "wb") as handle:
        link = tmp_path / "stdout"
        link.symlink_to(f"/proc/self/fd/{handle.fileno()}")
        write_atomic(link, [b"report\n"])
        assert os.fstat(handle.fileno()).st_ino == os.stat(out).st_ino  # not replaced
    assert out.read_bytes() == b"report\n"
    assert link.is_symlink()


def test_a_fifo_gets_the_bytes_and_stays_a_fifo(tmp_path):
    verts, faces = grid_mesh()
    fifo = tmp_path / "m.obj"
    os.mkfifo(fifo)
    reader = subprocess.Popen(
        [sys.executable, "-c", f"import sys; sys.stdout.write(open({str(fifo)!r}).read())"],
        stdout=subprocess.PIPE,
        text=True,
    )
    save_mesh(fifo, verts, faces)
    got, _ = reader.communicate(timeout=60)
    assert stat.S_ISFIFO(os.stat(fifo).st_mode)
    assert got.count("\nf ") == len(faces) and got.count("\nv ") == len(verts)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["m.obj"]


def test_a_link_to_a_regular_file_stays_a_link(tmp_path):
    verts, faces = grid_mesh()
    real = tmp_path / "real.ply"
    real.write_bytes(b"old")
    link = tmp_path / "link.ply"
    link.symlink_to(real)
    save_mesh(link, verts, faces)
    assert link.is_symlink() and os.readlink(link) == str(real)
    back = trimesh.load(real, process=False)
    np.testing.assert_array_equal(back.faces, faces)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["link.ply", "real.ply"]


def test_sigterm_while_writing_removes_the_temporary(tmp_path):
    out = tmp_path / "m.obj"
    script = f"""
    import sys, time
    import numpy as np
    from scanmesh.formats.write import save_mesh
    verts = np.random.default_rng(0).random((1000, 3))
    faces = np.random.default_rng(1).integers(0, 1000, (300_000, 3))

    def progress(done, total, value, stage):
        if done:
            print("started", flush=True)
            time.sleep(30)  # SIGTERM arrives here, mid-file

    save_mesh({str(out)!r}, verts, faces, progress=progress)
    """
    proc = subprocess.Popen(
        [sys.executable, "-c", textwrap.dedent(script)], stdout=subprocess.PIPE, text=True
    )
    try:
        assert proc.stdout.readline().strip() == "started"
        assert [p.name for p in tmp_path.iterdir()][0].endswith(".part")
        proc.send_signal(signal.SIGTERM)
        assert proc.wait(timeout=30) == -signal.SIGTERM  # it still dies by the signal
    finally:
        proc.kill()
    assert list(tmp_path.iterdir()) == []


@pytest.mark.parametrize("ending", [".ply", ".obj", ".off"])
def test_vertex_normals_round_trip(tmp_path, ending):
    verts, faces = grid_mesh()
    path = save_mesh(tmp_path / f"n{ending}", verts, faces, normals=True)
    back = trimesh.load(path, process=False)  # force="mesh" would recompute the normals
    np.testing.assert_array_equal(back.faces, faces)
    # the normals stored are the area-weighted face normals, unit length, computed apart
    tri = verts[faces]
    face_n = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
    want = np.zeros_like(verts)
    for k in range(3):
        for f, v in enumerate(faces[:, k]):
            want[v] += face_n[f]
    want /= np.linalg.norm(want, axis=1, keepdims=True)
    if ending == ".off":  # trimesh reads no NOFF normals: parse the text
        rows = path.read_text().splitlines()[2 : 2 + len(verts)]
        stored = np.array([[float(v) for v in r.split()[3:]] for r in rows])
    else:
        stored = np.asarray(back.vertex_normals)
    np.testing.assert_allclose(stored, want, atol=1e-12)
    with pytest.raises(ParameterError, match="normals"):
        save_mesh(tmp_path / "n.stl", verts, faces, normals=True)


def test_ctrl_c_while_writing_a_large_obj_leaves_nothing(tmp_path):
    from conftest import seconds_to_interrupt

    out = tmp_path / "big.obj"
    script = f"""
    import sys, time
    import numpy as np
    from scanmesh.formats.write import save_mesh
    verts = np.random.default_rng(0).random((1_000_000, 3))
    faces = np.random.default_rng(1).integers(0, 1_000_000, (2_000_000, 3))
    print("started", flush=True)
    try:
        save_mesh({str(out)!r}, verts, faces)
    except KeyboardInterrupt:
        print(f"interrupted {{time.monotonic()!r}}", flush=True)
        sys.exit(0)
    print("finished", flush=True)
    """
    assert seconds_to_interrupt(script, 1.0) < 0.5
    assert list(tmp_path.iterdir()) == []
