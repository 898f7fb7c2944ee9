"""Figures of a follower replayed on a track (:mod:`tether.follow.replay`): the run (target and
observer paths, the observer coloured by status, the losses) and the possible set while the
follower searched; an animation of the run.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np
from matplotlib.figure import Figure

from tether.plot.axes import (
    TARGET_COLOUR,
    animation_path,
    ensure_axes,
    new_axes,
    save_animation,
)
from tether.plot.map import plot_map

__all__ = ["STATUS_COLOURS", "animate_follow", "follow_figure", "plot_follow", "plot_search"]

#: Colour of the observer in each status.
STATUS_COLOURS = {"tracking": "tab:green", "searching": "tab:purple", "lost": "red"}


def plot_follow(run: Any, env: Any, ax: Any = None, baseline: Any = None) -> Any:
    """The run: the target's path, the observer's coloured by status, each loss (a red cross
    where the target was, labelled with its cause); ``baseline``'s observer dashed grey.

    Examples
    --------
    >>> import numpy as np
    >>> from tether import Environment
    >>> from tether.follow.baseline import SpinSearch
    >>> from tether.follow.replay import replay
    >>> from tether.io.tracks import Track
    >>> from tether.plot.follow import plot_follow
    >>> room = Environment([(0, 0), (4, 0), (4, 3), (0, 3)])
    >>> track = Track([0.0, 4.0], [(1, 1), (3, 2)])
    >>> run = replay(room, track, SpinSearch(0.5, 1.0), lss=0.5, vo=1.0, dt=0.5)
    >>> ax = plot_follow(run, room)
    >>> ax.get_title()
    'SpinSearch: 100% in view, 0 losses'
    """
    ax = ensure_axes(ax)
    plot_map(env, ax, labels=False)
    ax.plot(run.target[:, 0], run.target[:, 1], "-", color=TARGET_COLOUR, lw=1.2,
            label="target")
    if baseline is not None:
        ax.plot(baseline.observer[:, 0], baseline.observer[:, 1], "--", color="0.45", lw=1.0,
                label=f"{baseline.follower} observer")
    status = np.array(run.status)
    for name, colour in STATUS_COLOURS.items():
        k = status == name
        if k.any():
            ax.plot(run.observer[k, 0], run.observer[k, 1], ".", ms=2.5, color=colour,
                    label=f"observer {name}")
    for loss in run.losses:
        i = int(np.searchsorted(run.t, loss.t))
        i = min(i, len(run.t) - 1)
        ax.plot(*run.target[i], "x", color="red", ms=7, mew=2, zorder=6)
        ax.annotate(loss.cause.replace("occluded by ", ""), run.target[i], fontsize=6,
                    color="red", xytext=(3, 3), textcoords="offset points")
    ax.set_title(f"{run.follower}: {run.percent_in_view:.0f}% in view, "
                 f"{len(run.losses)} losses")
    ax.legend(fontsize=6, loc="upper right")
    ax.set_aspect("equal")
    return ax


def plot_search(run: Any, env: Any, ax: Any = None, count: int = 4) -> Any:
    """The possible set while searching: up to ``count`` snapshots of the longest search, each
    cell centre a dot coloured by time, with the target's position then."""
    ax = ensure_axes(ax)
    plot_map(env, ax, labels=False)
    snaps = list(run.snapshots)
    if snaps:
        times = np.array([s[0] for s in snaps])
        gaps = np.flatnonzero(np.diff(times) > 1.5 * max(np.median(np.diff(times)), 1e-9)
                              if len(times) > 1 else np.zeros(0, dtype=bool))
        bounds = np.r_[0, gaps + 1, len(snaps)]
        k = int(np.argmax(np.diff(bounds)))
        chosen = snaps[bounds[k]:bounds[k + 1]]
        pick = np.unique(np.linspace(0, len(chosen) - 1, min(count, len(chosen))).astype(int))
        cmap = _colours(len(pick))
        for colour, j in zip(cmap, pick, strict=True):
            t, cells = chosen[j]
            if len(cells):
                ax.plot(cells[:, 0], cells[:, 1], "s", ms=1.5, color=colour, alpha=0.5,
                        label=f"possible at t={t:.1f}s")
            i = min(int(np.searchsorted(run.t, t)), len(run.t) - 1)
            ax.plot(*run.target[i], "o", color=colour, mec="k", ms=5, zorder=6)
            ax.plot(*run.observer[i], "^", color=colour, mec="k", ms=6, zorder=6)
        ax.legend(fontsize=6, loc="upper right")
        ax.set_title("where the target can be while searching (o target, ^ observer)",
                     fontsize=8)
    else:
        ax.set_title("no search in this run", fontsize=8)
    ax.set_aspect("equal")
    return ax


def _colours(n: int) -> list:
    from matplotlib import colormaps

    return [colormaps["viridis"](x) for x in np.linspace(0.1, 0.9, max(n, 1))][:n]


def follow_figure(run: Any, env: Any, baseline: Any = None) -> Figure:
    """Two panels: :func:`plot_follow` and :func:`plot_search`."""
    fig, (a, b) = new_axes(2)
    plot_follow(run, env, a, baseline=baseline)
    plot_search(run, env, b)
    return fig


def animate_follow(run: Any, env: Any, path: str | Path, fps: int = 10,
                   max_frames: int = 100) -> Path:
    """Write an animation of the run to ``path`` (``.gif``, ``.mp4`` with ffmpeg, or
    ``.html``): target, observer (coloured by status), the line of sight when in view, and the
    latest possible set while searching.

    Raises
    ------
    TetherError
        Unknown extension, or ``.mp4`` without ffmpeg.
    """
    import matplotlib.pyplot as plt
    from matplotlib import animation

    path = animation_path(path)
    n = len(run.t)
    frames = np.unique(np.linspace(0, n - 1, min(max_frames, n)).astype(int))
    snap_t = np.array([s[0] for s in run.snapshots])
    fig, ax = plt.subplots(figsize=(6.4, 5.2))
    plot_map(env, ax, labels=False)
    (cells,) = ax.plot([], [], "s", ms=1.5, color="tab:purple", alpha=0.35, zorder=2)
    (trail,) = ax.plot([], [], "-", color=TARGET_COLOUR, lw=1.0, zorder=4)
    (sight,) = ax.plot([], [], "-", color="0.5", lw=1.0, zorder=4)
    (tgt,) = ax.plot([], [], "o", color=TARGET_COLOUR, ms=6, zorder=6)
    (obs,) = ax.plot([], [], "^", ms=8, zorder=6)
    title = ax.set_title("", fontsize=9)

    def draw(k: int) -> list:
        i = frames[k]
        st = run.status[i]
        trail.set_data(run.target[: i + 1, 0], run.target[: i + 1, 1])
        tgt.set_data([run.target[i, 0]], [run.target[i, 1]])
        obs.set_data([run.observer[i, 0]], [run.observer[i, 1]])
        obs.set_color(STATUS_COLOURS.get(st, "gray"))
        if run.seen[i]:
            sight.set_data([run.target[i, 0], run.observer[i, 0]],
                           [run.target[i, 1], run.observer[i, 1]])
        else:
            sight.set_data([], [])
        j = int(np.searchsorted(snap_t, run.t[i], side="right")) - 1
        if st == "searching" and j >= 0:
            c = run.snapshots[j][1]
            cells.set_data(c[:, 0], c[:, 1])
        else:
            cells.set_data([], [])
        title.set_text(f"t={run.t[i]:5.1f}s  {st}  {'in view' if run.seen[i] else 'unseen'}")
        return [cells, trail, sight, tgt, obs, title]

    anim = animation.FuncAnimation(fig, draw, frames=len(frames), interval=1000 / fps,
                                   blit=False)
    return save_animation(anim, fig, path, fps)
