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

Each return is given a trust in [0, 1] (:func:`trust`), as a scanner's physics suggests
(Curless & Levoy 1996 weight by the angle and ramp the weight down towards a range grid's
edges): a return at a grazing angle, on a silhouette or beside a depth jump is where a
triangulation scanner's spot is spread over several depths (mixed pixels, the ragged
fringe); a return with hardly any neighbour on its surface is an outlier.
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

#: Pixels from the edge of the returns (a pixel without return, or across a depth jump)
#: over which the trust ramps up to 1 from :data:`EDGE_TRUST` on the edge itself.
EDGE_PIXELS = 3.0

#: The trust of a return on the edge of the returns (before its agreement and angle): a
#: silhouette's returns are where a scanner's spot falls partly off the part, but on a
#: clean part they are its edges' only evidence.
EDGE_TRUST = 0.5

#: A return's second difference this many times the image's median one halves its trust.
ROUGH_SCALE = 4.0

#: Ray-to-normal cosines below this are not trusted (about 78°): the spot spreads over
#: five spacings and more along the ray.
GRAZING_COS = 0.2

#: Holes inside a view's returns up to the area of a disc of this radius (pixels) are not
#: read as rays that passed through empty space: a triangulation scanner loses its returns
#: where the camera does not see the laser's spot (shadows, dark or shiny spots, grazing
#: angles), so such a hole is no proof of empty space; carving along its rays bored
#: straight tunnels through the dragon (each a handle). A ray in such a hole shows empty
#: only the space in front of the hole's rim (a return of trust 0 at the rim's depth
#: nearest the scanner).
HOLE_PIXELS = 6.0

#: A return with fewer neighbours (of its 8) on its own surface (no depth jump between
#: them) is an isolated return, not trusted.
MIN_NEIGHBOURS = 2


@dataclass(frozen=True)
class DepthImage:
    """A view's depth image over a window of its image plane."""

    #: scanner (x, y) of pixel (0, 0)
    origin: tuple[float, float]
    #: distance between neighbouring rays (scanner units)
    step: float
    #: (H, W) float64 scanner z of the nearest return per pixel, NaN where none; a pixel
    #: without return near returns holds the nearest return's depth, at trust 0
    #: (:data:`HOLE_PIXELS`)
    depth: np.ndarray
    #: (H, W) float64 |cos| between the ray and the surface normal (1 where unknown)
    cos: np.ndarray
    #: (K,) int64 the points kept, one per pixel with a return
    kept: np.ndarray
    #: (K, 3) float64 unit normals of the kept points in scanner coordinates, towards +z
    normals: np.ndarray
    #: (K,) int64 the flat pixel (row-major) of each kept point
    pixels: np.ndarray
    #: (H, W) float64 trust in each return, in [0, 1] (:func:`trust`); 0 where none
    weight: np.ndarray


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
    depth = _fill_gaps(depth.reshape(height, width), JUMP_STEPS * step)
    gx = _slope(depth, step, axis=1)
    gy = _slope(depth, step, axis=0)
    normal = np.stack([-gx, -gy, np.ones_like(gx)], axis=-1)
    normal /= np.linalg.norm(normal, axis=-1, keepdims=True)
    cos = normal[..., 2].copy()
    weight = trust(depth, cos, step)
    return DepthImage(
        origin=(float(first[0]), float(first[1])),
        step=float(step),
        depth=_cover_holes(depth),
        cos=cos,
        kept=kept,
        normals=normal.reshape(-1, 3)[pixel],
        pixels=pixel,
        weight=weight,
    )


def trust(depth: np.ndarray, cos: np.ndarray, step: float) -> np.ndarray:
    """(H, W) trust in each return of a depth image (NaN: no return; ``cos`` the ray-to-
    normal cosines; ``step`` the ray spacing), in [0, 1], the product of:

    - agreement with its neighbours: the return's second difference along the row and the
      column (the larger, on one surface), against :data:`ROUGH_SCALE` times the image's
      median one: ``1 / (1 + (r / scale)²)`` (a mixed pixel or a stray return stands out
      of a surface its neighbours agree on; exact returns of a clean part all agree);
    - the distance from the edge of the returns (a pixel without return or a depth jump
      beside it): :data:`EDGE_TRUST` on the edge, rising linearly to 1 over
      :data:`EDGE_PIXELS`;
    - the angle: 0 under :data:`GRAZING_COS`, rising as the square root above it;

    0 for an isolated return (fewer than :data:`MIN_NEIGHBOURS` of its 8 neighbours on its
    surface). O(H · W)."""
    from scipy.ndimage import distance_transform_edt

    hit = ~np.isnan(depth)
    jump = JUMP_STEPS * step
    pad = np.pad(depth, 1, constant_values=np.nan)
    h, w = depth.shape

    def at(di: int, dj: int) -> np.ndarray:
        return pad[1 + di : 1 + di + h, 1 + dj : 1 + dj + w]

    near = np.zeros(depth.shape, dtype=np.int64)
    edge = ~hit
    with np.errstate(invalid="ignore"):
        for di in (-1, 0, 1):
            for dj in (-1, 0, 1):
                if di == 0 and dj == 0:
                    continue
                same = np.abs(at(di, dj) - depth) <= jump
                near += same
                if abs(di) + abs(dj) == 1:
                    edge |= hit & ~same
        second = [
            np.where(
                (np.abs(at(-di, -dj) - depth) <= jump) & (np.abs(at(di, dj) - depth) <= jump),
                np.abs(at(-di, -dj) - 2 * depth + at(di, dj)),
                np.nan,
            )
            for di, dj in ((1, 0), (0, 1))
        ]
    rough = np.fmax(second[0], second[1])
    known = np.isfinite(rough)
    # (a floor of a millionth of the step: the rounding of exact depths is no roughness)
    median = float(np.median(rough[known])) if known.any() else 0.0
    scale = max(ROUGH_SCALE * median, 1e-6 * step)
    agree = np.ones(depth.shape)
    agree[known] = 1.0 / (1.0 + (rough[known] / scale) ** 2)
    # distance in pixels to the nearest edge pixel (an edge pixel itself: 0)
    dist = distance_transform_edt(~edge) if edge.any() else np.full(depth.shape, np.inf)
    ramp = EDGE_TRUST + (1.0 - EDGE_TRUST) * np.clip(dist / EDGE_PIXELS, 0.0, 1.0)
    angle = np.clip((np.abs(cos) - GRAZING_COS) / (1.0 - GRAZING_COS), 0.0, 1.0)
    out = agree * ramp * np.sqrt(angle)
    out[hit & (near < MIN_NEIGHBOURS)] = 0.0
    out[~hit] = 0.0
    return out


def _cover_holes(depth: np.ndarray) -> np.ndarray:
    """``depth`` with each hole inside the returns (a run of pixels without return that
    does not reach the image's border, of at most the area of a disc of
    :data:`HOLE_PIXELS` radius) given the depth of the return nearest the scanner around
    it. The space beyond a silhouette is left to carve: there the rays did pass the part.
    O(H · W)."""
    from scipy.ndimage import binary_dilation, label, maximum

    miss = np.isnan(depth)
    if not miss.any() or miss.all():
        return depth
    runs, count = label(miss)
    sizes = np.bincount(runs.ravel(), minlength=count + 1)
    border = np.unique(np.concatenate([runs[0], runs[-1], runs[:, 0], runs[:, -1]]))
    small = sizes <= np.pi * HOLE_PIXELS**2
    small[0] = False
    small[border] = False
    if not small.any():
        return depth
    holes = small[runs]
    # each hole's rim: the returns beside it, and the nearest of them to the scanner
    rim = binary_dilation(holes, structure=np.ones((3, 3), bool)) & ~miss
    owner = np.zeros_like(runs)
    for di in (-1, 0, 1):
        for dj in (-1, 0, 1):
            shifted = np.roll(np.roll(np.where(holes, runs, 0), di, axis=0), dj, axis=1)
            owner = np.where(rim & (owner == 0), shifted, owner)
    ids = np.flatnonzero(small)
    top = maximum(np.where(rim, depth, -np.inf), labels=np.where(rim, owner, 0), index=ids)
    level = np.full(count + 1, np.nan)
    level[ids] = top
    out = depth.copy()
    out[holes] = level[runs[holes]]
    return out


def _fill_gaps(depth: np.ndarray, jump: float) -> np.ndarray:
    """``depth`` with each pixel without return between two returns on one surface (no
    depth jump between them) along its row or column given their mean: the gaps of a range
    grid coarser than the image along one axis (a Cyberware grid's rows are 1.3-1.5 times
    its columns' spacing), which are no rays the scanner shot. Two passes over both axes
    (a gap between gaps). O(H · W)."""
    out = depth.copy()
    for axis in (0, 1, 0, 1):
        depth = out.copy()
        pad = np.pad(
            depth, [(1, 1) if a == axis else (0, 0) for a in range(2)], constant_values=np.nan
        )
        n = depth.shape[axis]
        before = np.take(pad, np.arange(0, n), axis=axis)
        after = np.take(pad, np.arange(2, n + 2), axis=axis)
        with np.errstate(invalid="ignore"):
            fill = np.isnan(out) & (np.abs(after - before) <= jump)
        out[fill] = 0.5 * (before[fill] + after[fill])
    return out


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
