"""Maps that are never in general position, as real ones are: every vertex on a lattice of cell
``h`` (0.05 by default, a ROS map's cell), distances between walls and pillars exact multiples
of ``lss`` (walls exactly ``lss`` and ``2·lss`` apart, pillars exactly ``lss`` from walls and
from each other), reflex vertices aligned on grid lines, and rasterized random shapes.

Random generators never draw these coincidences; this one draws nothing else. Each function
returns ``(boundary, holes)`` as lists of ``(x, y)`` tuples, or an :class:`Environment` where
named so.
"""

from __future__ import annotations

import numpy as np
import shapely
from shapely.geometry import Polygon, box
from shapely.ops import unary_union

from tether.environment import Environment

H = 0.05  # a ROS map's cell, metres


def _rect(x0: float, y0: float, x1: float, y1: float) -> list[tuple[float, float]]:
    return [(x0, y0), (x1, y0), (x1, y1), (x0, y1)]


def _snap(v: float, h: float = H) -> float:
    """``v`` rounded to the lattice (exact multiples of ``h`` as the nearest doubles)."""
    return round(round(v / h) * h, 10)


def corridor(lss: float, length_in_lss: int = 6, pocket: bool = True
             ) -> tuple[list, list]:
    """A corridor exactly ``2·lss`` wide between two rooms, with (``pocket``) a side alcove of
    depth ``lss`` and width ``2·lss``: the offsets of the corridor's two walls coincide, the
    alcove's back wall is exactly ``lss`` from the corridor's far offset."""
    L = length_in_lss * lss
    w = 2 * lss
    room = 3 * lss
    pts = [(0, 0), (room, 0), (room, room), (room + L, room), (room + L, 0),
           (2 * room + L, 0), (2 * room + L, room + w + room), (room + L, room + w + room),
           (room + L, room + w), (room + 0.5 * L + lss, room + w),
           (room + 0.5 * L + lss, room + w + lss), (room + 0.5 * L - lss, room + w + lss),
           (room + 0.5 * L - lss, room + w), (room, room + w), (room, room + w + room),
           (0, room + w + room)]
    if not pocket:
        pts = pts[:9] + pts[13:]
    return pts, []


def room_with_pillars(lss: float, cols: int = 2, rows: int = 2, gap_in_lss: float = 1.0,
                      side_in_lss: float = 1.0) -> tuple[list, list]:
    """A rectangular room with ``cols × rows`` square pillars of side ``side_in_lss·lss``,
    exactly ``gap_in_lss·lss`` from the walls and from each other."""
    s, g = side_in_lss * lss, gap_in_lss * lss
    W = cols * s + (cols + 1) * g
    Hh = rows * s + (rows + 1) * g
    holes = []
    for i in range(cols):
        for j in range(rows):
            x, y = g + i * (s + g), g + j * (s + g)
            holes.append(_rect(x, y, x + s, y + s)[::-1])
    return _rect(0, 0, W, Hh), holes


def aligned_steps(lss: float, steps: int = 3) -> tuple[list, list]:
    """A staircase room whose reflex vertices lie pairwise on common grid lines (each step
    ``lss`` wide and ``lss`` high), and a pillar whose corners sit on the same lines."""
    pts = [(0.0, 0.0), (2 * steps * lss, 0.0)]
    x, y = 2 * steps * lss, 0.0
    for _ in range(steps):
        y += lss
        pts.append((x, y))
        x -= lss
        pts.append((x, y))
    pts += [(x, y + 2 * lss), (0.0, y + 2 * lss)]
    hole = _rect(lss, lss, 2 * lss, 2 * lss)[::-1]
    return pts, [hole]


def rasterized(seed: int, cells: int = 60, h: float = H, blobs: int = 5,
               holes: int = 3) -> tuple[list, list] | None:
    """A random shape rasterized on a grid of ``cells × cells`` cells of side ``h``: a union
    of random boxes, minus random boxes (obstacles), every vertex on the lattice. Returns the
    largest polygon's rings, or None if the shape is unusable (a ring touching another)."""
    rng = np.random.default_rng(seed)
    ks = []
    for _ in range(blobs):
        x0, y0 = rng.integers(0, cells - 10, size=2)
        w, hh = rng.integers(8, cells // 2, size=2)
        ks.append(box(x0, y0, min(x0 + w, cells), min(y0 + hh, cells)))
    free = unary_union(ks)
    for _ in range(holes):
        x0, y0 = rng.integers(2, cells - 6, size=2)
        w, hh = rng.integers(2, 6, size=2)
        free = free.difference(box(x0, y0, x0 + w, y0 + hh))
    parts = sorted(shapely.get_parts(free), key=lambda g: -g.area)
    if not parts:
        return None
    poly = shapely.set_precision(parts[0], 1.0)  # integer lattice
    if poly.geom_type != "Polygon" or not poly.is_valid:
        return None
    poly = shapely.simplify(poly, 0.0)  # drops collinear lattice vertices
    if poly.geom_type != "Polygon":
        return None
    ext = [(_snap(x * h, h), _snap(y * h, h)) for x, y in poly.exterior.coords[:-1]]
    hs = [[(_snap(x * h, h), _snap(y * h, h)) for x, y in r.coords[:-1]]
          for r in poly.interiors]
    # touching rings (valid by OGC rules): each ring must be simple on its own
    if any(not Polygon(r).is_valid for r in [ext, *hs]):
        return None
    return ext, hs


def env_of(rings: tuple[list, list], name: str = "lattice") -> Environment:
    """An :class:`Environment` of ``(boundary, holes)``."""
    boundary, holes = rings
    return Environment(np.array(boundary, float), tuple(np.array(h, float) for h in holes),
                       name)


#: Round following distances, as users pick them.
ROUND_LSS = (0.25, 0.5, 1.0, 2.0)


def families(lss: float) -> dict[str, tuple[list, list]]:
    """One map of each degenerate family for ``lss``."""
    return {
        "corridor": corridor(lss),
        "corridor_plain": corridor(lss, pocket=False),
        "pillars_lss": room_with_pillars(lss),
        "pillars_2lss": room_with_pillars(lss, gap_in_lss=2.0),
        "pillars_half": room_with_pillars(lss, 3, 2, gap_in_lss=0.5, side_in_lss=0.5),
        "steps": aligned_steps(lss),
    }
