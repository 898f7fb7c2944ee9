"""Closed vocabularies: string enums that print as the plain strings they stand for."""

from __future__ import annotations

from enum import StrEnum

__all__ = ["Vocabulary"]


class Vocabulary(StrEnum):
    """A :class:`enum.StrEnum` whose ``repr`` is its value's (``'held'``, not
    ``<Outcome.HELD: 'held'>``): members compare, hash, serialize and print as the strings.

    Examples
    --------
    >>> class Colour(Vocabulary):
    ...     RED = "red"
    >>> Colour.RED == "red", [Colour.RED], f"{Colour.RED}"
    (True, ['red'], 'red')
    """

    def __repr__(self) -> str:
        return repr(self.value)
