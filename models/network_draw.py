"""The figure of a network: points as columns, one row per element (``hybrid show FILE --out PNG``)."""

from __future__ import annotations

import textwrap
from collections import deque

from hybrid import ModelError

from .network_read import GROUND, Network

__all__ = ["MAX_DRAWN", "draw_network"]

#: Largest network drawn (rows of elements and forces); a larger one is refused with a clear error.
MAX_DRAWN = 120


def _layout(net: Network) -> dict[str, int]:
    """Columns of the points: the ground first, the masses in breadth-first order along the elements,
    each massless node between the points it joins (at the mean of their columns), so that a node
    hanging between two masses is drawn between them."""
    col = {GROUND: 0}
    adj: dict[str, list[str]] = {}
    for e in net.elements:
        adj.setdefault(e.a, []).append(e.b)
        adj.setdefault(e.b, []).append(e.a)
    queue = deque([GROUND])
    while queue:
        p = queue.popleft()
        for q in adj.get(p, []):
            if q not in col:
                col[q] = len(col)
                queue.append(q)
    for p in (*net.masses, *net.nodes):
        if p not in col:
            col[p] = len(col)
    order = list(col)  # breadth-first
    masses = [p for p in order if p not in net.nodes]
    pos = {p: float(k) for k, p in enumerate(masses)}
    nodes = [p for p in order if p in net.nodes]
    for u in nodes:
        pos[u] = float(len(masses))
    for _ in range(50):  # each node at the mean of its neighbours (the masses stay)
        for u in nodes:
            nb = [pos[q] for q in adj.get(u, []) if q in pos]
            if nb:
                pos[u] = sum(nb) / len(nb)
    ranked = sorted(order, key=lambda p: (pos[p], p in net.nodes, col[p]))
    return {p: k for k, p in enumerate(ranked)}


def draw_network(net: Network, path) -> None:
    """Draw the network as a PNG: points as columns (ground hatched, masses as boxes, nodes as dots),
    one row per element (springs as zigzags, dampers as pistons, friction as blocks), forces as arrows.

    Parameters
    ----------
    net : Network
    path : str or Path
        The PNG to write.

    Raises
    ------
    ModelError
        The network has more than :data:`MAX_DRAWN` elements and forces (the figure would be unreadable).
    """
    import numpy as np
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure
    from matplotlib.patches import Rectangle

    rows = len(net.elements) + len(net.forces)
    if rows > MAX_DRAWN:
        raise ModelError(
            f"network `{net.name}` has {rows} elements and forces; at most {MAX_DRAWN} are drawn (one row "
            "each). `hybrid show` without --out prints it; to see the structure, draw a copy of the file "
            "with fewer copies of its cells"
        )
    col = _layout(net)
    width = max(6.5, 2.0 + 1.8 * len(col))
    fig = Figure(figsize=(width, 1.4 + 0.55 * rows))
    FigureCanvasAgg(fig)
    ax = fig.add_subplot()
    top = rows + 0.5
    for p, x in col.items():
        if p == GROUND:
            ax.add_patch(Rectangle((x - 0.08, -0.5), 0.08, top + 0.5, hatch="///", fill=False, lw=1))
            label = "base y(t)" if net.base else "ground"
        elif p in net.masses:
            ax.add_patch(Rectangle((x - 0.15, -0.5), 0.3, top + 0.5, color="0.85", ec="k", lw=1, zorder=2))
            label = f"{p}\n({net.masses[p][0]})"
        else:
            ax.plot([x, x], [-0.5, top], color="k", lw=1, ls=":")
            label = p
        ax.text(x, top + 0.25, label, ha="center", va="bottom", fontsize=9)

    def edge(p: str) -> float:
        return 0.15 if p in net.masses else 0.0

    for row, e in enumerate(net.elements):
        (xa, pa), (xb, pb) = sorted(((col[e.a], e.a), (col[e.b], e.b)))
        y = row
        if pa == GROUND and xb - xa > 1:
            # to the ground across other points: a ground of its own beside the point, not a line
            # drawn through the masses in between
            xa = xb - 1
            ax.add_patch(Rectangle((xa - 0.08, y - 0.3), 0.08, 0.6, hatch="///", fill=False, lw=1, zorder=3))
        lo, hi = xa + edge(pa), xb - edge(pb)
        if any(xa < col[q] < xb for q in net.masses):
            # across a mass (between two other points): the symbol in the first gap, the line
            # passing behind the masses (their boxes are drawn over it)
            hi_sym = min(col[q] for q in col if xa < col[q] < xb) - edge(pb)
            ax.plot([hi_sym, hi], [y, y], color="0.5", lw=1, ls="--", zorder=1)
            hi = hi_sym
        mid = 0.5 * (lo + hi)
        w = min(0.5, 0.4 * (hi - lo))
        if e.kind == "spring":
            zx = np.linspace(mid - w / 2, mid + w / 2, 9)
            zy = y + 0.15 * np.array([0, 1, -1, 1, -1, 1, -1, 1, 0])
            ax.plot([lo, mid - w / 2], [y, y], "k", lw=1)
            ax.plot(zx, zy, "k", lw=1)
            ax.plot([mid + w / 2, hi], [y, y], "k", lw=1)
        elif e.kind == "damper":
            ax.plot([lo, mid], [y, y], "k", lw=1)
            ax.plot(
                [mid - w / 3, mid + w / 3, mid + w / 3, mid - w / 3],
                [y - 0.15, y - 0.15, y + 0.15, y + 0.15],
                "k",
                lw=1,
            )
            ax.plot([mid, mid], [y - 0.12, y + 0.12], "k", lw=2)
            ax.plot([mid, hi], [y, y], "k", lw=1)
        else:
            ax.plot([lo, mid], [y, y], "k", lw=1)
            ax.add_patch(Rectangle((mid - w / 4, y - 0.18), w / 2, 0.36, color="tab:red", alpha=0.6))
            ax.plot([mid + w / 4, hi], [y, y], "k", lw=1)
        level = e.coef + (f", {e.static}" if e.static else "")
        ax.text(mid, y + 0.22, f"{e.name}: {level}", ha="center", va="bottom", fontsize=8)
    for k, f in enumerate(net.forces):
        y = len(net.elements) + k
        x = col[f.on]
        arrow = {"arrowstyle": "->", "color": "tab:blue"}
        ax.annotate("", xy=(x + 0.6, y), xytext=(x + edge(f.on), y), arrowprops=arrow)
        ax.text(
            x + 0.2, y + 0.15, f"{f.name} = {force_text(f, ' ')}", va="bottom", fontsize=8, color="tab:blue"
        )
    ax.set_xlim(-0.6, len(col) - 0.2)
    ax.set_ylim(-0.8, top + 0.9)
    ax.set_axis_off()
    title = f"network `{net.name}`" + (f": {net.title}" if net.title else "")
    ax.set_title(textwrap.fill(title, int(11 * width)), fontsize=10)
    fig.tight_layout()
    fig.savefig(path, dpi=110)


def force_text(f, times: str = "*") -> str:
    """An excitation as text: ``F0 + F*sin(Omega*t + phase)``, or a sum of harmonics
    ``F0 + F1*sin(Omega*t) + F2*sin(2*Omega*t + phi2)``."""
    waves = []
    for amp, n, phase in f.terms():
        arg = (f"{n}{times}" if n != 1 else "") + f"{f.frequency}{times}t" + (f" + {phase}" if phase else "")
        waves.append(f"{amp}{times}sin({arg})")
    return " + ".join(p for p in (f.offset, *waves) if p)
