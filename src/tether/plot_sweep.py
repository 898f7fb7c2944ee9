"""Deprecated: moved to :mod:`tether.plot.sweep` (this alias goes in the next release)."""

import warnings

from tether.plot.sweep import *  # noqa: F403
from tether.plot.sweep import __all__  # noqa: F401

warnings.warn("tether.plot_sweep is deprecated; import from tether.plot.sweep (or tether.plot)",
              DeprecationWarning, stacklevel=2)
