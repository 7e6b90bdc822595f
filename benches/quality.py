"""Quality against true surfaces: every method on simulated scans of real CAD parts.

    python benches/quality.py                       # all parts, all methods, Markdown tables
    python benches/quality.py --parts conrod        # one part
    python benches/quality.py --figures benches/figures   # also a picture per part
    python benches/quality.py --check-cli           # rod: the same rows via `scanmesh compare`

Each part is scanned by the virtual digitizer (:func:`scanmesh.simulate_scan`, no noise, so
every point lies on the true surface) at the settings in :data:`PARTS`; each method
triangulates the same points, projected along the scanning direction. Per mesh: tac norms,
smallest 3-D angle, sliver share (the row ``scanmesh compare`` prints, from the same
function), closest-point height error against the CAD mesh at 100,000 random points on the
mesh's area (:func:`scanmesh.evaluate.truth.height_error`, as ``scanmesh compare --truth``),
the mean angle between mesh and true normals at the same points
(:func:`scanmesh.evaluate.truth.normal_error`), the domain against the part's shadow on the
plane (air covered, shadow missed, in % of the shadow:
:func:`scanmesh.evaluate.truth.domain_error`, also in ``scanmesh compare --truth``) and wall
time of the triangulation. Baselines: spade Delaunay (method ``delaunay``, trimmed at
5 x median spacing) and ``scipy.spatial.Delaunay`` on the same projected points, trimmed by
the same code at the same length.
"""

from __future__ import annotations

import argparse
import contextlib
import io
import json
import os
import platform
import tempfile
import time
from pathlib import Path

import numpy as np

import scanmesh
from scanmesh.cli._common import _quality_row
from scanmesh.evaluate.truth import TrueSurface, domain_error, height_error, normal_error
from scanmesh.present.render import auto_view as _auto_view

SHARED = Path(__file__).resolve().parents[2] / "shared" / "data"
CAD = SHARED / "cad"

#: part -> (CAD file, simulate_scan settings, projection plane). The rod is the embedded rod
#: scan (``scanmesh.load_rod()``, made with exactly these settings by benches/make_demo.py).
PARTS: dict[str, tuple[str, dict, str]] = {
    "conrod": ("conrod_slevin48_onshape.stl", {"up": "y", "along": "x", "n_points": 14_339}, "y"),
    "octagonal_pocket": (
        "octagonal_pocket.ply",
        {"up": "z", "along": "x", "n_points": 15_000},
        "z",
    ),
    "fandisk": ("fandisk.obj", {"up": "y", "along": "x", "n_points": 17_000}, "y"),
    "turbineblade +y": ("turbineblade.ply", {"up": "y", "along": "z", "n_points": 15_000}, "y"),
    "turbineblade -y": ("turbineblade.ply", {"up": "-y", "along": "z", "n_points": 15_000}, "y"),
}

#: scanmesh methods in the table (plus the scipy baseline, added after spade's Delaunay).
METHODS = ("delaunay", "lookahead", "shortest-path", "lop", "anneal")

LABELS = {"delaunay": "spade Delaunay", "scipy": "scipy Delaunay"}

N_SAMPLES = 100_000
SEED = 0


def machine() -> str:
    load = os.getloadavg()
    return (
        f"{platform.machine()}, {os.cpu_count()} cores, Python {platform.python_version()},"
        f" load average {load[0]:.1f} / {load[1]:.1f} / {load[2]:.1f} (1 / 5 / 15 min)"
    )


def scan(part: str) -> tuple[np.ndarray, np.ndarray]:
    """(points, line_ids) of a part at its stated settings."""
    if part == "conrod":
        return scanmesh.load_rod()
    cad, settings, _ = PARTS[part]
    return scanmesh.simulate_scan(CAD / cad, **settings)


def scipy_delaunay(points: np.ndarray, plane: str) -> scanmesh.Surface:
    """scipy.spatial.Delaunay (Qhull) on the same projection, trimmed like ``delaunay``."""
    from scipy.spatial import Delaunay

    from scanmesh import _core
    from scanmesh.scan.projection import project
    from scanmesh.stages.delaunay import resolve_max_edge

    uv, frame = project(points, plane)
    faces = np.ascontiguousarray(Delaunay(uv).simplices, dtype=np.int64)
    limit = resolve_max_edge(uv, faces, None)
    faces = _core.trim_long_edges(uv, faces, limit)
    return scanmesh.Surface(
        vertices=points, faces=faces, method="scipy", options={"max_edge": limit}, frame=frame
    )


def run_method(points, lines, plane, method):
    t0 = time.perf_counter()
    if method == "scipy":
        surface = scipy_delaunay(points, plane)
    else:
        # line ids travel with the scan; only annealing takes a seed
        scan = scanmesh.planar_scan(points, plane=plane, lines=lines)
        seeded = {"seed": SEED} if method == "anneal" else {}
        surface = scanmesh.reconstruct(scan, method, **seeded)
    return surface, time.perf_counter() - t0


def measure(part: str, figures: Path | None) -> list[dict]:
    cad, settings, plane = PARTS[part]
    points, lines = scan(part)
    truth = TrueSurface(CAD / cad)
    rows, shown = [], {}
    for method in ("delaunay", "scipy", *METHODS[1:]):
        surface, elapsed = run_method(points, lines, plane, method)
        row = {"part": part, "method": method, "time_s": elapsed, "faces": len(surface.faces)}
        row.update(_quality_row(surface))
        h = height_error(surface, truth, n_samples=N_SAMPLES, seed=SEED)
        n = normal_error(surface, truth, n_samples=N_SAMPLES, seed=SEED)
        row.update({k: h[k] for k in ("h_rms", "h_mean", "h_max")})
        row.update({k: n[k] for k in ("n_mean_deg", "n_median_deg")})
        d = domain_error(surface, truth)
        row.update({k: d[k] for k in ("air_share", "missed_share")})
        rows.append(row)
        if method in ("delaunay", "shortest-path", "anneal"):
            shown[method] = (surface, row)
    for row in rows:
        row["points"], row["lines"], row["settings"] = len(points), int(lines.max()) + 1, settings
    if figures is not None:
        from scanmesh.present.panels import render_compare

        figures.mkdir(parents=True, exist_ok=True)
        ref = shown["delaunay"][0]
        name = part.replace(" ", "").replace("+", "_pos").replace("-", "_neg")
        render_compare(
            [s for s, _ in shown.values()],
            figures / f"quality_{name}.png",
            titles=[
                f"{m}: tac_1 {r['tac_1']:.3g}, RMS {r['h_rms']:.2g}" for m, (_, r) in shown.items()
            ],
            size=(400, 300),
            **_auto_view(ref.vertices, ref.faces, ref.frame),
        )
    return rows


def print_table(rows: list[dict]) -> None:
    first = rows[0]
    s = first["settings"]
    print(
        f"\n**{first['part']}**: {first['points']:,} points on {first['lines']} lines"
        f" (`simulate_scan(up={s['up']!r}, along={s['along']!r}, n_points={s['n_points']:,})`)\n"
    )
    print(
        "| method | time (s) | tac_1 | tac_2 | tac_inf | tac_1 / Del. | min angle (°) | slivers"
        " | h_rms | h_mean | h_max | h_rms / Del. | normal mean (°) | normal median (°) | air |"
        " missed |"
    )
    print("|---|" + "---|" * 15)
    base = rows[0]

    def ratio(value: float, reference: float) -> str:
        # a flat part's trimmed Delaunay has tac exactly 0: no ratio to give
        return f"{value / reference:.3f}" if reference else "-"

    for r in rows:
        label = {"delaunay": "spade Delaunay", "scipy": "scipy Delaunay"}.get(
            r["method"], r["method"]
        )
        print(
            f"| {label} | {r['time_s']:.2f} | {r['tac_1']:.4g} | {r['tac_2']:.4g} |"
            f" {r['tac_inf']:.3g} | {ratio(r['tac_1'], base['tac_1'])} | {r['min_angle_deg']:.2g} |"
            f" {100 * r['sliver_fraction']:.2f} % | {r['h_rms']:.3g} | {r['h_mean']:.3g} |"
            f" {r['h_max']:.3g} | {ratio(r['h_rms'], base['h_rms'])} | {r['n_mean_deg']:.2f} |"
            f" {r['n_median_deg']:.2g} | {100 * r['air_share']:.3f} % |"
            f" {100 * r['missed_share']:.2f} % |",
            flush=True,
        )


def check_cli() -> None:
    """Run the rod through ``scanmesh compare --truth --json`` and compare with the library."""
    from scanmesh.cli import main
    from scanmesh.formats.write import write_points

    points, lines = scan("conrod")
    with tempfile.TemporaryDirectory() as tmp:
        xyz = Path(tmp) / "rod.xyz"
        write_points(xyz, points, lines)
        argv = ["compare", str(xyz), "--truth", str(CAD / PARTS["conrod"][0]), "--plane", "y"]
        argv += ["--methods", "delaunay", "shortest-path", "--json", "--quiet"]
        out = io.StringIO()
        with contextlib.redirect_stdout(out):
            status = main(argv)
    cli_rows = {r["method"]: r for r in json.loads(out.getvalue())["methods"]}
    truth = TrueSurface(CAD / PARTS["conrod"][0])
    print(f"`scanmesh {' '.join(argv)}` exit {status}")
    for method, r in cli_rows.items():
        s, _ = run_method(points, lines, "y", method)
        h = height_error(s, truth, n_samples=N_SAMPLES, seed=SEED)
        print(
            f"{method}: cli tac_1 {r['tac_1']:.6g} h_rms {r['h_rms']:.6g};"
            f" library tac_1 {s.quality.tac_1:.6g} h_rms {h['h_rms']:.6g}"
        )


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--parts", nargs="+", choices=list(PARTS), default=list(PARTS))
    parser.add_argument("--figures", type=Path, default=None, help="folder for one PNG per part")
    parser.add_argument("--json", type=Path, default=None, help="also write all rows as JSON")
    parser.add_argument("--check-cli", action="store_true", help="rod via `scanmesh compare`")
    args = parser.parse_args()
    if args.check_cli:
        check_cli()
        return
    print(f"machine: {machine()}")
    every = []
    for part in args.parts:
        rows = measure(part, args.figures)
        print_table(rows)
        every += rows
    print(f"\nmachine after the run: {machine()}")
    if args.json:
        args.json.write_text(json.dumps(every, indent=1))


if __name__ == "__main__":
    main()
