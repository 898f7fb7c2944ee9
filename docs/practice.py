"""Simulated people against tether's controllers and follower → docs/practice.md (+ a figure).

Run ``python docs/practice.py [--people N] [--duration S] [--quick]`` (the committed page is
the default: 4 people a map, 30 s each, about five minutes on two cores; ``--quick`` is a smoke run
of one map, one person, 10 s, kernels on a coarse grid, that the slow tests execute).

People: :func:`tether.sim.crowd.pedestrian_tracks` (jupedsim's collision-free speed model,
seeded, random journeys), walking at the desired speed ``vt`` (with ``vo = 1``, ``vt`` is the
ratio ``vt/vo``) on the docs' maps and the bundled office.

Part 1, the controllers with the target always known (``tether simulate --target track``):
each person from their first position, the rod at the free orientation deepest in the
surveillance kernel there (:func:`tether.game.surveillance_kernel`, its default grid), against
the paper's controller, the kernel controller (following that kernel) and the follow law, under
the simulator's monitor: held or lost, and why. Losses from a start outside the grid kernel's
*optimistic* bracket (``scheme="outer"``, same grid) are counted apart; that bracket is not a
proven bound (issue #22), so they are not claimed to be unavoidable.

Part 2, sensing: the same tracks replayed with the target observed only in view (line of sight
within a range of ``2·lss``, no noise; :func:`tether.follow.replay.replay`) by the
:class:`tether.Follower` (follow law while tracking, the reachable-set search when unseen)
and by the Nav2-like spin-in-place follower (:mod:`tether.follow.baseline`): time in view,
losses, and how long each took to see the person again.
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

#: (label, map file relative to the repository, lss): the gallery and a generated floor plan
#: at the lss of ``docs/strategy.md``, and the office at the lss its sweep allows
#: (``docs/ros_office.md``).
MAPS = [("gallery", "src/tether/examples/gallery.json", 2.0),
        ("floorplan-40", "docs/maps/floorplan-40.json", 0.6),
        ("office", "src/tether/examples/office.yaml", 0.8)]
RATIOS = (0.3, 0.6, 0.9)
CONTROLLERS = ("paper", "kernel", "follow")
#: Simulator step (s) of part 1 and loop period (s) of part 2.
SIM_DT, LOOP_DT = 0.05, 0.1
#: Sensor range of part 2, in rod lengths.
RANGE = 2.0


def _say(text: str) -> None:
    print(text, file=sys.stderr, flush=True)


def scene(label: str, src: str, lss: float, ratio: float, coarse: bool = False):
    """The World (decomposition, verdict, the kernel on its default grid, or with ``coarse``
    on 1/50 of the map's size and 90 orientations) and the optimistic kernel on the same
    grid."""
    from tether.analysis import analyze
    from tether.decomposition import decompose
    from tether.game import surveillance_kernel
    from tether.io import load_map
    from tether.sim.protocols import World

    env = load_map(HERE.parent / src)
    dec = decompose(env, lss)
    world = World(env, lss, ratio, 1.0, dec, analyze(dec))
    x0, y0, x1, y1 = env.bounds
    grid = {"h": max(x1 - x0, y1 - y0) / 50, "orientations": 90} if coarse else {}
    world.extra["kernel"] = surveillance_kernel(env, lss, ratio, 1.0, **grid)
    outer = surveillance_kernel(env, lss, ratio, 1.0, scheme="outer", **grid)
    return world, outer


def start_angle(world, p) -> float:
    """The free rod orientation at ``p`` deepest in the world's kernel (72 tried)."""
    from tether.arcs import rod_is_free_many

    a = np.linspace(-math.pi, math.pi, 72, endpoint=False)
    pts = np.repeat(np.asarray(p, float)[None, :], len(a), axis=0)
    free = rod_is_free_many(world.env, pts, a, world.lss)
    depth = world.extra["kernel"].depth_at(pts, a)
    return float(a[free][int(np.argmax(depth[free]))])


def short(reason: str | None) -> str:
    """A loss reason without its numbers."""
    if not reason:
        return ""
    head = reason.split(":")[0].split(" (")[0]
    return " ".join(w for w in head.split() if not w[:1].isdigit())


def controllers_part(world, outer, tracks, label: str) -> list[dict]:
    """Part 1 rows: per controller, the runs' outcomes."""
    from tether.sim.replay import TrackTarget
    from tether.sim.simulate import simulate
    from tether.strategies import CONTROLLERS as REGISTRY

    rows = []
    for name in CONTROLLERS:
        held, causes, unavoidable, outside = 0, Counter(), 0, 0
        for tr in tracks:
            p = tr.xy[0]
            a = start_angle(world, p)
            inside = bool(outer.contains(p[None, :], [a])[0])
            outside += not inside
            target = TrackTarget(world, track=tr, dt=SIM_DT, speed="clip")
            r = simulate(world, REGISTRY[name](world), target, (float(p[0]), float(p[1]), a),
                         duration=tr.duration, dt=SIM_DT)
            if r.held:
                held += 1
            else:
                causes[short(r.reason)] += 1
                unavoidable += not inside
        rows.append({"map": label, "lss": world.lss, "ratio": world.vt, "controller": name,
                     "people": len(tracks), "held": held, "causes": dict(causes),
                     "unavoidable": unavoidable, "outside": outside,
                     "kernel": 100 * float(outer.safe_fraction_total())})
        _say(f"  {label} {world.vt:g} {name}: held {held}/{len(tracks)}")
    return rows


def sensing_part(world, tracks, label: str) -> tuple[list[dict], object]:
    """Part 2 rows (Follower, then spin) and the Follower run with the longest search."""
    from tether.follow import Follower
    from tether.follow.baseline import SpinSearch
    from tether.follow.replay import replay

    env, lss, vt = world.env, world.lss, world.vt
    follower = Follower(env, lss, vt, 1.0, rate=1 / LOOP_DT, sensor_range=RANGE * lss)
    rows, best = [], (0.0, None)
    for kind in ("Follower", "spin"):
        view, losses, back, never, causes = [], 0, [], 0, Counter()
        for tr in tracks:
            p = tr.xy[0]
            o = p + lss * np.array([math.cos(a := start_angle(world, p)), math.sin(a)])
            if kind == "Follower":
                follower.reset()
                who = follower
            else:
                who = SpinSearch(lss, 1.0, rate=1 / LOOP_DT)
            run = replay(env, tr, who, lss=lss, vo=1.0, dt=LOOP_DT, sensor_range=RANGE * lss,
                         start=o)
            view.append(run.percent_in_view)
            losses += len(run.losses)
            back += run.reacquisitions
            never += sum(x.back is None for x in run.losses)
            causes.update(_kind(x.cause) for x in run.losses)
            searched = run.status.count("searching")
            if kind == "Follower" and searched > best[0]:
                best = (searched, run)
        rows.append({"map": label, "ratio": vt, "follower": kind, "people": len(tracks),
                     "in_view": float(np.mean(view)), "losses": losses,
                     "causes": dict(causes), "back": back, "never": never})
    return rows, best[1]


def _kind(cause: str) -> str:
    """A replay's loss cause without the feature's name."""
    if cause.startswith("occluded by V"):
        return "occluded by a corner"
    if cause.startswith("occluded by E"):
        return "occluded by a wall"
    return cause


def _fmt_causes(causes: dict) -> str:
    return "; ".join(f"{c} ×{k}" for c, k in sorted(causes.items(), key=lambda x: -x[1])) or "-"


def _fmt_back(back: list[float]) -> str:
    if not back:
        return "-"
    b = np.array(back)
    return f"{np.median(b):.1f} / {np.percentile(b, 90):.1f} / {b.max():.1f}"


def page(rows1, rows2, args, seconds: float, figure: str | None) -> str:
    """The Markdown page."""
    cmd = "python docs/practice.py" + (" --quick" if args.quick else
                                       f" --people {args.people} --duration {args.duration:g}")
    lines = [
        "# In practice: simulated people, the controllers and the follower",
        "",
        f"Generated by `{cmd}` ({seconds:.0f} s); do not edit by hand.",
        "",
        f"People walk random journeys through each map ({args.people} a map, {args.duration:g} s, "
        "`tether.sim.crowd.pedestrian_tracks`: jupedsim's collision-free speed model, seed 0) "
        "at the desired speed `vt`; the observer's speed bound is `vo = 1`, so `vt` is the "
        "ratio `vt/vo`. Maps: the gallery and the 40-vertex floor plan of `docs/strategy.md`, "
        "and the bundled office of `docs/ros_office.md`, each at its `lss`.",
        "",
        "## 1. The controllers, the person always known",
        "",
        "Each person is replayed as a `track` target (`tether simulate --target track`, "
        f"step {SIM_DT:g} s) from their first position, the rod at the free orientation deepest "
        "in the surveillance kernel there (its default grid), against the paper's controller, "
        "the kernel controller (following that kernel) and the follow law, under the "
        "simulator's monitor. *Outside the optimistic kernel*: "
        "losses from a start outside the grid kernel's optimistic bracket "
        "(`scheme=\"outer\"`, same grid), where the grid game says some target motion "
        "escapes whatever the observer does. That bracket is not a proven bound: at 0.6 and "
        "0.9 it is empty on these grids although these people are mostly held (on the gallery "
        "at lss 2 and vt/vo 0.6 it keeps 94 % of the free states on a grid of size/50 and 90 "
        "orientations, and none on the default size/100 and 180), so a loss counted there is "
        "*not* shown to be unavoidable. Where it is empty the kernel controller climbs the "
        "depth of an empty kernel, so its rows there say nothing of the controller where the "
        "kernel exists.",
        "",
        "| map | lss | vt/vo | controller | people | held | held % | losses by cause | "
        "optimistic kernel, % of free states | starts outside it | losses from those starts |",
        "|---|---|---|---|---|---|---|---|---|---|---|",
    ]
    for r in rows1:
        lines.append(f"| {r['map']} | {r['lss']:g} | {r['ratio']:g} | {r['controller']} | "
                     f"{r['people']} | {r['held']} | {100 * r['held'] / r['people']:.0f} | "
                     f"{_fmt_causes(r['causes'])} | {r['kernel']:.1f} | {r['outside']} | "
                     f"{r['unavoidable']} |")
    lines += [
        "",
        "## 2. Sensing: in view only, and finding the person again",
        "",
        "The same tracks, the person observed only while in view: line of sight within "
        f"{RANGE:g}·lss, no noise, a {1 / LOOP_DT:g} Hz loop (`tether follow ... --range R "
        "--baseline spin`). **Follower**: `tether.Follower` (the follow law while tracking; "
        "when the person is unseen, the set of positions they can have reached, by exact "
        "geodesic distance, and the observer pose that brings most of it back in view soonest, "
        "the corner where they left view first). **spin**: the Nav2 Following Server's "
        "behaviour (keep the set distance to the last detected pose; when lost, rotate in place "
        "for up to 10 s, then give up; with an all-round sensor the spin is standing still). "
        "*Back in view*: seconds from a loss to the next sighting, median / 90th percentile / "
        "max over the losses that ended before the track did; *never*: losses not recovered.",
        "",
        "| map | vt/vo | follower | people | in view % | losses | causes | back in view (s) "
        "| never |",
        "|---|---|---|---|---|---|---|---|---|",
    ]
    for r in rows2:
        lines.append(f"| {r['map']} | {r['ratio']:g} | {r['follower']} | {r['people']} | "
                     f"{r['in_view']:.1f} | {r['losses']} | {_fmt_causes(r['causes'])} | "
                     f"{_fmt_back(r['back'])} | {r['never']} |")
    lines += ["", _summary(rows2), ""]
    if figure:
        lines += ["The Follower's run with the longest search (left: paths, the observer "
                  "coloured by status, losses as red crosses; right: where the person could "
                  "be while it searched):", "", f"![longest search](figures/{figure})", ""]
    return "\n".join(lines)


def _summary(rows2) -> str:
    f = [r for r in rows2 if r["follower"] == "Follower"]
    s = [r for r in rows2 if r["follower"] == "spin"]
    fb = [x for r in f for x in r["back"]]
    sb = [x for r in s for x in r["back"]]
    return (f"Over every map and ratio: the Follower lost the person {sum(r['losses'] for r in f)}"
            f" times and found them again {len(fb)} times (median "
            f"{np.median(fb) if fb else float('nan'):.1f} s), {sum(r['never'] for r in f)} "
            f"never; the spin search lost them {sum(r['losses'] for r in s)} times, found them "
            f"again {len(sb)} times (median {np.median(sb) if sb else float('nan'):.1f} s, "
            f"by their coming back into view), {sum(r['never'] for r in s)} never.")


def main(argv=None) -> None:
    """Run both parts and write ``docs/practice.md``."""
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--people", type=int, default=4, help="people a map (4)")
    ap.add_argument("--duration", type=float, default=30.0, help="seconds a person (30)")
    ap.add_argument("--quick", action="store_true", help="smoke run: one map, one person, 10 s, "
                    "coarse kernels")
    args = ap.parse_args(argv)
    from tether.sim.crowd import pedestrian_tracks

    maps = MAPS
    if args.quick:
        maps, args.people, args.duration = MAPS[:1], 1, 10.0
    t0 = time.time()
    rows1, rows2, longest = [], [], (0, None, None)
    for label, src, lss in maps:
        for ratio in RATIOS:
            _say(f"{label}, vt/vo = {ratio:g}")
            world, outer = scene(label, src, lss, ratio, coarse=args.quick)
            tracks = pedestrian_tracks(world.env, args.people, seed=0, speed=ratio,
                                       duration=args.duration, dt=SIM_DT)
            rows1 += controllers_part(world, outer, tracks, label)
            r2, run = sensing_part(world, tracks, label)
            rows2 += r2
            if run is not None and run.status.count("searching") > longest[0]:
                longest = (run.status.count("searching"), run, world.env)
    figure = None
    if longest[1] is not None:
        from tether.plot import save
        from tether.plot.follow import follow_figure

        FIGS.mkdir(exist_ok=True)
        figure = "practice_search.png"
        save(follow_figure(longest[1], longest[2]), FIGS / figure)
    text = page(rows1, rows2, args, time.time() - t0, figure)
    (HERE / "practice.md").write_text(text)
    _say(f"wrote {HERE / 'practice.md'} in {time.time() - t0:.0f} s")


if __name__ == "__main__":
    main()
