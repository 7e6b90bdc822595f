"""What merge trusts of a range view (fusion/depth.py's ``trust``) and the specks it takes
off the fused mesh (fusion/pieces.py)."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest
import trimesh

import scanmesh
from scanmesh.evaluate.digitizer import axis_views
from scanmesh.fusion import depth, pieces


def test_trust_falls_at_edges_rough_returns_isolated_and_grazing_ones():
    y, x = np.mgrid[0:20, 0:20].astype(float)
    img = np.where((x >= 2) & (x < 18) & (y >= 2) & (y < 18), 0.1 * x + 0.05 * y, np.nan)
    img[0, 19] = 1.0  # an isolated return
    img[12, 12] += 0.5  # a stray return standing out of the plane (under the jump)
    cos = np.ones_like(img)
    cos[6, 12] = 0.1  # a grazing one
    w = depth.trust(img, cos, 1.0)
    assert w[0, 19] == 0.0
    assert w[6, 12] == 0.0
    assert w[12, 12] < 0.01  # on a plane the median second difference is 0: any is rough
    assert w[2, 9] == pytest.approx(depth.EDGE_TRUST)  # on the edge
    step = (1 - depth.EDGE_TRUST) / depth.EDGE_PIXELS
    assert w[3, 9] == pytest.approx(depth.EDGE_TRUST + step)
    assert w[7, 7] == 1.0
    assert (w[np.isnan(img)] == 0).all()
    # a depth jump is an edge too: a step of 10 across column 10
    jump = np.ones((12, 20))
    jump[:, 10:] = 11.0
    wj = depth.trust(jump, np.ones_like(jump), 1.0)
    assert wj[6, 9] == depth.EDGE_TRUST and wj[6, 10] == depth.EDGE_TRUST and wj[6, 5] == 1.0


def test_pieces_give_genus_of_closed_and_holes_of_open_ones():
    torus = trimesh.creation.torus(1.0, 0.3)
    box = trimesh.creation.box((0.1, 0.1, 0.1))
    box.vertices += 5.0
    open_box = trimesh.creation.box((1.0, 1.0, 1.0))
    open_box = trimesh.Trimesh(open_box.vertices + 10.0, open_box.faces[2:], process=False)
    merged = trimesh.util.concatenate([torus, box, open_box])
    parts = pieces.pieces(merged.vertices, merged.faces)
    assert len(parts) == 3
    by_faces = {p.faces: p for p in parts}
    assert by_faces[len(torus.faces)].genus == 1 and by_faces[len(torus.faces)].closed
    assert by_faces[12].genus == 0
    assert by_faces[10].holes == 1 and by_faces[10].genus is None
    v, f, labels, gone = pieces.drop_specks(
        merged.vertices, merged.faces, np.zeros(len(merged.faces), np.uint8)
    )
    # the small box (0.06 of area, 0.4 % of the torus's) is a speck; the open box is not
    assert gone["pieces"] == 1 and gone["faces"] == 12
    assert gone["area"] == pytest.approx(box.area)
    assert len(f) == len(merged.faces) - 12 and len(labels) == len(f)
    assert f.max() == len(v) - 1


def test_outlier_returns_leave_no_speck_on_a_box_from_six_views():
    """Stray returns in front of the box's top (one view, a few rays each): without the
    trust and the speck rule they close into little bodies off the part."""
    box = trimesh.creation.box((2.0, 1.0, 0.6))
    views = axis_views(box, 0.04, noise=0.04 / 30, grazing=80.0, seed=1)
    rng = np.random.default_rng(0)
    top = next(k for k, v in enumerate(views) if v.up[2] > 0.9)
    scan = views[top]
    stray = scan.points[rng.choice(len(scan.points), 12, replace=False)].copy()
    stray[:, 2] += rng.uniform(0.1, 0.3, len(stray))  # 2-8 spacings above the face
    views[top] = dataclasses.replace(scan, points=np.vstack([scan.points, stray]), line_ids=None)
    surface = scanmesh.merge(views)
    parts = pieces.pieces(surface.vertices, surface.faces)
    assert len(parts) == 1 and parts[0].closed and parts[0].genus == 0
    # the mesh keeps the box: its area within 2 %
    assert sum(surface.label_areas.values()) == pytest.approx(box.area, rel=0.02)
