"""A one-line progress bar on stderr, shown only when stderr is a terminal."""

from __future__ import annotations

import sys
import time
from typing import TextIO

__all__ = ["Progress"]


class Progress:
    """Callable ``progress(stage, fraction)`` that redraws a bar like
    ``decompose [#######-----] 58% regions``; silent when the stream is not a terminal."""

    def __init__(self, label: str, stream: TextIO | None = None, width: int = 24) -> None:
        self.label = label
        self.stream = stream if stream is not None else sys.stderr
        self.width = width
        self.enabled = hasattr(self.stream, "isatty") and self.stream.isatty()
        self.start = time.perf_counter()

    def __call__(self, stage: str, fraction: float) -> None:
        """Draw the bar for ``stage`` at ``fraction`` done (0 to 1); nothing off a terminal."""
        if not self.enabled:
            return
        n = int(round(self.width * min(max(fraction, 0.0), 1.0)))
        bar = "#" * n + "-" * (self.width - n)
        secs = time.perf_counter() - self.start
        self.stream.write(f"\r{self.label} [{bar}] {fraction:4.0%} {stage:<16} {secs:5.1f}s")
        if fraction >= 1.0:
            self.stream.write("\n")
        self.stream.flush()
