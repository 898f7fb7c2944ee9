"""Names a package loads on first use (PEP 562), so importing it stays cheap."""

from __future__ import annotations

import importlib
from collections.abc import Callable, Iterable, Mapping
from typing import Any

__all__ = ["lazy_attributes"]


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
