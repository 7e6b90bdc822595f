"""``scanmesh demo``: a CAD part with creases scanned with noise, reconstructed by Delaunay
and by annealing, judged against the part and pictured side by side."""

from __future__ import annotations

import argparse
import time
from pathlib import Path

from scanmesh.cli._common import _Console, _dumps, _quality_row
from scanmesh.demo import PART_SCAN, demo_part, scan_demo_part
from scanmesh.errors import ParameterError
from scanmesh.evaluate.truth import MEASURE, TrueSurface, height_error
from scanmesh.formats.write import save_mesh
from scanmesh.present.render import auto_view
from scanmesh.present.side_by_side import render_side_by_side
from scanmesh.reconstruction import reconstruct
from scanmesh.scan.planar import planar_scan
from scanmesh.stages.delaunay import delaunay

#: File names ``scanmesh demo`` writes: the annealed mesh, the two meshes shaded, and the
#: two coloured by tac on one scale (Delaunay left, annealed right).
DEMO_MESH = "demo_part.stl"
DEMO_PREVIEW = "demo_part.png"
DEMO_TAC = "demo_tac.png"

#: Rows of the printed table: label, format, key.
ROWS = (
    ("faces", "{:,}", "faces"),
    ("tac_1 (rad)", "{:.4g}", "tac_1"),
    ("tac_inf (rad)", "{:.4g}", "tac_inf"),
    ("smallest angle (deg)", "{:.2f}", "min_angle_deg"),
    ("slivers (%)", "{:.2f}", "sliver_fraction"),
    ("RMS height error", "{:.3e}", "h_rms"),
    ("max height error", "{:.3e}", "h_max"),
    ("time (s)", "{:.2f}", "time_s"),
)


def cmd_demo(args: argparse.Namespace, con: _Console) -> int:
    """Scan the fandisk, reconstruct it by Delaunay and by annealing, compare both with the
    part; write demo_part.stl, demo_part.png and demo_tac.png into ``args.output_dir``."""
    folder = Path(args.output_dir)
    parent = folder.parent if str(folder.parent) else Path(".")
    if not parent.is_dir():
        raise ParameterError(f"cannot write into {folder}: folder {parent} does not exist")
    folder.mkdir(exist_ok=True)
    mesh_path, png_path, tac_path = folder / DEMO_MESH, folder / DEMO_PREVIEW, folder / DEMO_TAC
    part = demo_part()
    points, line_ids, spacing = scan_demo_part(part)
    plane = PART_SCAN["up"]
    con.out(
        f"demo: Hoppe's fandisk turned {PART_SCAN['turn_deg']:g} degrees about {plane}, so its"
        f" creases cross the scan lines, scanned along {plane} with noise"
        f" {PART_SCAN['noise'] * spacing:.2g} (1/{1 / PART_SCAN['noise']:.0f} of the spacing):"
        f" {len(points):,} points on {int(line_ids.max()) + 1} lines"
    )
    # One scan and one Delaunay triangulation: a column of the table and annealing's start.
    t0 = time.perf_counter()
    scan = planar_scan(points, plane=plane, lines=line_ids)
    base = delaunay(scan)
    t_base = time.perf_counter() - t0
    t0 = time.perf_counter()
    surface = reconstruct(scan, "anneal", initial=base, seed=0, progress=con.progress)
    t_anneal = t_base + time.perf_counter() - t0
    save_mesh(mesh_path, surface.vertices, surface.faces)
    camera = auto_view(surface.vertices, surface.faces, surface.frame)
    render_side_by_side([base, surface], png_path, size=(800, 600), **camera)
    _, scale = render_side_by_side([base, surface], tac_path, color_by="tac", **camera)
    truth = TrueSurface(part)
    results = {}
    for name, surf, seconds in (("delaunay", base, t_base), ("anneal", surface, t_anneal)):
        row = {"time_s": seconds, "faces": int(len(surf.faces)), **_quality_row(surf)}
        err = height_error(surf, truth, seed=0)
        row.update({k: err[k] for k in ("h_rms", "h_max")})
        results[name] = row
    files = [str(mesh_path), str(png_path), str(tac_path)]
    if con.json:
        print(
            _dumps(
                {
                    "points": len(points),
                    "lines": int(line_ids.max()) + 1,
                    "plane": plane,
                    "seed": 0,
                    "methods": results,
                    "height_error": MEASURE,
                    "tac_scale": None if scale is None else list(scale[1:3]),
                    "files": files,
                }
            )
        )
        return 0
    d, a = results["delaunay"], results["anneal"]
    con.out(f"{'':<24}{'Delaunay':>12}{'annealed':>12}")
    for label, spec, key in ROWS:
        factor = 100 if key == "sliver_fraction" else 1
        con.out(f"{label:<24}{spec.format(d[key] * factor):>12}{spec.format(a[key] * factor):>12}")
    con.out(
        f"annealing ({surface.options['sweeps']:,} sweeps from LOP's optimum, seed 0): tac_1"
        f" {a['tac_1'] / d['tac_1']:.2f} x and RMS height error {a['h_rms'] / d['h_rms']:.2f} x"
        " Delaunay's"
    )
    con.out(
        "height error: closest-point distance to the part at 100,000 random points on each mesh"
    )
    con.out(f"pictures: Delaunay left, annealed right; {png_path.name} shaded by one light")
    if scale is not None:
        con.out(f"{tac_path.name}: faces coloured by {scale.describe()}, bar at the right")
    con.summary(f"wrote {', '.join(files)}")
    return 0
