"""README's tour runs as written, in an empty folder, on the files it says how to make."""

from __future__ import annotations

import os
import re
import shlex
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

import scanmesh

README = Path(__file__).resolve().parent.parent / "README.md"


def _tour() -> str:
    text = README.read_text(encoding="utf-8")
    return text[text.index("## A short tour") : text.index("## Scans larger than memory")]


def _blocks(kind: str) -> list[str]:
    return re.findall(rf"```{kind}\n(.*?)```", _tour(), flags=re.DOTALL)


def _commands(block: str) -> list[list[str]]:
    """Each line of a shell block as argv (comments dropped), run by this Python."""
    out = []
    for line in block.splitlines():
        argv = shlex.split(line, comments=True)
        if not argv:
            continue
        if argv[0] == "scanmesh":
            argv = [sys.executable, "-m", "scanmesh", *argv[1:]]
            if argv[3] == "view":
                argv.append("--no-open")
        elif argv[0] == "python":
            argv[0] = sys.executable
        out.append(argv)
    return out


def _run(argv: list[str], cwd: Path) -> subprocess.CompletedProcess:
    temp = cwd / "temp"  # scanmesh view's page, kept out of the real temporary folder
    temp.mkdir(exist_ok=True)
    env = {**os.environ, "TMPDIR": str(temp)}
    result = subprocess.run(argv, cwd=cwd, capture_output=True, text=True, timeout=600, env=env)
    assert result.returncode == 0, (argv, result.stderr)
    return result


@pytest.fixture(scope="module")
def folder(tmp_path_factory):
    """An empty folder with the files the tour says how to make."""
    path = tmp_path_factory.mktemp("tour")
    making, *_ = _blocks("sh")
    for argv in _commands(making):
        _run(argv, path)
    return path


@pytest.mark.slow
def test_the_tour_says_how_to_make_its_files(folder):
    assert {"part.stl", "scan.xyz", "scan.txt"} <= {p.name for p in folder.iterdir()}
    points, ids = scanmesh.simulate_scan(folder / "part.stl", up="y", spacing=0.05)
    assert 1000 < len(points) < 100_000 and len(np.unique(ids)) > 20  # a scan, not 14 points


@pytest.mark.slow
def test_the_python_tour_runs(folder, monkeypatch):
    (code,) = _blocks("python")[:1]
    monkeypatch.chdir(folder)
    monkeypatch.setattr(scanmesh.Surface, "show", lambda self, **kw: None)  # no window here
    namespace: dict = {}
    exec(compile(code, str(README), "exec"), namespace)
    assert (folder / "rod.stl").is_file() and (folder / "rod.glb").is_file()
    assert (folder / "rod.html").is_file()


@pytest.mark.slow
def test_the_command_tour_runs(folder):
    block = next(b for b in _blocks("sh") if "scanmesh compare" in b)
    for argv in _commands(block):
        _run(argv, folder)
    assert (folder / "mesh.stl").is_file() and (folder / "mesh.png").is_file()
    picture = folder / "methods.png"  # "one table, one picture"
    assert picture.is_file() and picture.read_bytes()[:4] == b"\x89PNG"


def test_the_pictures_example_runs(tmp_path, monkeypatch):
    (code,) = [block for block in _blocks("python") if "render_panels" in block]
    monkeypatch.chdir(tmp_path)
    exec(compile(code, str(README), "exec"), {"scanmesh": scanmesh})
    assert (tmp_path / "side.png").stat().st_size > 0 and (tmp_path / "tac.png").is_file()
