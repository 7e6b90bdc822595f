"""Seeded fuzz cases for the native flip optimizers: Delaunay, then LOP or annealing.

One integer seed fixes a case: 5-60 points of an awkward kind (random, exact integer
grid, collinear-heavy, duplicates, clusters), a plane, optional trimming and the options
of every stage. `run_case(seed)` runs it through ``scanmesh._core`` exactly as the Python
layer does (LOP and the annealer get Delaunay's own planar coordinates) and returns what
went wrong, or None. A stage may refuse its input with a ScanmeshError; anything else
(another exception, an invalid mesh, a point lost) is a finding.

Used by tests/test_fuzz_core.py (a bounded number of seeds in CI) and by
benches/fuzz_core.py (the long run, each case in a child process with a time limit).

The validity check is independent of ``_core.validate``: orientation by exact rational
arithmetic on the same unit-square coordinates (``scanmesh_core::geometry::unit_square``
redone in numpy, same IEEE operations), each interior edge shared by two faces in
opposite directions, and planar angles around every interior vertex summing to 2π (no
fold).
"""

from __future__ import annotations

import math
from collections import Counter
from fractions import Fraction
from typing import Any

import numpy as np

from scanmesh import ScanmeshError, _core

KINDS = ("random", "integer-grid", "collinear", "duplicates", "clusters")
PLANES = ("best-fit", "z", "x")


def make_case(seed: int) -> dict[str, Any]:
    """The points and options of case `seed` (deterministic)."""
    rng = np.random.default_rng(seed)
    kind = KINDS[rng.integers(len(KINDS))]
    n = int(rng.integers(5, 61))
    if kind == "random":
        xy = rng.random((n, 2))
    elif kind == "integer-grid":
        side = int(rng.integers(2, 11))
        k = rng.permutation(side * side)[: min(n, side * side)]
        xy = np.column_stack([k % side, k // side]).astype(float)
    elif kind == "collinear":
        # Most points on two or three exact lines, a few off them.
        lines = int(rng.integers(1, 4))
        t = rng.integers(0, 20, size=n).astype(float)
        which = rng.integers(0, lines, size=n)
        xy = np.column_stack([t, 2.0 * which + 0.5 * t])
        off = rng.random(n) < 0.15
        xy[off] = rng.random((int(off.sum()), 2)) * 20
    elif kind == "duplicates":
        xy = rng.random((n, 2))
        src = rng.integers(0, n, size=n // 3)
        xy[rng.integers(0, n, size=n // 3)] = xy[src]
    else:
        centres = rng.random((3, 2))
        xy = centres[rng.integers(0, 3, size=n)] + 1e-6 * rng.random((n, 2))
    z = np.round(0.3 * np.sin(6 * xy[:, 0]) * np.cos(4 * xy[:, 1]) + 0.05 * xy[:, 0] ** 2, 3)
    if kind == "integer-grid":
        z = (xy[:, 0] * xy[:, 1]) % 3 - xy[:, 0] // 2
    points = np.column_stack([xy, z]).astype(np.float64)
    method = ("lop-tac", "lop-max-min", "anneal")[rng.integers(3)]
    options: dict[str, Any] = {
        "plane": PLANES[rng.integers(len(PLANES))],
        "trim": bool(rng.random() < 0.3),
        "method": method,
        "p": float(rng.choice([1.0, 1.5, 2.0])),
        "sliver_guard": bool(rng.random() < 0.7),
        "tie_tolerance": float(rng.choice([0.0, 1e-10, 1e-3])),
    }
    if method == "anneal":
        options.update(
            sweeps=int(rng.integers(0, 31)),
            seed=int(rng.integers(0, 2**63)),
            initial_acceptance=float(rng.choice([0.1, 0.8, 0.99])),
            final_temperature_ratio=float(rng.choice([1e-4, 0.5, 1.0])),
            patience=int(rng.choice([0, 3, 50])),
            polish=bool(rng.random() < 0.8),
            calibration_samples=int(rng.choice([0, 1, 50, 2000])),
            chains=int(rng.choice([0, 1, 3])),
            tiles=int(rng.choice([1, 2, 3, 8, 64])),
        )
        options["planar_ties"] = bool(rng.random() < 0.5)
    return {"seed": seed, "kind": kind, "points": points, "options": options}


def unit_square(uv: np.ndarray) -> np.ndarray:
    """``scanmesh_core::geometry::unit_square`` in numpy: the same IEEE operations."""
    lo, hi = uv.min(axis=0), uv.max(axis=0)
    center = lo * 0.5 + hi * 0.5
    half = max(hi[0] * 0.5 - lo[0] * 0.5, hi[1] * 0.5 - lo[1] * 0.5)
    scale = 1.0 / half if half > 0.0 else 1.0
    out = (uv - center) * scale
    out[np.abs(out) < 1e-40] = 0.0
    return out


def degenerate_faces(xy: np.ndarray, faces: np.ndarray) -> list[int]:
    """Faces that are not strictly counter-clockwise in `xy`, by exact rational arithmetic
    on the float coordinates."""
    exact = [(Fraction(x), Fraction(y)) for x, y in xy.tolist()]
    bad = []
    for f, (a, b, c) in enumerate(faces.tolist()):
        (ax, ay), (bx, by), (cx, cy) = exact[a], exact[b], exact[c]
        if (bx - ax) * (cy - ay) - (by - ay) * (cx - ax) <= 0:
            bad.append(f)
    return bad


def mesh_fault(uv: np.ndarray, faces: np.ndarray) -> str | None:
    """What is wrong with `faces` as a planar triangulation of `uv` in the unit-square
    coordinates every planar predicate of the core sees, or None: exact orientation, edge
    pairing, and planar angle sums of interior vertices (a fold winds 4π)."""
    q = unit_square(uv)
    bad = degenerate_faces(q, faces)
    if bad:
        return f"face {bad[0]} {faces[bad[0]].tolist()} is not strictly counter-clockwise"
    directed = Counter(
        (int(a), int(b)) for f in faces for a, b in zip(f, np.roll(f, -1), strict=True)
    )
    if any(k > 1 for k in directed.values()):
        return "a directed edge is used twice"
    boundary = {e for e in directed if (e[1], e[0]) not in directed}
    on_boundary = {v for e in boundary for v in e}
    total = np.zeros(len(uv))
    for f in faces:
        for k in range(3):
            p, a, b = q[f[k]], q[f[(k + 1) % 3]], q[f[(k + 2) % 3]]
            u, w = a - p, b - p
            # Every face is counter-clockwise (checked exactly): each corner is in (0, π),
            # whatever the rounding of the cross product of a sliver.
            total[f[k]] += math.atan2(abs(u[0] * w[1] - u[1] * w[0]), u @ w)
    for v in set(faces.ravel().tolist()) - on_boundary:
        if abs(total[v] - 2 * math.pi) > 1e-6:
            return f"interior vertex {v}: planar angles sum to {total[v]:.6f}, not 2π (a fold)"
    return None


def _stage(name: str, call: Any) -> tuple[Any, str | None, bool]:
    """(result, finding, refused): a ScanmeshError is a refusal, any other exception a
    finding (a Rust panic arrives as a BaseException)."""
    try:
        return call(), None, False
    except ScanmeshError as exc:
        if not str(exc):
            return None, f"{name}: {type(exc).__name__} without a message", True
        return None, None, True
    except BaseException as exc:  # noqa: BLE001 - the point of the fuzz
        if isinstance(exc, KeyboardInterrupt):
            raise
        return None, f"{name}: {type(exc).__name__} instead of a ScanmeshError: {exc}", True


def run_case(seed: int, caller_plane: bool = False) -> str | None:
    """Runs case `seed`; returns a description of the first finding, or None. With
    `caller_plane`, a Delaunay face that is degenerate in the caller's planar coordinates
    (though not in the unit square the core works in) is a finding too."""
    case = make_case(seed)
    pts, o = case["points"], case["options"]
    got, finding, refused = _stage("project", lambda: _core.project(pts, o["plane"]))
    if finding or refused:
        return finding
    uv = got[0]
    got, finding, refused = _stage("delaunay", lambda: _core.delaunay(uv))
    if finding or refused:
        return finding
    faces, duplicate_of = got
    if o["trim"] and len(faces):
        limit = _core.DEFAULT_MAX_EDGE_FACTOR * _core.median_spacing(uv, faces)
        faces, finding, refused = _stage("trim", lambda: _core.trim_long_edges(uv, faces, limit))
        if finding or refused:
            return finding
    if len(faces) == 0:
        return None
    start = f"delaunay{' + trim' if o['trim'] else ''}"
    fault = mesh_fault(uv, faces)
    if fault:
        return f"{start}: {fault}"
    try:
        _core.validate(uv, faces)
    except ScanmeshError as exc:
        return f"{start}: _core.validate: {exc}"
    if caller_plane and degenerate_faces(uv, faces):
        bad = degenerate_faces(uv, faces)[0]
        return f"{start}: face {bad} {faces[bad].tolist()} is degenerate in the caller's plane"
    if not o["trim"]:
        used = np.zeros(len(pts), dtype=bool)
        used[faces.ravel()] = True
        used[duplicate_of >= 0] = True
        if not used.all():
            return f"delaunay: points {np.flatnonzero(~used)[:5].tolist()} are nowhere"
    if o["method"] == "anneal":
        keys = (
            "sweeps p seed initial_acceptance final_temperature_ratio patience sliver_guard"
            " tie_tolerance planar_ties polish calibration_samples chains tiles"
        ).split()

        def anneal() -> np.ndarray:
            run = _core.Annealer(pts, uv, faces, _core.AnnealParams(**{k: o[k] for k in keys}))
            while not run.done:
                run.advance(10_000, 1.0)
            return run.finish().faces

        out, finding, refused = _stage("anneal", anneal)
    else:
        criterion = o["method"].removeprefix("lop-")
        out, finding, refused = _stage(
            f"lop {criterion}",
            lambda: _core.lop(
                pts,
                uv,
                faces,
                criterion,
                p=o["p"],
                sliver_guard=o["sliver_guard"],
                tie_tolerance=o["tie_tolerance"],
            )[0],
        )
    if finding:
        return finding
    if refused:
        # The start validated, the options are in range and small: nothing to refuse.
        return f"{o['method']} refused a valid start"
    fault = mesh_fault(uv, out)
    if fault:
        return f"{o['method']}: {fault}"
    # Flips refuse near-collinear corners, so the faces they make are counter-clockwise in
    # the caller's coordinates too (the start's own faces are Delaunay's business).
    start_faces = {tuple(np.roll(t, -int(np.argmin(t)))) for t in faces.tolist()}
    made = np.array(
        [t for t in out.tolist() if tuple(np.roll(t, -int(np.argmin(t)))) not in start_faces]
    )
    if len(made) and degenerate_faces(uv, made):
        return f"{o['method']}: a flip made a face degenerate in the caller's plane"
    try:
        _core.validate(uv, out)
    except ScanmeshError as exc:
        return f"{o['method']}: _core.validate disagrees: {exc}"
    if len(out) != len(faces) or set(out.ravel().tolist()) != set(faces.ravel().tolist()):
        return f"{o['method']}: flips changed the face count or the vertex set"
    return None
