"""Time and peak memory of ``merge`` on real multi-view scans, at its voxel and at half of it,
against Open3D's screened Poisson (depth 8, and 9 with ``--depths``) in the same run.

    nice python benches/fusion_scaling.py                       # both sets, Markdown table
    nice python benches/fusion_scaling.py --sets happy_side --halves 0
    python benches/fusion_scaling.py --json out.jsonl

Each run is a child process (its peak resident memory is its own ``ru_maxrss``). The
scans are read from ``../shared/data/multiview/SET/*.conf`` with ``read_conf(...,
inverse_rotation=True)`` (the convention these files align with; see the data's README),
``camera`` and ``mesh`` lines dropped and ``FILE.ply.gz`` read where the file names
``FILE.ply``. Poisson gets the same points: normals estimated per scan (Open3D, 12
neighbours) and oriented towards that scan's scanner (its +z), estimated inside its time.
Seconds are wall time on a shared machine: compare ratios within one run.
"""

from __future__ import annotations

import argparse
import json
import subprocess
import sys
from pathlib import Path

DATA = Path(__file__).resolve().parents[1] / ".." / "shared" / "data" / "multiview"
SETS = {
    "dragon_stand": "dragonStandRight.conf",
    "dragon_side": "dragonSideRight.conf",
    "happy_side": "happySideRight.conf",
}

CHILD = r"""
import json, resource, sys, tempfile, time
from pathlib import Path
import numpy as np
import scanmesh

conf, what, arg = Path(sys.argv[1]), sys.argv[2], float(sys.argv[3])
# only the scans, under the names the files have
lines = [l.split() for l in conf.read_text().splitlines()]
scans = [l for l in lines if l and l[0] == "bmesh"]
tmp = Path(tempfile.mkdtemp())
for l in scans:
    name = l[1] if (conf.parent / l[1]).exists() else l[1] + ".gz"
    (tmp / l[1]).symlink_to((conf.parent / name).resolve())
(tmp / conf.name).write_text("\n".join(" ".join(l) for l in scans) + "\n")
views = scanmesh.read_conf(tmp / conf.name, inverse_rotation=True)
points = sum(len(v.points) for v in views)
t0 = time.perf_counter()
if what == "merge":
    voxel = None if arg == 0 else arg
    surface = scanmesh.merge(views, voxel=voxel)
    out = {"faces": len(surface.faces), "voxel": surface.options["voxel"],
           "grid": surface.options["grid"],
           "allocated": surface.options.get("allocated_voxels"),
           "timings": surface.timings}
else:
    import open3d as o3d
    pts, nrm = [], []
    for v in views:
        pcd = o3d.geometry.PointCloud(o3d.utility.Vector3dVector(v.points))
        pcd.estimate_normals(o3d.geometry.KDTreeSearchParamKNN(knn=12))
        pcd.orient_normals_to_align_with_direction(np.array([0.0, 0.0, 1.0]))
        rot, shift = v.pose[:3, :3], v.pose[:3, 3]
        pts.append(v.points @ rot.T + shift)
        nrm.append(np.asarray(pcd.normals) @ rot.T)
    cloud = o3d.geometry.PointCloud(o3d.utility.Vector3dVector(np.concatenate(pts)))
    cloud.normals = o3d.utility.Vector3dVector(np.concatenate(nrm))
    mesh, _ = o3d.geometry.TriangleMesh.create_from_point_cloud_poisson(cloud, depth=int(arg))
    out = {"faces": len(mesh.triangles)}
out["seconds"] = time.perf_counter() - t0
out["points"] = points
out["peak GiB"] = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 2**20
print(json.dumps(out))
"""


def run(conf: Path, what: str, arg: float) -> dict:
    r = subprocess.run(
        [sys.executable, "-c", CHILD, str(conf), what, str(arg)],
        capture_output=True,
        text=True,
        check=False,
    )
    if r.returncode != 0:
        return {"error": r.stderr.strip().splitlines()[-1] if r.stderr else "failed"}
    return json.loads(r.stdout.strip().splitlines()[-1])


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--sets", nargs="*", choices=list(SETS), default=["dragon_stand", "happy_side"])
    ap.add_argument("--data", type=Path, default=DATA)
    ap.add_argument("--halves", type=int, default=1, help="also merge at voxel / 2**k, k <= this")
    ap.add_argument("--depths", nargs="*", type=int, default=[8, 9], help="Poisson depths")
    ap.add_argument("--json", type=Path, help="also write the rows here (JSON lines)")
    args = ap.parse_args()
    rows = []
    for name in args.sets:
        conf = args.data / name / SETS[name]
        for depth in args.depths:
            row = run(conf, "poisson", depth)
            rows.append({"set": name, "method": f"open3d poisson d{depth}", **row})
            print(rows[-1], file=sys.stderr, flush=True)
        base = run(conf, "merge", 0)
        rows.append({"set": name, "method": "scanmesh merge", **base})
        print(rows[-1], file=sys.stderr, flush=True)
        for k in range(1, args.halves + 1):
            if "voxel" not in base:
                break
            voxel = base["voxel"] / 2**k
            rows.append({"set": name, "method": f"merge voxel/{2**k}", **run(conf, "merge", voxel)})
            print(rows[-1], file=sys.stderr, flush=True)
    if args.json:
        with args.json.open("a") as f:
            for r in rows:
                f.write(json.dumps(r) + "\n")
    print(
        "| set | method | points | voxel | grid (box) | nodes allocated: distances + flags"
        " | faces | seconds | × d8 | peak GiB |"
    )
    print("|---|---|---|---|---|---|---|---|---|---|")
    for r in rows:
        d8 = next(x for x in rows if x["set"] == r["set"] and x["method"].endswith("d8"))
        ratio = r["seconds"] / d8["seconds"] if "seconds" in r and "seconds" in d8 else float("nan")
        voxel = f"{r['voxel']:.3g}" if "voxel" in r else ""
        grid = " × ".join(map(str, r["grid"])) if r.get("grid") else ""
        alloc = " + ".join(f"{a:,}" for a in r["allocated"]) if r.get("allocated") else ""
        if "error" in r:
            print(f"| {r['set']} | {r['method']} | | | | | | {r['error'][:60]} | | |")
            continue
        print(
            f"| {r['set']} | {r['method']} | {r['points']:,} | {voxel} | {grid} | {alloc}"
            f" | {r['faces']:,} | {r['seconds']:.1f} | {ratio:.2f} | {r['peak GiB']:.2f} |"
        )


if __name__ == "__main__":
    main()
