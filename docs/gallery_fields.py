"""Rebuild the gallery's certified fields with a rod shorter than 1 (``docs/certified.md``,
"Where no field is certified": the gallery at 0.6 and 0.9) and save them for
``docs/evidence_runs.py --field-file`` and ``docs/certified_table.py --field-file``.

The search of :func:`~tether.game.certified.certified_kernel` runs its three core sizes and
keeps the *last* field tried. Here one core size is chosen (``--core``, in units of
:func:`~tether.game.field_lp.vortex_radius`), and the field it gives is repaired where it
fails by rounds of :func:`~tether.game.refine.refine_certified` with a local search
(``search_ring=2``, one round at a time, stopping at the first certified field, at most
``--rounds``). Whatever it prints as certified was passed by
:func:`~tether.game.certificate.certify`; the file is certified again when read.

Usage::

    python docs/gallery_fields.py --lss 0.4 --ratio 0.6 --h 0.2 --core 2/3 --rounds 8 \\
        --save docs/evidence/gallery_0.6_0.2_0.4_refined.npz

    python docs/gallery_fields.py --windings --ratio 0.6      # where the cores must fit

(how ``docs/evidence/fields/file_gallery_0.6_0.2_0.4_refined.npz`` was made: 5 rounds,
4,442 vertices, 24 CPU s). The core size is given exactly (``2/3``): the search is sensitive
to it (0.6667 instead of 2/3 moves some vertices in or out of the core, and the same search
ends with 104 failing triangles instead of 21).
"""

from __future__ import annotations

import argparse
import time
from fractions import Fraction

import numpy as np
import shapely

from tether.examples import load
from tether.game.certificate import FULL, first_field, lifted_ends
from tether.game.certified import CertifiedKernel
from tether.game.field_lp import solve_field, vortex_radius
from tether.game.kernel import surveillance_kernel
from tether.game.refine import refine_certified


def search(env, lss: float, vt: float, vo: float, h: float, core: float) -> CertifiedKernel:
    """The search of ``certified_kernel`` with the one core size ``core`` (units of
    ``vortex_radius``), in the map's normalized frame as there."""
    t0 = time.perf_counter()
    frame, space = env.frame, env.internal
    s = frame.scale
    kern = surveillance_kernel(space, lss * s, vt / vo, 1.0, h=h * s, orientations=180)
    f, checks, log = solve_field(space, kern, lss * s, vt / vo, 1.0, tries=(core,))
    return CertifiedKernel(env, lss, vt, vo, h, f, checks, log, time.perf_counter() - t0,
                           frame, space, 0.0)


def repair(ck: CertifiedKernel, rounds: int) -> CertifiedKernel:
    """Rounds of local refinement where ``ck`` fails, until it is certified (at most
    ``rounds``); each round's failing triangles go to stdout."""
    outer = surveillance_kernel(ck.env, ck.lss, ck.vt, ck.vo, h=ck.h, orientations=180,
                                scheme="outer")
    for k in range(rounds):
        if ck.certified:
            break
        ck = refine_certified(ck, outer, max_rounds=1, search_ring=2)
        print(f"round {k + 1}: {len(ck.field.points)} vertices, failing "
              f"{ck.checks.counts()}", flush=True)
    return ck


def windings(env, lss: float, vt: float, vo: float, h: float, merge: float = 0.6
              ) -> list[tuple[float, float, float]]:
    """Where the search's first field winds: ``(x, y, clear)`` per place (map units), the
    centroid of a whole-circle triangle whose gap centres wind (winding triangles closer than
    ``merge`` counted once) and its distance to the nearest wall."""
    s = env.frame.scale
    kern = surveillance_kernel(env.internal, lss * s, vt / vo, 1.0, h=h * s, orientations=180)
    f = first_field(kern)
    _, _, winds = lifted_ends(f.lo, f.w, f.tri)
    hot = winds & (f.w >= FULL)[f.tri].all(axis=1)
    cen = env.frame.to_user(f.points[f.tri[hot]].mean(axis=1))
    clear = shapely.distance(shapely.points(cen), env.polygon.boundary)
    out: list[tuple[float, float, float]] = []
    for (x, y), d in zip(cen, clear, strict=True):
        if all(np.hypot(x - a, y - b) > merge for a, b, _ in out):
            out.append((float(x), float(y), float(d)))
    return out


def winding_table(vt: float, sizes=((1.0, 0.25), (0.5, 0.25), (0.4, 0.2))) -> str:
    """Markdown rows: per ``(lss, h)``, the clear radius at the first field's windings and how
    many hold a core of the search's full and 2/3 size (``q·vortex_radius + lss``)."""
    env = load("gallery")
    rows = ["| lss | h | windings | clear radius there | full core fits | 2/3 core fits |",
            "| --- | --- | --- | --- | --- | --- |"]
    for lss, h in sizes:
        w = windings(env, lss, vt, 1.0, h)
        d = np.array([c for _, _, c in w])
        rv = vortex_radius(lss, vt, 1.0)
        full, two = (int((d >= q * rv + lss).sum()) for q in (1.0, 2 / 3))
        miss = [f"({x:.1f}, {y:.1f}) clear {c:.2f}" for x, y, c in w if c < 2 / 3 * rv + lss]
        no = ", ".join(miss) if len(miss) <= 3 else ""  # a few are named
        rows.append(f"| {lss:g} | {h:g} | {len(w)} | {d.min():.2f} to {d.max():.2f} | "
                    f"{full} of {len(w)} | {two} of {len(w)}{': not at ' + no if no else ''} |")
    return "\n".join(rows)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--lss", type=float, default=0.4, help="rod length (map units)")
    ap.add_argument("--ratio", type=float, default=0.6, help="vt/vo (vo = 1)")
    ap.add_argument("--h", type=float, default=0.2, help="mesh spacing (map units)")
    ap.add_argument("--core", default="2/3",
                    help="core size in units of vortex_radius, exactly (a fraction; 2/3)")
    ap.add_argument("--rounds", type=int, default=8, help="local refinement rounds at most")
    ap.add_argument("--save", help="write the field here (CertifiedKernel.save)")
    ap.add_argument("--windings", action="store_true",
                    help="print where the first field winds and which cores fit, only")
    args = ap.parse_args()
    if args.windings:
        print(winding_table(args.ratio))
        return
    c0, w0 = time.process_time(), time.perf_counter()
    env = load("gallery")
    ck = search(env, args.lss, args.ratio, 1.0, args.h, float(Fraction(args.core)))
    if ck.checks is None:
        raise SystemExit(f"no first field: {ck.log[-1]}")
    print(f"search: {len(ck.field.points)} vertices, failing {ck.checks.counts()}", flush=True)
    ck = repair(ck, args.rounds)
    cpu, wall = time.process_time() - c0, time.perf_counter() - w0
    print(f"certified {ck.certified}, {len(ck.field.points)} vertices, {cpu:.0f} CPU s, "
          f"{wall:.0f} s wall")
    if ck.certified:
        frac, err = ck.safe_fraction(20_000)
        print(f"certified share of the free states {100 * frac:.1f} ± {100 * err:.1f} %")
    if args.save:
        ck.save(args.save)


if __name__ == "__main__":
    main()
