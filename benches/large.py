"""Large scans: time and peak memory of each stage at 100k, 1M and 10M points, and
the command end to end.

    python benches/large.py                              # 100k, 1M, 10M: every stage
    python benches/large.py --sizes 100000 1000000 --anneal-sweeps 2
    python benches/large.py --cli 10000000               # the command alone, /usr/bin/time -v
    python benches/large.py --cli 10000000 --method lookahead --cli-flags "" --work scratch

The scan: a smooth height field (benches/speed.py's surface, in millimetres over a 100 mm
square) on straight scan lines, positions jittered by up to 5 % of the spacing, written as
XYZ text with a line-id column (``x y z line``, 4-5 decimals: 29 bytes per point) into
scanmesh-large/ in the system's temporary folder. 10M points are 3,000 lines of 3,333
points; smaller sizes keep the same shape (lines = 3,000 x sqrt(N / 10M)).

Every stage runs in its own Python process, so its peak resident size (``ru_maxrss``) is its
own; "RSS before" is the size after loading that stage's input (``.npy`` files saved by the
stage before, which are not part of the stage). Stages:

- read: ``scanmesh.read(file)`` (text parse, checks, ScanPoints);
- lines: ``scanmesh.scan.lines.scan_lines(points, ids, plane="z")`` (projection, segments,
  median step, gaps; the strips stage does this again inside its native call);
- strips: ``strip_surface(points, lines=ids, plane="z")`` (projection, lines, shortest-path
  strips with the default weight, planar check), split by ``Surface.timings``;
- anneal: ``reconstruct(..., "anneal", initial="shortest-path", sweeps=S, patience=0,
  polish=False)``: seconds per sweep = ``timings["anneal"] / S`` (so it includes the
  annealer's setup: T0 calibration, relabelling, building the result);
- write: ``save_mesh(.stl)`` of the strips' faces (binary STL, atomic).
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import re
import resource
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
WORK = Path(tempfile.gettempdir()) / "scanmesh-large"
STAGES = ("read", "lines", "strips", "anneal", "write")


def surface_z(x: np.ndarray, y: np.ndarray) -> np.ndarray:
    """Height (mm) of the synthetic part at (x, y) in mm: speed.py's field on a 100 mm square."""
    u, v = x / 100.0, y / 100.0
    wave = 0.2 * np.sin(7 * u) * np.cos(5 * v) + 0.05 * np.sin(23 * u + 11 * v)
    return 100.0 * (wave + 0.1 * u * u)


def synthetic_xyz(path: Path, n: int, lines: int, seed: int = 0) -> Path:
    """Write about n points on ``lines`` scan lines as ``x y z line`` text; returns path.

    Formatted 100 lines at a time (one %-format per block, no Python step per point).
    """
    per = max(n // lines, 3)
    rng = np.random.default_rng(seed)
    step, gap = 100.0 / per, 100.0 / lines
    tmp = path.with_name(path.name + ".part")
    with open(tmp, "wb") as f:
        f.write(b"# synthetic scan: x y z line (mm), benches/large.py\n")
        for first in range(0, lines, 100):
            last = min(lines, first + 100)
            k = (last - first) * per
            x = np.tile(np.arange(per) * step, last - first) + rng.uniform(-0.05, 0.05, k) * step
            y = np.repeat(np.arange(first, last) * gap, per) + rng.uniform(-0.05, 0.05, k) * gap
            ids = np.repeat(np.arange(first, last), per).astype(np.float64)
            values = np.column_stack([x, y, surface_z(x, y), ids]).ravel().tolist()
            f.write((("%.4f %.4f %.5f %d\n" * k) % tuple(values)).encode("ascii"))
    tmp.replace(path)
    return path


def lines_for(n: int) -> int:
    """3,000 lines at 10M points, the same aspect at other sizes."""
    return max(int(round(3000 * np.sqrt(n / 10_000_000))), 3)


def rss_mb() -> float:
    """Peak resident size of this process so far (MB; Linux reports kB)."""
    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024


def current_rss_mb() -> float:
    with open("/proc/self/statm") as f:
        return int(f.read().split()[1]) * os.sysconf("SC_PAGE_SIZE") / 2**20


def files(n: int) -> dict[str, Path]:
    base = WORK / f"scan{n}"
    return {
        "xyz": base.with_suffix(".xyz"),
        "points": Path(f"{base}.points.npy"),
        "ids": Path(f"{base}.ids.npy"),
        "faces": Path(f"{base}.faces.npy"),
        "stl": base.with_suffix(".stl"),
    }


def child(stage: str, n: int, sweeps: int) -> None:
    """Run one stage on size n and print a JSON line."""
    import scanmesh
    from scanmesh.formats.write import save_mesh
    from scanmesh.scan.lines import scan_lines
    from scanmesh.stages.strips import strip_surface

    f = files(n)
    out: dict = {"stage": stage, "n": n}
    if stage == "read":
        base = current_rss_mb()
        t0 = time.perf_counter()
        scan = scanmesh.read(f["xyz"])
        out["time_s"] = time.perf_counter() - t0
        np.save(f["points"], scan.points)
        np.save(f["ids"], scan.line_ids)
        out["detail"] = f"{len(scan):,} points, {scan.n_lines:,} lines"
    else:
        points, ids = np.load(f["points"]), np.load(f["ids"])
        faces = np.load(f["faces"]) if stage == "write" else None
        base = current_rss_mb()
        t0 = time.perf_counter()
        if stage == "lines":
            lines = scan_lines(points, ids, plane="z")
            out["detail"] = f"{lines.n_lines:,} lines, {lines.n_segments:,} segments"
        elif stage == "strips":
            surface = strip_surface(points, lines=ids, plane="z")
            out["detail"] = ", ".join(
                f"{k} {v:.3g}" for k, v in surface.timings.items()
            ) + f"; {len(surface.faces):,} faces"
            np.save(f["faces"], surface.faces)
        elif stage == "anneal":
            surface = scanmesh.reconstruct(
                points, "anneal", lines=ids, plane="z", initial="shortest-path",
                sweeps=sweeps, patience=0, polish=False, seed=0,
            )
            done = len(surface.trace["energy"])
            out["per_sweep_s"] = surface.timings["anneal"] / max(done, 1)
            out["detail"] = (
                f"{done} sweep(s): anneal {surface.timings['anneal']:.3g} s"
                f" (strips before it {surface.timings.get('strips', 0):.3g} s)"
            )
        elif stage == "write":
            save_mesh(f["stl"], points, faces)
            out["detail"] = f"{len(faces):,} faces, {f['stl'].stat().st_size / 1e6:,.0f} MB"
        out["time_s"] = time.perf_counter() - t0
    out["base_mb"], out["peak_mb"] = base, rss_mb()
    print(json.dumps(out))


def run_child(stage: str, n: int, sweeps: int, timeout: float) -> dict:
    cmd = [sys.executable, __file__, "--child", stage, str(n), "--anneal-sweeps", str(sweeps),
           "--work", str(WORK)]
    try:
        res = subprocess.run(cmd, capture_output=True, text=True, timeout=timeout, check=True)
    except subprocess.TimeoutExpired:
        return {"stage": stage, "n": n, "error": f"over {timeout:.0f} s"}
    except subprocess.CalledProcessError as exc:
        last = (exc.stderr.strip().splitlines() or ["?"])[-1]
        return {"stage": stage, "n": n, "error": last[:90]}
    return json.loads(res.stdout.strip().splitlines()[-1])


def machine() -> str:
    load = os.getloadavg()
    return (
        f"{platform.machine()}, {os.cpu_count()} cores, Python {platform.python_version()},"
        f" {time.strftime('%Y-%m-%d %H:%M')}, load average {load[0]:.1f} / {load[1]:.1f} /"
        f" {load[2]:.1f}"
    )


def prepare(n: int) -> Path:
    path = files(n)["xyz"]
    if not path.exists():
        WORK.mkdir(parents=True, exist_ok=True)
        synthetic_xyz(path, n, lines_for(n))
    return path


def stages_table(sizes: list[int], sweeps: int, timeout: float, skip: set[str]) -> None:
    print(f"machine: {machine()}\n", flush=True)
    print("| points | stage | time (s) | peak RSS (MB) | RSS before (MB) | detail |")
    print("|---:|---|---:|---:|---:|---|", flush=True)
    for n in sizes:
        path = prepare(n)
        for stage in STAGES:
            if stage in skip:
                continue
            r = run_child(stage, n, sweeps, timeout)
            if "error" in r:
                print(f"| {n:,} | {stage} | {r['error']} | - | - | - |", flush=True)
                continue
            t = f"{r['time_s']:.3g}"
            if stage == "anneal":
                t = f"{r['per_sweep_s']:.3g} per sweep"
            elif stage == "read":
                t += f" ({path.stat().st_size / r['time_s'] / 1e6:,.0f} MB/s)"
            print(
                f"| {n:,} | {stage} | {t} | {r['peak_mb']:,.0f} | {r['base_mb']:,.0f} |"
                f" {r.get('detail', '')} |",
                flush=True,
            )
    print(f"\nmachine after: {machine()}", flush=True)


def cli(n: int, method: str, extra: list[str]) -> None:
    """The command end to end under /usr/bin/time -v: wall time and peak RSS."""
    path = prepare(n)
    out = files(n)["stl"]
    cmd = ["scanmesh", "reconstruct", str(path), "-o", str(out), "--method", method, *extra]
    print(f"machine: {machine()}\n$ /usr/bin/time -v {' '.join(cmd)}", flush=True)
    res = subprocess.run(["/usr/bin/time", "-v", *cmd], capture_output=True, text=True)
    print(res.stdout)
    wall = re.search(r"Elapsed \(wall clock\) time.*: (\S+)", res.stderr)
    peak = re.search(r"Maximum resident set size \(kbytes\): (\d+)", res.stderr)
    cpu = re.search(r"Percent of CPU this job got: (\S+)", res.stderr)
    print(f"exit {res.returncode}; wall {wall and wall.group(1)}; CPU {cpu and cpu.group(1)};"
          f" peak RSS {int(peak.group(1)) / 1024:,.0f} MB" if peak else res.stderr[-500:])
    print(f"machine after: {machine()}", flush=True)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--sizes", type=int, nargs="+", default=[100_000, 1_000_000, 10_000_000])
    parser.add_argument("--anneal-sweeps", type=int, default=2)
    parser.add_argument("--timeout", type=float, default=900.0, help="seconds per process")
    parser.add_argument("--skip", nargs="*", default=[], choices=STAGES)
    parser.add_argument("--cli", type=int, metavar="N", help="the command end to end at N points")
    parser.add_argument("--method", default="shortest-path", help="--cli: the method")
    parser.add_argument(
        "--cli-flags", default="--plane z", help="--cli: more flags of the command (one string)"
    )
    parser.add_argument("--work", type=Path, help=f"folder of the scans and meshes ({WORK})")
    parser.add_argument("--child", nargs=2, metavar=("STAGE", "N"), help=argparse.SUPPRESS)
    args = parser.parse_args()
    if args.work is not None:
        globals()["WORK"] = args.work
    if args.child:
        child(args.child[0], int(args.child[1]), args.anneal_sweeps)
    elif args.cli:
        cli(args.cli, args.method, args.cli_flags.split())
    else:
        stages_table(args.sizes, args.anneal_sweeps, args.timeout, set(args.skip))


if __name__ == "__main__":
    main()
