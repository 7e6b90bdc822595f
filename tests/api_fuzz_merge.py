"""Seeded fuzz cases for merge and the newer readers: ``scanmesh.merge`` (views, poses and
options of every kind), ``scanmesh.read_conf`` (``.conf`` files true and lying), range-grid
PLY files (headers and cells that lie) and gzip-compressed files (truncated, corrupt,
padded, in several members). :mod:`api_fuzz` hands every fifth seed here.

Allowed outcomes: a result that holds together (a merged Surface closed, with one label per
face and finite vertices; read points finite with a grid that indexes them once each) or a
ScanmeshError with a message naming one of the bad inputs when the case has one. Anything
else is a finding (another exception, a bad value accepted, a broken result); hangs and
crashes are the Runner's.
"""

from __future__ import annotations

import gzip
import math
import re
import tempfile
import warnings
from pathlib import Path
from typing import Any

import numpy as np

import scanmesh
from fuzz_outcome import crash, refusal
from scanmesh import ScanmeshError, shape
from scanmesh.fusion.grid import OPTIONS

#: Valid draws no larger than this (a valid max_voxels of 2**63 lets a fine voxel build a
#: grid for minutes: a long run, not a fault).
MERGE_CAPS: dict[str, float] = {"max_voxels": 300_000}

KINDS = ("merge", "merge", "conf", "range-grid", "gzip")


def _cap(n: int, rng: np.random.Generator) -> np.ndarray:
    """A sphere cap seen from +z, n x n rays about 2 across, with a little noise."""
    g = np.stack(np.meshgrid(np.linspace(-1, 1, n), np.linspace(-1, 1, n)), -1).reshape(-1, 2)
    z = np.sqrt(np.clip(2.0 - (g**2).sum(1), 0.0, None)) + 0.002 * rng.standard_normal(len(g))
    return np.c_[g, z]


def _rotation(rng: np.random.Generator) -> np.ndarray:
    q = rng.normal(size=4)
    q /= np.linalg.norm(q)
    x, y, z, w = q
    return np.array(
        [
            [1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
            [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
            [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)],
        ]
    )


def _view(rng: np.random.Generator, junk: float, scale: float) -> tuple[Any, Any, bool]:
    """(points, pose, valid): a cap turned and moved, points and translation times
    ``scale``."""
    pts: Any = _cap(int(rng.integers(4, 16)), rng)
    pose: Any = np.eye(4)
    pose[:3, :3] = _rotation(rng)
    pose[:3, 3] = rng.normal(size=3) * 0.2
    pts, pose[:3, 3] = pts * scale, pose[:3, 3] * scale
    if rng.random() >= junk:
        return pts, pose, True
    pick = int(rng.integers(9))
    if pick == 0:
        # 0 or 1 point: a view needs two on different rays to have a spacing; two are
        # merge's to take (a fuzz run flagged a view of 2 merged with two others)
        pts = pts[: int(rng.integers(0, 2))]
    elif pick == 1:
        pts[int(rng.integers(len(pts))), int(rng.integers(3))] = math.nan
    elif pick == 2:
        pts = pts[:, :2]
    elif pick == 3:
        pts = np.repeat(pts[:1], len(pts), axis=0)
    elif pick == 4:
        pose[0, 1] += 0.5
    elif pick == 5:
        pose[int(rng.integers(3)), 3] = (math.inf, 1e308, math.nan)[int(rng.integers(3))]
    elif pick == 6:
        pose = pose[:3]
    elif pick == 7:
        pose = [["a"] * 4] * 4
    else:
        pose = np.diag([-1.0, 1.0, 1.0, 1.0])
    return pts, pose, False


def _option_value(option: Any, rng: np.random.Generator, junk: float) -> Any:
    from api_fuzz import _option_draw, valid_value

    value = _option_draw(option, rng, junk)
    cap = MERGE_CAPS.get(option.name)
    if cap is not None and valid_value(option, value) and value is not None and value > cap:
        value = int(rng.integers(option.low or 1, cap + 1))
    return value


def make_merge_case(seed: int, rng: np.random.Generator) -> dict[str, Any]:
    from api_fuzz import valid_value

    junk = 0.0 if rng.random() < 0.5 else 0.3
    views, bad = [], []
    # one scale for the case (views of different scales are refused: too coarse a voxel)
    scale = 10.0 ** float(rng.choice([0, 0, 0, 150, -150, 300, -300, 0]))
    if rng.random() < 0.05:
        scale = -1.0  # per view below
    for k in range(int(rng.integers(1, 4))):
        each = scale if scale > 0 else 10.0 ** float(rng.choice([0, 150, -150, 300, -300]))
        pts, pose, ok = _view(rng, junk, each)
        views.append((pts, pose))
        if not ok:
            bad.append(f"view {k}")
    kwargs: dict[str, Any] = {"max_voxels": int(rng.integers(3000, MERGE_CAPS["max_voxels"]))}
    for option in OPTIONS:
        if rng.random() < 0.5:
            kwargs[option.name] = _option_value(option, rng, junk)
            if valid_value(option, kwargs[option.name]) is False:
                bad.append(option.name)
    if rng.random() < junk / 3:
        kwargs["toward"] = ("w", 3, (0, 0, 0), "-q")[int(rng.integers(4))]
        bad.append("toward")
    elif rng.random() < 0.2:
        kwargs["toward"] = ("z", "-z", "x", (0.0, 1.0, 1.0))[int(rng.integers(4))]
    return {"seed": seed, "kind": "merge", "views": views, "kwargs": kwargs, "bad": bad}


def _conf_text(rng: np.random.Generator, names: list[str]) -> tuple[str, bool]:
    lines, ok, scans = ["camera 0 0 0 0 0 0 1"], True, 0
    for name in names:
        q = rng.normal(size=4)
        q /= np.linalg.norm(q)
        t = rng.normal(size=3)
        words = ["bmesh", name, *map(repr, t.tolist()), *map(repr, q.tolist())]
        if rng.random() < 0.3:
            pick = int(rng.integers(8))
            # a `mesh` line (a Stanford .conf's non-scan mesh) is skipped, not wrong
            ok = ok and pick == 3
            if pick == 0:
                words[2] = ("1e308", "nan", "inf", "1e301", "zero")[int(rng.integers(5))]
            elif pick == 1:
                words = words[: int(rng.integers(1, 9))]
            elif pick == 2:
                words[5:9] = ["0", "0", "0", "2"]
            elif pick == 3:
                words[0] = "mesh"
                scans -= 1
            elif pick == 4:
                words[1] = "missing.xyz"
            elif pick == 5:
                words.append("9")
            elif pick == 6:
                words[5:9] = ["0", "0", "0", "0"]
            else:
                words[1] = "../" * 40 + "etc"
        scans += 1
        lines.append(" ".join(words))
    if rng.random() < 0.1:
        scans = 0
        lines = lines[:1]
    return "\n".join(lines) + "\n", ok and scans > 0


def _range_grid_ply(rng: np.random.Generator) -> tuple[bytes, bool]:
    rows, cols = int(rng.integers(1, 6)), int(rng.integers(1, 6))
    present = rng.random(rows * cols) < 0.8
    n = int(present.sum())
    cells = np.full(rows * cols, -1)
    cells[present] = rng.permutation(n)
    ok = n > 0
    head_rows, head_cols = rows, cols
    if rng.random() < 0.4:
        ok = False
        pick = int(rng.integers(6))
        if pick == 0:
            head_rows, head_cols = -rows, -cols
        elif pick == 1:
            head_rows = 0
        elif pick == 2:
            head_cols = cols + 1
        elif pick == 3 and n:
            cells[np.flatnonzero(present)[0]] = n + 5
        elif pick == 4 and n > 1:
            cells[np.flatnonzero(present)[:2]] = cells[np.flatnonzero(present)[0]]
        else:
            head_rows = 2**40
    vertices = "".join(f"{k} {rng.random():.6f} {rng.random():.6f}\n" for k in range(n))
    grid = "".join("0\n" if c < 0 else f"1 {c}\n" for c in cells)
    head = (
        "ply\nformat ascii 1.0\n"
        f"obj_info num_cols {head_cols}\nobj_info num_rows {head_rows}\n"
        f"element vertex {n}\nproperty float x\nproperty float y\nproperty float z\n"
        f"element range_grid {rows * cols}\nproperty list uchar int vertex_indices\nend_header\n"
    )
    return (head + vertices + grid).encode(), ok


def _gzip_bytes(rng: np.random.Generator) -> tuple[bytes, bool]:
    pts = rng.random((int(rng.integers(3, 40)), 3))
    text = "".join(f"{x:.6f} {y:.6f} {z:.6f}\n" for x, y, z in pts).encode()
    data = gzip.compress(text)
    ok = True
    pick = int(rng.integers(7))
    if pick == 0:
        data, ok = data[: int(rng.integers(2, len(data)))], False
    elif pick == 1:
        at = int(rng.integers(10, len(data)))
        data, ok = data[:at] + bytes([data[at] ^ 0xFF]) + data[at + 1 :], False
    elif pick == 2:
        data = data + gzip.compress(text)
    elif pick == 3:
        data = data + b"\x00" * int(rng.integers(1, 50))
    elif pick == 4:
        data, ok = data + b"junk", False
    elif pick == 5:
        data = gzip.compress(b"")
        ok = False
    return data, ok


def make_reader_case(seed: int, kind: str, rng: np.random.Generator) -> dict[str, Any]:
    case: dict[str, Any] = {"seed": seed, "kind": kind, "bad": []}
    if kind == "conf":
        names = [f"s{k}.xyz" for k in range(int(rng.integers(1, 4)))]
        text, ok = _conf_text(rng, names)
        case["files"] = {"part.conf": text.encode()} | {
            name: "".join(
                f"{x:.5f} {y:.5f} {z:.5f}\n" for x, y, z in _cap(int(rng.integers(3, 9)), rng)
            ).encode()
            for name in names
        }
        case["call"] = "read_conf"
    elif kind == "range-grid":
        data, ok = _range_grid_ply(rng)
        case["files"] = {"grid.ply": data}
        case["call"] = "read"
    else:
        data, ok = _gzip_bytes(rng)
        case["files"] = {"scan.xyz.gz": data}
        case["call"] = "read"
    if not ok:
        case["bad"] = ["file"]
    return case


def make_case(seed: int) -> dict[str, Any]:
    """Case ``seed`` of merge or a reader (deterministic)."""
    rng = np.random.default_rng(seed)
    kind = KINDS[int(rng.integers(len(KINDS)))]
    return make_merge_case(seed, rng) if kind == "merge" else make_reader_case(seed, kind, rng)


def _names(message: str, bad: list[str]) -> bool:
    # refine=True with a single view is refused for itself, whatever else is bad
    words = [w.split()[0] for w in bad] + ["view", "pose", "points", "voxel", "max_voxels"]
    words.append("refine")
    return any(re.search(rf"(?<!\w){re.escape(w)}(?!\w)", message) for w in words)


def _surface_fault(surface: Any) -> str | None:
    faces = surface.faces
    if len(faces) == 0:
        return "a merged Surface with no faces"
    if not np.isfinite(surface.vertices).all():
        return "non-finite vertices"
    if faces.min() < 0 or faces.max() >= len(surface.vertices):
        return "a face index out of range"
    if surface.face_labels is None or len(surface.face_labels) != len(faces):
        return "labels do not match the faces"
    if not shape.is_watertight(faces):
        return "a merged Surface that is not closed"
    return None


def _points_fault(scan: Any) -> str | None:
    if not np.isfinite(scan.points).all():
        return "non-finite points read"
    if scan.grid is not None:
        used = scan.grid[scan.grid >= 0]
        if len(np.unique(used)) != len(used) or (len(used) and used.max() >= len(scan.points)):
            return "a grid that indexes points twice or beyond them"
    return None


def run_case(seed: int) -> dict[str, Any]:
    """Runs case ``seed``: {"outcome": ..., "finding": class or None, "detail": ...}."""
    case = make_case(seed)
    kind, bad = case["kind"], case["bad"]
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            if kind == "merge":
                result = scanmesh.merge(case["views"], **case["kwargs"])
                fault = _surface_fault(result)
            else:
                with tempfile.TemporaryDirectory() as folder:
                    for name, data in case["files"].items():
                        Path(folder, name).write_bytes(data)
                    first = Path(folder, next(iter(case["files"])))
                    if case["call"] == "read_conf":
                        result = scanmesh.read_conf(first)
                        fault = (
                            None
                            if all(np.isfinite(v.world).all() for v in result)
                            else ("non-finite world points")
                        )
                    else:
                        fault = _points_fault(scanmesh.read(first))
    except ScanmeshError as exc:
        named = kind != "merge" or _names(str(exc), bad)
        return refusal(kind, exc, bad if kind == "merge" else None, named)
    except KeyboardInterrupt:
        raise
    except BaseException as exc:  # noqa: BLE001 - a panic is a BaseException; the point of the fuzz
        return crash(kind, exc)
    if fault is not None:
        return {"outcome": "result", "finding": f"{kind}: {fault}", "detail": fault}
    if bad:
        return {"outcome": "result", "finding": f"{kind}: bad {bad[0]} accepted", "detail": ""}
    return {"outcome": "result", "finding": None, "detail": ""}


def reproducer(seed: int) -> str:
    """Python that repeats case ``seed``."""
    return (
        f"# merge/reader case {seed}\n"
        "import sys; sys.path.insert(0, 'tests')\n"
        f"from api_fuzz_merge import make_case, run_case\nprint(make_case({seed}))\n"
        f"print(run_case({seed}))"
    )
