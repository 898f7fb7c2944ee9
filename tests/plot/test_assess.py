"""The figure of a start's assessment (``tether assess --plot``)."""

import pytest

from tether.analysis import assess
from tether.plot import plot_assessment, save
from tether.sim.scenarios import _world


@pytest.mark.slow
def test_plot_assessment_draws_the_start(tmp_path):
    world = _world("nonconvex_corner", 2.0, 0.5, 1.0)
    res = assess(world.verdict, 0.5, 1.0, 5.0, 1.0, 1.57)
    ax = plot_assessment(res, world)
    assert ax.get_title() == "assess (5, 1, 1.57): safe"
    save(ax.figure, tmp_path / "a.png")
    assert (tmp_path / "a.png").stat().st_size > 0
