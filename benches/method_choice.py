"""Would a holdout among the methods pick, on each panel scan, the method that is best there?

For each scan of ``benches/panel.py``: a window of at most ``--window`` points (consecutive
scan lines around the middle one), a seeded share of it withheld (single points, or whole
lines), every candidate method built on the rest, and each withheld point's distance to
each candidate's mesh measured (along the projection normal, and along the mesh's normal),
on the points every candidate's mesh covers. The candidates' true errors are the panel's:
height RMS against the part (simulated scans; the choice made on the scan), the panel's
holdout RMS per split (real scans; the choice made on each split's 90 % input).

    python benches/method_choice.py --scans fran_cut,octagonal_axis_s/10 --out /tmp/mc
    python benches/method_choice.py --report /tmp/mc      # the picks under each variant

Per scan one pickle in ``--out``; ``--report`` reads them and prints, per variant of the
judge (points or lines withheld, vertical or normal distance, tie margin for anneal), the
pick and the pick's true error over the best baseline's.
"""

from __future__ import annotations

import argparse
import pickle
import sys
import tempfile
import time
import warnings
from pathlib import Path

import numpy as np
import panel

import scanmesh
from scanmesh.evaluate.holdout import holdout_error
from scanmesh.scan.locate import normal_distances
from scanmesh.stages.choice import folds, window

CANDIDATES = ("anneal", "lop", "delaunay", "shortest-path")
BASELINES = ("delaunay", "lop", "lookahead", "shortest-path")
#: Methods whose true error is measured.
MEASURED_METHODS = ("anneal", *BASELINES)


class _Box:
    """A queue stand-in for ``panel.child``: collects what it puts."""

    def __init__(self) -> None:
        self.got: dict = {}

    def put(self, item: dict) -> None:
        self.got.update(item)


def _kw(method: str, plane, lines, seed: int) -> dict:
    """The keywords panel.child passes to ``method``."""
    kw = {"plane": plane} if plane is not None else {}
    if method in ("lookahead", "shortest-path", "anneal") and lines is not None:
        kw["lines"] = lines
    if method == "anneal":
        kw["seed"] = seed
    return kw


def distances(pts: np.ndarray, kept: np.ndarray, out: np.ndarray, surface) -> np.ndarray:
    """(2, len(out)): vertical and normal distance of each withheld point to the mesh built
    on ``pts[kept]`` (nan outside)."""
    frame = surface.frame
    axes = np.column_stack([frame.u, frame.v])
    tri = pts[kept][surface.faces]
    vertical, face = normal_distances(pts[out], tri, axes, frame.normal)
    inside = face >= 0
    got = np.full((2, len(out)), np.nan)
    held = face[inside]
    along = vertical[inside]
    cross = np.cross(tri[held, 1] - tri[held, 0], tri[held, 2] - tri[held, 0])
    cosine = np.abs(cross @ frame.normal) / np.maximum(np.linalg.norm(cross, axis=1), 1e-300)
    got[0, inside] = along
    got[1, inside] = along * cosine
    return got


def judge(pts, lines, plane, seed: int, size: int, measured: int, modes) -> dict:
    """Per (by, method): per fold the (2, withheld) distances of the withheld window points."""
    win = np.arange(len(pts)) if lines is None else window(lines, size)
    wp = pts[win]
    wl = None if lines is None else lines[win]
    got: dict = {"window": len(win)}
    for by in modes:
        if by == "lines":
            ids = np.unique(wl)
            parts = [
                np.flatnonzero(np.isin(wl, ids[f]))
                for f in folds(len(ids), seed, measured // max(1, len(wp) // len(ids)))
            ]
        else:
            parts = folds(len(wp), seed, measured)
        for m in CANDIDATES:
            t = time.perf_counter()
            per = []
            for out in parts:
                kept = np.setdiff1d(np.arange(len(wp)), out)
                kw = _kw(m, plane, None if wl is None else wl[kept], seed)
                surface = scanmesh.reconstruct(wp[kept], m, **kw)
                per.append(distances(wp, kept, out, surface))
            got[by, m] = (per, time.perf_counter() - t)
    return got


def measure(scan: dict, folder: Path, size: int, measured: int, modes) -> dict:
    info = panel.prepare(scan, folder)
    data = np.load(info["npz"])
    pts = data["points"]
    lines = data["lines"] if len(data["lines"]) else None
    plane = info.get("plane")
    out: dict = {"name": scan["name"], "kind": scan["kind"], "n": len(pts)}
    if scan["kind"] == "sim":
        out["truth"] = {}
        for m in MEASURED_METHODS:
            box = _Box()
            panel.child("sim", info, m, box)
            out["truth"][m] = box.got["h_rms"]
        out["judges"] = [judge(pts, lines, plane, 0, size, measured, modes)]
    else:
        out["truth"] = {m: [] for m in MEASURED_METHODS}
        out["judges"] = []
        for s in panel.HOLDOUT_SEEDS:
            kept = None
            for m in MEASURED_METHODS:
                kw = _kw(m, plane, lines, s)
                kw.pop("seed", None)
                r = holdout_error(pts, m, fraction=panel.HOLDOUT_FRACTION, seed=s, **kw)
                out["truth"][m].append(r["rms"])
                kept = r["kept"]
            sub_lines = None if lines is None else lines[kept]
            out["judges"].append(judge(pts[kept], sub_lines, plane, s, size, measured, modes))
    return out


def _rms(d: np.ndarray) -> float:
    return float(np.sqrt(np.mean(d * d)))


def pick(j: dict, by: str, kind: int, tie: float, common: bool, nf: int) -> tuple[str, dict]:
    """The judged pick on the first ``nf`` folds: lowest RMS (anneal within ``tie`` wins)."""
    ds = {
        m: np.concatenate([f[kind] for f in j[by, m][0][:nf]]) for m in CANDIDATES if (by, m) in j
    }
    if common:
        ok = np.logical_and.reduce([np.isfinite(d) for d in ds.values()])
        rms = {m: _rms(d[ok]) for m, d in ds.items()}
    else:
        rms = {m: _rms(d[np.isfinite(d)]) for m, d in ds.items()}
    best = min(rms.values())
    if rms["anneal"] <= best * (1 + tie):
        return "anneal", rms
    return min(rms, key=rms.__getitem__), rms


def report(folder: Path) -> None:
    runs = [pickle.loads(p.read_bytes()) for p in sorted(folder.glob("*.pkl"))]
    variants = [
        (by, kind, tie, common, nf)
        for by in ("points", "lines")
        for kind in (0, 1)
        for tie in (0.0, 0.02)
        for common in (True,)
        for nf in (1, 2, 3, 10)
    ]
    for by, kind, tie, common, nf in variants:
        if not all((by, "anneal") in r["judges"][0] for r in runs):
            continue
        label = f"by={by} {'normal' if kind else 'vertical'} tie={tie} folds<={nf}"
        met, worst, lines = 0, 0.0, []
        for r in runs:
            truth = r["truth"]
            if r["kind"] == "sim":
                p, rms = pick(r["judges"][0], by, kind, tie, common, nf)
                err = truth[p]
                picks = p
            else:
                ps = [pick(j, by, kind, tie, common, nf)[0] for j in r["judges"]]
                err = float(np.mean([truth[p][k] for k, p in enumerate(ps)]))
                truth = {m: float(np.mean(v)) for m, v in truth.items()}
                picks = "/".join(ps)
            base = min(truth[m] for m in BASELINES)
            ratio = err / base
            met += ratio <= 1.0 + 1e-9
            worst = max(worst, ratio)
            anneal = truth["anneal"] / base
            lines.append(f"  {r['name']:24s} {picks:40s} {ratio:.3f} (anneal {anneal:.3f})")
        print(f"{label}: goal met on {met}/{len(runs)}, worst {worst:.3f}")
        print("\n".join(lines))


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--data", type=Path, default=panel.SHARED)
    parser.add_argument("--scans", help="comma-separated panel scan names")
    parser.add_argument("--out", type=Path, help="folder for one pickle per scan")
    parser.add_argument("--report", type=Path, help="print the picks from a folder")
    parser.add_argument("--window", type=int, default=25_000)
    parser.add_argument("--measured", type=int, default=5_000, help="withheld points to measure")
    parser.add_argument("--modes", default="points,lines")
    args = parser.parse_args()
    if args.report:
        report(args.report)
        return
    full = {s["name"]: s for s in panel.panel(args.data, False)}
    args.out.mkdir(parents=True, exist_ok=True)
    for name in args.scans.split(","):
        with tempfile.TemporaryDirectory() as tmp:
            t = time.perf_counter()
            got = measure(full[name], Path(tmp), args.window, args.measured, args.modes.split(","))
        (args.out / f"{name.replace('/', '-')}.pkl").write_bytes(pickle.dumps(got))
        print(f"{name}: {time.perf_counter() - t:.0f} s", file=sys.stderr, flush=True)


if __name__ == "__main__":
    warnings.simplefilter("ignore")
    main()
