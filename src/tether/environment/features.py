"""The map's named features: walls ``E<i>`` (edge ``i``) and reflex vertices ``V<j>``, and
their integer codes (edge ``i`` is code ``i``, vertex ``j`` code ``n + j``)."""

from __future__ import annotations

from typing import NamedTuple

from tether.environment.model import Environment

__all__ = ["Feature", "feature_code", "feature_name"]


class Feature(NamedTuple):
    """A map feature bounding a free arc: wall ``("E", i)`` (edge ``i``) or reflex vertex
    ``("V", i)``; ``str()`` gives its name, ``"E1"`` or ``"V2"``. :func:`feature_name` and
    :func:`feature_code` are the codecs between names and the integer codes (edge ``i`` is
    code ``i``, vertex ``i`` code ``n + i``)."""

    kind: str
    index: int

    def __str__(self) -> str:
        return f"{self.kind}{self.index}"

    @classmethod
    def parse(cls, name: str) -> Feature:
        """The feature named ``name`` (``"E1"``, ``"V2"``); ValueError if it is not one."""
        kind, digits = name[:1], name[1:]
        if kind not in ("E", "V") or not digits.isdigit():
            raise ValueError(f"not a feature name: {name!r}")
        return cls(kind, int(digits))

    @classmethod
    def of(cls, env: Environment, code: int) -> Feature:
        """The feature of code ``code`` in ``env``'s numbering."""
        code = int(code)
        return cls("E", code) if code < env.n else cls("V", code - env.n)

    def code(self, env: Environment) -> int:
        """The feature's code in ``env``'s numbering."""
        return self.index if self.kind == "E" else env.n + self.index


def feature_name(env: Environment, code: int) -> str:
    """Name of a feature code: ``E<i>`` for ``code < n``, else ``V<code - n>`` (``str`` of
    :meth:`Feature.of`)."""
    code = int(code)
    return f"E{code}" if code < env.n else f"V{code - env.n}"


def feature_code(env: Environment, name: str) -> int:
    """Inverse of :func:`feature_name` (:meth:`Feature.code` of :meth:`Feature.parse`)."""
    return Feature.parse(name).code(env)
