"""Figures and animations of a simulated run over the decomposition.

:func:`plot_run` draws a run (target and observer paths, rods, the mode as colour, escape points
and the second set of critical curves for the final orientation); :func:`animate_run` writes an
animation: GIF (matplotlib's Pillow writer), MP4 (only where ffmpeg is installed, else a clean
error) or HTML (a self-contained JavaScript player). :func:`draw_scene` and
:func:`draw_trigger_curves` draw the background a run or a start is shown over.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np

from tether.plot.axes import animation_path, save_animation
from tether.plot.map import plot_map
from tether.sim.protocols import Mode, Outcome

__all__ = ["MODE_COLOURS", "draw_scene", "draw_trigger_curves", "plot_run", "animate_run"]

#: Colour of each mode.
MODE_COLOURS = {Mode.REACTIVE: "tab:green", Mode.ROTATIONAL: "tab:purple",
                Mode.COMPLIANT: "tab:orange", Mode.KERNEL: "tab:blue",
                Mode.CERTIFIED: "tab:cyan", Mode.LOST: "red"}


def _colour(mode: str) -> str:
    return MODE_COLOURS.get(mode, "tab:gray")


def draw_trigger_curves(ax: Any, world: Any, a: float, grid: int = 90) -> list:
    """The second set of critical curves for orientation ``a`` (purple): target positions at
    ``L_g`` (solid) and the paper's ``L`` (dashed) from the escape points concerning ``a``; none
    when no strategy exists. Returns the contour sets added."""
    if world.verdict is None or not world.verdict.strategy_exists:
        return []
    from tether.analysis.assessment import critical_distance_field

    x0, y0, x1, y1 = world.env.bounds
    xs, ys = np.linspace(x0, x1, grid), np.linspace(y0, y1, grid)
    arts = []
    for paper, style in ((False, "solid"), (True, "dashed")):
        f = critical_distance_field(world.verdict, world.vt, world.vo, a, xs, ys, paper=paper)
        if np.isfinite(f).any() and f.min() < 0 < np.nanmax(np.where(np.isfinite(f), f, 0)):
            arts.append(ax.contour(xs, ys, np.where(np.isfinite(f), f, 1e9), levels=[0.0],
                                   colors="purple", linestyles=style, linewidths=1.0,
                                   zorder=3))
    return arts


def draw_scene(ax: Any, world: Any) -> None:
    """The background of a run or a start: the decomposition of ``world`` (or its map when it
    has none) and, when a strategy exists, the escape points (purple dots)."""
    if world.decomposition is not None:
        world.decomposition.plot(ax, labels=False)
    else:
        plot_map(world.env, ax, labels=False)
    if world.verdict is not None and world.verdict.strategy_exists:
        from tether.analysis.escape_points import escape_table_of

        t = escape_table_of(world.verdict)
        if len(t):
            ax.plot(t.q[:, 0], t.q[:, 1], ".", color="purple", ms=2, zorder=3,
                    label="escape points")
    ax.set_aspect("equal")


def plot_run(result: Any, world: Any, ax: Any = None, rods: int = 12) -> Any:
    """Figure of a run: paths, rods coloured by mode, escape points, purple curves at the end.
    Returns the axes."""
    import matplotlib.pyplot as plt

    if ax is None:
        _, ax = plt.subplots(figsize=(7, 6))
    draw_scene(ax, world)
    tr = result.trace
    ax.plot(tr.p[:, 0], tr.p[:, 1], "-", color="black", lw=1.2, label="target", zorder=4)
    modes = list(tr.mode) + [tr.mode[-1] if tr.mode else Mode.REACTIVE]
    for m in sorted(set(modes)):
        sel = np.array([x == m for x in modes])
        ox = np.where(sel, tr.observer[:, 0], np.nan)
        oy = np.where(sel, tr.observer[:, 1], np.nan)
        ax.plot(ox, oy, "-", color=_colour(m), lw=1.6, label=f"observer: {m}", zorder=4)
    for i in np.linspace(0, len(tr) - 1, min(rods, len(tr))).astype(int):
        ax.plot([tr.p[i, 0], tr.observer[i, 0]], [tr.p[i, 1], tr.observer[i, 1]], "-",
                color=_colour(modes[i]), lw=0.8, alpha=0.7, zorder=4)
    draw_trigger_curves(ax, world, float(tr.a[-1]))
    if result.outcome == Outcome.LOST:
        ax.plot(*tr.p[-1], "x", color="red", ms=10, mew=2, zorder=6)
    ax.set_title(f"{result.target} vs {result.controller}: {result.outcome}"
                 + (f" at t={result.lost_at:.2f}s" if result.lost_at is not None else ""),
                 fontsize=9)
    ax.legend(fontsize=6, loc="upper right")
    return ax


def animate_run(result: Any, world: Any, path: str | Path, fps: int = 20,
                max_frames: int = 150, purple: bool = True) -> Path:
    """Write an animation of the run to ``path`` (``.gif``, ``.mp4`` or ``.html``).

    Raises
    ------
    TetherError
        Unknown extension, or ``.mp4`` without ffmpeg.
    """
    import matplotlib.pyplot as plt
    from matplotlib import animation

    path = animation_path(path)
    tr = result.trace
    frames = np.unique(np.linspace(0, len(tr) - 1, min(max_frames, len(tr))).astype(int))
    fig, ax = plt.subplots(figsize=(6.4, 5.2))
    draw_scene(ax, world)
    (trail,) = ax.plot([], [], "-", color="black", lw=1.0, zorder=4)
    (otrail,) = ax.plot([], [], "-", color="gray", lw=1.0, zorder=4)
    (rod,) = ax.plot([], [], "-", lw=2.5, zorder=5)
    (tgt,) = ax.plot([], [], "o", color="black", ms=6, zorder=6)
    (obs,) = ax.plot([], [], "o", ms=7, zorder=6)
    title = ax.set_title("", fontsize=9)
    region_patch: list = []
    curves: list = []
    dec = world.decomposition
    modes = list(tr.mode) + [tr.mode[-1] if tr.mode else Mode.REACTIVE]

    def draw(k: int) -> list:
        i = frames[k]
        c = _colour(modes[i])
        if result.outcome == Outcome.LOST and i == len(tr) - 1:
            c = "red"
        trail.set_data(tr.p[: i + 1, 0], tr.p[: i + 1, 1])
        otrail.set_data(tr.observer[: i + 1, 0], tr.observer[: i + 1, 1])
        rod.set_data([tr.p[i, 0], tr.observer[i, 0]], [tr.p[i, 1], tr.observer[i, 1]])
        rod.set_color(c)
        tgt.set_data([tr.p[i, 0]], [tr.p[i, 1]])
        obs.set_data([tr.observer[i, 0]], [tr.observer[i, 1]])
        obs.set_color(c)
        for art in region_patch + curves:
            art.remove()
        region_patch.clear()
        curves.clear()
        if dec is not None:
            r = int(dec.region_at(tr.p[i])[0])
            if r >= 0:
                for poly in getattr(dec.regions[r].polygon, "geoms", [dec.regions[r].polygon]):
                    xy = np.asarray(poly.exterior.coords)
                    region_patch.extend(ax.fill(xy[:, 0], xy[:, 1], color="gold", alpha=0.35,
                                                zorder=2))
        if purple:
            curves.extend(draw_trigger_curves(ax, world, float(tr.a[i]), grid=60))
        title.set_text(f"t={tr.t[i]:5.2f}s  mode={modes[i]}  "
                       f"{result.target} vs {result.controller}")
        return [trail, otrail, rod, tgt, obs, title]

    anim = animation.FuncAnimation(fig, draw, frames=len(frames), interval=1000 / fps,
                                   blit=False)
    return save_animation(anim, fig, path, fps)
