"""Robustness: every bad input gets a clear error, odd but valid input a valid mesh,
nothing panics, Ctrl-C returns quickly, threads agree with serial runs.

Complements test_errors.py (shapes and options of ``delaunay``), test_readers.py (file
errors), test_strips.py / test_lines.py (strip options, line ids) and test_cli.py (exit
codes, atomic outputs); the cases already there are not repeated.
"""

from __future__ import annotations

import re
import threading
import warnings

import numpy as np
import pytest

import scanmesh
from conftest import bumpy_patch, seconds_to_interrupt
from scanmesh import (
    CoincidentPointsWarning,
    DegenerateInputError,
    NotAHeightFieldWarning,
    ParameterError,
    ScanmeshError,
    _core,
)
from scanmesh.scan.steep import STEEP_ANGLE_DEG, STEEP_WARN_FRACTION, steep_fraction
from scanmesh.stages.strips import CrossingLinesWarning
from test_lines import line_scan

#: Every method but "optimal" (exponential; its errors are tested in test_optimal.py), with
#: options that keep annealing short.
FAST = {
    "delaunay": {},
    "lookahead": {},
    "shortest-path": {},
    "lop": {},
    "anneal": {"sweeps": 3},
}


def run(points, method, **kwargs) -> scanmesh.Surface:
    return scanmesh.reconstruct(points, method, **FAST[method], **kwargs)


def canonical(faces: np.ndarray) -> np.ndarray:
    """Faces rotated to start at their smallest index, rows sorted: order-free comparison."""
    f = np.asarray(faces)
    if len(f) == 0:
        return f.reshape(0, 3)
    k = np.argmin(f, axis=1)
    rolled = np.stack([np.roll(row, -s) for row, s in zip(f, k, strict=True)])
    return rolled[np.lexsort(rolled.T[::-1])]


def planar_uv(surface: scanmesh.Surface) -> np.ndarray:
    uv, _ = scanmesh.project(surface.vertices, surface.options["plane"])
    return uv


def assert_accounted_for(surface: scanmesh.Surface) -> None:
    """Every input point is a vertex of a face, a reported duplicate, or reported as trimmed
    (Delaunay-based methods) or unused (strip methods)."""
    n = len(surface.vertices)
    used = np.zeros(n, dtype=bool)
    used[surface.faces.ravel()] = True
    used[surface.duplicates[:, 0]] = True
    for key in ("trimmed", "unused"):
        if key in surface.options:
            used[np.asarray(surface.options[key], dtype=np.int64)] = True
    assert used.all(), f"points {np.flatnonzero(~used)[:10]} are nowhere"


def assert_no_panic(call) -> BaseException | None:
    """Runs call(); returns the exception it raised, failing on anything but a ScanmeshError
    (a Rust panic arrives as pyo3's PanicException, a BaseException)."""
    try:
        call()
    except ScanmeshError as exc:
        assert str(exc), "an error must say what is wrong"
        return exc
    except BaseException as exc:  # noqa: BLE001 - the point of the test
        pytest.fail(f"{type(exc).__name__} instead of a ScanmeshError: {exc}")
    return None


# --------------------------------------------------------------------------- bad points


BAD_POINTS = {
    "nan": (
        np.where(np.arange(60).reshape(20, 3) == 31, np.nan, bumpy_patch(20, 1)),
        r"points\[10\].*y=.*nan",
    ),
    "inf": (
        np.where(np.arange(60).reshape(20, 3) == 5, -np.inf, bumpy_patch(20, 1)),
        r"points\[1\].*z=.*inf",
    ),
    "no points": (np.empty((0, 3)), "at least 3 points"),
    "two points": (np.eye(3)[:2], "at least 3 points"),
    "three identical": (np.ones((3, 3)), "3 distinct points"),
    "many identical": (np.full((50, 3), 7.5), "3 distinct points"),
    "two distinct": (np.repeat(np.eye(3)[:2], 10, axis=0), "3 distinct points|collinear"),
    "collinear 3-D": (np.outer(np.linspace(-1, 1, 30), [1.0, -2.0, 0.5]), "collinear"),
    "wrong shape 1-D": (np.zeros(9), r"shape \(N, 3\)"),
    "wrong shape (N, 4)": (np.zeros((6, 4)), r"shape \(N, 3\)"),
    "ragged list": ([[0, 0, 0], [1, 0], [0, 1, 0]], "cannot be read|shape|real numbers"),
    "objects": (np.array([[0, 0, 0], [1, 0, 0], [0, 1, None]], dtype=object), "real numbers"),
    "booleans as text": (np.array([["0", "0", "0"]] * 4), "real numbers"),
}


@pytest.mark.parametrize("method", FAST)
@pytest.mark.parametrize("case", BAD_POINTS)
def test_bad_points_raise_a_named_error_in_every_method(case, method):
    points, match = BAD_POINTS[case]
    exc = assert_no_panic(lambda: run(points, method))
    assert exc is not None, f"{case}: {method} accepted bad points"
    assert re.search(match, str(exc)), f"{case}: {exc}"


@pytest.mark.parametrize("method", FAST)
def test_collinear_only_after_projection_names_the_plane(method):
    # a zig-zag wall: spans a plane in 3-D, a line when seen along z
    wall = np.column_stack([np.arange(30.0), 2 * np.arange(30.0), np.arange(30.0) % 4])
    exc = assert_no_panic(lambda: run(wall, method, plane="z"))
    assert isinstance(exc, DegenerateInputError)
    assert "after projection" in str(exc) and "plane" in str(exc)


@pytest.mark.filterwarnings("ignore:overflow:RuntimeWarning")
def test_magnitudes_beyond_the_range_are_clear_errors_not_panics():
    # 1e308-sized coordinates overflow in every plane fit; they must fail cleanly (or work)
    pts = bumpy_patch(40, 2) * 1.7e308
    for method in FAST:
        assert_no_panic(lambda m=method: run(pts, m))


# --------------------------------------------------------------------------- odd but valid


@pytest.mark.parametrize("method", ["delaunay", "lop", "anneal"])
def test_near_duplicates_give_a_valid_mesh(method):
    pts = bumpy_patch(120, 4)
    # every point scanned twice, 1e-12 apart: the spacing must not collapse to 1e-12
    jitter = np.random.default_rng(4).normal(scale=1e-12, size=pts.shape)
    twice = np.vstack([pts, pts + jitter])
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", CoincidentPointsWarning)
        surface = run(twice, method)
    _core.validate(planar_uv(surface), surface.faces)
    assert len(surface.faces) > 150
    assert_accounted_for(surface)


@pytest.mark.parametrize("method", FAST)
def test_exact_duplicates_and_points_above_each_other(method):
    pts, ids = line_scan(5, 12)
    # exact repeats, and points that coincide in the plane but differ in height, each right
    # after its twin (as a scanner repeats a point)
    at = [3, 20, 41]
    extra = pts[at] + [[0, 0, 0], [0, 0, 0.5], [0, 0, -2.0]]
    pts = np.insert(pts, np.add(at, 1), extra, axis=0)
    ids = np.insert(ids, np.add(at, 1), ids[at])
    kwargs = {"lines": ids} if method in ("lookahead", "shortest-path") else {}
    with pytest.warns(CoincidentPointsWarning):
        surface = run(pts, method, plane="z", **kwargs)
    _core.validate(planar_uv(surface), surface.faces)
    assert_accounted_for(surface)
    assert len(surface.duplicates) >= 3


@pytest.mark.parametrize("method", ["lookahead", "shortest-path"])
@pytest.mark.parametrize("scale", [1e-300, 1e-150, 1e150, 1e300])
def test_strips_at_extreme_magnitudes_give_the_same_mesh(method, scale):
    pts, ids = line_scan(6, 14)
    ref = canonical(run(pts, method, lines=ids, plane="z").faces)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        given = run(pts * scale, method, lines=ids, plane="z")
        detected = run(pts * scale, method, plane="z")
    np.testing.assert_array_equal(canonical(given.faces), ref)
    np.testing.assert_array_equal(canonical(detected.faces), ref)


@pytest.mark.filterwarnings("ignore::scanmesh.NotAHeightFieldWarning")
@pytest.mark.parametrize("method", ["lop", "anneal", "shortest-path"])
def test_any_dtype_and_layout_gives_the_same_faces(method):
    pts, ids = line_scan(5, 10)
    pts = np.round(pts * 4) / 4  # exactly representable in float32 and as quarters
    # (the rounding to quarters makes stairs: steep triangles, warned about and ignored)
    # lines= only where the method uses it (LOP and annealing start from Delaunay here)
    lined = {"lines": ids} if method == "shortest-path" else {}
    ref = canonical(run(pts, method, **lined).faces)
    variants = {
        "float32": pts.astype(np.float32),
        "fortran": np.asfortranarray(pts),
        "strided": np.repeat(pts, 3, axis=0)[::3],
        "list": pts.tolist(),
        "int (x4)": None,
    }
    for name, v in variants.items():
        if v is None:
            v = (pts * 4).astype(np.int64)  # a uniform scale: the same connectivity
        got = canonical(run(v, method, **lined).faces)
        np.testing.assert_array_equal(got, ref, err_msg=name)


# --------------------------------------------------------------------------- scan lines


@pytest.mark.parametrize(
    "lines, match",
    [
        (np.zeros((40, 2), dtype=np.int64), "one id per point"),
        (np.zeros(39, dtype=np.int64), "one id per point"),
        (np.full(40, np.nan), "integer"),
        (np.arange(40) + 0.5, "integer"),
        (np.array(["a"] * 40), "integer"),
    ],
)
@pytest.mark.parametrize("method", ["lookahead", "shortest-path"])
def test_line_ids_that_do_not_match_the_points(method, lines, match):
    pts, _ = line_scan(4, 10)
    with pytest.raises(ScanmeshError, match=match):
        run(pts, method, lines=lines)


@pytest.mark.parametrize("method", ["lookahead", "shortest-path"])
def test_lines_of_one_point_each_are_no_strip(method):
    pts, _ = line_scan(4, 10)
    exc = assert_no_panic(lambda: run(pts, method, lines=np.arange(len(pts)), plane="z"))
    assert isinstance(exc, DegenerateInputError) and "no strip" in str(exc)


@pytest.mark.parametrize("seed", range(12))
@pytest.mark.parametrize("method", ["lookahead", "shortest-path"])
def test_scrambled_line_ids_never_give_a_wrong_mesh_silently(method, seed):
    # Random line ids make lines that cross and fold in the plane: the result must be a
    # valid planar triangulation (with a CrossingLinesWarning when triangles were dropped)
    # or a DegenerateInputError, never a panic.
    pts, _ = line_scan(5, 9)
    rng = np.random.default_rng(seed)
    ids = rng.integers(0, rng.integers(2, 8), size=len(pts))
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        result = []
        exc = assert_no_panic(lambda: result.append(run(pts, method, lines=ids, plane="z")))
    if exc is not None:
        assert isinstance(exc, DegenerateInputError)
        return
    surface = result[0]
    # Where lines cross, the overlapping triangles are dropped and the warning says so: the
    # mesh is always a valid planar triangulation.
    crossing = any(issubclass(w.category, CrossingLinesWarning) for w in caught)
    assert crossing == (surface.options["dropped_overlaps"] > 0)
    assert surface.options["planar_valid"]
    _core.validate(planar_uv(surface), surface.faces)
    assert_accounted_for(surface)


# --------------------------------------------------------------------------- height fields


def cylinder(n_around: int = 60, n_along: int = 20) -> np.ndarray:
    """Points on a unit cylinder around the z axis (not a height field over x or y)."""
    th, z = np.meshgrid(
        np.linspace(0, 2 * np.pi, n_around, endpoint=False), np.linspace(0, 3, n_along)
    )
    return np.column_stack([np.cos(th).ravel(), np.sin(th).ravel(), z.ravel()])


def test_steep_fraction_is_reported_and_scale_free():
    flat = bumpy_patch(200, 5) * [1, 1, 0]
    assert scanmesh.delaunay(flat, plane="z").steep_fraction == 0.0
    bumpy = scanmesh.delaunay(bumpy_patch(200, 5))
    assert 0.0 <= bumpy.steep_fraction < STEEP_WARN_FRACTION
    for scale in (1e-300, 1e300):
        s = scanmesh.delaunay(bumpy_patch(200, 5) * scale)
        assert s.steep_fraction == pytest.approx(bumpy.steep_fraction)
    # a 80-degree ramp is steep, a 70-degree one is not (threshold STEEP_ANGLE_DEG)
    xy = np.random.default_rng(1).random((100, 2))
    for deg, expect in ((STEEP_ANGLE_DEG + 5, 1.0), (STEEP_ANGLE_DEG - 5, 0.0)):
        ramp = np.column_stack([xy, np.tan(np.radians(deg)) * xy[:, 0]])
        faces = scanmesh.delaunay(ramp, plane="z").faces
        assert steep_fraction(ramp, faces, np.array([0.0, 0.0, 1.0])) == expect


@pytest.mark.parametrize("method", ["delaunay", "shortest-path", "anneal"])
def test_a_surface_seen_from_the_side_warns_and_suggests_a_plane(method):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", CoincidentPointsWarning)
        warnings.simplefilter("ignore", scanmesh.ScanmeshWarning)
        warnings.simplefilter("error", NotAHeightFieldWarning)
        # Seen from the side the strips fold onto themselves entirely: nothing valid is
        # left, an error that suggests a plane instead of the warning.
        expected = DegenerateInputError if method == "shortest-path" else NotAHeightFieldWarning
        with pytest.raises(expected, match="plane="):
            run(cylinder(), method, plane="x")


def test_the_embedded_rod_over_its_plane_is_a_height_field(rod_scan):
    pts, _ = rod_scan
    with warnings.catch_warnings():
        warnings.simplefilter("error", NotAHeightFieldWarning)
        surface = scanmesh.reconstruct(pts, "delaunay", plane="y")
    assert surface.steep_fraction < 0.02


def test_points_folded_onto_themselves_are_not_trimmed_to_nothing_silently(rod_scan):
    pts, _ = rod_scan
    # seen along x, the rod's two faces coincide almost everywhere: an error, not 0 faces
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", CoincidentPointsWarning)
        with pytest.raises(DegenerateInputError, match="plane="):
            scanmesh.delaunay(pts, plane="x")


# --------------------------------------------------------------------------- options


@pytest.mark.parametrize(
    "method, options, match",
    [
        ("lop", {"p": 0.5}, "p must"),
        ("lop", {"p": float("nan")}, "p must"),
        ("anneal", {"sweeps": -5}, "sweeps"),
        ("anneal", {"patience": -1}, "patience"),
        ("anneal", {"p": 0}, "p must"),
        ("lookahead", {"alpha": 0}, "alpha"),
        ("lookahead", {"alpha": True}, "alpha"),
        ("shortest-path", {"weight": "smoothness"}, "weight"),
        ("shortest-path", {"weight": {"angle": float("nan")}}, "finite"),
        ("delaunay", {"max_edge": 0.0}, "max_edge"),
        ("delaunay", {"plane": [np.nan, 0, 1]}, "plane|normal|finite"),
        ("delaunay", {"plane": "xy"}, "plane"),
    ],
)
def test_invalid_options_are_named(method, options, match):
    pts, ids = line_scan(4, 10)
    kwargs = dict(FAST[method])
    kwargs.update(options)
    if method in ("lookahead", "shortest-path"):
        kwargs["lines"] = ids
    exc = assert_no_panic(lambda: scanmesh.reconstruct(pts, method, **kwargs))
    assert isinstance(exc, ParameterError), f"{options}: {exc!r}"
    assert re.search(match, str(exc)), str(exc)


# --------------------------------------------------------------------------- threads


def test_four_threads_give_the_serial_results():
    pts, ids = line_scan(8, 25)
    pts[:, 2] = 0.3 * np.sin(pts[:, 0] / 3) * np.cos(pts[:, 1] / 2)
    jobs = [
        ("delaunay", {}),
        ("shortest-path", {"lines": ids}),
        ("anneal", {"sweeps": 30, "seed": 3}),
        ("anneal", {"sweeps": 30, "seed": 4, "initial": "shortest-path", "lines": ids}),
    ]
    serial = [scanmesh.reconstruct(pts, m, **kw).faces for m, kw in jobs]
    results: dict[int, np.ndarray] = {}
    errors: list[BaseException] = []
    barrier = threading.Barrier(len(jobs))

    def work(k: int) -> None:
        try:
            barrier.wait()
            for _ in range(3):
                m, kw = jobs[k]
                results[k] = scanmesh.reconstruct(pts, m, **kw).faces
                np.testing.assert_array_equal(results[k], serial[k])
        except BaseException as exc:  # noqa: BLE001 - reported below
            errors.append(exc)

    threads = [threading.Thread(target=work, args=(k,)) for k in range(len(jobs))]
    for t in threads:
        t.start()
    for t in threads:
        t.join(timeout=120)
    assert not errors, errors
    assert sorted(results) == list(range(len(jobs)))


# --------------------------------------------------------------------------- Ctrl-C


CTRL_C_SCRIPT = """
import sys, time
import numpy as np
import scanmesh
# 2.4M points: several seconds of native work even for the fastest method on an idle
# machine, so the interrupt (0.8 s after "started") always lands inside the call.
x, y = np.meshgrid(np.arange(3000.0), 1.2 * np.arange(800))
pts = np.column_stack([x.ravel(), y.ravel(), np.sin(x.ravel() / 30) * np.cos(y.ravel() / 20)])
ids = np.repeat(np.arange(800), 3000)
print("started", flush=True)
try:
    # each method gets the keyword it uses: line ids for strips, max_edge for Delaunay
    kw = {"lines": ids} if METHOD == "shortest-path" else {"max_edge": MAX_EDGE}
    scanmesh.reconstruct(pts, METHOD, plane="z", **kw)
except KeyboardInterrupt:
    print(f"interrupted {time.monotonic()!r}", flush=True)
    sys.exit(0)
print("finished", flush=True)
"""


@pytest.mark.slow
@pytest.mark.parametrize("method, max_edge", [("shortest-path", None), ("delaunay", 5.0)])
def test_ctrl_c_during_a_long_native_call_returns_quickly(method, max_edge):
    script = CTRL_C_SCRIPT.replace("METHOD", repr(method)).replace("MAX_EDGE", repr(max_edge))
    # 0.8 s is inside the native call (600k points take seconds).
    assert seconds_to_interrupt(script, 0.8) < 0.2


@pytest.mark.slow
def test_ctrl_c_while_reading_a_large_text_file_returns_quickly(tmp_path):
    path = tmp_path / "big.xyz"
    script = f"""
    import sys, time
    import scanmesh
    rows = "".join(f"{{i * 1e-3:.6f}} {{i * 2e-3:.6f}} {{i * 1e-4:.6f}}\\n" for i in range(100_000))
    with open({str(path)!r}, "w") as handle:
        for _ in range(40):  # 4 million points, about 100 MB: seconds to parse
            handle.write(rows)
    print("started", flush=True)
    try:
        scanmesh.read({str(path)!r})
    except KeyboardInterrupt:
        print(f"interrupted {{time.monotonic()!r}}", flush=True)
        sys.exit(0)
    print("finished", flush=True)
    """
    # early: with the native chunk parser an idle machine reads the 100 MB in about 0.5 s
    assert seconds_to_interrupt(script, 0.1) < 0.2


SLOW_SMALL_SCRIPT = """
import sys, time
import numpy as np
import scipy.optimize  # loaded before the clock starts, as the stage's first run does
import scanmesh
rng = np.random.default_rng(0)
def progress(done, total, value, stage):
    if stage == "strips" and done == 0:
        print("started", flush=True)
if METHOD == "optimal":
    # 200 points: HiGHS runs for tens of seconds, in one call
    xy = rng.random((200, 2))
    pts = np.column_stack([xy, 0.1 * np.sin(5 * xy[:, 0])])
    kw = {"time_limit": 120.0}
    print("started", flush=True)
else:
    # two lines of 20,000 points: the whole-matrix solver's 4e8 cells take a minute
    t = np.linspace(0.0, 1.0, 20_000)
    pts = np.vstack([np.column_stack([t, 0 * t, 0.01 * np.sin(20 * t)]),
                     np.column_stack([t + 1e-5, 0 * t + 1e-3, 0.01 * np.cos(20 * t)])])
    kw = {"lines": np.repeat([0, 1], 20_000), "solver": "dp", "progress": progress}
try:
    scanmesh.reconstruct(pts, METHOD, plane="z", **kw)
except KeyboardInterrupt:
    print(f"interrupted {time.monotonic()!r}", flush=True)
    sys.exit(0)
print("finished", flush=True)
"""


@pytest.mark.slow
@pytest.mark.parametrize("method, wait", [("optimal", 3.0), ("shortest-path", 0.3)])
def test_ctrl_c_during_a_slow_call_on_few_points_returns_quickly(method, wait):
    """Small but slow: the exact optimum (HiGHS) on 200 points, the whole-matrix strip
    solver on 2 x 20,000 points. Below the point count that used to move a call into a
    worker thread, they ran in the main thread and Ctrl-C waited for them."""
    script = SLOW_SMALL_SCRIPT.replace("METHOD", repr(method))
    assert seconds_to_interrupt(script, wait) < 0.5


def test_ctrl_c_during_an_import_that_swallows_it_still_interrupts(tmp_path):
    """trimesh guards its optional imports with ``except BaseException``: a Ctrl-C landing
    there was swallowed and ``compare --truth`` ran on. A stand-in module that sleeps inside
    such a guard: imported through import_interruptibly, Ctrl-C still interrupts."""
    (tmp_path / "swallowing.py").write_text(
        "import time\ntry:\n    time.sleep(3)\nexcept BaseException:\n    pass\n"
    )
    script = f"""
    import sys, time
    sys.path.insert(0, {str(tmp_path)!r})
    from scanmesh._interrupt import import_interruptibly
    print("started", flush=True)
    try:
        import_interruptibly("swallowing")
    except KeyboardInterrupt:
        print(f"interrupted {{time.monotonic()!r}}", flush=True)
        sys.exit(0)
    print("finished", flush=True)
    """
    assert seconds_to_interrupt(script, 0.3) < 0.2
