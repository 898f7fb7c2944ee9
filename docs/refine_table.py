"""Regenerate the adaptive-refinement table of ``docs/certified.md`` (between its
``refine_table`` markers): per bundled map and speed ratio, the certified kernel on the uniform
mesh at two spacings and on the coarser one refined where its band is
(:func:`tether.game.refine.refine_certified`), with the band against the optimistic grid
kernel on the coarse lattice, the mesh's size, the time and the contradictions; and the
certified controller's runs from random certified starts of each refined field against every
target kind, with the simulator's monitor on (``docs/certified_table.py``'s runs).

Usage::

    python docs/refine_table.py                          # rewrites the table
    python docs/refine_table.py --only gallery:0.3       # that row group only
    python docs/refine_table.py --quick                  # the room at 0.3, one round, prints
    python docs/refine_table.py --only nonconvex_corner:0.3 --whole  # and the LP everywhere

The refined row widens the field by the LP local to the split triangles (one ring around
them, :data:`tether.game.refine.RING`); ``--whole`` adds a row refined the same way with the
LP over the whole mesh every round (``ring=None``, the search before issue #22's local LP),
for the time and band it costs.

The docs are written after every map and ratio, each round's band on stderr.

Takes about half an hour on the shared 2-core machine.
"""

from __future__ import annotations

import argparse
import importlib.util
import sys
import time
from pathlib import Path

import numpy as np

from tether.examples import path as example_path
from tether.game import surveillance_kernel
from tether.game.band import undecided_band
from tether.game.certified import certified_kernel
from tether.game.refine import refine_certified
from tether.io import load_map

DOCS = Path(__file__).resolve().parent
#: (map, vt/vo, coarse spacing, fine spacing or None, refinement rounds).
ROWS = (("nonconvex_corner", 0.3, 0.5, 0.25, 3),
        ("nonconvex_corner", 0.6, 0.5, 0.25, 3),
        ("gallery", 0.3, 0.4, None, 3))
LSS, VO = 1.0, 1.0
BEGIN, END = "<!-- refine_table: begin -->", "<!-- refine_table: end -->"


def _certified_table():
    """``docs/certified_table.py`` as a module (its runs from certified starts)."""
    spec = importlib.util.spec_from_file_location("certified_table", DOCS / "certified_table.py")
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod


def _cells(name: str, ratio: float, mesh: str, ck, outer, secs: float) -> str:
    """One markdown row of the band of ``ck`` against ``outer``."""
    b = undecided_band(ck, outer)
    yes = "yes" if ck.certified else f"no ({int(ck.checks.bad.sum())} triangles fail)" \
        if ck.checks is not None else "no"
    pct = 100 / max(b.free_states, 1)
    return (f"| {name} | {ratio:g} | {mesh} | {yes} | {len(ck.field.points):,} | "
            f"{pct * b.certified_states:.1f} | {pct * b.undecided_states:.1f} | "
            f"{b.reach:.2f} | {b.reach_95:.2f} | {b.contradictions} | {secs:.0f} |")


BAND_HEAD = ("| map | vt/vo | mesh | certified | vertices | certified % | undecided % | reach | "
             "reach (95 %) | contradictions | seconds |\n"
             "| --- | --- | --- | --- | --- | --- | --- | --- | --- | --- | --- |")
RUN_HEAD = ("| map | vt/vo | mesh | runs from certified starts | lost | states outside |\n"
            "| --- | --- | --- | --- | --- | --- |")


def group(name: str, ratio: float, h: float, fine, rounds: int, starts: int, seconds: float,
          workers: int, rng, whole: bool = False) -> tuple[list[str], list[str]]:
    """The band rows and the runs row of one map and ratio (``whole``: and the refined row
    with the LP over the whole mesh)."""
    ct = _certified_table()
    band, run = [], []
    env = load_map(example_path(name))
    outer = surveillance_kernel(env, LSS, ratio * VO, VO, h=h, scheme="outer")
    t0 = time.perf_counter()
    ck = certified_kernel(env, LSS, ratio * VO, VO, h=h)
    band.append(_cells(name, ratio, f"uniform h = {h:g}", ck, outer, time.perf_counter() - t0))
    print(band[-1], flush=True)
    if fine is not None:
        t0 = time.perf_counter()
        fk = certified_kernel(env, LSS, ratio * VO, VO, h=fine)
        band.append(_cells(name, ratio, f"uniform h = {fine:g}", fk, outer,
                           time.perf_counter() - t0))
        print(band[-1], flush=True)
    t0 = time.perf_counter()
    rk = refine_certified(ck, outer, max_rounds=rounds,
                          progress=lambda e: print(f"  {name} {ratio:g}: {e}", file=sys.stderr,
                                                   flush=True))
    secs = ck.seconds + time.perf_counter() - t0
    band.append(_cells(name, ratio, f"h = {h:g} refined, {rk.refined} rounds", rk, outer, secs))
    print(band[-1], flush=True)
    if whole:
        t0 = time.perf_counter()
        wk = refine_certified(ck, outer, max_rounds=rounds, ring=None)
        secs = ck.seconds + time.perf_counter() - t0
        band.append(_cells(name, ratio, f"h = {h:g} refined, {wk.refined} rounds, LP on the "
                           "whole mesh", wk, outer, secs))
        print(band[-1], flush=True)
    if rk.certified and starts:
        n, lost, out = ct.runs(rk, starts, seconds, rng, workers)
        run.append(f"| {name} | {ratio:g} | h = {h:g} refined, {rk.refined} rounds | {n} | "
                   f"{lost} | {out} |")
        print(run[-1], flush=True)
    return band, run


def _key(line: str) -> tuple[str, float] | None:
    """(map, ratio) of a table row, None for a header or another line."""
    cells = [c.strip() for c in line.strip().strip("|").split("|")]
    try:
        return cells[0], float(cells[1])
    except (IndexError, ValueError):
        return None


def write(doc: Path, new: dict, starts: int) -> None:
    """Put the rows of ``new`` ({(map, ratio): (band rows, runs rows)}) into ``doc``'s block,
    keeping the rows of the other maps and ratios already there, in :data:`ROWS`' order."""
    text = doc.read_text()
    if BEGIN not in text:
        raise SystemExit(f"{doc} has no {BEGIN} marker")
    old = text[text.index(BEGIN) + len(BEGIN):text.index(END)]
    parts = old.split("\n\n")
    groups: dict = {}
    for i, part in enumerate((parts[0], parts[-1]) if len(parts) > 1 else ()):
        for line in part.splitlines():
            k = _key(line)
            if k is not None:
                groups.setdefault(k, ([], []))[i].append(line)
    groups.update(new)
    order = [(m, r) for m, r, *_ in ROWS]
    keys = sorted(groups, key=lambda k: order.index(k) if k in order else len(order))
    band = "\n".join([BAND_HEAD] + [x for k in keys for x in groups[k][0]])
    run = "\n".join([RUN_HEAD] + [x for k in keys for x in groups[k][1]])
    body = (f"{band}\n\nThe certified controller from random certified starts of each refined "
            f"field ({starts} per target kind, 15 s at `dt` = 0.02 s, the monitor on):\n\n"
            f"{run}")
    doc.write_text(text[:text.index(BEGIN) + len(BEGIN)] + f"\n{body}\n" + text[text.index(END):])


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true",
                    help="the room at 0.3, one round, no runs, print only")
    ap.add_argument("--only", action="append", default=[], metavar="MAP:RATIO",
                    help="regenerate only these rows (the others in the docs are kept); "
                         "repeatable")
    ap.add_argument("--starts", type=int, default=4,
                    help="random certified starts per target kind and refined field (default 4)")
    ap.add_argument("--whole", action="store_true",
                    help="also refine with the LP over the whole mesh every round (a row more)")
    ap.add_argument("--workers", type=int, default=1,
                    help="processes for the runs (forked; default 1)")
    args = ap.parse_args()
    if args.quick:
        group("nonconvex_corner", 0.3, 0.5, None, 1, 0, 5.0, 1, np.random.default_rng(0))
        return
    only = {(m, float(r)) for m, r in (x.split(":") for x in args.only)}
    for i, (name, ratio, h, fine, rounds) in enumerate(ROWS):
        if only and (name, ratio) not in only:
            continue
        rows = group(name, ratio, h, fine, rounds, args.starts, 15.0, args.workers,
                     np.random.default_rng(i), args.whole)  # same starts whatever runs
        write(DOCS / "certified.md", {(name, ratio): rows}, args.starts)


if __name__ == "__main__":
    main()
