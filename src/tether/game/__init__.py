"""The surveillance kernel: the bounded-speed game solved on a grid (``docs/formulas.md``,
"The surveillance kernel"; ``docs/kernel.md``).

* :mod:`tether.game.grid` — the grid over ``(x, y, a)`` and its free-state mask from the exact
  free arcs (:mod:`tether.arcs`), with the free run of orientations each state lies in;
* :mod:`tether.game.kernel` — :func:`surveillance_kernel`, the discriminating kernel by a
  vectorized fixed-point iteration with a worklist, and its :class:`Kernel` result;
* :mod:`tether.game.controller` — :class:`KernelController`, the rate in Ω keeping the next
  state deepest inside the kernel;
* :mod:`tether.game.evader` — :class:`KernelEvader`, the target move that leaves the kernel;
* the certified kernel (``docs/certified.md``): :mod:`tether.game.cells` (exact blocked
  orientations), :mod:`tether.game.certificate` (the arc field and its checks),
  :mod:`tether.game.field_lp` (the search), :mod:`tether.game.certified`
  (``certified_kernel``, ``CertifiedKernel``; imported from there, as it loads scipy's LP
  solver) and
  :class:`~tether.game.controller.CertifiedController`.

Never imports matplotlib (figures are in :mod:`tether.plot.kernel`).
"""

from tether.game.grid import StateGrid, build_grid
from tether.game.kernel import Kernel, load_kernel, surveillance_kernel

__all__ = ["Kernel", "StateGrid", "build_grid", "load_kernel", "surveillance_kernel"]
