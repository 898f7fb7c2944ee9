"""``tether follow``: the follower (:class:`tether.follow.Follower`) replayed on a target track,
the target observed only while in view; with ``--baseline spin`` the Nav2-like spin-in-place
search on the same track with the same sensing (:mod:`tether.follow.baseline`)."""

from __future__ import annotations

import argparse
import math
import sys

from tether.cli.common import (
    add_map_lss,
    float_arg,
    float_range,
    int_range,
    load_map_lss,
    print_json,
)
from tether.errors import InvalidParameterError

__all__ = ["cmd_follow", "register"]


def _check(args: argparse.Namespace) -> None:
    from tether._util.files import ANIMATION_KINDS, IMAGE_KINDS, check_output_path

    for name in ("vt", "vo"):
        v = getattr(args, name)
        if not (math.isfinite(v) and v >= 0):
            raise InvalidParameterError(f"--{name} must be a finite number >= 0 (got {v:g})")
    if not args.vo > args.vt:
        raise InvalidParameterError(f"vo must exceed vt (vo={args.vo:g}, vt={args.vt:g})")
    if args.plot:
        check_output_path(args.plot, IMAGE_KINDS)
    if args.animate:
        check_output_path(args.animate, ANIMATION_KINDS)


def _follower(args: argparse.Namespace, env):
    from tether.follow import Follower

    verdict = kernel = None
    if args.controller == "paper":
        from tether._util.progress import Progress
        from tether.analysis import analyze
        from tether.decomposition import decompose

        verdict = analyze(decompose(env, args.lss, progress=Progress("decompose")),
                          near_critical=False)
    return Follower(env, args.lss, args.vt, args.vo, rate=1.0 / args.dt,
                    controller=args.controller, verdict=verdict, kernel=kernel,
                    noise=args.noise, sensor_range=args.range, cell=args.cell)


def _summary(label: str, run) -> list[str]:
    d = run.to_dict()
    causes = ", ".join(f"{c}: {k}" for c, k in sorted(d["loss_causes"].items())) or "-"
    back = ", ".join(f"{x:.1f}" for x in d["reacquisition_times"]) or "-"
    st = d["time_per_status"]
    m = d["monitor"]
    return [
        f"  {label}: in view {d['time_in_view']:.1f} s ({d['percent_in_view']:.1f} %), "
        f"{d['losses']} losses ({causes})",
        f"    back in view after (s): {back}; never back: {d['never_reacquired']}",
        f"    time tracking {st['tracking']:.1f} s, searching {st['searching']:.1f} s, "
        f"lost {st['lost']:.1f} s",
        f"    monitor: max speed ratio {m['max_speed_ratio']:.4f}, blocked moves "
        f"{m['blocked_moves']}, rod at lss±10% {m['percent_in_view_at_rod_length']:.1f} % of "
        f"the time in view, max rod error while tracking {m['max_rod_error']:.3g}",
    ]


def cmd_follow(args: argparse.Namespace) -> int:
    """``tether follow``: replay the follower on a track; exit status."""
    from tether._util.progress import Progress
    from tether.follow.baseline import SpinSearch
    from tether.follow.replay import replay
    from tether.io.tracks import read_track

    _check(args)
    env = load_map_lss(args)
    track = read_track(args.track, topic=args.topic)
    if not bool(env.contains(*track.xy[0])):
        raise InvalidParameterError(
            f"the track starts at ({track.xy[0][0]:g}, {track.xy[0][1]:g}), outside the map's "
            "free space (is it in the map's frame?)")
    start = None if args.start is None else tuple(args.start)
    if start is not None and not (all(map(math.isfinite, start)) and bool(env.contains(*start))):
        raise InvalidParameterError(f"--start ({start[0]:g}, {start[1]:g}) is not in the map's "
                                    "free space")
    common = dict(lss=args.lss, vo=args.vo, dt=args.dt, sensor_range=args.range,
                  noise=args.noise, latency=args.latency, seed=args.seed, start=start)
    follower = _follower(args, env)
    print(f"follower ready ({len(follower.grid)} cells, "
          f"{len(follower.planner.static)} candidate poses)", file=sys.stderr)
    run = replay(env, track, follower, progress=Progress("follow"), **common)
    base = (replay(env, track, SpinSearch(args.lss, args.vo, rate=1.0 / args.dt), **common)
            if args.baseline == "spin" else None)
    fast = int((track.speeds() > args.vt * (1 + 1e-9)).sum()) if len(track) > 1 else 0
    if args.plot:
        from tether.plot import save
        from tether.plot.follow import follow_figure

        save(follow_figure(run, env, baseline=base), args.plot)
    if args.animate:
        from tether.plot.follow import animate_follow

        animate_follow(run, env, args.animate)
    head = {"map": env.name, "track": track.name, "lss": args.lss, "vt": args.vt,
            "vo": args.vo, "range": args.range, "noise": args.noise, "latency": args.latency,
            "dt": args.dt, "seed": args.seed, "controller": args.controller,
            "track_max_speed": track.max_speed, "segments_faster_than_vt": fast}
    if args.json:
        print_json({**head, "follower": run.to_dict(),
                    **({"baseline": base.to_dict()} if base is not None else {})})
        return 0
    rng = "unlimited" if args.range is None else f"{args.range:g}"
    print(f"follow '{track.name}' in '{env.name}' for {run.duration:.1f} s: lss={args.lss:g} "
          f"vt={args.vt:g} vo={args.vo:g}, controller {args.controller}, range {rng}, "
          f"noise {args.noise:g}, latency {args.latency:g} s")
    if fast:
        print(f"  note: {fast} track segments are faster than vt (max "
              f"{track.max_speed:.3g} map units/s): the reachable set assumes vt")
    for line in _summary("follower", run):
        print(line)
    if base is not None:
        for line in _summary("baseline spin (Nav2-like: spin in place up to 10 s)", base):
            print(line)
    return 0


def register(add) -> None:
    """Add ``tether follow`` with ``add``."""
    sp = add("follow", cmd_follow, "replay the follower on a target track (CSV, JSON, ROS bag), "
             "the target seen only while in view: time in view, losses, re-acquisitions")
    add_map_lss(sp)
    sp.add_argument("--track", required=True, help="the target's track: .csv (t,x,y), .json, "
                    "a rosbag2 folder or a ROS 1 .bag, in the map's frame")
    sp.add_argument("--topic", help="the bag's topic (default: its one supported topic)")
    sp.add_argument("--vt", type=float_arg, required=True, help="target speed bound")
    sp.add_argument("--vo", type=float_arg, required=True, help="observer speed bound (> vt)")
    sp.add_argument("--range", type=float_range(0, lo_open=True), default=None,
                    help="sensor range, map units (default: line of sight only)")
    sp.add_argument("--noise", type=float_range(0), default=0.0,
                    help="observation noise, standard deviation per axis, map units (0)")
    sp.add_argument("--latency", type=float_range(0), default=0.0,
                    help="age of each observation when it arrives, s (0)")
    sp.add_argument("--seed", type=int_range(0, 2**32 - 1), default=0, help="noise seed (0)")
    sp.add_argument("--dt", type=float_range(1e-3, 10), default=0.1,
                    help="loop period, s (0.1: 10 Hz)")
    sp.add_argument("--controller", default="follow", choices=("follow", "translate", "paper",
                                                               "kernel"),
                    help="tracking controller (follow; paper decomposes the map first)")
    sp.add_argument("--cell", type=float_range(0, lo_open=True), default=None,
                    help="cell of the reachable set's grid, map units (map diameter / 100)")
    sp.add_argument("--start", type=float_arg, nargs=2, metavar=("X", "Y"),
                    help="observer start (default: lss from the track's start, free rod)")
    sp.add_argument("--baseline", choices=("spin",), help="also run the Nav2-like "
                    "spin-in-place search on the same track and sensing")
    sp.add_argument("--json", action="store_true", help="print JSON")
    sp.add_argument("--plot", help="figure of the run and of the search (.png, ...)")
    sp.add_argument("--animate", help="animation of the run (.gif, .mp4 with ffmpeg, .html)")
