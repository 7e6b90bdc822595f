"""Scan points as a file gives them: :class:`ScanPoints`, what every reader returns."""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from scanmesh.errors import ScanmeshError
from scanmesh.formats.georef import Georef


def count_lines(ids: np.ndarray) -> int:
    """Number of distinct ids in (N,) integer ``ids``: O(N) when they never decrease (files
    list their lines in order), a sort otherwise."""
    if len(ids) < 2:
        return len(ids)
    steps = np.diff(ids)
    if (steps >= 0).all():
        return int(np.count_nonzero(steps)) + 1
    return int(len(np.unique(ids)))


#: The per-point colour channels, in the order they are written, as PLY names them.
COLOR_CHANNELS: tuple[str, ...] = ("red", "green", "blue", "alpha")


def checked_point_data(data: Mapping[str, Any] | None, n: int) -> dict[str, np.ndarray]:
    """``data`` as a dict of (n,) numeric arrays (booleans as uint8), or ScanmeshError naming
    the first value that is not one, or a name that is not one word."""
    out: dict[str, np.ndarray] = {}
    for name, values in (data or {}).items():
        if not isinstance(name, str) or not name or len(name.split()) != 1 or not name.isascii():
            raise ScanmeshError(f"point_data names must be single ASCII words, got {name!r}")
        arr = np.asarray(values)
        if arr.dtype == np.bool_:
            arr = arr.astype(np.uint8)
        if arr.shape != (n,) or arr.dtype.kind not in "iuf":
            raise ScanmeshError(
                f"point_data[{name!r}] must hold one number per point ({n},), got"
                f" {arr.dtype} {arr.shape}"
            )
        out[name] = arr
    return out


def colors_of(point_data: Mapping[str, np.ndarray]) -> np.ndarray | None:
    """(N, 3) or (N, 4) uint8 RGB(A) colours from ``point_data``'s ``red``, ``green``,
    ``blue`` (and ``alpha``) channels, or None when it lacks one of the three. Channels of
    a wider type (16-bit LAS colours) are scaled to 0..255 by their type's range."""
    if not all(c in point_data for c in COLOR_CHANNELS[:3]):
        return None
    names = [c for c in COLOR_CHANNELS if c in point_data]
    out = np.empty((len(point_data["red"]), len(names)), dtype=np.uint8)
    for k, name in enumerate(names):
        values = point_data[name]
        if values.dtype.kind == "f":  # 0..1 floats, as PCL and Open3D keep them
            out[:, k] = np.clip(np.rint(values * 255.0), 0, 255)
        elif values.dtype.itemsize > 1:
            top = np.iinfo(values.dtype).max if values.max(initial=0) > 255 else 255
            out[:, k] = np.clip(np.rint(values * (255.0 / top)), 0, 255)
        else:
            out[:, k] = values
    return out


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
    #: per-point values the file carried besides the coordinates, by name, each (N,) in the
    #: file's number type: colours as ``red``, ``green``, ``blue`` (``alpha``) uint8,
    #: scalars such as ``intensity`` or ``quality``; written to PLY with the mesh
    point_data: dict[str, np.ndarray] = field(default_factory=dict)
    #: the coordinate reference system and units the file records (LAS/LAZ, USGS DEM,
    #: PLY written by scanmesh), else None
    georef: Georef | None = None

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
        object.__setattr__(self, "point_data", checked_point_data(self.point_data, len(pts)))

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
