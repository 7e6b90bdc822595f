"""Ctrl-C latency: how long the command and its last steps take to answer SIGINT.

    python benches/interrupt.py imports                   # the import times (5 runs each)
    python benches/interrupt.py command 2,3,4 -- merge \
        ../shared/data/multiview/dragon_stand/dragonStandRight.conf -o /tmp/d.ply
    python benches/interrupt.py report /tmp/d.ply          # the merge report's steps on a mesh

``imports``: wall seconds of ``python -c "import X"`` for Python alone, the entry point
(what runs before the command's Ctrl-C handler is in place), the package and the command.
``command``: the command started afresh for each moment (seconds after its start), SIGINT
sent then; the milliseconds until it exited, its exit status and its last progress line
(progress logged every 0.2 s). ``report``: each step the merge command runs after the
fusion (speck removal, pieces, Euler characteristic, label areas, creases, writing), timed
whole, then interrupted at 8 moments within it from a timer thread; the worst
milliseconds from the signal to ``KeyboardInterrupt``, called directly and in
``interruptible``'s worker. Prints the load average first.
"""

from __future__ import annotations

import argparse
import os
import signal
import subprocess
import sys
import tempfile
import threading
import time
from collections.abc import Callable
from pathlib import Path

import numpy as np

#: The command in a child, its progress logged every 0.2 s (as tests/test_interrupt_latency.py).
CHILD = """
import signal, sys
signal.signal(signal.SIGINT, signal.default_int_handler)
import scanmesh._progress
scanmesh._progress.LOG_INTERVAL_SECONDS = 0.2
from scanmesh.cli import main
sys.argv = ["scanmesh", *sys.argv[1:]]
sys.exit(main())
"""


def imports(runs: int = 5) -> None:
    for what in ("", "scanmesh._entry_point", "scanmesh", "scanmesh.cli"):
        times = []
        for _ in range(runs):
            t0 = time.perf_counter()
            subprocess.run([sys.executable, "-c", f"import {what}" if what else "pass"], check=True)
            times.append(time.perf_counter() - t0)
        print(f"import {what or '(python alone)'}: {min(times):.3f}-{max(times):.3f} s")


def command(moments: list[float], args: list[str]) -> None:
    for moment in moments:
        t0 = time.monotonic()
        proc = subprocess.Popen(
            [sys.executable, "-c", CHILD, *args],
            stderr=subprocess.PIPE,
            stdout=subprocess.DEVNULL,
            text=True,
        )
        lines: list[str] = []
        assert proc.stderr is not None
        reader = threading.Thread(target=lines.extend, args=(proc.stderr,), daemon=True)
        reader.start()
        time.sleep(max(0.0, moment - (time.monotonic() - t0)))
        last = next((line.strip() for line in reversed(lines) if line.startswith("scanmesh: ")), "")
        if proc.poll() is not None:
            print(f"{moment:6.2f} s: ended before the signal (exit {proc.returncode})")
            continue
        sent = time.monotonic()
        proc.send_signal(signal.SIGINT)
        code = proc.wait(timeout=120)
        took = time.monotonic() - sent
        print(f"{moment:6.2f} s: {1000 * took:5.0f} ms, exit {code}, during {last[:80]!r}")


def worst_latency(step: Callable[[], object], seconds: float) -> float:
    """The worst seconds from SIGINT to KeyboardInterrupt over 8 moments within ``step``."""
    worst = 0.0
    for at in np.linspace(0.02, max(seconds - 0.02, 0.03), 8):
        sent: list[float] = []

        def fire(at: float = float(at), sent: list[float] = sent) -> None:
            time.sleep(at)
            sent.append(time.monotonic())
            os.kill(os.getpid(), signal.SIGINT)

        timer = threading.Thread(target=fire)
        timer.start()
        try:
            step()
            try:  # it ended before the signal: let the signal pass
                timer.join()
                time.sleep(0.05)
            except KeyboardInterrupt:
                pass
        except KeyboardInterrupt:
            worst = max(worst, time.monotonic() - sent[0])
            timer.join()
    return worst


def report(mesh: Path) -> None:
    import trimesh

    from scanmesh import shape
    from scanmesh._interrupt import UNBOUNDED, interruptible
    from scanmesh.fusion.pieces import drop_specks, pieces
    from scanmesh.surface import Surface

    signal.signal(signal.SIGINT, signal.default_int_handler)
    loaded = trimesh.load(mesh, process=False)
    v = np.asarray(loaded.vertices, dtype=np.float64)
    f = np.asarray(loaded.faces, dtype=np.int64)
    labels = np.zeros(len(f), dtype=np.uint8)
    print(f"{mesh}: {len(v):,} vertices, {len(f):,} faces")

    def surface() -> Surface:
        return Surface(vertices=v, faces=f, method="merge", face_labels=labels)

    out = Path(tempfile.mkdtemp()) / "mesh.ply"
    steps: dict[str, Callable[[], object]] = {
        "drop_specks": lambda: drop_specks(v, f, labels),
        "pieces": lambda: pieces(v, f),
        "euler characteristic": lambda: shape.euler_characteristic(f),
        "label areas": lambda: surface().label_areas,
        "creases": lambda: surface().creases,
        "save (.ply)": lambda: surface().save(out),
    }
    in_worker = {"drop_specks", "pieces", "euler characteristic"}
    for name, step in steps.items():
        t0 = time.perf_counter()
        step()
        seconds = time.perf_counter() - t0
        line = f"{name}: {seconds:.2f} s, Ctrl-C {1000 * worst_latency(step, seconds):.0f} ms"
        if name in in_worker:
            worker = worst_latency(lambda step=step: interruptible(UNBOUNDED, step), seconds)
            line += f" ({1000 * worker:.0f} ms in the worker)"
        print(line, flush=True)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    sub = parser.add_subparsers(dest="what", required=True)
    sub.add_parser("imports")
    run = sub.add_parser("command")
    run.add_argument("moments", help="seconds after the start, comma-separated")
    run.add_argument("args", nargs=argparse.REMAINDER, help="-- and the command's arguments")
    rep = sub.add_parser("report")
    rep.add_argument("mesh", type=Path)
    args = parser.parse_args()
    print(f"load average {os.getloadavg()[0]:.1f}")
    if args.what == "imports":
        imports()
    elif args.what == "command":
        rest = args.args[1:] if args.args[:1] == ["--"] else args.args
        command([float(m) for m in args.moments.split(",")], rest)
    else:
        report(args.mesh)


if __name__ == "__main__":
    main()
