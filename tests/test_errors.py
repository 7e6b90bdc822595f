"""Every bad input of the foundation raises a ScanmeshError naming the problem."""

from __future__ import annotations

import numpy as np
import pytest

import scanmesh
import scanmesh.errors
from conftest import bumpy_patch
from scanmesh import DegenerateInputError, ParameterError, ScanmeshError, formats


def test_error_hierarchy():
    assert issubclass(ScanmeshError, ValueError)
    for cls in (
        DegenerateInputError,
        ParameterError,
        scanmesh.InvalidMeshError,
        scanmesh.FileFormatError,
    ):
        assert issubclass(cls, ScanmeshError)


@pytest.mark.parametrize(
    "points, match",
    [
        (np.zeros(5), r"shape \(N, 3\), got \(5,\)"),
        (np.zeros((5, 2)), r"shape \(N, 3\), got \(5, 2\)"),
        (np.zeros((2, 5, 3)), r"shape \(N, 3\)"),
        (np.array([["a", "b", "c"]] * 4), "real numbers"),
        (np.ones((4, 3), dtype=complex), "real numbers"),
        (np.zeros((2, 3)), "at least 3 points"),
    ],
)
def test_bad_shapes_and_types(points, match):
    with pytest.raises(ScanmeshError, match=match):
        scanmesh.delaunay(points)


@pytest.mark.parametrize("bad", [np.nan, np.inf, -np.inf])
def test_non_finite_values_name_the_point(bad):
    pts = bumpy_patch(20, 1)
    pts[7, 1] = bad
    with pytest.raises(DegenerateInputError, match=r"points\[7\].*y="):
        scanmesh.delaunay(pts)


def test_identical_and_collinear_points():
    with pytest.raises(DegenerateInputError, match="distinct"):
        scanmesh.delaunay(np.ones((5, 3)))
    line = np.outer(np.arange(10.0), [1.0, 2.0, 3.0])
    with pytest.raises(DegenerateInputError, match="collinear"):
        scanmesh.delaunay(line)
    # Not collinear in 3-D, but collinear when seen along z.
    wall = np.column_stack([np.arange(10.0), np.arange(10.0), np.arange(10.0) % 3])
    with pytest.raises(DegenerateInputError, match="after projection"):
        scanmesh.delaunay(wall, plane="z")


@pytest.mark.parametrize(
    "kwargs, match",
    [
        ({"plane": "w"}, "plane"),
        ({"plane": [0, 0, 0]}, "normal"),
        ({"plane": [1, 0]}, "3 components"),
        ({"max_edge": -1.0}, "max_edge"),
        ({"max_edge": float("nan")}, "max_edge"),
    ],
)
def test_bad_options(kwargs, match):
    with pytest.raises(ParameterError, match=match):
        scanmesh.delaunay(bumpy_patch(30, 2), **kwargs)


@pytest.mark.parametrize("scale", [1e-300, 1e300])
def test_extreme_magnitudes_work(scale):
    pts = bumpy_patch(100, 3)
    s = scanmesh.delaunay(pts * scale)
    assert len(s.faces) > 100
    assert np.isfinite(s.quality.tac_1)


def test_every_error_and_warning_class_is_exported_under_the_package_name():
    classes = [
        obj
        for obj in vars(scanmesh.errors).values()
        if isinstance(obj, type) and issubclass(obj, (ScanmeshError, scanmesh.ScanmeshWarning))
    ]
    assert len(classes) >= 15  # the core's five errors, those of errors.py and the warnings
    for cls in classes:
        assert cls.__name__ in scanmesh.__all__, cls
        assert cls.__name__ in scanmesh.errors.__all__, cls
        assert getattr(scanmesh, cls.__name__) is cls
        assert cls.__module__ == "scanmesh", cls  # tracebacks name the public class


def test_every_reader_is_named_in_the_package_docstring():
    read_line = " ".join(
        line.strip() for line in scanmesh.__doc__.split(":func:`read`")[1].split("- :")[0].split()
    )
    readers = [f for f in (*formats.FORMATS, formats._ESRI) if f.reader is not None]
    assert len(readers) >= 15
    for fmt in readers:
        assert fmt.name.split()[0].upper() in read_line, fmt.name
