"""The map: a polygon with holes, its named features, its validation and its internal frame.

The model reads and writes no file: :mod:`tether.io` does (``load_map``, ``save_map``).

Feature names follow the file: vertices ``V0..V(n-1)`` and edges ``E0..E(n-1)`` in the order the
file gives them, boundary ring first, then each hole in order. Edge ``Ei`` runs from ``Vi`` to the
next vertex of the same ring (see ``docs/conventions.md``).
"""

from __future__ import annotations

from typing import Any

from tether.environment.frame import Frame, normalizing_frame
from tether.environment.model import Environment

__all__ = ["Environment", "Frame", "normalizing_frame"]

#: Readers that lived here, deprecated: they are :mod:`tether.io`'s.
_MOVED = ("from_dict", "from_geojson", "from_wkt", "load_map")


def __getattr__(name: str) -> Any:
    """``load_map``, ``from_dict``, ``from_geojson`` and ``from_wkt``, deprecated here: the
    model reads no file; the readers are :mod:`tether.io`'s."""
    if name in _MOVED:
        import warnings

        import tether.io

        warnings.warn(f"tether.environment.{name} is deprecated and will be removed in the next "
                      f"release: use tether.io.{name}", DeprecationWarning, stacklevel=2)
        return getattr(tether.io, name)
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
