"""Names a package loads on first use (PEP 562), so importing it stays cheap."""

from __future__ import annotations

import importlib
from collections.abc import Callable, Iterable, Iterator, Mapping, Sequence
from typing import Any

__all__ = ["LazyTuple", "lazy_attributes"]


def lazy_attributes(package: str, namespace: dict, names: Mapping[str, str],
                    submodules: Iterable[str] = ()) -> tuple[Callable[[str], Any],
                                                             Callable[[], list[str]]]:
    """The ``__getattr__`` and ``__dir__`` of a package (PEP 562) that loads each of ``names``
    from its module (``names[name]``, an absolute module name) on first use and keeps it in the
    package's ``namespace``; ``submodules`` are reachable as attributes without an import.

    Examples
    --------
    >>> ns = {}
    >>> getattr_, dir_ = lazy_attributes("pkg", ns, {"sqrt": "math"})
    >>> getattr_("sqrt")(4.0), "sqrt" in ns
    (2.0, True)
    """
    subs = frozenset(submodules)

    def __getattr__(name: str) -> Any:
        if name in names:
            value = namespace[name] = getattr(importlib.import_module(names[name]), name)
            return value  # kept: later lookups skip this function
        if name in subs:
            return importlib.import_module(f"{package}.{name}")
        raise AttributeError(f"module {package!r} has no attribute {name!r}")

    def __dir__() -> list[str]:
        return sorted(set(namespace) | set(names) | subs)

    return __getattr__, __dir__


class LazyTuple(Sequence):
    """A tuple made on the first read of any item: a subclass gives ``_all()`` (the tuple, made
    once and kept) and ``__len__`` (known without making it). Equal to the tuple of the same
    items (and to another ``LazyTuple`` of them) and hashed as it; pickled as that tuple.

    Examples
    --------
    >>> class Squares(LazyTuple):
    ...     def __len__(self): return 3
    ...     def _all(self): return (0, 1, 4)
    >>> Squares() == (0, 1, 4), Squares()[2], hash(Squares()) == hash((0, 1, 4))
    (True, 4, True)
    """

    def _all(self) -> tuple:  # pragma: no cover - every subclass gives it
        raise NotImplementedError

    def __len__(self) -> int:  # pragma: no cover - every subclass gives it
        raise NotImplementedError

    def __getitem__(self, i: Any) -> Any:
        return self._all()[i]

    def __iter__(self) -> Iterator[Any]:
        return iter(self._all())

    def __eq__(self, other: object) -> bool:
        if isinstance(other, (tuple, LazyTuple)):
            return tuple(self) == tuple(other)
        return NotImplemented

    def __hash__(self) -> int:
        return hash(self._all())

    def __repr__(self) -> str:
        return repr(self._all())

    def __reduce__(self) -> tuple:
        return (tuple, (self._all(),))
