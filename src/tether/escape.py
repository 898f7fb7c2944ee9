"""Escapable cells, their elimination and the existence verdict (``math.md`` §8, Prop. 1).

Cell ``K`` over ``R`` is escapable with respect to the surviving cells ``S`` iff some piece
``γ`` bounding ``R`` (toward ``R'``) has no cell of ``S`` over ``R'`` adjacent to ``K`` across
``γ``: the target crosses ``γ`` and no observer position continues the rod. Elimination is the
greatest fixed point of removing escapable cells, computed with a worklist in rounds (round
``k`` removes the cells escapable once rounds ``< k`` are removed). Since the free space is
connected the outcome is all-or-nothing: a surveillance strategy can exist iff some cell
survives (with unbounded observer speed, any start in a surviving cell can be held).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

from tether.decomposition import Decomposition
from tether.graph import ConnectivityGraph, build_graph


@dataclass(frozen=True)
class Elimination:
    """Why a cell fell: crossing ``piece`` into ``escapes_to`` loses it, in ``round``;
    ``because`` is the last partner across that piece whose removal made it escapable (None in
    round 1, or when the other side never had a partner)."""

    cell: str
    escapes_to: str
    piece: str
    round: int
    because: str | None

    def to_dict(self) -> dict:
        return {"cell": self.cell, "escapes_to": self.escapes_to, "piece": self.piece,
                "round": self.round, "because": self.because}


@dataclass(frozen=True, eq=False)
class Verdict:
    """The result of :func:`analyze`: surviving cells, eliminations, verdict and witness."""

    dec: Decomposition = field(repr=False)
    graph: ConnectivityGraph = field(repr=False)
    surviving: frozenset[str]
    eliminated: tuple[Elimination, ...]
    witness_region: int | None
    #: the cheap self-check run by :func:`analyze` (a
    #: :class:`tether.decomposition.CheckReport`), or None if it was skipped
    self_check: Any = None

    @property
    def verified(self) -> bool | None:
        """Whether the self-check passed (None: not run). A verdict with ``verified`` False
        rests on a decomposition that disagrees with exact evaluation somewhere."""
        return None if self.self_check is None else bool(self.self_check.ok)

    @property
    def strategy_exists(self) -> bool:
        """Whether some cell survives the elimination (necessary condition, Prop. 1)."""
        return bool(self.surviving)

    @property
    def rounds(self) -> int:
        return max((e.round for e in self.eliminated), default=0)

    def is_safe(self, points: Any, angles: Any) -> list[bool]:
        """Whether each rod configuration ``(x, y, a)`` lies in a surviving cell."""
        return [c is not None and c in self.surviving for c in self.dec.cell_at(points, angles)]

    def story(self) -> list[str]:
        """The escape in plain sentences: from the first escapable cell to the witness."""
        return escape_story(self)

    def counts(self) -> dict:
        return {"regions": len(self.dec.regions), "cells": len(self.dec.cells),
                "pieces": len(self.dec.pieces), "edges": len(self.graph.edge_list),
                "surviving_cells": len(self.surviving)}

    def to_dict(self) -> dict:
        return {
            "map": self.dec.env.name,
            "lss": self.dec.lss,
            "counts": self.counts(),
            "edges": [list(e) for e in self.graph.edges],
            "verdict": {
                "strategy_exists": self.strategy_exists,
                "witness_region": None if self.witness_region is None
                else f"R{self.witness_region}",
                "rounds": self.rounds,
                "surviving": sorted(self.surviving),
                "eliminated": [e.to_dict() for e in self.eliminated],
                "story": self.story(),
            },
            "self_check": None if self.self_check is None else self.self_check.to_dict(),
            "verified": self.verified,
        }

    def __repr__(self) -> str:
        return (f"Verdict(strategy_exists={self.strategy_exists}, "
                f"surviving={len(self.surviving)}/{len(self.dec.cells)}, "
                f"witness={self.witness_region})")

    def plot(self, fig: Any = None) -> Any:
        """The paper-style figure (see :func:`tether.plot.plot_verdict`)."""
        from tether.plot import plot_verdict

        return plot_verdict(self, fig)


def eliminate(graph: ConnectivityGraph) -> tuple[frozenset[str], tuple[Elimination, ...]]:
    """Greatest fixed point of removing escapable cells, by rounds (linear in the graph).

    Returns the surviving cells and the eliminations in the order they happened.
    """
    dec = graph.dec
    region_of = {c.id: c.region for c in dec.cells}
    alive, removed = fixed_point(region_of, graph.pieces_of, graph.partners)
    out = [Elimination(c, f"R{_other_region(dec, piece, region_of[c])}", f"P{piece}", rnd,
                       because) for c, piece, rnd, because in removed]
    return alive, tuple(out)


def fixed_point(region_of: dict[str, int], pieces_of: dict[int, tuple[int, ...]],
                partners: dict[tuple[str, int], tuple[str, ...]]
                ) -> tuple[frozenset[str], list[tuple[str, int, int, str | None]]]:
    """The elimination on abstract data: cells with their regions, the pieces bounding each
    region, and each (cell, piece)'s partners. A worklist keeps, per (cell, piece), the count
    of surviving partners; a cell falls when one count reaches 0. Returns the survivors and
    ``(cell, piece, round, because)`` per removal, in order."""
    alive = set(region_of)
    rank = {c: i for i, c in enumerate(sorted(region_of, key=_cell_key))}
    count = {key: len(ps) for key, ps in partners.items()}
    level: list[tuple[str, int, str | None]] = []
    for c in sorted(alive, key=rank.__getitem__):
        for piece in pieces_of[region_of[c]]:
            if count.get((c, piece), 0) == 0:
                level.append((c, piece, None))
                break
    queued = {c for c, _, _ in level}
    removed: list[tuple[str, int, int, str | None]] = []
    rnd = 0
    while level:
        rnd += 1
        for c, piece, because in level:
            alive.discard(c)
            removed.append((c, piece, rnd, because))
        nxt: list[tuple[str, int, str | None]] = []
        for c, _, _ in level:
            for piece in pieces_of[region_of[c]]:
                for partner in partners.get((c, piece), ()):
                    key = (partner, piece)
                    count[key] -= 1
                    if count[key] == 0 and partner in alive and partner not in queued:
                        queued.add(partner)
                        nxt.append((partner, piece, c))
        level = sorted(nxt, key=lambda t: rank[t[0]])
    return frozenset(alive), removed


def _cell_key(cid: str) -> tuple:
    """Sort key of a cell id ``(R3,E1,V2)``; other ids sort as plain strings after them."""
    parts = cid.strip("()").split(",")
    if len(parts) == 3 and parts[0][:1] == "R" and parts[0][1:].isdigit():
        return (0, int(parts[0][1:]), parts[1], parts[2])
    return (1, cid, "", "")


def _other_region(dec: Decomposition, piece: int, region: int) -> int:
    a, b = dec.pieces[piece].regions
    return b if a == region else a


def analyze(dec: Decomposition, graph: ConnectivityGraph | None = None,
            self_check: bool = True) -> Verdict:
    """Build G (unless given), eliminate escapable cells, and decide.

    The witness is a region without any cell (lowest id), else the first region emptied.
    With ``self_check`` (the default) the decomposition is verified cheaply first (see
    :func:`tether.decomposition.self_check`); :attr:`Verdict.verified` says whether it passed.
    """
    report = None
    if self_check:
        from tether.decomposition import self_check as run_self_check

        report = run_self_check(dec)
    graph = build_graph(dec) if graph is None else graph
    surviving, elim = eliminate(graph)
    witness = None
    if not surviving:
        empty = [r.id for r in dec.regions if not r.cells]
        if empty:
            witness = empty[0]
        else:
            left = {r.id: len(r.cells) for r in dec.regions}
            for e in elim:
                r = int(e.cell.strip("()").split(",")[0][1:])
                left[r] -= 1
                if left[r] == 0:
                    witness = r
                    break
    return Verdict(dec, graph, surviving, elim, witness, report)


def escape_story(v: Verdict) -> list[str]:
    """Plain sentences following the chain of eliminations that empties the witness region."""
    dec = v.dec
    if v.strategy_exists:
        lines = [f"{len(v.surviving)} of {len(dec.cells)} cells survive the elimination "
                 f"({len(v.eliminated)} eliminated in {v.rounds} rounds): a surveillance "
                 "strategy can exist if the rod starts in a surviving cell."]
        if v.eliminated:
            e = v.eliminated[0]
            lines.append(f"For example, from {e.cell} the target escapes by crossing "
                         f"{_piece_text(dec, e.piece)} into {e.escapes_to}.")
        return lines
    w = v.witness_region
    if w is not None and not dec.regions[w].cells:
        return [f"In region R{w} no rod orientation is free at all: a target that reaches it "
                "cannot be watched from distance lss. No surveillance strategy exists."]
    by_cell = {e.cell: e for e in v.eliminated}
    last = [e for e in v.eliminated if e.cell in dec.regions[w].cells][-1]
    chain = [last]
    while chain[-1].because is not None:
        chain.append(by_cell[chain[-1].because])
    lines = []
    for e in reversed(chain):
        if e.because is None:
            lines.append(f"Round {e.round}: cell {e.cell} is escapable. The target crosses "
                         f"{_piece_text(dec, e.piece)} into {e.escapes_to}, where no free arc "
                         "continues the rod's arc.")
        else:
            lines.append(f"Round {e.round}: {e.cell} falls. Across {_piece_text(dec, e.piece)} "
                         f"into {e.escapes_to} its last continuation, {e.because}, was "
                         "eliminated.")
    lines.append(f"Every cell over R{w} is eliminated: wherever the observer is, a target in "
                 f"R{w} can escape. No surveillance strategy exists (Proposition 1).")
    return lines


def _piece_text(dec: Decomposition, piece: str) -> str:
    from tether.curves import KIND_NAMES

    p = dec.pieces[int(piece[1:])]
    kinds = "/".join(KIND_NAMES.get(k, k) for k in p.kind)
    return f"{piece} ({kinds} of {', '.join(p.features)})"
