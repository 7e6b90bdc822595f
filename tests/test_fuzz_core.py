"""The native flip optimizers under fuzzing (cases in fuzz_core.py), and the annealing runs
that used to hang or abort: they end, or are refused with a ParameterError naming the
option and what it would cost. The long run is benches/fuzz_core.py."""

from __future__ import annotations

import subprocess
import sys
import textwrap

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from fuzz_core import make_case, mesh_fault, run_case
from scanmesh import ParameterError, _core


@pytest.mark.slow
@settings(
    max_examples=150,
    deadline=None,
    derandomize=True,
    suppress_health_check=[HealthCheck.too_slow],
)
@given(st.integers(0, 2**32 - 1))
def test_delaunay_then_lop_or_annealing_gives_a_valid_mesh_or_a_scanmesh_error(seed: int) -> None:
    assert run_case(seed) is None, f"case {seed}: {run_case(seed)}"


def test_cases_cover_every_kind_and_method() -> None:
    cases = [make_case(seed) for seed in range(200)]
    assert {c["kind"] for c in cases} == {
        "random",
        "integer-grid",
        "collinear",
        "duplicates",
        "clusters",
    }
    assert {c["options"]["method"] for c in cases} == {"lop-tac", "lop-max-min", "anneal"}
    assert {c["options"].get("tiles") for c in cases} >= {1, 3, 64}


def test_the_independent_check_catches_what_validate_catches() -> None:
    # Two triangles of a square, then one turned clockwise, then a fold (a vertex whose
    # fan winds twice, every triangle counter-clockwise).
    uv = np.array([[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 1.0]])
    good = np.array([[0, 1, 2], [0, 2, 3]])
    assert mesh_fault(uv, good) is None
    assert "counter-clockwise" in mesh_fault(uv, good[:, ::-1].copy())
    angles = np.linspace(0, 4 * np.pi, 10, endpoint=False)
    ring = np.column_stack([np.cos(angles), np.sin(angles)]) * (1 + 0.01 * np.arange(10))[:, None]
    uv = np.vstack([[0.0, 0.0], ring])
    fold = np.array([[0, 1 + k, 1 + (k + 1) % 10] for k in range(10)])
    fault = mesh_fault(uv, fold)
    assert fault is not None
    with pytest.raises(_core.InvalidMeshError):
        _core.validate(uv, fold)


def _annealer(points: np.ndarray, **options: int) -> _core.Annealer:
    uv, _ = _core.project(points, "z")
    faces, _ = _core.delaunay(uv)
    return _core.Annealer(points, uv, faces, _core.AnnealParams(**{"seed": 1, **options}))


def _bumpy(n: int) -> np.ndarray:
    rng = np.random.default_rng(n)
    xy = rng.random((n, 2))
    return np.column_stack([xy, np.sin(5 * xy[:, 0]) * np.cos(3 * xy[:, 1])])


@pytest.mark.parametrize(
    ("option", "value", "needs"),
    [
        ("chains", 10**6, "calibration proposals"),
        ("calibration_samples", 10**9, "calibration proposals"),
        ("sweeps", 2**62, "flip proposals"),
    ],
)
def test_runs_too_costly_are_refused_naming_the_option(option: str, value: int, needs: str) -> None:
    with pytest.raises(ParameterError, match=rf"^{option}={value} needs .*{needs}"):
        _annealer(_bumpy(50), **{option: value})


@pytest.mark.slow
def test_stripes_too_narrow_for_an_edge_still_end() -> None:
    # Used to loop forever (each phase started again with no tile able to flip). In a child
    # process, so that a regression fails instead of hanging the suite.
    code = textwrap.dedent(
        """
        import numpy as np
        from test_fuzz_core import _annealer, _bumpy
        for n, tiles in [(8, 3), (300, 64)]:
            run = _annealer(_bumpy(n), tiles=tiles, sweeps=300, chains=1, patience=0)
            while not run.done:
                run.advance(10_000, 1.0)
            trace = run.finish().trace
            assert len(trace) == 300, len(trace)
        print("ended")
        """
    )
    out = subprocess.run(
        [sys.executable, "-c", code],
        capture_output=True,
        text=True,
        timeout=300,
        cwd=__file__.rsplit("/", 1)[0],
    )
    assert out.stdout.strip() == "ended", out.stderr
