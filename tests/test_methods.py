"""The table of methods: every option checked once, no keyword dropped, the command's flags."""

from __future__ import annotations

import math
import subprocess
import sys

import numpy as np
import pytest

import scanmesh
from conftest import bumpy_patch
from scanmesh import ParameterError, ScanmeshError
from scanmesh.cli import main
from scanmesh.methods import METHODS, SHARED, TABLE

#: Values no option of any method accepts where a number or a flag belongs.
NOT_A_NUMBER = ["abc", None, 1j, {"a": 1}, b"1", [1], math.nan]
HUGE = [2**64, 10**30, -(2**64)]


def _points() -> tuple[np.ndarray, np.ndarray]:
    x, y = np.meshgrid(np.arange(6.0), np.arange(5.0))
    z = 0.1 * np.sin(x) * np.cos(y)
    return np.column_stack([x.ravel(), y.ravel(), z.ravel()]), np.repeat(np.arange(5), 6)


def _cases():
    for spec in TABLE.values():
        for option in spec.options:
            if option.kind == "any" and option.name != "initial":
                continue
            # None is a value of its own for an automatic option (worked out from the data)
            bad = [v for v in NOT_A_NUMBER if not (v is None and option.automatic)]
            if option.kind == "int":
                # huge positive counts are bad where the option has a ceiling
                bad += [v for v in HUGE if v < 0 or option.high is not None]
                bad += [-1, 2.5, True]
            elif option.kind == "float":
                bad += [10**400, True, "1.0"]
            elif option.kind == "bool":
                bad += ["yes", 1, 0]
            for value in bad:
                case = f"{spec.name}-{option.name}-{value!r}"
                yield pytest.param(spec.name, option.name, value, id=case)


@pytest.mark.parametrize("method, name, value", list(_cases()))
def test_every_bad_option_value_is_a_parameter_error_naming_it(method, name, value):
    pts, _ = _points()
    with pytest.raises(ParameterError, match=name) as info:
        scanmesh.reconstruct(pts, method, plane="z", **{name: value})
    shown = repr(value)
    assert shown[:20] in str(info.value) or name == "initial"


@pytest.mark.parametrize("method", METHODS)
def test_unknown_keywords_are_parameter_errors(method):
    pts, _ = _points()
    with pytest.raises(ParameterError, match=r"unknown option\(s\) \['lookahed'\]"):
        scanmesh.reconstruct(pts, method, lookahed=3)


@pytest.mark.parametrize(
    "method, keyword, value",
    [
        ("delaunay", "lines", "ids"),
        ("delaunay", "seed", 1),
        ("shortest-path", "max_edge", 2.0),
        ("shortest-path", "seed", 1),
        ("lookahead", "seed", 1),
        ("lop", "seed", 1),
        ("lop", "lines", "ids"),
        ("optimal", "max_edge", 2.0),
        ("optimal", "seed", 1),
        ("optimal", "lines", "ids"),
    ],
)
def test_keywords_a_method_does_not_use_are_refused(method, keyword, value):
    pts, ids = _points()
    with pytest.raises(ParameterError, match=f"does not use {keyword}="):
        scanmesh.reconstruct(pts, method, plane="z", **{keyword: ids if value == "ids" else value})


def test_annealing_estimates_its_noise_along_the_given_lines():
    pts, ids = _points()
    surface = scanmesh.reconstruct(
        pts, "anneal", plane="z", lines=ids, sweeps=5, tie_tolerance=None
    )
    assert surface.options["noise"] == pytest.approx(scanmesh.noise(pts, lines=ids, plane="z"))
    # with a tolerance given (the default, exact ties) no estimate is needed or made
    exact = scanmesh.reconstruct(pts, "anneal", plane="z", lines=ids, sweeps=5)
    assert exact.options["noise"] is None


def test_annealing_tie_tolerance_is_automatic_when_asked():
    pts, ids = _points()
    auto = scanmesh.reconstruct(pts, "anneal", plane="z", lines=ids, sweeps=5, tie_tolerance=None)
    given = scanmesh.reconstruct(pts, "anneal", plane="z", sweeps=5, tie_tolerance=0.25)
    assert given.options["tie_tolerance"] == 0.25
    assert auto.options["tie_tolerance"] != 0.25
    # the automatic choice comes from the noise estimate (see test_noise) and is reported
    assert auto.options["tie_tolerance"] >= scanmesh.stages.anneal.ANNEAL_DEFAULTS["tie_tolerance"]


def test_keywords_follow_the_initial_triangulation():
    pts, ids = _points()
    s = scanmesh.reconstruct(pts, "lop", plane="z", initial="shortest-path", lines=ids)
    assert s.options["initial"] == "shortest-path"
    with pytest.raises(ParameterError, match="initial='delaunay' does"):
        scanmesh.reconstruct(pts, "anneal", plane="z", initial="shortest-path", max_edge=3.0)
    scanmesh.reconstruct(pts, "anneal", plane="z", max_edge=3.0, seed=2, sweeps=3)


def test_shared_keywords_are_checked_too():
    pts, _ = _points()
    for bad in (2**64, -1, "0", 1.5):
        with pytest.raises(ParameterError, match="seed"):
            scanmesh.reconstruct(pts, "anneal", plane="z", seed=bad, sweeps=2)
    for bad in ("abc", 0, -1.0, 1j):
        with pytest.raises(ParameterError, match="max_edge"):
            scanmesh.reconstruct(pts, "delaunay", plane="z", max_edge=bad)


def test_good_values_pass_through_unchanged():
    """The checks return what the method runs with: the values given, as their types."""
    spec = TABLE["anneal"]
    params = spec.check({"sweeps": np.int64(7), "p": 2, "polish": np.bool_(False)}, {})
    assert params["sweeps"] == 7 and type(params["sweeps"]) is int
    assert params["p"] == 2.0 and type(params["p"]) is float
    assert params["polish"] is False
    assert params["tiles"] == 1  # the default filled in
    assert SHARED["max_edge"].check(math.inf) == math.inf


def test_strip_options_of_the_other_method_are_refused():
    pts, ids = _points()
    with pytest.raises(ParameterError, match=r"\['alpha'\]"):
        scanmesh.stages.strips.strip_surface(pts, lines=ids, plane="z", alpha=4)
    with pytest.raises(ParameterError, match=r"\['solver'\]"):
        scanmesh.stages.strips.strip_surface(
            pts, lines=ids, plane="z", method="lookahead", solver="dp"
        )
    with pytest.raises(ParameterError, match=r"weight\['angle'\]"):
        scanmesh.stages.strips.strip_surface(pts, lines=ids, plane="z", weight={"angle": "x"})


def test_line_detection_checks_its_gap_factor():
    pts = bumpy_patch(30, 1)
    for bad in ("abc", 0.0, math.inf, None, 10**400):
        with pytest.raises(ParameterError, match="gap_factor"):
            scanmesh.detect_lines(pts, gap_factor=bad)


# --------------------------------------------------------------------------- the command


def test_every_method_option_with_a_text_form_has_a_flag():
    help_text = subprocess.run(
        [sys.executable, "-m", "scanmesh", "reconstruct", "--help"],
        capture_output=True,
        text=True,
        check=True,
    ).stdout
    for spec in TABLE.values():
        for option in spec.options:
            if option.kind != "any" or option.name == "initial":
                assert option.flag in help_text, option.flag


@pytest.fixture
def scan_file(tmp_path):
    pts, ids = _points()
    path = tmp_path / "scan.xyz"
    np.savetxt(path, np.column_stack([pts, ids]))
    return path


@pytest.mark.parametrize(
    "flags, message",
    [
        (["--sweeps", str(10**23)], "--sweeps must be a whole number from 0 to"),
        (["--sweeps", "-1"], "--sweeps must be"),
        (["--tiles", "65"], "--tiles must be"),
        (["--p", "0.5"], "--p must be"),
        (["--initial-acceptance", "1"], "--initial-acceptance must be"),
        (["--seed", str(2**64)], "--seed must be"),
    ],
)
def test_bad_flag_values_are_one_line_naming_the_flag(scan_file, tmp_path, flags, message, capsys):
    out = tmp_path / "out.stl"
    code = main(["reconstruct", str(scan_file), "-o", str(out), "--plane", "z", *flags])
    err = capsys.readouterr().err
    assert code == 1
    assert err.count("\n") == 1 and message in err and "Traceback" not in err
    assert not out.exists()


def test_flags_for_another_method_are_usage_errors(scan_file, tmp_path, capsys):
    out = tmp_path / "out.stl"
    for flags, text in (
        (
            ["--method", "delaunay", "--sweeps", "5"],
            "--sweeps applies to --method anneal, strips-anneal only",
        ),
        (
            ["--method", "delaunay", "--seed", "5"],
            "--seed applies to --method anneal, strips-anneal, auto only",
        ),
        (["--method", "shortest-path", "--max-edge", "2"], "--max-edge applies"),
        (["--method", "lookahead", "--solver", "dp"], "--solver applies"),
    ):
        with pytest.raises(SystemExit) as info:
            main(["reconstruct", str(scan_file), "-o", str(out), *flags])
        assert info.value.code == 2
        assert text in capsys.readouterr().err


def test_method_flags_reach_the_method(scan_file, tmp_path, capsys):
    import json

    out, report = tmp_path / "out.stl", tmp_path / "r.json"
    args = ["reconstruct", str(scan_file), "-o", str(out), "--plane", "z", "--report", str(report)]
    assert main([*args, "--method", "lop", "--criterion", "max-min", "--no-sliver-guard"]) == 0
    options = json.loads(report.read_text())["options"]
    assert options["criterion"] == "max-min" and options["sliver_guard"] is False
    assert main([*args, "--method", "shortest-path", "--solver", "dijkstra", "--band", "7"]) == 0
    options = json.loads(report.read_text())["options"]
    assert options["solver"] == "dijkstra" and options["band"] == 7


def test_compare_builds_one_scan_and_one_delaunay(scan_file, monkeypatch, capsys):
    from scanmesh import _core

    calls = {"project": 0, "delaunay_trimmed": 0}
    for name in calls:
        real = getattr(_core, name)

        def count(*args, _real=real, _name=name, **kwargs):
            calls[_name] += 1
            return _real(*args, **kwargs)

        monkeypatch.setattr(_core, name, count)
    # without the holdout (which rebuilds every method from 90 % of the points)
    args = ["compare", str(scan_file), "--plane", "z", "--sweeps", "3", "--holdout", "0"]
    code = main([*args, "--json", "-q"])
    assert code == 0, capsys.readouterr().err
    assert calls == {"project": 1, "delaunay_trimmed": 1}


def test_errors_are_scanmesh_errors_not_type_errors():
    pts, _ = _points()
    for method in METHODS:
        with pytest.raises(ScanmeshError):
            scanmesh.reconstruct(pts, method, plane=b"z")
        with pytest.raises(ScanmeshError):
            scanmesh.reconstruct(pts, method, plane={"a": 1})


def test_the_command_speaks_flags_and_reports_what_it_used(scan_file, tmp_path, capsys):
    import json

    out, report = tmp_path / "out.stl", tmp_path / "r.json"
    # a negative vector right after its flag; a steep view, so a warning comes
    args = ["reconstruct", str(scan_file), "-o", str(out), "--report", str(report)]
    flags = ["--method", "delaunay", "--plane", "-1,0,0.2", "--max-edge", "inf", "-q"]
    assert main([*args, *flags]) == 0
    captured = capsys.readouterr()
    assert captured.out == "" and captured.err == ""  # -q: no summary, no warnings on stderr
    data = json.loads(report.read_text())
    assert data["scanmesh"] == scanmesh.__version__
    normal = np.asarray(data["plane"]["normal"])
    np.testing.assert_allclose(np.abs(normal), np.abs([-1, 0, 0.2]) / math.hypot(1, 0.2))
    assert data["plane"]["asked"] == [-1.0, 0.0, 0.2]
    assert any("--plane" in w for w in data["warnings"])  # the report keeps them, in flags
    assert not any("plane=" in w for w in data["warnings"])
    assert {"read", "project", "triangulate"} <= set(data["timings"])


def test_demo_refuses_an_output_folder_whose_parent_is_missing(tmp_path, capsys):
    target = tmp_path / "missing" / "out"
    assert main(["demo", "-o", str(target)]) == 1
    assert "does not exist" in capsys.readouterr().err
    assert not (tmp_path / "missing").exists()
