"""Figures of the surveillance kernel (:mod:`tether.game`): the plane coloured by the safe
fraction of orientations, slices of the kernel at chosen orientations, and runs drawn over
them."""

from __future__ import annotations

import math
from typing import Any

import numpy as np
from matplotlib.colors import ListedColormap
from matplotlib.figure import Figure

from tether.plot.axes import OBSERVER_COLOUR, ROD_COLOUR, TARGET_COLOUR, ensure_axes
from tether.plot.map import plot_map

__all__ = ["CERTIFIED_COLOURS", "SLICE_COLOURS", "certified_figure", "kernel_figure",
           "kernel_run_strip", "plot_certified_slice", "plot_kernel_run", "plot_kernel_slice",
           "plot_safe_fraction"]

#: Slice colours: blocked rod, free but outside the kernel, in the kernel.
SLICE_COLOURS = ("0.85", "tab:orange", "tab:green")


#: Certified slice colours: blocked rod, unsafe (outside the optimistic kernel), undecided,
#: certified safe.
CERTIFIED_COLOURS = ("0.85", "tab:red", "gold", "tab:green")


def _extent(kernel: Any) -> tuple[float, float, float, float]:
    g = kernel.grid
    ny, nx, _ = g.shape
    x0, y0 = g.origin
    return (x0 - g.h / 2, x0 + (nx - 0.5) * g.h, y0 - g.h / 2, y0 + (ny - 0.5) * g.h)


def _lattice(kernel: Any, values: np.ndarray, fill: float = np.nan) -> np.ndarray:
    """Scatter per-point values onto the (ny, nx) lattice."""
    g = kernel.grid
    ny, nx, _ = g.shape
    out = np.full((ny, nx), fill, dtype=float)
    out[g.ij[:, 1], g.ij[:, 0]] = values
    return out


def plot_safe_fraction(kernel: Any, ax: Any = None, colorbar: bool = True) -> list:
    """The plane coloured by the fraction of each point's free orientations in the kernel;
    points with free orientations but no safe one are marked with red dots."""
    ax = ensure_axes(ax)
    img = ax.imshow(_lattice(kernel, kernel.safe_fraction()), origin="lower",
                    extent=_extent(kernel), vmin=0, vmax=1, cmap="viridis",
                    interpolation="nearest", zorder=1)
    arts: list = [img]
    arts += plot_map(kernel.grid.env, ax, labels=False)
    bad = kernel.no_safe_start
    if len(bad):
        arts.append(ax.scatter(bad[:, 0], bad[:, 1], s=2, color="tab:red",
                               label="no safe orientation"))
    if colorbar:
        ax.figure.colorbar(img, ax=ax, label="safe fraction of free orientations")
    ax.set_title(f"kernel: vt/vo = {kernel.vt / kernel.vo:.2g}, lss = {kernel.lss:g}")
    ax.set_aspect("equal")
    return arts


def plot_kernel_slice(kernel: Any, angle: float, ax: Any = None) -> list:
    """The slice of the kernel at the orientation bin nearest ``angle`` (radians): grey where
    the rod is blocked, orange where it is free but outside the kernel, green inside."""
    ax = ensure_axes(ax)
    g = kernel.grid
    k = int(g.bin_at(np.array([angle]))[0])
    code = g.free[:, k].astype(float) + kernel.kernel[:, k]
    img = ax.imshow(_lattice(kernel, code), origin="lower", extent=_extent(kernel),
                    cmap=ListedColormap(list(SLICE_COLOURS)), vmin=-0.5, vmax=2.5,
                    interpolation="nearest", zorder=1)
    arts: list = [img]
    arts += plot_map(g.env, ax, labels=False)
    ax.set_title(f"a = {math.degrees(g.angles[k]):.0f}°")
    ax.set_aspect("equal")
    return arts


def kernel_figure(kernel: Any, angles: tuple[float, ...] = (0.0, math.pi / 2, math.pi,
                                                             3 * math.pi / 2),
                  fig: Any = None) -> Figure:
    """Safe fraction beside slices of the kernel at ``angles`` (radians)."""
    if fig is None:
        fig = Figure(figsize=(4.2 * (1 + math.ceil(len(angles) / 2)), 7.0), layout="constrained")
    ncols = 1 + math.ceil(len(angles) / 2)
    gs = fig.add_gridspec(2, ncols)
    plot_safe_fraction(kernel, fig.add_subplot(gs[:, 0]))
    for n, a in enumerate(angles):
        plot_kernel_slice(kernel, a, fig.add_subplot(gs[n % 2, 1 + n // 2]))
    fig.suptitle("surveillance kernel — green: safe, orange: free but the target wins, "
                 "grey: rod blocked", fontsize=9)
    return fig


def plot_kernel_run(kernel: Any, result: Any, ax: Any = None) -> list:
    """A simulator run (:class:`~tether.sim.simulate.SimResult`) drawn over the safe-fraction
    map: target path, observer path, a few rods, and where the run was lost if it was."""
    ax = ensure_axes(ax)
    arts = plot_safe_fraction(kernel, ax, colorbar=False)
    tr = result.trace
    p, o = tr.p, tr.observer
    arts += ax.plot(p[:, 0], p[:, 1], color=TARGET_COLOUR, lw=1.5, label="target", zorder=4)
    arts += ax.plot(o[:, 0], o[:, 1], color=OBSERVER_COLOUR, lw=1.5, label="observer", zorder=4)
    for i in np.linspace(0, len(p) - 1, 8).astype(int):
        arts += ax.plot([p[i, 0], o[i, 0]], [p[i, 1], o[i, 1]], color=ROD_COLOUR, lw=1, zorder=4)
    if not result.held:
        arts.append(ax.scatter(*p[-1], marker="x", color="tab:red", s=60, zorder=5,
                               label=f"lost at t = {result.lost_at:.2f} s"))
    ax.legend(loc="upper right", fontsize=7)
    ax.set_title(f"{result.controller} vs {result.target}: {result.outcome}")
    return arts


def kernel_run_strip(kernel: Any, result: Any, frames: int = 4, fig: Any = None) -> Figure:
    """A simulator run as a strip of ``frames`` panels at evenly spaced times: each panel is
    the kernel's slice at the rod's orientation then (green: in the kernel), with the target's
    and observer's paths so far and the rod. A controller that keeps the state in the kernel
    keeps the target's dot on green."""
    observer = "tab:purple"  # the slice's orange means 'outside'

    tr = result.trace
    if fig is None:
        fig = Figure(figsize=(3.6 * frames, 3.6), layout="constrained")
    axes = fig.subplots(1, frames, squeeze=False)[0]
    idx = np.linspace(0, len(tr.p) - 1, frames).astype(int)
    for ax, i in zip(axes, idx, strict=True):
        a = float(tr.a[i])
        plot_kernel_slice(kernel, a, ax)
        p, o = tr.p[: i + 1], tr.observer[: i + 1]
        ax.plot(p[:, 0], p[:, 1], color=TARGET_COLOUR, lw=1.2, zorder=4)
        ax.plot(o[:, 0], o[:, 1], color=observer, lw=1.2, zorder=4)
        ax.plot([p[-1, 0], o[-1, 0]], [p[-1, 1], o[-1, 1]], color=ROD_COLOUR, lw=2.5,
                zorder=5)
        ax.plot(*p[-1], "o", color=TARGET_COLOUR, ms=5, zorder=6)
        inside = bool(kernel.contains(p[-1:], a)[0])
        ax.set_title(f"t = {tr.t[i]:.1f} s, a = {math.degrees(a) % 360:.0f}°"
                     f"{'' if inside else ' (outside)'}", fontsize=9)
    fig.suptitle(f"{result.controller} vs {result.target}: {result.outcome} — the kernel's "
                 "slice at the rod's orientation (green: safe)", fontsize=9)
    return fig


def plot_certified_slice(certified: Any, optimistic: Any, angle: float, ax: Any = None,
                         pixels: int = 160) -> list:
    """The states at orientation ``angle`` (radians) in four colours
    (:data:`CERTIFIED_COLOURS`): rod blocked, unsafe (outside ``optimistic``, a grid kernel of
    scheme ``"outer"``), undecided, certified safe (``certified``, a
    :class:`~tether.game.certified.CertifiedKernel`); ``pixels`` across the larger side."""
    from tether.arcs import rod_is_free_many
    from tether.game.certified import classify

    ax = ensure_axes(ax)
    env = certified.env
    x0, y0, x1, y1 = env.bounds
    step = max(x1 - x0, y1 - y0) / pixels
    xs = np.arange(x0 + step / 2, x1, step)
    ys = np.arange(y0 + step / 2, y1, step)
    X, Y = np.meshgrid(xs, ys)
    pts = np.column_stack([X.ravel(), Y.ravel()])
    code = np.full(len(pts), np.nan)
    inside = env.contains(pts[:, 0], pts[:, 1])
    q = pts[inside]
    free = rod_is_free_many(env, q, np.full(len(q), angle), certified.lss)
    word = classify(certified, optimistic, q, angle)
    rank = {"unsafe": 1.0, "undecided": 2.0, "safe": 3.0}
    code[inside] = np.where(free, np.vectorize(rank.get, otypes=[float])(word), 0.0)
    img = ax.imshow(code.reshape(X.shape), origin="lower",
                    extent=(x0, x0 + len(xs) * step, y0, y0 + len(ys) * step),
                    cmap=ListedColormap(list(CERTIFIED_COLOURS)), vmin=-0.5, vmax=3.5,
                    interpolation="nearest", zorder=1)
    arts: list = [img]
    arts += plot_map(env, ax, labels=False)
    ax.set_title(f"a = {math.degrees(angle):.0f}°")
    ax.set_aspect("equal")
    return arts


def certified_figure(certified: Any, optimistic: Any,
                     angles: tuple[float, ...] = (0.0, math.pi / 2, math.pi, 3 * math.pi / 2),
                     fig: Any = None) -> Figure:
    """Slices of the certified answer at ``angles`` (radians): certified safe, undecided and
    unsafe in three colours (:func:`plot_certified_slice`)."""
    if fig is None:
        fig = Figure(figsize=(4.2 * math.ceil(len(angles) / 2), 7.0), layout="constrained")
    ncols = math.ceil(len(angles) / 2)
    for n, a in enumerate(angles):
        plot_certified_slice(certified, optimistic, a, fig.add_subplot(2, ncols, 1 + n))
    state = "certified" if certified.certified else "NOT certified: nothing is claimed safe"
    fig.suptitle(f"certified kernel ({state}), vt/vo = {certified.vt / certified.vo:.2g}, "
                 f"lss = {certified.lss:g} — green: safe, gold: undecided, red: unsafe "
                 "(optimistic kernel), grey: rod blocked", fontsize=9)
    return fig
