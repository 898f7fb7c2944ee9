"""Axes and saving: a figure is written whole or not at all."""

import os

from tether.plot import axes


def test_plot_save_is_atomic(tmp_path):
    fig, _ = axes.new_axes()
    axes.save(fig, tmp_path / "f.svg")
    assert os.listdir(tmp_path) == ["f.svg"]

