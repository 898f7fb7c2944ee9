"""Why a run from a safe start was lost: the paper's conditions along the trajectory.

:func:`explain_loss` walks back from the loss to the last state that the paper's conditions
call safe (as :func:`tether.analysis.assessment` applies them: every concerning escape point farther
than its ``L_g``, no Prop. 3 conflict) and names what changed at the next step. Each cause is
either a *gap* of the paper's conditions (the controller did what the paper prescribes and the
target still won: ``docs/formulas.md``, "Escape points and the trigger") or a *bug* (the
controller or the escape table did not do what the paper prescribes). The trace itself is the
evidence: the state at ``t_safe`` is safe by the paper's conditions, the one a step later is
not, and the loss follows without the state becoming safe again.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from tether.analysis.assessment import conflicts, escape_point, escape_rows
from tether.analysis.escape_points import escape_table_of, row_name
from tether.sim.local import LocalArcs
from tether.sim.protocols import World

__all__ = ["CAUSES", "LossCause", "explain_loss"]

#: Causes: name → (``"gap"`` or ``"bug"``, what happened).
CAUSES: dict[str, tuple[str, str]] = {
    "prop3": ("gap", "a Prop. 3 conflict arose: two escape points in reach came to need "
                     "opposite sweeps that no schedule serves in time. The paper's conditions "
                     "held a step before; the target steered into this configuration instead "
                     "of dashing straight to one escape point, which is all the trigger "
                     "assumes"),
    "overtaken": ("gap", "the rotation toward this escape point's goal was under way (the "
                         "trigger had fired) and the target still came within L_g: the goal "
                         "moved with the target or an arc end held the rod back, neither of "
                         "which L_g accounts for"),
    "serial": ("gap", "the observer was rotating toward another escape point's goal when this "
                      "one came within L_g: the paper's strategy serves one escape point at "
                      "a time"),
    "appeared": ("gap", "the escape point became a concern of the rod already inside its L_g, "
                        "or its margin jumped below zero in one step: the rod turned into a "
                        "steep-wall cone with its tip near the wall, crossed into a cell with "
                        "an escape point close by, or an obstacle came to block the short "
                        "sweep. The trigger assumes margins that shrink continuously"),
    "late": ("bug", "the margin was within the trigger's pad and the controller was not "
                    "rotating: the trigger fired late"),
    "unforeseen": ("bug", "no escape point was within its L_g up to the loss: the escape "
                          "table misses what beat the observer"),
    "unsafe-start": ("start", "the start itself is unsafe by the paper's conditions "
                              "(tether assess says why)"),
}


@dataclass(frozen=True)
class LossCause:
    """The cause of a loss (:data:`CAUSES`): ``t_safe`` (s) the last time the paper's
    conditions held; ``escape`` the escape point (``P<k>``, ``V<j>``, ``E<i>``) whose margin
    went negative, or the Prop. 3 pair; ``margin``/``previous`` (map units) its margin after
    and before; ``committed`` the escape point the controller was rotating toward then."""

    cause: str
    t_safe: float | None
    lost_at: float | None
    escape: str | None = None
    margin: float | None = None
    previous: float | None = None
    committed: str | None = None

    @property
    def kind(self) -> str:
        """``"gap"``, ``"bug"`` or ``"start"`` (the start was not safe)."""
        return CAUSES[self.cause][0]

    @property
    def text(self) -> str:
        """The cause in words."""
        return CAUSES[self.cause][1]

    def to_dict(self) -> dict:
        """The diagnosis as JSON-ready values (times in seconds)."""
        return {"cause": self.cause, "kind": self.kind, "t_safe": self.t_safe,
                "lost_at": self.lost_at, "escape": self.escape, "margin": self.margin,
                "previous": self.previous, "committed": self.committed}


def _state(world: World, table, local: LocalArcs, p: np.ndarray, a: float):
    """Margins of every row (``inf`` where not concerned) and the Prop. 3 conflicts (pairs of
    escape-point names) at ``(p, a)``."""
    arc = local.arc(float(p[0]), float(p[1]), a)
    rows, values = escape_rows(table, p, a, world.vt, world.vo, world.lss, arc)
    pts = [escape_point(table, i, values, world.vt, world.vo, world.lss) for i in rows]
    pairs = conflicts(pts, world.vt, world.vo, world.lss, a, arc)
    return values[2], [f"{pts[i].piece}/{pts[j].piece}" for i, j in pairs]


def explain_loss(world: World, result, controller=None) -> LossCause | None:
    """The cause of ``result``'s loss (``None`` when it was held). ``controller``: the
    ``PaperController(record=True)`` of the run, for the escape-table row it was rotating
    toward at each step and its trigger pad; without it no step counts as committed and the
    pad is the default controller's."""
    if result.held:
        return None
    table = escape_table_of(world.verdict, world.vt / world.vo)
    if not len(table):
        return LossCause("unforeseen", None, result.lost_at)
    local = LocalArcs(world.env, world.lss, pad=0.0)
    names = [row_name(int(k)) for k in table.piece]
    tr = result.trace
    if controller is None:
        from tether.sim.controller import PaperController

        controller = PaperController(world)
    pad = controller.pad(result.dt)
    after = None
    for i in range(len(tr.t) - 1, -1, -1):
        margin, conflicts = _state(world, table, local, tr.p[i], float(tr.a[i]))
        if margin.min() >= 0 and not conflicts:
            break
        after = (margin, conflicts)
    else:
        return LossCause("unsafe-start", None, result.lost_at)
    t_safe = float(tr.t[i])
    if after is None:
        return LossCause("unforeseen", t_safe, result.lost_at)
    rows = controller.commitments
    goal = rows[i] if i < len(rows) else None
    goal_name = None if goal is None else names[goal]
    m_after, c_after = after
    k = int(np.argmin(m_after))
    if m_after[k] >= 0:
        return LossCause("prop3", t_safe, result.lost_at, c_after[0], committed=goal_name)
    before = float(margin[k])
    if goal_name == names[k]:
        cause = "overtaken"
    elif goal_name is not None:
        cause = "serial"
    elif not math.isfinite(before) or before > pad:
        cause = "appeared"
    else:
        cause = "late"
    return LossCause(cause, t_safe, result.lost_at, names[k], float(m_after[k]),
                     before if math.isfinite(before) else None, goal_name)
