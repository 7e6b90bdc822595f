"""Fingerprints of the faces every method returns on a fixed corpus, for refactors that
must not change behaviour.

Run it before and after a change and compare the two outputs line by line: a line names
the scan, the method and the SHA-256 of the faces (int64, in the order returned) with the
face count. Nothing random is left unseeded; annealing runs a fixed number of sweeps (no
time limit), so the fingerprints do not depend on the machine's load.

    python benches/face_hashes.py > before.txt
    python benches/face_hashes.py --data ../shared/data > before_shared.txt   # bench scans

The default corpus is the repository's own: the embedded rod scan and every file of
``tests/data`` (the CAD parts scanned by ``simulate_scan`` along z, clean and noisy), plus
seeded random scans. Then the default (``auto``: the holdout's choice) on the simulated and
random scans, the holdout error of two methods on the demo (its figures to the last digit),
and merged meshes (``scanmesh.merge`` of a box and of the fandisk seen from the six axis
directions: SHA-256 of the vertices, float64, and of the faces).
"""

from __future__ import annotations

import argparse
import hashlib
import sys
from pathlib import Path

import numpy as np
import trimesh

import scanmesh
from scanmesh.evaluate.digitizer import axis_views
from scanmesh.evaluate.holdout import holdout_error

ROOT = Path(__file__).resolve().parent.parent

#: Per method (its name, and after a space a label for the options): keywords that keep the
#: run deterministic and short on every scan.
METHOD_OPTIONS: dict[str, dict] = {
    "delaunay": {},
    "lookahead": {},
    "lookahead α=1": {"alpha": 1},
    "shortest-path": {},
    "lop": {},
    "anneal": {"sweeps": 30, "seed": 0},
}

#: The methods that take the scan lines (the others refuse ``lines=``).
LINE_METHODS = ("lookahead", "shortest-path", "anneal")


def _fingerprint(faces: np.ndarray) -> str:
    return _digest(faces, np.int64)


def _scans(data: Path) -> list[tuple[str, object]]:
    """(name, source) pairs: a source is a path or (points, line_ids)."""
    scans: list[tuple[str, object]] = [("rod", scanmesh.load_rod())]
    for path in sorted(data.rglob("*")):
        if path.suffix in (".vtk", ".dem", ".laz"):
            scans.append((str(path.relative_to(data)), path))
    for path in sorted((data / "cad").glob("*")):
        for noise in (0.0, 1e-3):
            pts, ids = scanmesh.simulate_scan(path, up="z", n_points=6000, noise=noise, seed=1)
            scans.append((f"{path.name} z noise={noise:g}", (pts, ids)))
    rng = np.random.default_rng(2026)
    for k in range(3):
        n = 400 * (k + 1)
        xy = rng.random((n, 2))
        z = np.sin(3 * xy[:, 0]) * np.cos(2 * xy[:, 1]) + rng.normal(0, 0.01, n)
        order = np.lexsort((xy[:, 0], np.floor(xy[:, 1] * 20)))
        pts = np.column_stack([xy, z])[order]
        ids = np.floor(pts[:, 1] * 20).astype(np.int64)
        scans.append((f"random {n}", (pts, ids)))
    return scans


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--data", type=Path, default=ROOT / "tests" / "data")
    parser.add_argument("--methods", nargs="*", default=list(METHOD_OPTIONS))
    parser.add_argument(
        "--only", choices=("methods", "extras"), help="the methods' rows or the extras alone"
    )
    args = parser.parse_args(argv)
    if args.only != "extras":
        _methods(args)
    if args.only != "methods":
        _extras(args.data)
    return 0


def _methods(args: argparse.Namespace) -> None:
    """Every method of ``--methods`` on every scan, and the optimum of a small set."""
    for name, source in _scans(args.data):
        for method in args.methods:
            kwargs = dict(METHOD_OPTIONS[method])
            name_only = method.split()[0]
            try:
                if isinstance(source, tuple):
                    pts, ids = source
                    if name_only in LINE_METHODS:
                        kwargs["lines"] = ids
                    surface = scanmesh.reconstruct(pts, name_only, **kwargs)
                else:
                    surface = scanmesh.reconstruct(source, name_only, **kwargs)
            except scanmesh.ScanmeshError as exc:
                print(f"{name} | {method} | error {type(exc).__name__}: {exc}")
                continue
            print(f"{name} | {method} | {len(surface.faces)} | {_fingerprint(surface.faces)}")
            sys.stdout.flush()
    small = np.random.default_rng(7).random((12, 3))
    surface = scanmesh.reconstruct(small, "optimal")
    print(f"random 12 | optimal | {len(surface.faces)} | {_fingerprint(surface.faces)}")


def _extras(data: Path) -> None:
    """The default's choice, the holdout error and merged meshes (module docstring)."""
    for name, source in _scans(data):
        if isinstance(source, tuple):
            surface = scanmesh.reconstruct(source[0], seed=0)
            chosen = surface.options["method_choice"]["built"]
            print(
                f"{name} | auto ({chosen}) | {len(surface.faces)} | {_fingerprint(surface.faces)}"
            )
    fandisk = ROOT / "tests" / "data" / "cad" / "fandisk.obj"
    pts, ids = scanmesh.simulate_scan(fandisk, up="z", n_points=6000, noise=1e-3, seed=1)
    for method, by in (("delaunay", "points"), ("lop", "points"), ("shortest-path", "lines")):
        lines = {"lines": ids} if by == "lines" else {}
        err = holdout_error(pts, method, seed=3, by=by, **lines)
        print(
            f"fandisk noise=0.001 | holdout {method} by {by} | {err['rms']!r} | {err['p99']!r}"
            f" | {err['outside']}"
        )
    parts = {
        "box": (trimesh.creation.box(extents=(1.0, 0.8, 0.6)), 0.04),
        "fandisk": (trimesh.load(fandisk, force="mesh"), None),
    }
    for name, (mesh, spacing) in parts.items():
        if spacing is None:
            spacing = float(np.linalg.norm(mesh.extents)) / 120
        views = axis_views(mesh, spacing, noise=spacing / 30, grazing=80.0, seed=1)
        merged = scanmesh.merge(views)
        print(
            f"merge {name} six views | {len(merged.vertices)} | {len(merged.faces)}"
            f" | {_digest(merged.vertices, np.float64)} | {_digest(merged.faces, np.int64)}"
        )
        sys.stdout.flush()


def _digest(array: np.ndarray, dtype: type) -> str:
    return hashlib.sha256(np.ascontiguousarray(array, dtype=dtype).tobytes()).hexdigest()[:16]


if __name__ == "__main__":
    raise SystemExit(main())
