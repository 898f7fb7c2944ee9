"""Run figures and animations (GIF through Pillow, HTML player, MP4 only with ffmpeg)."""

import shutil

import pytest

from tether.errors import TetherError
from tether.plot.run import animate_run, plot_run
from tether.sim.scenarios import fig8


@pytest.fixture(scope="module")
def run():
    return fig8("paper", dt=0.1)


@pytest.mark.slow
def test_plot_run(run, tmp_path):
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    w, r = run
    fig, ax = plt.subplots()
    plot_run(r, w, ax)
    fig.savefig(tmp_path / "r.png")
    plt.close(fig)
    assert (tmp_path / "r.png").stat().st_size > 1000


@pytest.mark.slow
@pytest.mark.parametrize("ext", [".gif", ".html"])
def test_animation_files(run, tmp_path, ext):
    w, r = run
    out = animate_run(r, w, tmp_path / f"a{ext}", max_frames=4, purple=False)
    assert out.stat().st_size > 1000
    if ext == ".gif":
        assert out.read_bytes()[:3] == b"GIF"


@pytest.mark.slow
def test_mp4_needs_ffmpeg(run, tmp_path):
    w, r = run
    if shutil.which("ffmpeg") is None:
        with pytest.raises(TetherError, match="ffmpeg"):
            animate_run(r, w, tmp_path / "a.mp4", max_frames=3)
    with pytest.raises(TetherError):
        animate_run(r, w, tmp_path / "a.avi")
