"""The hand-built wall-band fields of ``tether.game.wall_band`` on the gallery at vt/vo = 0.9,
by rod length (``docs/certified.md``, "Where no field is certified": the gallery at 0.9).

Each row builds the field and runs :func:`~tether.game.certificate.certify`; it prints the
failing triangles per check and where they are: each failing triangle is counted at the
nearest corner of the map (a vertex of a wall) within 2 map units of its centroid, else as
"walls" (along a straight wall) or "core" (farther than ``depth`` from every wall).

Usage::

    python docs/wall_band_fields.py                 # the table of the doc (a few minutes)
    python docs/wall_band_fields.py --room          # the 10 x 10 room at lss 0.15 only
    python docs/wall_band_fields.py --lss 0.15 --h 0.075 --direction core --profile wall \\
        --save FILE.npz                             # one row, its field saved
"""

from __future__ import annotations

import argparse
import math
import time
from collections import Counter

import numpy as np

from tether import Environment
from tether.errors import InvalidParameterError
from tether.examples import load
from tether.game.wall_band import wall_band_field

#: (lss, h): h = lss/2 where free_mesh meshes the gallery (it fails below h = 0.07 there).
SIZES = ((0.25, 0.125), (0.2, 0.1), (0.15, 0.075), (0.1, 0.07))
#: The saddle of direction="saddle": the centre of the gallery's largest clear disc (2.65),
#: moved off the lattice so that no vertex sits on it.
Z0 = (2.7 + 0.0123, 2.65 + 0.0071)


def where(env, ck, mask: np.ndarray, depth: float) -> str:
    """The failing triangles of ``mask`` counted at the nearest map corner within 1 map unit,
    else along the walls or in the core (the five largest counts)."""
    if not mask.any():
        return ""
    cen = ck.field.points[ck.field.tri[mask]].mean(axis=1)
    corners = np.concatenate([np.asarray(r, dtype=float) for r in env.rings])
    dist = np.hypot(*(cen[:, None, :] - corners[None, :, :]).transpose(2, 0, 1))
    near = dist.argmin(axis=1)
    wall = env.boundary_distance(cen[:, 0], cen[:, 1])
    labels = [f"({corners[k][0]:g}, {corners[k][1]:g})" if dist[i, k] <= 2.0
              else ("walls" if wall[i] < depth else "core") for i, k in enumerate(near)]
    return ", ".join(f"{n} at {lab}" for lab, n in Counter(labels).most_common(5))


def row(env, lss: float, h: float, direction: str, profile: str, save: str | None = None
        ) -> str:
    """Build, check and describe one field (a table row)."""
    kw = {"alpha_wall": math.pi / 5, "reach": 0.95} if profile == "corner" else {}
    if direction == "saddle":
        kw.update(z0=Z0, smooth=0.5, tilt=0.9)
    t, w = time.process_time(), time.perf_counter()
    try:
        ck = wall_band_field(env, lss, 0.9, 1.0, h, direction=direction, profile=profile, **kw)
    except InvalidParameterError as e:  # the band is deeper than the map holds
        return f"| {lss:g} | {h:g} | {direction} | {profile} | | no field: {e} | | | |"
    cpu, wall = time.process_time() - t, time.perf_counter() - w
    if save:
        ck.save(save)
    c = ck.checks.counts()
    depth = ck.log[0]["wall_band"]["depth"]
    verdict = "**certified**" if ck.certified else f"{int(ck.checks.bad.sum())}"
    return (f"| {lss:g} | {h:g} | {direction} | {profile} | {len(ck.field.points):,} | "
            f"{verdict} | {c['free']}, {c['open']}, {c['lo']}, {c['hi']} | "
            f"{where(env, ck, ck.checks.bad, depth)} | {cpu:.0f} ({wall:.0f}) |")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--room", action="store_true", help="the 10 x 10 room at lss 0.15 only")
    ap.add_argument("--lss", type=float)
    ap.add_argument("--h", type=float)
    ap.add_argument("--direction", default="core", choices=("core", "saddle"))
    ap.add_argument("--profile", default="wall", choices=("wall", "corner"))
    ap.add_argument("--save")
    a = ap.parse_args()
    print("| lss | h | direction | profile | vertices | failing | free, open, lo, hi "
          "| where | CPU s (wall) |")
    print("| --- | --- | --- | --- | --- | --- | --- | --- | --- |")
    if a.room:
        room = Environment([(0, 0), (10, 0), (10, 10), (0, 10)])
        print(row(room, 0.15, 0.075, "core", "corner", a.save))
        return
    env = load("gallery")
    if a.lss is not None:
        print(row(env, a.lss, a.h, a.direction, a.profile, a.save), flush=True)
        return
    for direction, profile in (("core", "wall"), ("core", "corner"), ("saddle", "wall")):
        for lss, h in SIZES:
            print(row(env, lss, h, direction, profile), flush=True)


if __name__ == "__main__":
    main()
