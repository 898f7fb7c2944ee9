"""Why the office map's certified field fails (issue #22): geometry against ``lss`` and the
first field's failing checks by region. Cheap (a few CPU seconds): no search runs.

Prints three tables for the bundled office (``tether.examples.load("office", ".yaml")``,
lss 0.8, ``vt/vo`` 0.3) beside ``floor_plan(20, seed=0)`` at lss 0.15 (certified):

1. clearance (distance to the walls, sampled at 0.05 m) against ``lss`` and the whole-circle
   core a vortex needs (:func:`~tether.game.field_lp.vortex_radius` + ``lss``, every
   alignment; :func:`~tether.game.field_lp.aligned_radius` + ``lss``, the gap aligned);
2. the free space eroded by ``r``: its parts (where the map splits into rooms);
3. the first field (:func:`~tether.game.certificate.first_field` of the grid kernel at the
   coarse spacing 0.2 m, 180 orientations) checked by
   :func:`~tether.game.certificate.certify`, failing triangles per check and region (the
   office's regions from its coordinates: the corridor ``y < 1.85``, three rooms, and the
   three doors, 0.9 m wide in 0.15 m walls, within 0.6 m of a door's centre).

``--rooms`` prints instead the numbers of the door argument (``docs/certified.md``, "Big
maps"): per part of the free space cut at its doors, its largest clearance and whether a
whole-circle core fits, and per rod length the shortest half and whole turn of an arc end
(:func:`~tether.game.end_turn.turn_length`) and the passages a core fits in; ``--docs``
writes them into ``docs/certified.md``.

Usage::

    python benchmarks/office_diagnosis.py
    python benchmarks/office_diagnosis.py --rooms [--docs]
"""

from __future__ import annotations

import argparse
import math
import time
from pathlib import Path

import numpy as np
import shapely
from shapely import distance, points
from shapely.geometry import Polygon, box

from tether.examples import floor_plan, load
from tether.game.certificate import certify, first_field
from tether.game.end_turn import turn_length
from tether.game.field_lp import aligned_radius, vortex_radius
from tether.game.kernel import surveillance_kernel

VT, VO = 0.3, 1.0
#: the office's door centres (office.yaml: gaps x 1.0-1.9, 5.4-6.3, 9.6-10.5 in y 1.85-2.0)
DOORS = np.array([[1.45, 1.925], [5.85, 1.925], [10.05, 1.925]])
#: The door openings (office.yaml), cut out of the free space to split it into its parts.
DOOR_BOXES = [box(1.0, 1.85, 1.9, 2.0), box(5.4, 1.85, 6.3, 2.0), box(9.6, 1.85, 10.5, 2.0)]
#: The office's narrow passages (m): the doors, the gaps beside the table (room 2) and the
#: pillar (corridor), ``(name, width)`` from office.yaml's coordinates.
PASSAGES = (("doors", 0.9), ("table to room 2's west wall", 4.6 - 3.65),
            ("pillar to the corridor's south wall", 0.5 + 0.35),
            ("pillar to the corridor's north wall", 1.85 - 0.9))


def free_polygon(env) -> Polygon:
    """The free space of ``env`` as a shapely polygon."""
    return Polygon(env.boundary, list(env.holes))


def clearance_rows(env, lss: float, step: float = 0.05) -> list[str]:
    """Clearance at the free points of a ``step`` grid (map units) against the radii."""
    poly = free_polygon(env)
    x0, y0, x1, y1 = poly.bounds
    gx, gy = np.meshgrid(np.arange(x0, x1, step), np.arange(y0, y1, step))
    p = np.c_[gx.ravel(), gy.ravel()]
    p = p[[poly.contains(q) for q in points(p)]]
    d = distance(points(p), poly.boundary)
    rv, ra = vortex_radius(lss, VT, VO), aligned_radius(lss, VT, VO)
    cells = " | ".join(f"{np.mean(d >= r) * 100:.1f}" for r in (lss, ra + lss, rv + lss))
    return [f"| {env.name or 'map'} | {lss} | {d.max():.2f} | {np.median(d):.2f} "
            f"| {rv:.3f} | {cells} |"]


def erosion_rows(env, radii: tuple[float, ...]) -> list[str]:
    """Parts (and their areas, m²) of the free space eroded by each radius."""
    poly, rows = free_polygon(env), []
    for r in radii:
        e = poly.buffer(-r)
        parts = [] if e.is_empty else list(getattr(e, "geoms", [e]))
        areas = ", ".join(f"{q.area:.2f}" for q in sorted(parts, key=lambda q: -q.area))
        rows.append(f"| {env.name or 'map'} | {r:.3f} | {len(parts)} | {areas} |")
    return rows


def office_regions(centres: np.ndarray) -> np.ndarray:
    """The office region of each point (corridor, rooms, doors)."""
    x, y = centres[:, 0], centres[:, 1]
    room = np.where(x < 3.5, "room 1 (x < 3.5)",
                    np.where(x < 7.8, "room 2 (table)", "room 3 (x > 7.95)"))
    reg = np.where(y < 1.85, "corridor (pillar)", room)
    near = np.min(np.linalg.norm(centres[:, None, :] - DOORS[None], axis=2), axis=1)
    return np.where(near < 0.6, "doors (0.6 m)", reg)


def first_field_rows(env, lss: float, coarse_h: float = 0.2) -> list[str]:
    """The first field's failing triangles per check and office region."""
    kern = surveillance_kernel(env, lss, VT, VO, h=coarse_h, orientations=180)
    f = first_field(kern, 0.0)
    c = certify(f, env, lss, VT, VO, 0.0)
    reg = office_regions(f.points[f.tri].mean(axis=1))
    rows = []
    for r in [*np.unique(reg), "all"]:
        m = np.ones(len(reg), bool) if r == "all" else reg == r
        n = [int(k[m].sum()) for k in (c.bad, c.free, c.open, c.lo, c.hi)]
        rows.append(f"| {r} | {int(m.sum())} | " + " | ".join(str(v) for v in n) + " |")
    return rows


def part_name(part: Polygon) -> str:
    """The office region holding ``part``'s representative point."""
    return str(office_regions(np.array(part.representative_point().coords))[0])


def room_rows(env, sizes: tuple[float, ...], step: float = 0.02) -> list[str]:
    """Per part of the free space cut at its doors: area, holes, the largest clearance (the
    distance to the walls, door openings not counted, at the points of a ``step`` grid, so
    within ``step/√2`` below the exact value) and whether a whole-circle core of
    ``vortex_radius`` fits (clearance >= lss + r_v) at each rod length of ``sizes``."""
    poly = free_polygon(env)
    parts = poly.difference(shapely.union_all(DOOR_BOXES))
    rows = []
    for part in sorted(parts.geoms, key=lambda q: q.bounds[0] + 10 * q.bounds[1]):
        x0, y0, x1, y1 = part.bounds
        gx, gy = np.meshgrid(np.arange(x0, x1, step), np.arange(y0, y1, step))
        pts = points(np.c_[gx.ravel(), gy.ravel()])
        d = distance(pts[shapely.contains(part, pts)], poly.boundary).max()
        fits = " | ".join("yes" if d >= lss + vortex_radius(lss, VT, VO) else "no"
                          for lss in sizes)
        rows.append(f"| {part_name(part)} | {part.area:.1f} | {len(part.interiors)} | "
                    f"{d:.2f} | {fits} |")
    return rows


def turn_rows(sizes: tuple[float, ...]) -> list[str]:
    """Per rod length: ``r_v``, the core's clearance, the shortest turns of an arc end by π
    and 2π (:func:`~tether.game.end_turn.turn_length`) and the passages whose half width
    holds a whole core (``lss + r_v``)."""
    rows = []
    for lss in sizes:
        rv = vortex_radius(lss, VT, VO)
        fit = [f"{w:g}" for _, w in PASSAGES if w / 2 >= lss + rv]
        rows.append(f"| {lss:g} | {rv:.3f} | {lss + rv:.3f} | "
                    f"{turn_length(math.pi, lss, VT, VO):.3f} | "
                    f"{turn_length(math.tau, lss, VT, VO):.3f} | "
                    f"{', '.join(sorted(set(fit))) or 'none'} |")
    return rows


def rooms_tables(sizes: tuple[float, ...] = (0.8, 0.5, 0.3, 0.25, 0.24)) -> str:
    """The two tables of the door argument (``docs/certified.md``, "Big maps")."""
    env = load("office", ".yaml")
    head = " | ".join(f"core fits at {lss:g}" for lss in sizes)
    out = [f"| part | area m² | holes | largest clearance m | {head} |",
           "|---|---:|---:|---:|" + "---|" * len(sizes), *room_rows(env, sizes), "",
           "| lss | r_v | lss + r_v | π turn needs m | 2π turn needs m "
           "| passages (m wide) whose half width holds lss + r_v |",
           "|---:|---:|---:|---:|---:|---|", *turn_rows(sizes)]
    return "\n".join(out)


def write_docs(tables: str) -> None:
    """Put ``tables`` between the ``office_diagnosis --rooms`` markers of
    ``docs/certified.md``."""
    doc = Path(__file__).resolve().parents[1] / "docs" / "certified.md"
    mark = "<!-- office_diagnosis --rooms: {} -->"
    begin, end = mark.format("begin"), mark.format("end")
    text = doc.read_text()
    if begin not in text or end not in text:
        raise SystemExit(f"no {begin} ... {end} block in {doc}")
    head, rest = text.split(begin, 1)
    doc.write_text(f"{head}{begin}\n{tables}\n{end}{rest.split(end, 1)[1]}")


def main() -> None:
    """Print the tables (``--rooms``: the door argument's two only)."""
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--rooms", action="store_true", help="the per-room tables only")
    ap.add_argument("--docs", action="store_true",
                    help="with --rooms: write them into docs/certified.md (\"Big maps\")")
    args = ap.parse_args()
    t0, w0 = time.process_time(), time.perf_counter()
    if args.rooms:
        tables = rooms_tables()
        print(tables)
        if args.docs:
            write_docs(tables)
        print(f"\n{time.process_time() - t0:.1f} CPU s, {time.perf_counter() - w0:.1f} wall s")
        return
    office = load("office", ".yaml")
    plan = floor_plan(20, 0)
    print("| map | lss | max clearance | median | r_v | % >= lss | % >= r_a+lss | % >= r_v+lss |")
    print("|---|---:|---:|---:|---:|---:|---:|---:|")
    for env, lss in ((office, 0.8), (plan, 0.15)):
        print("\n".join(clearance_rows(env, lss)))
    print("\n| map | eroded by | parts | areas m² |\n|---|---:|---:|---|")
    radii = (0.4, 0.45, 0.5, 0.8, 1.167)
    print("\n".join(erosion_rows(office, radii) + erosion_rows(plan, radii)))
    print("\n| office region | triangles | failing | free | open | lo | hi |")
    print("|---|---:|---:|---:|---:|---:|---:|")
    print("\n".join(first_field_rows(office, 0.8)))
    print(f"\n{time.process_time() - t0:.1f} CPU s, {time.perf_counter() - w0:.1f} wall s")


if __name__ == "__main__":
    main()
