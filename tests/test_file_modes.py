"""A replaced file keeps its mode and owner; a new one honours the umask of the moment,
which the writer reads without changing it."""

from __future__ import annotations

import os
import stat

import numpy as np
import pytest

from scanmesh.formats.write import save_mesh, write_atomic

VERTS = np.array([[0.0, 0, 0], [1, 0, 0], [0, 1, 0]])
FACES = np.array([[0, 1, 2]])


def _mode(path) -> int:
    return stat.S_IMODE(os.stat(path).st_mode)


@pytest.fixture
def umask():
    """Set the umask for the test (returns the setter); restored after."""
    saved = os.umask(0o022)
    os.umask(saved)
    yield os.umask
    os.umask(saved)


@pytest.mark.parametrize("mode", [0o600, 0o640, 0o444, 0o755])
def test_replacing_a_file_keeps_its_mode(tmp_path, mode):
    out = tmp_path / "private.ply"
    out.write_bytes(b"old")
    out.chmod(mode)
    save_mesh(out, VERTS, FACES)
    assert _mode(out) == mode and out.read_bytes() != b"old"
    write_atomic(out, [b"report"])
    assert _mode(out) == mode


@pytest.mark.parametrize("mask", [0o077, 0o002, 0o027])
def test_new_files_honour_the_umask_of_the_moment(tmp_path, umask, mask):
    umask(mask)  # after scanmesh was imported
    save_mesh(tmp_path / "new.stl", VERTS, FACES)
    write_atomic(tmp_path / "new.json", [b"{}"])
    assert _mode(tmp_path / "new.stl") == 0o666 & ~mask
    assert _mode(tmp_path / "new.json") == 0o666 & ~mask


def test_the_writer_leaves_the_umask_alone(tmp_path, umask, monkeypatch):
    umask(0o027)

    def refuse(mask: int) -> int:
        raise AssertionError("os.umask changes the umask of every thread")

    monkeypatch.setattr(os, "umask", refuse)
    save_mesh(tmp_path / "a.ply", VERTS, FACES)
    assert _mode(tmp_path / "a.ply") == 0o640


@pytest.mark.skipif(not hasattr(os, "geteuid") or os.geteuid() != 0, reason="needs root")
def test_root_replacing_a_file_keeps_its_owner(tmp_path):
    out = tmp_path / "theirs.ply"
    out.write_bytes(b"old")
    os.chown(out, 4242, 4343)
    out.chmod(0o640)
    save_mesh(out, VERTS, FACES)
    info = os.stat(out)
    assert (info.st_uid, info.st_gid, _mode(out)) == (4242, 4343, 0o640)
