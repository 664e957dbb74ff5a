"""Figures of a trajectory and of a periodic orbit, drawn with matplotlib's Agg canvas (no pyplot state).

:func:`plot_trajectory` follows the manner of the paper's Figs. 5/6: the force
of the non-smooth element against time and against its relative velocity,
with the phases of the modes named in the hints' ``shade_modes`` shaded, above the displacement
history. :func:`plot_orbit` draws the same for one period of a periodic
orbit, with its Floquet multipliers. Which outputs to draw comes from the
model's ``plot`` hints, completed by :func:`hybrid.model.plot_hints.plot_hints`
(derived from the model where it gives none); a model without a switching
quantity to draw gets the displacement panels only, never an empty axis.
"""

from __future__ import annotations

from fnmatch import fnmatchcase
from pathlib import Path

import numpy as np
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure

from ..engine.record import Envelope
from ..engine.trajectory import Trajectory
from ..model.plot_hints import plot_hints, unit_of

__all__ = ["plot_trajectory", "plot_orbit", "trajectory_figure", "orbit_figure"]


def _label(traj: Trajectory, name: str) -> str:
    units = {v.name: v.unit for v in traj.system.variables}
    unit = units.get(name) or plot_hints(traj.system).get("units", {}).get(name, "")
    return f"{name} [{unit}]" if unit else name


def _parameter_line(system, params) -> str:
    """``m1 = 1 kg, c1 = 1 N/m, ...``: the parameter values with their units, wrapped to two lines at most."""
    import textwrap

    def one(k: str, v: float) -> str:
        u = unit_of(system, k)
        return f"{k} = {v:g}" + (f" {u}" if u else "")

    lines = textwrap.wrap(", ".join(one(k, v) for k, v in params.items()), 150)
    return "\n".join(lines[:2]) + (" ..." if len(lines) > 2 else "")


def _new_figure(figsize: tuple[float, float], layout: str | None = "constrained") -> Figure:
    fig = Figure(figsize=figsize, layout=layout)
    FigureCanvasAgg(fig)
    return fig


def _shade_pattern(mode: str, shade: set) -> str | None:
    """The entry of ``shade`` that names ``mode``: the mode itself, or a pattern with ``*`` that matches
    it (``motion|stick|*``: every mode of a system with components whose first component sticks; mode
    names hold no ``*``)."""
    if mode in shade:
        return mode
    return next((p for p in shade if "*" in p and fnmatchcase(mode, p)), None)


def _shade_modes(ax, traj: Trajectory, shade: set, t_lo: float = -float("inf")) -> bool:
    """Shade the intervals of the modes in ``shade`` (names or patterns, see :func:`_shade_pattern`)
    from ``t_lo`` on; True if any was shaded."""
    shaded_any = False
    for t0, t1, mode in traj.mode_intervals():
        hit = _shade_pattern(mode, shade) if t1 > t_lo else None
        if hit is not None:
            ax.axvspan(max(t0, t_lo), t1, color="C2", alpha=0.15, lw=0, label=None if shaded_any else hit)
            shaded_any = True
    return shaded_any


def plot_trajectory(
    traj: Trajectory, path: str | Path, *, last_periods: float = 4.0, history: Envelope | None = None
) -> Path:
    """Write the figure of a trajectory as PNG (see :func:`trajectory_figure`).

    Parameters
    ----------
    traj : Trajectory
        As :func:`trajectory_figure`.
    path : str or Path
        PNG file to write.
    last_periods : float
        As :func:`trajectory_figure`.
    history : Envelope, optional
        As :func:`trajectory_figure`.

    Returns
    -------
    Path
    """
    path = Path(path)
    trajectory_figure(traj, last_periods=last_periods, history=history).savefig(path, dpi=110)
    return path


def trajectory_figure(
    traj: Trajectory, *, last_periods: float = 4.0, history: Envelope | None = None
) -> Figure:
    """The figure of a trajectory: the switching force against time and velocity, the displacements.

    Parameters
    ----------
    traj : Trajectory
        Result of :func:`hybrid.simulate`; the windowed panels draw its
        samples (a streamed run needs to have kept the window).
    last_periods : float
        Window of the force plots, in forcing periods at the end of the run
        (the whole run if the model has no period).
    history : Envelope, optional
        Min/max envelope of the displacements over the whole run (recorded
        while a streamed run went on), drawn in the whole-run panel instead of
        the trajectory's samples: as the line through the extrema, or, with
        more than 8 samples per bucket, as the band between them (rendering a
        dense zigzag takes memory growing with its density).

    Returns
    -------
    matplotlib.figure.Figure
    """
    system = traj.system
    hints = plot_hints(system)
    force = hints.get("force")
    vel = hints.get("velocity")
    disp = list(hints["displacements"])
    shade = set(hints["shade_modes"])
    period = system.period_value(traj.params)
    t = traj.t
    t_lo = max(traj.t_start, traj.t_final - last_periods * period) if period else traj.t_start
    win = t >= t_lo

    # without a switching quantity to draw, the displacement panels take the whole figure
    fig = _new_figure((11, 7.5) if force else (11, 4.2))
    gs = fig.add_gridspec(2 if force else 1, 2)
    ax_w = fig.add_subplot(gs[-1, 0])  # displacements in the window
    ax_x = fig.add_subplot(gs[-1, 1])  # displacement history of the whole run
    if force:
        ax_t = fig.add_subplot(gs[0, :] if not vel else gs[0, 0])
        H = traj[force]
        ax_t.plot(t[win], H[win], color="C0", lw=1.2)
        ax_t.set_xlabel("t [s]")
        ax_t.set_ylabel(_label(traj, force))
        ax_t.set_title(
            f"{force} against time (last {last_periods:g} periods)" if period else f"{force} against time"
        )
        ax_t.grid(alpha=0.3)
        if vel:
            ax_v = fig.add_subplot(gs[0, 1])
            ax_v.plot(traj[vel][win], H[win], color="C0", lw=1.2)
            ax_v.set_xlabel(_label(traj, vel))
            ax_v.set_ylabel(_label(traj, force))
            ax_v.set_title(f"{force} against {vel} (same window)")
            ax_v.axvline(0.0, color="0.6", lw=0.6)
            ax_v.grid(alpha=0.3)
        if _shade_modes(ax_t, traj, shade, t_lo):
            ax_t.legend(loc="upper right", fontsize=8)
    # draw the first displacement last so that it stays visible on top of larger ones
    for k, name in reversed(list(enumerate(disp))):
        ax_w.plot(t[win], traj[name][win], lw=1.0, color=f"C{k}", label=_label(traj, name))
        if history is None:
            ax_x.plot(t, traj[name], lw=0.6, color=f"C{k}", label=_label(traj, name))
        elif history.count < 8 * history.buckets:  # a few samples per bucket: the line through the extrema
            ax_x.plot(*history.series(name), lw=0.6, color=f"C{k}", label=_label(traj, name))
        else:  # dense: the band between the extrema (the same picture, drawn in constant memory)
            ax_x.fill_between(*history.bounds(name), color=f"C{k}", lw=0.6)
            ax_x.plot([], [], lw=0.6, color=f"C{k}", label=_label(traj, name))
    ax_w.set_title("displacements" + (f" (last {last_periods:g} periods)" if period else ""))
    ax_x.set_title("displacement history (whole run)")
    for ax in (ax_w, ax_x):
        ax.set_xlabel("t [s]")
        ax.set_ylabel("displacement")
        ax.grid(alpha=0.3)
        ax.legend(loc="upper left", fontsize=8)
    params = _parameter_line(system, traj.params)
    fig.suptitle(f"{system.title or system.name}\n{params}", fontsize=10)
    return fig


def plot_orbit(orbit, path: str | Path) -> Path:
    """Write the figure of one period of a periodic orbit as PNG (see :func:`orbit_figure`).

    Parameters
    ----------
    orbit : PeriodicOrbit
        A converged result of :func:`hybrid.periodic_orbit` (it has a trajectory).
    path : str or Path
        PNG file to write.

    Returns
    -------
    Path
    """
    path = Path(path)
    orbit_figure(orbit).savefig(path, dpi=110)
    return path


def orbit_figure(orbit) -> Figure:
    """The figure of one period of a periodic orbit.

    Panels: the force of the non-smooth element against time and against its
    relative velocity (if the model's ``plot`` hints name them), the
    displacements against time (phases of the ``shade_modes`` shaded), and
    the multipliers in the complex plane with the unit circle.

    Parameters
    ----------
    orbit : PeriodicOrbit
        A converged result of :func:`hybrid.periodic_orbit` (it has a trajectory).

    Returns
    -------
    matplotlib.figure.Figure
    """
    traj = orbit.trajectory
    system = orbit.system
    hints = plot_hints(system)
    force = hints.get("force")
    vel = hints.get("velocity")
    disp = list(hints["displacements"])
    shade = set(hints["shade_modes"])
    t = traj.t

    fig = _new_figure((11, 7.5) if force else (11, 4.2))
    gs = fig.add_gridspec(2 if force else 1, 2)
    ax_d = fig.add_subplot(gs[-1, 0])
    ax_m = fig.add_subplot(gs[-1, 1])
    if force:
        ax_t = fig.add_subplot(gs[0, :] if not vel else gs[0, 0], sharex=ax_d)
        H = traj[force]
        ax_t.plot(t, H, color="C0", lw=1.2)
        ax_t.set_ylabel(_label(traj, force))
        ax_t.set_title(f"{force} over one period")
        ax_t.grid(alpha=0.3)
        if _shade_modes(ax_t, traj, shade):
            ax_t.legend(loc="upper right", fontsize=8)
        if vel:
            ax_v = fig.add_subplot(gs[0, 1])
            ax_v.plot(traj[vel], H, color="C0", lw=1.2)
            ax_v.axvline(0.0, color="0.6", lw=0.6)
            ax_v.set_xlabel(_label(traj, vel))
            ax_v.set_ylabel(_label(traj, force))
            ax_v.set_title(f"{force} against {vel}")
            ax_v.grid(alpha=0.3)
    for k, name in reversed(list(enumerate(disp))):
        amp = orbit.amplitude.get(name)
        label = _label(traj, name) + (f", max |{name}| = {amp:.4g}" if amp is not None else "")
        ax_d.plot(t, traj[name], lw=1.2, color=f"C{k}", label=label)
    shaded = _shade_modes(ax_d, traj, shade)
    ax_d.set_xlabel("t [s]")
    ax_d.set_ylabel("displacement")
    ax_d.set_title(
        "displacements over one period" + (f" (shaded: {', '.join(sorted(shade))})" if shaded else "")
    )
    ax_d.set_xlim(t[0], t[-1])
    ax_d.grid(alpha=0.3)
    ax_d.legend(loc="best", fontsize=8, framealpha=0.9)

    # Multipliers in the complex plane.
    phi = np.linspace(0.0, 2.0 * np.pi, 361)
    ax_m.plot(np.cos(phi), np.sin(phi), color="0.6", lw=0.8)
    styles = {
        "floquet": dict(marker="o", color="C3", label="Floquet"),
        "neutral": dict(marker="s", color="C0", label="neutral (family of orbits)"),
        "structural": dict(marker="x", color="0.4", label="structural (slave variable)"),
    }
    for kind, st in styles.items():
        mu = np.array(
            [m for m, k in zip(orbit.multipliers, orbit.multiplier_kinds, strict=True) if k == kind]
        )
        if mu.size:
            ax_m.plot(mu.real, mu.imag, ls="none", ms=7, mfc="none", mew=1.5, **st)
    fl = np.abs(orbit.floquet_multipliers)
    n_family = sum(1 for k in orbit.multiplier_kinds if k == "neutral")
    extra = "; 1 from the family" * bool(n_family) + (
        f"; largest {'other ' * bool(n_family)}|mu| = {fl.max():.6g}" if fl.size else ""
    )
    ax_m.set_title(f"multipliers: {orbit.stability}{extra}", fontsize=9)
    ax_m.set_xlabel("Re mu")
    ax_m.set_ylabel("Im mu")
    ax_m.set_aspect("equal", adjustable="datalim")
    ax_m.axhline(0.0, color="0.8", lw=0.6)
    ax_m.axvline(0.0, color="0.8", lw=0.6)
    ax_m.grid(alpha=0.3)
    ax_m.legend(loc="upper right", fontsize=8, framealpha=0.9)

    params = _parameter_line(orbit.system, orbit.params)
    fig.suptitle(
        f"{system.title or system.name}: periodic orbit, T = {orbit.period:.6g} s, "
        f"{orbit.transitions_per_period} switches per period\n{params}",
        fontsize=10,
    )
    return fig
