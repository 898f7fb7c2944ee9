"""The figure of a start's assessment (``tether assess --plot``): the rod at the start over the
decomposition, the escape points in reach and the second set of critical curves."""

from __future__ import annotations

import math
from typing import Any

from tether.plot.run import draw_scene, draw_trigger_curves

__all__ = ["plot_assessment"]


def plot_assessment(assessment: Any, world: Any, ax: Any = None, escape_points: int = 8) -> Any:
    """Figure of a start: the scene of ``world`` (:func:`~tether.plot.run.draw_scene`), the
    curves for the start's orientation, the rod (green when safe, red when not), the target's
    position and the first ``escape_points`` escape points of the
    :class:`~tether.analysis.Assessment`. Returns the axes."""
    import matplotlib.pyplot as plt

    if ax is None:
        _, ax = plt.subplots(figsize=(7, 6))
    x, y, a = assessment.start
    draw_scene(ax, world)
    draw_trigger_curves(ax, world, a)
    ax.plot([x, x + assessment.lss * math.cos(a)], [y, y + assessment.lss * math.sin(a)], "-",
            color="green" if assessment.safe else "red", lw=2.5, zorder=6)
    ax.plot([x], [y], "ko", zorder=7)
    for e in assessment.escape_points[:escape_points]:
        ax.plot(*e.point, "*", color="purple", ms=9, zorder=7)
    ax.set_title(f"assess ({x:g}, {y:g}, {a:g}): {'safe' if assessment.safe else 'unsafe'}",
                 fontsize=9)
    return ax
