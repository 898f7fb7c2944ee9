"""The decomposition drawn (paper Figs. 6-8): the map, the critical curves and the regions."""

from __future__ import annotations

from typing import Any

import numpy as np

from tether.plot.axes import ensure_axes
from tether.plot.map import plot_map

__all__ = ["CURVE_COLOURS", "plot_decomposition"]

CURVE_COLOURS = {"A": "tab:red", "B": "tab:purple", "C": "tab:green", "D": "tab:brown",
                 "E": "tab:pink"}


def plot_decomposition(dec: Any, ax: Any = None, by_type: bool = False, labels: bool = True,
                       marked_regions: Any = (), tint: bool = True) -> list:
    """Paper Figs. 6-8: the map, critical curves (red, or coloured by type), regions tinted
    and labelled ``R<k>``; ``marked_regions`` get a red rectangle around their label.

    Examples
    --------
    >>> import matplotlib; matplotlib.use("Agg")
    >>> from tether import Environment
    >>> from tether.decomposition import decompose
    >>> from tether.plot import plot_decomposition
    >>> room = Environment([(0, 0), (1.5, 0), (1.5, 3), (0, 3)])
    >>> artists = plot_decomposition(decompose(room, 1.0))
    >>> sum(a.get_text().startswith("R") for a in artists if hasattr(a, "get_text"))  # regions
    19
    """
    import matplotlib as mpl

    ax = ensure_axes(ax)
    arts = plot_map(dec.env, ax, labels=labels)
    if tint:
        cmap = mpl.colormaps["Pastel1"]
        for r in dec.regions:
            for poly in getattr(r.polygon, "geoms", [r.polygon]):
                xy = np.asarray(poly.exterior.coords)
                arts += ax.fill(xy[:, 0], xy[:, 1], color=cmap(r.id % 9), alpha=0.55, lw=0,
                                zorder=1)
    for kind in "ABCDE":
        colour = CURVE_COLOURS[kind] if by_type else "red"
        first = True
        for c in dec.curves:
            if c.kind != kind:
                continue
            for p in c.polylines:
                (line,) = ax.plot(p[:, 0], p[:, 1], color=colour, lw=0.9, zorder=2,
                                  label=f"{kind}: {_kind_name(kind)}" if by_type and first
                                  else None)
                arts.append(line)
                first = False
    if labels and len(dec.regions) <= 120:
        marked = set(marked_regions)
        for r in dec.regions:
            box = dict(boxstyle="square,pad=0.15", fc="none", ec="red", lw=1.5) \
                if r.id in marked else None
            arts.append(ax.text(*r.point, r.name, fontsize=7, ha="center", va="center",
                                zorder=6, bbox=box, clip_on=True))
    if by_type:
        ax.legend(fontsize=7, loc="upper right")
    ax.set_title(f"{dec.env.name or 'map'}: lss={dec.lss:g}, {len(dec.regions)} regions, "
                 f"{len(dec.cells)} cells")
    return arts


def _kind_name(kind: str) -> str:
    from tether.curves import KIND_NAMES

    return KIND_NAMES[kind]
