"""Sweeps over the rod length: the verdict for many ``lss``, and the intervals with a strategy.

A user's question is "what is the longest following distance this building allows?".
:func:`sweep` answers it by running the whole pipeline (decompose, analyze) at every ``lss`` of
a list, then refining each end of every interval of ``lss`` with a strategy by bisection down to a
tolerance. Each evaluation is independent, so the work goes to any
:class:`concurrent.futures.Executor`: serially in this process (``executor=None``), on local
processes (:class:`~concurrent.futures.ProcessPoolExecutor`), or on a Dask cluster through
``distributed.Client(address).get_executor()``. This module never imports dask.

The verdict is not monotone in ``lss`` in general: a sampled sweep finds the intervals its samples
hit; an interval narrower than the sample step, between two samples without a strategy, can be
missed. The ends reported are exact to the tolerance only for the transitions the samples bracket.

With the speeds ``vt`` and ``vo`` given, every row also carries
the surveillance kernel's safe fraction: the fraction of free states in the kernel
(``Kernel.safe_fraction_total()``).

:func:`delay_sweep` answers "how much sensing latency can this map afford at this following
distance and these speeds?": the certified kernel's safe fraction per delay
(``docs/certified.md``, "Sensing delay").
"""

from __future__ import annotations

import csv
import io
import math
import time
from collections.abc import Callable, Iterable, Sequence
from concurrent.futures import Executor, Future
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from tether.environment import Environment
from tether.errors import InvalidParameterError

__all__ = ["DelayRow", "DelaySweep", "Interval", "SweepResult", "SweepRow", "delay_sweep",
           "evaluate", "parse_lss_range", "sweep"]

_COUNT_KEYS = ("regions", "cells", "pieces", "edges", "surviving_cells")


@dataclass(frozen=True)
class SweepRow:
    """The pipeline's result at one rod length.

    ``strategy_exists`` is ``None`` when the run failed (``error`` says why; an error starting
    ``kernel:`` means only the kernel failed and the verdict stands); ``refined`` marks
    rows evaluated by the bisection rather than from the user's list; ``seconds`` is wall time;
    ``verified`` is whether the decomposition passed :func:`analyze`'s cheap self-check (``None``
    when not run).
    """

    lss: float
    strategy_exists: bool | None
    counts: dict = field(default_factory=dict)
    safe_fraction: float | None = None
    error: str | None = None
    refined: bool = False
    seconds: float = 0.0
    verified: bool | None = None

    def to_dict(self) -> dict:
        """The row as JSON-ready values (``lss`` in map units, ``seconds`` rounded)."""
        return {"lss": self.lss, "strategy_exists": self.strategy_exists,
                "verified": self.verified, "counts": self.counts,
                "safe_fraction": self.safe_fraction, "error": self.error,
                "refined": self.refined, "seconds": round(self.seconds, 4)}


@dataclass(frozen=True)
class Interval:
    """A maximal run of evaluated ``lss`` with a strategy: ``[lo, hi]`` (both evaluated).

    ``below`` / ``above`` are the nearest evaluated lengths *without* a strategy on each side
    (``None`` at the ends of the sweep): the true end lies between ``below`` and ``lo`` (and
    between ``hi`` and ``above``), a gap at most the tolerance where bisection ran.
    """

    lo: float
    hi: float
    below: float | None
    above: float | None

    def to_dict(self) -> dict:
        """The interval as JSON-ready values (map units)."""
        return {"lo": self.lo, "hi": self.hi, "below": self.below, "above": self.above}


@dataclass(frozen=True)
class SweepResult:
    """Rows sorted by ``lss`` (sampled and refined), intervals with a strategy, settings."""

    map_name: str
    rows: tuple[SweepRow, ...]
    intervals: tuple[Interval, ...]
    tol: float | None
    vt: float | None = None
    vo: float | None = None

    @property
    def longest(self) -> float | None:
        """The longest evaluated ``lss`` with a strategy (``None`` if none has one)."""
        return max((iv.hi for iv in self.intervals), default=None)

    @property
    def errors(self) -> list[SweepRow]:
        """The rows whose evaluation failed."""
        return [r for r in self.rows if r.error is not None]

    @property
    def unverified(self) -> list[SweepRow]:
        """Rows whose decomposition failed the self-check: their verdict is not trusted."""
        return [r for r in self.rows if r.verified is False]

    def to_dict(self) -> dict:
        """The result as JSON-ready values (the ``tether sweep --json`` fields)."""
        return {"map": self.map_name, "tol": self.tol, "vt": self.vt, "vo": self.vo,
                "longest_lss_with_strategy": self.longest,
                "intervals": [iv.to_dict() for iv in self.intervals],
                "rows": [r.to_dict() for r in self.rows]}

    def to_csv(self) -> str:
        """One line per row: lss, verdict, counts, safe fraction, refined flag, error."""
        buf = io.StringIO()
        w = csv.writer(buf, lineterminator="\n")
        w.writerow(["lss", "strategy_exists", "verified", *_COUNT_KEYS, "safe_fraction",
                    "refined", "error"])
        for r in self.rows:
            verdict = "" if r.strategy_exists is None else str(r.strategy_exists).lower()
            checked = "" if r.verified is None else str(r.verified).lower()
            w.writerow([repr(r.lss), verdict, checked, *(r.counts.get(k, "") for k in _COUNT_KEYS),
                        "" if r.safe_fraction is None else f"{r.safe_fraction:.6g}",
                        str(r.refined).lower(), r.error or ""])
        return buf.getvalue()

    def plot(self, ax: Any = None) -> Any:
        """The sweep figure (see :func:`tether.plot.plot_sweep`)."""
        from tether.plot.sweep import plot_sweep

        return plot_sweep(self, ax)

    def __repr__(self) -> str:
        return (f"SweepResult(map={self.map_name!r}, rows={len(self.rows)}, "
                f"intervals={[(iv.lo, iv.hi) for iv in self.intervals]})")


# ---------------------------------------------------------------------- one evaluation
def _kernel_fraction(env: Environment, lss: float, vt: float, vo: float) -> float:
    """The fraction of free states in the surveillance kernel (:mod:`tether.game`)."""
    from tether.game import surveillance_kernel

    return float(surveillance_kernel(env, lss, vt, vo).safe_fraction_total())


def evaluate(env_data: dict, lss: float, vt: float | None = None, vo: float | None = None,
             refined: bool = False) -> SweepRow:
    """Decompose and analyze the map ``env_data`` (:meth:`Environment.to_dict`) at ``lss``.

    A module-level function of plain arguments, so that any executor (local processes, Dask
    workers) can run it. A failure becomes a row with ``error`` set, never an exception: one bad
    length does not lose the whole sweep.
    """
    from tether.analysis import analyze
    from tether.decomposition import decompose

    t0 = time.perf_counter()
    try:
        env = Environment(env_data["boundary"], tuple(env_data["holes"]),
                          env_data.get("name", ""))
        verdict = analyze(decompose(env, lss), near_critical=False)
    except Exception as exc:  # noqa: BLE001 - reported in the row
        return SweepRow(float(lss), None, {}, None, f"{type(exc).__name__}: {exc}",
                        refined=refined, seconds=time.perf_counter() - t0)
    frac, error = None, None
    if vt is not None and vo is not None:
        try:
            frac = _kernel_fraction(env, lss, vt, vo)
        except Exception as exc:  # noqa: BLE001 - the verdict stands; the kernel's failure noted
            error = f"kernel: {type(exc).__name__}: {exc}"
    return SweepRow(float(lss), verdict.strategy_exists, verdict.counts(), frac, error,
                    refined=refined, seconds=time.perf_counter() - t0,
                    verified=getattr(verdict, "verified", None))


# ---------------------------------------------------------------------- the sweep
class _Runner:
    """Runs :func:`evaluate` for a batch of lengths on an executor (or in this process)."""

    def __init__(self, env: Environment, executor: Executor | None, vt: float | None,
                 vo: float | None, progress: Callable[[str, float], None] | None) -> None:
        self.data = env.to_dict()
        self.executor = executor
        self.vt, self.vo = vt, vo
        self.progress = progress
        self.done = 0
        self.total = 0

    def _tick(self, row: SweepRow) -> None:
        self.done += 1
        if self.progress is not None:
            self.progress(f"lss {row.lss:.4g}", min(self.done / max(self.total, 1), 0.99))

    def run(self, values: Sequence[float], refined: bool) -> list[SweepRow]:
        args = (self.data,)
        if self.executor is None:
            rows = []
            for v in values:
                rows.append(evaluate(*args, v, self.vt, self.vo, refined))
                self._tick(rows[-1])
            return rows
        futures: list[Future] = [self.executor.submit(evaluate, *args, v, self.vt, self.vo,
                                                      refined) for v in values]
        rows = []
        for f in futures:
            rows.append(f.result())
            self._tick(rows[-1])
        return rows


def _intervals(rows: Sequence[SweepRow]) -> tuple[Interval, ...]:
    out = []
    i = 0
    while i < len(rows):
        if rows[i].strategy_exists:
            j = i
            while j + 1 < len(rows) and rows[j + 1].strategy_exists:
                j += 1
            below = rows[i - 1].lss if i > 0 else None
            above = rows[j + 1].lss if j + 1 < len(rows) else None
            out.append(Interval(rows[i].lss, rows[j].lss, below, above))
            i = j + 1
        else:
            i += 1
    return tuple(out)


def _brackets(rows: Sequence[SweepRow], tol: float) -> list[tuple[float, float]]:
    """Adjacent pairs of rows whose verdicts differ (strategy vs not) and lie > tol apart."""
    out = []
    for a, b in zip(rows, rows[1:], strict=False):
        if bool(a.strategy_exists) != bool(b.strategy_exists) and b.lss - a.lss > tol:
            out.append((a.lss, b.lss))
    return out


def _check_values(lss_values: Iterable[float]) -> list[float]:
    vals = sorted({float(v) for v in lss_values})
    if not vals:
        raise InvalidParameterError("the sweep needs at least one lss value")
    bad = [v for v in vals if not (math.isfinite(v) and v > 0)]
    if bad:
        raise InvalidParameterError(f"lss values must be finite and > 0, got {bad[0]:g}")
    return vals


def _check_speeds(vt: float | None, vo: float | None) -> None:
    if (vt is None) != (vo is None):
        raise InvalidParameterError("give both vt and vo, or neither")
    if vt is not None and not (math.isfinite(vt) and math.isfinite(vo) and 0 < vt < vo):
        raise InvalidParameterError(f"need 0 < vt < vo, got vt {vt:g}, vo {vo:g}")


def sweep(env: Environment, lss_values: Iterable[float], executor: Executor | None = None,
          vt: float | None = None, vo: float | None = None, tol: float | None = None,
          progress: Callable[[str, float], None] | None = None) -> SweepResult:
    """The verdict at every ``lss`` in ``lss_values``, and the intervals of ``lss`` with a
    strategy, their ends refined by bisection.

    Parameters
    ----------
    env : Environment
    lss_values : iterable of float
        Rod lengths to evaluate, map units, > 0 (sorted and deduplicated).
    executor : concurrent.futures.Executor, optional
        Where to run the evaluations; default: serially in this process.
    vt, vo : float, optional
        Target and observer speed bounds (both or neither, ``0 < vt < vo``); with them, rows
        carry the surveillance kernel's safe fraction.
    tol : float, optional
        Bisection tolerance on each interval end, map units; default: an eighth of the smallest
        step between the given values. ``0`` turns the refinement off.
    progress : callable, optional
        Called as ``progress(stage, fraction_done)``.

    Returns
    -------
    SweepResult

    Raises
    ------
    InvalidParameterError
        If a length is not positive, the speeds are inconsistent or ``tol`` is negative.

    Examples
    --------
    The 1.5 × 3 room has no strategy at ``lss`` 1 but has one for short rods:

    >>> from tether import Environment
    >>> from tether.sweep import sweep
    >>> room = Environment([(0, 0), (1.5, 0), (1.5, 3), (0, 3)])
    >>> result = sweep(room, [0.25, 1.0])
    >>> [(row.lss, row.strategy_exists) for row in result.rows if not row.refined]
    [(0.25, True), (1.0, False)]
    >>> result.longest is not None and 0.25 <= result.longest < 1.0
    True
    """
    vals = _check_values(lss_values)
    _check_speeds(vt, vo)
    if tol is None:
        tol = float(np.min(np.diff(vals))) / 8 if len(vals) > 1 else 0.0
    if not (math.isfinite(tol) and tol >= 0):
        raise InvalidParameterError(f"tol must be a finite number >= 0, got {tol!r}")
    runner = _Runner(env, executor, vt, vo, progress)
    runner.total = len(vals)
    rows = runner.run(vals, refined=False)
    rows.sort(key=lambda r: r.lss)
    brackets = _brackets(rows, tol) if tol > 0 else []
    if brackets:
        steps = max(math.ceil(math.log2((b - a) / tol)) for a, b in brackets)
        runner.total += steps * len(brackets)
    while brackets:
        mids = [(a + b) / 2 for a, b in brackets]
        rows.extend(runner.run(mids, refined=True))
        rows.sort(key=lambda r: r.lss)
        brackets = _brackets_within(rows, brackets, tol)
    if progress is not None:
        progress("done", 1.0)
    rows_t = tuple(rows)
    return SweepResult(env.name, rows_t, _intervals(rows_t), tol or None, vt, vo)


def _brackets_within(rows: Sequence[SweepRow], old: list[tuple[float, float]], tol: float
                     ) -> list[tuple[float, float]]:
    """The changing pairs that still need bisection, inside the previous brackets only."""
    out = []
    for a, b in _brackets(rows, tol):
        if any(lo <= a and b <= hi for lo, hi in old):
            out.append((a, b))
    return out


# ---------------------------------------------------------------------- lss ranges
def parse_lss_range(text: str) -> list[float]:
    """Parse ``START:STOP:STEP`` (both ends included, to within a millionth of a step), a
    comma-separated list ``0.5,1,2`` or a single number into a list of lengths.

    Raises
    ------
    InvalidParameterError
        If the text is malformed, a step is not positive or the range holds over 10,000 values.
    """
    text = text.strip()
    try:
        if ":" in text:
            parts = [float(p) for p in text.split(":")]
            if len(parts) != 3:
                raise ValueError
            start, stop, step = parts
            if not (math.isfinite(step) and step > 0):
                raise InvalidParameterError(f"lss range {text!r}: the step must be > 0")
            if stop < start:
                raise InvalidParameterError(f"lss range {text!r}: STOP is below START")
            n = int(math.floor((stop - start) / step + 1e-6)) + 1
            if n > 10_000:
                raise InvalidParameterError(f"lss range {text!r} holds {n} values; "
                                            "at most 10,000")
            return [round(start + k * step, 12) for k in range(n)]
        return [float(p) for p in text.split(",") if p.strip()]
    except ValueError:
        raise InvalidParameterError(f"lss {text!r}: expected START:STOP:STEP, a comma-separated "
                                    "list or a number") from None


# ---------------------------------------------------------------------- delays
#: Monte Carlo samples of the certified fraction per delay.
DELAY_SAMPLES = 20_000


@dataclass(frozen=True)
class DelayRow:
    """The certified kernel at one sensing delay.

    ``delay`` (s); ``certified``: whether a field passed the checks at this delay;
    ``safe_fraction`` (± ``error``, Monte Carlo): the share of free states in it (0 when not
    certified); ``source``: ``"search"`` (found at this delay) or ``"delay D"`` (the field
    certified at the longer delay ``D``, checked again at this one: a field certified for a
    delay is certified for every shorter one); ``seconds``: wall time.
    """

    delay: float
    certified: bool
    safe_fraction: float
    error: float
    source: str
    seconds: float

    def to_dict(self) -> dict:
        """The row as JSON-ready values."""
        return {"delay": self.delay, "certified": self.certified,
                "safe_fraction": self.safe_fraction, "safe_fraction_error": self.error,
                "source": self.source, "seconds": round(self.seconds, 3)}


@dataclass(frozen=True)
class DelaySweep:
    """Result of :func:`delay_sweep`: rows by increasing delay, and the settings (map units,
    map units per second); ``kernels``: the field each row reports
    (:class:`~tether.game.certified.CertifiedKernel`, certified at the row's delay or a longer
    one)."""

    map_name: str
    lss: float
    vt: float
    vo: float
    h: float
    rows: tuple[DelayRow, ...]
    kernels: tuple = field(default=(), repr=False, compare=False)

    @property
    def longest(self) -> float | None:
        """The longest delay (s) with a certified field, ``None`` if none."""
        return max((r.delay for r in self.rows if r.certified), default=None)

    def to_dict(self) -> dict:
        """The result as JSON-ready values (the ``tether sweep --delay --json`` fields)."""
        return {"map": self.map_name, "lss": self.lss, "vt": self.vt, "vo": self.vo,
                "h": self.h, "longest_certified_delay": self.longest,
                "rows": [r.to_dict() for r in self.rows]}

    def format(self) -> str:
        """The sweep as a text table."""
        lines = [f"map {self.map_name!r}, lss {self.lss:g}, vt {self.vt:g}, vo {self.vo:g}: "
                 f"certified kernel per sensing delay (mesh h {self.h:.4g})",
                 f"{'delay s':>8}  {'vt*delay':>8}  {'certified':<9}  {'safe %':>13}  "
                 f"{'seconds':>7}  field"]
        for r in self.rows:
            frac = (f"{100 * r.safe_fraction:5.1f} +/- {100 * r.error:3.1f}" if r.certified
                    else "0")
            lines.append(f"{r.delay:8.4g}  {self.vt * r.delay:8.4g}  "
                         f"{'yes' if r.certified else 'no':<9}  {frac:>13}  "
                         f"{r.seconds:7.1f}  {r.source if r.certified else '-'}")
        longest = self.longest
        lines.append("no delay has a certified field" if longest is None else
                     f"longest delay with a certified field: {longest:g} s "
                     f"(the distance then within lss +/- {self.vt * longest:.4g})")
        return "\n".join(lines)


def delay_sweep(env: Environment, lss: float, vt: float, vo: float,
                delays: Iterable[float], h: float | None = None, orientations: int = 180,
                samples: int = DELAY_SAMPLES,
                progress: Callable[[str, float], None] | None = None) -> DelaySweep:
    """The certified kernel's safe fraction at each sensing delay (seconds).

    Work is reused where it is sound, and every field is checked at the delay it is reported
    for: the delays run in increasing order, each search starting from the field certified at
    the previous delay (a candidate; :func:`~tether.game.certified.certified_kernel` checks
    it and searches on from it); then, from the longest delay down, a field certified at a
    longer delay whose fraction is larger replaces the row's own (it is checked again at the
    row's delay: a field certified for a delay passes at every shorter one, and the check
    says so, not this function).

    Parameters
    ----------
    env : Environment
    lss, vt, vo : float
        Rod length (map units) and speeds (map units per second).
    delays : iterable of float
        Delays, seconds, each ``>= 0`` with ``vt·delay < lss``.
    h : float, optional
        Mesh spacing (map units; default that of
        :func:`~tether.game.certified.certified_kernel`).
    orientations : int
        Orientation bins of the grid kernel the search starts from.
    samples : int
        Monte Carlo samples of each fraction (the same states at every delay).
    progress : callable, optional
        ``progress(stage, fraction)``.
    """
    from tether.game.certificate import certify
    from tether.game.certified import certified_kernel, check_delay

    values = sorted({check_delay(d, vt, lss) for d in delays})
    if not values:
        raise InvalidParameterError("no delay to sweep")
    kernels, rows = [], []
    prev = None
    for i, d in enumerate(values):
        if progress is not None:
            progress(f"delay {d:g} s", i / len(values))
        ck = certified_kernel(env, lss, vt, vo, h=h, orientations=orientations, delay=d,
                              start=prev)
        frac, err = ck.safe_fraction(samples) if ck.certified else (0.0, 0.0)
        kernels.append(ck)
        rows.append(DelayRow(d, ck.certified, frac, err, "search", ck.seconds))
        if ck.certified:
            prev = ck
    best = None  # (row index) the certified field of a longer delay with the largest fraction
    for i in range(len(values) - 1, -1, -1):
        if best is not None and rows[best].safe_fraction > rows[i].safe_fraction:
            t0 = time.perf_counter()
            ck = kernels[best]
            env_i, lss_i, vt_i, vo_i = ck.game
            grow = vt * values[i] * ck.frame.scale
            if certify(ck.field, env_i, lss_i, vt_i, vo_i, grow).passed:
                rows[i] = DelayRow(values[i], True, rows[best].safe_fraction, rows[best].error,
                                   f"delay {values[best]:g}",
                                   rows[i].seconds + time.perf_counter() - t0)
                kernels[i] = ck
                continue
        if rows[i].certified and (best is None
                                  or rows[i].safe_fraction >= rows[best].safe_fraction):
            best = i
    if progress is not None:
        progress("done", 1.0)
    return DelaySweep(env.name, lss, vt, vo, kernels[0].h, tuple(rows), tuple(kernels))
