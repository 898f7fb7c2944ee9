"""Deprecated: moved to :mod:`tether.plot.kernel` (this alias goes in the next release)."""

import warnings

from tether.plot.kernel import *  # noqa: F403
from tether.plot.kernel import __all__  # noqa: F401

warnings.warn("tether.plot_kernel is deprecated; import from tether.plot.kernel (or tether.plot)",
              DeprecationWarning, stacklevel=2)
