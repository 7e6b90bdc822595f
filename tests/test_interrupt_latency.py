"""Ctrl-C ends the command within half a second in its long stages: merge's fusion and the
default's choice of method. Each case runs the command in a child whose progress lines
(every 0.2 s) say which stage runs; SIGINT goes out once the stage is named."""

from __future__ import annotations

import signal
import subprocess
import sys
import textwrap
import time
from pathlib import Path

import numpy as np
import pytest
import trimesh

from conftest import seconds_to_interrupt, write_views
from scanmesh.evaluate.digitizer import axis_views

CHILD = textwrap.dedent(
    """
    import signal, sys
    signal.signal(signal.SIGINT, signal.default_int_handler)  # not ignored in a background job
    import scanmesh._progress
    scanmesh._progress.LOG_INTERVAL_SECONDS = 0.2
    from scanmesh.cli import main
    sys.argv = ["scanmesh", *sys.argv[1:]]
    sys.exit(main())
    """
)


def seconds_to_exit(args: list[str], stage: str) -> tuple[float, subprocess.CompletedProcess]:
    """Start the command, send SIGINT at its first progress line of ``stage``; return the
    seconds until the process ended, and its outcome."""
    proc = subprocess.Popen(
        [sys.executable, "-c", CHILD, *args],
        stderr=subprocess.PIPE,
        stdout=subprocess.DEVNULL,
        text=True,
    )
    try:
        lines = []
        for line in proc.stderr:  # type: ignore[union-attr]
            lines.append(line)
            if line.startswith(f"scanmesh: {stage}:"):
                break
        else:
            raise AssertionError(f"no {stage} stage: {''.join(lines)[-800:]}")
        sent = time.monotonic()
        proc.send_signal(signal.SIGINT)
        rest = proc.stderr.read()  # type: ignore[union-attr]
        code = proc.wait(timeout=60)
        took = time.monotonic() - sent
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.wait()
    return took, subprocess.CompletedProcess(args, code, "", rest)


def test_ctrl_c_in_merge_ends_the_command_within_half_a_second(tmp_path):
    """929 ms before: the interpreter's shutdown waited beside the abandoned native call."""
    box = trimesh.creation.box((2.0, 1.0, 0.6))
    names, _ = write_views(axis_views(box, 0.008, noise=0.0002, seed=1), tmp_path)
    out = tmp_path / "part.ply"
    args = ["merge", *names, "--poses", str(tmp_path / "poses.json"), "-o", str(out)]
    # the blocks make integration quick: the extraction is the stage that lasts
    took, done = seconds_to_exit(args, "extract")
    assert done.returncode == 130, done.stderr
    assert done.stderr.strip().splitlines()[-1] == "scanmesh: interrupted"
    assert took < 0.5, took
    assert not out.exists()


@pytest.mark.parametrize("side", [450, 120])
def test_ctrl_c_while_the_default_chooses_ends_the_command_within_half_a_second(tmp_path, side):
    """A 20,000-point part (450 x 450 rays) held Ctrl-C 574 ms: LOP and the annealer's
    state ran holding the main thread (LOP called directly) or the GIL (the state built
    before the native call released it). Under 20,000 points (120 x 120) the first
    candidate is built on all points in a thread beside the judge: Ctrl-C still ends the
    command within half a second, writing nothing."""
    rng = np.random.default_rng(0 if side == 450 else 1)
    g = np.stack(np.meshgrid(np.arange(side), np.arange(side)), -1).reshape(-1, 2) * 1.0
    g += 0.01 * rng.random(g.shape)
    z = np.sin(g[:, 0] / 7) + 0.01 * rng.random(len(g))
    np.savetxt(tmp_path / "scan.xyz", np.c_[g, z, np.repeat(np.arange(side), side)], fmt="%.5f")
    out = tmp_path / "mesh.ply"
    took, done = seconds_to_exit(
        ["reconstruct", str(tmp_path / "scan.xyz"), "-o", str(out)], "choose"
    )
    assert done.returncode == 130, done.stderr
    assert took < 0.5, took
    assert not out.exists()


def test_ctrl_c_while_the_command_starts_exits_130_with_one_line(tmp_path):
    """The command imports numpy, scipy, trimesh and the core before it runs (1.3-1.8 s on
    a busy machine): a Ctrl-C then printed a KeyboardInterrupt traceback from inside some
    import, exit status 1 (the console script) or a death by SIGINT. Now it says the one
    line and exits 130, as everywhere else. SIGINT at moments through the first 1.5 s, on
    the console script (where installed beside this Python) and on ``python -m scanmesh``;
    from 0.25 s, after Python's own start (its site packages: 30-160 ms here)."""
    side = 300
    g = np.stack(np.meshgrid(np.arange(side), np.arange(side)), -1).reshape(-1, 2) * 1.0
    np.savetxt(tmp_path / "scan.xyz", np.c_[g, np.sin(g[:, 0] / 7)], fmt="%.5f")
    out = tmp_path / "mesh.ply"
    args = ["reconstruct", str(tmp_path / "scan.xyz"), "-o", str(out), "--quiet"]
    console = Path(sys.executable).with_name("scanmesh")
    starts = [[sys.executable, "-m", "scanmesh"]] + ([[str(console)]] if console.exists() else [])
    for start in starts:
        for moment in (0.25, 0.4, 0.55, 0.7, 0.85, 1.0, 1.15, 1.3, 1.5):
            proc = subprocess.Popen(
                [*start, *args],
                stdout=subprocess.DEVNULL,
                stderr=subprocess.PIPE,
                text=True,
                # Ctrl-C as in an interactive shell (a background job's children ignore it)
                preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_DFL),
            )
            try:
                time.sleep(moment)
                proc.send_signal(signal.SIGINT)
                _, err = proc.communicate(timeout=60)
            finally:
                proc.kill()
            lines = err.strip().splitlines()
            assert proc.returncode == 130, (start[-1], moment, proc.returncode, err[-800:])
            assert lines == ["scanmesh: interrupted"], (start[-1], moment, err[-800:])
            assert not out.exists()


def test_ctrl_c_while_the_pieces_of_a_large_mesh_are_counted_returns_within_half_a_second():
    """The merge command's report (each piece closed or not, its genus and holes) and
    ``scanmesh info`` count a mesh's edges with ``scanmesh.shape``. np.unique of the (E, 2)
    edge rows, and numpy's hashing np.unique of plain values, took seconds in one call
    that Ctrl-C could not interrupt (on a fused dragon of 1.48 million faces under load:
    1.6-1.7 s from the interrupt to the exception; the euler characteristic 9.6 s in all).
    A closed torus of 1.28 million faces and half of it, their edges counted over and over;
    SIGINT after 0.8 s."""
    script = """
    import sys, time
    import numpy as np
    from scanmesh import shape

    n = 800  # an n x n grid of vertices around a torus: 2 n^2 faces, genus 1
    i, j = [k.ravel() for k in np.meshgrid(np.arange(n), np.arange(n), indexing="ij")]
    i1, j1 = (i + 1) % n, (j + 1) % n
    a, b, c, d = i * n + j, i1 * n + j, i * n + j1, i1 * n + j1
    faces = np.concatenate([np.c_[a, b, d], np.c_[a, d, c]])
    band = faces[np.tile(i < n // 2, 2)]  # half the torus: a band with two rims
    assert shape.euler_characteristic(faces) == 0 and shape.is_watertight(faces)
    assert sorted(map(len, shape.boundary_loops(band))) == [n, n]
    print("started", flush=True)
    try:
        while True:
            shape.euler_characteristic(faces), shape.is_watertight(faces)
            shape.boundary_loops(band)
    except KeyboardInterrupt:
        print(f"interrupted {time.monotonic()!r}", flush=True)
        sys.exit(0)
    """
    assert seconds_to_interrupt(script, 0.8) < 0.5


def test_ctrl_c_while_the_quality_of_a_large_mesh_is_measured_returns_within_half_a_second():
    """``scanmesh.quality`` (the report of every command, Surface.save's measures) called
    the core's mesh_quality directly: one native call of 2 s on a torus of 5.1 million
    faces under load, Ctrl-C waiting for its end. SIGINT after 0.3 s."""
    script = """
    import sys, time
    import numpy as np
    import scanmesh

    n = 1600  # an n x n grid of vertices around a torus: 2 n^2 faces
    i, j = [k.ravel() for k in np.meshgrid(np.arange(n), np.arange(n), indexing="ij")]
    i1, j1 = (i + 1) % n, (j + 1) % n
    a, b, c, d = i * n + j, i1 * n + j, i * n + j1, i1 * n + j1
    faces = np.concatenate([np.c_[a, b, d], np.c_[a, d, c]])
    u, w = 2 * np.pi * i / n, 2 * np.pi * j / n
    points = np.c_[(3 + np.cos(w)) * np.cos(u), (3 + np.cos(w)) * np.sin(u), np.sin(w)]
    scanmesh.quality(points[:9], [[0, 1, 2]])  # the core's pool and numpy's C-API loaded
    print("started", flush=True)
    try:
        scanmesh.quality(points, faces)
    except KeyboardInterrupt:
        print(f"interrupted {time.monotonic()!r}", flush=True)
        sys.exit(0)
    print("finished", flush=True)
    """
    assert seconds_to_interrupt(script, 0.3) < 0.5


def test_ctrl_c_while_annealing_calibrates_long_on_few_points_returns_within_half_a_second():
    """Annealing's calibration ran on the main thread when its points were few, however
    many proposals ``calibration_samples`` asked of each chain: 60 points and 256,578
    samples (63 automatic chains, 16 million proposals) held Ctrl-C for 1.4-3.6 s (a
    fuzz case that needed 4.4 s). SIGINT 0.5 s into that calibration."""
    script = """
    import sys, time
    import numpy as np
    import scanmesh

    rng = np.random.default_rng(5)
    points = np.c_[rng.random((60, 2)), rng.random(60) * 0.1]
    scanmesh.reconstruct(points, "anneal", sweeps=1)  # the core's pool and numpy loaded
    print("started", flush=True)
    try:
        while True:
            scanmesh.reconstruct(points, "anneal", calibration_samples=256_578, sweeps=1)
    except KeyboardInterrupt:
        print(f"interrupted {time.monotonic()!r}", flush=True)
        sys.exit(0)
    """
    assert seconds_to_interrupt(script, 0.5) < 0.5
