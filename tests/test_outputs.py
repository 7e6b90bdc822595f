"""Every writer's outputs: never an input by any alias, no temporary left behind or
over-long, signals that end the process clean up first."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import textwrap
import time
from pathlib import Path

import numpy as np
import pytest

import scanmesh
from scanmesh.errors import ParameterError
from scanmesh.formats.write import save_mesh, temporary_name, write_atomic
from test_cli import assert_failed, run


def _patch(n: int = 6) -> np.ndarray:
    """(n*n, 3) points of a gentle height field on a grid, jittered a little."""
    x, y = np.meshgrid(np.linspace(0, 1, n), np.linspace(0, 1, n))
    rng = np.random.default_rng(3)
    pts = np.column_stack([x.ravel(), y.ravel(), 0.1 * x.ravel() * y.ravel()])
    pts[:, :2] += rng.normal(0, 1e-3, (len(pts), 2))
    return pts


def _ply_points(path: Path) -> bytes:
    """Write a PLY of points only (the scan) to ``path``, whatever its ending; its bytes."""
    save_mesh(path.with_suffix(".ply"), _patch(), np.empty((0, 3), dtype=np.int64))
    if path.suffix != ".ply":
        path.with_suffix(".ply").rename(path)
    return path.read_bytes()


# --------------------------------------------------------------------------- the input rule


def test_save_after_chdir_refuses_the_scan(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    original = _ply_points(tmp_path / "scan.ply")
    surface = scanmesh.reconstruct("scan.ply", "delaunay")  # a relative path, read here
    (tmp_path / "sub").mkdir()
    monkeypatch.chdir(tmp_path / "sub")
    with pytest.raises(ParameterError, match="input file"):
        surface.save("../scan.ply")
    assert (tmp_path / "scan.ply").read_bytes() == original
    surface.save("mesh.ply")  # any other file is fine
    assert (tmp_path / "sub" / "mesh.ply").stat().st_size > 0


def test_save_after_chdir_refuses_the_scan_read_first(tmp_path, monkeypatch):
    """The same through ``scanmesh.read``: the points it returns keep their file."""
    monkeypatch.chdir(tmp_path)
    original = _ply_points(tmp_path / "scan.ply")
    surface = scanmesh.reconstruct(scanmesh.read("scan.ply"), "delaunay")
    (tmp_path / "sub").mkdir()
    monkeypatch.chdir(tmp_path / "sub")
    with pytest.raises(ParameterError, match="input file"):
        surface.save("../scan.ply")
    assert (tmp_path / "scan.ply").read_bytes() == original


def test_save_refuses_the_scan_by_content_glb_and_moved(tmp_path):
    scan = tmp_path / "scan.glb"  # a PLY read by its content
    original = _ply_points(scan)
    surface = scanmesh.reconstruct(scan, "delaunay")
    with pytest.raises(ParameterError, match="input file"):
        surface.save(scan)
    with pytest.raises(ParameterError, match="input file"):
        scanmesh.present.view.save_glb(surface, scan)
    assert scan.read_bytes() == original
    # moved after reading: the device and inode recorded when it was read still name it
    moved = tmp_path / "moved.glb"
    scan.rename(moved)
    with pytest.raises(ParameterError, match="input file"):
        surface.save(moved)
    assert moved.read_bytes() == original


def test_html_and_preview_refuse_the_scan(tmp_path):
    page, picture = tmp_path / "scan.html", tmp_path / "scan.png"
    for path in (page, picture):
        original = _ply_points(path)  # read by its content
        surface = scanmesh.reconstruct(path, "delaunay")
        with pytest.raises(ParameterError, match="input file"):
            if path == page:
                surface.to_html(page)
            else:
                scanmesh.present.render.render_mesh(surface, picture)
        assert path.read_bytes() == original


def _scans(folder: Path) -> list[Path]:
    """Three small scan files of consecutive lines: q0.ply, q1.ply, t0.xyz."""
    folder.mkdir()
    pts = _patch(9)
    ids = np.repeat(np.arange(9), 9)
    paths = []
    for k, name in enumerate(("q0.xyz", "q1.xyz", "t0.xyz")):
        rows = slice(27 * k, 27 * (k + 1))
        scanmesh.formats.write.write_points(folder / name, pts[rows], ids[rows])
        paths.append(folder / name)
    return paths


@pytest.mark.slow
def test_dask_command_refuses_an_input_as_output(tmp_path):
    paths = _scans(tmp_path / "scans")
    before = [p.read_bytes() for p in paths]
    pattern = str(tmp_path / "scans" / "q*.xyz")
    # the mesh over a file the pattern matches
    out = paths[1].with_suffix(".ply")
    paths[1].rename(out)
    res = run(
        "reconstruct",
        pattern.replace(".xyz", ".*"),
        "-o",
        out,
        "--dask",
        "local",
        "--method",
        "delaunay",
        timeout=120,
    )
    assert "input file" in assert_failed(res)
    out.rename(paths[1])
    # the report over an input the pattern matches
    res = run(
        "reconstruct",
        str(tmp_path / "scans" / "*.xyz"),
        "-o",
        tmp_path / "m.ply",
        "--report",
        paths[2],
        "--dask",
        "local",
        "--method",
        "delaunay",
        timeout=120,
    )
    assert "input file" in assert_failed(res)
    assert [p.read_bytes() for p in paths] == before
    assert not (tmp_path / "m.ply").exists()


def test_reconstruct_distributed_refuses_an_input_as_output(tmp_path):
    pytest.importorskip("distributed")
    from scanmesh.distributed import reconstruct_distributed

    paths = _scans(tmp_path / "scans")
    target = paths[0].with_suffix(".ply")
    paths[0].rename(target)
    original = target.read_bytes()
    with pytest.raises(ParameterError, match="input file"):
        reconstruct_distributed([target, paths[1]], "delaunay", output=target)
    with pytest.raises(ParameterError, match="input file"):
        reconstruct_distributed(str(tmp_path / "scans" / "*"), "delaunay", output=target)
    assert target.read_bytes() == original


def test_remote_output_is_refused_naming_the_flag(tmp_path):
    scan = tmp_path / "scan.xyz"
    scanmesh.formats.write.write_points(scan, _patch())
    message = assert_failed(run("reconstruct", scan, "-o", "s3://bucket/x.stl"))
    assert "remote URLs are not supported" in message and "-o" in message
    assert "does not exist" not in message


@pytest.mark.slow
@pytest.mark.parametrize(
    ("args", "flag"),
    [
        (("render", "MESH", "-o", "s3://b/x.png"), "-o/--output"),
        (("view", "MESH", "-o", "gs://b/x.html", "--no-open"), "-o/--output"),
        (("simulate", "MESH", "-o", "s3://b/x.xyz", "--spacing", "0.1"), "-o/--output"),
        (("compare", "SCAN", "--picture", "s3://b/x.png"), "--picture"),
        (("demo", "-o", "s3://b/demo"), "-o/--output-dir"),
        (("reconstruct", "SCAN", "-o", "m.stl", "--report", "s3://b/r.json"), "--report"),
    ],
)
def test_every_command_refuses_a_remote_output_naming_the_flag(tmp_path, args, flag):
    scan, mesh = tmp_path / "scan.xyz", tmp_path / "m.ply"
    scanmesh.formats.write.write_points(scan, _patch())
    save_mesh(mesh, _patch(), np.array([[0, 1, 6], [1, 7, 6]]))
    given = [{"MESH": str(mesh), "SCAN": str(scan)}.get(a, a) for a in args]
    message = assert_failed(run(*given))
    assert "remote URLs are not supported" in message and f"{flag} " in message


# --------------------------------------------------------------------------- temporaries


def test_long_output_name_is_written(tmp_path):
    verts, faces = _patch(), np.array([[0, 1, 6]])
    out = tmp_path / ("m" * 251 + ".ply")  # 255 bytes: NAME_MAX
    save_mesh(out, verts, faces)
    assert out.stat().st_size > 0
    assert len(temporary_name(out).name.encode()) <= 255
    save_mesh(out, verts, faces)  # and replaced
    assert [p.name for p in tmp_path.iterdir()] == [out.name]


def test_stale_temporaries_of_the_output_are_removed(tmp_path):
    out = tmp_path / "mesh.ply"
    long_out = tmp_path / ("n" * 251 + ".ply")
    old = time.time() - 3600
    stale = [
        tmp_path / ".mesh.ply.a1b2c3d4.part",  # an earlier version's name
        temporary_name(out),  # this version's (this process's pid: but written earlier)
        tmp_path / ".mesh.ply.999999999-0123456789ab.part",  # a writer long gone
        temporary_name(long_out),
    ]
    kept = [
        tmp_path / ".other.ply.a1b2c3d4.part",  # another output's
        tmp_path / ".mesh.ply.x.ply.a1b2c3d4.part",  # the temporary of mesh.ply.x.ply
        tmp_path / "mesh.ply.a1b2c3d4.part",  # not hidden: not a temporary
    ]
    for path in stale + kept:
        path.write_bytes(b"half a mesh")
        os.utime(path, (old, old))
    fresh = temporary_name(out)  # being written by a live writer now
    fresh.write_bytes(b"being written")
    verts, faces = _patch(), np.array([[0, 1, 6]])
    save_mesh(out, verts, faces)
    save_mesh(long_out, verts, faces)
    assert not any(p.exists() for p in stale)
    assert all(p.exists() for p in kept) and fresh.exists()


# A child started under nohup inherits SIGHUP ignored, and write_atomic leaves an ignored
# signal ignored (as it should): the writer puts the default back first, as a terminal has it.
_WRITER = """
import signal, sys, time
signal.signal(signal.SIGHUP, signal.SIG_DFL)
from scanmesh.formats.write import write_atomic

def chunks():
    yield b"x" * 1000
    print("started", flush=True)
    time.sleep(30)
    yield b"y"

write_atomic(sys.argv[1], chunks())
"""


@pytest.mark.parametrize("signum", [signal.SIGHUP, signal.SIGTERM])
def test_signal_during_a_write_removes_the_temporary(tmp_path, signum):
    out = tmp_path / "mesh.ply"
    out.write_bytes(b"old mesh")
    child = subprocess.Popen(
        [sys.executable, "-c", textwrap.dedent(_WRITER), str(out)],
        stdout=subprocess.PIPE,
        text=True,
    )
    assert child.stdout is not None and child.stdout.readline().strip() == "started"
    assert any(p.name.endswith(".part") for p in tmp_path.iterdir())
    child.send_signal(signum)
    assert child.wait(timeout=20) == -signum  # still ended by the signal
    assert [p.name for p in tmp_path.iterdir()] == ["mesh.ply"]
    assert out.read_bytes() == b"old mesh"


def test_write_atomic_protects_inputs(tmp_path):
    source = tmp_path / "scan.xyz"
    source.write_bytes(b"1 2 3\n")
    alias = tmp_path / "alias.xyz"
    os.link(source, alias)
    with pytest.raises(ParameterError, match="input file"):
        write_atomic(alias, [b"report"], protect=[source])
    assert source.read_bytes() == b"1 2 3\n"
