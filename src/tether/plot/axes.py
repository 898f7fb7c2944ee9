"""The axes every figure draws into, the colours the figures share, and saving.

Figures are built with ``matplotlib.figure.Figure`` (not registered with pyplot) so that saving
works under any backend.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

from matplotlib.figure import Figure

__all__ = [
    "TARGET_COLOUR", "OBSERVER_COLOUR", "ROD_COLOUR", "animation_path", "new_axes", "ensure_axes",
    "save", "save_animation",
]

TARGET_COLOUR = "tab:blue"
OBSERVER_COLOUR = "tab:orange"
ROD_COLOUR = "0.55"


def new_axes(ncols: int = 1, size: tuple[float, float] = (6.4, 4.8)) -> tuple[Figure, Any]:
    """A new figure (not registered with pyplot) and its axes."""
    fig = Figure(figsize=(size[0] * ncols, size[1]), layout="constrained")
    axes = fig.subplots(1, ncols)
    return fig, axes


def ensure_axes(ax: Any) -> Any:
    """``ax``, or the axes of a new figure when ``ax`` is None."""
    return new_axes()[1] if ax is None else ax


def save(fig: Figure, path: str | Path, dpi: int = 120) -> None:
    """Save a figure whole: written to a temporary file with the same extension, then renamed
    (:func:`tether._util.files.atomic_output`); nothing is left behind if saving fails."""
    from tether._util.files import atomic_output

    with atomic_output(Path(path)) as tmp:
        fig.savefig(tmp, dpi=dpi)


def animation_path(path: str | Path) -> Path:
    """``path`` as a :class:`~pathlib.Path` when tether can write an animation there
    (``.gif``, ``.html``, or ``.mp4`` with ffmpeg installed).

    Raises
    ------
    TetherError
        Unknown extension, or ``.mp4`` without ffmpeg.
    """
    import shutil

    from tether.errors import TetherError

    path = Path(path)
    kind = path.suffix.lower()
    if kind not in (".gif", ".mp4", ".html"):
        raise TetherError(f"{path}: animations are .gif, .mp4 or .html")
    if kind == ".mp4" and shutil.which("ffmpeg") is None:
        raise TetherError(f"{path}: writing MP4 needs ffmpeg, which is not installed; "
                          "use .gif or .html")
    return path


def save_animation(anim: Any, fig: Figure, path: Path, fps: float) -> Path:
    """Write a matplotlib animation to ``path`` (checked by :func:`animation_path`) whole or not
    at all, then close its figure; ``fps`` frames per second."""
    import matplotlib.pyplot as plt
    from matplotlib import animation

    from tether._util.files import atomic_output

    kind = path.suffix.lower()
    with atomic_output(path) as tmp:
        if kind == ".gif":
            anim.save(tmp, writer=animation.PillowWriter(fps=fps))
        elif kind == ".mp4":
            anim.save(tmp, writer=animation.FFMpegWriter(fps=fps))
        else:
            Path(tmp).write_text(anim.to_jshtml(fps=fps))
    plt.close(fig)
    return path
