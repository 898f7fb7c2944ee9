"""Per-object caches of derived values, declared as a field of the objects that hold them."""

from __future__ import annotations

from dataclasses import field
from typing import Any

__all__ = ["Memo", "memo_field"]


class Memo(dict):
    """Values derived from an immutable result and computed once on demand (spatial indexes,
    name tables, lookup arrays), keyed by name. The result stays frozen: its fields never
    change, and the memo is the one declared place its caches live."""


def memo_field() -> Any:
    """A dataclass field holding a fresh :class:`Memo`, outside ``__init__``, ``repr`` and
    comparisons."""
    return field(default_factory=Memo, init=False, repr=False, compare=False)
