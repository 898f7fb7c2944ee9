"""The cell decomposition (``docs/formulas.md``, "Critical curves" and "The verdict"): regions,
cells and boundary pieces, point location.

Regions are the maximal connected open sets of target positions over which the labelled
free-arc structure stays the same. They are computed from the arrangement of the critical
curves, never from a grid: the curves' polylines and the map's rings are noded (shapely) and
the faces of the noded lines traced from their half-edges; each face's structure is evaluated
exactly at a point well inside it; faces adjacent across a curve piece with equal structure
are merged. Sampling is how :func:`check` verifies the result.

Tolerances: curves are drawn within ``curve_tol = REL_CURVE_TOL * diameter`` of their exact
shape. A face whose inscribed circle is smaller than ``2 * curve_tol`` is below that resolution:
it gets no structure of its own and joins the neighbour it shares most boundary with.
A target passing exactly through an arrangement vertex is not modelled.

The package, bottom to top: :mod:`~tether.decomposition.structure` and
:mod:`~tether.decomposition.views` (the records and their storage),
:mod:`~tether.decomposition.model` (:class:`Decomposition`, :class:`Region`),
:mod:`~tether.decomposition.frame` (results reported in the map's frame),
:mod:`~tether.decomposition.coincidence`, :mod:`~tether.decomposition.noding`,
:mod:`~tether.decomposition.faces` and :mod:`~tether.decomposition.arrangement`,
:mod:`~tether.decomposition.pieces`, :mod:`~tether.decomposition.regions`,
:mod:`~tether.decomposition.pipeline` (:func:`decompose`), and
:mod:`~tether.decomposition.scan` and :mod:`~tether.decomposition.verify` (verification).
"""

from __future__ import annotations

from tether.decomposition.arrangement import SOURCE_BATCH as SOURCE_BATCH
from tether.decomposition.faces import MIC_MIN_BOUND as MIC_MIN_BOUND
from tether.decomposition.model import Decomposition, Region
from tether.decomposition.pieces import ACROSS_BATCH as ACROSS_BATCH
from tether.decomposition.pieces import CLEARANCE_BATCH as CLEARANCE_BATCH
from tether.decomposition.pieces import CLEARANCE_STAGES as CLEARANCE_STAGES
from tether.decomposition.pieces import CLEARANCE_Z_CELL as CLEARANCE_Z_CELL
from tether.decomposition.pipeline import decompose
from tether.decomposition.structure import FREE as FREE
from tether.decomposition.structure import Structure as Structure
from tether.decomposition.structure import crossing_points as crossing_points
from tether.decomposition.structure import feature_name_rank as feature_name_rank
from tether.decomposition.structure import structure_codes as structure_codes
from tether.decomposition.structure import structure_ids as structure_ids
from tether.decomposition.structure import structure_names as structure_names
from tether.decomposition.structure import structures
from tether.decomposition.structure import structures_across as structures_across
from tether.decomposition.verify import (
    SELF_CHECK_REGIONS as SELF_CHECK_REGIONS,
)
from tether.decomposition.verify import (
    UNRESOLVED_MAX_ROOT as UNRESOLVED_MAX_ROOT,
)
from tether.decomposition.verify import (
    UNRESOLVED_MAX_TOLS as UNRESOLVED_MAX_TOLS,
)
from tether.decomposition.verify import CheckReport, check, sample_in_regions, self_check
from tether.decomposition.views import PIECE_BATCH as PIECE_BATCH
from tether.decomposition.views import Cell, Piece, cell_name
from tether.decomposition.views import valid_polygons as valid_polygons
from tether.errors import ArrangementError

__all__ = ["ArrangementError", "Cell", "CheckReport", "Decomposition", "Piece", "Region",
           "cell_name", "check", "decompose", "sample_in_regions", "self_check", "structures"]
