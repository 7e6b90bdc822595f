"""Progress in logs: with stderr not a terminal, a long stage writes a line (stage,
done / total, time left) at least every LOG_INTERVAL_SECONDS."""

from __future__ import annotations

import threading
import time

import numpy as np
import pytest

import scanmesh._progress as progress_module
from scanmesh._progress import LogProgress, Stage


class FakeClock:
    def __init__(self) -> None:
        self.now = 0.0

    def __call__(self) -> float:
        return self.now


def test_lines_every_interval_with_a_fake_clock():
    clock, lines = FakeClock(), []
    log = LogProgress(lines.append, interval=10.0, clock=clock, start=False)
    log(0, 1000, None, stage="delaunay")
    clock.now = 9.0
    log.tick()
    assert lines == []  # a short stage says nothing
    clock.now = 10.5
    log.tick()
    assert lines == [
        "scanmesh: delaunay: 0 / 1,000 points (0 %), 0 min 10 s elapsed, time left unknown"
    ]
    clock.now = 15.0
    log(500, 1000, None, stage="delaunay")  # within the interval: silent
    assert len(lines) == 1
    clock.now = 21.0
    log.tick()  # the rate so far: 500 in 21 s, 500 to go
    assert lines[-1] == (
        "scanmesh: delaunay: 500 / 1,000 points (50 %), 0 min 21 s elapsed, 24 points/s,"
        " about 0 min 21 s left"
    )
    clock.now = 24.0
    log(1000, 1000, None, stage="delaunay")  # reported while it ran: its end is said
    assert lines[-1] == "scanmesh: delaunay: 1,000 points done in 0 min 24 s, 42 points/s"
    clock.now = 100.0
    log.tick()
    assert len(lines) == 3  # finished: nothing more
    # annealing's own estimate of the time left wins over the rate
    log(10, 400, 3.5, stage="anneal", seconds_left=125.0)
    clock.now = 111.0
    log(20, 400, 3.4, stage="anneal", seconds_left=130.0)
    assert lines[-1] == (
        "scanmesh: anneal: 20 / 400 sweeps (5 %), 0 min 11 s elapsed, 1.8 sweeps/s,"
        " about 2 min 10 s left"
    )


def test_lines_come_further_apart_as_a_long_stage_goes_on():
    clock, lines = FakeClock(), []
    log = LogProgress(lines.append, interval=10.0, clock=clock, start=False)
    log(0, 10**6, None, stage="extract")
    times = []
    for second in range(1, 12 * 60 + 1):  # twelve minutes, ticked every second
        clock.now = float(second)
        log(second * 1000, 10**6, None, stage="extract")
        if len(lines) > len(times):
            times.append(second)
    gaps = np.diff(times)
    assert times[0] == 10 and gaps[0] == 10  # the first lines as before
    assert 15 <= len(times) <= 35 and gaps.max() <= 60 and gaps[-1] > 30, times
    assert all(b >= a for a, b in zip(gaps, gaps[1:], strict=False))
    # every line says how far, how fast and how long yet: the figures move
    assert "1,000 nodes/s" in lines[-1] and lines[-1].endswith("left")
    assert len(set(lines)) == len(lines)


def test_a_blocking_stage_is_reported_while_it_runs():
    """One native call counts nothing until it returns: its lines say so and how long it has
    run (not "0 / 5,000 (0 %)" again and again), and its last line its total and rate."""
    lines: list[str] = []
    log = LogProgress(lines.append, interval=0.05)
    try:
        with Stage(log, "strips", 5000, blocking=True):
            time.sleep(0.4)  # one native call: no updates come
        seen = len(lines)
        time.sleep(0.2)
    finally:
        log.close()
    assert seen >= 3 and len(lines) == seen
    running, last = lines[:-1], lines[-1]
    assert all(
        line.startswith("scanmesh: strips: 5,000 points in one native call,")
        and "counts nothing until it returns" in line
        for line in running
    ), lines
    assert not any("(0 %)" in line for line in lines)
    assert last.startswith("scanmesh: strips: 5,000 points done in 0 min 00 s,"), last
    assert last.endswith("points/s")


def test_a_stage_of_nothing_is_not_reported_after_it_ends():
    """A stage of 0 items (trimming that kept no face) stayed the running stage once closed:
    the watcher wrote "trim: 0 faces in one native call" until the next stage began."""
    clock, lines = FakeClock(), []
    log = LogProgress(lines.append, interval=10.0, clock=clock, start=False)
    with Stage(log, "trim", 0, blocking=True):
        pass
    clock.now = 30.0
    log.tick()
    assert lines == []


def test_a_bar_is_drawn_in_a_terminal_without_a_size():
    """A pseudo-terminal that reports 0 columns (``script`` without a terminal around it):
    tqdm drew nothing there; the bar now gets a width of its own."""
    import os
    import pty
    import subprocess
    import sys

    code = (
        "import time\n"
        "from scanmesh._progress import Stage\n"
        "with Stage(True, 'delaunay', 100) as s:\n"
        "    for k in range(1, 101):\n"
        "        time.sleep(0.02)\n"
        "        s.update(k)\n"
    )
    main, child = pty.openpty()  # a fresh pty: 0 rows, 0 columns
    try:
        proc = subprocess.Popen([sys.executable, "-c", code], stderr=child, stdout=child)
        os.close(child)
        out = b""
        while True:
            try:
                chunk = os.read(main, 4096)
            except OSError:  # the child closed its end
                break
            if not chunk:
                break
            out += chunk
        assert proc.wait(timeout=60) == 0
    finally:
        os.close(main)
    assert b"delaunay:" in out and b"points/s]" in out, out  # a bar, drawn


def test_the_command_writes_progress_lines_to_a_log(tmp_path, monkeypatch, capsys):
    from scanmesh.cli import main

    rng = np.random.default_rng(0)
    x, y = np.meshgrid(np.linspace(0, 1, 40), np.linspace(0, 1, 30))
    z = 0.2 * np.sin(5 * x) * np.cos(3 * y) + rng.normal(0, 1e-3, x.shape)
    scan = tmp_path / "scan.xyz"
    np.savetxt(scan, np.column_stack([x.ravel(), y.ravel(), z.ravel()]))
    monkeypatch.setattr(progress_module, "LOG_INTERVAL_SECONDS", 0.0)
    before = set(threading.enumerate())
    code = main(["reconstruct", str(scan), "-o", str(tmp_path / "out.stl"), "--sweeps", "50"])
    err = capsys.readouterr().err
    assert code == 0
    lines = [line for line in err.splitlines() if " / " in line and "elapsed" in line]
    stages = {line.split(":")[1].strip() for line in lines}
    assert "anneal" in stages, err
    assert any("sweeps" in line and "left" in line for line in lines)
    assert "\r" not in err  # no bars in a log
    # no thread of the command outlives it (the earlier tests' threads are not its own)
    started = [t for t in threading.enumerate() if t not in before]
    for thread in started:
        thread.join(timeout=5)
    assert not [t.name for t in started if t.is_alive()]


def _counts(err: str, stage: str) -> tuple[list[int], list[str]]:
    """The done counts of ``stage``'s running lines in a log, and its closing lines."""
    running = [line for line in err.splitlines() if line.startswith(f"scanmesh: {stage}: ")]
    counts = [
        int(line.split(": ")[2].split(" / ")[0].replace(",", ""))
        for line in running
        if " / " in line
    ]
    return counts, [line for line in running if " done in " in line]


@pytest.mark.parametrize("method", ["delaunay", "shortest-path"])
def test_a_native_stage_counts_in_the_log_while_it_runs(method, tmp_path, monkeypatch, capsys):
    """Delaunay and the strips are one native call each: their lines said "in one native
    call" until it returned; the core now counts its passes and the log's lines advance."""
    from scanmesh.cli import main

    rng = np.random.default_rng(1)
    lines, per = 150, 800  # 120,000 points: a native call in a worker, about a second
    x = np.repeat(np.arange(lines) * 0.25, per)
    y = np.tile(np.linspace(0, 200, per), lines) + rng.normal(0, 0.01, lines * per)
    scan = tmp_path / "scan.xyz"
    np.savetxt(scan, np.column_stack([x, y, np.sin(x / 5) + np.cos(y / 30), x * 4]), fmt="%.4f")
    monkeypatch.setattr(progress_module, "LOG_INTERVAL_SECONDS", 0.0)  # a line per count
    out = tmp_path / "out.ply"
    args = ["reconstruct", str(scan), "-o", str(out), "--method", method, "--columns", "x y z line"]
    assert main(args) == 0
    err = capsys.readouterr().err
    stage = "delaunay" if method == "delaunay" else "strips"
    counts, closing = _counts(err, stage)
    assert f"{stage}: 120,000 points in one native call" not in err
    # the watcher repeats a count between two polls: never back, and forward at least twice
    assert counts == sorted(counts) and len(set(counts)) >= 3, counts
    assert counts[-1] <= lines * per
    assert closing == [closing[0]] and closing[0].startswith(
        f"scanmesh: {stage}: 120,000 points done"
    )


@pytest.mark.slow
def test_merge_extraction_counts_in_the_log_while_it_runs(tmp_path, monkeypatch, capsys):
    """merge's extraction said "0 %" (then "in one native call") for the whole stage."""
    import trimesh

    from conftest import write_views
    from scanmesh.cli import main
    from scanmesh.evaluate.digitizer import axis_views

    box = trimesh.creation.box((2.0, 1.0, 0.6))
    names, poses = write_views(axis_views(box, 0.012, noise=0.0002, seed=1), tmp_path)
    monkeypatch.setattr(progress_module, "LOG_INTERVAL_SECONDS", 0.0)
    out = tmp_path / "part.ply"
    assert main(["merge", *names, "--poses", str(poses), "-o", str(out)]) == 0
    counts, closing = _counts(capsys.readouterr().err, "extract")
    assert counts == sorted(counts) and len(set(counts)) >= 3, counts
    assert len(closing) == 1 and " nodes done in " in closing[0]


@pytest.mark.slow
def test_annealing_start_and_polish_count_in_the_log_while_they_run(tmp_path, monkeypatch, capsys):
    """Annealing's "calibrate" (the state, the descent to LOP's optimum, the chains' set-up)
    and "polish" were one silent native call each: 44 s and 7 s at 2M points. Here the
    start takes about two seconds and the polish a tenth, a few polls: the polish's counts
    are checked for order only (their reaching the total: the core's own tests)."""
    from scanmesh.cli import main

    rng = np.random.default_rng(2)
    lines, per = 150, 600  # 90,000 points: a start of about two seconds
    x = np.repeat(np.arange(lines) * 0.25, per)
    y = np.tile(np.linspace(0, 150, per), lines) + rng.normal(0, 0.01, lines * per)
    z = np.sin(x / 3) * np.cos(y / 20) + rng.normal(0, 0.002, lines * per)
    scan = tmp_path / "scan.xyz"
    np.savetxt(scan, np.column_stack([x, y, z]), fmt="%.4f")
    monkeypatch.setattr(progress_module, "LOG_INTERVAL_SECONDS", 0.0)  # a line per count
    out = tmp_path / "out.ply"
    args = ["reconstruct", str(scan), "-o", str(out), "--method", "anneal", "--sweeps", "1"]
    assert main(args) == 0
    err = capsys.readouterr().err
    for stage in ("calibrate", "polish"):
        counts, closing = _counts(err, stage)
        assert "one native call" not in " ".join(
            line for line in err.splitlines() if f": {stage}: " in line
        )
        assert counts == sorted(counts) and counts, (stage, counts)
        assert len(closing) == 1, (stage, closing)
    # the descent's LOP may reach most of its edges between two polls (seen: 0, then
    # 59,565, then done): one count past 0 before the closing line is
    # the log advancing while the call runs
    assert max(_counts(err, "calibrate")[0]) > 0
