"""Text files written with a decimal comma (as spreadsheets in many locales save them), read
with ``decimal=","`` / ``--decimal ,``; the same numbers as the file written with points."""

from __future__ import annotations

import numpy as np
import pytest

import scanmesh
from scanmesh.errors import FileFormatError, ParameterError
from test_cli import run


def _points(n=60, seed=2):
    rng = np.random.default_rng(seed)
    pts = rng.random((n, 3)) * [10, 5, 1] - [5, 0, 0.5]
    return np.round(pts, 6)


@pytest.mark.parametrize(("ending", "sep"), [(".csv", ";"), (".xyz", "\t"), (".txt", " ")])
def test_decimal_commas_read_as_the_decimal_points(tmp_path, ending, sep):
    pts = _points()
    rows = [sep.join(f"{v:.6f}" for v in row) for row in pts]
    (tmp_path / f"p{ending}").write_text("\n".join(rows) + "\n")
    (tmp_path / f"c{ending}").write_text("\n".join(r.replace(".", ",") for r in rows) + "\n")
    dots = scanmesh.read(tmp_path / f"p{ending}")
    commas = scanmesh.read(tmp_path / f"c{ending}", decimal=",")
    np.testing.assert_array_equal(commas.points, dots.points)
    np.testing.assert_allclose(commas.points, pts, atol=1e-12)
    with pytest.raises(FileFormatError, match=r"line 1.*decimal=',' \(--decimal ,\)"):
        scanmesh.read(tmp_path / f"c{ending}")  # without the option: refused, pointing to it


def test_comma_separated_values_are_not_taken_for_decimal_commas(tmp_path):
    (tmp_path / "s.csv").write_text("x,y,z\n1,2,3\n4,5,6\n7,8,9\n")
    with pytest.raises(FileFormatError, match="line 2.*semicolons"):
        scanmesh.read(tmp_path / "s.csv", decimal=",")
    with pytest.raises(ParameterError, match="decimal"):
        scanmesh.read(tmp_path / "s.csv", decimal=";")
    np.save(tmp_path / "p.npy", _points())
    with pytest.raises(ParameterError, match="decimal"):
        scanmesh.read(tmp_path / "p.npy", decimal=",")  # not an option of .npy files


def test_the_command_takes_decimal(tmp_path):
    pts = _points(200)
    rows = ["x;y;z", *(";".join(f"{v:.6f}".replace(".", ",") for v in row) for row in pts)]
    (tmp_path / "s.csv").write_text("\n".join(rows) + "\n")
    out = tmp_path / "m.ply"
    result = run("reconstruct", tmp_path / "s.csv", "-o", out, "--method", "delaunay",
                 "--decimal", ",", "-q")  # fmt: skip
    assert result.returncode == 0, result.stderr
    np.testing.assert_allclose(scanmesh.read(out).points, pts, atol=1e-12)
