"""The seam between Python and the Rust core: each annealing option is declared once (the
core's ``AnnealParams``, its ``Default``), and everything else that names it must agree."""

import math

import numpy as np
import pytest

from scanmesh import _core
from scanmesh.errors import ParameterError
from scanmesh.stages import anneal, options

#: Annealing options of the Python table that the core does not take: ``time_limit`` bounds
#: the Python loop that drives the core in chunks.
PYTHON_ONLY = {"time_limit"}

#: Core parameters that are no option of the annealing table: ``seed`` is the keyword
#: shared by every random method (``SEED_OPTION``, None meaning 0), passed apart.
CORE_ONLY = {"seed"}

#: Options whose table default is not the core's, on purpose: ``sweeps`` defaults to None,
#: a schedule sized to the scan by the core (``AnnealParams.auto_sweeps``, capped at the
#: core's default).
AUTOMATIC = {"sweeps"}


def core_defaults() -> dict:
    return _core.AnnealParams().as_dict()


def test_the_annealing_table_names_the_core_params():
    table = {o.name for o in anneal.OPTIONS}
    assert table - PYTHON_ONLY == set(core_defaults()) - CORE_ONLY
    assert anneal.PYTHON_HANDLED == CORE_ONLY
    assert not PYTHON_ONLY & set(core_defaults())


def test_every_annealing_default_is_the_core_s():
    core = core_defaults()
    for o in anneal.OPTIONS:
        if o.name in PYTHON_ONLY:
            continue
        if o.name in AUTOMATIC:
            assert o.default is None and o.automatic, o.name
            continue
        assert o.default == core[o.name] and type(o.default) is type(core[o.name]), o.name
    assert anneal.ANNEAL_DEFAULTS == {k: v for k, v in core.items() if k not in CORE_ONLY}
    # the shared records LOP uses too, and the floor of the automatic tolerance
    for shared in (options.P_OPTION, options.SLIVER_GUARD_OPTION, options.TIE_TOLERANCE_OPTION):
        assert shared.default == core[shared.name], shared.name
    # seed: the shared keyword's None means the core's default
    assert options.SEED_OPTION.default is None and core["seed"] == 0


def test_lop_defaults_are_annealing_s():
    import inspect

    core = core_defaults()
    text = _core.lop.__text_signature__
    assert text is not None and "p=" in text
    # the binding takes them from AnnealParams::default(); check the values it uses
    rng = np.random.default_rng(1)
    xy = rng.random((30, 2))
    pts = np.column_stack([xy, np.sin(3 * xy[:, 0])])
    uv, _ = _core.project(pts, "z")
    faces, _ = _core.delaunay(uv)
    implicit = _core.lop(pts, uv, faces, "tac")
    explicit = _core.lop(
        pts,
        uv,
        faces,
        "tac",
        p=core["p"],
        sliver_guard=core["sliver_guard"],
        tie_tolerance=core["tie_tolerance"],
    )
    np.testing.assert_array_equal(implicit[0], explicit[0])
    assert implicit[1] == explicit[1]
    assert inspect.signature(_core.lop).parameters["p"].default is not inspect.Parameter.empty


def test_anneal_params_replace_the_named_fields_and_refuse_others():
    p = _core.AnnealParams(sweeps=7, planar_ties=True, seed=3)
    d = p.as_dict()
    assert (d["sweeps"], d["planar_ties"], d["seed"]) == (7, True, 3)
    assert {k: v for k, v in d.items() if k not in ("sweeps", "planar_ties", "seed")} == {
        k: v for k, v in core_defaults().items() if k not in ("sweeps", "planar_ties", "seed")
    }
    with pytest.raises(TypeError, match="unexpected keyword argument 'sweep'"):
        _core.AnnealParams(sweep=7)
    with pytest.raises(TypeError, match="'polish'"):
        _core.AnnealParams(polish="yes")
    # the range checks are the core's (AnnealParams::check), naming the field
    with pytest.raises(ParameterError, match="initial_acceptance"):
        _core.AnnealParams(initial_acceptance=1.5)
    with pytest.raises(ParameterError, match="tiles"):
        _core.AnnealParams(tiles=0)
    assert repr(p).startswith("AnnealParams(sweeps=7, p=1.0, seed=3")


def _bumpy(n: int = 60):
    rng = np.random.default_rng(n)
    xy = rng.random((n, 2))
    pts = np.column_stack([xy, np.sin(5 * xy[:, 0]) * np.cos(3 * xy[:, 1])])
    uv, _ = _core.project(pts, "z")
    faces, _ = _core.delaunay(uv)
    return pts, uv, faces


def test_annealing_ends_in_a_typed_outcome():
    pts, uv, faces = _bumpy()
    run = _core.Annealer(pts, uv, faces, _core.AnnealParams(sweeps=20, chains=2, seed=5))
    while not run.done:
        run.advance(10_000, 1.0)
    out = run.finish()
    assert isinstance(out, _core.AnnealOutcome)
    assert out.faces.shape == faces.shape and out.faces.dtype == np.int64
    assert out.trace.shape[1] == 4 and len(out.trace) <= 2 * 20
    assert out.chains == 2 == len(out.chain_energies)
    assert out.energy == min(out.chain_energies) or math.isclose(
        out.energy, min(out.chain_energies)
    )
    assert out.stopped in anneal.STOP_REASONS and out.proposals > 0
    with pytest.raises(AttributeError):
        out.energy = 0.0  # type: ignore[misc]
    with pytest.raises(_core.ScanmeshError, match="finished"):
        run.finish()


def _wavy_scan(lines: int = 12, per_line: int = 40):
    x, y = np.meshgrid(np.linspace(0, 1, per_line), np.arange(lines) * 0.03)
    points = np.column_stack([x.ravel(), y.ravel(), 0.1 * np.sin(4 * x.ravel())])
    ids = np.repeat(np.arange(lines, dtype=np.int64), per_line)
    return points, np.ascontiguousarray(points[:, :2]), ids


ANGLE_DIHEDRAL = {"angle": 1.0, "dihedral": 0.3}


def test_strip_mesh_returns_a_typed_result():
    points, uv, ids = _wavy_scan()
    params = _core.StripParams("shortest-path", weight=ANGLE_DIHEDRAL, band=16)
    r = _core.strip_mesh(points, uv, ids, params, 4.0)
    assert isinstance(r, _core.StripResult)
    assert r.faces.ndim == 2 and r.faces.shape[1] == 3 and r.n_strips > 0
    assert r.planar_error is None or isinstance(r.planar_error, str)
    for name in ("unused", "duplicates", "trimmed"):
        assert getattr(r, name).dtype == np.int64
    assert isinstance(r.cost, float) and isinstance(r.signed_area, float)
    assert isinstance(r.dropped_jumps, int) and isinstance(r.dropped_overlaps, int)


def test_strip_params_take_the_weight_by_name_and_refuse_what_the_method_ignores():
    points, uv, ids = _wavy_scan()
    by_name = _core.StripParams("lookahead", weight={"length": 1.0}, alpha=2)
    zeros = _core.StripParams(
        "lookahead", weight={"length": 1.0, "area": 0.0, "angle": 0.0, "dihedral": 0.0}, alpha=2
    )
    faces = [_core.strip_mesh(points, uv, ids, p, 4.0).faces for p in (by_name, zeros)]
    np.testing.assert_array_equal(faces[0], faces[1])
    assert "Lookahead(2)" in repr(by_name) and "length: 1.0" in repr(by_name)
    refused = [
        ({"method": "lookahead", "alpha": 2, "band": 3}, "band is not an option"),
        ({"method": "lookahead", "alpha": 2, "solver": "dp"}, "solver is not an option"),
        ({"method": "lookahead"}, "needs its depth alpha"),
        ({"method": "shortest-path", "alpha": 2}, "alpha is not an option"),
        ({"method": "shortest-path", "solver": "dp", "band": 3}, "band is not an option"),
        ({"method": "shortest-path", "solver": "astar"}, "solver must be"),
        ({"method": "greedy"}, "method must be"),
    ]
    for kwargs, message in refused:
        method = kwargs.pop("method")
        with pytest.raises(_core.ParameterError, match=message):
            _core.StripParams(method, weight={"angle": 1.0}, **kwargs)
    with pytest.raises(_core.ParameterError, match='unknown weight criterion "curvature"'):
        _core.StripParams("shortest-path", weight={"curvature": 1.0})
    for weight in ({"angle": -1.0}, {"angle": math.nan}, {"angle": 0.0}, {}):
        with pytest.raises(_core.ParameterError, match="weight"):
            _core.StripParams("shortest-path", weight=weight)
    with pytest.raises(TypeError):
        _core.StripParams("shortest-path", {"angle": 1.0})  # type: ignore[misc]


def test_a_scan_solved_in_its_own_context_is_solved_as_without_one():
    """The context's fields reach the core in their places: a scan given its own bounding
    box, planar scale, median step and orientation gives the same mesh as no context, and
    rows restrict the strips returned to those between lines within them."""
    points, uv, ids = _wavy_scan()
    params = _core.StripParams("shortest-path", weight=ANGLE_DIHEDRAL)
    alone = _core.strip_mesh(points, uv, ids, params, 4.0)
    own = dict(
        lo=tuple(points.min(axis=0)),
        hi=tuple(points.max(axis=0)),
        largest_planar=float(np.abs(uv).max()),
        median_step=_core.scan_segments(uv, ids, 4.0).median_step,
        first_turned=False,
    )
    whole = _core.strip_mesh(points, uv, ids, params, 4.0, _core.ScanContext(**own))
    np.testing.assert_array_equal(whole.faces, alone.faces)
    assert whole.cost == alone.cost and whole.signed_area == alone.signed_area
    rows = _core.ScanContext(**own, own_rows=(0, 4 * 40))
    part = _core.strip_mesh(points, uv, ids, params, 4.0, rows)
    assert part.n_strips == 3 and len(part.faces) < len(alone.faces)
    assert "own_rows: Some((0, 160))" in repr(rows)
    with pytest.raises(TypeError):
        _core.ScanContext(own["lo"], own["hi"], 1.0, 0.1, False)  # type: ignore[misc]


def test_scan_segments_are_read_by_name():
    x, y = np.meshgrid(np.linspace(0, 1, 10), np.arange(3) * 0.03)
    uv = np.insert(np.column_stack([x.ravel(), y.ravel()]), 1, [0.0, 0.0], axis=0)
    ids = np.insert(np.repeat(np.arange(3, dtype=np.int64), 10), 1, 0)  # point 1 repeats 0
    s = _core.scan_segments(uv, ids, 4.0)
    assert isinstance(s, _core.ScanSegments)
    assert [len(line) for line in s.lines] == [1, 1, 1]
    np.testing.assert_array_equal(s.lines[0][0], [0, *range(2, 11)])
    np.testing.assert_array_equal(s.lines[1][0], np.arange(11, 21))
    np.testing.assert_array_equal(s.duplicates, [[1, 0]])
    assert s.median_step == pytest.approx(1 / 9) and s.gap == pytest.approx(4 / 9)


def test_max_tiles_is_the_core_s_limit():
    from scanmesh.stages import anneal

    assert anneal.MAX_TILES == _core.MAX_TILES
    _core.AnnealParams(tiles=_core.MAX_TILES)
    with pytest.raises(_core.ParameterError, match="tiles"):
        _core.AnnealParams(tiles=_core.MAX_TILES + 1)


def test_lop_options_are_keywords():
    rng = np.random.default_rng(2)
    xy = rng.random((20, 2))
    pts = np.column_stack([xy, np.sin(3 * xy[:, 0])])
    uv, _ = _core.project(pts, "z")
    faces, _ = _core.delaunay(uv)
    with pytest.raises(TypeError):
        _core.lop(pts, uv, faces, "tac", 1.0)  # type: ignore[misc]


def test_result_classes_cannot_be_built_from_python():
    for cls in (
        _core.StripResult,
        _core.ScanSegments,
        _core.AnnealOutcome,
        _core.TrimmedDelaunay,
        _core.CheapestFans,
        _core.TextTable,
        _core.TextProblem,
    ):
        with pytest.raises(TypeError):
            cls()


def test_the_stub_declares_what_the_module_has():
    """The stub's ``__all__`` is the module's public names (stubtest checks signatures)."""
    import ast
    import pathlib

    stub = pathlib.Path(_core.__file__).with_name("_core.pyi")
    if not stub.exists():  # an installed wheel without the source tree
        import scanmesh

        stub = pathlib.Path(scanmesh.__file__).with_name("_core.pyi")
    tree = ast.parse(stub.read_text())
    declared = next(
        ast.literal_eval(node.value)
        for node in tree.body
        if isinstance(node, ast.Assign) and getattr(node.targets[0], "id", "") == "__all__"
    )
    public = {n for n in dir(_core) if not n.startswith("_")}
    assert set(declared) == public
