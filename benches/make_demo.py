"""Regenerate the embedded data (python/scanmesh/data/): the rod's scan, the demo's part.

    python benches/make_demo.py            # write the files
    python benches/make_demo.py --check    # fail if the shipped files differ

The output is byte for byte deterministic: no noise, zip entries with a fixed date, gzip
without a time stamp. The STL is read from ../shared/data/cad/ and checked by SHA-256.
"""

from __future__ import annotations

import argparse
import gzip
import hashlib
import io
import sys
import zipfile
from pathlib import Path

import numpy as np

from scanmesh.evaluate.digitizer import simulate_scan

ROOT = Path(__file__).resolve().parents[1]
SOURCE = ROOT.parent / "shared" / "data" / "cad" / "conrod_slevin48_onshape.stl"
SOURCE_SHA256 = "245274520eab8ba9b5b93aed6cb5f9ed787537fb9b623c7a1a28b0a9ac2e4754"
OUT = ROOT / "python" / "scanmesh" / "data"
SCAN = OUT / "conrod_scan.npz"
TRUTH = OUT / "conrod_slevin48_onshape.stl.gz"
#: The part ``scanmesh demo`` scans (scanmesh.demo.demo_part), shipped as it is, gzipped.
PART_SOURCE = ROOT.parent / "shared" / "data" / "cad" / "fandisk.obj"
PART_SOURCE_SHA256 = "27e201141bf9c869b922ce4f03fdef7b5dfc62b7e721f77b44efae1e2aecdce9"
PART = OUT / "fandisk.obj.gz"
ATTRIBUTION = OUT / "ATTRIBUTION.md"

#: The paper's connecting rod had 14,339 points.
N_POINTS = 14_339
SETTINGS = {"up": "y", "along": "x", "n_points": N_POINTS, "noise": 0.0, "table": False}


def npz_bytes(arrays: dict[str, np.ndarray]) -> bytes:
    """An .npz (deflated zip of .npy files) whose bytes depend only on the arrays."""
    buf = io.BytesIO()
    with zipfile.ZipFile(buf, "w", compression=zipfile.ZIP_DEFLATED) as archive:
        for name, arr in arrays.items():
            info = zipfile.ZipInfo(f"{name}.npy", date_time=(1980, 1, 1, 0, 0, 0))
            info.compress_type = zipfile.ZIP_DEFLATED
            info.external_attr = 0o644 << 16
            member = io.BytesIO()
            np.lib.format.write_array(member, np.ascontiguousarray(arr), allow_pickle=False)
            archive.writestr(info, member.getvalue(), compresslevel=9)
    return buf.getvalue()


def build() -> dict[Path, bytes]:
    raw = SOURCE.read_bytes()
    digest = hashlib.sha256(raw).hexdigest()
    if digest != SOURCE_SHA256:
        sys.exit(f"{SOURCE} has SHA-256 {digest}, expected {SOURCE_SHA256}")
    points, line_ids = simulate_scan(SOURCE, **SETTINGS)
    along = np.diff(points[line_ids == line_ids[0], 0])
    spacing = float(along.min())
    scan = npz_bytes({"points": points, "line_ids": line_ids})
    truth = gzip.compress(raw, compresslevel=9, mtime=0)
    text = ATTRIBUTION_TEXT.format(
        sha=SOURCE_SHA256,
        n=len(points),
        lines=int(line_ids.max()) + 1,
        spacing=spacing,
        scan_sha=hashlib.sha256(scan).hexdigest(),
        truth_sha=hashlib.sha256(truth).hexdigest(),
        lo=np.array2string(points.min(axis=0), precision=4),
        hi=np.array2string(points.max(axis=0), precision=4),
    )
    part_raw = PART_SOURCE.read_bytes()
    digest = hashlib.sha256(part_raw).hexdigest()
    if digest != PART_SOURCE_SHA256:
        sys.exit(f"{PART_SOURCE} has SHA-256 {digest}, expected {PART_SOURCE_SHA256}")
    part = gzip.compress(part_raw, compresslevel=9, mtime=0)
    text += PART_TEXT.format(sha=PART_SOURCE_SHA256, gz_sha=hashlib.sha256(part).hexdigest())
    return {SCAN: scan, TRUTH: truth, PART: part, ATTRIBUTION: text.encode()}


ATTRIBUTION_TEXT = """\
# Embedded data: the rod's scan and the demo's part

## conrod_slevin48_onshape.stl.gz: the true surface

A connecting rod modelled in Onshape: binary STL, 524 vertices / 1,044 faces, watertight,
5.61 x 0.79 x 1.97 (inches), long axis x, thickness along y.

- source: GitHub repository slevin48/3d, file `conrod.stl`, commit 6c52a466
- licence: MIT, as the repository's README states (it has no LICENSE file naming a
  holder; the copyright is the repository owner's, slevin48); the MIT terms follow below
- stored: the original bytes, gzip-compressed (`gzip.compress(raw, 9, mtime=0)`);
  SHA-256 of the uncompressed STL: `{sha}`
  (the same file as `shared/data/cad/conrod_slevin48_onshape.stl`)

## conrod_scan.npz: a simulated scan of it (`scanmesh.load_rod()`)

Made by this project (no noise, so every point lies on the STL's surface):

```
python benches/make_demo.py
# i.e. scanmesh.evaluate.digitizer.simulate_scan(
#     "conrod_slevin48_onshape.stl", up="y", along="x", n_points=14339,
#     noise=0.0, table=False)
```

- {n:,} points on {lines} scan lines, like the 14,339-point rod of Weinert, Mehnen and
  Prestifilippo (1997); rays cast down -y (the thickness axis), lines run along +x and are
  stacked along -z (across = up x along); the search settled on spacing = line spacing
  = {spacing!r} inches
- rays that miss the part (outside it and through its two bores) are dropped, so lines
  have gaps; vertical walls are not sampled
- bounds: min {lo}, max {hi}
- arrays: `points` (N, 3) float64 in the STL's coordinates, `line_ids` (N,) int64
- SHA-256 of conrod_scan.npz: `{scan_sha}`;
  of conrod_slevin48_onshape.stl.gz: `{truth_sha}`

## MIT licence of the connecting rod model

Copyright (c) slevin48

Permission is hereby granted, free of charge, to any person obtaining a copy of this
software and associated documentation files (the "Software"), to deal in the Software
without restriction, including without limitation the rights to use, copy, modify, merge,
publish, distribute, sublicense, and/or sell copies of the Software, and to permit persons
to whom the Software is furnished to do so, subject to the following conditions:

The above copyright notice and this permission notice shall be included in all copies or
substantial portions of the Software.

THE SOFTWARE IS PROVIDED "AS IS", WITHOUT WARRANTY OF ANY KIND, EXPRESS OR IMPLIED,
INCLUDING BUT NOT LIMITED TO THE WARRANTIES OF MERCHANTABILITY, FITNESS FOR A PARTICULAR
PURPOSE AND NONINFRINGEMENT. IN NO EVENT SHALL THE AUTHORS OR COPYRIGHT HOLDERS BE LIABLE
FOR ANY CLAIM, DAMAGES OR OTHER LIABILITY, WHETHER IN AN ACTION OF CONTRACT, TORT OR
OTHERWISE, ARISING FROM, OUT OF OR IN CONNECTION WITH THE SOFTWARE OR THE USE OR OTHER
DEALINGS IN THE SOFTWARE.
"""


PART_TEXT = """
## fandisk.obj.gz: the part `scanmesh demo` scans

Hoppe's fandisk, the classic CAD test part with sharp creases: 2,877 vertices, OBJ.

- source: GitHub repository mikedh/trimesh, file `models/fandisk.obj`, commit 0b4a8a9f
  (the same file as `shared/data/cad/fandisk.obj`)
- licence: MIT, the trimesh repository's licence (Copyright (c) 2023 Michael
  Dawson-Haggerty); the MIT terms are those given below for the rod, with that holder
- stored: the original bytes, gzip-compressed (`gzip.compress(raw, 9, mtime=0)`);
  SHA-256 of the uncompressed OBJ: `{sha}`; of fandisk.obj.gz: `{gz_sha}`
- `scanmesh demo` turns it 30 degrees about y through its centroid (so that its creases
  cross the scan lines) and scans it along y with noise (`scanmesh.demo.scan_demo_part`,
  settings in `scanmesh.demo.PART_SCAN`); the scan (`scanmesh.load_demo()`) is made
  when called (under a second)
"""


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--check", action="store_true", help="compare instead of writing")
    args = parser.parse_args()
    files = build()
    if args.check:
        stale = [p for p, data in files.items() if not p.is_file() or p.read_bytes() != data]
        for path in stale:
            print(f"differs: {path.relative_to(ROOT)}")
        return 1 if stale else 0
    OUT.mkdir(parents=True, exist_ok=True)
    for path, data in files.items():
        path.write_bytes(data)
        print(f"wrote {path.relative_to(ROOT)} ({len(data):,} bytes)")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
