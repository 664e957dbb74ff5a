"""Figure of a frequency-response curve (:class:`hybrid.continuation.frc.FrequencyResponse`), Agg canvas only.

One row per displacement coordinate (the model's ``plot.displacements``):
the whole range with a logarithmic amplitude axis, then one panel per
resonance zoomed on where the orbits switch (between its special points), with a
linear axis. Stable orbits are drawn solid, unstable dashed, neutral ones
(e.g. the undamped stuck response, a family of orbits) thin in another
colour; special points are marked and labelled; overlay curves (model
knowledge from the ``hybrid.frc_overlays`` entry points) are
drawn under the branches.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
from matplotlib.lines import Line2D
from matplotlib.patches import Patch
from matplotlib.ticker import MaxNLocator

from ..continuation.frc import FrequencyResponse
from ..model.plot_hints import plot_hints
from .trajectory import _new_figure

__all__ = ["plot_frc", "zoom_windows"]

STYLE = {
    "stable": dict(color="C0", ls="-", lw=1.8),
    "unstable": dict(color="C3", ls="--", lw=1.5),
    "neutral": dict(color="C2", ls="-", lw=0.9),
}
LABEL = {"stable": "stable", "unstable": "unstable", "neutral": "neutral (multiplier on the unit circle)"}
MARKER = {
    "fold": "D",
    "period-doubling": "s",
    "neimark-sacker": "^",
    "grazing": "v",
    "mode-gained": "o",
    "mode-lost": "o",
}
SHORT = {
    "fold": "fold",
    "period-doubling": "PD",
    "neimark-sacker": "NS",
    "grazing": "grazing",
    "mode-gained": "+mode",
    "mode-lost": "-mode",
}
OVERLAY_STYLE = [
    dict(color="k", ls=":", lw=1.0),
    dict(color="C1", ls="-.", lw=1.2),
    dict(color="C4", ls=(0, (5, 2, 1, 2)), lw=1.0),
    dict(color="C5", ls=":", lw=1.4),
]


def zoom_windows(fr: FrequencyResponse) -> list[tuple[float, float, float]]:
    """``(lo, hi, resonance)`` of each zoom panel, one per piece of the range that holds a resonance.

    The panel spans the piece's special points (e.g. where slip sets in and
    where it stops) and its gap, padded by 60 % of that span on each side;
    without special points, the orbits that switch modes; without those, 1 %
    around the resonance.
    """
    out = []
    for pc in fr.pieces:
        if pc.resonance is None:
            continue
        span = [sp.parameter for b in pc.branches for sp in b.special if pc.lo <= sp.parameter <= pc.hi]
        if not span:
            span = [o.params[fr.parameter] for b in pc.branches for o in b.points if o.transitions_per_period]
        span += [v for g in pc.gaps for v in g]
        if span:
            a, b = min(span), max(span)
            pad = max(0.6 * (b - a), 2e-4 * pc.resonance)
            a, b = a - pad, b + pad
        else:
            a, b = 0.99 * pc.resonance, 1.01 * pc.resonance
        out.append((max(a, pc.lo), min(b, pc.hi), pc.resonance))
    return out


def _runs(stab: list[str], unknown: frozenset = frozenset()) -> list[tuple[int, int, str]]:
    """Maximal runs ``[i, j]`` (inclusive) of equal stability, each extended to the next run's first point.

    The segment between two runs is drawn in the style of the earlier one: a
    located onset (e.g. of slip) is the first point of the new regime, so the
    segment up to it still belongs to the old one. Not across a segment in
    ``unknown`` (``j`` with a special point only bracketed between points ``j``
    and ``j + 1``): what lies there was not computed.
    """
    out = []
    i = 0
    n = len(stab)
    while i < n:
        j = i
        while j + 1 < n and stab[j + 1] == stab[i]:
            j += 1
        out.append((i, j if j in unknown else min(j + 1, n - 1), stab[i]))
        i = j + 1
    return out


def _unknown_segments(b) -> frozenset:
    """Segments ``(j, j + 1)`` of a branch that hold a special point it only bracketed."""
    return frozenset(sp.index - 1 for sp in b.special if sp.status == "bracketed" and sp.index > 0)


def _draw_branches(ax, fr: FrequencyResponse, name: str, window=None) -> list[float]:
    """Draw every branch's ``max |name|`` (on its own piece of the range); return the amplitudes in ``window``."""
    inside: list[float] = []
    lo, hi = fr.p_range
    for pc in fr.pieces:
        # inner piece ends: a step past them belongs to the neighbour; the range's ends clip by the axes
        a = pc.lo if pc.lo > lo else -np.inf
        b_ = pc.hi if pc.hi < hi else np.inf
        for b in pc.branches:
            if not b.points:
                continue
            p, amp = b.values, b.amplitude(name)
            amp = np.where((p >= a) & (p <= b_), amp, np.nan)
            unknown = _unknown_segments(b)
            for i, j, s in _runs(b.stability, unknown):
                st = STYLE.get(s)
                if st is not None:
                    ax.plot(p[i : j + 1], amp[i : j + 1], zorder=3, **st)
            for j in unknown:  # a bracketed change between two points: not computed in between
                if j + 1 < p.size:
                    ax.plot(p[j : j + 2], amp[j : j + 2], color="0.6", lw=0.8, ls=":", zorder=2)
            if window is not None:
                m = (p >= window[0]) & (p <= window[1]) & np.isfinite(amp)
                inside += list(amp[m])
    return inside


def _draw_special(ax, fr: FrequencyResponse, name: str, window=None, label: bool = True) -> None:
    k = 0
    last: dict[str, float] = {}
    width = (window[1] - window[0]) if window is not None else (fr.p_range[1] - fr.p_range[0])
    for b in fr.branches:
        for sp in b.special:
            if name not in sp.amplitude:
                continue
            x, y = sp.parameter, sp.amplitude[name]
            if sp.status == "bracketed":
                # at the orbit reported for it (on the curve), with the bracket as a bar
                x = b.points[sp.index].params[fr.parameter]
                ax.plot(list(sp.interval), [y, y], color="k", lw=1.2, zorder=5)
            if window is not None and not (window[0] <= x <= window[1]):
                continue
            filled = sp.kind != "mode-lost"
            ax.plot(
                [x],
                [y],
                marker=MARKER.get(sp.kind, "*"),
                ms=6,
                color="k",
                mfc="k" if filled else "w",
                ls="none",
                zorder=5,
            )
            # one label for a cluster of points of one kind (e.g. a grazing pair 1e-8 apart)
            if label and abs(x - last.get(sp.kind, -np.inf)) > 0.02 * width:
                last[sp.kind] = x
                dy = 12 if k % 2 == 0 else -16
                ax.annotate(
                    f"{SHORT.get(sp.kind, sp.kind)}\n{x:.5f}",
                    (x, y),
                    xytext=(6, dy),
                    textcoords="offset points",
                    fontsize=7,
                    va="center",
                    zorder=6,
                )
                k += 1


def _draw_overlays(ax, overlays, grid, name: str) -> None:
    for k, coords in enumerate(overlays.values()):
        if name in coords:
            st = OVERLAY_STYLE[k % len(OVERLAY_STYLE)]
            ax.plot(grid, coords[name], zorder=2, **st)


def plot_frc(
    fr: FrequencyResponse,
    path: str | Path,
    *,
    overlays: dict | None = None,
    grid: np.ndarray | None = None,
    coordinates: list[str] | None = None,
) -> Path:
    """Write the frequency-response figure as PNG.

    Parameters
    ----------
    fr : FrequencyResponse
    path : str or Path
    overlays : dict, optional
        ``{curve label: {coordinate: values on grid}}`` (e.g. from a ``hybrid.frc_overlays`` entry point).
    grid : ndarray, optional
        Frequencies of the overlay values [rad/s].
    coordinates : list of str, optional
        Coordinates to draw (default: the model's ``plot.displacements``, or those derived by
        :func:`hybrid.model.plot_hints.plot_hints`).

    Returns
    -------
    Path
    """
    system = fr.system
    overlays = overlays or {}
    coords = coordinates or list(plot_hints(system)["displacements"])
    units = {v.name: v.unit for v in system.variables}
    zooms = zoom_windows(fr)
    ncol = 1 + len(zooms)
    width, height = max(4.2 * ncol + 1.0, 10.0), 3.4 * len(coords) + 1.6
    # A fixed layout (margins in inches): matplotlib's constrained layout measures every tick label
    # once more and took 0.9 of the 1.7 s of this figure.
    fig = _new_figure((width, height), layout=None)
    gs = fig.add_gridspec(
        len(coords),
        ncol,
        width_ratios=[1.3] + [1.0] * len(zooms),
        left=0.85 / width,
        right=1.0 - 0.25 / width,
        top=1.0 - 0.75 / height,
        bottom=1.25 / height,
        wspace=0.28,
        hspace=0.45,
    )
    lo, hi = fr.p_range
    par = fr.parameter
    for r, name in enumerate(coords):
        ylab = f"max |{name}|" + (f" [{units[name]}]" if units.get(name) else "")
        ax = fig.add_subplot(gs[r, 0])
        amps = _draw_branches(ax, fr, name, (lo, hi))
        if grid is not None:
            _draw_overlays(ax, overlays, grid, name)
        _draw_special(ax, fr, name, label=not zooms)
        for a, b, _ in zooms:
            ax.axvspan(a, b, color="0.85", lw=0, zorder=0)
        for a, b in fr.gaps:
            ax.axvspan(a, b, color="C3", alpha=0.15, lw=0, zorder=0)
        pos = [a for a in amps if a > 0]
        if pos and max(pos) > 10.0 * min(pos):  # log axis where the amplitudes span decades
            ax.set_yscale("log")
            ax.set_ylim(min(pos) / 3.0, max(pos) * 5.0)
        elif amps:
            ax.set_ylim(0.0, 1.2 * max(amps))
        ax.set_xlim(lo, hi)
        ax.xaxis.set_major_locator(MaxNLocator(6))
        ax.ticklabel_format(axis="x", useOffset=False)
        ax.set_ylabel(ylab)
        ax.set_title(
            f"{name}: {par} {lo:.6g} to {hi:.6g} rad/s" + (" (grey: zoomed)" if zooms else ""),
            fontsize=9,
            y=1.0,
        )
        ax.grid(alpha=0.3, which="both")
        for c, (a, b, w) in enumerate(zooms, start=1):
            az = fig.add_subplot(gs[r, c])
            inside = _draw_branches(az, fr, name, (a, b))
            if grid is not None:
                _draw_overlays(az, overlays, grid, name)
            _draw_special(az, fr, name, (a, b))
            for ga, gb in fr.gaps:
                az.axvspan(ga, gb, color="C3", alpha=0.15, lw=0, zorder=0)
            az.set_xlim(a, b)
            if inside:
                az.set_ylim(0.0, 1.2 * max(inside))
            az.axvline(w, color="0.5", lw=0.6, ls=":")
            az.set_title(f"{name} near the resonance at {w:.5g} rad/s", fontsize=9, y=1.0)
            az.xaxis.set_major_locator(MaxNLocator(5))
            az.ticklabel_format(axis="x", useOffset=False)
            az.grid(alpha=0.3)
    for ax in fig.axes[-ncol:]:
        ax.set_xlabel(f"{par} [rad/s]")

    handles = [Line2D([], [], **STYLE[s], label=LABEL[s]) for s in STYLE]
    handles += [
        Line2D([], [], **OVERLAY_STYLE[k % len(OVERLAY_STYLE)], label=c) for k, c in enumerate(overlays)
    ]
    kinds = sorted({sp.kind for b in fr.branches for sp in b.special})
    handles += [
        Line2D(
            [],
            [],
            marker=MARKER.get(k, "*"),
            color="k",
            mfc="w" if k == "mode-lost" else "k",
            ls="none",
            label=f"{k} ({SHORT.get(k, k)})",
        )
        for k in kinds
    ]
    if fr.gaps:
        handles.append(Patch(color="C3", alpha=0.15, label="no orbit computed"))
    fig.legend(handles=handles, loc="lower center", ncol=min(len(handles), 4), fontsize=8, frameon=False)
    params = ", ".join(f"{k}={v:g}" for k, v in fr.params.items() if k != par)
    fig.suptitle(
        f"{system.title or system.name}: frequency response (max |x| over a period)\n{params}", fontsize=10
    )
    path = Path(path)
    fig.savefig(path, dpi=110)
    return path
