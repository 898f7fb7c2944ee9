"""matplotlib figures. Reads every stage of the pipeline and changes none.

Every function takes ``ax=None`` (a new figure is made when omitted), draws, and returns the
list of artists it added; none calls ``plt.show()``. Figures are built with
``matplotlib.figure.Figure`` so that saving works under any backend.
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

import numpy as np
from matplotlib.figure import Figure

from tether import motion
from tether.bounds import check_speeds, distance_bound, worst_case_distance, worst_straight_time

TARGET_COLOUR = "tab:blue"
OBSERVER_COLOUR = "tab:orange"
ROD_COLOUR = "0.55"


def new_axes(ncols: int = 1, size: tuple[float, float] = (6.4, 4.8)) -> tuple[Figure, Any]:
    """A new figure (not registered with pyplot) and its axes."""
    fig = Figure(figsize=(size[0] * ncols, size[1]), layout="constrained")
    axes = fig.subplots(1, ncols)
    return fig, axes


def _ax(ax: Any) -> Any:
    return new_axes()[1] if ax is None else ax


def save(fig: Figure, path: str | Path, dpi: int = 120) -> None:
    """Save a figure whole: written to a temporary file with the same extension, then renamed
    (:func:`tether._util.files.atomic_output`); nothing is left behind if saving fails."""
    from tether._util.files import atomic_output

    with atomic_output(Path(path)) as tmp:
        fig.savefig(tmp, dpi=dpi)


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
    ax = _ax(ax)
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
    ax = _ax(ax)
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
    ax = _ax(ax)
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
    ax = _ax(ax)
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
    ax = _ax(ax)
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


# ---------------------------------------------------------------------- maps and decompositions
CURVE_COLOURS = {"A": "tab:red", "B": "tab:purple", "C": "tab:green", "D": "tab:brown",
                 "E": "tab:pink"}


def plot_map(env: Any, ax: Any = None, labels: bool = True) -> list:
    """The free space: obstacles grey, edges black, features labelled ``V<j>``/``E<i>`` as in
    the paper's figures (reflex vertices marked)."""
    ax = _ax(ax)
    x0, y0, x1, y1 = env.bounds
    pad = 0.04 * env.diameter
    arts = [ax.fill([x0 - pad, x1 + pad, x1 + pad, x0 - pad],
                    [y0 - pad, y0 - pad, y1 + pad, y1 + pad], color="0.85", zorder=0)]
    arts += ax.fill(env.boundary[:, 0], env.boundary[:, 1], color="white", zorder=0)
    for h in env.holes:
        arts += ax.fill(h[:, 0], h[:, 1], color="0.85", zorder=0)
    for ring in env.rings:
        closed = np.vstack((ring, ring[:1]))
        arts += ax.plot(closed[:, 0], closed[:, 1], color="k", lw=1.5, zorder=3)
    if labels and env.n <= 80:
        V = env.vertices
        c = V.mean(axis=0)
        for j, v in enumerate(V):
            off = v - c
            off = 0.015 * env.diameter * off / max(np.hypot(*off), 1e-300)
            arts.append(ax.annotate(f"V{j}", v, xytext=v + off, fontsize=7, color="navy",
                                    ha="center", va="center", zorder=5))
        nxt = env.next_vertex
        for i in range(env.n):
            mid = 0.5 * (V[i] + V[nxt[i]])
            arts.append(ax.text(*(mid - 0.02 * env.diameter * env.free_normals[i]), f"E{i}",
                                fontsize=7, color="darkgreen", ha="center", va="center",
                                zorder=5))
        r = env.reflex_indices
        arts += ax.plot(V[r, 0], V[r, 1], "o", color="navy", ms=3, zorder=4)
    ax.set_aspect("equal")
    ax.set_xlim(x0 - pad, x1 + pad)
    ax.set_ylim(y0 - pad, y1 + pad)
    return arts


def plot_decomposition(dec: Any, ax: Any = None, by_type: bool = False, labels: bool = True,
                       marked_regions: Any = (), tint: bool = True) -> list:
    """Paper Figs. 6-8: the map, critical curves (red, or coloured by type), regions tinted
    and labelled ``R<k>``; ``marked_regions`` get a red rectangle around their label."""
    import matplotlib as mpl

    ax = _ax(ax)
    arts = plot_map(dec.env, ax, labels=labels)
    if tint:
        cmap = mpl.colormaps["Pastel1"]
        for r in dec.regions:
            for poly in getattr(r.polygon, "geoms", [r.polygon]):
                xy = np.asarray(poly.exterior.coords)
                arts += ax.fill(xy[:, 0], xy[:, 1], color=cmap(r.id % 9), alpha=0.55, lw=0,
                                zorder=1)
    for kind in "ABCDE":
        colour = CURVE_COLOURS[kind] if by_type else "red"
        first = True
        for c in dec.curves:
            if c.kind != kind:
                continue
            for p in c.polylines:
                (line,) = ax.plot(p[:, 0], p[:, 1], color=colour, lw=0.9, zorder=2,
                                  label=f"{kind}: {_kind_name(kind)}" if by_type and first
                                  else None)
                arts.append(line)
                first = False
    if labels and len(dec.regions) <= 120:
        marked = set(marked_regions)
        for r in dec.regions:
            box = dict(boxstyle="square,pad=0.15", fc="none", ec="red", lw=1.5) \
                if r.id in marked else None
            arts.append(ax.text(*r.point, r.name, fontsize=7, ha="center", va="center",
                                zorder=6, bbox=box, clip_on=True))
    if by_type:
        ax.legend(fontsize=7, loc="upper right")
    ax.set_title(f"{dec.env.name or 'map'}: lss={dec.lss:g}, {len(dec.regions)} regions, "
                 f"{len(dec.cells)} cells")
    return arts


def _kind_name(kind: str) -> str:
    from tether.curves import KIND_NAMES

    return KIND_NAMES[kind]


def plot_graph(verdict: Any, ax: Any = None, only_surviving: bool = True) -> list:
    """The connectivity graph G (after elimination by default), nodes placed at their regions'
    points and spread around them; eliminated cells (if shown) in red."""
    import networkx as nx

    ax = _ax(ax)
    g = verdict.graph.graph
    dec = verdict.dec
    keep = [c for c in g.nodes if c in verdict.surviving or not only_surviving]
    sub = g.subgraph(keep)
    pos = {}
    scale = 0.03 * dec.env.diameter
    for r in dec.regions:
        cs = [c for c in r.cells if c in sub]
        for k, c in enumerate(cs):
            ang = 2 * math.pi * k / max(len(cs), 1)
            off = scale * np.array([math.cos(ang), math.sin(ang)]) if len(cs) > 1 else 0
            pos[c] = np.asarray(r.point) + off
    colours = ["tab:blue" if c in verdict.surviving else "tab:red" for c in sub.nodes]
    arts = [nx.draw_networkx_edges(sub, pos, ax=ax, edge_color="0.5", width=0.8)]
    arts.append(nx.draw_networkx_nodes(sub, pos, ax=ax, node_size=18, node_color=colours))
    if sub.number_of_nodes() <= 60:
        labels = {c: c.strip("()").replace(",", " ") for c in sub.nodes}
        arts.append(nx.draw_networkx_labels(sub, pos, labels, ax=ax, font_size=6))
    x0, y0, x1, y1 = dec.env.bounds
    ring = np.vstack((dec.env.boundary, dec.env.boundary[:1]))
    arts += ax.plot(ring[:, 0], ring[:, 1], color="0.8", lw=1, zorder=0)
    ax.set_aspect("equal")
    ax.set_title(f"G after elimination: {len(verdict.surviving)} of {len(dec.cells)} cells"
                 if only_surviving else
                 f"G: {len(dec.cells)} cells, all eliminated (red) in {verdict.rounds} rounds")
    return arts


def plot_verdict(verdict: Any, fig: Any = None) -> Figure:
    """Paper Figs. 6-8: left, the decomposition with regions holding eliminated cells marked
    by red rectangles; right, the graph G after elimination."""
    if fig is None:
        fig, (ax1, ax2) = new_axes(2, size=(6.4, 6.4))
    else:
        ax1, ax2 = fig.subplots(1, 2)
    marked = {int(e.cell.strip("()").split(",")[0][1:]) for e in verdict.eliminated}
    plot_decomposition(verdict.dec, ax1, marked_regions=marked)
    if verdict.witness_region is not None:
        w = verdict.dec.regions[verdict.witness_region]
        ax1.text(*w.point, w.name, fontsize=8, ha="center", va="center", zorder=7,
                 color="white", bbox=dict(boxstyle="square,pad=0.2", fc="red", ec="red"))
    # after elimination when something survives (as in the paper); else all of G, red = fallen
    plot_graph(verdict, ax2, only_surviving=verdict.strategy_exists)
    word = "a strategy can exist" if verdict.strategy_exists else "no strategy"
    fig.suptitle(f"{verdict.dec.env.name}: {word}"
                 + ("" if verdict.witness_region is None
                    else f" (witness R{verdict.witness_region})"))
    return fig
