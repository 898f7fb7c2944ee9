"""Figures of the surveillance kernel: safe fraction, slices, runs drawn over them."""

from __future__ import annotations

import pytest

from tether import load_map
from tether.examples import path as example_path
from tether.plot.axes import save
from tether.plot.kernel import kernel_figure, kernel_run_strip, plot_kernel_run


@pytest.mark.slow
def test_kernel_figures(tmp_path):
    import math

    from tether.game import surveillance_kernel
    from tether.game.controller import KernelController
    from tether.sim.protocols import World
    from tether.sim.simulate import simulate
    from tether.strategies import make_target

    env = load_map(example_path("nonconvex_corner"))
    k = surveillance_kernel(env, 1.0, 0.6, 1.0, h=0.5, orientations=36)
    save(kernel_figure(k, angles=(0.0, math.pi)), tmp_path / "k.png")
    w = World(env, 1.0, 0.6, 1.0, extra={"kernel": k})
    r = simulate(w, KernelController(), make_target("kernel-evader", w), (5.0, 5.0, 0.0),
                 duration=2.0, dt=0.05)
    arts = plot_kernel_run(k, r)
    assert arts
    assert (tmp_path / "k.png").stat().st_size > 0
    fig = kernel_run_strip(k, r, frames=3)
    assert len(fig.axes) == 3 and "t = 2.0 s" in fig.axes[-1].get_title()
    save(fig, tmp_path / "strip.png")
    assert (tmp_path / "strip.png").stat().st_size > 0
