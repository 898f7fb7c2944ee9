"""Speed of the surveillance kernel (issue #11): gallery map, growth with the grid.

For each grid (``h`` = map size / N, ``n_a`` orientations) the table gives the setup time (free
mask from the exact arcs, and the continuations of every move, computed once), the iteration
time, iterations, states per second per iteration (``states × iterations / iteration time``)
and the total. The goal: N = 100, 180 orientations under 30 s. The machine is shared: times
are noisy (say so when quoting them).

Usage::

    python benchmarks/bench_kernel.py [--ratio 0.6] [--lss 1]

``--office`` instead times the certified kernel on big maps (issue #22, "Speed"): the bundled
office at 0.05 m (lss 0.8) and ``floor_plan(20, seed=0)`` at 0.1 (lss 0.4), each searched on a
coarse mesh first, read on the fine one and repaired there in patches
(``certified_kernel(coarse_h=...)``, :mod:`tether.game.patches`). Each row runs in a child
process (its own peak memory), and ``--docs`` writes the table into ``docs/certified.md``
("Big maps")::

    python benchmarks/bench_kernel.py --office [--ratios 0.3,0.6] [--seconds 300] [--docs]
    python benchmarks/bench_kernel.py --office --rows ROWS.jsonl --docs  # a former run's rows
    python benchmarks/bench_kernel.py --office --lss 0.24 --coarse 0.1 --ratios 0.3 --maps office

(``--lss`` and ``--coarse`` replace the office's rod length and coarse spacing; ``--maps``
picks the rows.)
"""

from __future__ import annotations

import argparse
import json
import os
import re
import resource
import subprocess
import sys
import time
from pathlib import Path

from tether.examples import path as example_path
from tether.game import build_grid, surveillance_kernel
from tether.io import load_map

#: The big maps' rows: (name, lss, h, coarse h), map units.
BIG_MAPS = (("office", 0.8, 0.05, 0.2), ("floor_plan(20, seed=0)", 0.4, 0.1, 0.2))
_DOCS = Path(__file__).resolve().parents[1] / "docs" / "certified.md"
_BEGIN, _END = "<!-- bench_kernel --office: begin -->", "<!-- bench_kernel --office: end -->"


def _big_map(name: str):
    from tether.examples import load
    from tether.examples.floorplan import floor_plan

    return load("office", ".yaml") if name == "office" else floor_plan(20, seed=0)


def _one_big(name: str, ratio: float, seconds: float, save: str | None,
             lss: float | None = None, coarse: float | None = None) -> dict:
    """One row, in this process: the certified kernel of a big map, timed by stage (``lss``,
    ``coarse``: the office's rod length and coarse spacing instead of :data:`BIG_MAPS`')."""
    from tether.game.certified import certified_kernel

    lss0, h, coarse0 = next((b[1], b[2], b[3]) for b in BIG_MAPS if b[0] == name)
    lss = lss0 if lss is None or name != "office" else lss
    coarse = coarse0 if coarse is None or name != "office" else coarse
    env = _big_map(name)
    t0, c0 = time.perf_counter(), time.process_time()
    ck = certified_kernel(env, lss, ratio, 1.0, h=h, coarse_h=coarse, repair_seconds=seconds)
    wall, cpu = time.perf_counter() - t0, time.process_time() - c0
    first = ck.log[0]["coarse"]
    passes = [e for e in ck.log[1:] if "pass" in e]
    row = {"map": name, "lss": lss, "vt/vo": ratio, "h": h, "coarse h": coarse,
           "vertices": len(ck.field.points), "triangles": len(ck.field.tri),
           "coarse failing": first["failing"], "first failing": first["fine_failing"],
           "failing": int(ck.checks.bad.sum()), "certified": ck.certified,
           "safe %": 100 * ck.safe_fraction(samples=20_000)[0] if ck.certified else 0.0,
           "t coarse kernel": first["t_kernel"], "t coarse search": first["t_search"],
           "t fine mesh": first["t_mesh"],
           "t patches": passes[-1]["seconds"] if passes else 0.0,
           "patches": sum(e["patches"] for e in passes), "wall s": wall, "cpu s": cpu,
           "peak MB": resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024,
           "load": os.getloadavg()[0]}
    if save and ck.certified:
        ck.save(save)
    return row


_COLS = (("map", "{}"), ("lss", "{:g}"), ("vt/vo", "{:g}"), ("h", "{:g}"), ("coarse h", "{:g}"),
         ("triangles", "{:,}"), ("coarse failing", "{:,}"), ("first failing", "{:,}"),
         ("failing", "{:,}"), ("safe %", "{:.1f}"), ("t coarse search", "{:.0f}"),
         ("t fine mesh", "{:.0f}"), ("t patches", "{:.0f}"), ("wall s", "{:.0f}"),
         ("cpu s", "{:.0f}"), ("peak MB", "{:,.0f}"), ("load", "{:.1f}"))


def _table(rows: list[dict]) -> str:
    head = "| " + " | ".join(c for c, _ in _COLS) + " |"
    rule = "|" + "|".join("---" if c == "map" else "---:" for c, _ in _COLS) + "|"
    body = ["| " + " | ".join(f.format(r[c]) if r[c] is not None else "–" for c, f in _COLS)
            + " |" for r in rows]
    return "\n".join([head, rule, *body])


def big_maps(ratios: list[float], seconds: float, docs: bool, save: str | None,
             rows_file: str | None = None, maps: tuple[str, ...] | None = None,
             extra: tuple[str, ...] = ()) -> None:
    """Every big map (of ``maps``; default all) at every ratio, each in a child process (or
    the rows a former run wrote to ``rows_file``, one JSON object a line: its stderr); the
    table printed (and written into the docs with ``docs``). ``extra``: more arguments for
    the children (``--lss``, ``--coarse``)."""
    rows = []
    if rows_file is not None:
        rows = [json.loads(line) for line in Path(rows_file).read_text().splitlines()
                if line.startswith("{")]
    for name, _, h, _ in BIG_MAPS if rows_file is None else ():
        if maps is not None and name.split("(")[0] not in maps:
            continue
        for ratio in ratios if name == "office" else [0.3]:
            out = subprocess.run(
                [sys.executable, __file__, "--one", name, str(ratio), "--seconds", str(seconds),
                 *extra]
                + (["--save", save.format(map=name.split("(")[0], ratio=ratio, h=h)] if save
                   else []), capture_output=True, text=True, check=True)
            rows.append(json.loads(out.stdout.strip().splitlines()[-1]))
            print(json.dumps(rows[-1]), file=sys.stderr, flush=True)
    table = _table(rows)
    print(table)
    if docs:
        text = _DOCS.read_text()
        block = f"{_BEGIN}\n{table}\n{_END}"
        new = re.sub(re.escape(_BEGIN) + ".*?" + re.escape(_END), lambda _: block, text,
                     flags=re.S)
        if new == text and block not in text:
            raise SystemExit(f"no {_BEGIN} ... {_END} block in {_DOCS}")
        _DOCS.write_text(new)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--ratio", type=float, default=0.6, help="vt/vo (vo = 1)")
    ap.add_argument("--lss", type=float,
                    help="rod length (default 1; with --office: the office's, default 0.8)")
    ap.add_argument("--coarse", type=float,
                    help="with --office: the office's coarse mesh spacing (default 0.2)")
    ap.add_argument("--maps", help="with --office: comma-separated rows (office, floor_plan)")
    ap.add_argument("--grids", default="50:90,100:180,141:256",
                    help="comma-separated N:n_a (h = size/N)")
    ap.add_argument("--office", action="store_true",
                    help="the certified kernel on the big maps instead (module docstring)")
    ap.add_argument("--ratios", default="0.3,0.6", help="with --office: the office's vt/vo")
    ap.add_argument("--seconds", type=float, default=300.0,
                    help="with --office: the patches' budget per map, seconds")
    ap.add_argument("--docs", action="store_true",
                    help="with --office: write the table into docs/certified.md")
    ap.add_argument("--save", help="with --office: save each certified field to this path "
                                   "(format keys {map}, {ratio} and {h})")
    ap.add_argument("--rows", help="with --office: the table from the rows a former run "
                                   "printed on stderr (no run)")
    ap.add_argument("--one", nargs=2, metavar=("MAP", "RATIO"), help=argparse.SUPPRESS)
    args = ap.parse_args()
    if args.one:
        print(json.dumps(_one_big(args.one[0], float(args.one[1]), args.seconds, args.save,
                                  args.lss, args.coarse)))
        return
    if args.office:
        extra = [*(["--lss", str(args.lss)] if args.lss is not None else []),
                 *(["--coarse", str(args.coarse)] if args.coarse is not None else [])]
        big_maps([float(r) for r in args.ratios.split(",")], args.seconds, args.docs,
                 args.save, args.rows, tuple(args.maps.split(",")) if args.maps else None,
                 tuple(extra))
        return
    args.lss = 1.0 if args.lss is None else args.lss
    env = load_map(example_path("gallery"))
    x0, y0, x1, y1 = env.bounds
    size = max(x1 - x0, y1 - y0)
    print(f"gallery, lss {args.lss:g}, vt/vo {args.ratio:g}, scheme inner, 8 directions")
    print(f"{'N':>5} {'n_a':>5} {'states':>10} {'free':>10} {'setup s':>8} {'iter s':>8} "
          f"{'iters':>6} {'states/s/iter':>14} {'total s':>8} {'safe %':>7}")
    for spec in args.grids.split(","):
        n, n_a = (int(x) for x in spec.split(":"))
        t0 = time.perf_counter()
        grid = build_grid(env, args.lss, size / n, n_a)
        grid.continuations(8)  # cached on the grid: the kernel below only iterates
        t_setup = time.perf_counter() - t0
        k = surveillance_kernel(env, args.lss, args.ratio, 1.0, grid=grid)
        t_iter = max(k.seconds, 1e-9)
        rate = k.states * k.iterations / t_iter
        print(f"{n:>5} {n_a:>5} {k.states:>10} {k.free_states:>10} {t_setup:>8.2f} "
              f"{t_iter:>8.2f} {k.iterations:>6} {rate:>14.3g} {t_setup + k.seconds:>8.2f} "
              f"{100 * k.safe_fraction_total():>7.2f}")


if __name__ == "__main__":
    main()
