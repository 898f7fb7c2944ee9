"""The map model: feature names, free sides, reflex and straight flags."""

from __future__ import annotations

import numpy as np
from conftest import L_SHAPE

from tether import Environment


def test_feature_numbering_follows_the_file_not_the_orientation():
    # boundary given clockwise, hole given counter-clockwise: both opposite to the convention
    env = Environment([[0, 0], [0, 12], [12, 12], [12, 0]], ([[4, 4], [6, 4], [6, 6], [4, 6]],))
    assert np.allclose(env.vertices[0], [0, 0]) and np.allclose(env.vertices[4], [4, 4])
    # edge E0 runs V0 -> V1 = (0,0)->(0,12); free side is +x, i.e. to its right
    assert not env.free_on_left[0]
    assert np.allclose(env.free_normals[0], [1, 0])
    # hole edge E4 runs (4,4)->(6,4): the free space is below it (outside the hole)
    assert np.allclose(env.free_normals[4], [0, -1])
    assert list(env.reflex_indices) == [4, 5, 6, 7]


def test_reflex_vertices_of_an_l_shape():
    assert list(L_SHAPE.reflex_indices) == [3]  # (4, 4)


def test_collinear_vertex_is_not_reflex():
    env = Environment([[0, 0], [5, 0], [10, 0], [10, 10], [0, 10]])
    assert not env.reflex.any()
