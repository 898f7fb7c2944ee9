"""Regenerate the figures of ``docs/paper_examples.md``: ``python docs/make_figures.py``."""

from __future__ import annotations

from pathlib import Path

from tether import load_map
from tether.analysis import analyze
from tether.decomposition import decompose
from tether.examples import path as example_path
from tether.plot import new_axes, plot_decomposition, plot_verdict, save

OUT = Path(__file__).with_name("figures")


def main() -> None:
    OUT.mkdir(exist_ok=True)
    for name in ("rectangle", "convex_corner", "nonconvex_corner"):
        v = analyze(decompose(load_map(example_path(name)), 1.0))
        save(plot_verdict(v), OUT / f"{name}.png")
        if name != "rectangle":  # the paper draws only the neighbourhood of the corner
            fig, ax = new_axes(size=(6, 6))
            marked = {v.dec.cells[e.cell].region for e in v.eliminated}
            plot_decomposition(v.dec, ax, marked_regions=marked)
            lo = -2.5 if name == "convex_corner" else -0.5
            ax.set_xlim(lo, lo + 5)
            ax.set_ylim(lo, lo + 5)
            ax.set_title(f"{name}: the corner's neighbourhood (lss = 1)")
            save(fig, OUT / f"{name}_zoom.png")
        print(name, v.counts())


if __name__ == "__main__":
    main()
