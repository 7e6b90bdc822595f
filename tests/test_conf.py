"""Stanford ``.conf`` files as shipped: skipped lines, ``.ply.gz`` scans, the rotation
convention that aligns them, and the warning for a view that overlaps no other."""

from __future__ import annotations

import gzip
import re
import warnings

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

import scanmesh
from conftest import DATA
from scanmesh.fusion.views import overlaps

FOLDER = DATA / "multiview"

#: The fixture's scanner directions: turns about y, as a turntable's (degrees).
TURNS = (0.0, 50.0, 100.0)
TRANSLATION = (0.01, -0.02, 0.03)


def ellipsoid_views() -> tuple[np.ndarray, list[tuple[np.ndarray, np.ndarray]]]:
    """The fixture's truth: a 1 × 0.5 × 0.3 ellipsoid of 4,000 points (world), and per
    view the points facing its scanner in scanner coordinates with the (qi, qj, qk, qr, t)
    it is posed by, ``world = R(q)ᵀ p + t``."""
    n = 4000
    k = np.arange(n) + 0.5
    phi = np.arccos(1 - 2 * k / n)
    theta = np.pi * (1 + 5**0.5) * k
    unit = np.column_stack([np.cos(theta) * np.sin(phi), np.sin(theta) * np.sin(phi), np.cos(phi)])
    axes = np.array([1.0, 0.5, 0.3])
    world = unit * axes
    normal = unit / axes
    normal /= np.linalg.norm(normal, axis=1)[:, None]
    t = np.array(TRANSLATION)
    views = []
    for turn in TURNS:
        rot = Rotation.from_euler("y", turn, degrees=True)
        r = rot.as_matrix()  # R(q); the scanner's +z in world is Rᵀ e_z, R's last row
        facing = normal @ r[2] > 0.2
        local = (world[facing] - t) @ r.T  # p = R (world - t)
        views.append((local, np.concatenate([rot.as_quat(), t])))
    return world, views


def ply_bytes(points: np.ndarray) -> bytes:
    head = f"ply\nformat ascii 1.0\nelement vertex {len(points)}\n"
    head += "property float x\nproperty float y\nproperty float z\nend_header\n"
    body = "".join(f"{x:.6f} {y:.6f} {z:.6f}\n" for x, y, z in points)
    return (head + body).encode()


def conf_text(views) -> str:
    lines = ["camera 0 -0.1 -0.7 0 1 0 0", "mesh ellipsoid_cybcyl 0 0 0 0 0 0 1"]
    for k, (_, pose) in enumerate(views):
        q, t = pose[:4], pose[4:]
        values = " ".join(f"{v:.9g}" for v in [*t, *q])
        lines.append(f"bmesh ellipsoid_{k}.ply {values}")
    return "\n".join(lines) + "\n"


def write_fixture(folder) -> None:
    """Writes the fixture as shipped: the ``.conf`` names ``.ply`` files, the folder holds
    ``.ply.gz`` (gzip without a time stamp, so the bytes repeat)."""
    _, views = ellipsoid_views()
    (folder / "ellipsoid.conf").write_text(conf_text(views))
    for k, (points, _) in enumerate(views):
        with open(folder / f"ellipsoid_{k}.ply.gz", "wb") as raw:
            with gzip.GzipFile(fileobj=raw, mode="wb", mtime=0) as out:
                out.write(ply_bytes(points))


def test_the_fixture_is_what_its_writer_writes(tmp_path):
    write_fixture(tmp_path)
    for path in sorted(tmp_path.iterdir()):
        made = path.read_bytes()
        shipped = (FOLDER / path.name).read_bytes()
        if path.suffix == ".gz":
            made, shipped = gzip.decompress(made), gzip.decompress(shipped)
        assert made == shipped, path.name


def test_read_conf_reads_a_stanford_file_as_shipped():
    """``camera`` and ``mesh`` lines skipped, each ``FILE.ply`` read from ``FILE.ply.gz``,
    and by default ``world = R(q)ᵀ p + t``: every view's points land on the ellipsoid."""
    world, _ = ellipsoid_views()
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        views = scanmesh.read_conf(FOLDER / "ellipsoid.conf")
    assert [v.source.split("/")[-1] for v in views] == [f"ellipsoid_{k}.ply.gz" for k in range(3)]
    from scipy.spatial import cKDTree

    tree = cKDTree(world)
    for view in views:
        assert tree.query(view.world)[0].max() < 1e-5  # the file's 6 decimals
    assert min(overlaps(views)) > 0.4


def test_a_view_that_overlaps_no_other_is_warned_about_by_name():
    """The same file read as ``R(q) p + t`` puts the turned views elsewhere: each is named
    with its share of points near another view's."""
    with pytest.warns(scanmesh.ScanmeshWarning) as caught:
        views = scanmesh.read_conf(FOLDER / "ellipsoid.conf", inverse_rotation=False)
    text = str(caught[0].message)
    shares = overlaps(views)
    assert "ellipsoid_2.ply.gz" in text and "overlap no other view" in text
    assert f"ellipsoid_2.ply.gz {shares[2]:.0%}" in text
    assert shares[2] < 0.2


def test_the_command_reads_the_conf_and_says_what_came_out(tmp_path, capsys):
    """Pieces with the genus of each closed one, the specks taken off, the label areas."""
    from scanmesh.cli import main

    out = tmp_path / "ellipsoid.ply"
    assert main(["merge", str(FOLDER / "ellipsoid.conf"), "-o", str(out)]) == 0
    said = capsys.readouterr().out
    assert "from 3 views" in said
    assert re.search(r"\b1 piece \(1 closed, genus \d+\)", said), said
    assert "measured" in said and "inferred" in said and "filled" in said
    assert main(["merge", str(FOLDER / "ellipsoid.conf"), "-o", str(out), "--json"]) == 0
    import json

    row = json.loads(capsys.readouterr().out)
    assert len(row["pieces"]) == 1 and row["pieces"][0]["closed"] and row["holes"] == 0
    assert f"genus {row['pieces'][0]['genus']:g})" in said
