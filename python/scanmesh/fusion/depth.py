"""A range view as a depth image: its points binned into the rays of a regular grid.

The scanner sits towards +z of the view's coordinates and its rays run along z, so a
point (x, y, z) is the return of the ray through (x, y); the pixel keeps the return
nearest the scanner (largest z). The grid's step is the view's own spacing (the median
distance from a point to its nearest neighbour across the rays), its origin on the
points' lattice, so a range grid maps one point to one pixel.

Normals come from the depth differences of neighbouring pixels: on each axis the
one-sided difference whose own neighbour agrees with it best (an ENO choice), so a pixel
next to a crease takes the slope of its own face, not the mean of both; differences over
:data:`JUMP_STEPS` pixel steps are depth jumps, not slopes.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.spatial import cKDTree

from scanmesh._core import JUMP_STEPS
from scanmesh._memory import describe_bytes, memory_room
from scanmesh.errors import DegenerateInputError, MemoryLimitError

#: Points whose nearest neighbour is measured for the spacing (a sample of larger views).
SPACING_SAMPLE = 20_000

#: Largest depth image built (pixels); a view finer than this over the part is refused.
MAX_PIXELS = 50_000_000

#: Peak bytes per pixel while a depth image is built: depth, cosine, normals and the
#: slopes' shifted copies (about twenty float64 arrays of the image's size).
BYTES_PER_PIXEL = 160


@dataclass(frozen=True)
class DepthImage:
    """A view's depth image over a window of its image plane."""

    #: scanner (x, y) of pixel (0, 0)
    origin: tuple[float, float]
    #: distance between neighbouring rays (scanner units)
    step: float
    #: (H, W) float64 scanner z of the nearest return per pixel, NaN where none
    depth: np.ndarray
    #: (H, W) float64 |cos| between the ray and the surface normal (1 where unknown)
    cos: np.ndarray
    #: (K,) int64 the points kept, one per pixel with a return
    kept: np.ndarray
    #: (K, 3) float64 unit normals of the kept points in scanner coordinates, towards +z
    normals: np.ndarray


def view_spacing(xy: np.ndarray, where: str = "a view", seed: int = 0) -> float:
    """Median distance from a point to its nearest other point across the rays (scanner
    x, y), on a sample of at most SPACING_SAMPLE points; DegenerateInputError naming
    ``where`` when no two points lie on different rays. O(N log N)."""
    if len(xy) < 2:
        raise DegenerateInputError(
            f"{where}: a view of {len(xy)} point has no spacing across its rays; a view needs"
            " at least 2 points on different rays"
        )
    tree = cKDTree(xy)
    rng = np.random.default_rng(seed)
    probe = xy if len(xy) <= SPACING_SAMPLE else xy[rng.choice(len(xy), SPACING_SAMPLE, False)]
    dist, _ = tree.query(probe, k=2)
    near = dist[:, 1][np.isfinite(dist[:, 1]) & (dist[:, 1] > 0)]
    if len(near) == 0:
        raise DegenerateInputError(
            f"{where}: the view's points all lie on one ray: no spacing across rays"
        )
    return float(np.median(near))


def depth_image(points: np.ndarray, step: float, window: np.ndarray) -> DepthImage:
    """The depth image of ``points`` (N, 3) (scanner coordinates) with ray spacing ``step``
    over ``window`` ((2, 2): min and max scanner x, y to cover), its pixels on the lattice
    of the first point. O(N log N + pixels)."""
    base = points[0, :2]
    first = base - np.ceil((base - window[0]) / step) * step
    size = np.floor((window[1] - first) / step).astype(np.int64) + 1
    width, height = int(size[0]), int(size[1])
    if width * height > MAX_PIXELS:
        raise MemoryLimitError(
            f"a depth image of {width} x {height} rays (spacing {step:g}) is over the"
            f" {MAX_PIXELS:,} allowed; use a larger voxel"
        )
    need, room = width * height * BYTES_PER_PIXEL, memory_room()
    if need > room.bytes:
        raise MemoryLimitError(
            f"a depth image of {width} x {height} rays needs about {describe_bytes(need)} of"
            f" memory, more than {room.limit}; use a larger voxel"
        )
    ij = np.rint((points[:, :2] - first) / step).astype(np.int64)
    inside = (ij >= 0).all(axis=1) & (ij[:, 0] < width) & (ij[:, 1] < height)
    index = np.flatnonzero(inside)
    flat = ij[index, 1] * width + ij[index, 0]
    order = np.lexsort((-points[index, 2], flat))  # per pixel, nearest the scanner first
    first_of = np.ones(len(order), dtype=bool)
    first_of[1:] = flat[order][1:] != flat[order][:-1]
    kept = index[order[first_of]]
    pixel = flat[order[first_of]]
    depth = np.full(width * height, np.nan)
    depth[pixel] = points[kept, 2]
    depth = depth.reshape(height, width)
    gx = _slope(depth, step, axis=1)
    gy = _slope(depth, step, axis=0)
    normal = np.stack([-gx, -gy, np.ones_like(gx)], axis=-1)
    normal /= np.linalg.norm(normal, axis=-1, keepdims=True)
    return DepthImage(
        origin=(float(first[0]), float(first[1])),
        step=float(step),
        depth=depth,
        cos=normal[..., 2].copy(),
        kept=kept,
        normals=normal.reshape(-1, 3)[pixel],
    )


def _slope(depth: np.ndarray, step: float, axis: int) -> np.ndarray:
    """dz/d(axis) per pixel: the one-sided difference whose next difference agrees with it
    best, depth jumps left out, 0 where no neighbour has a return."""
    pad = np.pad(depth, [(2, 2) if a == axis else (0, 0) for a in range(2)], constant_values=np.nan)
    n = depth.shape[axis]

    def shifted(k: int) -> np.ndarray:
        return np.take(pad, np.arange(2 + k, 2 + k + n), axis=axis)

    d = {k: shifted(k) for k in (-2, -1, 0, 1, 2)}
    jump = JUMP_STEPS * step
    back, back2 = d[0] - d[-1], d[-1] - d[-2]
    fwd, fwd2 = d[1] - d[0], d[2] - d[1]
    back = np.where(np.abs(back) <= jump, back, np.nan)
    fwd = np.where(np.abs(fwd) <= jump, fwd, np.nan)
    # disagreement with the next difference out; a missing one counts as large
    bad_back = np.nan_to_num(np.abs(back - back2), nan=np.inf)
    bad_fwd = np.nan_to_num(np.abs(fwd - fwd2), nan=np.inf)
    pick = np.where(bad_back <= bad_fwd, back, fwd)
    pick = np.where(np.isnan(pick), np.where(np.isnan(back), fwd, back), pick)
    return np.nan_to_num(pick, nan=0.0) / step
