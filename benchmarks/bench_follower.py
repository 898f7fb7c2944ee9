"""The follower's loop rate on the 80-vertex floor plan, tracking and searching separately
(issue 24 asks >= 50 Hz).

Run: ``python benchmarks/bench_follower.py``. A person walks shortest paths between random
points of the free space at ``vt`` (:class:`tether.sim.paths.PathPlanner`, seeded); the follower
is replayed on that track with line-of-sight sensing limited to a range of ``2·lss``, so that it
both tracks and searches (:func:`tether.follow.replay.replay`); each ``update`` is timed and
filed under the status it returned (the first update of each search, which computes the
geodesic distance field and the escape poses, apart as ``search start``). A second run times
a pure search: one sighting, then no observation at all. Wall-clock on a shared machine:
noisy, compare medians.
"""

from __future__ import annotations

import time

import numpy as np

from tether.examples.floorplan import floor_plan
from tether.follow import Follower
from tether.follow.reachable import visible_from
from tether.follow.replay import replay
from tether.io.tracks import Track
from tether.sim.paths import PathPlanner

LSS, VT, VO, DT = 1.0, 0.5, 1.0, 0.1


class _Timed:
    """A follower whose updates are timed, by returned status."""

    def __init__(self, follower: Follower) -> None:
        self.follower = follower
        self.times: dict[str, list[float]] = {"tracking": [], "search start": [],
                                              "searching": [], "lost": []}
        self._was = ""

    def update(self, *args, **kwargs):
        t0 = time.perf_counter()
        cmd = self.follower.update(*args, **kwargs)
        took = time.perf_counter() - t0
        status = str(cmd.status)
        first = status == "searching" and self._was != "searching"
        self.times["search start" if first else status].append(took)
        self._was = status
        return cmd


def _walk(env, seconds: float, seed: int) -> Track:
    planner = PathPlanner(env)
    rng = np.random.default_rng(seed)
    pts = [planner.random_point(rng)]
    while True:
        leg = planner.path(pts[-1], planner.random_point(rng))
        pts.extend(leg[1:])
        length = np.linalg.norm(np.diff(np.array(pts), axis=0), axis=1).sum()
        if length > VT * seconds:
            break
    xy = np.array(pts)
    keep = np.r_[True, np.linalg.norm(np.diff(xy, axis=0), axis=1) > 1e-9]
    xy = xy[keep]
    t = np.r_[0.0, np.cumsum(np.linalg.norm(np.diff(xy, axis=0), axis=1))] / VT
    return Track(t, xy, "walk")


def _row(name: str, times: list[float]) -> str:
    if not times:
        return f"{name:<12} {0:>8}"
    ms = 1e3 * np.array(times)
    return (f"{name:<12} {len(ms):>8} {np.median(ms):>10.2f} {np.percentile(ms, 90):>8.2f} "
            f"{np.max(ms):>8.2f} {1e3 / np.median(ms):>10.0f}")


def main() -> None:
    env = floor_plan(80, seed=0)
    t0 = time.perf_counter()
    follower = Follower(env, LSS, VT, VO, rate=1 / DT, sensor_range=2 * LSS)
    build = time.perf_counter() - t0
    track = _walk(env, 120.0, seed=1)
    timed = _Timed(follower)
    run = replay(env, track, timed, lss=LSS, vo=VO, dt=DT, sensor_range=2 * LSS)
    print(f"floor plan, 80 vertices (seed 0): lss={LSS:g} vt={VT:g} vo={VO:g}, loop {1 / DT:g} "
          f"Hz, sensor range {2 * LSS:g}; grid {len(follower.grid)} cells of "
          f"{follower.grid.h:.3g}, {len(follower.planner.static)} candidate poses")
    print(f"construction: {build:.2f} s; replay of {run.duration:.0f} s: "
          f"{run.percent_in_view:.0f}% in view, {len(run.losses)} losses")
    print(f"{'status':<12} {'updates':>8} {'median ms':>10} {'p90 ms':>8} {'max ms':>8} "
          f"{'rate Hz':>10}")
    for name in ("tracking", "search start", "searching", "lost"):
        print(_row(name, timed.times[name]))
    # a pure search: one sighting, then nothing, the observer taken to a point that does not
    # see the sighting (moved by its commands afterwards)
    follower.reset()
    p = track.xy[len(track) // 2]
    rng = np.random.default_rng(2)
    x0, y0, x1, y1 = env.bounds
    cand = rng.uniform((x0, y0), (x1, y1), (400, 2))
    cand = cand[env.contains(cand[:, 0], cand[:, 1])]
    far = cand[~visible_from(env, p, cand)][0]
    follower.update(0.0, p, observer=far)
    times, statuses = [], []
    for k in range(1, 301):
        t1 = time.perf_counter()
        cmd = follower.update(k * DT, None)
        times.append(time.perf_counter() - t1)
        statuses.append(str(cmd.status))
    print(_row("search", times) + f"   (30 s unseen from one sighting: "
          f"{statuses.count('searching')} searching, {statuses.count('lost')} lost)")

if __name__ == "__main__":
    main()
