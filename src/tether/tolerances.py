"""The numerical tolerances of tether, one per kind of quantity.

Lengths are compared with ``REL_LENGTH_TOL * diameter`` where ``diameter`` is the diagonal of
the map's bounding box (see :attr:`tether.environment.Environment.length_tol`); angles with
``ANGLE_TOL`` radians. Computed points (curve crossings, contacts) are always compared with
these tolerances, never exactly.
"""

#: Relative length tolerance: two points closer than this times the map diameter are equal.
REL_LENGTH_TOL = 1e-9

#: Angular tolerance in radians: blocked intervals closer than this merge, free arcs shorter
#: than this (isolated semi-free orientations, which exist only on critical curves) are dropped.
ANGLE_TOL = 1e-9

#: Polyline approximation of the critical curves, relative to the map diameter: every curve is
#: drawn within ``REL_CURVE_TOL * diameter`` of its exact shape. Regions thinner than a few
#: times this are below tether's geometric resolution.
REL_CURVE_TOL = 1e-6
