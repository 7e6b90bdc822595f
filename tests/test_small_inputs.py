"""Small hostile inputs: a bad grid spacing, magnitudes near float64's limit, a tiny plane
normal, crossing scan lines."""

from __future__ import annotations

import re
import warnings
from pathlib import Path

import numpy as np
import pytest

import scanmesh
from scanmesh.errors import FileFormatError, ScanmeshError
from scanmesh.stages.strips import CrossingLinesWarning

GUIDE = Path(__file__).resolve().parent.parent / "docs" / "guide" / "methods.md"


@pytest.mark.parametrize("spacing", ["0", "-2", "nan", "inf"])
def test_esri_grid_bad_cellsize_names_file_line_and_field(tmp_path, spacing):
    path = tmp_path / "dem.asc"
    rows = "\n".join(" ".join(["1.0"] * 3) for _ in range(3))
    path.write_text(f"ncols 3\nnrows 3\nxllcorner 0\nyllcorner 0\ncellsize {spacing}\n{rows}\n")
    with pytest.raises(FileFormatError) as info:
        scanmesh.read(path)
    message = str(info.value)
    assert message.startswith(f"{path}, line 5:") and "cellsize" in message
    assert "cell=" not in message


def test_esri_grid_bad_dx_is_named(tmp_path):
    path = tmp_path / "dem.asc"
    path.write_text("ncols 2\nnrows 2\ndx 1\ndy 0\n1 2\n3 4\n")
    with pytest.raises(FileFormatError, match=r"line 4: .*dy"):
        scanmesh.read(path)
    assert len(scanmesh.read(path, cell=0.5).points) == 4  # cell= overrides the header


@pytest.mark.parametrize("method", ["delaunay", "shortest-path", "lop"])
@pytest.mark.parametrize("plane", [None, "best-fit", "z"])
def test_magnitudes_near_the_float_limit_are_refused_clearly(method, plane):
    rng = np.random.default_rng(0)
    points = (rng.random((50, 3)) * 2 - 1) * 1.7e308  # finite, but differences overflow
    with warnings.catch_warnings():
        warnings.simplefilter("error", RuntimeWarning)  # said by the error, not by numpy too
        with pytest.raises(ScanmeshError, match="too large for float64"):
            scanmesh.reconstruct(points, method, plane=plane)


@pytest.mark.parametrize("scale", [1e-200, 1e200, 1.0])
def test_plane_normal_of_any_finite_size_is_accepted(scale):
    rng = np.random.default_rng(2)
    points = rng.random((40, 3))
    surface = scanmesh.reconstruct(points, "delaunay", plane=[scale, 0, scale])
    assert np.allclose(surface.frame.normal, [2**-0.5, 0, 2**-0.5])
    assert len(surface.faces) > 0


def test_crossing_lines_drop_overlaps_and_stay_planar_valid_as_documented():
    rng = np.random.default_rng(1)
    points = rng.random((60, 3)) * [1, 1, 0.1]
    lines = np.repeat(np.arange(6), 10)  # random points: the lines cross in the plane
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        surface = scanmesh.reconstruct(points, "shortest-path", lines=lines, plane="z")
    assert any(w.category is CrossingLinesWarning for w in caught)
    assert surface.options["planar_valid"] is True
    assert surface.options["dropped_overlaps"] > 0
    text = " ".join(GUIDE.read_text().split())
    assert re.search(r"CrossingLinesWarning[^.]*planar_valid\"\]` is True", text)
    assert 'planar_valid"]` is False' not in text
