"""merge's inputs held to reconstruct's standard: every option checked by one table before
anything is read or allocated, views and poses refused by name, no magnitude overflowing,
no output written over an input, and the command one line with exit 1 for each."""

from __future__ import annotations

import json
import math
import shutil

import numpy as np
import pytest

import scanmesh
from scanmesh.cli import build_parser, main
from scanmesh.fusion.grid import OPTIONS, smallest_grid

FLIP = np.diag([1.0, -1.0, -1.0, 1.0])  # the second scanner faces the first


def cap(n: int = 20) -> np.ndarray:
    """A sphere cap seen from +z, (n * n, 3), about 2 across."""
    g = np.stack(np.meshgrid(np.linspace(-1, 1, n), np.linspace(-1, 1, n)), -1).reshape(-1, 2)
    return np.c_[g, np.sqrt(2.0 - (g**2).sum(1))]


def two_views(scale: float = 1.0, shift: float = 0.0) -> list[tuple[np.ndarray, np.ndarray]]:
    back = FLIP.copy()
    back[0, 3] = shift
    return [(cap() * scale, np.eye(4)), (cap() * scale, back)]


# options: one table, checked before any work


@pytest.mark.parametrize(
    ("options", "words"),
    [
        # an OverflowError ("can't convert negative int to unsigned") before the table
        ({"voxel": 1e-300}, ["voxel=1e-300", "max_voxels=64,000,000"]),
        ({"voxel": 5e-324}, ["voxel=5e-324", "max_voxels="]),
        ({"truncation": 1e300}, ["truncation=1e+300", "max_voxels="]),
        # "invalid dims=[2007195853, ...]"
        ({"voxel": 1e-9}, ["voxel=1e-09", "max_voxels=64,000,000", "2000000012 x"]),
        ({"voxel": 1e-7}, ["voxel=1e-07", "max_voxels="]),
        # ZeroDivisionError, numpy's TypeError
        ({"max_voxels": 0}, ["max_voxels must be a whole number >= 1, got 0"]),
        ({"max_voxels": -5}, ["max_voxels must be a whole number >= 1, got -5"]),
        # a grid over the limit was built
        ({"max_voxels": 1}, ["max_voxels=1 is too small", "13 nodes along each axis"]),
        ({"max_voxels": np.int64(8)}, ["max_voxels=8 is too small"]),
        ({"voxel": 0.01, "max_voxels": 1000}, ["voxel=0.01", "over max_voxels=1,000"]),
        # 0 faces, no word
        ({"voxel": 1e6}, ["voxel=1000000.0 is coarser than any view (2 across)"]),
        ({"voxel": "1"}, ["voxel must be a finite number"]),
        ({"max_voxels": 1.5}, ["max_voxels must be a whole number"]),
        ({"truncation": math.nan}, ["truncation must be a finite number"]),
        ({"truncation": 0.5}, ["truncation must be a number >= 1"]),
        ({"refine": 1}, ["refine must be True or False"]),
    ],
)
def test_each_option_is_refused_by_name(options, words):
    with pytest.raises(scanmesh.ParameterError) as info:
        scanmesh.merge(two_views(), **options)
    for word in words:
        assert word in str(info.value), str(info.value)


def test_options_are_checked_before_the_views_are_read(tmp_path):
    """max_voxels is honoured before any allocation: nothing is read for a bad option."""
    with pytest.raises(scanmesh.ParameterError, match="max_voxels"):
        scanmesh.merge([str(tmp_path / "missing.xyz")], max_voxels=0)


def test_the_default_voxel_keeps_the_grid_under_max_voxels():
    """One coarsening step was taken and the grid built whatever its size (13 x 13 x 13
    for max_voxels=1). A long thin part needs several steps."""
    rng = np.random.default_rng(0)
    rod = np.c_[rng.random((3000, 1)) * 60, rng.random((3000, 1)), 0.1 * rng.random((3000, 1))]
    for limit in (60_000, 200_000):
        surface = scanmesh.merge([(rod, np.eye(4)), (rod, FLIP)], max_voxels=limit)
        assert math.prod(surface.options["grid"]) <= limit and len(surface.faces)
    assert smallest_grid(3.0) ** 3 == 13**3


def test_views_far_apart_are_refused_naming_max_voxels():
    """Two views 1e6 apart: the default voxel grew past the views' own size (the grid was
    refused only by the depth images' memory check)."""
    with pytest.raises(scanmesh.ParameterError) as info:
        scanmesh.merge(two_views(shift=1e6))
    text = str(info.value)
    assert "max_voxels=64,000,000" in text and "coarser than any view" in text, text


def test_a_view_of_one_point_is_named():
    views = two_views()
    views[1] = (cap()[:1], FLIP)
    with pytest.raises(scanmesh.DegenerateInputError, match="view 1: a view of 1 point"):
        scanmesh.merge(views)


@pytest.mark.parametrize("scale", [2.0**600, 2.0**-600])
def test_huge_and_tiny_magnitudes_give_the_unit_mesh_scaled(scale):
    """Points times 1e200 overflowed the grid size (OverflowError). The fusion works on the
    views scaled by a power of two: the same faces, the vertices scaled back exactly."""
    unit = scanmesh.merge(two_views())
    scaled = scanmesh.merge(two_views(scale))
    np.testing.assert_array_equal(scaled.faces, unit.faces)
    np.testing.assert_array_equal(scaled.vertices, unit.vertices * scale)
    assert scaled.options["voxel"] == unit.options["voxel"] * scale
    np.testing.assert_array_equal(scaled.options["poses"][1], unit.options["poses"][1])


def test_points_at_1e200_merge():
    surface = scanmesh.merge(two_views(1e200))
    assert len(surface.faces) > 0 and np.isfinite(surface.vertices).all()
    assert 1e199 < surface.options["voxel"] < 1e201


# no output over an input


def test_a_merged_surface_refuses_to_replace_its_scans(tmp_path):
    """merge(paths).save(one of the paths) replaced the input scan."""
    for k in range(2):
        np.savetxt(tmp_path / f"v{k}.xyz", cap())
    scanmesh.merge([str(tmp_path / "v0.xyz"), str(tmp_path / "v1.xyz")], poses=[np.eye(4), FLIP])
    scan = tmp_path / "v1.ply"
    scanmesh.merge(
        [str(tmp_path / "v0.xyz"), str(tmp_path / "v1.xyz")], poses=[np.eye(4), FLIP]
    ).save(scan)
    before = scan.read_bytes()
    surface = scanmesh.merge([str(tmp_path / "v0.xyz"), str(scan)], poses=[np.eye(4), FLIP])
    with pytest.raises(scanmesh.ParameterError, match="it is the input file"):
        surface.save(scan)
    assert scan.read_bytes() == before


def test_a_surface_from_read_conf_refuses_to_replace_a_listed_scan(tmp_path):
    np.savetxt(tmp_path / "a.xyz", cap())
    shutil.copy(tmp_path / "a.xyz", tmp_path / "b.xyz")
    scanmesh.merge(two_views()).save(tmp_path / "b.ply")
    (tmp_path / "part.conf").write_text(
        "bmesh a.xyz 0 0 0 0 0 0 1\nbmesh b.ply 0 0 0 1 0 0 0\n", encoding="utf-8"
    )
    before = (tmp_path / "b.ply").read_bytes()
    surface = scanmesh.merge(scanmesh.read_conf(tmp_path / "part.conf"))
    with pytest.raises(scanmesh.ParameterError, match="it is the input file"):
        surface.save(tmp_path / "b.ply")
    assert (tmp_path / "b.ply").read_bytes() == before


def command(capsys, *args) -> tuple[int, list[str]]:
    code = main([str(a) for a in args])
    return code, capsys.readouterr().err.strip().splitlines()


@pytest.fixture()
def scans(tmp_path):
    names = []
    for k in range(2):
        np.savetxt(tmp_path / f"v{k}.xyz", cap())
        names.append(tmp_path / f"v{k}.xyz")
    (tmp_path / "poses.json").write_text(json.dumps([np.eye(4).tolist(), FLIP.tolist()]))
    return names


def test_the_command_refuses_to_write_over_the_poses_file(tmp_path, capsys, scans):
    """`-o poses.ply` with `--poses poses.ply` overwrote the poses with the mesh, exit 0."""
    poses = tmp_path / "poses.ply"
    shutil.copy(tmp_path / "poses.json", poses)
    before = poses.read_bytes()
    code, err = command(capsys, "merge", *scans, "--poses", poses, "-o", poses)
    assert code == 1 and len(err) == 1 and "it is the input file" in err[0], err
    assert poses.read_bytes() == before


@pytest.mark.parametrize(
    ("args", "given"),
    [
        (["reconstruct", "{scan}", "--truth", "{mesh}", "-o", "{mesh}"], "{mesh}"),
        (["simulate", "{mesh}", "-o", "{mesh}"], "{mesh}"),
        (["reconstruct", "{scan}", "-o", "out.ply", "--report", "{scan}"], "{scan}"),
        (["merge", "{scan}", "-o", "{mesh}", "--poses", "{mesh}"], "{mesh}"),
    ],
)
def test_every_command_refuses_an_output_that_is_an_input(tmp_path, capsys, args, given):
    scan, mesh = tmp_path / "scan.xyz", tmp_path / "part.stl"
    np.savetxt(scan, cap())
    scanmesh.merge(two_views()).save(mesh)
    files = {"{scan}": str(scan), "{mesh}": str(mesh)}
    target = tmp_path / files[given]
    before = target.read_bytes()
    code, err = command(
        capsys, *[files.get(a, str(tmp_path / a) if a == "out.ply" else a) for a in args]
    )
    assert code == 1 and len(err) == 1 and "it is the input file" in err[0], err
    assert target.read_bytes() == before


# --poses files


@pytest.mark.parametrize(
    ("text", "words"),
    [
        ("[[1, 2", "not a JSON file of poses"),
        (
            "[" * 100_000 + "]" * 100_000,
            "not a JSON file of poses (nested too deeply)",
        ),  # RecursionError
        (json.dumps([np.eye(4).tolist()]), "expected one 4 x 4 pose per scan (2), got 1"),
        (json.dumps({"v0.xyz": np.eye(4).tolist()}), "no pose for v1.xyz"),
        (
            json.dumps([np.eye(4).tolist(), FLIP.tolist()]).replace("-1.0", "NaN", 1),
            "pose 1 (v1.xyz): pose entry [1, 1] is nan",
        ),
        (
            json.dumps(
                [np.eye(4).tolist(), [[1, 0.5, 0, 0], [0, 1, 0, 0], [0, 0, 1, 0], [0, 0, 0, 1]]]
            ),
            "pose 1 (v1.xyz): a pose must be rigid",
        ),
        (
            json.dumps([np.eye(4).tolist(), [["a"] * 4] * 4]),
            "pose 1 (v1.xyz): a pose must be a 4 x 4 matrix of numbers",
        ),
        (
            json.dumps([np.eye(4).tolist(), FLIP.tolist()]).replace("0.0", "1" + "0" * 400, 1),
            "pose 0 (v0.xyz): a pose must be a 4 x 4 matrix of numbers",
        ),  # OverflowError
        ("null", "got no list of poses"),
    ],
)
def test_bad_poses_files_are_one_line_naming_the_file(tmp_path, capsys, scans, text, words):
    bad = tmp_path / "bad.json"
    bad.write_text(text)
    code, err = command(capsys, "merge", *scans, "--poses", bad, "-o", tmp_path / "out.ply")
    assert code == 1 and len(err) == 1, err
    assert err[0].startswith(f"scanmesh: error: --poses {bad}") and words in err[0], err
    assert not (tmp_path / "out.ply").exists()


def test_bad_poses_through_the_api_are_scanmesh_errors(scans):
    from scanmesh.cli.merge import read_poses

    for pose in ([[10**400] * 4] * 4, "abc", [[1, 2], [3]]):
        with pytest.raises(scanmesh.ParameterError, match="view 0"):
            scanmesh.merge([(cap(), pose)])
    assert len(read_poses(scans[0].parent / "poses.json", scans)) == 2


# the command's flags come from the table


def test_the_merge_flags_and_their_help_come_from_the_options_table():
    parser = build_parser()
    merge_parser = parser._subparsers._group_actions[0].choices["merge"]  # type: ignore[union-attr]
    flags = {s: a for a in merge_parser._actions for s in a.option_strings}
    for option in OPTIONS:
        assert option.flag in flags, option.flag
        assert option.doc in flags[option.flag].help.replace("%%", "%")
    assert "--no-refine" in flags


@pytest.mark.parametrize(
    ("flags", "words"),
    [
        (["--voxel", "1e-300"], ["--voxel 1e-300", "--max-voxels 64,000,000"]),
        (["--truncation", "1e300"], ["--truncation 1e+300", "--max-voxels"]),
        (["--max-voxels", "0"], ["--max-voxels must be a whole number >= 1, got 0"]),
        (["--voxel", "0"], ["--voxel must be a number > 0, got 0.0"]),
        (["--voxel", "1e6"], ["--voxel 1000000.0 is coarser than any view"]),
    ],
)
def test_bad_flags_are_one_line_naming_the_flag(tmp_path, capsys, scans, flags, words):
    out = tmp_path / "out.ply"
    code, err = command(
        capsys, "merge", *scans, "--poses", tmp_path / "poses.json", "-o", out, *flags
    )
    assert code == 1 and len(err) == 1, err
    for word in words:
        assert word in err[0], err
    assert not out.exists()


def test_a_conf_translation_beyond_1e300_is_refused_by_line(tmp_path):
    """read_conf accepted 1e308, and merge then overflowed (OverflowError)."""
    np.savetxt(tmp_path / "a.xyz", cap())
    conf = tmp_path / "part.conf"
    conf.write_text("bmesh a.xyz 1e308 0 0 0 0 0 1\n", encoding="utf-8")
    with pytest.raises(scanmesh.FileFormatError, match=r"part.conf, line 1: translation"):
        scanmesh.read_conf(conf)


@pytest.mark.parametrize("far", [1e20, 1e300, 1e308])
def test_a_pose_too_far_for_float64_to_hold_the_points_apart_is_refused(far):
    """At 1e20 the neighbouring floats are 16,384 apart: the views' points were rounded
    together and a mesh came out anyway; at 1e308 an OverflowError."""
    views = two_views()
    for k, (points, pose) in enumerate(views):
        moved = pose.copy()
        moved[0, 3] = far
        views[k] = (points, moved)
    with pytest.raises(scanmesh.DegenerateInputError, match="view 0: its pose puts its points"):
        scanmesh.merge(views)
