"""Simulation: controllers, targets, the simulator and its monitor.

The simulator takes a controller and a target as objects that follow the protocols of
:mod:`tether.sim.protocols`, so the paper's controller (:mod:`tether.sim.controller`) and the
surveillance kernel's (:mod:`tether.game`) are interchangeable, and so are the target kinds.
May import the pipeline stages above it (environment, arcs, decomposition, escape, bounds,
rates); never imports matplotlib.
"""
