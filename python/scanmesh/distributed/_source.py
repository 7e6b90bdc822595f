"""Stand-in for dask-strips' _source.py (the lead takes theirs): parts of a scan."""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np


@dataclass(frozen=True)
class Part:
    """One file of consecutive scan lines."""

    index: int
    path: str | None
    offset: int  # global index of its first point
    count: int


def load_part(part: Part) -> tuple[np.ndarray, np.ndarray]:
    """(points (n, 3) float64, line_ids (n,) int64) of a part; runs on a worker."""
    assert part.path is not None
    points = np.load(part.path).astype(np.float64)
    lines = Path(part.path).with_suffix(".lines.npy")
    ids = np.load(lines).astype(np.int64) if lines.exists() else np.zeros(len(points), np.int64)
    return points, ids
