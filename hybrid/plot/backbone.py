"""Figure of ``hybrid backbone``: frequency and damping ratio against amplitude (Agg canvas).

Two panels over a logarithmic amplitude axis: ``omega(a)`` [rad/s] with the linear limits of the
model's ``linear_references`` (e.g. every contact stuck, every contact sliding) as horizontal
lines, and ``D(a) = xi / (2 omega)``; the located events (first switch, all switched) marked.
Other curves (e.g. an approximation) may be drawn beside, each labelled as given.
"""

from __future__ import annotations

from collections.abc import Mapping
from pathlib import Path

import numpy as np

from ..model.plot_hints import unit_of
from .trajectory import _new_figure

__all__ = ["backbone_figure", "plot_backbone"]


def backbone_figure(bb, extra: Mapping[str, tuple] | None = None):
    """The figure of a :class:`hybrid.Backbone` (see the module docstring).

    Parameters
    ----------
    bb : Backbone
    extra : mapping, optional
        Label -> ``(amplitudes, omegas, damping_ratios)`` of other curves, drawn dashed.

    Returns
    -------
    matplotlib.figure.Figure
    """
    fig = _new_figure((8.0, 6.5))
    ax_w, ax_d = fig.subplots(2, 1, sharex=True)
    a = bb.column("amplitude")
    w = bb.column("omega")
    D = bb.column("damping_ratio")
    ax_w.plot(a, w, "-o", color="k", ms=3, lw=1.5, label="backbone (EPMC, time domain)")
    ax_d.plot(a, D, "-o", color="k", ms=3, lw=1.5, label="backbone (EPMC, time domain)")
    for k, (label, value) in enumerate(bb.references.items()):
        ax_w.axhline(value, color=f"C{k + 2}", ls=":", lw=1.2, label=f"{label} ({value:.6g} rad/s)")
    for k, (label, (ea, ew, ed)) in enumerate((extra or {}).items()):
        ax_w.plot(ea, ew, "--", color=f"C{k}", lw=1.2, label=label)
        ax_d.plot(ea, ed, "--", color=f"C{k}", lw=1.2, label=label)
    for j, e in enumerate(bb.events):
        for ax in (ax_w, ax_d):
            ax.axvline(e.amplitude, color="C3", lw=0.8, alpha=0.6)
        ax_w.annotate(
            f"{e.kind} a = {e.amplitude:.6g} ({e.status})",
            (e.amplitude, float(np.nanmax(w)) if w.size else 0.0),
            textcoords="offset points",
            xytext=(4, -12 - 12 * j),
            color="C3",
            fontsize=8,
        )
    unit = unit_of(bb.system, bb.coordinate)
    ax_d.set_xscale("log")
    ax_w.set_ylabel("omega [rad/s]")
    ax_d.set_ylabel("damping ratio D = xi / (2 omega)")
    ax_d.set_xlabel(f"amplitude max {bb.coordinate}" + (f" [{unit}]" if unit else ""))
    ax_w.set_title(f"{bb.system.name}: backbone of mode {bb.mode} ({bb.parameter} solved for)", fontsize=10)
    ax_w.legend(fontsize=8, loc="best")
    if extra:
        ax_d.legend(fontsize=8, loc="best")
    for ax in (ax_w, ax_d):
        ax.grid(True, which="both", alpha=0.3)
    return fig


def plot_backbone(bb, path, extra: Mapping[str, tuple] | None = None) -> Path:
    """Write :func:`backbone_figure` to ``path`` (PNG); returns the path."""
    path = Path(path)
    backbone_figure(bb, extra).savefig(path, dpi=110)
    return path
