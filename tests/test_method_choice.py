"""The default method (``"auto"``): a holdout among annealing, LOP, Delaunay and shortest-path
on a window of the scan chooses the method, seeded; what each candidate measured is kept."""

from __future__ import annotations

import dataclasses
import threading
import time
import warnings

import numpy as np
import pytest
import trimesh

import scanmesh
from conftest import DATA, bumpy_patch
from scanmesh import methods
from scanmesh._context import QUIET
from scanmesh.methods import DEFAULT_METHOD
from scanmesh.scan.planar import as_scan
from scanmesh.stages import anneal as anneal_stage
from scanmesh.stages import choice
from scanmesh.stages import strips_anneal as strips_anneal_stage


def _turned_scan(name: str, up: str, noise: float):
    """The panel's oblique scan of a part in tests/data: turned 30 degrees about ``up``,
    scanned at 1/150 of its extent with noise ``noise`` x the spacing (seed 0)."""
    part = trimesh.load(DATA / "cad" / name, force="mesh")
    axis = np.eye(3)["xyz".index(up)]
    turn = trimesh.transformations.rotation_matrix(np.radians(30.0), axis, part.centroid)
    part.apply_transform(turn)
    across = [k for k in range(3) if "xyz"[k] != up]
    spacing = float(np.ptp(part.bounds[:, across], axis=0).max()) / 150
    return scanmesh.simulate_scan(
        part, up=up, along="x", spacing=spacing, noise=noise * spacing, seed=0
    )


def test_the_default_is_auto_and_anneal_still_anneals(monkeypatch):
    monkeypatch.setattr(choice, "MEASURED", 1)  # one tenth withheld: quick
    monkeypatch.setattr(choice, "MIN_POINTS", 30)
    pts = bumpy_patch(400, 3)
    assert DEFAULT_METHOD == "auto"
    default = scanmesh.reconstruct(pts, plane="z")
    made = default.options["method_choice"]
    assert made["chosen"] == default.method
    assert set(made["holdout"]) == set(methods.CANDIDATES)
    assert made["measured"] > 0 and made["folds"] == 1
    annealed = scanmesh.reconstruct(pts, "anneal", plane="z")
    assert annealed.method == "anneal" and "method_choice" not in annealed.options


@pytest.mark.slow
def test_the_same_seed_makes_the_same_choice_and_faces(monkeypatch):
    monkeypatch.setattr(choice, "MEASURED", 1)
    monkeypatch.setattr(choice, "MIN_POINTS", 30)
    pts = bumpy_patch(600, 5)
    a = scanmesh.reconstruct(pts, plane="z", seed=3)
    b = scanmesh.reconstruct(pts, plane="z", seed=3)
    assert a.options["method_choice"]["holdout"] == b.options["method_choice"]["holdout"]
    assert np.array_equal(a.faces, b.faces)
    other = scanmesh.reconstruct(pts, plane="z", seed=4)
    # another seed withholds other points: other figures
    assert other.options["method_choice"]["holdout"] != a.options["method_choice"]["holdout"]


def test_the_lowest_holdout_wins_and_the_earlier_candidate_an_exact_tie(monkeypatch):
    monkeypatch.setattr(choice, "MIN_POINTS", 30)
    scan = as_scan(bumpy_patch(300, 1), plane="z")
    built = {}

    def build(name, part):
        built[name] = built.get(name, 0) + 1
        surface = scanmesh.reconstruct(part, "delaunay")
        if name == "bad":  # the same faces half a unit higher
            return dataclasses.replace(surface, vertices=surface.vertices + [0.0, 0.0, 0.5])
        return surface

    made = choice.choose(scan, build, candidates=("bad", "good", "same"))
    assert made.chosen == "good"  # "same" ties with it exactly: the earlier wins
    assert made.holdout["good"] == made.holdout["same"] < made.holdout["bad"]
    assert built == {name: made.folds for name in ("bad", "good", "same")}


def test_the_judge_builds_each_triangulation_once_a_part(monkeypatch):
    """LOP starts from the part's Delaunay mesh and annealing from LOP's optimum: one
    Delaunay triangulation per judged part (three before: Delaunay, LOP's start and
    annealing's), and one more for the winner when it starts from Delaunay."""
    monkeypatch.setattr(choice, "MEASURED", 3_000)
    monkeypatch.setattr(choice, "CLEAR", float("inf"), raising=False)  # every tenth judged
    monkeypatch.setattr(choice, "MIN_POINTS", 30)
    calls = []
    real = methods.delaunay

    def counted(scan, **kwargs):
        calls.append(len(scan.points))
        return real(scan, **kwargs)

    monkeypatch.setattr(methods, "delaunay", counted)
    surface = scanmesh.reconstruct(bumpy_patch(400, 3), plane="z", seed=1)
    made = surface.options["method_choice"]
    assert made["folds"] == 10  # 40 withheld a tenth, every point once
    final = surface.method in ("anneal", "lop", "delaunay")
    assert calls == [360] * made["folds"] + [400] * final


def test_the_judge_estimates_the_noise_once(monkeypatch):
    """strips-anneal's tie tolerance follows the noise: estimated on the first part and
    kept for the others (one estimate a part before), and once more for the winner when
    it is strips-anneal (built beside the judge: estimated there, whoever wins, unless
    it was stopped first)."""
    monkeypatch.setattr(choice, "CLEAR", float("inf"), raising=False)
    monkeypatch.setattr(choice, "MIN_POINTS", 30)
    estimated = []
    real = anneal_stage.noise_tolerance

    def counted(initial, p, given, floor):
        if given is None:
            estimated.append(len(initial.scan.points))
        return real(initial, p, given, floor)

    monkeypatch.setattr(anneal_stage, "noise_tolerance", counted)
    surface = scanmesh.reconstruct(bumpy_patch(400, 3), plane="z", seed=1)
    assert surface.options["method_choice"]["folds"] == 10
    assert estimated.count(360) == 1 and len(estimated) == 1 + estimated.count(400)
    assert estimated.count(400) == 1 or surface.method != "strips-anneal"


def test_the_judge_anneals_the_short_schedule_and_the_winner_the_full_one(monkeypatch):
    monkeypatch.setattr(choice, "MEASURED", 1)
    monkeypatch.setattr(choice, "MIN_POINTS", 30)
    runs = []
    real = anneal_stage.build_anneal

    def recorded(initial, params, context=QUIET, fixed=None, **keywords):
        out = real(initial, params, context, fixed, **keywords)
        runs.append(
            (len(initial.scan.points), initial.method, out.options["sweeps"], params["polish"])
        )
        return out

    monkeypatch.setattr(anneal_stage, "build_anneal", recorded)
    surface = scanmesh.reconstruct(bumpy_patch(400, 3), plane="z", seed=1, method="auto")
    judged = [r for r in runs if r[0] == 360]
    assert sorted(r[1] for r in judged) == ["lop", "shortest-path"]
    assert {r[2:] for r in judged} == {(methods.JUDGE_SCHEDULE["sweeps"], False)}
    # the first candidate's build beside the judge may finish and be left: not the winner's
    final = [r for r in runs if r[0] == 400 and r[1] == surface.options.get("initial")]
    if surface.method in ("anneal", "strips-anneal"):
        assert len(final) == 1 and final[0][2] > methods.JUDGE_SCHEDULE["sweeps"]
        assert final[0][3]  # the winner polished
    else:
        assert final == []


def _offset_builds(offsets: dict[str, float], built: dict[str, int] | None = None):
    """A judge's ``build``: the part's Delaunay mesh raised by ``offsets[name]`` (builds
    counted in ``built``)."""

    def build(name, part):
        if built is not None:
            built[name] = built.get(name, 0) + 1
        surface = scanmesh.reconstruct(part, "delaunay")
        return dataclasses.replace(surface, vertices=surface.vertices + [0.0, 0.0, offsets[name]])

    return build


def test_a_clear_verdict_stops_early_with_the_full_judges_choice(monkeypatch):
    """6,000 points: tenths of 600, five until 3,000 are measured. A candidate 0.01 higher
    than the surface is clear after the first tenth, and the early verdict is the full
    judge's; an exact tie is never clear, so every tenth is judged."""
    monkeypatch.setattr(choice, "MIN_POINTS", 30)
    scan = as_scan(bumpy_patch(6_000, 4), plane="z")
    build = _offset_builds({"high": 0.01, "exact": 0.0, "same": 0.0})
    early = choice.choose(scan, build, candidates=("high", "exact"))
    assert early.chosen == "exact" and early.folds == 1 and early.measured >= choice.CLEAR_MEASURED
    monkeypatch.setattr(choice, "CLEAR", float("inf"))
    full = choice.choose(scan, build, candidates=("high", "exact"))
    assert full.folds == 5 and full.chosen == early.chosen
    monkeypatch.setattr(choice, "CLEAR", 0.03)
    tie = choice.choose(scan, build, candidates=("high", "exact", "same"))
    assert tie.folds == 5 and tie.chosen == "exact"


def test_a_candidate_behind_is_built_no_more_and_the_verdict_is_the_full_judges(monkeypatch):
    """Two candidates tie exactly (never clear: every tenth judged), a third is 0.01 above
    the surface: behind after the first tenth, it is not built again, and the verdict and
    the others' figures are the full judge's."""
    monkeypatch.setattr(choice, "MIN_POINTS", 30)
    scan = as_scan(bumpy_patch(6_000, 4), plane="z")
    built: dict[str, int] = {}
    build = _offset_builds({"high": 0.01, "exact": 0.0, "same": 0.0}, built)
    heard: list[tuple[str, ...]] = []
    raced = choice.choose(scan, build, candidates=("high", "exact", "same"), watch=heard.append)
    assert built == {"high": 1, "exact": 5, "same": 5} and raced.folds == 5
    assert heard == [("exact", "same")] * 5  # what a build beside the judge is stopped by
    monkeypatch.setattr(choice, "CLEAR", float("inf"))
    full = choice.choose(scan, build, candidates=("high", "exact", "same"))
    assert raced.chosen == full.chosen == "exact"
    assert raced.holdout["exact"] == full.holdout["exact"] == full.holdout["same"]
    assert raced.holdout["high"] > 1.03 * raced.holdout["exact"]


def test_lanes_build_side_by_side_with_the_figures_of_one_lane(monkeypatch):
    """The registry's lanes: strips-anneal beside annealing with the LOP and Delaunay it
    starts from. Lanes after the first are built (and their meshes measured) in another
    thread; the figures are the ones of all candidates built in turn."""
    assert methods.judge_lanes(methods.CANDIDATES) == (
        ("strips-anneal",),
        ("anneal", "lop", "delaunay"),
    )
    monkeypatch.setattr(choice, "MIN_POINTS", 30)
    scan = as_scan(bumpy_patch(3_000, 4), plane="z")
    where: dict[str, set[str]] = {}
    offsets = {"a": 0.0, "b": 0.001, "c": -0.002}
    plain = _offset_builds(offsets)

    def build(name, part):
        where.setdefault(name, set()).add(threading.current_thread().name)
        return plain(name, part)

    measured_in = []
    real = choice.normal_distances

    def counted(held, seen):
        measured_in.append(threading.current_thread().name)
        return real(held, seen)

    monkeypatch.setattr(choice, "normal_distances", counted)
    beside = choice.choose(scan, build, ("a", "b", "c"), lanes=(("a",), ("b", "c")))
    assert where == {"a": {"MainThread"}, "b": {"scanmesh-judge"}, "c": {"scanmesh-judge"}}
    # each lane measures its own meshes, beside the other lane's builds
    assert sorted(set(measured_in)) == ["MainThread", "scanmesh-judge"]
    assert measured_in.count("scanmesh-judge") == 2 * measured_in.count("MainThread")
    in_turn = choice.choose(scan, build, ("a", "b", "c"))
    assert where["b"] == {"scanmesh-judge", "MainThread"}
    assert beside == dataclasses.replace(in_turn, seconds=beside.seconds)


def test_a_candidate_not_judged_is_built_no_more(monkeypatch):
    """A mesh covering half the plane leaves half the withheld points outside (as the strips
    do on the Autzen ground): not judged after the first tenth, it is not built again,
    while two tied candidates are judged on every tenth; one leaving 16 % outside is not
    judged either, but built on (the rod along its thickness: 10 %, judged on some tenths)."""
    monkeypatch.setattr(choice, "MIN_POINTS", 30)
    scan = as_scan(bumpy_patch(8_000, 4), plane="z")  # 4 tenths of 800
    built: dict[str, int] = {}

    def build(name, part):
        built[name] = built.get(name, 0) + 1
        surface = scanmesh.reconstruct(part, "delaunay")
        if name in ("half", "most"):  # faces west of x = 0.5 (0.84): 50 % (16 %) outside
            west = surface.vertices[surface.faces][:, :, 0].mean(axis=1) < 0.5 + 0.34 * (
                name == "most"
            )
            return dataclasses.replace(surface, faces=surface.faces[west])
        return surface

    made = choice.choose(scan, build, candidates=("exact", "same", "half", "most"))
    # "most" is not judged either (over OUTSIDE more outside) but might be on other
    # tenths (under OUTSIDE_FAR): built on every one
    assert built == {"exact": 4, "same": 4, "half": 1, "most": 4}
    assert np.isnan(made.holdout["half"]) and made.outside["half"] > 350
    assert np.isnan(made.holdout["most"])


def test_a_lead_carried_by_a_few_points_does_not_put_a_candidate_behind(monkeypatch):
    """A candidate far off at a few points only (a spike: the vertices within 0.03 of one
    spot raised by 1) has a far larger RMS after the first tenth, but its paired
    differences are a few points' (under CLEAR_Z standard errors): it is judged on more
    tenths than one, as a heavy tail needs (the fandisk's creases)."""
    monkeypatch.setattr(choice, "MIN_POINTS", 30)
    scan = as_scan(bumpy_patch(6_000, 4), plane="z")
    built: dict[str, int] = {}

    def build(name, part):
        built[name] = built.get(name, 0) + 1
        surface = scanmesh.reconstruct(part, "delaunay")
        if name == "spike":
            near = np.linalg.norm(surface.vertices[:, :2] - 0.5, axis=1) < 0.03
            raised = surface.vertices + near[:, None] * [0.0, 0.0, 1.0]
            return dataclasses.replace(surface, vertices=raised)
        return surface

    made = choice.choose(scan, build, candidates=("exact", "spike"))
    assert made.holdout["spike"] > 10 * made.holdout["exact"]
    assert built["spike"] > 1 and made.chosen == "exact"


def test_the_window_is_whole_lines_around_the_middle_and_the_folds_disjoint():
    lines = np.repeat(np.arange(100), 300)  # 30,000 points, 300 a line
    win = choice.window(lines, size=20_000)
    kept = np.unique(lines[win])
    assert len(win) <= 20_000 and len(win) == 300 * len(kept)
    assert np.all(np.diff(kept) == 1) and kept[0] <= 50 <= kept[-1]
    parts = choice.folds(2_000, seed=1, measured=500)
    assert len(parts) == 3  # tenths of 200 until 500 are withheld
    joined = np.concatenate(parts)
    assert len(np.unique(joined)) == len(joined)
    assert [p.tolist() for p in choice.folds(2_000, seed=1, measured=500)] == [
        p.tolist() for p in parts
    ]
    assert len(choice.folds(2_000, seed=1, measured=10**6)) == 10  # each point once


@pytest.mark.slow
def test_on_the_noisy_oblique_conrod_the_default_takes_delaunay():
    """The conrod turned 30 degrees at noise s/30 (the panel's scan): Delaunay is 12 % closer
    to the part than annealing; the holdout ranks it first too."""
    pts, lines = _turned_scan("conrod_slevin48_onshape.stl", "y", 1 / 30)
    default = scanmesh.reconstruct(pts, plane="y", lines=lines, seed=0)
    assert default.method == "delaunay"
    made = default.options["method_choice"]
    assert made["holdout"]["delaunay"] < made["holdout"]["anneal"]


@pytest.mark.slow
def test_on_the_noisy_oblique_conrod_the_judge_stops_early_with_the_full_verdict(monkeypatch):
    """The same scan judged with candidates dropped once behind, and on every tenth with
    none dropped: the same choice, in fewer builds."""
    pts, lines = _turned_scan("conrod_slevin48_onshape.stl", "y", 1 / 30)
    scan = as_scan(pts, plane="y", lines=lines)
    quiet = methods.Keywords()

    def judged(lanes):
        builds = []
        build = methods.judge_builder(quiet)

        def counted(name, part):
            builds.append(name)
            return build(name, part)

        return choice.choose(scan, counted, methods.CANDIDATES, lanes=lanes), len(builds)

    (early, n_early) = judged(methods.judge_lanes(methods.CANDIDATES))
    monkeypatch.setattr(choice, "CLEAR", float("inf"))
    monkeypatch.setattr(choice, "OUTSIDE_FAR", float("inf"))
    (full, n_full) = judged(None)
    assert early.chosen == full.chosen == "delaunay"
    assert n_early < n_full == full.folds * len(methods.CANDIDATES)


def test_on_the_oblique_pocket_the_holdout_ties_and_the_first_candidate_stays():
    """The pocket of test_anneal_start's oblique crease test, noise-free: away from its
    steps every candidate's mesh holds the withheld points exactly alike, so the first
    candidate (the strips annealed) is built. (Annealing from LOP's free optimum is 6 %
    closer to the part there: docs/benchmarks/panel.md.)"""
    pts, lines = _turned_scan("octagonal_pocket.ply", "z", 0.0)
    default = scanmesh.reconstruct(pts, plane="z", lines=lines, seed=0)
    assert default.method == methods.CANDIDATES[0] == "strips-anneal"
    holdout = default.options["method_choice"]["holdout"]
    assert len(set(holdout.values())) == 1


def test_a_scan_too_small_to_judge_is_annealed():
    pts = bumpy_patch(choice.MIN_POINTS - 1, 2)
    surface = scanmesh.reconstruct(pts, plane="z")
    made = surface.options["method_choice"]
    assert surface.method == "anneal" and made["folds"] == 0 and made["measured"] == 0


@pytest.mark.slow
def test_on_a_gridded_scan_delaunay_chosen_builds_the_grid(monkeypatch):
    """The judge's parts have no range grid, so Delaunay stands in for the grid there; on
    a range scan the grid is what gets built (no curtains), as LOP and annealing start
    from it."""
    scan = scanmesh.simulate_range_scan(
        DATA / "cad" / "fandisk.obj", up="x", along="y", n_points=1_500
    )
    real = choice.choose

    def delaunay_wins(*args, **kwargs):
        return dataclasses.replace(real(*args, **kwargs), chosen="delaunay")

    monkeypatch.setattr(choice, "choose", delaunay_wins)
    monkeypatch.setattr(choice, "MIN_POINTS", 30)
    with pytest.warns(scanmesh.CurtainsWarning):  # what Delaunay alone keeps here
        alone = scanmesh.reconstruct(scan, "delaunay")
    assert alone.options["curtains"]["count"] > 0
    surface = scanmesh.reconstruct(scan)
    assert surface.options["method_choice"]["chosen"] == "delaunay"
    assert surface.method == surface.options["method_choice"]["built"] == "grid"
    assert surface.options["curtains"]["count"] == 0


@pytest.mark.slow
def test_on_a_gridded_scan_the_strips_are_no_candidate():
    """The default stays inside a range grid's domain: the strips join lines wherever both
    have samples, so on a gridded scan only annealing, LOP and Delaunay (the grid) are
    judged; the same points without their grid are judged with the strips."""
    scan = scanmesh.simulate_range_scan(
        DATA / "cad" / "fandisk.obj", up="x", along="y", n_points=1_500
    )
    gridded = scanmesh.reconstruct(scan).options["method_choice"]
    assert set(gridded["holdout"]) == set(methods.GRID_CANDIDATES)
    assert "shortest-path" not in gridded["holdout"] and gridded["folds"] > 0
    plain = scanmesh.reconstruct(dataclasses.replace(scan, grid=None))
    plain = plain.options["method_choice"]
    assert set(plain["holdout"]) == set(methods.CANDIDATES)


def test_the_first_candidate_is_built_beside_the_judge_and_taken_when_it_wins(monkeypatch):
    """On a small scan the first candidate is built on all points in a thread while the
    judge runs (before: after the judge, on its own), with the call's seed: the very mesh
    built alone, its warnings the call's and the judge's parts' none."""
    monkeypatch.setattr(choice, "MEASURED", 1)
    monkeypatch.setattr(choice, "MIN_POINTS", 30)
    pts = bumpy_patch(400, 3)  # in no scan order: the strips warn of what they drop
    events: list = []
    real_choose, real_build = choice.choose, strips_anneal_stage.build_strips_anneal

    def first_wins(*args, **kwargs):
        made = real_choose(*args, **kwargs)
        events.append("judged")
        return dataclasses.replace(made, chosen=methods.CANDIDATES[0])

    def build(scan, params, context=QUIET):
        if len(scan.points) == len(pts):
            events.append(threading.current_thread().name)
        return real_build(scan, params, context)

    monkeypatch.setattr(choice, "choose", first_wins)
    monkeypatch.setattr(strips_anneal_stage, "build_strips_anneal", build)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        surface = scanmesh.reconstruct(pts, plane="z", seed=2)
    assert events == ["scanmesh-ahead", "judged"]
    with warnings.catch_warnings(record=True) as warned:
        warnings.simplefilter("always")
        alone = scanmesh.reconstruct(pts, methods.CANDIDATES[0], plane="z", seed=2)
    assert surface.method == alone.method and np.array_equal(surface.faces, alone.faces)
    said = [str(w.message) for w in warned]
    assert said and [str(w.message) for w in caught] == said


def _slow_method(monkeypatch, run):
    """Registers method "slow" running ``run(scan, params, keywords)``."""
    slow = dataclasses.replace(methods.TABLE["delaunay"], name="slow", run=run)
    monkeypatch.setitem(methods.TABLE, "slow", slow)


def test_a_build_beside_the_judge_reports_once_taken_and_ends_when_stopped(monkeypatch):
    """Its progress is the call's from the moment it is taken (the stage running, not the
    reports before; a callable of annealing's own convention hears annealing only);
    stopped, it ends at its next report and keeps no mesh."""
    scan = as_scan(bumpy_patch(100, 1), plane="z")
    reached, first, second = threading.Event(), [], []

    def taken(box):  # the build goes on once the caller took it (its progress is shown)
        while not box or not box[0]._shown:
            time.sleep(0.001)

    def run(scan, params, kw):
        with kw.context.stage("anneal", 3) as stage:
            stage.update(1)
            reached.set()
            taken(first)
            stage.update(2)
        return "mesh"

    _slow_method(monkeypatch, run)
    first.append(methods._Ahead("slow", scan, methods.Keywords()))
    assert reached.wait(30)
    heard = []
    assert first[0].take(lambda done, total, value, stage: heard.append((stage, done))) == "mesh"
    assert heard == [("anneal", 2), ("anneal", 3)]

    def stages(scan, params, kw):
        taken(second)
        for name in ("strips", "anneal"):
            with kw.context.stage(name, 2) as stage:
                stage.update(1)
        return "mesh"

    _slow_method(monkeypatch, stages)
    second.append(methods._Ahead("slow", scan, methods.Keywords()))
    sweeps = []
    assert second[0].take(lambda done, total, energy: sweeps.append((done, total))) == "mesh"
    assert sweeps == [(0, 2), (1, 2), (2, 2)]

    def endless(scan, params, kw):
        with kw.context.stage("anneal", 10**9) as stage:
            for done in range(10**9):
                stage.update(done)
                time.sleep(0.001)

    _slow_method(monkeypatch, endless)
    ahead = methods._Ahead("slow", scan, methods.Keywords())
    ahead.stop()
    assert ahead.result is None and ahead.error is None
    assert ahead.take(False) is None
