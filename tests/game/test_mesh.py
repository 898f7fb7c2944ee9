"""The certified kernel's mesh (``certificate.free_mesh``) on walls whose points are not in
general position: an edge whose end ``a + 1·(b − a)`` rounds off ``b`` must still give one wall
point there (two points 1e-16 apart made qhull drop one and the wall piece go missing)."""

from __future__ import annotations

import numpy as np
import pytest

from tether import Environment
from tether.game.certificate import free_mesh


def _lattice(env: Environment, h: float) -> np.ndarray:
    x0, y0, x1, y1 = env.bounds
    xs = np.arange(x0 + h / 2, x1, h)
    ys = np.arange(y0 + h / 2, y1, h)
    X, Y = np.meshgrid(xs, ys)
    pts = np.column_stack([X.ravel(), Y.ravel()])
    return pts[env.contains(pts[:, 0], pts[:, 1])]


def test_an_edge_end_that_rounds_off_is_one_wall_point():
    a, b = -10.0, -3.85
    assert a + (b - a) != b  # the pinned rounding
    env = Environment([(a, 0.0), (b, 0.0), (b, 5.0), (a, 5.0)])
    h = 0.25
    pts, tri, source = free_mesh(env, h, _lattice(env, h))
    wall = pts[source < 0]
    near = np.hypot(*(wall - [b, 0.0]).T)
    assert (near < 1e-9).sum() == 1 and (wall == [b, 0.0]).all(axis=1).any()
    e1, e2 = pts[tri[:, 1]] - pts[tri[:, 0]], pts[tri[:, 2]] - pts[tri[:, 0]]
    area = 0.5 * np.abs(e1[:, 0] * e2[:, 1] - e1[:, 1] * e2[:, 0]).sum()
    assert abs(area - env.polygon.area) < 1e-9 * env.polygon.area


@pytest.mark.slow
def test_office_map_meshes_at_its_own_resolution():
    """The bundled office occupancy map (0.05 m cells) meshed at h = 0.05 in its normalized
    frame: it failed at a corner where an edge's end rounded off."""
    from tether.examples import path
    from tether.io import load_map

    env = load_map(path("office", ".yaml")).internal
    h = 0.05 * load_map(path("office", ".yaml")).frame.scale
    pts, tri, source = free_mesh(env, h, _lattice(env, h))
    assert len(tri) > 10_000


@pytest.mark.slow
def test_a_mesh_of_more_than_46341_points():
    """The wall-piece check keyed edges as ``i·n + j`` on qhull's int32 indices: past 46,340
    points the key overflowed, no wall piece matched, and every big mesh was refused (the
    gallery at h = 0.05 "does not follow the wall near (0, 0)"). A 12 x 12 room at h = 0.05
    (about 58,000 points): meshed, every wall piece an edge (checked here on Python ints), the
    triangles tiling the room."""
    env = Environment([(0.0, 0.0), (12.0, 0.0), (12.0, 12.0), (0.0, 12.0)])
    h = 0.05
    pts, tri, source = free_mesh(env, h, _lattice(env, h))
    assert len(pts) > 46_341
    edges = {tuple(sorted((int(a), int(b)))) for t in tri.tolist()
             for a, b in ((t[0], t[1]), (t[1], t[2]), (t[0], t[2]))}
    wall = np.flatnonzero(source < 0)
    bottom = wall[pts[wall, 1] == 0.0]
    bottom = bottom[np.argsort(pts[bottom, 0])]
    assert len(bottom) == 12 / (h / 2) + 1
    pairs = zip(bottom[:-1], bottom[1:], strict=True)
    assert all(tuple(sorted((int(a), int(b)))) in edges for a, b in pairs)
    e1, e2 = pts[tri[:, 1]] - pts[tri[:, 0]], pts[tri[:, 2]] - pts[tri[:, 0]]
    area = 0.5 * np.abs(e1[:, 0] * e2[:, 1] - e1[:, 1] * e2[:, 0]).sum()
    assert abs(area - env.polygon.area) < 1e-9 * env.polygon.area
