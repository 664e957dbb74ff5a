"""Figure of ``hybrid cont``: amplitude and period against the continued parameter (Agg canvas).

Equilibria (amplitude 0) and periodic orbits together; stable solid, unstable dashed, neutral
dotted; a loss of stability of an equilibrium (Hopf point) marked by a circle, the end of an
orbit branch at a grazing by a cross.
"""

from __future__ import annotations

import textwrap
from pathlib import Path

import numpy as np
from matplotlib.lines import Line2D

from ..model.plot_hints import unit_of
from .frc import with_unit
from .trajectory import _new_figure

__all__ = ["plot_cont", "cont_figure"]

_STYLE = {"stable": "-", "unstable": "--", "neutral": ":"}


def _runs(values, stability):
    """Consecutive pieces of equal stability (each piece shares its end point with the next)."""
    start = 0
    for k in range(1, len(values) + 1):
        if k == len(values) or stability[k] != stability[start]:
            yield slice(start, min(k + 1, len(values))), stability[start]
            start = k


def cont_figure(system, parameter: str, coord: str, eq_branches, orbit_branches):
    """The figure (see the module docstring); returns a matplotlib Figure."""
    fig = _new_figure((8.0, 6.5))
    ax_a, ax_t = fig.subplots(2, 1, sharex=True)
    for eb in eq_branches:
        keep = [e for e in eb.points if e.converged and e.admissible]
        p = np.array([e.params[parameter] for e in keep])
        st = [e.stability for e in keep]
        for sl, s in _runs(p, st):
            ax_a.plot(p[sl], np.zeros(p[sl].size), _STYLE.get(s, "-"), color="k", lw=1.5)
        for sp in eb.special:
            ax_a.plot([sp.parameter], [0.0], "o", color="C3", ms=8, zorder=5)
            ax_a.annotate(
                f"{sp.kind} {parameter} = {with_unit(sp.parameter, unit_of(system, parameter))}",
                (sp.parameter, 0.0),
                textcoords="offset points",
                xytext=(6, 8),
                color="C3",
                fontsize=8,
            )
            frequency = abs(float(eb.points[sp.index].eigenvalues[0].imag))
            if sp.kind == "hopf" and frequency > 0:
                ax_t.plot([sp.parameter], [2 * np.pi / frequency], "o", color="C3", ms=8, zorder=5)
    for kind, br in orbit_branches:
        if not br.points:
            continue
        color = "C0" if kind == "hopf" else "C1"
        p = br.values
        amp = br.half_peak_to_peak(coord)
        T = np.array([o.period for o in br.points])
        st = br.stability
        order = np.arange(p.size)
        for sl, s in _runs(p, st):
            ax_a.plot(p[order[sl]], amp[sl], _STYLE.get(s, "-"), color=color, lw=1.8)
            ax_t.plot(p[order[sl]], T[sl], _STYLE.get(s, "-"), color=color, lw=1.8)
        if br.reason == "grazing":
            ax_a.plot([p[-1]], [amp[-1]], "x", color="C3", ms=9, mew=2, zorder=5)
            ax_t.plot([p[-1]], [T[-1]], "x", color="C3", ms=9, mew=2, zorder=5)
    unit = unit_of(system, parameter)
    ax_t.set_xlabel(f"{parameter}" + (f" [{unit}]" if unit else ""))
    cu = unit_of(system, coord)
    ax_a.set_ylabel(f"amplitude of {coord} (half peak-to-peak)" + (f" [{cu}]" if cu else ""))
    ax_t.set_ylabel("period T [s]")
    handles = [
        Line2D([], [], color="k", ls="-", label="equilibrium, stable"),
        Line2D([], [], color="k", ls="--", label="equilibrium, unstable"),
        Line2D([], [], color="C0", ls="--", label="orbits from the Hopf point"),
        Line2D([], [], color="C1", ls="-", label="orbits from the preset's cycle"),
        Line2D([], [], color="grey", ls="-", label="stable (solid) / unstable (dashed)"),
        Line2D([], [], color="C3", marker="o", ls="", label="loss of stability (Hopf)"),
        Line2D([], [], color="C3", marker="x", ls="", mew=2, label="grazing (branch end)"),
    ]
    ax_a.legend(handles=handles, fontsize=8, loc="best")
    params = next((b.params for b in [*eq_branches, *(br for _, br in orbit_branches)] if b.points), {})
    others = ", ".join(
        f"{k} = {with_unit(v, unit_of(system, k))}" for k, v in params.items() if k != parameter
    )
    head = f"{system.title or system.name}: equilibria and periodic orbits against {parameter}"
    ax_a.set_title("\n".join([head, *textwrap.wrap(others, 95)]), fontsize=9)
    for ax in (ax_a, ax_t):
        ax.grid(alpha=0.3)
    return fig


def plot_cont(system, parameter: str, coord: str, eq_branches, orbit_branches, path) -> Path:
    """Write :func:`cont_figure` to ``path`` (PNG); returns the path."""
    path = Path(path)
    cont_figure(system, parameter, coord, eq_branches, orbit_branches).savefig(path, dpi=110)
    return path
