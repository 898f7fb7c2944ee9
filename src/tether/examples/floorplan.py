"""A seeded generator of floor plans: rooms in a grid, walls with doors, a corridor, pillars.

Used by the benchmarks and the tests as "real floor plans of hundreds of vertices". Interior
walls are free-standing obstacles (holes): each wall between two rooms is split by a door and
stops short of the junctions, so every wall piece is a thin rectangle strictly inside the
building and disjoint from the others. Pillars fill the vertex budget.
"""

from __future__ import annotations

import math

import numpy as np
from shapely.geometry import Polygon, box

from tether.environment import Environment

__all__ = ["floor_plan"]

ROOM_W, ROOM_H = 6.0, 5.0  # metres
WALL = 0.2  # wall thickness
JUNCTION_GAP = 0.6  # free gap where walls would meet
DOOR = 1.2  # door width
PILLAR = 0.5  # pillar side
CLEARANCE = 0.5  # minimum free gap between a pillar and anything else


def floor_plan(vertices: int = 100, seed: int = 0) -> Environment:
    """A floor plan with about ``vertices`` vertices (within 4), reproducible from ``seed``.

    The building is ``cols * 6`` m by ``rows * 5`` m, rooms on a grid, the middle row of walls
    left out as a corridor. Returns an :class:`Environment` named ``plan-<vertices>-<seed>``.
    """
    rng = np.random.default_rng(seed)
    rooms = max(1, round(0.7 * vertices / 16))
    cols = max(1, math.ceil(math.sqrt(rooms * 1.3)))
    rows = max(1, math.ceil(rooms / cols))
    width, height = cols * ROOM_W, rows * ROOM_H
    outline = box(0, 0, width, height)
    holes: list[Polygon] = []
    budget = vertices - 4

    def wall(x0: float, y0: float, x1: float, y1: float, vertical: bool) -> None:
        length = (y1 - y0) if vertical else (x1 - x0)
        lo, hi = JUNCTION_GAP, length - JUNCTION_GAP
        if hi - lo < DOOR + 0.6:
            return
        door = rng.uniform(lo + 0.3, hi - DOOR - 0.3)
        for a, b in ((lo, door), (door + DOOR, hi)):
            if b - a < 0.3 or len(holes) * 4 + 4 > budget:
                continue
            if vertical:
                holes.append(box(x0 - WALL / 2, y0 + a, x0 + WALL / 2, y0 + b))
            else:
                holes.append(box(x0 + a, y0 - WALL / 2, x0 + b, y0 + WALL / 2))

    corridor = rows // 2 if rows > 1 else -1
    for j in range(rows):
        for i in range(1, cols):
            wall(i * ROOM_W, j * ROOM_H, i * ROOM_W, (j + 1) * ROOM_H, vertical=True)
    for j in range(1, rows):
        if j == corridor:
            continue
        for i in range(cols):
            wall(i * ROOM_W, j * ROOM_H, (i + 1) * ROOM_W, j * ROOM_H, vertical=False)
    tries = 0
    while len(holes) * 4 + 4 <= budget and tries < 10_000:
        tries += 1
        cx, cy = rng.uniform(1.0, width - 1.0), rng.uniform(1.0, height - 1.0)
        p = box(cx - PILLAR / 2, cy - PILLAR / 2, cx + PILLAR / 2, cy + PILLAR / 2)
        if not outline.buffer(-CLEARANCE).contains(p):
            continue
        if any(p.distance(h) < CLEARANCE for h in holes):
            continue
        holes.append(p)
    rings = [np.asarray(h.exterior.coords)[:-1] for h in holes]
    return Environment(np.asarray(outline.exterior.coords)[:-1], tuple(rings),
                       f"plan-{vertices}-{seed}")
