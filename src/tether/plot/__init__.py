"""matplotlib figures: every stage of the pipeline drawn, none changed. The only part of tether
that imports matplotlib.

Every ``plot_*`` function takes ``ax=None`` (a new figure is made when omitted), draws, and
returns the list of artists it added (the run and start figures return their axes); none calls
``plt.show()``. Figures are built with ``matplotlib.figure.Figure`` so that saving works under
any backend.

Modules: :mod:`~tether.plot.axes` (axes, colours, saving), :mod:`~tether.plot.motion` (the
observer's motions and the distance bound), :mod:`~tether.plot.map`,
:mod:`~tether.plot.decomposition`, :mod:`~tether.plot.verdict` (G after elimination),
:mod:`~tether.plot.sweep`, :mod:`~tether.plot.kernel` (the surveillance kernel),
:mod:`~tether.plot.run` (simulated runs, animations) and :mod:`~tether.plot.assess` (a start).
"""

from __future__ import annotations

from tether.plot.assess import plot_assessment
from tether.plot.axes import OBSERVER_COLOUR, ROD_COLOUR, TARGET_COLOUR, new_axes, save
from tether.plot.decomposition import CURVE_COLOURS, plot_decomposition
from tether.plot.kernel import (
    CERTIFIED_COLOURS,
    SLICE_COLOURS,
    certified_figure,
    kernel_figure,
    kernel_run_strip,
    plot_certified_slice,
    plot_kernel_run,
    plot_kernel_slice,
    plot_safe_fraction,
)
from tether.plot.map import plot_map
from tether.plot.motion import (
    bound_figure,
    plot_distance_bound,
    plot_rotation,
    plot_tractrix,
    plot_vertex,
    plot_wall,
)
from tether.plot.run import MODE_COLOURS, animate_run, draw_scene, draw_trigger_curves, plot_run
from tether.plot.sweep import plot_sweep
from tether.plot.verdict import plot_graph, plot_verdict

__all__ = [
    # axes, colours, saving
    "new_axes", "save", "TARGET_COLOUR", "OBSERVER_COLOUR", "ROD_COLOUR", "CURVE_COLOURS",
    "MODE_COLOURS", "SLICE_COLOURS", "CERTIFIED_COLOURS",
    # the observer's motions and the distance bound
    "plot_tractrix", "plot_rotation", "plot_wall", "plot_vertex", "plot_distance_bound",
    "bound_figure",
    # maps, decompositions, the verdict
    "plot_map", "plot_decomposition", "plot_graph", "plot_verdict",
    # sweeps and the surveillance kernel
    "plot_sweep", "plot_safe_fraction", "plot_kernel_slice", "kernel_figure", "plot_kernel_run",
    "kernel_run_strip", "certified_figure", "plot_certified_slice",
    # simulated runs and starts
    "draw_scene", "draw_trigger_curves", "plot_run", "animate_run", "plot_assessment",
]
