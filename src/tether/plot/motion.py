"""The observer's motions of the paper's Figs. 2-5 integrated from the velocity laws
(:mod:`tether.motion`), and the distance bound ``L`` against the rotation angle
(``tether plot-motion``, ``tether bound --plot``; see ``docs/formulas.md``)."""

from __future__ import annotations

import math
from typing import Any

import numpy as np
from matplotlib.figure import Figure

import tether.motion as motion
from tether.bounds import check_speeds, distance_bound, worst_case_distance, worst_straight_time
from tether.plot.axes import OBSERVER_COLOUR, ROD_COLOUR, TARGET_COLOUR, ensure_axes, new_axes

__all__ = ["plot_tractrix", "plot_rotation", "plot_wall", "plot_vertex", "plot_distance_bound",
           "bound_figure"]


def _draw_trace(ax: Any, sol: Any, t_end: float, n_rods: int = 9) -> list:
    t = np.linspace(0, min(t_end, sol.t[-1]), 400)
    y = sol.sol(t)
    arts = ax.plot(y[0], y[1], color=TARGET_COLOUR, lw=2, label="target")
    arts += ax.plot(y[2], y[3], color=OBSERVER_COLOUR, lw=2, label="observer")
    for tk in np.linspace(t[0], t[-1], n_rods):
        Tx, Ty, Ox, Oy, _ = sol.sol(tk)
        arts += ax.plot([Tx, Ox], [Ty, Oy], color=ROD_COLOUR, lw=1)
        arts += ax.plot([Tx], [Ty], "o", color=TARGET_COLOUR, ms=3)
        arts += ax.plot([Ox], [Oy], "o", color=OBSERVER_COLOUR, ms=3)
    ax.set_aspect("equal")
    ax.legend(loc="best", fontsize=8)
    return arts


def plot_tractrix(ax: Any = None, lss: float = 1.0, vt: float = 1.0, s0: float = -3.0,
                  s1: float = 3.0) -> list:
    """Paper Fig. 2: the follow (hound) motion against a straight target is the tractrix.

    Integrates :func:`tether.motion.follow` and overlays the closed form ``x = lss (s - tanh s)``,
    ``y = lss sech s`` (dashed)."""
    ax = ensure_axes(ax)
    x0, y0 = motion.tractrix(s0, lss)
    t_end = (s1 - s0) * lss / vt
    sol = motion.trace(motion.follow, lambda t, T, O: (vt, 0.0), (lss * s0, 0.0),
                       (float(x0), float(y0)), t_end)
    arts = _draw_trace(ax, sol, t_end)
    s = np.linspace(s0, s1, 300)
    x, y = motion.tractrix(s, lss)
    arts += ax.plot(x, y, "k--", lw=1, label="closed form")
    ax.set_title(f"Follow motion = tractrix (lss={lss:g}, vt={vt:g})")
    ax.legend(loc="best", fontsize=8)
    return arts


def plot_rotation(ax: Any = None, vt: float = 1.0, vo: float = 2.0, lss: float = 1.0,
                  theta0: float = 0.0, thetaf: float = 2 * math.pi) -> list:
    """Paper Fig. 3: saturated rotation around a target running along +x; the observer traces
    the cycloid-like curve. Angles are the paper's θ (lifted); the sense is their order."""
    from tether.bounds import rotation_time

    vt, vo, lss = check_speeds(vt, vo, lss)
    ax = ensure_axes(ax)
    sense = 1 if thetaf >= theta0 else -1
    a0 = theta0 - math.pi / 2  # ψ = 0
    T_rot = rotation_time(theta0, thetaf, vt, vo, lss)
    sol = motion.trace(lambda T, O, V: motion.rotate(T, O, V, vo, sense),
                       lambda t, T, O: (vt, 0.0), (0.0, 0.0),
                       (lss * math.cos(a0), lss * math.sin(a0)), T_rot * 1.0000001 + 1e-9)
    arts = _draw_trace(ax, sol, T_rot, n_rods=13)
    ax.set_title(f"Saturated rotation: {math.degrees(abs(thetaf - theta0)):.0f}° "
                 f"{'CCW' if sense > 0 else 'CW'} in {T_rot:.3g} s (vt={vt:g}, vo={vo:g})")
    return arts


def plot_wall(ax: Any = None, vt: float = 1.0, vo: float = 2.0, lss: float = 1.0,
              h: float = 0.6, heading: float = -0.35, t_end: float = 2.0) -> list:
    """Paper Fig. 4: the observer end slides along a wall (the x-axis) while the target, at
    height ``h``, runs with ``heading`` (radians) toward the wall; stops where infeasible."""
    vt, vo, lss = check_speeds(vt, vo, lss)
    ax = ensure_axes(ax)
    V = (vt * math.cos(heading), vt * math.sin(heading))
    T0 = (0.0, h)
    O0 = (math.sqrt(lss * lss - h * h), 0.0)
    sol = motion.trace(lambda T, O, Vt: motion.slide_on_wall(T, O, Vt, (1.0, 0.0), vo),
                       lambda t, T, O: V, T0, O0, t_end,
                       stop=lambda t, y: y[1] - 0.05 * lss)
    arts = ax.fill_between([-0.5 * lss, O0[0] + vt * t_end + lss], -0.25 * lss, 0,
                           color="0.8", label="obstacle")
    arts = [arts] + _draw_trace(ax, sol, sol.t[-1])
    ax.set_title(f"Compliant motion along a wall (vt={vt:g}, vo={vo:g})"
                 + ("; stops: infeasible" if sol.infeasible else ""))
    return arts


def plot_vertex(ax: Any = None, vt: float = 1.0, vo: float = 2.5, lss: float = 2.0,
                lt: float = 1.2, t_end: float = 1.0) -> list:
    """Paper Fig. 5: the rod kept in contact with a reflex vertex at the origin while the
    target runs straight up, ``lt`` from the vertex at the start; the rod pivots on the vertex
    and the observer swings away from the obstacle."""
    vt, vo, lss = check_speeds(vt, vo, lss)
    ax = ensure_axes(ax)
    V = np.zeros(2)
    T0 = (-lt, 0.0)
    O0 = (lss - lt, 0.0)
    sol = motion.trace(lambda T, O, Vt: motion.contact_vertex(T, O, Vt, V, vo),
                       lambda t, T, O: (0.0, vt), T0, O0, t_end)
    # the obstacle lies where free translation would push the rod: above it, beyond V
    wedge = np.array([[0, 0], [0.8 * lss, 0.03 * lss], [0.8 * lss, 0.9 * lss],
                      [0.08 * lss, 0.9 * lss]])
    arts = ax.fill(wedge[:, 0], wedge[:, 1], color="0.8", label="obstacle")
    arts += _draw_trace(ax, sol, sol.t[-1])
    arts += ax.plot([0], [0], "ks", ms=5)
    ax.set_title(f"Compliant motion around a vertex (vt={vt:g}, vo={vo:g})"
                 + ("; stops: infeasible" if sol.infeasible else ""))
    return arts


def plot_distance_bound(ax: Any = None, ratios: tuple[float, ...] = (0.25, 0.5, 0.75, 0.9),
                        vo: float = 1.0, lss: float = 1.0, mark: tuple[float, float] | None = None
                        ) -> list:
    """``L`` against the rotation angle Δ for a few speed ratios ``vt/vo``: the paper's bound
    for the worst straight heading (solid) and the safe bound ``L_g`` against a steering target
    (dashed). ``mark = (Δ, L)`` adds a point."""
    ax = ensure_axes(ax)
    delta = np.linspace(0, 2 * math.pi, 200)
    arts = []
    for r in ratios:
        vt = r * vo
        ls = vt * worst_straight_time(delta, vt, vo, lss)
        (line,) = ax.plot(np.degrees(delta), ls / lss, lw=2, label=f"vt/vo = {r:g}")
        arts.append(line)
        arts += ax.plot(np.degrees(delta), worst_case_distance(delta, vt, vo, lss) / lss, "--",
                        color=line.get_color(), lw=1)
    if mark is not None:
        arts += ax.plot([math.degrees(mark[0])], [mark[1] / lss], "k*", ms=10, label="this case")
    ax.set_xlabel("rotation Δ (degrees)")
    ax.set_ylabel("L / lss")
    ax.set_yscale("log")
    ax.set_title("Distance bound: straight target (solid), steering target L_g (dashed)")
    ax.legend(fontsize=8)
    ax.grid(alpha=0.3)
    return arts


def bound_figure(theta0: float, thetaf: float, vt: float, vo: float, lss: float) -> Figure:
    """Figure of ``tether bound --plot``: L against Δ with this case marked."""
    fig, ax = new_axes()
    ratio = vt / vo
    ratios = tuple(sorted({0.25, 0.5, 0.75, round(ratio, 3)}))
    plot_distance_bound(ax, ratios, vo, lss,
                        mark=(abs(thetaf - theta0), distance_bound(theta0, thetaf, vt, vo, lss)))
    return fig
