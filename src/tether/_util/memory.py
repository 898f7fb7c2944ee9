"""Memory plumbing of the big stages: the cyclic garbage collector paused, the C heap trimmed,
and the memory budget a computation may use (``docs/memory.md``).

The budget is the memory this process may use: ``TETHER_MEMORY_LIMIT`` (a size such as
``8G``, set by ``--memory-limit`` on the command line) if set, else the smallest of the
machine's limits: the available physical memory (``MemAvailable`` of ``/proc/meminfo``, plus
what this process holds already), the cgroup's limit (``memory.max``, or ``memory.limit_in_bytes``
of cgroup v1) and the address-space limit ``RLIMIT_AS``. A source that cannot be read (another
operating system, no cgroup) is left out; with none at all the budget is unbounded.
"""

from __future__ import annotations

import gc
import math
import os
import re
from collections.abc import Iterator
from contextlib import contextmanager
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from tether.errors import InvalidParameterError

__all__ = ["ENV_VAR", "MemoryBudget", "format_size", "gc_paused", "machine_limits",
           "memory_budget", "memory_limit", "parse_size", "release_memory"]

#: The environment variable holding an explicit memory limit (a size, :func:`parse_size`)
ENV_VAR = "TETHER_MEMORY_LIMIT"

#: Files read for the machine's limits (module attributes: tests point them elsewhere)
MEMINFO = Path("/proc/meminfo")
CGROUP_FILES = (Path("/sys/fs/cgroup/memory.max"),
                Path("/sys/fs/cgroup/memory/memory.limit_in_bytes"))
STATUS = Path("/proc/self/status")

#: A cgroup v1 limit at or above this many bytes means "no limit" (the kernel writes
#: ``PAGE_COUNTER_MAX`` pages, about 2**63)
_CGROUP_UNLIMITED = 1 << 60

_UNITS = {"": 1, "B": 1, "K": 1 << 10, "M": 1 << 20, "G": 1 << 30, "T": 1 << 40}
_SIZE = re.compile(r"^\s*([0-9]*\.?[0-9]+(?:[eE][+-]?[0-9]+)?)\s*([KMGT]?)(?:I?B)?\s*$",
                   re.IGNORECASE)


def parse_size(text: str) -> int:
    """A memory size in bytes from text: a number with an optional unit ``K``, ``M``, ``G`` or
    ``T`` (powers of 1024; ``KB``/``KiB`` spellings and lower case accepted), e.g. ``8G``,
    ``500M``, ``1.5g``, ``1048576``.

    Raises
    ------
    InvalidParameterError
        If the text is not such a size or the size is below one kilobyte (1024 bytes).

    Examples
    --------
    >>> parse_size("8G"), parse_size("500M"), parse_size("1.5k"), parse_size("2048")
    (8589934592, 524288000, 1536, 2048)
    """
    m = _SIZE.match(str(text))
    if m is None:
        raise InvalidParameterError(f"memory size {text!r} is not a size such as 8G, 500M or "
                                    "1048576 (bytes; units K, M, G, T are powers of 1024)")
    value = float(m.group(1)) * _UNITS[m.group(2).upper()]
    if not math.isfinite(value) or value < 1024:
        raise InvalidParameterError(f"memory size {text!r} is below 1K (1024 bytes)")
    return int(value)


def format_size(n: float) -> str:
    """A size in bytes as text with a binary unit (``1.50 GB``, ``512 MB``; 1 GB = 1024**3).

    Examples
    --------
    >>> format_size(1536 * 1024**2), format_size(500 * 1024**2), format_size(2048)
    ('1.50 GB', '500 MB', '2 KB')
    """
    for unit, scale in (("TB", 1 << 40), ("GB", 1 << 30), ("MB", 1 << 20)):
        if n >= scale:
            v = n / scale
            return f"{v:.2f} {unit}" if v < 10 else f"{v:.0f} {unit}"
    return f"{max(n, 0) / 1024:.0f} KB"


@dataclass(frozen=True)
class MemoryBudget:
    """The memory a computation may use: ``bytes`` (None: unbounded) and where it comes from
    (``source``: ``"TETHER_MEMORY_LIMIT"``, ``"available memory"``, ``"cgroup limit"``,
    ``"RLIMIT_AS"`` or ``"none"``)."""

    bytes: int | None
    source: str

    def describe(self) -> str:
        """The budget in words, e.g. ``"3.20 GB (available memory)"``."""
        if self.bytes is None:
            return "unbounded (no limit found)"
        shown = "--memory-limit/TETHER_MEMORY_LIMIT" if self.source == ENV_VAR else self.source
        return f"{format_size(self.bytes)} ({shown})"


def memory_budget() -> MemoryBudget:
    """The memory this process may use (see the module's docstring): ``TETHER_MEMORY_LIMIT``
    if set, else the smallest of :func:`machine_limits`.

    Raises
    ------
    InvalidParameterError
        If ``TETHER_MEMORY_LIMIT`` is set but is not a size (:func:`parse_size`).
    """
    text = os.environ.get(ENV_VAR, "").strip()
    if text:
        try:
            return MemoryBudget(parse_size(text), ENV_VAR)
        except InvalidParameterError as exc:
            raise InvalidParameterError(f"{ENV_VAR}: {exc}") from None
    limits = {k: v for k, v in machine_limits().items() if v is not None}
    if not limits:
        return MemoryBudget(None, "none")
    source = min(limits, key=limits.__getitem__)
    return MemoryBudget(limits[source], source)


def machine_limits() -> dict[str, int | None]:
    """The machine's limits on this process's memory, bytes (None: none found):
    ``"available memory"`` (``MemAvailable`` plus this process's resident memory: what it
    holds counts toward its peak), ``"cgroup limit"`` (v2 ``memory.max``, else v1
    ``memory.limit_in_bytes``; the whole group's limit, other processes of the group not
    subtracted) and ``"RLIMIT_AS"`` (the soft address-space limit)."""
    available = _meminfo_kb("MemAvailable")
    rss = _status_kb("VmRSS") or 0
    return {"available memory": None if available is None else (available + rss) * 1024,
            "cgroup limit": _cgroup_limit(),
            "RLIMIT_AS": _rlimit_as()}


def _meminfo_kb(key: str) -> int | None:
    """A ``kB`` field of ``/proc/meminfo`` (None if unreadable)."""
    return _kb_field(MEMINFO, key)


def _status_kb(key: str) -> int | None:
    """A ``kB`` field of ``/proc/self/status`` (None if unreadable)."""
    return _kb_field(STATUS, key)


def _kb_field(path: Path, key: str) -> int | None:
    try:
        text = path.read_text()
    except OSError:
        return None
    m = re.search(rf"^{key}:\s*([0-9]+)\s*kB", text, re.MULTILINE)
    return int(m.group(1)) if m else None


def _cgroup_limit() -> int | None:
    """The cgroup's memory limit in bytes, the first of :data:`CGROUP_FILES` that reads as a
    number (``max`` or a huge v1 value: no limit)."""
    for path in CGROUP_FILES:
        try:
            text = path.read_text().strip()
        except OSError:
            continue
        if text == "max":
            return None
        if text.isdigit():
            value = int(text)
            return None if value >= _CGROUP_UNLIMITED else value
    return None


def _rlimit_as() -> int | None:
    """The soft ``RLIMIT_AS`` in bytes (None: unlimited, or no ``resource`` module)."""
    try:
        import resource
    except ImportError:  # not on this operating system
        return None
    soft = resource.getrlimit(resource.RLIMIT_AS)[0]
    return None if soft == resource.RLIM_INFINITY or soft < 0 else int(soft)


@contextmanager
def memory_limit(size: int | str | None) -> Iterator[None]:
    """Set the memory budget (``TETHER_MEMORY_LIMIT``) for a block: ``size`` in bytes or as
    text (:func:`parse_size`); None leaves it as it is. Child processes started in the block
    (``--workers``) inherit it; the previous value is restored on leaving."""
    if size is None:
        yield
        return
    value = parse_size(size) if isinstance(size, str) else int(size)
    before = os.environ.get(ENV_VAR)
    os.environ[ENV_VAR] = str(value)
    try:
        yield
    finally:
        if before is None:
            os.environ.pop(ENV_VAR, None)
        else:
            os.environ[ENV_VAR] = before


def release_memory() -> None:
    """Return the C heap's free memory to the system (glibc's ``malloc_trim``; nothing
    elsewhere). Freed geometry memory stays in the heap otherwise, where Python's own object
    arenas cannot reuse it: trimming it lowers the peak of the stages that follow."""
    trim = _malloc_trim()
    if trim is not None:
        trim(0)


def _malloc_trim() -> Any:
    """The C library's ``malloc_trim`` (glibc; None where there is none), looked up once."""
    got = globals().get("_TRIM", False)
    if got is False:
        got = None
        try:
            import ctypes

            got = ctypes.CDLL("libc.so.6").malloc_trim
        except (OSError, AttributeError):
            pass
        globals()["_TRIM"] = got
    return got


@contextmanager
def gc_paused() -> Iterator[None]:
    """Pause Python's cyclic garbage collector for a block. A decomposition creates millions of
    small objects that live on (cells, names, geometries) and none in reference cycles: each
    collection would walk them all again (a fifth of the time at 400 vertices) to free
    nothing. Reference counting still frees everything else at once.

    On leaving the outermost pause, the objects still alive (the results) go straight to the
    oldest generation (``gc.freeze`` then ``gc.unfreeze``, both constant time): re-enabled as
    they were, the collector's next young collection would walk every one of them (1.2 s at
    1,000 map vertices) and the one after that again. They stay collectable by a full
    collection; nothing is left frozen (skipped if the caller froze objects itself)."""
    was = gc.isenabled()
    gc.disable()
    try:
        yield
    finally:
        if was:
            if gc.get_freeze_count() == 0:
                gc.freeze()
                gc.unfreeze()
            gc.enable()
