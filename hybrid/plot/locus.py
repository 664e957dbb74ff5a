"""Figure of ``hybrid locus``: loci of special points in a parameter plane with the one-parameter
branch they came from (Agg canvas).

Top: the branch, an amplitude against its parameter (stable solid, unstable dashed, neutral
dotted), its special points marked. Bottom: the parameter plane; the branch lies on the line of
the second parameter's value it was computed at (grey), its special points on it; each locus a
curve through its located points (a bracketed point hollow), one colour per kind.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
from matplotlib.figure import Figure

from .cont import _STYLE, _runs
from .trajectory import _new_figure

__all__ = ["locus_figure", "plot_locus"]

_COLOUR = {
    "fold": "C3",
    "period-doubling": "C4",
    "neimark-sacker": "C6",
    "branch-point": "C5",
    "mode-gained": "C0",
    "mode-lost": "C1",
    "grazing": "C2",
    "sequence-change": "C7",
    "hopf": "C3",
    "real-eigenvalue": "C8",
}


def locus_figure(loci: list, branches: list, coord: str | None = None) -> Figure:
    """The figure of ``hybrid locus``: the branch above, the parameter plane below (see the module
    docstring).

    Parameters
    ----------
    loci : list of hybrid.Locus
        The loci (:func:`hybrid.continue_locus`), drawn in the plane of their two parameters.
    branches : list of hybrid.Branch
        The one-parameter branches they came from, drawn once each.
    coord : str, optional
        The variable or output whose half peak-to-peak amplitude the branch shows (default: the
        first state variable of its orbits).

    Returns
    -------
    matplotlib.figure.Figure
        On an Agg canvas (no pyplot state).
    """
    fig = _new_figure((8.0, 8.0))
    ax_b, ax_p = fig.subplots(2, 1, sharex=True, gridspec_kw={"height_ratios": [1, 1.4]})
    p1, p2 = loci[0].parameters if loci else (branches[0].parameter, "")
    for br in branches:
        if not br.points:
            continue
        x = br.values
        if br.kind == "equilibria":
            keep = [e for e in br.points if e.converged and e.admissible]
            x = np.array([e.params[p1] for e in keep])
            y = np.zeros(x.size)
            st = [e.stability for e in keep]
        else:
            name = coord or next(iter(br.points[0].state_names), None)
            y = br.half_peak_to_peak(name) if name else np.zeros(x.size)
            st = br.stability
        for sl, s in _runs(x, st):
            ax_b.plot(x[sl], y[sl], _STYLE.get(s, "-"), color="k", lw=1.2)
        v2 = br.points[0].params.get(p2, np.nan)
        ax_p.plot([np.min(x), np.max(x)], [v2, v2], "-", color="0.6", lw=2.0, zorder=1)
        for sp in br.special:
            c = _COLOUR.get(sp.kind, "k")
            ax_p.plot([sp.parameter], [v2], "o", color=c, ms=6, zorder=4)
            yv = y[min(sp.index, y.size - 1)] if y.size else 0.0
            ax_b.plot([sp.parameter], [yv], "o", color=c, ms=6, zorder=4)
    seen = set()
    for lc in loci:
        a, b = lc.values(p1), lc.values(p2)
        c = _COLOUR.get(lc.kind, "k")
        label = lc.kind if lc.kind not in seen else None
        seen.add(lc.kind)
        ax_p.plot(a, b, "-", color=c, lw=1.5, label=label, zorder=3)
        located = np.array([q.status == "located" for q in lc.points])
        ax_p.plot(a[located], b[located], ".", color=c, ms=4, zorder=3)
        ax_p.plot(a[~located], b[~located], "o", mfc="none", color=c, ms=5, zorder=3)
    ax_b.set_ylabel(f"half peak-to-peak of {coord}" if coord else "amplitude")
    ax_p.set_xlabel(p1)
    ax_p.set_ylabel(p2)
    if seen:
        ax_p.legend(loc="best", fontsize=8)
    ax_b.grid(alpha=0.3)
    ax_p.grid(alpha=0.3)
    return fig


def plot_locus(loci: list, branches: list, path, coord: str | None = None) -> Path:
    """Write :func:`locus_figure` of ``loci`` over ``branches`` to ``path`` (PNG, 120 dpi).

    Parameters
    ----------
    loci, branches, coord
        As :func:`locus_figure`.
    path : str or Path
        The PNG file.

    Returns
    -------
    Path
    """
    path = Path(path)
    locus_figure(loci, branches, coord).savefig(path, dpi=120)
    return path
