"""Regenerate the evidence tables of ``docs/certified.md`` (between its ``certified_table``
markers): per bundled map and speed ratio, whether the certified kernel exists, the share of
free states it holds beside the conservative and optimistic grid kernels, its time, and the
certified controller's runs from certified starts against every target kind (the simulator's
monitor on).

Usage::

    python docs/certified_table.py            # rewrites the examples and the table
    python docs/certified_table.py --quick    # one ratio, fewer runs, prints only
    python docs/certified_table.py --starts 48 --workers 2 --skip gallery:0.6 --skip gallery:0.9
    python docs/certified_table.py --only convex_corner:0.3   # one row again, the rest kept
    python docs/certified_table.py --only gallery:0.3 --starts 0 --print-only  # a check
    python docs/certified_table.py --field-file docs/evidence/fields/file_STEM.npz --starts 48

``--field-file`` adds (or replaces) the row of a certified field saved with
``CertifiedKernel.save`` (a rod length other than 1, a refined mesh): the field is read and
certified again (its *seconds* are those checks), the grid kernels are computed at its own
``lss`` and spacing, and the runs start from it; every other row is kept.

The last is how the table in the docs was made: 48 random certified starts per target kind
and row (336 runs a row), on two processes, about half an hour on the shared 2-core machine.
"""

from __future__ import annotations

import argparse
import re
import time
from pathlib import Path

import numpy as np

from tether.examples import path as example_path
from tether.game import surveillance_kernel
from tether.game.certified import certified_kernel, load_certified
from tether.game.controller import CertifiedController
from tether.io import load_map
from tether.sim.protocols import World
from tether.sim.simulate import simulate
from tether.strategies import TARGETS, make_target

DOCS = Path(__file__).resolve().parent
#: The maps and their mesh spacing (map units): the gallery needs a finer mesh than size/40 at
#: 0.3; convex_corner's corridors are exactly lss wide.
MAPS = {"nonconvex_corner": 0.25, "convex_corner": 0.25, "gallery": 0.25}
RATIOS = (0.3, 0.6, 0.9)
KINDS = tuple(sorted(set(TARGETS) - {"path", "track", "pedestrian"}))
LSS, VO = 1.0, 1.0
BEGIN, END = "<!-- certified_table: begin -->", "<!-- certified_table: end -->"
HEADER = ("| map | vt/vo | lss | mesh h | certified | certified % | inner kernel % | "
          "outer kernel % | seconds | runs from certified starts | lost | states outside |")
RULE = "| --- | --- | --- | --- | --- | --- | --- | --- | --- | --- | --- | --- |"


def field_starts(ck, n: int, rng) -> tuple[np.ndarray, np.ndarray]:
    """``n`` random certified states: uniform free points, uniform places in their arcs."""
    x0, y0, x1, y1 = ck.env.bounds
    pts = rng.uniform([x0, y0], [x1, y1], size=(20 * n, 2))
    lo, hi, ok = ck.arcs(pts)
    pts, lo, hi = pts[ok][:n], lo[ok][:n], hi[ok][:n]
    return pts, lo + rng.uniform(0.0, 1.0, len(pts)) * (hi - lo)


_CK = None  # the kernel the forked workers run from (set before the pool is made)


def _one_run(task: tuple) -> tuple[bool, int]:
    """(held, sampled states outside the field) of one run: ``task`` is (kind, x, y, a, seed,
    seconds)."""
    kind, x, y, a, seed, seconds = task
    ck = _CK
    world = World(ck.env, lss=ck.lss, vt=ck.vt, vo=ck.vo)
    world.extra["certified"] = ck
    res = simulate(world, CertifiedController(), make_target(kind, world), (x, y, a),
                   duration=seconds, dt=0.02, seed=seed)
    return bool(res.held), int((ck.margin(res.trace.p, res.trace.a) < -1e-9).sum())


def runs(ck, starts: int, seconds: float, rng, workers: int = 1) -> tuple[int, int, int]:
    """(runs, lost, sampled states outside the field) of the certified controller from
    ``starts`` certified states per target kind, against every target kind, on ``workers``
    forked processes."""
    global _CK
    _CK = ck
    tasks = []
    for k, kind in enumerate(KINDS):
        pts, a = field_starts(ck, starts, rng)
        tasks += [(kind, float(pts[i, 0]), float(pts[i, 1]), float(a[i]), 1000 * k + i, seconds)
                  for i in range(len(pts))]
    if workers > 1:
        import multiprocessing
        from concurrent.futures import ProcessPoolExecutor

        with ProcessPoolExecutor(workers, mp_context=multiprocessing.get_context("fork")) as ex:
            out = list(ex.map(_one_run, tasks, chunksize=4))
    else:
        out = [_one_run(t) for t in tasks]
    return len(out), sum(not held for held, _ in out), sum(n for _, n in out)


def table(maps, ratios, starts: int, seconds: float, skip: frozenset = frozenset(),
          workers: int = 1, only: frozenset = frozenset(), old: str = "") -> str:
    """The markdown rows (``skip``: ``(map, ratio)`` pairs left out, each given a row that
    says so; ``only``: when not empty, the pairs computed, every other row copied from the
    table ``old``)."""
    kept = _rows_of(old)
    rows = [HEADER, RULE]
    rng = np.random.default_rng(0)
    for name, h in maps.items():
        env = load_map(example_path(name))
        for ratio in ratios:
            key = (name, ratio, LSS)
            if only and (name, ratio) not in only and key in kept:
                rows.append(kept.pop(key))
                continue
            kept.pop(key, None)
            if (name, ratio) in skip:
                rows.append(f"| {name} | {ratio:g} | {LSS:g} | {h:g} | not run (`--skip`) "
                            f"| | | | | | | |")
                continue
            t0 = time.perf_counter()
            ck = certified_kernel(env, LSS, ratio * VO, VO, h=h)
            rows.append(row(ck, time.perf_counter() - t0, starts, seconds, rng, workers))
            print(rows[-1], flush=True)
    rows += kept.values()  # the rows of field files, kept as they were
    return "\n".join(rows)


def row(ck, secs: float, starts: int, seconds: float, rng, workers: int = 1) -> str:
    """One row of the table for the certified kernel ``ck`` (``secs``: its time), the grid
    kernels computed at its rod length, speeds and spacing."""
    env, lss, vt, vo = ck.env, ck.lss, ck.vt, ck.vo
    inner = surveillance_kernel(env, lss, vt, vo, h=ck.h).safe_fraction_total()
    outer = surveillance_kernel(env, lss, vt, vo, h=ck.h, scheme="outer").safe_fraction_total()
    if ck.certified:
        frac, err = ck.safe_fraction(samples=50_000)
        n, lost, out = runs(ck, starts, seconds, rng, workers)
        cells = (f"yes | {100 * frac:.1f} ± {100 * err:.1f}", f"{n}", f"{lost}", f"{out}")
    else:
        if ck.checks is None:  # the grid kernel leaves some vertex no orientation
            why = f"no first field: {ck.log[-1].get('closed_arcs', '?')} closed arcs"
        else:
            why = f"{int(ck.checks.bad.sum())} triangles fail"
        cells = (f"no ({why}) | 0", "—", "—", "—")
    mesh = f"{ck.h:g} refined" if ck.refined else f"{ck.h:g}"
    return (f"| {ck.env.name} | {vt / vo:g} | {lss:g} | {mesh} | {cells[0]} | "
            f"{100 * inner:.1f} | {100 * outer:.1f} | {secs:.0f} | {cells[1]} | {cells[2]} | "
            f"{cells[3]} |")


def file_rows(paths: list[str], starts: int, seconds: float, old: str, workers: int = 1
              ) -> str:
    """The table ``old`` with a row for each saved field of ``paths`` (read and certified
    again; a row of the same map, ratio and lss replaced, else added at the end)."""
    kept = _rows_of(old)
    rng = np.random.default_rng(0)
    for p in paths:
        t0 = time.perf_counter()
        ck = load_certified(p)
        line = row(ck, time.perf_counter() - t0, starts, seconds, rng, workers)
        print(line, flush=True)
        kept[(ck.env.name, round(ck.vt / ck.vo, 6), ck.lss)] = line
    return "\n".join([HEADER, RULE, *kept.values()])


def _rows_of(text: str) -> dict:
    """The rows of the table in ``text`` (between its markers), by ``(map, ratio, lss)``, in
    their order (a row of the table before its ``lss`` column gets ``lss`` = 1)."""
    m = re.search(re.escape(BEGIN) + "(.*?)" + re.escape(END), text, flags=re.S)
    rows = {}
    for line in (m.group(1).splitlines() if m else []):
        cells = [c.strip() for c in line.strip().strip("|").split("|")]
        if len(cells) < 3 or cells[0] in ("map", "---"):
            continue
        if len(cells) == 11:  # no lss column yet: every such row has lss = 1
            cells.insert(2, f"{LSS:g}")
        rows[(cells[0], float(cells[1]), float(cells[2]))] = "| " + " | ".join(cells) + " |"
    return rows


def examples(text: str) -> str:
    """``text`` with its checked console examples regenerated (``docs/make_docs.py``)."""
    import importlib.util

    spec = importlib.util.spec_from_file_location("make_docs", DOCS / "make_docs.py")
    make_docs = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(make_docs)
    return make_docs.render(text)[0]


def figure() -> None:
    """``docs/figures/certified_nonconvex_corner.png``: slices of the certified answer on the
    10 x 10 room at vt/vo = 0.3."""
    from tether.plot import certified_figure, save

    env = load_map(example_path("nonconvex_corner"))
    ck = certified_kernel(env, LSS, 0.3, VO, h=0.25)
    outer = surveillance_kernel(env, LSS, 0.3, VO, h=0.25, scheme="outer")
    save(certified_figure(ck, outer), DOCS / "figures" / "certified_nonconvex_corner.png")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true", help="0.3 only, 2 starts, print only")
    ap.add_argument("--skip", action="append", default=[], metavar="MAP:RATIO",
                    help="leave out one row (its cell says so); repeatable")
    ap.add_argument("--starts", type=int, default=6,
                    help="random certified starts per target kind and row (default 6)")
    ap.add_argument("--workers", type=int, default=1,
                    help="processes for the runs (forked; default 1)")
    ap.add_argument("--only", action="append", default=[], metavar="MAP:RATIO",
                    help="recompute only this row, copy the others from the docs' table (and "
                         "leave the examples and the figure); repeatable")
    ap.add_argument("--print-only", action="store_true",
                    help="with --only: print the rows, write nothing (a quick check)")
    ap.add_argument("--field-file", action="append", default=[], metavar="PATH",
                    help="add (or replace) the row of a saved certified field, keep the rest; "
                         "repeatable")
    args = ap.parse_args()
    skip = frozenset((m, float(r)) for m, r in (x.split(":") for x in args.skip))
    only = frozenset((m, float(r)) for m, r in (x.split(":") for x in args.only))
    if args.quick:
        table(MAPS, (0.3,), 2, 5.0)
        return
    doc = DOCS / "certified.md"
    if args.field_file:
        text = doc.read_text()
        body = file_rows(args.field_file, args.starts, 15.0, text, args.workers)
        if args.print_only:
            return
    elif only:
        text = doc.read_text()
        body = table(MAPS, RATIOS, args.starts, 15.0, skip, args.workers, only, text)
        if args.print_only:
            return
    else:
        figure()
        body = table(MAPS, RATIOS, args.starts, 15.0, skip, args.workers)
        text = examples(doc.read_text())
    new = re.sub(re.escape(BEGIN) + ".*?" + re.escape(END), lambda m: f"{BEGIN}\n{body}\n{END}",
                 text, flags=re.S)
    doc.write_text(new)


if __name__ == "__main__":
    main()
