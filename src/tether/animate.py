"""Deprecated: moved to :mod:`tether.plot.run` (this alias goes in the next release)."""

import warnings

from tether.plot.run import *  # noqa: F403
from tether.plot.run import __all__  # noqa: F401

warnings.warn("tether.animate is deprecated; import from tether.plot.run (or tether.plot)",
              DeprecationWarning, stacklevel=2)
