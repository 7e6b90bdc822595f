"""Measurement noise of a scan: its standard deviation along the projection normal.

Design. Along a scan line the true surface is smooth between creases, steps and holes, and
the points are dense. So each point with two neighbours on either side in its line segment
is predicted by the cubic through those four neighbours (Lagrange interpolation in the
planar arc length, so uneven spacing is handled), and the prediction residual of its
height is divided by ``sqrt(1 + sum(w_j**2))`` (w_j the interpolation weights): with
independent noise of deviation sigma every such normalized residual has deviation sigma.

- A cubic stencil, not a second difference: a second difference of a curved noise-free
  surface is curvature x s^2 / 2 (s/20 on a cylinder 10 spacings in radius), while the
  cubic's error is of order s^4 times the fourth derivative, so smooth curved parts of a
  noise-free scan give residuals far below s/200.
- Creases and steps spoil only the few windows that straddle them (four per crossing),
  and gaps are never bridged (windows stay inside the segments of
  :func:`scanmesh.scan.lines.scan_lines`, which split lines at holes). Those residuals are
  outliers, so the scale is robust: it starts from the median absolute residual
  (x 1.4826) and is refined by a few rounds of a trimmed RMS (residuals within
  ``TRIM`` x the current estimate, corrected for the truncation of a Gaussian), which
  drops the straddling windows once the estimate is below their size. The median alone
  is biased up by such outliers (20 % outliers: +30 %); the trimmed rounds are not.

Across the lines a second estimate: each point against the quadratic least-squares fit of
the height over the plane through its :data:`NEIGHBOURS` nearest other points, the
residual normalized the same way (by ``sqrt(1 + var(fit at the point) / sigma**2)``), and
scaled robustly the same way. It also works for points in no scan order, and it sees noise
that the line stencil cannot: real scanners often shift a whole profile at once (noise
correlated along a line, independent between lines), which a fit along the line absorbs.
On the Cyberware face scan ``fran_cut.vtk`` the neighbourhood estimate is 3.8 times the
line estimate; on simulated white noise the two agree within a few per cent. The larger of
the two is the estimate.

Cost: O(N) numpy work after the line detection, and O(N log N) for the neighbourhood
search (fits at no more than :data:`MAX_FITS` points): about 10 s for 1M points on a
loaded machine.
"""

from __future__ import annotations

import math
import sys
from typing import TYPE_CHECKING

import numpy as np
from numpy.typing import ArrayLike

from scanmesh._checks import power_of_two_exponent
from scanmesh.errors import DegenerateInputError
from scanmesh.scan.lines import scan_lines
from scanmesh.scan.planar import PlanarScan, as_scan
from scanmesh.scan.projection import PlaneSpec
from scanmesh.scan.spacing import median_edge

if TYPE_CHECKING:
    from scanmesh.surface import Surface

#: Residuals beyond TRIM x the current estimate are left out of the refined estimate.
TRIM: float = 2.5

#: Rounds of the trimmed refinement (it settles in 3-4 on scans with steps and creases).
ROUNDS: int = 8

#: Neighbours of the quadratic fit when the points are not in scan order.
NEIGHBOURS: int = 12

#: Most points the neighbourhood estimate fits (a seeded random choice of them).
MAX_FITS: int = 100_000

#: Points fitted per vectorized chunk of the neighbourhood fit (bounds memory).
CHUNK: int = 1 << 16

#: Points per batch of the O(N) passes (line stencils, heights):
#: bounds their temporaries, a few hundred MB whatever the scan's size.
PASS_CHUNK: int = 1 << 20

#: Fewest residual windows an estimate is made from.
MIN_WINDOWS: int = 20

#: 1 / (the median of |z| for a standard normal z): turns a median absolute value into sigma.
MAD_SCALE: float = 1.482602218505602


def _truncated_variance(c: float) -> float:
    """Variance of a standard normal restricted to [-c, c]."""
    pdf = math.exp(-0.5 * c * c) / math.sqrt(2 * math.pi)
    mass = math.erf(c / math.sqrt(2))
    return 1.0 - 2.0 * c * pdf / mass


def line_residuals(
    points: ArrayLike | PlanarScan, lines: ArrayLike | None = None, plane: PlaneSpec = None
) -> np.ndarray:
    """Normalized cubic-prediction residuals of the heights along the scan lines.

    Parameters
    ----------
    points, lines, plane
        As :func:`noise`.

    Returns
    -------
    (W,) float64
        One residual per point that has two neighbours on either side in its line segment
        (model units); each has the noise's deviation where the surface is smooth. O(N).
    """
    scan = as_scan(points, plane=plane, lines=lines)
    return _line_residuals(scan, scan.uv, _heights(scan.points, scan))


def _heights(points: np.ndarray, scan: PlanarScan) -> np.ndarray:
    """(N,) float64 heights of ``points`` (the scan's, or an exactly rescaled copy) along
    the scan's normal."""
    return points @ np.asarray(scan.frame.normal, dtype=np.float64)


def _line_residuals(scan: PlanarScan, uv: np.ndarray, height: np.ndarray) -> np.ndarray:
    """:func:`line_residuals` from the scan's lines, with its planar coordinates ``uv`` and
    ``height`` (both in one unit, possibly scaled)."""
    segments = [seg for line in scan_lines(scan).lines for seg in line]
    segments = [seg for seg in segments if len(seg) >= 5]
    if not segments:
        return np.zeros(0)
    # Segments in batches of about PASS_CHUNK points: the stencil holds some twenty arrays
    # of a batch's length at once: 1.6 GB for 10M points in a single batch.
    out, batch, size = [], [], 0
    for seg in segments:
        batch.append(seg)
        size += len(seg)
        if size >= PASS_CHUNK:
            out.append(_segment_residuals(batch, uv, height))
            batch, size = [], 0
    if batch:
        out.append(_segment_residuals(batch, uv, height))
    return np.concatenate(out)


def _segment_residuals(
    segments: list[np.ndarray], uv: np.ndarray, height: np.ndarray
) -> np.ndarray:
    """The normalized cubic-prediction residuals of the points of ``segments`` (index arrays
    of at least 5 points each, in line order), in that order. O(total length)."""
    order = np.concatenate(segments)
    lengths = np.array([len(seg) for seg in segments])
    starts = np.cumsum(lengths) - lengths
    # arc length along each segment (the planar steps, restarted per segment)
    step = np.linalg.norm(np.diff(uv[order], axis=0), axis=1)
    arc = np.concatenate(([0.0], np.cumsum(step)))
    arc -= np.repeat(arc[starts], lengths)
    pos = np.arange(len(order)) - np.repeat(starts, lengths)
    centre = np.flatnonzero((pos >= 2) & (pos <= np.repeat(lengths, lengths) - 3))
    offsets = (-2, -1, 1, 2)
    t0 = arc[centre]
    ts = [arc[centre + o] for o in offsets]
    hs = [height[order[centre + o]] for o in offsets]
    predicted = np.zeros(len(centre))
    norm2 = np.ones(len(centre))
    for j in range(4):
        w = np.ones(len(centre))
        for m in range(4):
            if m != j:
                w *= (t0 - ts[m]) / (ts[j] - ts[m])
        predicted += w * hs[j]
        norm2 += w * w
    return (height[order[centre]] - predicted) / np.sqrt(norm2)


def neighbourhood_residuals(points: ArrayLike | PlanarScan, plane: PlaneSpec = None) -> np.ndarray:
    """Normalized residuals of the heights against the quadratic least-squares fit over the
    plane to each point's :data:`NEIGHBOURS` nearest other points (see the module docstring).

    At most :data:`MAX_FITS` points are fitted (a seeded random choice beyond that; their
    neighbours come from all points): the robust scale of so many residuals is as good as
    of all of them.

    Returns
    -------
    (M,) float64
        One residual per fitted point whose neighbourhood is not degenerate (model units).
        O(N log N).
    """
    scan = as_scan(points, plane=plane)
    return _neighbourhood_residuals(scan.uv, _heights(scan.points, scan))


def _neighbourhood_residuals(uv: np.ndarray, height: np.ndarray) -> np.ndarray:
    """:func:`neighbourhood_residuals` of points at planar ``uv`` with ``height`` (one unit)."""
    from scipy.spatial import cKDTree  # scipy loads only when needed: `import scanmesh` stays light

    if len(uv) <= NEIGHBOURS or not np.isfinite(uv).all():
        return np.zeros(0)
    # Distinct planar positions only (the first of each, as Delaunay keeps them): a copy
    # tells a fit nothing, and a million coincident points made the tree's queries
    # quadratic (minutes, for three distinct points).
    distinct = _first_of_each(uv)
    if len(distinct) < len(uv):
        uv, height = uv[distinct], height[distinct]
        if len(uv) <= NEIGHBOURS:
            return np.zeros(0)
    centres = np.arange(len(uv))
    if len(uv) > MAX_FITS:
        centres = np.sort(np.random.default_rng(0).choice(len(uv), MAX_FITS, replace=False))
    _, near = cKDTree(uv).query(uv[centres], k=NEIGHBOURS + 1)
    out = []
    for first in range(0, len(centres), CHUNK):
        own = centres[first : first + CHUNK]
        # without the point itself (first unless a coincident point came first)
        idx = np.where(
            near[first : first + CHUNK, :1] == own[:, None],
            near[first : first + CHUNK, 1:],
            near[first : first + CHUNK, :-1],
        )
        d = uv[idx] - uv[own, None, :]
        scale = np.sqrt(np.mean(np.sum(d * d, axis=2), axis=1))[:, None]  # conditioning
        x, y = d[..., 0] / scale, d[..., 1] / scale
        design = np.stack([np.ones_like(x), x, y, x * x, x * y, y * y], axis=2)  # (n, k, 6)
        gram = np.einsum("nki,nkj->nij", design, design)
        # neighbourhoods on a line (degenerate fits) are skipped; scaled, a sound one has a
        # determinant of order k^6
        ok = np.linalg.det(gram) > 1e-9 * NEIGHBOURS**6
        rhs = np.zeros((int(ok.sum()), 6, 2))
        rhs[:, :, 0] = np.einsum("nki,nk->ni", design[ok], height[idx[ok]])
        rhs[:, 0, 1] = 1.0  # the second column gives (X^T X)^-1 [0, 0]
        sol = np.linalg.solve(gram[ok], rhs)
        out.append((height[own[ok]] - sol[:, 0, 0]) / np.sqrt(1.0 + sol[:, 0, 1]))
    return np.concatenate(out)


def _first_of_each(uv: np.ndarray) -> np.ndarray:
    """Sorted indices of the first point at each distinct position of ``uv`` (N, 2): all
    of them when none coincide. O(N log N)."""
    rows = np.ascontiguousarray(uv, dtype=np.float64) + 0.0  # -0.0 as 0.0
    keys = rows.view(np.dtype((np.void, rows.dtype.itemsize * 2))).ravel()
    _, first = np.unique(keys, return_index=True)
    return np.sort(first)


def robust_scale(residuals: np.ndarray) -> float:
    """Standard deviation of the Gaussian core of ``residuals``, ignoring outliers.

    The median absolute value (x :data:`MAD_SCALE`), then :data:`ROUNDS` rounds of the RMS
    of the residuals within :data:`TRIM` x the estimate, divided by the truncated normal's
    deviation. O(W) per round.
    """
    r = np.abs(np.asarray(residuals, dtype=np.float64))
    sigma = MAD_SCALE * float(np.median(r))
    correction = math.sqrt(_truncated_variance(TRIM))
    for _ in range(ROUNDS):
        if sigma == 0.0:
            break
        kept = r[r <= TRIM * sigma]
        new = math.sqrt(float(np.mean(kept * kept))) / correction
        if abs(new - sigma) <= 1e-6 * sigma:
            sigma = new
            break
        sigma = new
    return sigma


def noise(
    points: ArrayLike | PlanarScan, lines: ArrayLike | None = None, plane: PlaneSpec = None
) -> float:
    """Estimate the standard deviation of the scan's noise along the projection normal.

    Parameters
    ----------
    points : (N, 3) float or PlanarScan
        Scan points, in scan order unless ``lines`` is given; a PlanarScan (its lines and
        plane) is used as it is, with no projection.
    lines : (N,) int, optional
        Scan line id of each point (detected from the point order when absent, see
        :func:`scanmesh.detect_lines`); points in no usable order are measured against
        their neighbourhoods only.
    plane : None, "best-fit", "x", "y", "z" or (3,) float
        Projection plane; heights are measured along its normal.

    Returns
    -------
    float
        sigma in model units: 0 (or nearly) for a noise-free scan of piecewise smooth
        surfaces. The larger of the estimates along the lines and over neighbourhoods (see
        the module docstring); O(N log N).

    Raises
    ------
    DegenerateInputError
        Neither estimate has :data:`MIN_WINDOWS` residuals (too few points).

    A PlanarScan keeps its estimate (:meth:`PlanarScan.once`): asked again (annealing's
    tie tolerance, ``scanmesh info``), it is not computed again.
    """
    scan = as_scan(points, plane=plane, lines=lines)
    return scan.once("noise", lambda: _noise(scan))


def _noise(scan: PlanarScan) -> float:
    """:func:`noise` of the scan, computed."""
    # Residuals scale with the coordinates: measured on an exactly rescaled copy, so that
    # squared distances and fits neither overflow at 1e300 nor vanish at 1e-300.
    exponent = power_of_two_exponent(scan.points)
    uv = np.ldexp(scan.uv, -exponent)
    height = np.concatenate(
        [
            _heights(np.ldexp(scan.points[first : first + PASS_CHUNK], -exponent), scan)
            for first in range(0, max(len(scan.points), 1), PASS_CHUNK)
        ]
    )
    found = [_line_residuals(scan, uv, height), _neighbourhood_residuals(uv, height)]
    estimates = [robust_scale(r) for r in found if len(r) >= MIN_WINDOWS]
    if not estimates:
        raise DegenerateInputError(
            f"the noise estimate needs at least {MIN_WINDOWS} points with a local fit, found"
            f" {max(len(r) for r in found)} among {len(scan.points)} points"
        )
    return math.ldexp(max(estimates), exponent)


#: Tie tolerance of annealing on tac_1 per (sigma / spacing)^2: a flip whose tac_1 change
#: is within this of zero is a tie (docs/benchmarks/noise.md: chosen on the rod and the
#: fandisk at sigma = s/30 and s/10).
TIE_PER_NOISE: float = 20.0


#: Below this sigma / spacing a scan counts as noise-free and anneals with exact ties: the
#: estimate then measures the facets of a tessellated CAD model (turbine blade: s/1000) or
#: rounding, and a tolerance from it only shuffles near-ties (fandisk: slivers 7.6 -> 7.9 %).
NOISE_FREE: float = 1 / 500


#: log of the largest float: the tie tolerance is capped there (finite, as the core needs).
LOG_FLOAT_MAX: float = math.log(sys.float_info.max)

#: Below this many points annealing keeps exact ties whatever the noise: a small input is
#: settled by the energy itself (the certified-optimum benchmark, 30-point patches with 1 %
#: noise: within 1 % of the optimum on 38 of 40 with exact ties, 6 of 40 with the noise
#: tolerance), while noise-level ties matter on scans, where chasing the noise lays slivers.
MIN_TIE_POINTS: int = 1_000


def tie_tolerance(sigma: float, spacing: float, p: float = 1.0, floor: float = 0.0) -> float:
    """The annealing tie tolerance for noise ``sigma`` on a mesh of edge length ``spacing``.

    Noise of deviation sigma tilts the triangles around a vertex by about sigma / spacing
    radians, and its angle defect (tac) by the square of that: flips whose tac change is
    within ``TIE_PER_NOISE * (sigma / spacing)**2`` only chase the noise, so annealing
    treats them as ties (free moves; the sliver guard picks among them). Raised to the
    power ``p`` for the energy sum tac^p; never below ``floor`` (the exact-tie tolerance),
    and ``floor`` itself when sigma / spacing is below :data:`NOISE_FREE`. O(1).
    """
    if spacing <= 0 or not math.isfinite(sigma / spacing) or sigma / spacing < NOISE_FREE:
        return floor
    # (.)^p in logs: a large p overflows the power (the energy's own ties stay finite)
    log_tolerance = p * math.log(TIE_PER_NOISE * (sigma / spacing) ** 2)
    return max(math.exp(min(log_tolerance, LOG_FLOAT_MAX)), floor)


def noise_tolerance(
    initial: Surface, p: float, given: float | None, floor: float
) -> tuple[float | None, float]:
    """The noise of an annealing run's scan and the tie tolerance it anneals with.

    Parameters
    ----------
    initial : Surface
        The initial triangulation, with the PlanarScan it was built on (points, planar
        coordinates, scan lines if known: nothing is projected again).
    p : float
        The energy exponent.
    given : float or None
        A tie tolerance the caller chose (kept as it is), or None: derive it from the noise
        (:func:`tie_tolerance` with the median edge of ``initial`` as the spacing), on scans
        of at least :data:`MIN_TIE_POINTS` points (``floor`` below).
    floor : float
        The exact-tie tolerance (the default), the least tolerance returned.

    Returns
    -------
    sigma : float or None
        :func:`noise` of the vertices (None when too few points give an estimate, or when
        ``given`` is a tolerance: then the estimate is not needed and not made).
    tolerance : float
        O(N) (O(N log N) for points in no scan order).
    """
    if given is not None:
        return None, float(given)
    scan = initial.scan
    assert scan is not None
    try:
        sigma = noise(scan)
    except DegenerateInputError:
        sigma = None
    if sigma is None or len(scan.points) < MIN_TIE_POINTS:
        return sigma, floor
    return sigma, tie_tolerance(sigma, median_edge(scan.uv, initial.faces), p, floor)
