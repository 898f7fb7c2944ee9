"""The ``tracks`` command: simulated people (jupedsim) written as track files for reuse by
``tether simulate --target track``."""

from __future__ import annotations

import argparse

from tether.cli.common import float_range, int_range, print_json

__all__ = ["cmd_tracks", "register"]

#: The most people one command walks.
MAX_COUNT = 1000


def cmd_tracks(args: argparse.Namespace) -> int:
    """``tether tracks``: write ``count`` simulated people's tracks into a folder; exit
    status."""
    from tether._util.files import check_output_dir, make_output_dir
    from tether._util.progress import Progress
    from tether.io import load_map
    from tether.io.tracks import write_track
    from tether.sim.crowd import pedestrian_tracks

    check_output_dir(args.out)
    env = load_map(args.map)
    people = pedestrian_tracks(env, args.count, args.seed, speed=args.speed,
                               duration=args.duration, dt=args.dt,
                               progress=Progress("tracks"))
    folder = make_output_dir(args.out)
    written = []
    for k, person in enumerate(people):
        path = folder / f"track_{k:03d}.{args.format}"
        write_track(person, path)
        written.append({"path": str(path), "name": person.name, "samples": len(person),
                        "start": person.xy[0].tolist(), "max_speed": person.max_speed})
    speed = people[0].meta["speed"]
    if args.json:
        print_json({"map": args.map, "count": args.count, "seed": args.seed, "speed": speed,
                    "duration": args.duration, "dt": args.dt, "files": written})
        return 0
    print(f"wrote {len(written)} tracks of {args.duration:g}s (every {args.dt:g}s, desired "
          f"speed {speed:g} map units/s, seed {args.seed}) into {folder}")
    return 0


def register(add) -> None:
    """Add the ``tracks`` subcommand with ``add``."""
    sp = add("tracks", cmd_tracks, "simulated people walking the map's free space (jupedsim, "
             "needs tether[crowd]), written as track files")
    sp.add_argument("map", help="map file (.json, .geojson, .wkt or ROS .yaml)")
    sp.add_argument("--count", type=int_range(1, MAX_COUNT), required=True,
                    help=f"number of people (1 to {MAX_COUNT})")
    sp.add_argument("--seed", type=int_range(0, 2**63 - 1), default=0,
                    help="seed of the starts and goals (0)")
    sp.add_argument("--out", required=True, metavar="DIR",
                    help="folder to write track_000.csv, ... into (created)")
    sp.add_argument("--speed", type=float_range(0, lo_open=True),
                    help="desired walking speed, map units/s (default 1.34, a person's in "
                    "metres)")
    sp.add_argument("--duration", type=float_range(0, 86400, lo_open=True), default=60.0,
                    help="seconds of walking (60)")
    sp.add_argument("--dt", type=float_range(0, 60, lo_open=True), default=0.05,
                    help="sampling step in seconds (0.05)")
    sp.add_argument("--format", choices=["csv", "json"], default="csv",
                    help="file format (csv)")
    sp.add_argument("--json", action="store_true", help="print JSON: what was written")
