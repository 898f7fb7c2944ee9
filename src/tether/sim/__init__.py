"""Simulation: controllers, targets, the simulator and its monitor.

The simulator takes a controller and a target as objects that follow the protocols of
:mod:`tether.sim.protocols`, so the paper's controller (:mod:`tether.sim.controller`) and the
surveillance kernel's (:mod:`tether.game`) are interchangeable, and so are the target kinds.
It never imports :mod:`tether.game` (the registries naming both are :mod:`tether.strategies`)
nor matplotlib.

Modules: ``protocols`` (World, Command, Controller, Target), ``simulate`` (the loop, the
monitor, traces), ``controller`` (paper, follow, translate), ``targets`` (path, random, wall,
tangential, dash, escape, search), ``local`` (the free arc around the rod in µs), ``paths``
(shortest paths for targets), ``scenarios`` (the paper's Figs. 7 and 8, live), ``diagnose``
(why a run from a safe start was lost: a gap of the paper's conditions or a bug).
"""

__all__: list[str] = []  # the modules are the interface: tether.sim.simulate, .controller, …
