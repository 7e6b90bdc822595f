"""Shared fixtures: where the real data lives, and small synthetic scans."""

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

#: The real models and scans the tests read, inside the repository (tests/data/ATTRIBUTION.md
#: names each file's source, licence and SHA-256). The only place a test finds its data.
DATA = Path(__file__).resolve().parent / "data"


def bumpy_patch(n: int, seed: int) -> np.ndarray:
    """(n, 3) points of a smooth height field z = f(x, y) at random planar positions."""
    rng = np.random.default_rng(seed)
    xy = rng.random((n, 2))
    z = 0.3 * np.sin(6 * xy[:, 0]) * np.cos(4 * xy[:, 1]) + 0.2 * xy[:, 0] ** 2
    return np.column_stack([xy, z])


def write_views(views: list, folder: Path) -> tuple[list[str], Path]:
    """Each scanned view (``evaluate.digitizer`` scans) written as ``v{k}.xyz`` in its own
    frame (looking along its ``up``) and the poses back to the world as ``poses.json``:
    the files of ``scanmesh merge v0.xyz ... --poses poses.json``."""
    import json

    from scanmesh.fusion.views import toward_frame

    names, poses = [], []
    for k, scan in enumerate(views):
        turn = toward_frame(scan.up)
        np.savetxt(folder / f"v{k}.xyz", scan.points @ turn.T)
        pose = np.eye(4)
        pose[:3, :3] = turn.T
        names.append(str(folder / f"v{k}.xyz"))
        poses.append(pose.tolist())
    (folder / "poses.json").write_text(json.dumps(poses))
    return names, folder / "poses.json"


@pytest.fixture(scope="session")
def rod_scan() -> tuple[np.ndarray, np.ndarray]:
    """The embedded connecting-rod scan (`scanmesh.load_rod`): (points, line_ids)."""
    import scanmesh

    return scanmesh.load_rod()


def seconds_to_interrupt(script: str, wait: float) -> float:
    """Run ``script`` in a child; after it prints "started" and ``wait`` seconds pass, send
    SIGINT; return how long the child took to reach its ``except KeyboardInterrupt``."""
    # A child started from a background job inherits SIGINT ignored, and Python then keeps
    # it ignored: the child would never see the interrupt and readline() would wait for
    # ever. Python's own handler is put back first, as in an interactive shell.
    restore = "import signal\nsignal.signal(signal.SIGINT, signal.default_int_handler)\n"
    proc = subprocess.Popen(
        [sys.executable, "-c", restore + textwrap.dedent(script)], stdout=subprocess.PIPE, text=True
    )
    try:
        assert proc.stdout.readline().strip() == "started"
        time.sleep(wait)
        sent = time.monotonic()
        os.kill(proc.pid, signal.SIGINT)
        line = proc.stdout.readline().split()
        assert proc.wait(timeout=60) == 0
    finally:
        proc.kill()
    assert line and line[0] == "interrupted", line
    return float(line[1]) - sent


def cyberware_range_grid(
    rows: int,
    cols: int,
    step: float,
    vertices: list[str],
    cells: list[str],
    comment: str | None = None,
) -> str:
    """The text of an ASCII Cyberware range-grid PLY: ``vertices`` ("x y z" lines), the
    ``rows * cols`` range_grid ``cells`` ("0": no sample, "1 i": vertex i), frames
    ``step`` (``echo_lgincr``) apart, and an optional header ``comment``."""
    head = ["ply", "format ascii 1.0"] + ([f"comment {comment}"] if comment else [])
    head += [
        "obj_info is_cyberware_data 1",
        f"obj_info num_cols {cols}",
        f"obj_info num_rows {rows}",
        f"obj_info echo_lgincr {step}",
        f"element vertex {len(vertices)}",
        "property float x",
        "property float y",
        "property float z",
        f"element range_grid {rows * cols}",
        "property list uchar int vertex_indices",
        "end_header",
    ]
    return "\n".join(head + vertices + cells) + "\n"
