"""The numerical tolerances of tether, one per kind of quantity.

All computation happens in a normalized internal frame (:attr:`tether.environment.Environment.
frame`): the map translated to its bounding box's centre and scaled by a power of two (exact) to
a diameter near 1, so every tolerance below is relative to the map and a map gives the same
answer wherever it sits. Results are reported back in the user's coordinates.

Lengths are compared with ``REL_LENGTH_TOL * diameter`` where ``diameter`` is the largest
distance between two of the map's vertices, which rotation does not change (see
:attr:`tether.environment.Environment.length_tol`); angles with
``ANGLE_TOL`` radians. Computed points (curve crossings, contacts) are always compared with
these tolerances, never exactly.
"""

__all__ = [
    "ANGLE_MAX", "ANGLE_TOL", "CHECK_LINES", "COORD_MAX", "LINES_RANGE", "LSS_MAX_REL",
    "LSS_MIN_REL", "MAX_MAP_BYTES", "MAX_VERTICES", "MIN_DIAMETER", "MIN_DIAMETER_REL",
    "REL_CURVE_TOL", "REL_FEATURE_TOL", "REL_LENGTH_TOL", "REL_STRAIGHT_TOL", "SAMPLES_RANGE",
    "SCAN_POINTS_PER_DIAMETER", "SELF_CHECK_LINES", "SPEED_GAP_REL", "VALUE_MAX"
]

#: Relative length tolerance: two points closer than this times the map diameter are equal.
REL_LENGTH_TOL = 1e-9

#: Angular tolerance in radians: blocked intervals closer than this merge, free arcs shorter
#: than this (isolated semi-free orientations, which exist only on critical curves) are dropped.
#: A blocked interval narrower than this is a tangency (dropped) only if the edge's part inside
#: the rod's disc is also shorter than the length tolerance: seen nearly end-on, a long edge
#: part subtends less than ANGLE_TOL without being a tangency (issue #9).
ANGLE_TOL = 1e-9

#: Polyline approximation of the critical curves, relative to the map diameter: every curve is
#: drawn within ``REL_CURVE_TOL * diameter`` of its exact shape. Regions thinner than a few
#: times this are below tether's geometric resolution.
REL_CURVE_TOL = 1e-6

# ---------------------------------------------------------------------- valid ranges
# Inputs outside these ranges are rejected with one line (InvalidParameterError /
# InvalidMapError) instead of exhausting memory or losing every digit; see docs/conventions.md.

#: ``lss`` must lie within ``[LSS_MIN_REL, LSS_MAX_REL] ×`` the map's diameter. Below, the
#: critical curves would need more than ~1e9 polyline points; above, every rod reaches every
#: wall and the geometry is that of lss = 1e3 × diameter anyway.
LSS_MIN_REL = 1e-3
LSS_MAX_REL = 1e3

#: Speeds (``vt``, ``vo``), lengths (``lss`` in ``bound``/``plot-motion``) are at most this in
#: absolute value, and positive ones at least ``1 / VALUE_MAX``: far from the float limits so
#: that products and quotients of three of them stay finite and keep their digits.
VALUE_MAX = 1e12

#: ``vo`` must exceed ``vt`` by this fraction of ``vo`` (the safe bound divides by ``vo - vt``).
SPEED_GAP_REL = 1e-9

#: Rotation angles (``--from``, ``--to``) are at most this many radians in absolute value.
ANGLE_MAX = 1e4

#: Maps: at most this many vertices in all, and files at most this many bytes.
MAX_VERTICES = 100_000
MAX_MAP_BYTES = 64 * 2**20

#: ``tether check --samples`` per region.
SAMPLES_RANGE = (1, 100_000)

#: Random lines scanned (:mod:`tether.decomposition.scan`): by ``tether check --lines`` (its
#: range and default) and by ``analyze``'s self-check; points evaluated along a line per map
#: diameter.
LINES_RANGE = (0, 10_000)
CHECK_LINES = 20
SELF_CHECK_LINES = 6
SCAN_POINTS_PER_DIAMETER = 2000

#: Map coordinates are at most this in absolute value (squares of differences stay finite).
COORD_MAX = 1e15

#: A map's diameter (largest distance between two vertices) is at least ``MIN_DIAMETER`` map
#: units and at least
#: ``MIN_DIAMETER_REL`` times its largest absolute coordinate: a map 1e-12 of its own offset
#: keeps fewer than 4 of a double's 16 digits for its shape.
MIN_DIAMETER = 1e-9
MIN_DIAMETER_REL = 1e-12

#: A vertex is *straight* (no feature of the free space) when its distance to the chord joining
#: its neighbours is at most this times the chord's length (an interior angle within about
#: ``4 * REL_STRAIGHT_TOL`` radians of pi). Straight vertices produce no curves and no regions;
#: the walls they join keep the file's name of their first edge.
REL_STRAIGHT_TOL = 1e-7

#: Geometric resolution, relative to the map diameter: a wall or a gap thinner than this (a
#: vertex closer than ``REL_FEATURE_TOL * diameter`` to a wall it does not bound, straight
#: vertices aside) is rejected with a message naming the vertex and the wall. Curves overshoot
#: their ends by ``20 * REL_CURVE_TOL`` (see :mod:`tether.curves`); features thinner than a few
#: times that cannot be told apart by the decomposition (``check`` then disagrees).
REL_FEATURE_TOL = 5e-5
