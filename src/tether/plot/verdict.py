"""The paper's result drawn (Figs. 6-8): the connectivity graph G after elimination, beside the
decomposition with the regions of eliminated cells marked."""

from __future__ import annotations

import math
from typing import Any

import numpy as np
from matplotlib.figure import Figure

from tether.decomposition.views import parse_cell_name
from tether.plot.axes import ensure_axes, new_axes
from tether.plot.decomposition import plot_decomposition

__all__ = ["plot_graph", "plot_verdict"]


def plot_graph(verdict: Any, ax: Any = None, only_surviving: bool = True) -> list:
    """The connectivity graph G (after elimination by default), nodes placed at their regions'
    points and spread around them; eliminated cells (if shown) in red."""
    import networkx as nx

    ax = ensure_axes(ax)
    g = verdict.graph.graph
    dec = verdict.dec
    keep = [c for c in g.nodes if c in verdict.surviving or not only_surviving]
    sub = g.subgraph(keep)
    pos = {}
    scale = 0.03 * dec.env.diameter
    for r in dec.regions:
        cs = [c for c in r.cells if c in sub]
        for k, c in enumerate(cs):
            ang = 2 * math.pi * k / max(len(cs), 1)
            off = scale * np.array([math.cos(ang), math.sin(ang)]) if len(cs) > 1 else 0
            pos[c] = np.asarray(r.point) + off
    colours = ["tab:blue" if c in verdict.surviving else "tab:red" for c in sub.nodes]
    arts = [nx.draw_networkx_edges(sub, pos, ax=ax, edge_color="0.5", width=0.8)]
    arts.append(nx.draw_networkx_nodes(sub, pos, ax=ax, node_size=18, node_color=colours))
    if sub.number_of_nodes() <= 60:
        labels = {c: "R{} {} {}".format(*parse_cell_name(c)) for c in sub.nodes}
        arts.append(nx.draw_networkx_labels(sub, pos, labels, ax=ax, font_size=6))
    x0, y0, x1, y1 = dec.env.bounds
    ring = np.vstack((dec.env.boundary, dec.env.boundary[:1]))
    arts += ax.plot(ring[:, 0], ring[:, 1], color="0.8", lw=1, zorder=0)
    ax.set_aspect("equal")
    ax.set_title(f"G after elimination: {len(verdict.surviving)} of {len(dec.cells)} cells"
                 if only_surviving else
                 f"G: {len(dec.cells)} cells, all eliminated (red) in {verdict.rounds} rounds")
    return arts


def plot_verdict(verdict: Any, fig: Any = None) -> Figure:
    """Paper Figs. 6-8: left, the decomposition with regions holding eliminated cells marked
    by red rectangles; right, the graph G after elimination.

    Examples
    --------
    >>> import matplotlib; matplotlib.use("Agg")
    >>> from tether import Environment
    >>> from tether.analysis import analyze
    >>> from tether.decomposition import decompose
    >>> from tether.plot import plot_verdict
    >>> room = Environment([(0, 0), (1.5, 0), (1.5, 3), (0, 3)])
    >>> fig = plot_verdict(analyze(decompose(room, 1.0)))
    >>> len(fig.axes), fig.axes[0].texts[-1].get_text()  # the witness region, boxed in red
    (2, 'R9')
    """
    if fig is None:
        fig, (ax1, ax2) = new_axes(2, size=(6.4, 6.4))
    else:
        ax1, ax2 = fig.subplots(1, 2)
    marked = {verdict.dec.cells[e.cell].region for e in verdict.eliminated}
    plot_decomposition(verdict.dec, ax1, marked_regions=marked)
    if verdict.witness_region is not None:
        w = verdict.dec.regions[verdict.witness_region]
        ax1.text(*w.point, w.name, fontsize=8, ha="center", va="center", zorder=7,
                 color="white", bbox=dict(boxstyle="square,pad=0.2", fc="red", ec="red"))
    # after elimination when something survives (as in the paper); else all of G, red = fallen
    plot_graph(verdict, ax2, only_surviving=verdict.strategy_exists)
    word = "a strategy can exist" if verdict.strategy_exists else "no strategy"
    fig.suptitle(f"{verdict.dec.env.name}: {word}"
                 + ("" if verdict.witness_region is None
                    else f" (witness R{verdict.witness_region})"))
    return fig
