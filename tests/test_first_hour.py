"""What a newcomer meets in the first hour: a mesh of slivers from columns read in the wrong
order, extras missing only at the end, flags spoken in the command's words, warnings under
--quiet, a height grid's cell, Surface.save's endings and reconstruct's help."""

from __future__ import annotations

import inspect
import json
import re
import shutil
import subprocess
import sys
import warnings
from pathlib import Path

import numpy as np
import pytest

import scanmesh
from conftest import DATA
from scanmesh.cli import main
from scanmesh.errors import DegenerateInputError, MissingExtraError, ScanmeshWarning
from scanmesh.formats.write import FORMATS


@pytest.fixture(scope="module")
def swapped(tmp_path_factory) -> Path:
    """The embedded rod scan written as a user's file with the columns line, z, x, y and no header:
    read as x, y, z its line ids are x, whole numbers a unit apart."""
    points, lines = scanmesh.load_rod()
    path = tmp_path_factory.mktemp("swapped") / "rod.xyz"
    table = np.column_stack([lines, points[:, 2], points[:, 0], points[:, 1]])
    np.savetxt(path, table, fmt="%.6f")
    return path


def test_a_mesh_of_slivers_from_swapped_columns_is_said_with_its_likely_cause(swapped):
    points = scanmesh.read(swapped).points
    with pytest.warns(scanmesh.SliversWarning) as caught:
        surface = scanmesh.reconstruct(points, "shortest-path")
    assert surface.quality.sliver_fraction > 0.99  # the mesh is what the warning says
    text = str(caught[0].message)
    assert "x: 116 whole numbers from 0 to 115" in text and "columns='line,z,x,y'" in text
    assert "plane=" in text
    # the same file in the right order: no such warning
    rod = scanmesh.load_rod()[0]
    with warnings.catch_warnings():
        warnings.simplefilter("error", scanmesh.SliversWarning)
        scanmesh.reconstruct(rod, "shortest-path")
    # trimmed Delaunay keeps nothing there: its error names the columns too
    with pytest.raises(DegenerateInputError, match=r"left no triangle.*columns='line,z,x,y'"):
        scanmesh.reconstruct(points, "delaunay")


def test_the_command_says_the_slivers_and_the_columns_in_its_flags(swapped, tmp_path, capsys):
    assert main(["reconstruct", str(swapped), "-o", str(tmp_path / "m.stl")]) == 0
    err = capsys.readouterr().err
    said = [line for line in err.splitlines() if "slivers" in line]
    assert len(said) == 1 and said[0].startswith("scanmesh: warning: 100 % of the triangles")
    assert "--columns 'line,z,x,y'" in said[0] and "columns=" not in said[0]
    assert main(["info", str(swapped)]) == 1  # a scan's info triangulates it: same advice
    err = capsys.readouterr().err
    assert "left no triangle" in err and "--columns 'line,z,x,y'" in err and "max_edge" not in err


def test_quiet_silences_warnings_and_the_report_keeps_them(tmp_path, capsys):
    np.save(tmp_path / "rod.npy", scanmesh.load_rod()[0])
    report = tmp_path / "r.json"
    args = ["reconstruct", str(tmp_path / "rod.npy"), "-o", str(tmp_path / "m.stl")]
    args += ["--method", "delaunay", "--plane", "1,0,1", "--report", str(report)]
    assert main([*args, "-q"]) == 0
    assert capsys.readouterr().err == ""
    kept = json.loads(report.read_text())["warnings"]
    assert any("steep" in w for w in kept), kept  # seen edge-on: warned, in the report only


@pytest.fixture
def no_matplotlib(monkeypatch):
    """matplotlib hidden, as in an install without the "plots" extra."""
    for name in [m for m in sys.modules if m == "matplotlib" or m.startswith("matplotlib.")]:
        monkeypatch.delitem(sys.modules, name)
    monkeypatch.setitem(sys.modules, "matplotlib", None)


def test_compare_says_a_missing_extra_before_any_work(no_matplotlib, monkeypatch, capsys, swapped):
    def no_work(*args, **kwargs):
        raise AssertionError("the scan was read before the missing extra was said")

    monkeypatch.setattr("scanmesh.cli.compare.planar_scan", no_work)
    monkeypatch.setattr("scanmesh.cli.compare.TrueSurface", no_work)
    cad = DATA / "cad" / "conrod_slevin48_onshape.stl"
    code = main(["compare", str(swapped), "--truth", str(cad), "--picture", "/tmp/never.png"])
    out, err = capsys.readouterr()
    assert code == 1 and out == ""
    assert "scanmesh[plots]" in err and "leave out --picture" in err


def test_compare_prints_its_table_whatever_happens_to_the_picture(monkeypatch, tmp_path, capsys):
    def broken(*args, **kwargs):
        raise OSError(28, "No space left on device")

    monkeypatch.setattr("scanmesh.cli.compare.render_compare", broken)
    points, _ = scanmesh.load_rod()
    np.save(tmp_path / "rod.npy", points[:3000])
    code = main(
        ["compare", str(tmp_path / "rod.npy"), "--methods", "delaunay", "--holdout", "0",
         "--picture", str(tmp_path / "p.png")]
    )  # fmt: skip
    out, err = capsys.readouterr()
    assert code == 1
    assert re.search(r"^delaunay\s+\d", out, re.M), out  # the table's row
    assert "No space left on device" in err and not (tmp_path / "p.png").exists()


def test_render_color_says_no_bar_needs_no_extra(no_matplotlib, tmp_path, capsys):
    points, _ = scanmesh.load_rod()
    mesh = tmp_path / "rod.stl"
    scanmesh.reconstruct(points[:2000], "delaunay").save(mesh)
    picture = tmp_path / "rod.png"
    assert main(["render", str(mesh), "-o", str(picture), "--color", "height"]) == 1
    err = capsys.readouterr().err
    assert "scanmesh[plots]" in err and "--no-bar" in err and not picture.exists()
    args = ["render", str(mesh), "-o", str(picture), "--color", "height", "--no-bar"]
    assert main(args) == 0 and picture.stat().st_size > 0


def test_the_extra_is_named_by_the_api_too(no_matplotlib):
    from scanmesh._extras import require

    with pytest.raises(MissingExtraError, match=r'scanmesh\[plots\]"; or try this'):
        require("matplotlib.figure", "plots", "a picture", instead="try this")


def test_a_grid_without_a_cell_says_that_cells_of_one_are_assumed(tmp_path, capsys):
    path = tmp_path / "heights.txt"
    np.savetxt(path, np.arange(20.0).reshape(4, 5))
    with pytest.warns(ScanmeshWarning, match="cells of 1.*cell="):
        scan = scanmesh.read(path, grid=True)
    assert scan.points[:, 0].max() == 4.0
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        assert scanmesh.read(path, grid=True, cell=0.5).points[:, 0].max() == 2.0
    assert main(["info", str(path), "--grid"]) == 0
    err = capsys.readouterr().err
    assert "cells of 1" in err and "--cell" in err and "cell=" not in err


def test_the_command_names_its_flags_where_the_user_typed_them(tmp_path, capsys):
    path = tmp_path / "heights.txt"
    np.savetxt(path, np.arange(20.0).reshape(4, 5))
    assert main(["info", str(path), "--grid", "--columns", "0,1,2"]) == 1
    err = capsys.readouterr().err
    assert "--grid reads a matrix of heights and takes only --cell, not --columns" in err, err
    assert main(["info", str(path), "--cell", "2"]) == 1
    err = capsys.readouterr().err
    assert "--cell does not apply" in err and "(--grid reads a matrix of heights)" in err, err
    assert "=" not in err.split("error:", 1)[1], err


def test_surface_save_lists_every_ending_it_writes(tmp_path):
    surface = scanmesh.reconstruct(scanmesh.load_rod()[0][:500], "delaunay")
    with pytest.raises(scanmesh.ParameterError) as caught:
        surface.save(tmp_path / "m.xyz")
    listed = set(re.findall(r"\.\w+", str(caught.value).split("use one of", 1)[1]))
    assert listed == {*FORMATS, ".glb", ".htm", ".html"}
    for ending in sorted(listed):  # and each one listed is written
        assert surface.save(tmp_path / f"m{ending}").stat().st_size > 0


def test_compare_judges_grid_without_calling_it_failed(capsys):
    scan = DATA / "scans" / "steps_range_grid.ply"
    assert main(["compare", str(scan), "--methods", "grid", "delaunay"]) == 0
    out, err = capsys.readouterr()
    assert "failed" not in err, err
    assert re.search(r"^grid\s+\d", out, re.M) and "grid: no holdout:" in out, out


def test_reconstruct_help_keeps_its_parameters_together():
    """In numpydoc, every line of the Parameters section at the section's indent names a
    parameter (``name : type`` or ``**options``): no paragraph sits between two."""
    doc = inspect.getdoc(scanmesh.reconstruct)
    section = doc.split("Parameters\n----------\n", 1)[1].split("\n\nReturns\n", 1)[0]
    flush = [line for line in section.splitlines() if line and not line.startswith(" ")]
    strays = [line for line in flush if not re.match(r"^(\*\*)?\w+( : .+)?$", line)]
    assert strays == [] and "lines : (N,) int, optional" in flush


def _ci_run(tmp_path: Path, *args: str, ci: str | None = None) -> tuple[int, list[str]]:
    """``.ci/run ARGS`` with every program it calls replaced by one that logs its name:
    (exit status, the programs called)."""
    repo = tmp_path / "repo"
    (repo / ".ci").mkdir(parents=True, exist_ok=True)
    shutil.copy(Path(__file__).resolve().parents[1] / ".ci" / "run", repo / ".ci" / "run")
    fake = tmp_path / "bin"
    fake.mkdir(exist_ok=True)
    log = tmp_path / "calls.txt"
    log.write_text("")
    for name in ("python3", "cargo", "apt-get"):
        (fake / name).write_text(f'#!/bin/sh\necho "{name} $*" >> "{log}"\n')
    (fake / "id").write_text("#!/bin/sh\necho 0\n")  # as root, where apt-get could install
    (fake / "dirname").write_text('#!/bin/sh\necho "${1%/*}"\n')
    for tool in fake.iterdir():
        tool.chmod(0o755)
    env = {"PATH": str(fake), "HOME": str(tmp_path)} | ({"CI": ci} if ci else {})
    done = subprocess.run(
        [shutil.which("bash") or "/bin/bash", str(repo / ".ci" / "run"), *args],
        env=env,
        capture_output=True,
        text=True,
        timeout=60,
    )
    return done.returncode, log.read_text().splitlines()


@pytest.mark.skipif(sys.platform == "win32", reason="a bash script")
def test_the_test_command_installs_system_packages_only_on_ci_or_when_asked(tmp_path):
    code, calls = _ci_run(tmp_path)
    assert code == 0 and not any(c.startswith("apt-get") for c in calls), calls
    assert any("pytest" in c for c in calls)  # and it still runs every test
    assert not any("not slow" in c for c in calls), calls
    for args, ci in (((), "true"), (("--with-chromium",), None)):
        code, calls = _ci_run(tmp_path, *args, ci=ci)
        assert code == 0 and any(c.startswith("apt-get install") for c in calls), calls
    code, calls = _ci_run(tmp_path, "--bogus")
    assert code == 2 and calls == []


@pytest.mark.slow
def test_compare_truth_is_a_stage_a_log_shows(tmp_path, monkeypatch, capsys):
    """The height and domain error against --truth took seconds per method with nothing in a
    log; it is a stage like the others (its end said once it was reported)."""
    import scanmesh._progress as progress_module

    cad = DATA / "cad" / "conrod_slevin48_onshape.stl"
    points, lines = scanmesh.simulate_scan(cad, n_points=3000)
    np.savetxt(tmp_path / "scan.xyz", np.column_stack([points, lines]))
    monkeypatch.setattr(progress_module, "LOG_INTERVAL_SECONDS", 0.0)
    args = ["compare", str(tmp_path / "scan.xyz"), "--truth", str(cad), "--methods", "delaunay"]
    assert main(args) == 0
    err = capsys.readouterr().err
    assert re.search(r"^scanmesh: truth: 100,000 samples in one native call", err, re.M), err
    assert re.search(r"^scanmesh: truth: 100,000 samples done in .* samples/s$", err, re.M), err


def test_the_quick_run_has_its_marker_registered_and_documented():
    """``-m "not slow"`` is the contributor's quick run: the marker is declared (an unknown
    one is an error) and CONTRIBUTING.md says how to run it."""
    root = Path(__file__).resolve().parents[1]
    config = (root / "pyproject.toml").read_text()
    assert re.search(r'^\s*"slow: ', config, re.M) and "--strict-markers" in config
    guide = (root / "CONTRIBUTING.md").read_text()
    assert 'python -m pytest -q -m "not slow"' in guide
