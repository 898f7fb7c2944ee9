"""Search a floor plan's certified field from the first field of
:mod:`tether.game.directions` (its singularities where a core fits, the gap direction along
narrow passages) instead of :func:`~tether.game.certificate.first_field`'s (``docs/certified.md``,
"Where no field is certified", floor plans), then repair it by local refinement.

The search is :func:`~tether.game.field_lp.solve_field` with ``start`` the direction field and
one core size (``--core``, units of :func:`~tether.game.field_lp.vortex_radius`); then rounds
of :func:`~tether.game.refine.refine_certified` (``search_ring=2``, ``gallery_fields.repair``)
until it is certified (at most ``--rounds``). Whatever it prints as certified was passed by
:func:`~tether.game.certificate.certify`; a saved file is certified again when read.

Usage::

    python docs/plan_fields.py --lss 0.3 --h 0.15 --save FILE
    python docs/plan_fields.py --lss 0.3 --h 0.15 --singularities   # where the field winds
"""

from __future__ import annotations

import argparse
import time
from fractions import Fraction

import numpy as np
import shapely
from gallery_fields import repair  # docs/, next to this script

from tether.examples.floorplan import floor_plan
from tether.game.certified import CertifiedKernel
from tether.game.directions import direction_field, singularities
from tether.game.field_lp import solve_field, vortex_radius
from tether.game.kernel import surveillance_kernel


def search(env, lss: float, vt: float, vo: float, h: float, core: float,
           directions: bool = True) -> CertifiedKernel:
    """The search from the direction field (``directions``; else from ``solve_field``'s own
    first field alone, the control) with the one core size ``core``, in the map's normalized
    frame as ``certified_kernel``'s."""
    t0 = time.perf_counter()
    frame, space = env.frame, env.internal
    s = frame.scale
    kern = surveillance_kernel(space, lss * s, vt / vo, 1.0, h=h * s, orientations=180)
    start = direction_field(kern)[0] if directions else None
    f, checks, log = solve_field(space, kern, lss * s, vt / vo, 1.0, tries=(core,),
                                 start=start)
    for rec in log:
        print({k: v for k, v in rec.items() if not k.startswith("t_")}, flush=True)
    return CertifiedKernel(env, lss, vt, vo, h, f, checks, log, time.perf_counter() - t0,
                           frame, space, 0.0)


def where_it_winds(env, lss: float, vt: float, h: float) -> list[str]:
    """One line per singular triangle of the direction field: index, place (map units), its
    clearance and whether a core of :func:`vortex_radius` beyond ``lss`` fits there."""
    s = env.frame.scale
    kern = surveillance_kernel(env.internal, lss * s, vt, 1.0, h=h * s, orientations=180)
    f, z = direction_field(kern)
    idx = singularities(z, f.tri)
    hot = np.flatnonzero(idx)
    cen = env.frame.to_user(f.points[f.tri[hot]].mean(axis=1))
    clear = shapely.distance(shapely.points(cen), env.polygon.boundary)
    need = lss + vortex_radius(lss, vt, 1.0)
    out = [f"index sum {int(idx.sum())}, core needs clearance {need:.3f}"]
    for k, (c, d) in zip(hot, zip(cen, clear, strict=True), strict=True):
        out.append(f"{idx[k]:+d} at ({c[0]:.2f}, {c[1]:.2f}) clear {d:.3f} "
                   f"{'fits' if d >= need else 'no core'}")
    return out


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--plan", default="20:0", help="floor_plan VERTICES:SEED")
    ap.add_argument("--lss", type=float, default=0.3, help="rod length (m)")
    ap.add_argument("--ratio", type=float, default=0.3, help="vt/vo (vo = 1)")
    ap.add_argument("--h", type=float, default=0.15, help="mesh spacing (m)")
    ap.add_argument("--core", default="0", help="core size, units of vortex_radius (exact)")
    ap.add_argument("--rounds", type=int, default=4, help="local refinement rounds at most")
    ap.add_argument("--control", action="store_true",
                    help="search from solve_field's own first field only (no direction field)")
    ap.add_argument("--save", help="write the field here (CertifiedKernel.save)")
    ap.add_argument("--singularities", action="store_true",
                    help="print where the direction field winds, only")
    args = ap.parse_args()
    n, seed = (int(x) for x in args.plan.split(":"))
    env = floor_plan(n, seed)
    if args.singularities:
        print("\n".join(where_it_winds(env, args.lss, args.ratio, args.h)))
        return
    c0, w0 = time.process_time(), time.perf_counter()
    ck = search(env, args.lss, args.ratio, 1.0, args.h, float(Fraction(args.core)),
                not args.control)
    if ck.checks is None:
        raise SystemExit(f"no first field: {ck.log[-1]}")
    print(f"search: {len(ck.field.points)} vertices, failing {ck.checks.counts()}, "
          f"{time.process_time() - c0:.0f} CPU s", flush=True)
    ck = repair(ck, args.rounds)  # gallery_fields' rounds of local refinement
    done = {"certified": ck.certified, "vertices": len(ck.field.points),
            "cpu_s": round(time.process_time() - c0), "wall_s": round(time.perf_counter() - w0)}
    if ck.certified:
        frac, err = ck.safe_fraction(20_000)
        done["share_%"] = f"{100 * frac:.1f} ± {100 * err:.1f}"
    print(done)
    if args.save:
        ck.save(args.save)

if __name__ == "__main__":
    main()
