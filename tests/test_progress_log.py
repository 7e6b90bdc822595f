"""Progress in logs: with stderr not a terminal, a long stage writes a line (stage,
done / total, time left) at least every LOG_INTERVAL_SECONDS."""

from __future__ import annotations

import threading
import time

import numpy as np

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
        "scanmesh: delaunay: 500 / 1,000 points (50 %), 0 min 21 s elapsed, about 0 min 21 s left"
    )
    log(1000, 1000, None, stage="delaunay")
    clock.now = 100.0
    log.tick()
    assert len(lines) == 2  # finished: nothing more
    # annealing's own estimate of the time left wins over the rate
    log(10, 400, 3.5, stage="anneal", seconds_left=125.0)
    clock.now = 111.0
    log(20, 400, 3.4, stage="anneal", seconds_left=130.0)
    assert lines[-1] == (
        "scanmesh: anneal: 20 / 400 sweeps (5 %), 0 min 11 s elapsed, about 2 min 10 s left"
    )


def test_a_blocking_stage_is_reported_while_it_runs():
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
    assert all(line.startswith("scanmesh: strips: 0 / 5,000 points (0 %)") for line in lines)


def test_the_command_writes_progress_lines_to_a_log(tmp_path, monkeypatch, capsys):
    from scanmesh.cli import main

    rng = np.random.default_rng(0)
    x, y = np.meshgrid(np.linspace(0, 1, 40), np.linspace(0, 1, 30))
    z = 0.2 * np.sin(5 * x) * np.cos(3 * y) + rng.normal(0, 1e-3, x.shape)
    scan = tmp_path / "scan.xyz"
    np.savetxt(scan, np.column_stack([x.ravel(), y.ravel(), z.ravel()]))
    monkeypatch.setattr(progress_module, "LOG_INTERVAL_SECONDS", 0.0)
    code = main(["reconstruct", str(scan), "-o", str(tmp_path / "out.stl"), "--sweeps", "50"])
    err = capsys.readouterr().err
    assert code == 0
    lines = [line for line in err.splitlines() if " / " in line and "elapsed" in line]
    stages = {line.split(":")[1].strip() for line in lines}
    assert "anneal" in stages, err
    assert any("sweeps" in line and "left" in line for line in lines)
    assert "\r" not in err  # no bars in a log
    assert threading.active_count() < 20
