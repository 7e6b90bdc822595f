"""The truth-free judge's steps (``scanmesh.judge``), checked against hand-computed heights."""

from __future__ import annotations

import math

import numpy as np

from scanmesh.judge import Seen, distances, rms, withhold

#: The unit square in z = x / 2 (a slope), two triangles, seen along z.
SLOPE = np.array(
    [[[0, 0, 0], [1, 0, 0.5], [1, 1, 0.5]], [[0, 0, 0], [1, 1, 0.5], [0, 1, 0]]], dtype=float
)
ALONG_Z = Seen(SLOPE, np.array([0.0, 0.0, 1.0]), np.array([[1.0, 0], [0, 1], [0, 0]]))


def test_distances_are_heights_along_the_normal_and_nan_outside():
    held = np.array([[0.5, 0.25, 1.0], [0.2, 0.9, -0.3], [2.0, 0.5, 0.0]])
    got, face = distances(held, ALONG_Z)
    assert np.allclose(got[:2], [1.0 - 0.25, 0.3 + 0.1])  # |z - x / 2|
    assert math.isnan(got[2]) and face[2] == -1 and face[0] >= 0 and face[1] >= 0
    assert math.isclose(rms(got[:2]), math.sqrt((0.75**2 + 0.4**2) / 2), rel_tol=1e-12)
    assert math.isnan(rms(got[:0]))


def test_withholding_is_seeded_and_counted():
    first = withhold(100, 10, np.random.default_rng(3))
    assert first.sum() == 10 and first.dtype == bool
    assert np.array_equal(first, withhold(100, 10, np.random.default_rng(3)))
    assert not np.array_equal(first, withhold(100, 10, np.random.default_rng(4)))
