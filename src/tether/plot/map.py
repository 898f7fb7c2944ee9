"""The map drawn: free space, obstacles, edges and the feature names of the paper's figures."""

from __future__ import annotations

from typing import Any

import numpy as np

from tether.plot.axes import ensure_axes

__all__ = ["plot_map"]


def plot_map(env: Any, ax: Any = None, labels: bool = True) -> list:
    """The free space: obstacles grey, edges black, features labelled ``V<j>``/``E<i>`` as in
    the paper's figures (reflex vertices marked).

    Examples
    --------
    >>> import matplotlib; matplotlib.use("Agg")
    >>> from tether import Environment
    >>> from tether.plot import plot_map
    >>> room = Environment([(0, 0), (1.5, 0), (1.5, 3), (0, 3)])
    >>> artists = plot_map(room)
    >>> sorted(a.get_text() for a in artists if hasattr(a, "get_text"))  # the feature names
    ['E0', 'E1', 'E2', 'E3', 'V0', 'V1', 'V2', 'V3']
    """
    ax = ensure_axes(ax)
    x0, y0, x1, y1 = env.bounds
    pad = 0.04 * env.diameter
    arts = [ax.fill([x0 - pad, x1 + pad, x1 + pad, x0 - pad],
                    [y0 - pad, y0 - pad, y1 + pad, y1 + pad], color="0.85", zorder=0)]
    arts += ax.fill(env.boundary[:, 0], env.boundary[:, 1], color="white", zorder=0)
    for h in env.holes:
        arts += ax.fill(h[:, 0], h[:, 1], color="0.85", zorder=0)
    for ring in env.rings:
        closed = np.vstack((ring, ring[:1]))
        arts += ax.plot(closed[:, 0], closed[:, 1], color="k", lw=1.5, zorder=3)
    if labels and env.n <= 80:
        V = env.vertices
        c = V.mean(axis=0)
        for j, v in enumerate(V):
            off = v - c
            off = 0.015 * env.diameter * off / max(np.hypot(*off), 1e-300)
            arts.append(ax.annotate(f"V{j}", v, xytext=v + off, fontsize=7, color="navy",
                                    ha="center", va="center", zorder=5))
        nxt = env.next_vertex
        for i in range(env.n):
            mid = 0.5 * (V[i] + V[nxt[i]])
            arts.append(ax.text(*(mid - 0.02 * env.diameter * env.free_normals[i]), f"E{i}",
                                fontsize=7, color="darkgreen", ha="center", va="center",
                                zorder=5))
        r = env.reflex_indices
        arts += ax.plot(V[r, 0], V[r, 1], "o", color="navy", ms=3, zorder=4)
    ax.set_aspect("equal")
    ax.set_xlim(x0 - pad, x1 + pad)
    ax.set_ylim(y0 - pad, y1 + pad)
    return arts
