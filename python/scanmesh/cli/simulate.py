"""``scanmesh simulate``: scan a CAD mesh with the virtual line digitizer and write the
points."""

from __future__ import annotations

import argparse
import time
from pathlib import Path

from scanmesh.cli._common import _check_outputs, _Console, _dumps
from scanmesh.errors import ParameterError
from scanmesh.evaluate.digitizer import simulate_scan
from scanmesh.formats.write import write_points
from scanmesh.scan.axes import parse_axis

#: File endings ``scanmesh simulate`` writes (XYZ text, read back by ``scanmesh.read``).
POINT_ENDINGS = (".xyz", ".txt", ".asc")


def cmd_simulate(args: argparse.Namespace, con: _Console) -> int:
    """Scan a mesh with the virtual line digitizer; write the points as XYZ text."""
    mesh, out = Path(args.mesh), Path(args.output)
    if out.suffix.lower() not in POINT_ENDINGS:
        raise ParameterError(
            f"cannot write {out}: points are written as XYZ text; use an ending in"
            f" {', '.join(POINT_ENDINGS)}"
        )
    _check_outputs([mesh], [out])
    t0 = time.perf_counter()
    points, line_ids = simulate_scan(
        mesh,
        up=args.up,
        along=args.along,
        spacing=args.spacing,
        line_spacing=args.line_spacing,
        n_points=args.n_points,
        noise=args.noise,
        table=args.table,
        seed=args.seed,
    )
    elapsed = time.perf_counter() - t0
    if len(points) == 0:
        raise ParameterError(f"no ray hit {mesh}; check --up and the spacing")
    write_points(out, points, line_ids, up=parse_axis(args.up, "up"), protect=[mesh])
    n_lines = int(line_ids.max()) + 1 if len(line_ids) else 0
    if con.json:
        print(
            _dumps(
                {
                    "mesh": str(mesh),
                    "output": str(out),
                    "points": len(points),
                    "lines": n_lines,
                    "time_s": elapsed,
                }
            )
        )
    else:
        con.summary(f"wrote {out}: {len(points):,} points on {n_lines:,} lines ({elapsed:.2f} s)")
    return 0
