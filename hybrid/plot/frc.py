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

from dataclasses import dataclass
from pathlib import Path

import numpy as np
from matplotlib.lines import Line2D
from matplotlib.patches import Patch
from matplotlib.ticker import FuncFormatter, MaxNLocator

from ..continuation.frc import FrequencyResponse
from ..model.plot_hints import plot_hints, unit_of
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


#: A zoom panel is drawn only for a window narrower than this fraction of the whole range: a wider one
#: shows nothing the whole-range panel does not.
ZOOM_MAX_FRACTION = 0.25
#: ... and only where the curve shows something there: two special points or more, a gap, or
#: amplitudes that vary by more than this fraction of their largest value in the window.
ZOOM_MIN_VARIATION = 0.02


def _shows_something(fr: FrequencyResponse, a: float, b: float, coords: list[str]) -> bool:
    """Whether the branches between ``a`` and ``b`` hold detail: 2+ special points, a gap, or a varying amplitude."""
    n_special = sum(1 for br in fr.branches for sp in br.special if a <= sp.parameter <= b)
    if n_special >= 2 or any(ga < b and gb > a for ga, gb in fr.gaps):
        return True
    for name in coords:
        amps = []
        for br in fr.branches:
            if not br.points:
                continue
            p = br.values
            try:
                amp = br.amplitude(name)
            except KeyError:
                continue
            m = (p >= a) & (p <= b) & np.isfinite(amp)
            amps += list(amp[m])
        if len(amps) >= 2 and max(amps) > 0 and (max(amps) - min(amps)) > ZOOM_MIN_VARIATION * max(amps):
            return True
    return False


def zoom_windows(fr: FrequencyResponse) -> list[tuple[float, float, float | None]]:
    """``(lo, hi, resonance)`` of each zoom panel: where a piece of the range holds detail too narrow
    to see over the whole range.

    For each piece of the range, the window spans its special points (e.g. where slip sets in and
    where it stops) and its gaps, padded by 60 % of that span on each side; without special
    points, the orbits that switch modes. It becomes a panel only if it is narrower than
    :data:`ZOOM_MAX_FRACTION` of the whole range and the curve shows something there (two special
    points or more, a gap, or amplitudes varying by more than :data:`ZOOM_MIN_VARIATION`);
    otherwise the whole-range panel shows it all, and there is no zoom. ``resonance`` is the
    piece's natural frequency if it lies in the window, else None.

    Parameters
    ----------
    fr : FrequencyResponse

    Returns
    -------
    list of (float, float, float or None)
    """
    out = []
    lo, hi = fr.p_range
    coords = list(plot_hints(fr.system)["displacements"])
    for pc in fr.pieces:
        span = [sp.parameter for b in pc.branches for sp in b.special if pc.lo <= sp.parameter <= pc.hi]
        if not span:
            span = [o.params[fr.parameter] for b in pc.branches for o in b.points if o.transitions_per_period]
        span += [v for g in pc.gaps for v in g]
        if not span:
            continue
        ref = pc.resonance if pc.resonance is not None else 0.5 * (pc.lo + pc.hi)
        a, b = min(span), max(span)
        pad = max(0.6 * (b - a), 2e-4 * ref)
        a, b = max(a - pad, pc.lo), min(b + pad, pc.hi)
        if b - a > ZOOM_MAX_FRACTION * (hi - lo) or not _shows_something(fr, a, b, coords):
            continue
        w = pc.resonance if pc.resonance is not None and a <= pc.resonance <= b else None
        out.append((a, b, w))
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


def _segment_at(b, sp, name: str) -> tuple[float, float, float, float] | None:
    """The part ``(x0, y0, x1, y1)`` of the straight segment between a bracketed point's neighbouring
    orbits that lies in its interval (the segment drawn for the branch there)."""
    j = sp.index - 1
    if j < 0 or sp.index >= len(b.points):
        return None
    p = b.values
    amp = b.amplitude(name)
    p0, p1, a0, a1 = p[j], p[j + 1], amp[j], amp[j + 1]
    if not (np.isfinite(a0) and np.isfinite(a1)) or p0 == p1:
        return None
    lo, hi = sorted(sp.interval)
    lo, hi = max(lo, min(p0, p1)), min(hi, max(p0, p1))
    if not lo <= hi:
        return None

    def at(x: float) -> float:
        return float(a0 + (a1 - a0) * (x - p0) / (p1 - p0))

    return lo, at(lo), hi, at(hi)


def _special_points(fr: FrequencyResponse, name: str, window) -> list[dict]:
    """Where each special point of ``name``'s curve is drawn: a marker on the curve, and for a
    bracketed one the interval along the curve."""
    out = []
    for b in fr.branches:
        for sp in b.special:
            if name not in sp.amplitude:
                continue
            item = {"kind": sp.kind, "x": sp.parameter, "y": sp.amplitude[name], "interval": None}
            if sp.status == "bracketed":
                seg = _segment_at(b, sp, name)
                if seg is not None:
                    x0, y0, x1, y1 = seg
                    item.update(x=0.5 * (x0 + x1), y=0.5 * (y0 + y1), interval=seg)
                else:  # at the orbit reported for it, on the curve
                    item.update(x=b.points[sp.index].params[fr.parameter])
            if window[0] <= item["x"] <= window[1]:
                out.append(item)
    return out


def _draw_special(ax, items: list[dict]) -> None:
    for it in items:
        if it["interval"] is not None:  # the interval in which it lies, drawn along the curve
            x0, y0, x1, y1 = it["interval"]
            ax.plot([x0, x1], [y0, y1], color="0.2", lw=5.0, alpha=0.35, solid_capstyle="butt", zorder=4)
            ax.plot([x0, x1], [y0, y1], color="k", ls="none", marker="|", ms=9, zorder=5)
        filled = it["kind"] != "mode-lost"
        ax.plot(
            [it["x"]],
            [it["y"]],
            marker=MARKER.get(it["kind"], "*"),
            ms=6,
            color="k",
            mfc="k" if filled else "w",
            ls="none",
            zorder=5,
        )


#: Offsets (points) tried for a label, in order; a label that fits none is left out.
LABEL_OFFSETS = [(6, 11), (6, -15), (-6, 11), (-6, -15), (6, 25), (6, -29), (-6, 25), (-6, -29)]


def _label_special(ax, items: list[dict], renderer, unit: str) -> int:
    """Label the special points where the labels do not overlap each other, the markers of other
    points or the axes' edges (one label for a cluster of one kind); return how many were left out."""
    axbox = ax.get_window_extent(renderer)
    placed = []
    marks = []
    for it in items:
        px, py = ax.transData.transform((it["x"], it["y"]))
        marks.append((px - 4, py - 4, px + 4, py + 4))
    dropped = 0
    last: dict[str, float] = {}
    xmin, xmax = ax.get_xlim()
    for it in sorted(items, key=lambda i: i["x"]):
        if not np.isfinite(it["y"]):
            continue
        if abs(it["x"] - last.get(it["kind"], -np.inf)) <= 0.02 * (xmax - xmin):
            continue  # a cluster of one kind (e.g. a grazing pair 1e-8 apart): one label
        if it["interval"] is not None:
            x0, _, x1, _ = it["interval"]
            text = f"{SHORT.get(it['kind'], it['kind'])} in\n{_interval(x0, x1)}"
        else:
            text = f"{SHORT.get(it['kind'], it['kind'])}\n{it['x']:.5g}"
        ok = False
        for dx, dy in LABEL_OFFSETS:
            ann = ax.annotate(
                text,
                (it["x"], it["y"]),
                xytext=(dx, dy),
                textcoords="offset points",
                fontsize=7,
                va="center",
                ha="left" if dx > 0 else "right",
                zorder=6,
            )
            bb = ann.get_window_extent(renderer)
            box = (bb.x0 - 1, bb.y0 - 1, bb.x1 + 1, bb.y1 + 1)
            inside = bb.x0 >= axbox.x0 and bb.x1 <= axbox.x1 and bb.y0 >= axbox.y0 and bb.y1 <= axbox.y1
            if inside and not any(_overlap(box, o) for o in placed + marks):
                placed.append(box)
                last[it["kind"]] = it["x"]
                ok = True
                break
            ann.remove()
        dropped += not ok
    return dropped


def _overlap(a, b) -> bool:
    return a[0] < b[2] and b[0] < a[2] and a[1] < b[3] and b[1] < a[3]


def _draw_overlays(ax, overlays, grid, name: str, styles) -> None:
    for k, coords in enumerate(overlays.values()):
        if name in coords:
            st = styles[k % len(styles)]
            ax.plot(grid, coords[name], zorder=2, **st)


#: Styles of the linear references (dark to light grey), apart from the models' own overlays.
REFERENCE_STYLE = [
    dict(color="0.25", ls=(0, (1, 1.5)), lw=1.3),
    dict(color="0.5", ls=(0, (4, 2)), lw=1.1),
    dict(color="0.65", ls=(0, (6, 2, 1, 2)), lw=1.1),
]
#: Tick labels of a logarithmic axis that spans less than a few decades: 0.8, 2, 30 (not 2 x 10^0).
PLAIN = FuncFormatter(lambda v, _: f"{v:g}")
#: Colour of the windows shown zoomed, on the whole-range panel.
ZOOM_COLOUR = "C1"


def with_unit(value: float, unit: str) -> str:
    """``"0.5 N"`` (``"0.5"`` without a unit)."""
    return f"{value:g} {unit}" if unit else f"{value:g}"


def _interval(lo: float, hi: float) -> str:
    """``[lo, hi]`` with as many digits as it takes to tell the ends apart (up to 10)."""
    for digits in range(5, 11):
        a, b = f"{lo:.{digits}g}", f"{hi:.{digits}g}"
        if a != b:
            break
    return f"[{a}, {b}]"


def plot_frc(
    fr: FrequencyResponse,
    path: str | Path,
    *,
    overlays: dict | None = None,
    grid: np.ndarray | None = None,
    coordinates: list[str] | None = None,
    references: dict | None = None,
) -> Path:
    """Write the frequency-response figure as PNG.

    One row per coordinate: the whole range, then a zoom panel for each window of
    :func:`zoom_windows` (none where the whole range shows everything), all panels of a row on
    one amplitude scale (logarithmic where the amplitudes span more than a decade). Stable orbits
    solid, unstable dashed, neutral thin; special points marked on the curve and labelled where
    the labels fit (a bracketed one drawn as the interval in which it lies); the linear
    references and the model's overlays under the branches; units from the model.

    Parameters
    ----------
    fr : FrequencyResponse
    path : str or Path
    overlays : dict, optional
        ``{curve label: {coordinate: values on grid}}`` (e.g. from a ``hybrid.frc_overlays`` entry point).
    grid : ndarray, optional
        Values of the continued parameter of the overlays and references.
    coordinates : list of str, optional
        Coordinates to draw (default: the model's ``plot.displacements``, or those derived by
        :func:`hybrid.model.plot_hints.plot_hints`).
    references : dict, optional
        ``{curve label: {coordinate: values on grid}}``: the linear references
        (:func:`hybrid.model.linear.linear_response`), drawn in grey.

    Returns
    -------
    Path
    """
    system = fr.system
    overlays = overlays or {}
    references = references or {}
    coords = coordinates or list(plot_hints(system)["displacements"])
    zooms = zoom_windows(fr)
    lay = _Layout.of(fr, coords, zooms, references, overlays)
    fig, gs = lay.figure()
    renderer = fig.canvas.get_renderer()
    curves = (grid, references, overlays)
    dropped = 0
    for r, name in enumerate(coords):
        ax = fig.add_subplot(gs[r, 0])
        log, n = _full_panel(ax, fr, name, lay, curves, renderer)
        dropped += n
        for c, (window, letter) in enumerate(zip(zooms, lay.letters, strict=True), start=1):
            az = fig.add_subplot(gs[r, c])
            dropped += _zoom_panel(az, fr, name, lay, curves, window, letter, log, renderer)
    for ax in fig.axes[-lay.ncol :]:
        ax.set_xlabel(lay.xlab)
    handles = _legend_handles(fr, references, overlays, lay, dropped)
    fig.legend(handles=handles, loc="lower center", ncol=min(len(handles), 3), fontsize=8, frameon=False)
    fig.suptitle("\n".join(lay.head), fontsize=10, y=1.0 - 0.25 / lay.height, va="top")
    path = Path(path)
    fig.savefig(path, dpi=110)
    return path


@dataclass(frozen=True)
class _Layout:
    """The frequency-response figure's geometry and the texts it shares across panels."""

    par: str
    par_unit: str
    p_range: tuple[float, float]
    zooms: list
    letters: list[str]
    ncol: int
    n_rows: int
    width: float
    height: float
    top_in: float
    bottom_in: float
    head: list[str]
    xlab: str

    @classmethod
    def of(cls, fr: FrequencyResponse, coords: list[str], zooms: list, references: dict, overlays: dict):
        """The layout of ``fr``'s figure with rows ``coords`` and zoom windows ``zooms``."""
        import textwrap

        system = fr.system
        par = fr.parameter
        par_unit = unit_of(system, par)
        letters = [chr(ord("A") + k) for k in range(len(zooms))]
        ncol = 1 + len(zooms)
        width = max(4.2 * ncol + 1.0, 10.0)
        # the figure's title: the model, then the other parameters with their units, wrapped
        params = ", ".join(
            f"{k} = {with_unit(v, unit_of(system, k))}" for k, v in fr.params.items() if k != par
        )
        head = [f"{system.title or system.name}: frequency response (max |x| over a period)"]
        head += textwrap.wrap(params, width=int(width * 13))
        top_in = 0.3 + 0.2 * len(head) + 0.35  # the title's lines, then the first panel's title
        n_legend = (
            4 + len(references) + len(overlays) + len({sp.kind for b in fr.branches for sp in b.special})
        )
        n_legend += 1 + bool(zooms) + bool(fr.gaps)
        bottom_in = 0.75 + 0.19 * -(-n_legend // 3)  # the x label, then the legend's rows
        height = 3.4 * len(coords) + top_in + bottom_in
        xlab = f"{par} [{par_unit}]" if par_unit else par
        return cls(
            par,
            par_unit,
            fr.p_range,
            zooms,
            letters,
            ncol,
            len(coords),
            width,
            height,
            top_in,
            bottom_in,
            head,
            xlab,
        )

    def figure(self):
        """The figure and its grid of panels. A fixed layout (margins in inches): matplotlib's
        constrained layout measures every tick label once more and took 0.9 of the 1.7 s of this
        figure."""
        fig = _new_figure((self.width, self.height), layout=None)
        gs = fig.add_gridspec(
            self.n_rows,
            self.ncol,
            width_ratios=[1.3] + [1.0] * len(self.zooms),
            left=0.85 / self.width,
            right=1.0 - 0.25 / self.width,
            top=1.0 - self.top_in / self.height,
            bottom=self.bottom_in / self.height,
            wspace=0.28,
            hspace=0.45,
        )
        return fig, gs


def _curves_and_gaps(ax, fr: FrequencyResponse, name: str, curves: tuple, window: tuple[float, float]):
    """Branches, overlays and references, special points and gaps of coordinate ``name`` over
    ``window``; returns the branches' amplitudes there and the special points drawn."""
    grid, references, overlays = curves
    amps = _draw_branches(ax, fr, name, window)
    if grid is not None:
        _draw_overlays(ax, references, grid, name, REFERENCE_STYLE)
        _draw_overlays(ax, overlays, grid, name, OVERLAY_STYLE)
    items = _special_points(fr, name, window)
    _draw_special(ax, items)
    for a, b in fr.gaps:
        ax.axvspan(a, b, color="C3", alpha=0.15, lw=0, zorder=0)
    return amps, items


def _full_panel(
    ax, fr: FrequencyResponse, name: str, lay: _Layout, curves: tuple, renderer
) -> tuple[bool, int]:
    """The panel of the whole range for ``name``; returns (its amplitude axis is logarithmic,
    labels left out)."""
    lo, hi = lay.p_range
    unit = unit_of(fr.system, name)
    amps, items = _curves_and_gaps(ax, fr, name, curves, (lo, hi))
    pos = [a for a in amps if a > 0]
    log = bool(pos) and max(pos) > 10.0 * min(pos)  # one scale for the row: log where amplitudes span decades
    if log:
        ax.set_yscale("log")
        ax.set_ylim(min(pos) / 3.0, max(pos) * 5.0)
    elif amps:
        ax.set_ylim(0.0, 1.2 * max(amps) if max(amps) > 0 else 1.0)
    ax.set_xlim(lo, hi)
    for (a, b, _), letter in zip(lay.zooms, lay.letters, strict=True):
        ax.axvspan(a, b, color=ZOOM_COLOUR, alpha=0.18, lw=0.8, ec=ZOOM_COLOUR, zorder=0)
        ax.annotate(
            letter,
            (0.5 * (a + b), 1.0),
            xycoords=("data", "axes fraction"),
            xytext=(0, -2),
            textcoords="offset points",
            ha="center",
            va="top",
            fontsize=8,
            color=ZOOM_COLOUR,
            fontweight="bold",
            bbox=dict(boxstyle="round,pad=0.1", fc="w", ec="none", alpha=0.85),
            zorder=7,
        )
    ax.xaxis.set_major_locator(MaxNLocator(6))
    ax.ticklabel_format(axis="x", useOffset=False)
    ax.set_ylabel(f"max |{name}|" + (f" [{unit}]" if unit else ""))
    ax.set_title(
        f"{name}, {lay.par} {lo:.6g} to {hi:.6g}"
        + (f" {lay.par_unit}" if lay.par_unit else "")
        + (f" (zoomed: {', '.join(lay.letters)})" if lay.zooms else ""),
        fontsize=9,
        y=1.0,
    )
    ax.grid(alpha=0.3, which="both")
    return log, (_label_special(ax, items, renderer, lay.par_unit) if not lay.zooms else 0)


def _zoom_panel(
    az, fr, name: str, lay: _Layout, curves: tuple, window, letter: str, log: bool, renderer
) -> int:
    """The zoom panel ``letter`` on ``window`` ``(a, b, natural frequency or None)``; returns the
    labels left out."""
    a, b, w = window
    inside, zitems = _curves_and_gaps(az, fr, name, curves, (a, b))
    az.set_xlim(a, b)
    zpos = [v for v in inside if v > 0]
    if log:
        az.set_yscale("log")
        if zpos:
            az.set_ylim(min(zpos) / 1.5, max(zpos) * 1.5)
        if zpos and max(zpos) < 30 * min(zpos):  # under a decade or so: plain numbers
            az.yaxis.set_major_formatter(PLAIN)
            az.yaxis.set_minor_formatter(PLAIN)
    elif inside:
        az.set_ylim(0.0, 1.2 * max(inside) if max(inside) > 0 else 1.0)
    kinds = sorted({it["kind"] for it in zitems})
    what = ", ".join(SHORT.get(k, k) for k in kinds)
    if w is not None:
        az.axvline(w, color="0.5", lw=0.6, ls=":")
        what = (what + "; " if what else "") + f"natural frequency {w:.5g} (dotted)"
    az.set_title(
        f"{letter}: {name}, {lay.par} {a:.6g} to {b:.6g}"
        + (f" {lay.par_unit}" if lay.par_unit else "")
        + (f"\n{what}" if what else ""),
        fontsize=8.5,
        y=1.0,
    )
    az.xaxis.set_major_locator(MaxNLocator(5))
    az.ticklabel_format(axis="x", useOffset=False)
    az.grid(alpha=0.3, which="both")
    return _label_special(az, zitems, renderer, lay.par_unit)


def _legend_handles(
    fr: FrequencyResponse, references: dict, overlays: dict, lay: _Layout, dropped: int
) -> list:
    """The figure's legend: branch styles, curves, special points, intervals, zooms, gaps."""
    handles = [Line2D([], [], **STYLE[s], label=LABEL[s]) for s in STYLE]
    handles += [
        Line2D([], [], **REFERENCE_STYLE[k % len(REFERENCE_STYLE)], label=c) for k, c in enumerate(references)
    ]
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
    if any(sp.status == "bracketed" for b in fr.branches for sp in b.special):
        handles.append(
            Line2D([], [], color="0.2", lw=5.0, alpha=0.35, label="bracketed: the interval where it lies")
        )
    if lay.zooms:
        handles.append(Patch(color=ZOOM_COLOUR, alpha=0.18, label=f"zoomed ({', '.join(lay.letters)})"))
    if fr.gaps:
        handles.append(Patch(color="C3", alpha=0.15, label="no orbit computed"))
    if dropped:
        handles.append(
            Line2D(
                [],
                [],
                ls="none",
                label=f"{dropped} labels left out where they would overlap (see frc_special.csv)",
            )
        )
    return handles
