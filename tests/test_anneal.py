"""Simulated annealing and LOP on tac: invariants, reproducibility, the rod, interruption."""

from __future__ import annotations

import dataclasses
import math
import textwrap
import time

import numpy as np
import pytest

import scanmesh
from conftest import bumpy_patch, seconds_to_interrupt
from scanmesh import _core
from scanmesh.stages.anneal import anneal_surface
from scanmesh.stages.lop import lop_surface


def canonical(faces):
    return np.unique(np.sort(faces, axis=1), axis=0)


@pytest.fixture(scope="module")
def rod_with_curtains(rod_scan):
    """The rod's Delaunay trimmed in the plane only: its tac lives in the curtains across
    the rod's steps (depth-jump trimming drops them, leaving flat faces with no tac), so it
    is the mesh on which the optimizers have something to do."""
    pts, _ = rod_scan
    d = scanmesh.delaunay(pts, plane="y")
    uv, _ = scanmesh.project(pts, "y")
    hull, _ = _core.delaunay(uv)
    return dataclasses.replace(d, faces=_core.trim_long_edges(uv, hull, d.options["max_edge"]))


#: The paper's annealing: from Delaunay itself, every flip by tac alone (the curtains'
#: triangles are slivers in 3-D, so the default move set could not touch them).
PAPER = {"descend": False, "sliver_angle": 0.0}


@pytest.fixture(scope="module")
def rod_results(rod_with_curtains):
    return {
        "delaunay": rod_with_curtains,
        "lop": lop_surface(rod_with_curtains),
        "anneal": anneal_surface(rod_with_curtains, sweeps=150, **PAPER),
    }


def test_anneal_beats_lop_beats_delaunay_on_the_rod(rod_results):
    d, lop, a = (rod_results[m].quality.tac_1 for m in ("delaunay", "lop", "anneal"))
    assert a < lop < d
    assert a < 0.15 * d


def test_results_are_valid_planar_triangulations(rod_results, rod_scan):
    pts, _ = rod_scan
    uv, _ = scanmesh.project(pts, "y")
    d = rod_results["delaunay"]
    for s in rod_results.values():
        _core.validate(uv, s.faces)
        # Flips keep the domain: same number of triangles, same boundary.
        assert len(s.faces) == len(d.faces)
        assert s.quality.n_interior == d.quality.n_interior


def test_sliver_guard_keeps_tac_and_removes_slivers(rod_with_curtains):
    guarded = anneal_surface(rod_with_curtains, sweeps=60, seed=3)
    raw = anneal_surface(rod_with_curtains, sweeps=60, seed=3, sliver_guard=False)
    assert guarded.quality.tac_1 <= raw.quality.tac_1 * 1.02
    # Annealing proposes only edges whose flip can lower tac, so flat faces keep
    # Delaunay's shapes even without the guard; the guard still removes slivers on top.
    assert guarded.quality.sliver_fraction < raw.quality.sliver_fraction
    assert guarded.quality.sliver_fraction < 0.5 * rod_with_curtains.quality.sliver_fraction


def test_energy_never_ends_above_the_start_and_trace_is_complete():
    pts = bumpy_patch(600, 1)
    a = scanmesh.reconstruct(pts, "anneal", sweeps=40, patience=0)
    opts = a.options
    assert opts["energy"] <= opts["initial_energy"]
    assert a.quality.tac_1 == pytest.approx(opts["energy"], rel=1e-9)
    assert set(a.trace) == {"temperature", "energy", "best", "acceptance"}
    assert all(len(v) == 40 for v in a.trace.values())
    assert np.all(np.diff(a.trace["best"]) <= 0)
    assert np.all(np.diff(a.trace["temperature"]) < 0)
    assert np.all((a.trace["acceptance"] >= 0) & (a.trace["acceptance"] <= 1))


def test_energy_with_p2_matches_the_quality_norm():
    pts = bumpy_patch(500, 2)
    a = scanmesh.reconstruct(pts, "anneal", sweeps=30, p=2)
    assert a.options["energy"] == pytest.approx(a.quality.tac_2**2, rel=1e-9)


def test_same_seed_same_faces_other_seed_other_faces():
    pts = bumpy_patch(500, 3)
    a = scanmesh.reconstruct(pts, "anneal", sweeps=30, seed=11)
    b = scanmesh.reconstruct(pts, "anneal", sweeps=30, seed=11)
    c = scanmesh.reconstruct(pts, "anneal", sweeps=30, seed=12)
    assert np.array_equal(a.faces, b.faces)
    assert not np.array_equal(canonical(a.faces), canonical(c.faces))


def test_lop_is_a_local_optimum_and_reruns_make_no_flip():
    pts = bumpy_patch(500, 4)
    once = scanmesh.reconstruct(pts, "lop")
    assert once.options["flips"] > 0
    again = lop_surface(once)
    assert again.options["flips"] == 0
    assert once.quality.tac_1 < scanmesh.delaunay(pts).quality.tac_1


def test_progress_callback_sees_every_sweep():
    pts = bumpy_patch(300, 5)
    seen = []
    s = scanmesh.reconstruct(
        pts,
        "anneal",
        sweeps=25,
        patience=0,
        progress=lambda done, total, energy: seen.append((done, total, energy)),
    )
    total = 25 * s.options["chains"]
    assert seen[-1][0] == total and all(t == total for _, t, _ in seen)
    assert [d for d, _, _ in seen] == sorted(d for d, _, _ in seen)


def test_progress_ends_where_an_early_stop_ended_the_run():
    pts = bumpy_patch(300, 5)
    seen = []
    s = scanmesh.reconstruct(
        pts,
        "anneal",
        sweeps=5000,
        patience=5,
        chains=1,
        progress=lambda done, total, energy: seen.append((done, total, energy)),
    )
    ran = len(s.trace["energy"])
    assert ran < 5000  # stopped early
    assert seen[-1][:2] == (ran, 5000)  # the last report: the sweeps run, the same total
    assert all(d <= ran and t == 5000 for d, t, _ in seen)
    assert [d for d, _, _ in seen] == sorted(d for d, _, _ in seen)


def test_progress_total_never_jumps_when_the_time_limit_stops_before_a_sweep():
    # A time limit reached before the first sweep reported 0/2000 then 0/0: a total that
    # changed mid-stage, and a division by zero for a callable showing a percentage.
    pts = bumpy_patch(300, 5)
    seen = []

    def progress(done, total, value, stage):
        seen.append((stage, done, total, 100 * done / total))

    s = scanmesh.reconstruct(
        pts, "anneal", sweeps=1000, chains=1, time_limit=1e-6, progress=progress
    )
    assert s.options["stopped"] == "time_limit"
    for stage in {st for st, *_ in seen}:
        totals = {t for st, _, t, _ in seen if st == stage}
        assert len(totals) == 1 and 0 not in totals, (stage, totals)
    assert [t for st, _, t, _ in seen if st == "anneal"][-1] == 1000


@pytest.mark.parametrize(
    "options, match",
    [
        ({"sweeps": -1}, "sweeps"),
        ({"sweeps": 2.5}, "sweeps"),
        ({"p": 0.5}, "p must"),
        ({"p": float("inf")}, "p must"),
        ({"initial_acceptance": 1.5}, "initial_acceptance"),
        ({"final_temperature_ratio": 0}, "final_temperature_ratio"),
        ({"bogus": 1}, r"unknown option\(s\) \['bogus'\]"),
        ({"tiles": 0}, "tiles"),
        ({"tiles": 65}, "tiles"),
        ({"tiles": 1.5}, "tiles"),
        ({"initial": "magic"}, "unknown initial"),
    ],
)
def test_bad_annealing_options(options, match):
    with pytest.raises(scanmesh.ParameterError, match=match):
        scanmesh.reconstruct(bumpy_patch(50, 6), "anneal", **options)


def test_bad_method_and_seed():
    with pytest.raises(scanmesh.ParameterError, match="unknown method"):
        scanmesh.reconstruct(bumpy_patch(50, 6), "magic")
    with pytest.raises(scanmesh.ParameterError, match="seed"):
        scanmesh.reconstruct(bumpy_patch(50, 6), "anneal", seed=-1)
    with pytest.raises(scanmesh.ParameterError, match="criterion"):
        scanmesh.reconstruct(bumpy_patch(50, 6), "lop", criterion="nope")


@pytest.mark.slow
@pytest.mark.parametrize("tiles", [1, 4])
def test_ctrl_c_stops_a_long_run_quickly(tmp_path, tiles):
    script = textwrap.dedent(
        """
        import sys, time
        import numpy as np
        import scanmesh
        rng = np.random.default_rng(0)
        xy = rng.random((60000, 2))
        pts = np.column_stack([xy, np.sin(5 * xy[:, 0]) * np.cos(3 * xy[:, 1])])
        started = []
        def progress(done, total, energy):
            if not started:
                started.append(1)
                print("started", flush=True)
        try:
            scanmesh.reconstruct(
                pts, "anneal", sweeps=100000, patience=0, tiles=TILES, progress=progress,
                tie_tolerance=0.0,
            )
        except KeyboardInterrupt:
            print(f"interrupted {time.monotonic()!r}", flush=True)
            sys.exit(0)
        print("finished", flush=True)
        """
    ).replace("TILES", str(tiles))
    # Exact ties: the noise estimate of this steep surface (tolerance 4e4) leaves annealing
    # no edge whose flip could lower tac by more than a tie, and the run would end at once.
    assert seconds_to_interrupt(script, 0.3) < 0.2


@pytest.mark.slow
def test_ctrl_c_stops_the_polish_of_a_large_run_quickly():
    """The polish after the sweeps is one native call of seconds on a large hot state: it
    runs in a worker thread, so Ctrl-C does not wait for it."""
    script = """
        import sys, time
        import numpy as np
        import scanmesh
        rng = np.random.default_rng(0)
        xy = rng.random((200000, 2))
        pts = np.column_stack([xy, np.sin(5 * xy[:, 0]) * np.cos(3 * xy[:, 1])])
        def progress(done, total, value, stage):
            if stage == "polish" and done == 0:
                print("started", flush=True)
        try:
            scanmesh.reconstruct(pts, "anneal", plane="z", sweeps=2, patience=0,
                                 progress=progress)
        except KeyboardInterrupt:
            print(f"interrupted {time.monotonic()!r}", flush=True)
            sys.exit(0)
        print("finished", flush=True)
        """
    assert seconds_to_interrupt(script, 0.05) < 0.5


def test_small_inputs_run_several_chains_and_keep_the_best():
    pts = bumpy_patch(40, 8)
    many = scanmesh.reconstruct(pts, "anneal", seed=4, max_edge=math.inf)
    # the automatic schedule shares its budget among the chains: the same sweeps here
    sweeps = many.options["sweeps"]
    one = scanmesh.reconstruct(pts, "anneal", seed=4, max_edge=math.inf, chains=1, sweeps=sweeps)
    energies = many.options["chain_energies"]
    assert many.options["chains"] == len(energies) > 1
    assert one.options["chains"] == 1
    # Chain 0 of the automatic run is the single-chain run with the same seed.
    assert energies[0] == pytest.approx(one.options["energy"], rel=1e-12)
    assert many.options["energy"] == min(energies)
    assert energies.index(min(energies)) == many.options["best_chain"]
    assert many.quality.tac_1 <= one.quality.tac_1 * (1 + 1e-12)
    again = scanmesh.reconstruct(pts, "anneal", seed=4, max_edge=math.inf)
    np.testing.assert_array_equal(again.faces, many.faces)


def test_large_inputs_run_one_chain_unless_asked():
    pts = bumpy_patch(4000, 9)
    auto = scanmesh.reconstruct(pts, "anneal", sweeps=2, patience=0)
    assert auto.options["chains"] == 1
    three = scanmesh.reconstruct(pts, "anneal", sweeps=2, patience=0, chains=3)
    assert three.options["chains"] == 3 and len(three.options["chain_energies"]) == 3


def test_tiles_anneal_the_rod_as_well_as_one_chain(rod_results, rod_with_curtains, rod_scan):
    pts, _ = rod_scan
    uv, _ = scanmesh.project(pts, "y")
    tiled = anneal_surface(rod_with_curtains, sweeps=150, tiles=3, **PAPER)
    _core.validate(uv, tiled.faces)
    assert len(tiled.faces) == len(rod_results["delaunay"].faces)
    assert tiled.options["tiles"] == 3
    assert tiled.quality.tac_1 < rod_results["lop"].quality.tac_1
    assert tiled.quality.tac_1 < 1.15 * rod_results["anneal"].quality.tac_1
    assert len(tiled.trace["energy"]) == 150
    assert np.all(np.diff(tiled.trace["best"]) <= 0)
    again = anneal_surface(rod_with_curtains, sweeps=150, tiles=3, **PAPER)
    np.testing.assert_array_equal(again.faces, tiled.faces)


def test_time_limit_stops_a_long_run_with_the_best_state():
    pts = bumpy_patch(5_000, 21)  # a million sweeps: hours
    start = scanmesh.delaunay(pts)
    left = []
    s = anneal_surface(
        start,
        sweeps=1_000_000,
        patience=0,
        time_limit=0.3,
        progress=lambda done, total, energy, seconds_left: left.append(seconds_left),
    )
    opts = s.options
    assert opts["stopped"] == "time_limit" and opts["time_limit"] == 0.3
    assert len(s.trace["energy"]) < 1_000_000
    # the best state so far, polished: a valid triangulation of the same domain
    _core.validate(start.scan.uv, s.faces)
    assert len(s.faces) == len(start.faces)
    accounted = set(s.faces.ravel().tolist()) | set(opts["trimmed"])
    accounted |= set(s.duplicates[:, 0].tolist())
    assert accounted == set(range(len(pts)))
    assert opts["energy"] <= opts["initial_energy"]
    assert s.quality.tac_1 == pytest.approx(opts["energy"], rel=1e-9)
    # the time left never exceeds what the limit leaves, and ends at zero
    assert all(x is not None and 0 <= x <= 0.3 for x in left) and left[-1] == 0


@pytest.mark.slow
def test_without_a_time_limit_results_and_stop_reasons_are_unchanged():
    pts = bumpy_patch(500, 3)
    a = scanmesh.reconstruct(pts, "anneal", sweeps=30, seed=11, patience=0)
    b = scanmesh.reconstruct(pts, "anneal", sweeps=30, seed=11, patience=0, time_limit=1e6)
    assert np.array_equal(a.faces, b.faces)
    assert a.options["stopped"] == b.options["stopped"] == "sweeps"
    assert a.options["time_limit"] is None
    # a scan large enough for noise-level ties (MIN_TIE_POINTS): the chain freezes early
    from scanmesh.scan.noise import MIN_TIE_POINTS

    noisy = bumpy_patch(MIN_TIE_POINTS, 3)
    early = scanmesh.reconstruct(
        noisy, "anneal", sweeps=5000, patience=5, chains=1, tie_tolerance=None
    )
    assert early.options["stopped"] == "patience"


def test_a_flat_scan_is_reported_exhausted_not_stopped_early():
    # A plane: every vertex's tac is rounding, no edge is live, no sweep runs; the reason
    # says so (it said "sweeps", and mid-run exhaustion "patience").
    rng = np.random.default_rng(5)
    xy = rng.random((400, 2))
    pts = np.column_stack([xy, 0.3 * xy[:, 0] - 0.2 * xy[:, 1]])
    flat = scanmesh.reconstruct(pts, "anneal", plane="z", sweeps=50, patience=0, chains=1)
    assert flat.options["stopped"] == "exhausted"
    assert len(flat.trace["energy"]) == 0 and flat.options["proposals"] == 0
    # a curved patch with the same schedule runs every sweep
    curved = scanmesh.reconstruct(bumpy_patch(400, 5), "anneal", sweeps=50, patience=0)
    assert curved.options["stopped"] == "sweeps" and len(curved.trace["energy"]) == 50


def test_stage_callables_get_the_time_left_only_when_they_take_it():
    pts = bumpy_patch(400, 7)
    extras = []
    scanmesh.reconstruct(pts, "anneal", sweeps=5, progress=lambda *a, **k: extras.append(k))
    anneal_calls = [k for k in extras if k["stage"] == "anneal"]
    assert anneal_calls and all("seconds_left" in k for k in anneal_calls)
    assert all(set(k) == {"stage"} for k in extras if k["stage"] != "anneal")
    stages = []

    def stage_only(done, total, value, stage):  # no seconds_left: never sent one
        stages.append(stage)

    scanmesh.reconstruct(pts, "anneal", sweeps=5, progress=stage_only)
    assert "anneal" in stages and "polish" in stages


@pytest.mark.parametrize("bad", [-1.0, 0.0, math.nan, math.inf, -math.inf, "5", True])
def test_bad_time_limit_names_the_option_and_value(bad):
    with pytest.raises(scanmesh.ParameterError, match=r"time_limit must .*got"):
        scanmesh.reconstruct(bumpy_patch(50, 6), "anneal", time_limit=bad)


def test_seconds_left_follows_the_work_done_and_the_limit():
    from scanmesh.stages.anneal import seconds_left

    # half the proposals of the only sweep in 2 s: 2 s more
    assert seconds_left(0, 1, 50, 100, 2.0, None) == pytest.approx(2.0)
    # proposals beyond the planned count are kept within the sweep under way
    assert seconds_left(1, 4, 400, 400, 3.0, None) == pytest.approx(3.0)
    assert seconds_left(0, 10, 0, 100, 0.5, None) is None
    assert seconds_left(0, 10, 0, 100, 0.5, 4.0) == 4.0
    assert seconds_left(5, 10, 500, 1000, 10.0, 1.5) == 1.5
    assert seconds_left(10, 10, 1000, 1000, 10.0, -0.2) == 0.0


def test_coincident_copies_are_annealed_as_one_point_in_seconds():
    """10^5 coincident points and three more: the noise estimate fitted every copy's
    neighbourhood (quadratic in the tree, minutes at 10^6) and each of 128 chains held
    them all (16.5 GiB at 10^6). Both now see the four distinct points."""
    pts = np.vstack([np.zeros((100_000, 3)), [[1.0, 0, 0], [0, 1.0, 0], [1.0, 1.0, 0.5]]])
    start = time.perf_counter()
    with pytest.warns(scanmesh.CoincidentPointsWarning, match="99999 point"):
        # plane given: a sample of 20,000 of these points holds none of the distinct three
        s = scanmesh.reconstruct(pts, "anneal", sweeps=2, plane="z")
    took = time.perf_counter() - start
    assert took < 30.0  # about 1.5 s on a loaded machine; 100 s before
    assert len(s.faces) == 2 and len(s.duplicates) == 99_999
    assert set(s.faces.ravel().tolist()) == {0, 100_000, 100_001, 100_002}
