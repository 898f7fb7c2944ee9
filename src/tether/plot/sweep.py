"""The sweep figure: verdict and counts against the rod length ``lss``, read from a
:class:`tether.sweep.SweepResult`."""

from __future__ import annotations

from typing import Any

import numpy as np

from tether.plot.axes import new_axes

__all__ = ["plot_sweep"]


def plot_sweep(result: Any, ax: Any = None) -> list:
    """Draw a sweep: shaded intervals of ``lss`` with a strategy, the counts of regions, cells
    and surviving cells per evaluated ``lss`` (log scale), the verdict of each row as a marker on
    the bottom line, and the kernel's safe fraction on a right axis when the rows carry it.

    Parameters
    ----------
    result : tether.sweep.SweepResult
    ax : matplotlib Axes, optional
        Drawn into; a new figure when omitted.

    Returns
    -------
    list
        The artists added.
    """
    if ax is None:
        ax = new_axes(size=(8, 4.5))[1]
    rows = result.rows
    lss = np.array([r.lss for r in rows])
    arts: list = []
    for k, iv in enumerate(result.intervals):
        arts.append(ax.axvspan(iv.lo, iv.hi, color="tab:green", alpha=0.18, lw=0,
                               label="strategy can exist" if k == 0 else None))
    ok = [r for r in rows if r.error is None]
    for key, colour in (("regions", "0.4"), ("cells", "tab:blue"),
                        ("surviving_cells", "tab:green")):
        x = [r.lss for r in ok]
        y = [max(r.counts.get(key, 0), 0.8) for r in ok]
        arts += ax.plot(x, y, ".-", color=colour, ms=4, lw=1, label=key.replace("_", " "))
    ax.set_yscale("log")
    base = 0.6
    for verdict, colour, label in ((True, "tab:green", "strategy"),
                                   (False, "tab:red", "no strategy"),
                                   (None, "0.5", "error")):
        x = lss[[r.strategy_exists is verdict for r in rows]]
        if len(x):
            arts.append(ax.scatter(x, np.full(len(x), base), marker="|", s=80, color=colour,
                                   label=label))
    ax.set_xlabel("lss (map units)")
    ax.set_ylabel("count (log)")
    longest = result.longest
    title = f"{result.map_name or 'map'}: "
    title += "no lss with a strategy" if longest is None else \
        f"longest lss with a strategy {longest:.4g}"
    ax.set_title(title)
    fracs = [(r.lss, r.safe_fraction) for r in rows if r.safe_fraction is not None]
    if fracs:
        ax2 = ax.twinx()
        fx, fy = zip(*fracs, strict=True)
        arts += ax2.plot(fx, fy, "s--", color="tab:purple", ms=3, lw=1,
                         label="kernel safe fraction")
        ax2.set_ylim(0, 1.05)
        ax2.set_ylabel("kernel safe fraction")
        ax2.legend(loc="upper right", fontsize=8)
    ax.legend(loc="upper left", fontsize=8)
    return arts
