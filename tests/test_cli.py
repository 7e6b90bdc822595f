"""The ``scanmesh`` command, run as users run it (``python -m scanmesh ...`` in a subprocess),
and the height-error measure (``scanmesh.evaluate.truth``) that ``scanmesh compare --truth``
prints."""

from __future__ import annotations

import importlib.util
import json
import os
import re
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest
import trimesh
from PIL import Image

import scanmesh
from conftest import DATA
from scanmesh.evaluate.holdout import holdout_error
from scanmesh.evaluate.truth import TrueSurface, height_error, point_triangle_distance

CONROD = DATA / "cad" / "conrod_slevin48_onshape.stl"

QUALITY_KEYS = ("tac_1", "tac_2", "tac_inf", "min_angle_deg", "sliver_fraction")
COMPARE_KEYS = ("method", "time_s", *QUALITY_KEYS)
HEIGHT_KEYS = ("h_rms", "h_mean", "h_max")
DOMAIN_KEYS = ("air_share", "missed_share")


def run(*args: str | os.PathLike, cwd: Path | None = None, timeout: float = 300):
    """``python -m scanmesh ARGS`` with captured text output."""
    return subprocess.run(
        [sys.executable, "-m", "scanmesh", *map(str, args)],
        capture_output=True,
        text=True,
        cwd=cwd,
        timeout=timeout,
    )


def assert_failed(result, code: int = 1) -> str:
    """Exit status ``code``; for bad input exactly one line on stderr, and never a traceback."""
    assert result.returncode == code, (result.stdout, result.stderr)
    assert "Traceback" not in result.stderr
    if code == 1:
        lines = result.stderr.strip().splitlines()
        assert len(lines) == 1 and lines[0].startswith("scanmesh: error: "), result.stderr
        assert result.stdout == ""
    return result.stderr


def grid_scan(nx: int = 20, ny: int = 15) -> tuple[np.ndarray, np.ndarray]:
    """A paraboloid cap sampled line by line: (N, 3) points and (N,) line ids."""
    x, y = np.meshgrid(np.linspace(0.0, 1.0, nx), np.linspace(0.0, 0.75, ny))
    z = 0.3 * (x**2 + y**2)
    points = np.column_stack([x.ravel(), y.ravel(), z.ravel()])
    return points, np.repeat(np.arange(ny), nx)


def write_xyz(path: Path, points: np.ndarray, line_ids: np.ndarray | None = None) -> Path:
    cols = points if line_ids is None else np.column_stack([points, line_ids])
    fmt = ["%.17g"] * 3 + (["%d"] if line_ids is not None else [])
    np.savetxt(path, cols, fmt=fmt)
    return path


def load_mesh(path: Path) -> trimesh.Trimesh:
    mesh = trimesh.load_mesh(path, process=False)
    assert isinstance(mesh, trimesh.Trimesh)
    assert len(mesh.faces) > 0
    return mesh


def assert_png(path: Path, size: tuple[int, int] | None = None) -> None:
    assert path.is_file()
    with Image.open(path) as image:
        assert image.format == "PNG"
        if size is not None:
            assert image.size == size


def no_partial_files(folder: Path) -> bool:
    return not any(p.name.endswith(".part") for p in folder.iterdir())


@pytest.fixture(scope="module")
def scan(tmp_path_factory) -> Path:
    """A small scan file: 300 points on 15 lines with a line-id column."""
    folder = tmp_path_factory.mktemp("scan")
    return write_xyz(folder / "cap.xyz", *grid_scan())


@pytest.fixture(scope="module")
def cap_truth(tmp_path_factory) -> Path:
    """The paraboloid the small scan samples, finely triangulated (its true surface)."""
    x, y = np.meshgrid(np.linspace(-0.05, 1.05, 111), np.linspace(-0.05, 0.8, 86))
    v = np.column_stack([x.ravel(), y.ravel(), 0.3 * (x.ravel() ** 2 + y.ravel() ** 2)])
    k = np.arange(110 * 85)
    i, j = k % 110 + (k // 110) * 111, k % 110 + (k // 110) * 111 + 111
    faces = np.concatenate([np.column_stack([i, i + 1, j]), np.column_stack([i + 1, j + 1, j])])
    path = tmp_path_factory.mktemp("truth") / "cap.stl"
    trimesh.Trimesh(v, faces, process=False).export(path)
    return path


@pytest.fixture(scope="module")
def rod_scan(tmp_path_factory) -> Path:
    """``scanmesh simulate`` of the connecting rod along its thickness axis (about 1,500 points)."""
    out = tmp_path_factory.mktemp("rod") / "rod.xyz"
    result = run("simulate", CONROD, "-o", out, "--up", "y", "--along", "x", "--n-points", 1500)
    assert result.returncode == 0, result.stderr
    return out


# --------------------------------------------------------------------------- usage errors


@pytest.mark.slow
def test_help_and_version():
    result = run("--help")
    assert result.returncode == 0
    for command in ("reconstruct", "compare", "simulate", "info", "render", "demo"):
        assert command in result.stdout
    result = run("--version")
    assert result.returncode == 0 and result.stdout.startswith("scanmesh ")


@pytest.mark.slow
@pytest.mark.parametrize(
    "args",
    [
        [],
        ["frobnicate"],
        ["reconstruct", "scan.xyz"],  # no -o
        ["reconstruct", "scan.xyz", "-o", "out.stl", "--method", "magic"],
        ["reconstruct", "scan.xyz", "-o", "out.stl", "--plane", "sideways"],
        ["reconstruct", "scan.xyz", "-o", "out.stl", "--method", "lop", "--sweeps", "20"],
        ["reconstruct", "scan.xyz", "-o", "out.stl", "--method", "delaunay", "--tiles", "2"],
        ["simulate", "part.stl", "-o", "s.xyz", "--spacing", "0.1", "--n-points", "100"],
    ],
    ids=lambda a: " ".join(a) or "nothing",
)
def test_usage_errors_exit_2(args, tmp_path):
    result = run(*args, cwd=tmp_path)
    assert_failed(result, code=2)
    assert "usage:" in result.stderr
    assert list(tmp_path.iterdir()) == []


# --------------------------------------------------------------------------- bad input


@pytest.mark.slow
@pytest.mark.parametrize(
    "name, content",
    [
        ("missing.xyz", None),
        ("empty.xyz", b""),
        ("words.xyz", b"x y z\nthis is not a scan\n" * 200),
        ("ragged.xyz", b"0 0 0\n1 0 0\n1 1\n"),
        ("binary.xyz", bytes(range(256)) * 8),
        ("points.unknown", b"0 0 0\n1 0 0\n0 1 0\n"),
        ("line.xyz", b"0 0 0\n1 0 0\n2 0 0\n3 0 0\n"),  # collinear: nothing to triangulate
    ],
)
def test_bad_scan_files_exit_1_with_one_line(name, content, tmp_path):
    source = tmp_path / name
    if content is not None:
        source.write_bytes(content)
    assert_failed(run("reconstruct", source, "-o", tmp_path / "out.stl", "--sweeps", "20"))
    assert not (tmp_path / "out.stl").exists()
    assert no_partial_files(tmp_path)


@pytest.mark.slow
def test_bad_files_for_the_other_commands(tmp_path):
    junk = tmp_path / "junk.stl"
    junk.write_bytes(b"solid nothing\nendsolid nothing\n")
    assert_failed(run("info", tmp_path / "nowhere.xyz"))
    assert_failed(run("render", junk, "-o", tmp_path / "p.png"))
    assert_failed(run("simulate", tmp_path / "nowhere.stl", "-o", tmp_path / "s.xyz"))
    assert_failed(run("compare", tmp_path / "nowhere.xyz", "--methods", "delaunay"))
    assert sorted(p.name for p in tmp_path.iterdir()) == ["junk.stl"]


@pytest.mark.slow
def test_unwritable_output_exits_1(scan, tmp_path):
    message = assert_failed(run("reconstruct", scan, "-o", tmp_path / "no" / "such" / "out.stl"))
    assert "does not exist" in message
    message = assert_failed(run("reconstruct", scan, "-o", tmp_path / "out.vrml"))
    assert ".vrml" in message
    message = assert_failed(
        run("reconstruct", scan, "-o", tmp_path / "o.stl", "--preview", "p.jpg")
    )
    assert "png" in message.lower()
    assert list(tmp_path.iterdir()) == []


@pytest.mark.slow
def test_reconstruct_refuses_to_overwrite_its_input(tmp_path):
    points, _ = grid_scan()
    # a PLY of points is both a scan the readers take and a mesh ending the writer takes
    cloud = tmp_path / "scan.ply"
    trimesh.PointCloud(points).export(cloud)
    before = cloud.read_bytes()
    sub = tmp_path / "sub"
    sub.mkdir()
    for target in (cloud, sub / ".." / "scan.ply"):
        message = assert_failed(run("reconstruct", cloud, "-o", target, "--method", "delaunay"))
        assert "input" in message
    os.symlink(cloud, tmp_path / "alias.ply")
    assert_failed(run("reconstruct", cloud, "-o", tmp_path / "alias.ply", "--method", "delaunay"))
    # the report and the preview may not name the input either
    assert_failed(
        run(
            "reconstruct",
            cloud,
            "-o",
            tmp_path / "m.stl",
            "--report",
            cloud,
            "--method",
            "delaunay",
        )
    )
    assert cloud.read_bytes() == before
    assert not (tmp_path / "m.stl").exists()
    assert no_partial_files(tmp_path)


# --------------------------------------------------------------------------- reconstruct


@pytest.mark.slow
def test_reconstruct_writes_mesh_report_and_preview(scan, tmp_path):
    out, report, preview = tmp_path / "cap.stl", tmp_path / "cap.json", tmp_path / "cap.png"
    result = run(
        "reconstruct",
        scan,
        "-o",
        out,
        "--sweeps",
        20,
        "--tiles",
        2,
        "--seed",
        3,
        "--report",
        report,
        "--preview",
        preview,
    )
    assert result.returncode == 0, result.stderr
    assert "anneal" in result.stdout and "tac_1" in result.stdout
    mesh = load_mesh(out)
    data = json.loads(report.read_text())
    assert data["method"] == "anneal"
    assert data["options"]["sweeps"] == 20 and data["options"]["seed"] == 3
    assert data["options"]["tiles"] == 2
    assert set(QUALITY_KEYS) <= set(data["quality"])
    assert data["counts"]["points"] == 300 and data["counts"]["lines"] == 15
    assert data["counts"]["faces"] == len(mesh.faces)
    assert data["time_s"] > 0 and "read" in data["timings"]
    assert_png(preview)
    assert no_partial_files(tmp_path)


@pytest.mark.slow
def test_reconstruct_without_quality_writes_the_same_mesh(scan, tmp_path):
    """--no-quality skips the measurement only: same faces, the report's quality null (and
    the summary says so), the other figures as with it."""
    runs = {}
    for flag in ((), ("--no-quality",)):
        out = tmp_path / f"cap{len(flag)}.stl"
        result = run("reconstruct", scan, "-o", out, "--method", "shortest-path", "--json", *flag)
        assert result.returncode == 0, result.stderr
        runs[flag] = (json.loads(result.stdout), load_mesh(out))
    (full, a), (light, b) = runs[()], runs[("--no-quality",)]
    np.testing.assert_array_equal(a.faces, b.faces)
    assert set(QUALITY_KEYS) <= set(full["quality"]) and "quality" in full["timings"]
    assert light["quality"] is None and "quality" not in light["timings"]
    assert light["counts"] == full["counts"]
    text = run(
        "reconstruct", scan, "-o", tmp_path / "t.stl", "--method", "delaunay", "--no-quality"
    )
    assert text.returncode == 0, text.stderr
    assert "quality not measured" in text.stdout and "tac_1" not in text.stdout


def test_reconstruct_whose_quality_runs_out_of_memory_warns_and_succeeds(
    scan, tmp_path, monkeypatch, capsys
):
    """The quality is measured beside the write; when it runs out of memory the mesh is
    written and whole, so the command warns, reports ``"quality": null`` and exits 0 (it
    exited 1 after writing the mesh)."""
    from scanmesh import surface as surface_module
    from scanmesh.cli import main

    def no_room(*args, **kwargs):
        raise scanmesh.MemoryLimitError("tac of 300 points needs about 9 GiB")

    monkeypatch.setattr(surface_module, "quality", no_room)
    out, report = tmp_path / "cap.stl", tmp_path / "cap.json"
    argv = ["reconstruct", str(scan), "-o", str(out), "--report", str(report)]
    assert main([*argv, "--method", "delaunay"]) == 0
    captured = capsys.readouterr()
    assert "quality not measured (out of memory)" in captured.out
    assert "warning: the quality was not measured (out of memory: tac of 300" in captured.err
    data = json.loads(report.read_text())
    assert data["quality"] is None and "quality" not in data["timings"]
    assert any("quality was not measured" in w for w in data["warnings"])
    mesh = load_mesh(out)
    assert len(mesh.faces) == data["counts"]["faces"] > 0
    assert no_partial_files(tmp_path)


@pytest.mark.slow
@pytest.mark.parametrize("ending", [".ply", ".obj", ".off"])
def test_reconstruct_writes_each_mesh_format(scan, tmp_path, ending):
    out = tmp_path / f"cap{ending}"
    result = run("reconstruct", scan, "-o", out, "--method", "delaunay", "--json", "--quiet")
    assert result.returncode == 0, result.stderr
    data = json.loads(result.stdout)  # --json: the report and nothing else
    mesh = load_mesh(out)
    assert data["counts"]["faces"] == len(mesh.faces)
    assert len(mesh.vertices) == 300


@pytest.mark.slow
def test_reconstruct_same_seed_same_mesh(scan, tmp_path):
    a, b = tmp_path / "a.ply", tmp_path / "b.ply"
    for out in (a, b):
        result = run("reconstruct", scan, "-o", out, "--sweeps", 20, "--seed", 7, "--plane", "z")
        assert result.returncode == 0, result.stderr
    np.testing.assert_array_equal(load_mesh(a).faces, load_mesh(b).faces)


def test_reconstruct_options_reach_the_method(scan, tmp_path):
    out = tmp_path / "hull.stl"
    result = run(
        "reconstruct",
        scan,
        "-o",
        out,
        "--method",
        "lop",
        "--max-edge",
        "inf",
        "--plane",
        "0,0,1",
        "--json",
    )
    assert result.returncode == 0, result.stderr
    data = json.loads(result.stdout)
    assert data["method"] == "lop"
    # the whole convex hull of a 20 x 15 grid: 2 x 19 x 14 triangles
    assert data["counts"]["faces"] == 2 * 19 * 14 == len(load_mesh(out).faces)


@pytest.mark.slow
def test_reconstruct_time_limit_stops_annealing_and_is_reported(tmp_path):
    rng = np.random.default_rng(4)
    xy = rng.random((3000, 2))
    scan_file = write_xyz(tmp_path / "bumps.xyz", np.column_stack([xy, np.sin(6 * xy[:, 0])]))
    out, report = tmp_path / "bumps.stl", tmp_path / "bumps.json"
    args = ["reconstruct", scan_file, "-o", out, "--plane", "z", "--sweeps", "1000000"]
    result = run(*args, "--patience", "0", "--time-limit", "0.5", "--report", report)
    assert result.returncode == 0, result.stderr
    data = json.loads(report.read_text())
    assert data["options"]["stopped"] == "time_limit" and data["options"]["time_limit"] == 0.5
    assert data["counts"]["sweeps_run"] < 1_000_000
    assert data["options"]["energy"] <= data["options"]["initial_energy"]
    assert len(load_mesh(out).faces) == data["counts"]["faces"]
    # without the flag the schedule ends the run, and a bad limit names the flag and value
    result = run(*args[:-2], "--sweeps", "3", "--json")
    assert result.returncode == 0, result.stderr
    assert json.loads(result.stdout)["options"]["stopped"] == "sweeps"
    for bad in ("-1", "nan", "inf", "0"):
        message = assert_failed(run(*args, "--time-limit", bad))
        expected = rf"--time-limit must be a (finite )?number > 0, got {float(bad)!r}"
        assert re.search(expected, message)
    assert list(tmp_path.glob("*.part")) == []


# --------------------------------------------------------------------------- compare


@pytest.mark.slow
def test_compare_json_has_every_key(scan, cap_truth, tmp_path):
    methods = ["delaunay", "lop", "anneal"]
    result = run(
        "compare",
        scan,
        "--truth",
        cap_truth,
        "--methods",
        *methods,
        "--sweeps",
        20,
        "--json",
        "--picture",
        tmp_path / "cmp.png",
    )
    assert result.returncode == 0, result.stderr
    data = json.loads(result.stdout)
    assert [row["method"] for row in data["methods"]] == methods
    for row in data["methods"]:
        for key in (*COMPARE_KEYS, *HEIGHT_KEYS, *DOMAIN_KEYS):
            assert isinstance(row[key], (int, float, str)), key
        # the scan samples the truth, so the meshes are close to it (chords of a paraboloid)
        assert 0 < row["h_mean"] <= row["h_rms"] <= row["h_max"] < 0.01
        # the truth reaches 0.05 past the scan on every side: a band missed, no air
        assert row["air_share"] < 0.002
        assert 0.1 < row["missed_share"] < 0.3
    assert "air" in data["domain_error"]["measure"]
    assert_png(tmp_path / "cmp.png")


@pytest.mark.slow
def test_compare_table_without_truth(scan):
    result = run("compare", scan, "--methods", "delaunay", "anneal", "--sweeps", 20)
    assert result.returncode == 0, result.stderr
    lines = result.stdout.splitlines()
    header = next(line for line in lines if line.startswith("method"))
    for column in ("time", "tac_1", "tac_2", "tac_inf", "min angle", "slivers"):
        assert column in header
    assert "h_rms" not in header
    assert any(line.startswith("delaunay") for line in lines)
    assert any(line.startswith("anneal") for line in lines)
    assert "holdout rms" in header
    result = run("compare", scan, "--methods", "delaunay", "--json")
    row = json.loads(result.stdout)["methods"][0]
    assert not set(HEIGHT_KEYS + DOMAIN_KEYS) & set(row)


@pytest.mark.slow
def test_compare_without_truth_reports_the_holdout_error(scan):
    points = scanmesh.read(scan)
    result = run("compare", scan, "--methods", "delaunay", "shortest-path", "--json", "--seed", 3)
    assert result.returncode == 0, result.stderr
    data = json.loads(result.stdout)
    assert data["holdout_error"]["fraction"] == 0.1
    for row in data["methods"]:
        # the same seeded withholding through the API gives the same figures
        expected = holdout_error(
            points.points, row["method"], fraction=0.1, seed=3, lines=points.line_ids
        )
        assert row["holdout_rms"] == pytest.approx(expected["rms"])
        assert row["holdout_outside"] == expected["outside"]
        assert 0 < row["holdout_rms"] <= row["holdout_p99"] * 2
    off = json.loads(run("compare", scan, "--methods", "delaunay", "--holdout", 0, "--json").stdout)
    assert "holdout_rms" not in off["methods"][0] and "holdout_error" not in off
    refused = run("compare", scan, "--holdout", 1)
    assert refused.returncode == 2 and "--holdout" in refused.stderr


@pytest.mark.skipif(
    importlib.util.find_spec("scanmesh.stages.strips") is None, reason="strip methods not built yet"
)
def test_compare_runs_every_method_by_default(scan):
    result = run("compare", scan, "--sweeps", 20, "--json")
    assert result.returncode == 0, result.stderr
    methods = [row["method"] for row in json.loads(result.stdout)["methods"]]
    # an xyz file has no range grid: no "grid" row (it would fail)
    assert methods == ["delaunay", "lookahead", "shortest-path", "lop", "anneal"]


def test_compare_runs_the_grid_on_a_gridded_scan_by_default():
    ply = DATA / "scans" / "steps_range_grid.ply"
    result = run("compare", ply, "--sweeps", 5, "--holdout", 0, "--json")
    assert result.returncode == 0, result.stderr
    rows = json.loads(result.stdout)["methods"]
    assert [row["method"] for row in rows] == [
        "delaunay",
        "grid",
        "lookahead",
        "shortest-path",
        "lop",
        "anneal",
    ]
    # the grid's row is the grid method's own mesh
    grid = scanmesh.reconstruct(ply, "grid")
    assert rows[1]["faces"] == len(grid.faces)


def test_compare_reports_a_failing_method_and_goes_on(tmp_path):
    # the exact method refuses more than MAX_OPTIMAL_POINTS (400) points
    big = write_xyz(tmp_path / "big.xyz", *grid_scan(25, 20))
    result = run("compare", big, "--methods", "delaunay", "optimal", "--json")
    assert result.returncode == 1
    data = json.loads(result.stdout)
    assert [row["method"] for row in data["methods"]] == ["delaunay"]
    assert "optimal" in data["failed"]
    lines = result.stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("scanmesh: optimal failed: ")
    assert "Traceback" not in result.stderr


# --------------------------------------------------------------------------- simulate, info


def test_simulate_writes_a_scan_that_reads_back(rod_scan):
    from scanmesh import read

    scan = read(rod_scan)
    assert abs(len(scan.points) - 1500) < 0.05 * 1500
    assert scan.n_lines > 10
    np.testing.assert_allclose(np.unique(np.round(scan.points[:, 1], 4)), [0.1969, 0.3937])


def test_simulate_noise_table_and_spacing(tmp_path):
    out = tmp_path / "noisy.xyz"
    result = run(
        "simulate",
        CONROD,
        "-o",
        out,
        "--up",
        "y",
        "--spacing",
        0.1,
        "--line-spacing",
        0.2,
        "--noise",
        0.001,
        "--table",
        "--seed",
        1,
        "--json",
    )
    assert result.returncode == 0, result.stderr
    data = json.loads(result.stdout)
    scan = scanmesh.read(out)  # a header row names x y z line; the up comment is read back
    rows = np.column_stack([scan.points, scan.line_ids])
    assert rows.shape == (data["points"], 4)
    assert len(np.unique(rows[:, 3])) == data["lines"]
    assert scan.up is not None and list(scan.up) == [0.0, 1.0, 0.0]
    # --table: rays that miss the rod (outside it, through its bores) touch the table at its
    # lowest y, -0.3937; noise moves every point a little along y
    table = np.abs(rows[:, 1] + 0.3937) < 0.01
    assert 0.2 * len(rows) < table.sum() < 0.9 * len(rows)
    assert np.std(rows[table, 1]) == pytest.approx(0.001, rel=0.2)


@pytest.mark.slow
def test_simulate_refuses_to_overwrite_the_mesh(tmp_path):
    copy = tmp_path / "rod.stl"
    copy.write_bytes(CONROD.read_bytes())
    assert_failed(run("simulate", copy, "-o", tmp_path / "rod.xyz" / ".." / "rod.stl"))
    assert_failed(run("simulate", copy, "-o", tmp_path / "rod.ply"))  # not a points ending
    assert copy.read_bytes() == CONROD.read_bytes()


@pytest.mark.slow
def test_info_text_and_json(rod_scan):
    result = run("info", rod_scan, "--json")
    assert result.returncode == 0, result.stderr
    data = json.loads(result.stdout)
    for key in ("points", "lines", "extent", "median_spacing", "steep_share", "noise"):
        assert key in data
    # a noise-free simulated scan: far below the spacing
    assert 0 <= data["noise"] < data["median_spacing"] / 200
    assert data["lines"] > 10
    assert len(data["extent"]["size"]) == 3
    assert data["extent"]["size"][0] == pytest.approx(5.6, abs=0.1)
    assert 0 < data["median_spacing"] < 0.2
    # rods walls are not sampled, but triangles bridging the recessed web are steep
    assert 0 < data["steep_share"] < 0.2
    text = run("info", rod_scan).stdout
    for word in ("points", "scan lines", "median spacing", "steep", "noise"):
        assert word in text


@pytest.mark.slow
def test_info_judges_a_mesh_file_by_the_same_criteria(tmp_path):
    import trimesh

    mesh = trimesh.load(CONROD)
    expected = scanmesh.quality(mesh.vertices, mesh.faces)
    for ending in (".stl", ".ply", ".obj"):
        path = tmp_path / f"m{ending}"
        mesh.export(path)
        result = run("info", path, "--json")
        assert result.returncode == 0, result.stderr
        data = json.loads(result.stdout)
        assert data["kind"] == "mesh" and data["faces"] == len(mesh.faces)
        assert data["quality"]["tac_1"] == pytest.approx(expected.tac_1, rel=1e-6)
        assert data["quality"]["sliver_fraction"] == pytest.approx(expected.sliver_fraction)
    assert "tac_1" in run("info", tmp_path / "m.stl").stdout


@pytest.mark.slow
def test_info_steep_share_of_a_flat_and_a_folded_scan(tmp_path):
    points, ids = grid_scan()
    flat = points.copy()
    flat[:, 2] = 0
    assert (
        json.loads(run("info", write_xyz(tmp_path / "f.xyz", flat), "--json").stdout)["steep_share"]
        == 0
    )
    wall = points.copy()
    # a sampled 87° ramp over 4 columns (a cliff between two columns would be a depth jump,
    # whose triangles trimming drops)
    wall[:, 2] = 5.0 * np.clip((wall[:, 0] - 0.4) / 0.2, 0.0, 1.0)
    data = json.loads(
        run("info", write_xyz(tmp_path / "w.xyz", wall), "--json", "--plane", "z").stdout
    )
    assert 0 < data["steep_share"] < 0.2


# --------------------------------------------------------------------------- render, demo


@pytest.mark.slow
def test_render_a_mesh(tmp_path):
    out = tmp_path / "rod.png"
    result = run("render", CONROD, "-o", out, "--size", "320x240", "--wire")
    assert result.returncode == 0, result.stderr
    assert_png(out, (320, 240))
    with Image.open(out) as image:
        pixels = np.asarray(image.convert("RGB"))
    assert (pixels != 255).any(axis=2).mean() > 0.05  # the part is drawn


@pytest.mark.slow
def test_demo_end_to_end(tmp_path):
    folder = tmp_path / "out"
    t0 = time.perf_counter()
    result = run("demo", "-o", folder, timeout=600)
    elapsed = time.perf_counter() - t0
    assert result.returncode == 0, result.stderr
    mesh = load_mesh(folder / "demo_part.stl")
    assert len(mesh.faces) > 15_000
    assert_png(folder / "demo_part.png", (2 * 800 + 12, 600))
    assert_png(folder / "demo_tac.png")
    assert "Delaunay" in result.stdout and "annealed" in result.stdout
    assert "tac_1" in result.stdout and "time" in result.stdout
    assert elapsed < 120, f"the demo took {elapsed:.0f} s"


@pytest.mark.slow
def test_demo_shows_annealing_winning_on_the_part(tmp_path):
    """The demo's point, in its own figures: on the creased part, annealing halves
    Delaunay's tac_1 and comes closer to the true surface (measured 0.21 x and 0.69 x)."""
    result = run("demo", "-o", tmp_path, "--json", timeout=600)
    assert result.returncode == 0, result.stderr
    figures = json.loads(result.stdout)
    d, a = figures["methods"]["delaunay"], figures["methods"]["anneal"]
    assert a["tac_1"] <= 0.5 * d["tac_1"]
    assert a["h_rms"] <= 0.8 * d["h_rms"]
    assert a["sliver_fraction"] <= 0.05
    assert len(figures["files"]) == 3 and figures["tac_scale"][0] == 0.0


# --------------------------------------------------------------------------- Ctrl-C


@pytest.mark.slow
@pytest.mark.skipif(not hasattr(os, "mkfifo"), reason="needs a named pipe")
def test_ctrl_c_exits_130_without_partial_output(tmp_path):
    source = tmp_path / "scan.xyz"
    os.mkfifo(source)  # the command blocks reading it: then it is past its imports
    out = tmp_path / "out.stl"
    proc = subprocess.Popen(
        [
            sys.executable,
            "-m",
            "scanmesh",
            "reconstruct",
            source,
            "-o",
            out,
            "--sweeps",
            "1000000",  # hours of work; 1e9 would be refused (more than 1e12 proposals)
        ],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
    )
    try:
        deadline = time.monotonic() + 120
        while True:  # opening a FIFO without blocking succeeds once a reader waits on it
            try:
                fd = os.open(source, os.O_WRONLY | os.O_NONBLOCK)
                break
            except OSError:
                assert proc.poll() is None, proc.communicate()
                assert time.monotonic() < deadline
                time.sleep(0.05)
        os.set_blocking(fd, True)
        points, ids = grid_scan()
        rows = "".join(
            f"{x!r} {y!r} {z!r} {i}\n" for (x, y, z), i in zip(points.tolist(), ids, strict=True)
        )
        os.write(fd, rows.encode())
        os.close(fd)
        time.sleep(1.5)  # annealing a million sweeps of many chains now
        assert proc.poll() is None
        proc.send_signal(signal.SIGINT)
        stdout, stderr = proc.communicate(timeout=60)
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.communicate()
    assert proc.returncode == 130
    assert stderr.strip().splitlines() == ["scanmesh: interrupted"]
    assert "Traceback" not in stderr
    assert not out.exists()
    assert no_partial_files(tmp_path)


# --------------------------------------------------------------------------- truth


def brute_distance(triangles: np.ndarray, points: np.ndarray) -> np.ndarray:
    return np.array(
        [
            point_triangle_distance(triangles, np.repeat(p[None], len(triangles), 0)).min()
            for p in points
        ]
    )


def test_point_triangle_distance_matches_trimesh_and_handles_degenerate_triangles():
    rng = np.random.default_rng(0)
    tri = rng.normal(size=(5000, 3, 3))
    pts = rng.normal(size=(5000, 3)) * 2
    tri[:50, 2] = tri[:50, 1]  # two corners coincide
    tri[50:100, 2] = 0.5 * (tri[50:100, 0] + tri[50:100, 1])  # collinear
    tri[100:150] = tri[100:150, :1]  # a point
    ref = np.linalg.norm(trimesh.triangles.closest_point(tri, pts) - pts, axis=1)
    np.testing.assert_allclose(point_triangle_distance(tri, pts), ref, rtol=0, atol=1e-12)


def test_true_surface_distance_is_exact():
    truth = TrueSurface(CONROD)
    rng = np.random.default_rng(1)
    lo, hi = truth.mesh.bounds
    near = truth.mesh.sample(300, seed=2) + rng.normal(size=(300, 3)) * 1e-3
    far = lo - (hi - lo) + rng.random((100, 3)) * 3 * (hi - lo)  # well outside too
    pts = np.concatenate([near, far])
    np.testing.assert_allclose(
        truth.distance(pts), brute_distance(truth.triangles, pts), rtol=0, atol=1e-12
    )


def test_height_error_of_a_plane_offset_along_its_normal():
    # the truth: a unit square at z = 0; the mesh: a smaller square at z = 0.01
    square = trimesh.Trimesh(
        [[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0]], [[0, 1, 2], [0, 2, 3]], process=False
    )
    lifted = (square.vertices * 0.5 + [0.25, 0.25, 0.01], square.faces)
    err = height_error(lifted, square, n_samples=1000, seed=0)
    assert err["n_samples"] == 1000 and "closest-point" in err["measure"]
    for key in HEIGHT_KEYS:
        assert err[key] == pytest.approx(0.01, abs=1e-12)
    assert height_error(square, square)["h_max"] < 1e-12
    # the same seed gives the same figures
    tilted = (square.vertices + [[0, 0, 0], [0, 0, 0.1], [0, 0, 0], [0, 0, 0]], square.faces)
    assert height_error(tilted, square, seed=5) == height_error(tilted, square, seed=5)
