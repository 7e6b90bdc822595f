"""The Python API under fuzzing (cases in api_fuzz.py): ``reconstruct`` with every method
and options of every type and size returns a valid mesh that accounts for every point, or
a ScanmeshError naming the bad input; never another exception, a hang or a crash. The
long run is benches/api_fuzz.py."""

from __future__ import annotations

import math
import subprocess
import sys

import numpy as np
import pytest

from api_fuzz import (
    JUNK,
    Runner,
    _names,
    make_case,
    reproducer,
    run_many,
    surface_fault,
    valid_value,
)
from scanmesh import METHODS, Surface, reconstruct
from scanmesh._checks import Option
from scanmesh.methods import TABLE

#: Examples in CI; each runs in a child process (benches/api_fuzz.py runs 100,000).
EXAMPLES = 300


@pytest.mark.slow
def test_reconstruct_gives_a_valid_mesh_or_a_scanmesh_error_naming_the_bad_input() -> None:
    findings, outcomes = run_many(range(EXAMPLES), timeout=60.0, memory_bytes=3 * 2**30)
    report = "\n".join(
        f"{name}: {len(hits)}, e.g. {hits[0][1]}\n{reproducer(hits[0][0])}"
        for name, hits in findings.items()
    )
    assert not findings, report
    # Both outcomes are exercised, not only refusals.
    assert outcomes["surface"] > EXAMPLES // 5, outcomes
    assert sum(v for k, v in outcomes.items() if k.startswith("refused")) > EXAMPLES // 5


def test_cases_cover_every_method_option_and_value_type() -> None:
    cases = [make_case(seed) for seed in range(2000)]
    assert {c["method"] for c in cases} == set(METHODS)
    for name, spec in TABLE.items():
        drawn = [c["kwargs"] for c in cases if c["method"] == name]
        for option in spec.options:
            values = [kw[option.name] for kw in drawn if option.name in kw]
            judged = {valid_value(option, v) for v in values}
            assert judged >= ({True, False} if option.kind != "any" else {None}), option.name
        assert any("plane" in kw for kw in drawn) and any("lines" in kw for kw in drawn)
    junk_types = {type(v) for v in JUNK}
    seen_types = {type(v) for c in cases for v in c["kwargs"].values()}
    assert junk_types <= seen_types
    assert {c["kind"] for c in cases} >= {"huge", "tiny", "integer-grid", "nan", "duplicates"}
    assert any(c["bad"] and c["bad"][0] not in TABLE[c["method"]].shared for c in cases)


def test_the_value_oracle() -> None:
    chains = Option("chains", "int", 0, "", low=0, high=1024)
    assert valid_value(chains, 1024) and valid_value(chains, np.int64(3))
    for value in (2**64, 10**6, -1, True, 3.0, "3", None, 1j):
        assert valid_value(chains, value) is False, value
    ratio = Option("r", "float", 0.5, "", low=0.0, high=1.0, low_open=True)
    assert valid_value(ratio, 1.0) and valid_value(ratio, 5e-324)
    assert not any(valid_value(ratio, v) for v in (0.0, float("nan"), np.float32("nan"), 1e300))
    edge = Option("max_edge", "float", None, "", low=0.0, low_open=True, finite=False)
    assert valid_value(edge, float("inf")) and not valid_value(edge, -float("inf"))


def test_a_refusal_must_name_the_input_as_a_word() -> None:
    assert _names("p must be >= 1, got nan", "p")
    assert not _names("the points are collinear", "p")
    assert _names("lines[3] = 1e300: ...", "lines")
    assert _names("need at least 3 points", "points")
    assert not _names("unknown option(s) ['sweeps']", "sweep")


def test_surface_fault_finds_a_clockwise_face_and_a_lost_point() -> None:
    pts = np.array([[0.0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0], [0.5, 0.5, 0.1]])
    good = reconstruct(pts, "delaunay", plane="z", max_edge=float("inf"))
    assert surface_fault(good, "delaunay", 5) is None
    flipped = Surface(pts, good.faces[:, ::-1].copy(), scan=good.scan)
    assert "invalid mesh" in str(surface_fault(flipped, "delaunay", 5))
    lost = Surface(pts, good.faces[:2].copy(), scan=good.scan)
    fault = str(surface_fault(lost, "delaunay", 5))
    assert "no face and no list" in fault or "invalid mesh" in fault


def test_the_runner_reports_a_hang_and_a_crash() -> None:
    class Stub(Runner):
        def __init__(self, code: str) -> None:
            super().__init__(timeout=2.0, memory_bytes=2**31)
            self.code = code

        def _start(self) -> subprocess.Popen[str]:
            return subprocess.Popen(
                [sys.executable, "-c", self.code],
                stdin=subprocess.PIPE,
                stdout=subprocess.PIPE,
                text=True,
                bufsize=1,
            )

    hang = Stub("import sys, time; sys.stdin.readline(); time.sleep(60)")
    assert hang.run(0)["outcome"] == "timeout"
    hang.close()
    crash = Stub("import os, sys; sys.stdin.readline(); os.abort()")
    result = crash.run(0)
    assert result["outcome"] == "crash" and "child died" in result["finding"]


# Found by the fuzz (benches/api_fuzz.py), fixed at the root.


def _random_scan(seed: int, n: int) -> np.ndarray:
    rng = np.random.default_rng(seed)
    xy = rng.random((n, 2))
    return np.column_stack([xy, 0.1 * np.sin(6 * xy[:, 0]) * np.cos(4 * xy[:, 1])])


def test_optimal_takes_every_magnitude_from_1e_300_to_1e300() -> None:
    # Found as: 7 points near 1e-199 gave a Surface with no faces, "certified" (the empty
    # triangles' orientation products underflowed to zero).
    pts = _random_scan(29, 9)
    unit = reconstruct(pts, "optimal", plane="z", time_limit=30.0)
    assert len(unit.faces) > 0 and unit.certified
    for scale in (1e-300, 1e-199, 1e300):
        scaled = reconstruct(pts * scale, "optimal", plane="z", time_limit=30.0)
        assert scaled.certified
        np.testing.assert_array_equal(np.sort(scaled.faces, axis=1), np.sort(unit.faces, axis=1))


def test_noise_and_annealing_at_1e300() -> None:
    # Found as: annealing on points near 1e300 ended in IndexError in the noise estimate
    # (the neighbour search's squared distances overflowed, so neighbours went missing).
    from scanmesh.scan.noise import noise

    pts = _random_scan(67, 40)
    sigma = noise(pts, plane="z")
    assert math.isfinite(sigma)
    for power in (-990, 990):
        assert noise(np.ldexp(pts, power), plane="z") == math.ldexp(sigma, power)
    surface = reconstruct(pts * 1e300, "anneal", plane="z", sweeps=5, max_edge=math.inf)
    assert surface_fault(surface, "anneal", len(pts)) is None


def test_optimal_strengthen_skips_a_start_with_a_face_the_enumeration_does_not_list() -> None:
    # Found as KeyError: an exact integer grid (best-fit plane), whose Delaunay start has a
    # face degenerate in the planar coordinates the empty triangles are enumerated in.
    grid = [
        [4, 6, -2], [3, 3, -1], [4, 3, -2], [1, 1, 1], [3, 2, -1], [0, 2, 0], [6, 6, -3],
        [4, 1, -1], [6, 0, -3], [3, 1, -1], [1, 2, 2], [3, 4, -1], [5, 1, 0], [1, 5, 2],
        [0, 6, 0], [5, 0, -2], [2, 4, 1], [6, 4, -3], [4, 0, -2], [2, 5, 0], [2, 0, -1],
        [0, 4, 0], [1, 4, 1], [5, 5, -1], [5, 4, 0], [3, 5, -1], [6, 1, -3], [2, 3, -1],
        [6, 2, -3], [0, 0, 0], [3, 0, -1], [5, 3, -2], [1, 6, 0], [0, 3, 0], [4, 4, -1],
        [5, 6, -2], [1, 0, 0], [1, 3, 0], [6, 3, -3], [2, 2, 0], [2, 6, -1], [0, 1, 0],
        [5, 2, -1], [4, 2, 0],
    ]  # fmt: skip
    surface = reconstruct(np.array(grid, dtype=float), "optimal", strengthen=True, time_limit=0.2)
    assert len(surface.faces) > 0


def test_optimal_strengthen_skips_a_start_that_is_no_triangulation_in_its_plane() -> None:
    # Found as RuntimeError "fan master LP failed (infeasible)": a start made of enumerated
    # triangles with a gap or an overlap in the planar coordinates.
    grid = [
        [6, 7, -3], [8, 5, -3], [0, 4, 0], [6, 6, -3], [5, 1, 0], [1, 2, 2], [7, 0, -3],
        [0, 1, 0], [8, 0, -4], [0, 7, 0], [6, 0, -3], [7, 8, -1], [3, 1, -1], [5, 2, -1],
        [5, 8, -1], [0, 3, 0], [0, 8, 0], [4, 2, 0], [1, 6, 0], [5, 4, 0], [0, 0, 0],
        [3, 7, -1], [1, 0, 0], [3, 0, -1], [0, 6, 0], [4, 0, -2], [1, 1, 1], [6, 4, -3],
        [2, 2, 0], [7, 6, -3], [2, 6, -1], [2, 4, 1], [4, 6, -2], [1, 3, 0], [2, 0, -1],
        [4, 3, -2], [4, 4, -1], [8, 4, -2], [5, 6, -2], [5, 5, -1], [2, 1, 1], [7, 7, -2],
    ]  # fmt: skip
    pts = np.array(grid, dtype=float)
    surface = reconstruct(pts, "optimal", p=math.inf, strengthen=True, time_limit=0.001)
    assert len(surface.faces) > 0
