"""The strategy, live: held/lost table and the paper's scenarios → docs/strategy.md + figures.

Run ``python docs/strategy_table.py [--runs N] [--duration S]`` (defaults are small so the
script runs in minutes on two shared cores; the issue's 200+ runs per cell is
``--runs 200``, hours). For each map, speed ratio ``vt/vo`` and target kind it draws seeded
starts that :func:`tether.assess.assess` calls **safe**, runs the paper's controller and records
held/lost and every loss's reason. It also runs the scripted Figs. 7 and 8 and draws them.
"""

from __future__ import annotations

import argparse
import math
import sys
import time
from collections import Counter
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
FIGS = HERE / "figures"

MAPS = ["nonconvex_corner", "convex_corner", "gallery"]
RATIOS = (0.3, 0.6, 0.9)
KINDS = ("random", "wall", "tangential", "dash", "escape", "search")


def safe_starts(world, n, rng, tries=4000):
    """Up to ``n`` seeded starts that assess calls safe."""
    from tether.arcs import rod_is_free
    from tether.assess import assess

    env = world.env
    x0, y0, x1, y1 = env.bounds
    out = []
    for _ in range(tries):
        if len(out) >= n:
            break
        x, y = rng.uniform((x0, y0), (x1, y1))
        a = rng.uniform(0, 2 * math.pi)
        if not (env.contains(x, y) and env.boundary_distance(x, y) > 0.05
                and rod_is_free(env, (x, y), a, world.lss)):
            continue
        if assess(world.verdict, world.vt, world.vo, x, y, a).safe:
            out.append((float(x), float(y), float(a)))
    return out


def short(reason):
    """A loss reason without its numbers (for counting)."""
    if reason is None:
        return ""
    head = reason.split(":")[0]
    if "pivot about" in reason:
        return head + " (pivot about a reflex vertex)"
    if "wall" in reason and "steep" in reason:
        return head + " (wall met too steeply)"
    return head


def table(runs, duration, dt):
    from tether.cli import example_path
    from tether.decomposition import decompose
    from tether.environment import load_map
    from tether.escape import analyze
    from tether.sim.controller import PaperController
    from tether.sim.protocols import World
    from tether.sim.simulate import simulate
    from tether.sim.targets import make_target

    rows, losses = [], []
    for name in MAPS:
        env = load_map(example_path(name))
        dec = decompose(env, 2.0)
        ver = analyze(dec)
        for ratio in RATIOS:
            w = World(env, 2.0, ratio, 1.0, dec, ver)
            starts = safe_starts(w, runs, np.random.default_rng(7))
            for kind in KINDS:
                held = lost = 0
                reasons = Counter()
                for k, st in enumerate(starts):
                    r = simulate(w, PaperController(w), make_target(kind, w), st,
                                 duration=duration, dt=dt, seed=k)
                    if r.held:
                        held += 1
                    else:
                        lost += 1
                        reasons[short(r.reason)] += 1
                        losses.append((name, ratio, kind, st, k, r.lost_at, r.reason))
                rows.append((name, ratio, kind, len(starts), held, lost, reasons,
                             ver.strategy_exists))
                print(f"{name} {ratio} {kind}: {held} held, {lost} lost", file=sys.stderr)
    return rows, losses


def scenarios():
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from tether.animate import plot_run
    from tether.sim.scenarios import fig7, fig8

    out = []
    for fn, fname in ((fig7, "strategy_fig7.png"), (fig8, "strategy_fig8.png")):
        w, r = fn("paper")
        _, r0 = fn("follow")
        fig, axes = plt.subplots(1, 2, figsize=(12, 5.5))
        plot_run(r, w, axes[0])
        plot_run(r0, w, axes[1])
        fig.tight_layout()
        fig.savefig(FIGS / fname, dpi=90)
        plt.close(fig)
        out.append((fn.__name__, fname, r, r0))
    return out


def gap():
    """The smallest counterexample found to the paper's literal conditions (Def. 2 pieces)."""
    import numpy as np

    from tether.assess import escape_table_of
    from tether.sim.controller import PaperController
    from tether.sim.scenarios import _world
    from tether.sim.simulate import simulate
    from tether.sim.targets import PathTarget

    w = _world("nonconvex_corner", 2.0, 0.5, 1.0)
    st = (3.0, 0.8, 0.0)
    t = escape_table_of(w.verdict, 0.5).subset("pieces")
    margin = float(t.margins(np.array(st[:2]), st[2], 0.5, 1.0)[3].min())
    out = {"start": st, "margin": margin}
    for rows in ("pieces", "all"):
        out[rows] = simulate(w, PaperController(w, escape_rows=rows),
                             PathTarget(w, waypoints=[[9.2, 0.8], [9.2, 6.0]]), st,
                             duration=25.0, dt=0.02)
    return out


def write(rows, losses, scen, runs, duration, dt, secs, g=None):
    lines = ["# The strategy, live", "",
             "Generated by `python docs/strategy_table.py "
             f"--runs {runs} --duration {duration:g}` ({secs:.0f} s); do not edit by hand.", "",
             "## The paper's examples", ""]
    for name, fname, r, r0 in scen:
        lines += [f"### {name}", "",
                  f"paper controller: **{r.outcome}**; modes "
                  + " → ".join(r.modes[:12]) + (" …" if len(r.modes) > 12 else ""),
                  "", "time per mode: " + ", ".join(f"{m} {t:.2f} s"
                                                    for m, t in r.mode_time.items()), "",
                  f"follow law only: **{r0.outcome}**"
                  + (f" at {r0.lost_at:.2f} s: {r0.reason}" if r0.reason else ""), "",
                  f"![{name}](figures/{fname})", ""]
    if g is not None:
        lp, la = g["pieces"], g["all"]
        lines += ["## The paper's escape points alone, on the room corner", "",
                  "The non-convex corner (a 10×10 room), lss = 2, vt = 0.5, vo = 1, start "
                  f"(x, y, a) = {g['start']}, a target walking along the floor into the corner "
                  "and up the right wall: every escape point of Def. 2 (escape pieces) is at "
                  f"least {g['margin']:.2f} farther than its L_g. With those rows alone the "
                  f"trigger strategy is **{lp.outcome}**"
                  + (f" at {lp.lost_at:.2f} s, {lp.reason}" if lp.reason else "")
                  + f"; with every row kind **{la.outcome}** (modes "
                  + " → ".join(la.modes) + ").", "",
                  "This run used to be lost with the pieces alone. The cause was not a gap in "
                  "Def. 2 but an escape row that ignored rods lying in the blocked gap next to "
                  "its cell at the sample point (the rod pointing at the right wall): the "
                  "follow law turns such a rod into the cell right at the escape piece. Rows "
                  "now concern the cell's arc widened over its neighbouring gaps. tether still "
                  "adds *steep-wall rows* (orientations within arcsin(vt/vo) of a wall's "
                  "normal, at distance lss from the wall, §5a) and *reflex-vertex rows* (the "
                  "no-pivot radius lss·vt/(vo+vt)) to the escape table, and `assess` applies "
                  "Prop. 3 to every pair of escape points of any kind.", "",
                  "The losses below (from starts that `assess` calls safe, with every row "
                  "kind) are not proven to be gaps: the trigger assumes a straight dash to one "
                  "escape point, and targets that round reflex corners at a hair's breadth or "
                  "change goal mid-rotation (Becerra 2010) beat it; the exact answer is the "
                  "kernel's (§11).", ""]
    lines += ["## Held / lost from starts that `assess` calls safe", "",
              f"Paper controller, lss = 2, vo = 1, dt = {dt:g} s, {duration:g} s per run, "
              f"{runs} seeded safe starts per (map, ratio) — far fewer than the 200 the issue "
              "asks for, to fit the time; rerun with `--runs 200` for the full table.", "",
              "| map | vt/vo | target | runs | held | lost | loss reasons |",
              "|---|---|---|---|---|---|---|"]
    for name, ratio, kind, n, held, lost, reasons, exists in rows:
        rs = "; ".join(f"{c}× {r}" for r, c in reasons.most_common()) or "—"
        label = name if exists else f"{name} (no strategy)"
        lines.append(f"| {label} | {ratio:g} | {kind} | {n} | {held} | {lost} | {rs} |")
    lines += ["", "A map with no strategy has no safe start, so its rows are empty.", "",
              "## Every loss from a safe start", "",
              "| map | vt/vo | target | start (x, y, a) | seed | t | reason |",
              "|---|---|---|---|---|---|---|"]
    for name, ratio, kind, st, k, t, reason in losses:
        lines.append(f"| {name} | {ratio:g} | {kind} | ({st[0]:.3f}, {st[1]:.3f}, "
                     f"{st[2]:.3f}) | {k} | {t:.2f} | {reason} |")
    lines += ["", "Rerun one: `tether simulate MAP.json --lss 2 --vt R --vo 1 --start X Y A "
              "--target KIND --seed K --duration D --plot run.png`.", ""]
    (HERE / "strategy.md").write_text("\n".join(lines))


def main(argv=None):
    p = argparse.ArgumentParser(description=__doc__)
    p.add_argument("--runs", type=int, default=3)
    p.add_argument("--duration", type=float, default=20.0)
    p.add_argument("--dt", type=float, default=0.02)
    args = p.parse_args(argv)
    t0 = time.perf_counter()
    FIGS.mkdir(exist_ok=True)
    scen = scenarios()
    g = gap()
    rows, losses = table(args.runs, args.duration, args.dt)
    write(rows, losses, scen, args.runs, args.duration, args.dt, time.perf_counter() - t0, g)


if __name__ == "__main__":
    main()
