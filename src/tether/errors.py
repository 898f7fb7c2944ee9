"""Exception types of tether.

Every error a user can cause (a bad map, a bad parameter, a target outside the free space)
is raised as a subclass of :class:`TetherError`; the CLI prints its message on one line and
exits with status 2.
"""

__all__ = [
    "ArrangementError", "InvalidMapError", "InvalidParameterError", "NonFiniteResultError",
    "OutputPathError", "OutsideFreeSpaceError", "ResourceLimitError", "TetherError"
]
__all__ += ["InvalidTrackError"]


class TetherError(Exception):
    """Base class of every error tether raises on purpose."""


class InvalidMapError(TetherError, ValueError):
    """The map file or polygon is malformed or geometrically invalid."""


class InvalidParameterError(TetherError, ValueError):
    """A numeric parameter is out of range or not finite (e.g. ``lss <= 0``, ``vo <= vt``)."""


class OutsideFreeSpaceError(TetherError, ValueError):
    """A target point lies outside the free space or on its boundary."""


class NonFiniteResultError(TetherError, ArithmeticError):
    """A result is not finite (NaN or infinite): the input is beyond tether's numerical range.
    Raised instead of writing non-finite numbers to JSON."""


class OutputPathError(TetherError, ValueError):
    """An output path cannot be written (missing folder, read-only, bad extension...)."""


class ArrangementError(TetherError):
    """The critical curves' arrangement could not be computed at tether's resolution."""


class ResourceLimitError(TetherError):
    """A computation would exceed tether's memory bound (refused before allocating)."""


class InvalidTrackError(InvalidParameterError):
    """A target track (a CSV, JSON or ROS bag file of timed positions) is malformed: a missing
    column, a non-numeric or non-finite value, times not increasing, no samples, an unknown topic
    or message type, a truncated file. The message names the file and what is wrong."""
