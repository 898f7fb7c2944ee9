"""Regenerate the delay table of ``docs/certified.md`` (between its ``delay_table`` markers):
on the 10 x 10 room (``nonconvex_corner``), per speed ratio and sensing delay, whether the
certified kernel exists, the share of free states it holds (:func:`tether.sweep.delay_sweep`,
which reuses a field certified at a longer delay where it passes the checks), and the certified
controller's runs with that delay from certified starts against every target kind (the
simulator's monitor on: the true line of sight, the chord and the distance within
``lss ± vt·delay``).

Usage::

    python docs/delay_table.py                     # 0.3, delays 0:0.5:0.1, rewrites the table
    python docs/delay_table.py --ratios 0.3 0.6    # also 0.6 (its kernel takes minutes)
    python docs/delay_table.py --quick             # two delays, one start, prints only
"""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np
from doc_tables import write_between  # docs/, next to this script

from tether.examples import path as example_path
from tether.game.controller import CertifiedController
from tether.io import load_map
from tether.sim.protocols import World
from tether.sim.simulate import simulate
from tether.strategies import TARGETS, make_target
from tether.sweep import delay_sweep

DOCS = Path(__file__).resolve().parent
MAP, H = "nonconvex_corner", 0.25
KINDS = tuple(sorted(set(TARGETS) - {"path", "track", "pedestrian"}))
LSS, VO, DT = 1.0, 1.0, 0.02
BEGIN, END = "<!-- delay_table: begin -->", "<!-- delay_table: end -->"


def runs(ck, delay: float, starts: int, seconds: float, rng) -> tuple[int, int, int]:
    """(runs, lost, sampled seen states outside the field) of the certified controller with
    ``delay`` from ``starts`` certified states per target kind."""
    world = World(ck.env, lss=ck.lss, vt=ck.vt, vo=ck.vo)
    world.extra["certified"] = ck
    total = lost = outside = 0
    x0, y0, x1, y1 = ck.env.bounds
    for k, kind in enumerate(KINDS):
        pts = rng.uniform([x0, y0], [x1, y1], size=(50 * starts, 2))
        lo, hi, ok = ck.arcs(pts)
        pts, lo, hi = pts[ok][:starts], lo[ok][:starts], hi[ok][:starts]
        a = lo + rng.uniform(0.0, 1.0, len(pts)) * (hi - lo)
        for i in range(len(pts)):
            res = simulate(world, CertifiedController(), make_target(kind, world),
                           (float(pts[i, 0]), float(pts[i, 1]), float(a[i])),
                           duration=seconds, dt=DT, seed=1000 * k + i, delay=delay)
            total += 1
            lost += not res.held
            seen = res.trace.seen if res.trace.seen is not None else res.trace.p
            outside += int((ck.margin(seen, res.trace.a) < -1e-9).sum())
    return total, lost, outside


def table(ratios, delays, starts: int, seconds: float) -> str:
    """The markdown table (and each row printed as it is made)."""
    env = load_map(example_path(MAP))
    head = ("| vt/vo | delay s | vt·delay | certified | certified % | field | seconds | "
            "runs from certified starts | lost | seen states outside |")
    lines = [head, "| " + " | ".join(["---"] * 10) + " |"]
    print(head, flush=True)
    for ratio in ratios:
        vt = ratio * VO
        res = delay_sweep(env, LSS, vt, VO, delays, h=H)
        for row, ck in zip(res.rows, res.kernels, strict=True):
            if row.certified:
                d = row.delay
                src = row.source if row.source == "search" else f"that of {row.source}"
                total, lost, out = runs(ck, d, starts, seconds,
                                        np.random.default_rng(int(1000 * (ratio + d))))
                cells = [f"{100 * row.safe_fraction:.1f} ± {100 * row.error:.1f}", src,
                         f"{row.seconds:.0f}", str(total), str(lost), str(out)]
            else:
                cells = ["0", "—", f"{row.seconds:.0f}", "—", "—", "—"]
            line = (f"| {ratio:g} | {row.delay:g} | {vt * row.delay:.3g} | "
                    f"{'yes' if row.certified else 'no'} | " + " | ".join(cells) + " |")
            lines.append(line)
            print(line, flush=True)
    return "\n".join(lines)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--ratios", type=float, nargs="+", default=[0.3])
    ap.add_argument("--delays", default="0:0.5:0.1", help="START:STOP:STEP seconds")
    ap.add_argument("--quick", action="store_true", help="two delays, one start, print only")
    args = ap.parse_args()
    from tether.sweep import parse_lss_range

    if args.quick:
        table(args.ratios, [0.0, 0.5], 1, 3.0)
        return
    body = table(args.ratios, parse_lss_range(args.delays), 3, 15.0)
    write_between(DOCS / "certified.md", BEGIN, END, body)


if __name__ == "__main__":
    main()
