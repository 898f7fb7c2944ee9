"""The internal frame: built explicitly for the internal map, the same at every scale."""

from __future__ import annotations

import pickle

import numpy as np
from conftest import L_SHAPE

from tether import Environment
from tether.environment import Frame, normalizing_frame


def test_the_internal_map_is_its_own_internal_map_in_the_identity_frame():
    env = Environment([[0, 0], [5, 0], [10, 0], [10, 10], [0, 10]], name="room")
    inner = env.internal
    assert not env.is_internal and inner.is_internal and inner.internal is inner
    assert inner.frame.scale == 1.0 and np.array_equal(inner.frame.origin, [0.0, 0.0])
    assert inner.n == env.n - 1 and np.array_equal(inner.vertex_map, np.arange(inner.n))
    assert env.vertex_map.tolist() == [0, 2, 3, 4]
    assert inner.name == "room"
    assert np.allclose(env.frame.to_user(inner.vertices), env.vertices[env.vertex_map])


def test_frame_is_a_power_of_two_about_the_centre():
    frame = normalizing_frame((0.0, 0.0, 30.0, 40.0))
    assert isinstance(frame, Frame) and np.array_equal(frame.origin, [15.0, 20.0])
    assert frame.scale == 2.0 ** -6  # diameter 50: nearest power of two on the log scale, 64


def test_internal_map_survives_pickling():
    inner = pickle.loads(pickle.dumps(L_SHAPE.internal))
    assert inner.internal is inner and inner.frame.scale == 1.0
