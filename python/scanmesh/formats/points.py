"""Scan points as a file gives them: :class:`ScanPoints`, what every reader returns."""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from scanmesh.errors import ScanmeshError


def count_lines(ids: np.ndarray) -> int:
    """Number of distinct ids in (N,) integer ``ids``: O(N) when they never decrease (files
    list their lines in order), a sort otherwise."""
    if len(ids) < 2:
        return len(ids)
    steps = np.diff(ids)
    if (steps >= 0).all():
        return int(np.count_nonzero(steps)) + 1
    return int(len(np.unique(ids)))


@dataclass(frozen=True, eq=False)
class ScanPoints:
    """Points read from a file, in file order, with their scan lines when the file gives them."""

    #: (N, 3) float64 point coordinates in the file's units
    points: np.ndarray
    #: (N,) int64 scan-line id per point, or None; points with one id form one line, in order
    line_ids: np.ndarray | None
    #: the file the points came from
    source: Path
    #: format details: format name, units, where the line ids came from, ...
    extra: dict[str, Any] = field(default_factory=dict)
    #: (L, K) int64 range grid, or None: ``grid[i, j]`` is the index of the j-th point along
    #: scan line i (-1 where the scanner saw nothing); rows follow the line ids' order
    grid: np.ndarray | None = None
    #: (3,) float64 unit direction the digitizer looked down along, reversed (its ``up``),
    #: when the file records one (``# scanmesh up x y z``), else None
    up: np.ndarray | None = None

    def __post_init__(self) -> None:
        pts = np.asarray(self.points)
        if pts.ndim != 2 or pts.shape[1] != 3 or not np.issubdtype(pts.dtype, np.number):
            raise ScanmeshError(
                f"{self.source}: points must be an (N, 3) numeric array,"
                f" got {pts.dtype} {pts.shape}"
            )
        pts = np.ascontiguousarray(pts, dtype=np.float64)
        bad = ~np.isfinite(pts)
        if bad.any():
            row, col = np.argwhere(bad)[0]
            raise ScanmeshError(
                f"{self.source}: point {row} has a non-finite {'xyz'[col]}={float(pts[row, col])!r}"
            )
        object.__setattr__(self, "points", pts)
        if self.line_ids is not None:
            ids = np.asarray(self.line_ids)
            if ids.ndim != 1 or len(ids) != len(pts):
                raise ScanmeshError(
                    f"{self.source}: {len(ids) if ids.ndim == 1 else ids.shape} line ids"
                    f" do not match {len(pts)} points"
                )
            if ids.size and not np.issubdtype(ids.dtype, np.integer):
                raise ScanmeshError(f"{self.source}: line ids must be integers, got {ids.dtype}")
            object.__setattr__(self, "line_ids", np.ascontiguousarray(ids, dtype=np.int64))
        if self.grid is not None:
            grid = np.asarray(self.grid)
            if grid.ndim != 2 or grid.dtype.kind not in "iu":
                raise ScanmeshError(f"{self.source}: grid must be a 2-D integer array")
            grid = np.ascontiguousarray(grid, dtype=np.int64)
            if grid.size and (grid.max() >= len(pts) or grid.min() < -1):
                raise ScanmeshError(f"{self.source}: grid indices must be -1 or below {len(pts)}")
            object.__setattr__(self, "grid", grid)
        if self.up is not None:
            up = np.asarray(self.up, dtype=np.float64).reshape(-1)
            length = float(np.linalg.norm(up)) if up.shape == (3,) else 0.0
            if not np.isfinite(length) or length == 0.0:
                raise ScanmeshError(f"{self.source}: up must be a non-zero 3-vector, got {up}")
            object.__setattr__(self, "up", up / length)
        object.__setattr__(self, "source", Path(self.source))

    def __len__(self) -> int:
        return len(self.points)

    @property
    def n_lines(self) -> int:
        """Number of distinct scan lines (0 when the file gives none)."""
        return 0 if self.line_ids is None else count_lines(self.line_ids)

    def lines(self) -> list[np.ndarray]:
        """Point indices of each scan line, lines ordered by first appearance, points in file order.

        Returns
        -------
        list of (k,) int64
            Empty when the file gives no line ids.
        """
        if self.line_ids is None or not len(self.line_ids):
            return []
        ids = self.line_ids
        _, first, inverse = np.unique(ids, return_index=True, return_inverse=True)
        rank = np.empty(len(first), dtype=np.int64)
        rank[np.argsort(first, kind="stable")] = np.arange(len(first))
        order = np.argsort(rank[inverse], kind="stable")
        bounds = np.cumsum(np.bincount(rank[inverse], minlength=len(first)))[:-1]
        return np.split(order.astype(np.int64), bounds)

    def __repr__(self) -> str:
        return (
            f"ScanPoints(source={str(self.source)!r}, points={len(self.points)},"
            f" lines={self.n_lines if self.line_ids is not None else None})"
        )
