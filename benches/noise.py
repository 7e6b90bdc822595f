"""Noisy and real scans: every method against the CAD truth, and the holdout error.

    python benches/noise.py                          # CAD parts at three noise levels, real scans
    python benches/noise.py --cad conrod --real      # one part, and every real scan
    python benches/noise.py --real fran              # one real scan
    python benches/noise.py --data DATA       # data elsewhere than ../shared/data
    python benches/noise.py --plane                  # the noise floor on a noisy plane

CAD parts (the settings of benches/quality.py: rod along y, fandisk along y, blade along
+-y) are scanned by the virtual digitizer with Gaussian noise along the ray of sigma = 0,
s/30 and s/10 (s: the median step along the lines of the noise-free scan; noise seed 1).
Per method: the noise estimate (``scanmesh.noise``), tac_1, sliver share, height RMS
against the CAD truth and its ratio to Delaunay's, and wall time. The height RMS is
:func:`paired_height_rms` at Delaunay's density of 100,000 samples: the estimate of
:func:`scanmesh.evaluate.truth.height_error`, but every face sampled at points drawn from its own
vertex ids, so that meshes sharing most faces are compared on the same points (independent
samples scatter the ratio by about 0.4 %, as much as the differences on the noisy rod).
``anneal`` is the default annealing (exact ties); ``anneal, noise ties`` anneals with the
tie tolerance from the noise estimate (``tie_tolerance=None``), ``anneal, planar ties`` the
same with ``planar_ties=True`` (flips between corners flat up to the noise judged by the
planar angle).

Real scans (``fran_cut.vtk``, ``SainteHelens.dem``, the LAS ground returns, class 2) have
no truth: :func:`scanmesh.evaluate.holdout.holdout_error` withholds 10 % of the points (seed 0),
reconstructs the rest and measures the withheld points along the projection normal.

The noise floor (column ``floor / Del.``, to hold against ``h_rms / Del.``): a mesh whose
vertices are the noisy samples interpolates their noise linearly, and at a point of barycentric
coordinates (l1, l2, l3) iid noise sigma leaves sigma^2 * (l1^2 + l2^2 + l3^2); uniform over a
triangle (Dirichlet(1, 1, 1): E[l_i^2] = 1/6) that is sigma^2 / 2 whatever the triangle's shape,
so no connectivity of these points gets below it (the noise-free interpolation error adds to it:
its cross term has mean zero). h_rms is a closest-point distance sampled over the 3-D area while
the noise is along the projection normal, so on a face tilted by theta the floor is
sigma * cos(theta) / sqrt(2): :func:`noise_floor` averages cos^2 over the noise-free Delaunay
mesh's area. A withheld noisy point adds its own noise: sigma * sqrt(3 / 2) (sigma estimated),
at least sigma * sqrt(4 / 3) (a point at a triangle's centroid). ``python noise.py --plane``
checks sigma / sqrt(2) and sigma * sqrt(3 / 2) on Delaunay meshes of a noisy plane.
"""

from __future__ import annotations

import argparse
import math
import time
import warnings
from pathlib import Path

import numpy as np
from quality import PARTS, SHARED, machine

import scanmesh
from scanmesh.evaluate.holdout import holdout_error
from scanmesh.evaluate.truth import TrueSurface
from scanmesh.methods import used_keywords
from scanmesh.scan.lines import scan_lines

#: CAD parts of the noise table (keys of quality.PARTS).
CAD_PARTS = ("conrod", "fandisk", "turbineblade +y", "turbineblade -y")

#: Noise levels, as fractions of the median step s.
LEVELS = (0.0, 1 / 30, 1 / 10)

#: Rows per scan: (label, method, options).
VARIANTS = (
    ("delaunay", "delaunay", {}),
    ("lookahead", "lookahead", {}),
    ("shortest-path", "shortest-path", {}),
    ("lop", "lop", {}),
    ("anneal", "anneal", {}),
    ("anneal, noise ties", "anneal", {"tie_tolerance": None}),
    ("anneal, planar ties", "anneal", {"tie_tolerance": None, "planar_ties": True}),
)

#: Real scans: name -> (file under shared/data, reader options, projection plane).
REAL = {
    "fran": ("scans/fran_cut.vtk", {}, None),
    "SainteHelens": ("terrain/SainteHelens.dem", {}, "z"),
    "autzen ground": ("lidar/autzen_trim.laz", {"classes": 2}, "z"),
}

NOISE_SEED = 1
SEED = 0
N_SAMPLES = 100_000


def shared(method: str, options: dict, lines: object) -> dict:
    """``lines`` and the seed, for the methods that use them (the others refuse them)."""
    given = {"lines": lines, "seed": SEED}
    return {k: v for k, v in given.items() if k in used_keywords(method, options)}


def _mix(x: np.ndarray) -> np.ndarray:
    """SplitMix64's finalizer on uint64 ``x``: well-mixed bits from consecutive keys."""
    x = (x ^ (x >> np.uint64(30))) * np.uint64(0xBF58476D1CE4E5B9)
    x = (x ^ (x >> np.uint64(27))) * np.uint64(0x94D049BB133111EB)
    return x ^ (x >> np.uint64(31))


def _unit(x: np.ndarray) -> np.ndarray:
    """Uniform floats in [0, 1) from the top 53 bits of uint64 ``x``."""
    return (x >> np.uint64(11)).astype(np.float64) * 2.0**-53


def paired_height_rms(surface: scanmesh.Surface, truth: TrueSurface, density: float) -> float:
    """Height RMS of ``surface`` against ``truth`` at ``density`` samples per unit 3-D area,
    each face sampled at points drawn from its own vertex ids (sorted) alone.

    The same estimate as :func:`scanmesh.evaluate.truth.height_error` (uniform over the mesh's area:
    a face of area A gets floor(A * density + u) samples, u uniform from its key), but with
    common random numbers: a face two meshes share gets the same samples in both, so their
    ratio measures only where the meshes differ (identical meshes: exactly 1). Independent
    samples of 100,000 points scatter a ratio by about 0.4 %, as much as the differences
    between the noisy rod's meshes. O(F + samples).
    """
    faces = np.sort(np.asarray(surface.faces, dtype=np.int64), axis=1)
    tri = np.asarray(surface.vertices, dtype=np.float64)[faces]
    area = 0.5 * np.linalg.norm(np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0]), axis=1)
    with np.errstate(over="ignore"):
        key = faces.astype(np.uint64)
        key = _mix(_mix(_mix(key[:, 0]) ^ key[:, 1]) ^ key[:, 2])
        count = np.floor(area * density + _unit(key)).astype(np.int64)
        face = np.repeat(np.arange(len(faces)), count)
        j = np.arange(len(face)) - np.repeat(np.cumsum(count) - count, count)
        stream = _mix(
            key[face] + np.uint64(0x9E3779B97F4A7C15) * (j.astype(np.uint64) + np.uint64(1))
        )
        r1 = np.sqrt(_unit(stream))
        r2 = _unit(_mix(stream))
    w = np.column_stack([1 - r1, r1 * (1 - r2), r1 * r2])
    samples = np.einsum("ij,ijk->ik", w, tri[face])
    dist = truth.distance(samples)
    return math.sqrt(float(np.mean(dist * dist)))


def noise_floor(surface: scanmesh.Surface) -> float:
    """Height RMS per unit sigma that the interpolated noise alone leaves on ``surface``:
    sqrt(mean over its 3-D area of cos^2(tilt from the projection normal) / 2). O(F)."""
    mesh = surface.to_trimesh()
    assert surface.scan is not None
    cos = np.abs(mesh.face_normals @ np.asarray(surface.scan.frame.normal, dtype=np.float64))
    return math.sqrt(float(np.average(cos * cos, weights=mesh.area_faces)) / 2)


def plane_check(n: int = 40_000, seed: int = 0) -> None:
    """Delaunay meshes of noisy samples of the plane z = 0 (random and grid sites): height
    RMS against sigma / sqrt(2), holdout RMS against sigma * sqrt(3 / 2)."""
    rng = np.random.default_rng(seed)
    side = int(math.sqrt(n))
    grid = np.stack(np.meshgrid(np.arange(side), np.arange(side)), axis=-1).reshape(-1, 2)
    print("| sites | sigma | h_rms / sigma | 1/sqrt(2) | holdout / sigma | sqrt(3/2) |")
    print("|---|---|---|---|---|---|")
    for name, uv in (("random", rng.random((side * side, 2)) * side), ("grid", grid * 1.0)):
        for sigma in (0.01, 0.1):
            points = np.column_stack([uv, rng.normal(0.0, sigma, len(uv))])
            surface = scanmesh.reconstruct(points, "delaunay", plane="z")
            # the plane is the truth: the height of a random area sample is its error
            tri = points[surface.faces]
            w = rng.dirichlet((1.0, 1.0, 1.0), size=len(tri))
            e1, e2 = tri[:, 1, :2] - tri[:, 0, :2], tri[:, 2, :2] - tri[:, 0, :2]
            area = np.abs(e1[:, 0] * e2[:, 1] - e1[:, 1] * e2[:, 0])
            pick = rng.choice(len(tri), 200_000, p=area / area.sum())
            h = np.einsum("ij,ij->i", w[pick], tri[pick, :, 2])
            held = holdout_error(points, "delaunay", seed=seed, plane="z")["rms"]
            print(
                f"| {name} | {sigma} | {math.sqrt(np.mean(h * h)) / sigma:.4f} |"
                f" {1 / math.sqrt(2):.4f} | {held / sigma:.4f} | {math.sqrt(1.5):.4f} |"
            )


def cad_rows(part: str, data: Path) -> None:
    cad, settings, plane = PARTS[part]
    truth = TrueSurface(data / "cad" / cad)
    # the rod's noise-free scan is the embedded one (load_rod), made with these settings
    clean, lines = scanmesh.simulate_scan(data / "cad" / cad, **settings)
    step = scan_lines(clean, lines, plane=plane).median_step
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        per_sigma = noise_floor(scanmesh.reconstruct(clean, "delaunay", plane=plane))
    print(
        f"\n**{part}**: {len(clean):,} points, s = {step:.4g}, plane {plane};"
        f" noise floor {per_sigma:.4f} sigma\n"
    )
    print(
        "| sigma | method | est. / sigma | tac_1 | slivers | h_rms | h_rms / Del."
        " | floor / Del. | time (s) |"
    )
    print("|---|---|---|---|---|---|---|---|---|")
    for level in LEVELS:
        if level:
            points, _ = scanmesh.simulate_scan(
                data / "cad" / cad, **settings, noise=level * step, seed=NOISE_SEED
            )
        else:
            points = clean
        base = density = None
        for label, method, options in VARIANTS:
            t0 = time.perf_counter()
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")
                surface = scanmesh.reconstruct(
                    points, method, plane=plane, **shared(method, options, lines), **options
                )
            elapsed = time.perf_counter() - t0
            if density is None:
                density = N_SAMPLES / surface.to_trimesh().area
            h = paired_height_rms(surface, truth, density)
            base = h if base is None else base
            sigma = surface.options.get("noise")
            ratio = "-" if sigma is None or not level else f"{sigma / (level * step):.3f}"
            q = surface.quality
            name = "0" if not level else f"s/{round(1 / level)}"
            print(
                f"| {name} | {label} | {ratio} | {q.tac_1:.4g} | {100 * q.sliver_fraction:.2f} % |"
                f" {h:.4g} | {h / base:.3f} | {per_sigma * level * step / base:.3f} |"
                f" {elapsed:.2f} |",
                flush=True,
            )


def real_rows(name: str, data: Path) -> None:
    path, read_options, plane = REAL[name]
    scan_ = scanmesh.read(data / path, **read_options)
    points, lines = scan_.points, scan_.line_ids
    sigma = scanmesh.noise(points, lines, plane=plane)
    print(
        f"\n**{name}** (`{path}`): {len(points):,} points, noise estimate {sigma:.4g},"
        f" plane {plane or 'best-fit'}; 10 % of the points withheld (seed {SEED})\n"
    )
    print(
        "| method | holdout RMS | / Del. | floor / Del. | p99 | max | outside | tac_1 | slivers"
        " | time (s) |"
    )
    print("|---|---|---|---|---|---|---|---|---|---|")
    base = None
    for label, method, options in VARIANTS:
        t0 = time.perf_counter()
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            r = holdout_error(points, method, seed=SEED, lines=lines, plane=plane, **options)
        elapsed = time.perf_counter() - t0
        base = r["rms"] if base is None else base
        q = r["surface"].quality
        print(
            f"| {label} | {r['rms']:.4g} | {r['rms'] / base:.3f} |"
            f" {sigma * math.sqrt(1.5) / base:.3f} | {r['p99']:.4g} |"
            f" {r['max']:.4g} | {r['outside']} | {q.tac_1:.4g} | {100 * q.sliver_fraction:.2f} % |"
            f" {elapsed:.2f} |",
            flush=True,
        )


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--cad", nargs="*", choices=CAD_PARTS, default=None)
    parser.add_argument("--real", nargs="*", choices=list(REAL), default=None)
    parser.add_argument("--data", type=Path, default=SHARED, help=f"shared data (default {SHARED})")
    parser.add_argument("--plane", action="store_true", help="only check the noise floor")
    args = parser.parse_args()
    if args.plane:
        plane_check()
        return
    everything = args.cad is None and args.real is None
    # a flag without names means all of its kind
    parts = list(CAD_PARTS) if everything or args.cad == [] else args.cad or []
    scans = list(REAL) if everything or args.real == [] else args.real or []
    print(f"machine: {machine()}")
    for part in parts:
        cad_rows(part, args.data)
    for name in scans:
        real_rows(name, args.data)
    print(f"\nmachine after the run: {machine()}")


if __name__ == "__main__":
    main()
