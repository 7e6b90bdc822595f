"""Short handles cut along their shortest non-separating loop (scanmesh.fusion.handles)."""

from __future__ import annotations

import numpy as np
import trimesh

import scanmesh
from scanmesh import shape
from scanmesh.evaluate.digitizer import axis_views
from scanmesh.fusion.handles import cut_short_handles, short_loops
from scanmesh.fusion.pieces import pieces

FILLED = scanmesh.Surface.LABELS.index("filled")


def torus(major: float, minor: float, offset=(0.0, 0.0, 0.0)) -> trimesh.Trimesh:
    mesh = trimesh.creation.torus(
        major_radius=major, minor_radius=minor, major_sections=64, minor_sections=16
    )
    mesh.apply_translation(offset)
    return mesh


def meridian(minor: float, sections: int = 16) -> float:
    """The length of the torus mesh's loop round its tube: a regular polygon's perimeter."""
    return 2 * sections * minor * np.sin(np.pi / sections)


def test_the_shortest_loop_of_a_thin_torus_rings_its_tube():
    ring = torus(1.0, 0.1)
    loops = short_loops(ring.vertices, ring.faces, 1.0)
    assert loops, "a thin torus has a short non-separating loop"
    assert abs(loops[0][0].length - meridian(0.1)) < 1e-9
    # the loop round the hole (2 pi (1 - 0.1) = 5.7 long) is not short
    assert short_loops(ring.vertices, ring.faces, 0.5) == []


def test_a_thin_handle_is_cut_and_capped_and_a_wide_one_kept():
    thin, wide = torus(1.0, 0.1), torus(1.0, 0.45, offset=(5.0, 0.0, 0.0))
    both = trimesh.util.concatenate([thin, wide])
    labels = np.zeros(len(both.faces), dtype=np.uint8)
    v, f, lab, cut = cut_short_handles(both.vertices, both.faces, labels, 1.0, FILLED)
    parts = pieces(v, f)
    assert [p.closed for p in parts] == [True, True]
    assert sorted(p.genus for p in parts) == [0.0, 1.0]  # the thin torus lost its handle
    assert len(cut) == 1 and abs(cut[0].length - meridian(0.1)) < 1e-9
    mesh = trimesh.Trimesh(v, f, process=False)
    assert mesh.is_winding_consistent and mesh.is_volume
    # two caps of one fan each, labelled filled; the rest as it was
    ring = len(cut[0].vertices)
    assert (lab == FILLED).sum() == 2 * ring and (lab[: len(labels)] == 0).all()
    # the caps are apart (each side drawn towards its own faces): the cut tube's volume is
    # the torus's but for a slice
    cut_tube = min(mesh.split(only_watertight=False), key=lambda m: m.volume)
    assert 0.9 * thin.volume < cut_tube.volume < thin.volume


def test_two_thin_handles_are_both_cut():
    # two pieces of one mesh, a thin handle each: disjoint loops of independent classes,
    # cut in one round
    a, b = torus(1.0, 0.1), torus(1.0, 0.12, offset=(0.0, 3.0, 0.0))
    both = trimesh.util.concatenate([a, b])
    v, f, _, cut = cut_short_handles(both.vertices, both.faces, None, 1.0, FILLED)
    assert len(cut) == 2 and [p.genus for p in pieces(v, f)] == [0.0, 0.0]


def test_a_mesh_that_is_not_closed_is_left_as_given():
    ring = torus(1.0, 0.1)
    faces = ring.faces[1:]
    v, f, lab, cut = cut_short_handles(ring.vertices, faces, None, 1.0, FILLED)
    assert cut == [] and lab is None and f is not faces
    np.testing.assert_array_equal(f, faces)


def arch_on_a_box(minor: float) -> trimesh.Trimesh:
    """A 2 x 1 x 0.6 box with a torus (major radius 0.45) standing half out of its top: an
    arch whose tube is ``minor`` thick."""
    box = trimesh.creation.box((2.0, 1.0, 0.6))
    arch = torus(0.45, minor)
    arch.apply_transform(trimesh.transformations.rotation_matrix(np.pi / 2, [1, 0, 0]))
    arch.apply_translation([0, 0, 0.3])
    return trimesh.util.concatenate([box, arch])


def test_merge_cuts_an_arch_thinner_than_the_views_resolve():
    """The arch's tube is 2 voxels across (a loop about 5.5 voxels round it on the fused
    mesh): a handle the views do not resolve, cut; merge made it genus 1 before."""
    surface = scanmesh.merge(axis_views(arch_on_a_box(0.04), 0.04, noise=0.04 / 30, seed=1))
    assert [p.genus for p in pieces(surface.vertices, surface.faces)] == [0.0]
    loops = surface.options["short_handles"]
    assert len(loops) == 1 and 4 < loops[0] < 8
    assert shape.is_watertight(surface.faces)


def test_merge_keeps_an_arch_the_views_resolve():
    """The arch's tube 5 voxels across (a loop of 16 voxels): a handle, kept."""
    surface = scanmesh.merge(axis_views(arch_on_a_box(0.1), 0.04, noise=0.04 / 30, seed=1))
    assert [p.genus for p in pieces(surface.vertices, surface.faces)] == [1.0]
    assert surface.options["short_handles"] == []


def test_a_handle_no_sample_lines_is_cut_up_to_the_longer_loop():
    """The tube's loop (1.87) is longer than the short limit (1.0) but within the unlined
    one (4.0): cut when no sample lies within a voxel (1.0 / HANDLE_LOOP) of it, kept when
    the samples line it."""
    ring = torus(1.0, 0.3)
    far = ring.vertices[:, :1] * 0 + np.array([[10.0, 0.0, 0.0]])  # samples elsewhere
    *_, cut = cut_short_handles(ring.vertices, ring.faces, None, 1.0, FILLED, far, 4.0)
    assert len(cut) == 1 and abs(cut[0].length - meridian(0.3)) < 1e-9
    lined = ring.vertices + 0.01 * ring.vertex_normals
    *_, cut = cut_short_handles(ring.vertices, ring.faces, None, 1.0, FILLED, lined, 4.0)
    assert cut == []
    # no samples given: only the short limit
    *_, cut = cut_short_handles(ring.vertices, ring.faces, None, 1.0, FILLED, None, 4.0)
    assert cut == []
