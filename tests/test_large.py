"""Large scans: progress of every stage, the text-file -> STL path end to end on a
100k-point synthetic scan (the 10M figures are in BENCHMARKS.md, from benches/large.py)."""

from __future__ import annotations

import struct
import sys
from collections import defaultdict
from pathlib import Path

import numpy as np
import pytest

import scanmesh
from scanmesh.cli import main

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "benches"))
from large import synthetic_xyz  # noqa: E402


class Recorder:
    """A stage-aware progress callback that keeps every call."""

    def __init__(self) -> None:
        self.calls: list[tuple[str, int, int, float | None]] = []

    def __call__(self, done: int, total: int, value: float | None, stage: str) -> None:
        self.calls.append((stage, done, total, value))

    def by_stage(self) -> dict[str, list[tuple[int, int, float | None]]]:
        out: dict[str, list] = defaultdict(list)
        for stage, done, total, value in self.calls:
            out[stage].append((done, total, value))
        return out

    def check_monotone(self) -> None:
        for stage, calls in self.by_stage().items():
            done = [d for d, _, _ in calls]
            totals = {t for _, t, _ in calls}
            assert len(totals) == 1, stage
            assert done == sorted(done), stage
            assert done[-1] == totals.pop(), stage


@pytest.fixture(scope="module")
def scan_file(tmp_path_factory) -> Path:
    path = tmp_path_factory.mktemp("large") / "scan.xyz"
    synthetic_xyz(path, 100_000, 100)
    return path


@pytest.mark.slow
def test_stage_progress_through_reconstruct(scan_file, monkeypatch):
    from scanmesh.formats import table
    from scanmesh.formats.write import save_mesh

    monkeypatch.setattr(table, "CHUNK_BYTES", 1 << 19)
    rec = Recorder()
    surface = scanmesh.reconstruct(scan_file, "shortest-path", plane="z", progress=rec)
    rec.check_monotone()
    stages = [s for s, *_ in rec.calls]
    assert list(dict.fromkeys(stages)) == ["read", "lines", "strips", "steep"]
    assert len(rec.by_stage()["read"]) > 3  # per chunk, not only start and end
    out = scan_file.with_suffix(".stl")
    surface_rec = Recorder()
    save_mesh(out, surface.vertices, surface.faces, progress=surface_rec)
    surface_rec.check_monotone()
    assert surface_rec.by_stage()["write"][-1][:2] == (len(surface.faces), len(surface.faces))


def test_stage_progress_through_delaunay_and_annealing():
    rng = np.random.default_rng(3)
    pts = np.column_stack([rng.random((3000, 2)), rng.random(3000) * 0.001])
    rec = Recorder()
    scanmesh.reconstruct(pts, "anneal", plane="z", sweeps=20, patience=0, progress=rec)
    rec.check_monotone()
    stages = rec.by_stage()
    assert list(stages) == ["delaunay", "trim", "noise", "calibrate", "anneal", "polish", "steep"]
    assert all(isinstance(v, float) for _, _, v in stages["anneal"])
    # the original convention still sees annealing only
    legacy = []
    scanmesh.reconstruct(
        pts,
        "anneal",
        plane="z",
        sweeps=5,
        patience=0,
        progress=lambda done, total, energy: legacy.append(total),
    )
    assert legacy and set(legacy) == {legacy[-1]}


def test_progress_callback_with_kwargs_sees_every_stage(scan_file):
    seen = []
    scanmesh.reconstruct(
        scan_file, "delaunay", plane="z", progress=lambda *a, **k: seen.append(k["stage"])
    )
    assert list(dict.fromkeys(seen)) == ["read", "delaunay", "trim", "steep"]


@pytest.mark.slow
def test_command_end_to_end_on_100k_points(scan_file, tmp_path, capsys):
    out = tmp_path / "mesh.stl"
    report = tmp_path / "report.json"
    assert (
        main(
            [
                "reconstruct",
                str(scan_file),
                "-o",
                str(out),
                "--method",
                "shortest-path",
                "--plane",
                "z",
                "--report",
                str(report),
                "--quiet",
            ]
        )
        == 0
    )
    data = out.read_bytes()
    (count,) = struct.unpack("<I", data[80:84])
    assert len(data) == 84 + 50 * count and count > 190_000
    import json

    rep = json.loads(report.read_text())
    assert rep["counts"]["faces"] == count and rep["counts"]["lines"] == 100
    assert {"read", "strips", "write"} <= set(rep["timings"])
    assert capsys.readouterr().err == ""  # --quiet: no bars, no remarks


def test_every_stage_of_an_annealing_command_reports(tmp_path, monkeypatch, capsys):
    """The command's whole annealing run, stage by stage: nothing that can take long on a
    large scan (the noise estimate, the annealer's start, the polish after the annealing
    bar, the quality report, the preview) runs without progress."""
    from scanmesh import cli

    scan = synthetic_xyz(tmp_path / "small.xyz", 3000, 30)
    rec = Recorder()
    monkeypatch.setattr(cli._Console, "progress", property(lambda self: rec))
    out = tmp_path / "small.stl"
    args = ["reconstruct", str(scan), "-o", str(out), "--plane", "z", "--sweeps", "3"]
    assert main([*args, "--method", "anneal", "--preview", str(tmp_path / "small.png")]) == 0
    rec.check_monotone()
    assert list(rec.by_stage()) == [
        "read",
        "delaunay",
        "trim",
        "noise",
        "calibrate",
        "anneal",
        "polish",
        "steep",
        "write",
        "quality",
        "preview",
    ]
    capsys.readouterr()


def test_collinear_check_on_many_points_uses_every_point():
    """The strided sample only short-cuts the rank-2 case: collinear input still raises,
    and one point off the line (which the sample misses) still counts."""
    from scanmesh.stages.strips import RANK_SAMPLE, _spans_plane

    n = 3 * RANK_SAMPLE + 7
    t = np.linspace(0.0, 1.0, n)
    line = np.column_stack([t, 2 * t + 1])
    assert not _spans_plane(line)
    off = line.copy()
    off[n - 2, 1] += 0.5
    assert _spans_plane(off)
    pts = np.column_stack([line, np.zeros(n)])
    with pytest.raises(scanmesh.DegenerateInputError, match="collinear"):
        scanmesh.reconstruct(pts, "shortest-path", lines=np.arange(n) // 1000, plane="z")


def test_steep_fraction_matches_the_angle_formula():
    """The native cosine form gives the share the atan2 of every triangle gives."""
    from scanmesh.scan import steep as steep_module

    rng = np.random.default_rng(5)
    verts = rng.normal(size=(400, 3)) * [1.0, 1.0, 0.7]
    faces = rng.integers(0, 400, size=(3000, 3))
    faces[:5, 1] = faces[:5, 0]  # degenerate triangles: tilt 0, not steep
    normal = np.array([0.3, -0.2, 0.9])
    fn = np.cross(verts[faces[:, 1]] - verts[faces[:, 0]], verts[faces[:, 2]] - verts[faces[:, 0]])
    unit = normal / np.linalg.norm(normal)
    tilt = np.degrees(np.arctan2(np.linalg.norm(np.cross(fn, unit), axis=1), fn @ unit))
    expect = float((tilt > steep_module.STEEP_ANGLE_DEG).mean())
    assert 0.2 < expect < 0.8
    assert steep_module.steep_fraction(verts, faces, normal) == expect
    # column-major arrays take the binding's copying path: same count
    tilt_limit = np.radians(steep_module.STEEP_ANGLE_DEG)
    count = scanmesh._core.steep_count(
        np.asfortranarray(verts), np.asfortranarray(faces), normal, tilt_limit
    )
    assert count / len(faces) == expect
    bad = faces.copy()
    bad[7, 2] = 400
    with pytest.raises(scanmesh.InvalidMeshError, match="face 7"):
        steep_module.steep_fraction(verts, bad, normal)
    bad[7, 2] = -1
    with pytest.raises(scanmesh.InvalidMeshError, match="face 7"):
        steep_module.steep_fraction(verts, bad, normal)
