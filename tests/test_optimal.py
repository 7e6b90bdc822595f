"""Exact tac optimum (MILP) and brute-force enumeration of all triangulations."""

from __future__ import annotations

import json
import math
import os
import subprocess
import sys
import textwrap
import time
from math import comb

import numpy as np
import pytest
from scipy.spatial import ConvexHull

import scanmesh
from conftest import seconds_to_interrupt
from scanmesh import _core
from scanmesh._killable import MARK, call_killable
from scanmesh.errors import (
    CoincidentPointsWarning,
    DegenerateInputError,
    InvalidMeshError,
    ParameterError,
    ScanmeshError,
)
from scanmesh.stages import optimal as optimal_stage
from scanmesh.stages.brute_force import brute_force_surface, triangulations
from scanmesh.stages.optimal import MIP_REL_GAP, optimal_surface


def bumpy(n: int, seed: int) -> np.ndarray:
    """(n, 3) random points in the unit square under a smooth bump with a little noise."""
    rng = np.random.default_rng(seed)
    xy = rng.random((n, 2))
    z = 0.3 * np.sin(3 * xy[:, 0]) * np.cos(2 * xy[:, 1]) + 0.03 * rng.standard_normal(n)
    return np.column_stack([xy, z])


def convex_polygon(n: int) -> np.ndarray:
    """(n, 3) points on an ellipse (strictly convex position) lifted onto a paraboloid."""
    a = 2 * np.pi * np.arange(n) / n + 0.1
    x, y = np.cos(a), 0.7 * np.sin(a)
    return np.column_stack([x, y, x**2 + 0.5 * y**2])


def grid(cols: int, rows: int, seed: int = 0) -> np.ndarray:
    """(cols*rows, 3) lattice points (collinear on the hull, cocircular squares), random z."""
    j, i = np.mgrid[0:rows, 0:cols]
    z = np.random.default_rng(seed).normal(0, 0.3, size=i.size)
    return np.column_stack([i.ravel(), j.ravel(), z]).astype(float)


def close(a: float, b: float) -> bool:
    """Equal up to the MILP's proven relative gap and solver tolerances."""
    return abs(a - b) <= 4 * MIP_REL_GAP * max(1.0, abs(a), abs(b)) + 1e-9


def assert_full_triangulation(points: np.ndarray, faces: np.ndarray, plane="z") -> None:
    """faces tile the convex hull of the projected points and pass HalfEdgeMesh::validate."""
    uv, _ = scanmesh.project(points, plane)
    _core.validate(uv, faces)
    a, b, c = (uv[faces[:, k]] for k in range(3))
    areas = 0.5 * ((b - a)[:, 0] * (c - a)[:, 1] - (b - a)[:, 1] * (c - a)[:, 0])
    assert np.all(areas > 0)
    assert math.isclose(areas.sum(), ConvexHull(uv).volume, rel_tol=1e-9)


# --- errors first -------------------------------------------------------------------------


def test_bad_inputs_raise_scanmesh_errors():
    pts = bumpy(8, 0)
    with pytest.raises(ParameterError, match="p must be 1 or inf"):
        optimal_surface(pts, p=2)
    with pytest.raises(ParameterError):
        optimal_surface(pts, p=0.5)
    with pytest.raises(ParameterError):
        brute_force_surface(pts, p=0.5)
    with pytest.raises(ParameterError):
        brute_force_surface(pts, p="one")
    for limit in (0, -1.0, math.nan, "soon"):
        with pytest.raises(ParameterError, match="time_limit"):
            optimal_surface(pts, time_limit=limit)
    line = np.column_stack([np.arange(6.0), 2 * np.arange(6.0), np.zeros(6)])
    with pytest.raises(DegenerateInputError):
        optimal_surface(line, plane="z")
    with pytest.raises(DegenerateInputError):
        brute_force_surface(line, plane="z")
    with pytest.raises(ScanmeshError):
        optimal_surface(np.zeros((5, 2)))
    with pytest.raises(DegenerateInputError):
        optimal_surface([[0, 0, 0], [1, 0, 0], [0, 1, math.nan]])


def test_the_enumeration_cap_is_an_error_not_a_truncation():
    pts = convex_polygon(9)  # Catalan(7) = 429 triangulations
    assert len(triangulations(pts, plane="z", max_count=429)) == 429
    with pytest.raises(ParameterError, match="max_count"):
        triangulations(pts, plane="z", max_count=428)
    with pytest.raises(ParameterError, match="max_count"):
        brute_force_surface(pts, plane="z", max_triangulations=100)
    for bad in (0, -3, 2.5, True):
        with pytest.raises(ParameterError):
            triangulations(pts, plane="z", max_count=bad)


def test_empty_triangles_refuse_coincident_points():
    uv = np.array([[0.0, 0.0], [1.0, 0.0], [0.0, 1.0], [1.0, 0.0]])
    with pytest.raises(ParameterError, match="distinct"):
        _core.empty_triangles(uv)


# --- counting triangulations --------------------------------------------------------------


@pytest.mark.parametrize("n", range(3, 11))
def test_convex_position_has_catalan_many_triangulations(n):
    catalan = comb(2 * (n - 2), n - 2) // (n - 1)
    every = triangulations(convex_polygon(n), plane="z")
    assert every.shape == (catalan, n - 2, 3)
    canon = {tuple(sorted(tuple(np.roll(t, -int(np.argmin(t)))) for t in tri)) for tri in every}
    assert len(canon) == catalan, "duplicates in the enumeration"
    assert brute_force_surface(convex_polygon(n), plane="z").options["n_triangulations"] == catalan


@pytest.mark.parametrize(
    ("points", "count"),
    [
        (grid(2, 2), 2),
        (grid(3, 2), 6),  # 1 x k lattice rectangles: C(2k, k)
        (grid(4, 2), 20),
        (grid(5, 2), 70),
        (grid(3, 3), 64),  # Kaibel and Ziegler (2003)
        (grid(4, 3), 852),
        # A square with its centre: both diagonals pass through it, one triangulation.
        (np.array([[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0], [0.5, 0.5, 1]], float), 1),
        # Off-centre interior point: degree 4, or either diagonal with the point beside it.
        (np.array([[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0], [0.7, 0.4, 1]], float), 3),
        # Triangle with one interior point: one triangulation; with a point on an edge: one.
        (np.array([[0, 0, 0], [4, 0, 0], [0, 4, 0], [1, 1, 1]], float), 1),
        (np.array([[0, 0, 0], [4, 0, 0], [0, 4, 0], [2, 0, 1]], float), 1),
    ],
)
def test_small_configurations_have_their_known_counts(points, count):
    every = triangulations(points, plane="z")
    assert len(every) == count
    for faces in every:
        assert_full_triangulation(points, faces)


# --- the MILP against brute force ---------------------------------------------------------


@pytest.mark.parametrize("p", [1, math.inf])
@pytest.mark.parametrize("n", [4, 5, 6, 7, 8, 9, 10])
def test_milp_optimum_equals_brute_force(n, p):
    strictly_better_than_delaunay = 0
    for seed in range(6):
        pts = bumpy(n, 100 * n + seed)
        exact = optimal_surface(pts, p=p, plane="z")
        brute = brute_force_surface(pts, p=p, plane="z")
        value, truth = exact.quality.tac_norm(p), brute.quality.tac_norm(p)
        assert close(value, truth), (n, seed, value, truth)
        assert exact.certified is True and 0.0 <= exact.gap <= MIP_REL_GAP
        assert brute.certified is True and brute.gap == 0.0
        assert_full_triangulation(pts, exact.faces)
        assert_full_triangulation(pts, brute.faces)
        # The brute force optimum really is the minimum over its own list.
        d = scanmesh.delaunay(pts, plane="z", max_edge=math.inf)
        assert value <= d.quality.tac_norm(p) * (1 + 4 * MIP_REL_GAP) + 1e-12
        strictly_better_than_delaunay += value < d.quality.tac_norm(p) - 1e-9
    if n >= 7:
        assert strictly_better_than_delaunay >= 2, "instances too easy to test anything"


@pytest.mark.parametrize("p", [1, math.inf])
def test_fan_cuts_keep_the_optimum(p):
    # strengthen=True adds cuts from column generation: they must never cut off the optimum.
    for seed in range(4):
        pts = bumpy(9, 500 + seed)
        strong = optimal_surface(pts, p=p, plane="z", strengthen=True)
        brute = brute_force_surface(pts, p=p, plane="z")
        assert strong.certified
        assert strong.options["fan_cuts"] > 0 and strong.options["fan_iterations"] >= 1
        assert strong.options["fan_bound"] <= brute.quality.tac_norm(p) * (1 + 1e-6) + 1e-9
        assert close(strong.quality.tac_norm(p), brute.quality.tac_norm(p))
        assert_full_triangulation(pts, strong.faces)


def test_brute_force_takes_any_p_and_is_the_minimum_of_all():
    pts = bumpy(8, 7)
    every = triangulations(pts, plane="z")
    for p in (1, 2, 3.5, math.inf):
        values = [scanmesh.quality(pts, f).tac_norm(p) for f in every]
        best = brute_force_surface(pts, p=p, plane="z")
        assert math.isclose(best.quality.tac_norm(p), min(values), rel_tol=1e-12, abs_tol=1e-15)
    assert len(set(np.round(values, 12))) > 10, "tac should vary between triangulations"


def test_collinear_hull_points_are_boundary_vertices():
    # 3 x 4 lattice with random heights: 2 interior vertices, 10 on the hull (6 collinear
    # with hull edges), 852 triangulations.
    for seed in range(3):
        pts = grid(4, 3, seed)
        for p in (1, math.inf):
            exact = optimal_surface(pts, p=p, plane="z")
            brute = brute_force_surface(pts, p=p, plane="z")
            assert exact.quality.n_interior == 2
            assert exact.options["interior_vertices"] == 2
            assert close(exact.quality.tac_norm(p), brute.quality.tac_norm(p))
            assert_full_triangulation(pts, exact.faces)


def test_a_stopped_search_accounts_for_every_point():
    """No time to find a solution: the fallback start (Delaunay's, whose trimming peels a
    collinear hull sliver) is returned, and the point it leaves out is listed, not lost
    (found by the API fuzz, case 26756)."""
    points = np.array(
        [
            [0, 2, 0],
            [0, 1, 0],
            [0, 0, 0],
            [1, 0, 0],
            [1, 2, 2],
            [2, 2, 0],
            [2, 1, 1],
            [2, 0, -1],
            [1, 1, 1],
        ],
        dtype=np.float64,
    )
    surface = scanmesh.reconstruct(points, "optimal", time_limit=5e-324)
    assert not surface.certified
    in_faces = set(surface.faces.ravel().tolist())
    listed = set(surface.options["trimmed"].tolist())
    assert not in_faces & listed
    assert in_faces | listed == set(range(len(points)))


def test_no_interior_vertex_means_zero():
    exact = optimal_surface(convex_polygon(7), plane="z")
    assert exact.certified and exact.quality.n_interior == 0 and exact.quality.tac_1 == 0.0
    assert_full_triangulation(convex_polygon(7), exact.faces)


def test_flat_points_have_zero_optimum():
    pts = bumpy(15, 3)
    pts[:, 2] = 0.25
    exact = optimal_surface(pts, plane="z")
    assert exact.certified and exact.quality.tac_1 < 1e-12


def test_coincident_points_are_merged_as_delaunay_does():
    pts = bumpy(9, 5)
    doubled = np.vstack([pts, pts[[2]] + [0, 0, 0.1], pts[[6]]])
    with pytest.warns(CoincidentPointsWarning):
        exact = optimal_surface(doubled, plane="z")
    with pytest.warns(CoincidentPointsWarning):
        brute = brute_force_surface(doubled, plane="z")
    assert exact.duplicates.tolist() == [[9, 2], [10, 6]]
    assert brute.duplicates.tolist() == [[9, 2], [10, 6]]
    assert not np.isin(exact.faces, [9, 10]).any()
    reference = brute_force_surface(pts, plane="z")
    assert close(exact.quality.tac_1, reference.quality.tac_1)
    assert close(brute.quality.tac_1, reference.quality.tac_1)


def test_other_planes_and_the_result_record():
    pts = bumpy(9, 21)[:, [2, 0, 1]]  # the height is now along x
    exact = optimal_surface(pts, plane="x")
    brute = brute_force_surface(pts, plane="x")
    assert close(exact.quality.tac_1, brute.quality.tac_1)
    assert_full_triangulation(pts, exact.faces, plane="x")
    assert exact.method == "optimal" and brute.method == "brute-force"
    assert exact.vertices is not pts and np.array_equal(exact.vertices, pts)
    assert exact.faces.dtype == np.int64 and exact.faces.shape == (
        2 * 9 - 2 - len(ConvexHull(scanmesh.project(pts, "x")[0]).vertices),
        3,
    )
    for key in ("candidate_triangles", "lower_bound", "status", "nodes", "interior_vertices"):
        assert key in exact.options
    assert set(exact.timings) >= {"empty_triangles", "solve"}
    default = optimal_surface(bumpy(9, 21))  # best-fit plane
    assert default.certified


def test_time_limit_gives_an_honest_uncertified_triangulation():
    pts = bumpy(45, 4)
    result = optimal_surface(pts, plane="z", time_limit=0.2)
    assert result.certified is False
    assert 0.0 < result.gap <= 1.0
    assert_full_triangulation(pts, result.faces)
    bound = result.options["lower_bound"]
    assert bound <= result.quality.tac_1
    assert math.isclose(result.gap, (result.quality.tac_1 - bound) / result.quality.tac_1)
    # The best triangulation known: never worse than LOP or Delaunay.
    assert result.options["source"] in ("highs", "lop", "delaunay")
    lop = scanmesh.reconstruct(pts, "lop", plane="z", max_edge=math.inf)
    assert result.quality.tac_1 <= lop.quality.tac_1 + 1e-12
    assert (
        result.quality.tac_1 <= scanmesh.delaunay(pts, plane="z", max_edge=math.inf).quality.tac_1
    )


@pytest.mark.parametrize("strengthen", [False, True])
def test_every_highs_call_is_given_only_the_time_left(monkeypatch, strengthen):
    """time_limit=8 spent 53 s. Every HiGHS call is given what is left of the limit, counted
    from the start: the enumeration of empty triangles is made to take 10 s of a 30 s limit
    (a clock that jumps, not a measured time), so no call may be given more than 20 s. The
    fan cuts' master LPs were given no limit before, the MILP 30 s less only the cuts' time."""
    import scipy.optimize

    limit, jump, offset, calls = 30.0, 10.0, [0.0], []
    clock = time.perf_counter
    monkeypatch.setattr(time, "perf_counter", lambda: clock() + offset[0])

    def slow_enumeration(*args):
        offset[0] += jump
        return enumerate_empty(*args)

    def recording(solver):
        def call(*args, **kwargs):
            calls.append((solver.__name__, (kwargs.get("options") or {}).get("time_limit")))
            return solver(*args, **kwargs)

        return call

    def recording_child(fn, args=(), kwargs=None, *, deadline=None):
        # the MILP runs in a helper process (pickled by reference): recorded on its way there
        calls.append((fn.__name__, (kwargs.get("options") or {}).get("time_limit")))
        return call_killable(fn, args, kwargs, deadline=deadline)

    enumerate_empty = _core.empty_triangles
    monkeypatch.setattr(_core, "empty_triangles", slow_enumeration)
    monkeypatch.setattr(scipy.optimize, "linprog", recording(scipy.optimize.linprog))
    monkeypatch.setattr(optimal_stage, "call_killable", recording_child)
    result = optimal_surface(bumpy(12, 7), plane="z", time_limit=limit, strengthen=strengthen)
    assert result.certified
    names = [name for name, _ in calls]
    assert names.count("milp") == 1 and (names.count("linprog") >= 1) == strengthen, names
    for name, given in calls:
        assert given is not None and 0 < given <= limit - jump, (name, given)


# --- heuristics against the optimum -------------------------------------------------------


def test_optimum_is_never_worse_than_delaunay():
    for seed in range(5):
        pts = bumpy(12, 800 + seed)
        exact = optimal_surface(pts, plane="z")
        assert exact.certified
        d = scanmesh.delaunay(pts, plane="z", max_edge=math.inf)
        assert exact.quality.tac_1 <= d.quality.tac_1 * (1 + 4 * MIP_REL_GAP)


@pytest.mark.slow
@pytest.mark.parametrize("p", [1, math.inf])
def test_optimum_is_never_worse_than_lop_or_annealing(p):
    worse = {"lop": 0, "anneal": 0}
    for seed in range(8):
        pts = bumpy(12, 900 + seed)
        exact = optimal_surface(pts, p=p, plane="z")
        assert exact.certified
        best = exact.quality.tac_norm(p)
        for method in worse:
            seeded = {"seed": seed} if method == "anneal" else {}
            heuristic = scanmesh.reconstruct(pts, method, plane="z", max_edge=math.inf, **seeded)
            assert_full_triangulation(pts, heuristic.faces)
            value = heuristic.quality.tac_norm(p)
            assert best <= value * (1 + 4 * MIP_REL_GAP) + 1e-12, (method, seed, best, value)
            worse[method] += value > best * (1 + 1e-6)
    # LOP is a local optimum: it should stop above the certified optimum somewhere.
    assert worse["lop"] >= 1


@pytest.mark.parametrize("seed", [3, 4, 5])
def test_an_incumbent_cuts_the_search_but_not_the_optimum(seed):
    pts = bumpy(9, seed)
    plain = optimal_surface(pts, plane="z")
    brute = brute_force_surface(pts, plane="z")
    # A worse incumbent (Delaunay): HiGHS still finds the optimum below it.
    delaunay = scanmesh.reconstruct(pts, "delaunay", plane="z", max_edge=math.inf)
    cut = optimal_surface(pts, plane="z", incumbent=delaunay)
    assert cut.certified and close(cut.quality.tac_1, brute.quality.tac_1)
    assert cut.options["incumbent_value"] == pytest.approx(delaunay.quality.tac_1, rel=1e-12)
    # The optimum as incumbent: nothing is strictly better, the program is infeasible,
    # and the incumbent comes back certified.
    again = optimal_surface(pts, plane="z", incumbent=plain.faces)
    assert again.certified and again.options["source"] in ("incumbent", "highs")
    assert close(again.quality.tac_1, brute.quality.tac_1)
    assert_full_triangulation(pts, again.faces)


def test_a_wrong_incumbent_is_refused_not_trusted():
    pts = bumpy(10, 6)
    best = optimal_surface(pts, plane="z")
    # every bad incumbent is an InvalidMeshError, the one class for bad faces
    with pytest.raises(InvalidMeshError, match="do not triangulate"):
        optimal_surface(pts, plane="z", incumbent=best.faces[1:])  # a hole: lower tac
    bad = best.faces.copy()
    bad[0, 1] = bad[0, 0]
    with pytest.raises(InvalidMeshError, match="face 0 "):
        optimal_surface(pts, plane="z", incumbent=bad)
    with pytest.raises(InvalidMeshError, match=f"face {len(best.faces)} .*repeats"):
        optimal_surface(pts, plane="z", incumbent=np.r_[best.faces, best.faces[:1]])
    with pytest.raises(InvalidMeshError, match=r"shape \(M, 3\)"):
        optimal_surface(pts, plane="z", incumbent=np.zeros((3, 2)))
    with pytest.raises(InvalidMeshError, match="refers to a vertex outside"):
        optimal_surface(pts, plane="z", incumbent=best.faces + 100)


# --- HiGHS in a helper process that is killed -------------------------------------------

#: Process ids of this process's helpers still running (Linux's /proc), as a script line.
HELPERS = (
    "import os\n"
    "def helpers(mark):\n"
    "    out = []\n"
    "    for pid in filter(str.isdigit, os.listdir('/proc')):\n"
    "        try:\n"
    "            stat = open(f'/proc/{pid}/stat').read().rsplit(')', 1)[1].split()\n"
    "            argv = open(f'/proc/{pid}/cmdline', 'rb').read().split(b'\\0')\n"
    "        except OSError:\n"
    "            continue\n"
    "        if stat[0] != 'Z' and int(stat[1]) == os.getpid() and mark.encode() in argv:\n"
    "            out.append(int(pid))\n"
    "    return out\n"
)
needs_proc = pytest.mark.skipif(not os.path.isdir("/proc/self"), reason="reads Linux's /proc")


def _helpers() -> list[int]:
    scope: dict = {}
    exec(HELPERS, scope)
    return scope["helpers"](MARK)


@pytest.mark.slow
@needs_proc
def test_a_killable_call_returns_raises_and_is_killed_at_its_deadline():
    assert call_killable(math.hypot, (3.0, 4.0)) == 5.0
    with pytest.raises(ValueError, match="math domain error"):
        call_killable(math.sqrt, (-1.0,))
    assert len(_helpers()) == 1  # one helper serves the calls in turn
    # a stand-in that sleeps for a minute, given one second: killed, nothing left running
    t0 = time.monotonic()
    assert call_killable(time.sleep, (60.0,), deadline=time.monotonic() + 1.0) is None
    assert time.monotonic() - t0 < 30.0  # generous: a loaded machine starts a helper slowly
    assert _helpers() == []
    assert call_killable(abs, (-2,)) == 2  # and the next call starts another


def test_a_killable_call_says_how_its_helper_ended():
    """Killed from outside: the signal is named, and memory is named as one possible cause
    only there; an answer that cannot be pickled is said in words."""
    with pytest.raises(ScanmeshError, match="killed by signal SIGKILL"):
        call_killable(_kill_self)
    with pytest.raises(ScanmeshError, match="answer could not be sent"):
        call_killable(_unpicklable)


def _kill_self() -> None:
    os.kill(os.getpid(), 9)


def _unpicklable():
    return lambda: None


@pytest.mark.slow
@needs_proc
def test_ctrl_c_ends_a_killable_call_and_its_helper():
    script = (
        HELPERS
        + """
import sys, time
from scanmesh._killable import MARK, call_killable
call_killable(abs, (1,))  # the helper started before the clock does
print("started", flush=True)
try:
    call_killable(time.sleep, (60.0,))
except KeyboardInterrupt:
    at = time.monotonic()
    print(f"interrupted {at!r}", flush=True)
    sys.exit(0 if not helpers(MARK) else 3)  # the helper was ended, not left running
print("finished", flush=True)
"""
    )
    assert seconds_to_interrupt(script, 0.5) < 0.5


def test_optimal_runs_in_a_plain_script_without_a_main_guard(tmp_path):
    """A user's script calls reconstruct at its top level, with no ``if __name__ ==
    "__main__":``: the solver's process must not run the script again (it did, and failed
    with "ended without an answer (... out of memory)")."""
    script = tmp_path / "plain.py"
    script.write_text(
        "import numpy as np\n"
        "import scanmesh\n"
        "rng = np.random.default_rng(3)\n"
        "xy = rng.random((9, 2))\n"
        "pts = np.column_stack([xy, 0.2 * np.sin(3 * xy[:, 0])])\n"
        "s = scanmesh.reconstruct(pts, method='optimal', plane='z', time_limit=60)\n"
        "print('RAN', s.certified, len(s.faces))\n"
    )
    done = subprocess.run(
        [sys.executable, str(script)], capture_output=True, text=True, timeout=300, cwd=tmp_path
    )
    assert done.returncode == 0, done.stderr
    assert done.stdout.split()[:2] == ["RAN", "True"], done.stdout  # once, and proven


@pytest.mark.slow
def test_optimal_keeps_its_time_limit_when_highs_overruns_it(tmp_path):
    """A stand-in for scipy's milp that sleeps a minute, as HiGHS's presolve overran
    time_limit=8 by 18 s: the call ends soon after its limit with the best triangulation
    known (LOP's or Delaunay's), not certified, and says why."""
    (tmp_path / "standin.py").write_text(
        "import time\n\ndef milp(*args, **kwargs):\n    time.sleep(60.0)\n"
    )
    script = f"""
    import sys, time, json
    sys.path.insert(0, {str(tmp_path)!r})  # the helper finds standin on this path
    import numpy as np, scipy.optimize, standin
    import scanmesh
    scipy.optimize.milp = standin.milp
    rng = np.random.default_rng(1)
    pts = np.column_stack([rng.random((12, 2)), 0.1 * rng.random(12)])
    t0 = time.monotonic()
    s = scanmesh.reconstruct(pts, "optimal", plane="z", time_limit=3.0)
    print(json.dumps({{"seconds": time.monotonic() - t0, "certified": s.certified,
                      "status": s.options["status"], "source": s.options["source"],
                      "faces": len(s.faces)}}))
    """
    done = subprocess.run(
        [sys.executable, "-c", textwrap.dedent(script)], capture_output=True, text=True, timeout=120
    )
    assert done.returncode == 0, done.stderr
    out = json.loads(done.stdout.strip().splitlines()[-1])
    assert out["seconds"] < 30.0, out  # generous: the stand-in alone sleeps 60 s
    assert not out["certified"] and "overran" in out["status"], out
    assert out["source"] in ("lop", "delaunay") and out["faces"] > 0, out
