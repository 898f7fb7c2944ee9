"""Speed of the certified kernel (issue #22): where the time goes, against the conservative grid
kernel on the same lattice.

For each mesh spacing (``h`` = map size / N) the table gives the grid kernel (``inner``, 180
orientations: the certified search starts from it), the first field, the LP rounds (count and
time; the first rounds of core sizes the search did not go on with included) and the exact
checks, the mesh's size, whether the field is certified and the total. The
search's time is split into the free windows (blocked spans and their windows), the LP
(HiGHS), the end rows (their bounds and the cutting planes) and the checks (``certify``); the
total is also given in CPU seconds of this process, and its ratio to the ``inner`` kernel's
CPU seconds (the machine is shared: wall times are noisy, say so and give the load average
when quoting them). The issue's goal: within 3x the
``inner`` scheme's time on the gallery at N = 100.

With ``--doc docs/kernel.md`` the table is also written, as Markdown with the load average
before and after, between the ``<!-- bench_certified: begin -->`` and ``end`` markers of that
file (the speed section of ``docs/kernel.md`` is regenerated this way, not typed).

Usage::

    python benchmarks/bench_certified.py [--map gallery] [--ratio 0.3] [--sizes 40,60,100]
                                         [--doc docs/kernel.md]
"""

from __future__ import annotations

import argparse
import os
import re
import time
from pathlib import Path

from tether.examples import path as example_path
from tether.game import surveillance_kernel
from tether.game.certificate import first_field
from tether.game.field_lp import PLATEAU_ROUNDS, RELEASE_ROUNDS, solve_field
from tether.io import load_map


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--map", default="gallery", help="a bundled example's name")
    ap.add_argument("--ratio", type=float, default=0.3, help="vt/vo (vo = 1)")
    ap.add_argument("--lss", type=float, default=1.0)
    ap.add_argument("--sizes", default="40,60,100", help="comma-separated N (h = size/N)")
    ap.add_argument("--plateau", type=int, default=PLATEAU_ROUNDS,
                    help="rounds without progress that stop a try (0: the stall only)")
    ap.add_argument("--release-rounds", type=int, default=RELEASE_ROUNDS,
                    help="rounds within which a release of core vertices must pay, else the "
                         "try ends (0: no such limit)")
    ap.add_argument("--h", type=float, default=None,
                    help="one mesh spacing (map units) instead of --sizes")
    ap.add_argument("--doc", default=None,
                    help="a Markdown file whose bench_certified block gets the table")
    args = ap.parse_args()
    load0 = os.getloadavg()[0]
    rows = []
    env = load_map(example_path(args.map))
    x0, y0, x1, y1 = env.bounds
    size = max(x1 - x0, y1 - y0)
    frame, space = env.frame, env.internal  # the frame certified_kernel works in
    lss, vt, vo = args.lss * frame.scale, args.ratio, 1.0
    print(f"{args.map}, lss {args.lss:g}, vt/vo {args.ratio:g}")
    print(f"{'N':>5} {'vertices':>9} {'inner s':>8} {'first s':>8} {'LP rounds':>10} "
          f"{'search s':>9} {'windows':>8} {'LP':>8} {'ends':>8} {'checks':>8} "
          f"{'certified':>10} {'total s':>8} {'x inner':>8} {'cpu s':>8} {'x cpu':>6}")
    sizes = [size / args.h] if args.h else [int(x) for x in args.sizes.split(",")]
    for n in sizes:
        h = size / n * frame.scale
        n = round(n)
        c0 = time.process_time()
        t0 = time.perf_counter()
        kern = surveillance_kernel(space, lss, vt, vo, h=h, orientations=180)
        t1 = time.perf_counter()
        cpu_inner = time.process_time() - c0
        f0 = first_field(kern)
        t2 = time.perf_counter()
        f, checks, log = solve_field(space, kern, lss, vt, vo, plateau=args.plateau,
                                     release_rounds=args.release_rounds)
        t3 = time.perf_counter()
        cpu = time.process_time() - c0
        # the first LP rounds of core sizes that were not run on (solve_field's probes)
        probes = [q for e in log for q in e.get("probes_not_run", [])]
        rounds = sum(e.get("rounds", 0) for e in log) + len(probes)
        split = [sum(e.get(key, 0.0) for e in log + probes)
                 for key in ("t_windows", "t_lp", "t_ends", "t_certify")]
        ok = checks is not None and checks.passed
        total = t3 - t0
        # solve_field makes its own first field: the search time is net of it
        rows.append([n, f"{len(f0.points):,}", f"{t1 - t0:.1f}", rounds,
                     f"{t3 - t2 - (t2 - t1):.1f}"]
                    + [f"{x:.1f}" for x in split]
                    + ["yes" if ok else "no", f"{total:.1f}", f"{total / (t1 - t0):.1f}",
                       f"{cpu:.1f}", f"{cpu / cpu_inner:.1f}"])
        print(f"{n:>5} {len(f0.points):>9} {t1 - t0:>8.2f} {t2 - t1:>8.2f} {rounds:>10} "
              f"{t3 - t2 - (t2 - t1):>9.2f} "
              + " ".join(f"{x:>8.2f}" for x in split)
              + f" {str(ok):>10} {total:>8.2f} {total / (t1 - t0):>8.1f} {cpu:>8.2f}"
              f" {cpu / cpu_inner:>6.1f}",
              flush=True)
        for e in log:  # one line per try of the search: its core size and how it ended
            if "rounds" in e:
                first = f", first slack {e['first_slack']:.4g}" if "first_slack" in e else ""
                print(f"      core {e['core']:.2f}: {e['rounds']} rounds{first}, slack "
                      f"{e['slack']:.4g}, {e['releases']} releases, {e['failing']} failing, "
                      f"stuck at "
                      f"{e.get('stuck') or '-'}{', kept' if e.get('kept') else ''}",
                      flush=True)
        for q in probes:
            print(f"      core {q['core']:.2f}: its first round only, slack "
                  f"{q['first_slack']:.4g}", flush=True)
    if args.doc:
        _write_doc(Path(args.doc), rows, load0, os.getloadavg()[0])


def _write_doc(doc: Path, rows: list, load0: float, load1: float) -> None:
    """Replace the block between the markers of ``doc`` by the table of ``rows``."""
    head = ["N", "vertices", "inner s", "LP rounds", "search s", "windows s", "LP s", "ends s",
            "checks s", "certified", "total s", "x inner", "CPU s", "x inner (CPU)"]
    lines = ["| " + " | ".join(head) + " |", "|" + " --- |" * len(head)]
    lines += ["| " + " | ".join(str(x) for x in r) + " |" for r in rows]
    lines.append("")
    lines.append(f"Load average (1 min) {load0:.1f} before, {load1:.1f} after.")
    begin, end = "<!-- bench_certified: begin -->", "<!-- bench_certified: end -->"
    text = doc.read_text()
    if begin not in text or end not in text:
        raise SystemExit(f"{doc}: no {begin} ... {end} block")
    body = "\n".join(lines)
    doc.write_text(re.sub(re.escape(begin) + ".*?" + re.escape(end),
                          lambda m: f"{begin}\n{body}\n{end}", text, flags=re.S))


if __name__ == "__main__":
    main()
