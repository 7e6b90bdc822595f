"""Stand-in for dask-strips' _output.py (the lead takes theirs): blocks of faces."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np


@dataclass
class FaceBlock:
    """Faces of one partition over global point indices, with their corners."""

    faces: np.ndarray  # (m,3) int64 global point indices
    corners: np.ndarray  # (m,3,3) float64 corner coordinates
    sums: dict[str, float]  # additive quality sums
