"""Noisy and real scans: every method against the CAD truth, and the holdout error.

    python benches/noise.py                          # CAD parts at three noise levels, real scans
    python benches/noise.py --cad conrod --real      # one part, and every real scan
    python benches/noise.py --real fran              # one real scan
    python benches/noise.py --data /work/shared/data  # data elsewhere than ../shared/data

CAD parts (the settings of benches/quality.py: rod along y, fandisk along y, blade along
+-y) are scanned by the virtual digitizer with Gaussian noise along the ray of sigma = 0,
s/30 and s/10 (s: the median step along the lines of the noise-free scan; noise seed 1).
Per method: the noise estimate (``scanmesh.noise``), tac_1, sliver share, height RMS
against the CAD truth (:func:`scanmesh.truth.height_error`, 100,000 samples) and its ratio
to Delaunay's, and wall time. ``anneal`` is the default (noise-aware) annealing;
``anneal, exact ties`` the annealing before noise awareness (``tie_tolerance=1e-10``).

Real scans (``fran_cut.vtk``, ``SainteHelens.dem``, the LAS ground returns, class 2) have
no truth: :func:`scanmesh.truth.holdout_error` withholds 10 % of the points (seed 0),
reconstructs the rest and measures the withheld points along the projection normal.
"""

from __future__ import annotations

import argparse
import time
import warnings
from pathlib import Path

from quality import PARTS, SHARED, machine

import scanmesh
from scanmesh.lines import scan_lines
from scanmesh.truth import TrueSurface, height_error, holdout_error

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
    ("anneal, exact ties", "anneal", {"tie_tolerance": 1e-10}),
)

#: Real scans: name -> (file under shared/data, reader options, projection plane).
REAL = {
    "fran": ("scans/fran_cut.vtk", {}, None),
    "SainteHelens": ("terrain/SainteHelens.dem", {}, "z"),
    "autzen ground": ("lidar/autzen_trim.laz", {"select": "ground"}, "z"),
}

NOISE_SEED = 1
SEED = 0
N_SAMPLES = 100_000


def cad_rows(part: str, data: Path) -> None:
    cad, settings, plane = PARTS[part]
    truth = TrueSurface(data / "cad" / cad)
    # the rod's noise-free scan is the embedded demo, made with these settings
    clean, lines = scanmesh.simulate_scan(data / "cad" / cad, **settings)
    step = scan_lines(clean, lines, plane=plane).median_step
    print(f"\n**{part}**: {len(clean):,} points, s = {step:.4g}, plane {plane}\n")
    print("| sigma | method | est. / sigma | tac_1 | slivers | h_rms | h_rms / Del. | time (s) |")
    print("|---|---|---|---|---|---|---|---|")
    for level in LEVELS:
        if level:
            points, _ = scanmesh.simulate_scan(
                data / "cad" / cad, **settings, noise=level * step, seed=NOISE_SEED
            )
        else:
            points = clean
        base = None
        for label, method, options in VARIANTS:
            t0 = time.perf_counter()
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")
                surface = scanmesh.reconstruct(
                    points, method, lines=lines, plane=plane, seed=SEED, **options
                )
            elapsed = time.perf_counter() - t0
            h = height_error(surface, truth, n_samples=N_SAMPLES, seed=SEED)["h_rms"]
            base = h if base is None else base
            sigma = surface.options.get("noise")
            ratio = "-" if sigma is None or not level else f"{sigma / (level * step):.3f}"
            q = surface.quality
            name = "0" if not level else f"s/{round(1 / level)}"
            print(
                f"| {name} | {label} | {ratio} | {q.tac_1:.4g} | {100 * q.sliver_fraction:.2f} % |"
                f" {h:.4g} | {h / base:.3f} | {elapsed:.2f} |",
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
    print("| method | holdout RMS | / Del. | p99 | max | outside | tac_1 | slivers | time (s) |")
    print("|---|---|---|---|---|---|---|---|---|")
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
            f"| {label} | {r['rms']:.4g} | {r['rms'] / base:.3f} | {r['p99']:.4g} |"
            f" {r['max']:.4g} | {r['outside']} | {q.tac_1:.4g} | {100 * q.sliver_fraction:.2f} % |"
            f" {elapsed:.2f} |",
            flush=True,
        )


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--cad", nargs="*", choices=CAD_PARTS, default=None)
    parser.add_argument("--real", nargs="*", choices=list(REAL), default=None)
    parser.add_argument("--data", type=Path, default=SHARED, help=f"shared data (default {SHARED})")
    args = parser.parse_args()
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
