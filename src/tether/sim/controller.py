"""Observer controllers: the rod rate each step (``docs/formulas.md``, "The observer's choice at
each instant").

Every controller here picks a *preferred* rate (follow law, translation, or a saturated rotation
when the paper's trigger fires) and then makes it admissible in two stages:

1. clip it to the rates whose observer chord over the step stays within ``vo·dt``
   (:func:`tether.rates.step_rate_interval`, exact for a sampled controller), and
2. keep the rod in its free arc at the end of the step (compliant motion): the arc's ends at the
   next target position are computed exactly by :class:`tether.sim.local.LocalArcs`; if an end
   sweeps over the rod, the rod is pushed along with it.

If the two sets do not meet, the target has won at this instant and the command says why. The
controller never commands an observer chord above ``vo·dt``.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from tether.analysis.escape_points import EscapeRows, escape_table_of, sweep_row
from tether.arcs import Feature
from tether.sim.local import LocalArcs
from tether.sim.protocols import Command, Mode, World

__all__ = [
    "CONTACT_MARGIN", "CompliantController", "FollowController", "PaperController",
    "TranslateController", "VO_MARGIN", "step_interval",
]

#: Rates are chosen within ``vo·(1 − VO_MARGIN)`` so that rounding never exceeds ``vo``.
VO_MARGIN = 1e-9
#: Angular margin (rad) kept inside a free arc when the rod is pushed by one of its ends.
CONTACT_MARGIN = 1e-9


def step_interval(vx: float, vy: float, a: float, lss: float, vo: float, dt: float
                  ) -> tuple[float, float]:
    """Scalar :func:`tether.rates.step_rate_interval` in plain floats (the control loop's)."""
    c, s = math.cos(a), math.sin(a)
    vr = (vx * c + vy * s) * dt
    vs = (-vx * s + vy * c) * dt
    wn = math.hypot(lss - vr, vs)
    w_minus_l = (vr * vr + vs * vs - 2.0 * lss * vr) / (wn + lss)
    half = ((vo * dt) ** 2 - w_minus_l ** 2) / (4.0 * lss * wn)
    if half >= 1.0:
        return -math.pi / dt, math.pi / dt
    beta = 2.0 * math.asin(math.sqrt(max(half, 0.0)))
    delta = math.atan2(vs, lss - vr)
    return min(-beta - delta, 0.0) / dt, max(beta - delta, 0.0) / dt


def _vel(v: np.ndarray, a: float, rate: float, lss: float) -> np.ndarray:
    return np.array([v[0] - lss * rate * math.sin(a), v[1] + lss * rate * math.cos(a)])


class CompliantController:
    """The base of the paper's controllers: each step, the rod rate a subclass prefers
    (:meth:`preferred`, rad/s, with its mode) clipped to the admissible step rates and made
    compliant with the free arc's ends (the rod slides on a wall or pivots on a vertex rather
    than cross it). A subclass sets ``name`` and overrides :meth:`preferred`."""

    name = "base"

    def __init__(self, world: World | None = None) -> None:
        self.world = world
        self.local: LocalArcs | None = None
        if world is not None:
            self._prepare(world)

    def _prepare(self, world: World) -> None:
        self.world = world
        self.lss = float(world.lss)
        self.vt = float(world.vt)
        self.vo = float(world.vo)
        self.local = world.extra.get("_local_arcs")
        if self.local is None or self.local.lss != self.lss:
            self.local = LocalArcs(world.env, self.lss, pad=0.0)
            world.extra["_local_arcs"] = self.local

    def reset(self, world: World, p: np.ndarray, a: float) -> None:
        """Get ready for a run in ``world`` from target point ``p`` and rod angle ``a``."""
        if self.world is not world or self.local is None:
            self._prepare(world)

    # the preferred motion ----------------------------------------------------------
    def preferred(self, p: np.ndarray, v: np.ndarray, a: float, dt: float) -> tuple[float, str]:
        """The rod rate (rad/s) this controller wants for target velocity ``v``, and its mode."""
        raise NotImplementedError

    # one step ---------------------------------------------------------------------
    def step(self, p: np.ndarray, v: np.ndarray, a: float, dt: float) -> Command:
        """The command for one step of ``dt`` seconds: the preferred rate made admissible."""
        want, mode = self.preferred(p, v, a, dt)
        return self.admissible(p, v, a, dt, want, mode)

    def admissible(self, p: np.ndarray, v: np.ndarray, a: float, dt: float, want: float,
                   mode: str) -> Command:
        """Make the preferred ``want`` (rad/s) admissible: chord within ``vo·dt`` and the rod in
        its free arc at the end of the step."""
        lo, hi = step_interval(float(v[0]), float(v[1]), a, self.lss,
                               self.vo * (1.0 - VO_MARGIN), dt)
        x1, y1 = float(p[0] + v[0] * dt), float(p[1] + v[1] * dt)
        ends = self.local.ends(x1, y1, a)
        if ends.free:
            hlo, hhi = -ends.cw_gap, ends.ccw_gap
            flo, fhi = ends.cw_feature, ends.ccw_feature
        elif ends.ccw_gap <= ends.cw_gap:  # an end swept over the rod: follow it out
            hlo, hhi, flo, fhi = ends.ccw_gap, math.inf, ends.ccw_feature, None
        else:
            hlo, hhi, flo, fhi = -math.inf, -ends.cw_gap, None, ends.cw_feature
        m = min(CONTACT_MARGIN, 0.25 * max(hhi - hlo, 0.0))
        clo = (hlo + m) / dt if math.isfinite(hlo) else -math.inf
        chi = (hhi - m) / dt if math.isfinite(hhi) else math.inf
        rlo, rhi = max(lo, clo), min(hi, chi)
        if rlo > rhi:
            return Command(math.nan, np.full(2, math.nan), Mode.LOST, False,
                           self._why(p, v, a, dt, lo, hi, clo, chi, flo, fhi))
        rate = min(max(want, rlo), rhi)
        if (rate == clo and clo > lo) or (rate == chi and chi < hi) or not ends.free:
            mode = Mode.COMPLIANT
        return Command(rate, _vel(v, a, rate, self.lss), mode)

    def _why(self, p: np.ndarray, v: np.ndarray, a: float, dt: float, lo: float, hi: float,
             clo: float, chi: float, flo: str | None, fhi: str | None) -> str:
        """Words for an arc end the observer cannot follow."""
        if clo > hi:
            feat, need, have = flo, clo, hi
        else:
            feat, need, have = fhi, chi, lo
        text = (f"rate needed beyond vo: the arc end {feat} moves at {need:.4g} rad/s, the "
                f"observer can turn at most {have:.4g} rad/s")
        env = self.world.env
        try:
            kind, index = Feature.parse(feat) if feat else (None, -1)
        except ValueError:  # not a feature name
            kind, index = None, -1
        if kind == "V":
            vtx = env.vertices[index]
            lt = float(np.hypot(*(vtx - p)))
            bound = self.lss * self.vt / (self.vo + self.vt)
            text += (f" (pivot about {feat} with l_t = {lt:.4g} "
                     f"{'<' if lt < bound else '>='} Lss·vt/(vo+vt) = {bound:.4g})")
        elif kind == "E":
            text += f" (wall {feat} met with the rod too steep to slide)"
        return text


class FollowController(CompliantController):
    """Reactive motion only: the follow law (``ȧ = −v·u⊥/lss``), compliant at arc ends."""

    name = "follow"

    def preferred(self, p: np.ndarray, v: np.ndarray, a: float, dt: float) -> tuple[float, str]:
        """The follow law's rate (rad/s) and the mode ``reactive``."""
        return (-(-v[0] * math.sin(a) + v[1] * math.cos(a)) / self.lss, Mode.REACTIVE)

    def mode_at(self, p: np.ndarray, v: np.ndarray, a: float) -> str:
        """The mode the controller would be in: always ``reactive``."""
        return Mode.REACTIVE


class TranslateController(CompliantController):
    """Reactive motion by translation (``ȧ = 0``), compliant at arc ends."""

    name = "translate"

    def preferred(self, p: np.ndarray, v: np.ndarray, a: float, dt: float) -> tuple[float, str]:
        """Rate 0 (translation) and the mode ``reactive``."""
        return 0.0, Mode.REACTIVE


class PaperController(CompliantController):
    """The paper's strategy (§§IV–VI; ``docs/formulas.md``, "Escape points and the trigger"):
    reactive far from escape points, saturated rotation toward the goal once the trigger fires,
    compliant at arc ends.

    The trigger: for the rod orientation ``a``, every escape sample ``q`` that concerns it
    (:meth:`tether.analysis.EscapeTable.sweeps`) needs a sweep ``Δ``; the rotation starts when
    ``|p − q| <= L_g(Δ) + pad`` with ``pad = trigger_steps·vt·dt`` and keeps its sense until the
    rod is in that sample's goal. The escape table is evaluated at every reactive step (a lazy
    re-evaluation, on a lower bound of the smallest margin, let the trigger fire late whenever
    an escape point became a concern of the rod already close to its ``L_g``: 36 of the
    losses once listed in ``docs/strategy.md``). A committed rotation goes on until the rod is
    ``overshoot`` rad inside the goal, or half the width of the goal's narrowest arc if that is
    less (a goal narrower than twice the overshoot would never release the rotation: the rod
    hovered in it); one pinned against an arc end for ``refresh`` steps is handed over
    (:meth:`_hand_over`).

    ``reactive`` is ``"follow"`` (default) or ``"translate"``. ``escape_rows``: ``"all"``
    (pieces, reflex vertices, steep walls), ``"pieces"`` (Def. 2 alone, the paper's literal
    escape points) or ``"pieces+vertices"``. ``record=True`` keeps, per step, the escape-table
    row the rotation serves (``None`` when reactive) in ``commitments``, for
    :func:`tether.sim.diagnose.explain_loss`. Needs ``world.verdict``.
    """

    name = "paper"

    def __init__(self, world: World | None = None, reactive: str = "follow",
                 trigger_steps: float = 2.0, refresh: int = 8, overshoot: float = 0.2,
                 escape_rows: EscapeRows | str = EscapeRows.ALL, record: bool = False) -> None:
        self.reactive = reactive
        self.record = bool(record)
        self.escape_rows = EscapeRows(escape_rows)
        self.overshoot = float(overshoot)
        self.trigger_steps = float(trigger_steps)
        self.refresh = int(refresh)
        super().__init__(world)

    def _prepare(self, world: World) -> None:
        super()._prepare(world)
        self.table = None
        if world.verdict is not None:
            self.table = escape_table_of(world.verdict, self.vt / self.vo)
            if self.escape_rows != EscapeRows.ALL:
                self.table = self.table.subset(self.escape_rows)
            # per-row Python values for the committed row's check, made once
            t = self.table
            self._k_arcs = list(zip(t.k_start.tolist(), t.k_end.tolist(), strict=True))
            self._anywhere = (t.piece < 0).tolist()
            gs, ge = t.g_start.reshape(len(t), -1), t.g_end.reshape(len(t), -1)
            self._goals = [(g[np.isfinite(g)].tolist(), h[np.isfinite(g)].tolist())
                           for g, h in zip(gs, ge, strict=True)]
            self._hysteresis = [min([self.overshoot] + [0.5 * (((e - s) % math.tau) or math.tau)
                                                        for s, e in zip(*g, strict=True)])
                                for g in self._goals]
        self._reset_state()

    def _reset_state(self) -> None:
        self.goal_row: int | None = None
        self.sense = 0
        self._pinned = 0  # steps the committed rotation has been held back by an arc end
        self.commitments: list[int | None] = []  # per step, with ``record``

    def reset(self, world: World, p: np.ndarray, a: float) -> None:
        """Start a run from ``(p, a)`` in ``world``, no rotation committed."""
        super().reset(world, p, a)
        self._reset_state()

    def __copy__(self) -> PaperController:
        """A copy that does not record (the `search` target's look-ahead copies the controller;
        a shared ``commitments`` list would mix its trial steps into the run's record)."""
        twin = object.__new__(type(self))
        twin.__dict__.update(self.__dict__)
        twin.record, twin.commitments = False, []
        return twin

    def _scan(self, p: np.ndarray, a: float) -> tuple[int | None, float, int]:
        """The concerning escape sample with the smallest margin: (row, margin, sense)."""
        t = self.table
        if t is None or not len(t):
            return None, math.inf, 0
        arc = self.local.arc(float(p[0]), float(p[1]), a)
        concern, _, sense, margin = t.margins(p, a, self.vt, self.vo, arc)
        k = int(np.argmin(margin))
        if not concern[k]:
            return None, math.inf, 0
        return k, float(margin[k]), int(sense[k])

    def _trigger(self, p: np.ndarray, a: float, dt: float) -> tuple[int | None, int]:
        pad = self.pad(dt)
        if self.goal_row is not None:
            # keep the committed rotation until the rod is ``overshoot`` rad inside the goal
            # (at most half the goal's narrowest arc)
            # (hysteresis: the reactive law would otherwise pull it straight back); only the
            # committed row is checked meanwhile
            back = self._hysteresis[self.goal_row]
            if not self._still_concerned(p, a - self.sense * back)[0]:
                self.goal_row, self.sense = None, 0
            else:
                # the sense is re-chosen every step for the rod's arc now: a rotation pinned
                # against an arc end (the goal unreachable that way, compliant and making no
                # progress) turns the other way as soon as the arc opens toward the goal
                concerned, sense = self._still_concerned(p, a)
                if concerned and sense:
                    self.sense = sense
                if self._pinned >= self.refresh:
                    self._hand_over(p, a)
                return self.goal_row, self.sense
        row, margin, sense = self._scan(p, a)
        if row is not None and margin <= pad:
            self.goal_row, self.sense = row, sense
        return self.goal_row, self.sense

    def _hand_over(self, p: np.ndarray, a: float) -> None:
        """A committed rotation pinned against an arc end for ``refresh`` steps (its goal
        unreachable that way for now): re-scan every row and commit to the escape point with
        the smallest margin if it belongs to another piece, vertex or wall. Without it the
        commitment was kept while a second escape point, needing the other sense, came within
        reach unseen (the floor plans' pivot losses in ``docs/strategy.md``)."""
        self._pinned = 0
        row, _, sense = self._scan(p, a)
        if row is not None and self.table.piece[row] != self.table.piece[self.goal_row]:
            self.goal_row, self.sense = row, sense

    def _still_concerned(self, p: np.ndarray, a: float) -> tuple[bool, int]:
        """Whether the committed row still concerns orientation ``a`` (one row only), and the
        sense of its sweep to the goal inside the rod's free arc now."""
        k = self.goal_row
        ks, ke = self._k_arcs[k]
        if self._anywhere[k]:
            ks, ke = self.local.arc(float(p[0]), float(p[1]), a) or (ks, ke)
        concern, _, sense = sweep_row(ks, ke, self._goals[k][0], self._goals[k][1], a % math.tau)
        return concern, sense

    def preferred(self, p: np.ndarray, v: np.ndarray, a: float, dt: float) -> tuple[float, str]:
        """The saturated rate toward the goal once the trigger fires, else the reactive rate
        (rad/s), and the mode."""
        row, sense = self._trigger(p, a, dt)
        if row is not None:
            lo, hi = step_interval(float(v[0]), float(v[1]), a, self.lss,
                                   self.vo * (1.0 - VO_MARGIN), dt)
            return (hi if sense > 0 else lo), Mode.ROTATIONAL
        if self.reactive == "translate":
            return 0.0, Mode.REACTIVE
        return -(-v[0] * math.sin(a) + v[1] * math.cos(a)) / self.lss, Mode.REACTIVE

    def pad(self, dt: float) -> float:
        """The trigger's pad (map units) at control period ``dt`` (s)."""
        return self.trigger_steps * self.vt * dt

    def step(self, p: np.ndarray, v: np.ndarray, a: float, dt: float) -> Command:
        """The admissible command, counting the steps an arc end holds back the rotation."""
        cmd = super().step(p, v, a, dt)
        # a committed rotation held back by an arc end (compliant, turning less than half as
        # fast as asked, or the wrong way)
        if self.goal_row is not None and cmd.feasible and cmd.mode == Mode.COMPLIANT and \
                self.sense * cmd.rate < 0.5 * self.vo / self.lss:
            self._pinned += 1
        else:
            self._pinned = 0
        if self.record:
            self.commitments.append(self.goal_row)
        return cmd


def __getattr__(name: str) -> Any:
    """``CONTROLLERS``, deprecated here: the registry is :data:`tether.strategies.CONTROLLERS`
    (it names the kernel's controller too, which the simulation does not import)."""
    if name == "CONTROLLERS":
        import warnings

        from tether.strategies import CONTROLLERS

        warnings.warn("tether.sim.controller.CONTROLLERS is deprecated and will be removed in "
                      "the next release: use tether.strategies.CONTROLLERS",
                      DeprecationWarning, stacklevel=2)
        return CONTROLLERS
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
