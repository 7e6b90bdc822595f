"""README.md is a front door: short, two set-up commands, links that lead on, and a tour that
runs as written, in an empty folder, on a curved part where the methods differ, drawing
pictures that show the part."""

from __future__ import annotations

import os
import re
import shlex
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from PIL import Image

import scanmesh

README = Path(__file__).resolve().parent.parent / "README.md"
TEXT = README.read_text(encoding="utf-8")

#: A picture shows the part when at least this share of its pixels differs from the
#: background (an edge-on view of a flat part drew 0.02 %; the tour's pictures draw 20-35 %).
DRAWN_SHARE = 0.10



def _section(title: str) -> str:
    start = TEXT.index(f"## {title}")
    end = TEXT.find("\n## ", start + 1)
    return TEXT[start : len(TEXT) if end < 0 else end]


def _blocks(kind: str, section: str = "A short tour") -> list[str]:
    return re.findall(rf"```{kind}\n(.*?)```", _section(section), flags=re.DOTALL)


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


def drawn_share(path: Path) -> float:
    """The share of a picture's pixels that differ from its background (its corner)."""
    with Image.open(path) as image:
        pixels = np.asarray(image.convert("RGB")).astype(int)
    return float((np.abs(pixels - pixels[0, 0]).sum(axis=2) > 30).mean())


# the front door


def test_the_readme_is_short_and_leads_on():
    assert len(TEXT.splitlines()) <= 120
    first_screen = "\n".join(TEXT.splitlines()[:12])
    assert "triangle mesh" in first_screen and "scan" in first_screen
    for target in (
        "docs/guide/README.md",
        "docs/options.md",
        "BENCHMARKS.md",
        "ARCHITECTURE.md",
        "CONTRIBUTING.md",
    ):
        assert f"]({target})" in TEXT, target


def test_two_set_up_commands_in_a_virtual_environment():
    setup = _section("Set up")
    assert re.findall(r"```sh\n(.*?)```", setup, flags=re.DOTALL) == [
        "pip install . && scanmesh demo\n",
        "bash .ci/run\n",
    ]
    assert "virtual environment" in setup and "four minutes" in setup
    assert "-o DIR" in setup  # where the demo writes


def test_the_readme_names_merge_and_read_conf_with_a_conf_file():
    tour = _section("A short tour")
    assert "scanmesh.merge(" in tour and "read_conf(" in tour and ".conf" in tour
    assert "scanmesh merge part.conf" in tour


# the tour


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
    assert {"part.stl", "scan.xyz"} <= {p.name for p in folder.iterdir()}
    scan = scanmesh.read(folder / "scan.xyz")
    assert 5_000 < len(scan.points) < 20_000 and len(np.unique(scan.line_ids)) > 100


@pytest.mark.slow
def test_the_tours_scan_is_curved_and_the_methods_differ_on_it(folder):
    """Not a flat part (where every tac is 0 and every method gives the same picture)."""
    base = scanmesh.reconstruct(folder / "scan.xyz", "delaunay")
    annealed = scanmesh.reconstruct(base.scan, "anneal", initial=base, seed=0)
    assert base.quality.tac_1 > 50.0
    assert annealed.quality.tac_1 < 0.5 * base.quality.tac_1


@pytest.fixture(scope="module")
def python_tour(folder):
    (code,) = _blocks("python")
    cwd = os.getcwd()
    os.chdir(folder)
    try:
        namespace: dict = {}
        exec(compile(code, str(README), "exec"), namespace)
    finally:
        os.chdir(cwd)
    return namespace


@pytest.mark.slow
def test_the_python_tour_runs_and_shows_annealing_ahead_of_delaunay(folder, python_tour):
    base, annealed, part = python_tour["base"], python_tour["annealed"], python_tour["part"]
    from scanmesh.evaluate.truth import height_error

    assert annealed.quality.tac_1 < 0.3 * base.quality.tac_1  # the comment says 0.21 x
    assert height_error(annealed, part)["h_rms"] < 0.8 * height_error(base, part)["h_rms"]
    assert (folder / "fandisk.ply").is_file()
    assert python_tour["auto"].options["method_choice"]["chosen"] == "strips-anneal"


@pytest.mark.slow
def test_the_tours_tac_picture_shows_two_different_panels(folder, python_tour):
    path = folder / "tac.png"
    assert drawn_share(path) > DRAWN_SHARE
    with Image.open(path) as image:
        pixels = np.asarray(image.convert("L")).astype(float)
    half = pixels.shape[1] // 2
    left, right = pixels[:, :half], pixels[:, half : 2 * half]
    assert np.abs(left - right).mean() > 2.0  # Delaunay's bright creases, annealing's dark


@pytest.mark.slow
def test_the_tours_conf_file_puts_every_view_where_it_was(folder, python_tour):
    """The .conf the tour writes (world = R(q)ᵀ p + t) read back by read_conf's default."""
    written = python_tour["views"]
    read = scanmesh.read_conf(folder / "part.conf")
    assert len(read) == len(written) == 6
    for view, again in zip(written, read, strict=True):
        np.testing.assert_allclose(again.world, view.world, atol=1e-9)
    closed = python_tour["closed"]
    assert closed.face_labels is not None and len(closed.face_labels) == len(closed.faces)


@pytest.mark.slow
def test_the_command_tour_runs_and_its_pictures_show_the_part(folder, python_tour):
    (block,) = [b for b in _blocks("sh") if "scanmesh compare" in b]
    for argv in _commands(block):
        _run(argv, folder)
    assert (folder / "mesh.ply").is_file() and (folder / "closed.ply").is_file()
    for name in ("mesh.png", "top.png", "methods.png", "mesh_tac.png"):
        assert drawn_share(folder / name) > DRAWN_SHARE, name
