"""Figures of a trajectory, drawn with matplotlib's Agg canvas (no pyplot state, no display).

:func:`plot_trajectory` follows the manner of the paper's Figs. 5/6: the force
of the non-smooth element against time and against its relative velocity,
with the phases of the shaded modes (stick) marked, above the displacement
history. Which outputs to draw comes from the model's ``plot`` hints.
"""

from __future__ import annotations

from pathlib import Path

from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure

from ._trajectory import Trajectory

__all__ = ["plot_trajectory"]


def _label(traj: Trajectory, name: str) -> str:
    units = {v.name: v.unit for v in traj.system.variables}
    unit = units.get(name) or traj.system.plot.get("units", {}).get(name, "")
    return f"{name} [{unit}]" if unit else name


def plot_trajectory(traj: Trajectory, path: str | Path, *, last_periods: float = 4.0) -> Path:
    """Write the stick-slip figure of a trajectory as PNG.

    Parameters
    ----------
    traj : Trajectory
        Result of :func:`hybrid.simulate`.
    path : str or Path
        PNG file to write.
    last_periods : float
        Window of the force plots, in forcing periods at the end of the run
        (the whole run if the model has no period).

    Returns
    -------
    Path
    """
    system = traj.system
    hints = system.plot
    force = hints.get("force")
    vel = hints.get("velocity")
    disp = list(hints.get("displacements", ())) or [traj.names[0]]
    shade = set(hints.get("shade_modes", ()))
    period = system.period_value(traj.params)
    t = traj.t
    t_lo = max(traj.t_start, traj.t_final - last_periods * period) if period else traj.t_start
    win = t >= t_lo

    fig = Figure(figsize=(11, 7.5), layout="constrained")
    FigureCanvasAgg(fig)
    gs = fig.add_gridspec(2, 2)
    ax_w = fig.add_subplot(gs[1, 0])  # displacements in the window
    ax_x = fig.add_subplot(gs[1, 1])  # displacement history of the whole run
    if force:
        ax_t = fig.add_subplot(gs[0, 0])
        ax_v = fig.add_subplot(gs[0, 1])
        H = traj[force]
        ax_t.plot(t[win], H[win], color="C0", lw=1.2)
        ax_t.set_xlabel("t [s]")
        ax_t.set_ylabel(_label(traj, force))
        ax_t.set_title(
            f"{force} against time (last {last_periods:g} periods)" if period else f"{force} against time"
        )
        if vel:
            ax_v.plot(traj[vel][win], H[win], color="C0", lw=1.2)
            ax_v.set_xlabel(_label(traj, vel))
            ax_v.set_ylabel(_label(traj, force))
            ax_v.set_title(f"{force} against {vel} (same window; stick: {vel} = 0)")
            ax_v.axvline(0.0, color="0.6", lw=0.6)
        for ax in (ax_t, ax_v):
            ax.grid(alpha=0.3)
        shaded_any = False
        for t0, t1, mode in traj.mode_intervals():
            if mode in shade and t1 > t_lo:
                ax_t.axvspan(
                    max(t0, t_lo), t1, color="C2", alpha=0.15, lw=0, label=None if shaded_any else mode
                )
                shaded_any = True
        if shaded_any:
            ax_t.legend(loc="upper right", fontsize=8)
    # draw the first displacement last so that it stays visible on top of larger ones
    for k, name in reversed(list(enumerate(disp))):
        ax_w.plot(t[win], traj[name][win], lw=1.0, color=f"C{k}", label=_label(traj, name))
        ax_x.plot(t, traj[name], lw=0.6, color=f"C{k}", label=_label(traj, name))
    ax_w.set_title("displacements" + (f" (last {last_periods:g} periods)" if period else ""))
    ax_x.set_title("displacement history (whole run)")
    for ax in (ax_w, ax_x):
        ax.set_xlabel("t [s]")
        ax.set_ylabel("displacement")
        ax.grid(alpha=0.3)
        ax.legend(loc="upper left", fontsize=8)
    params = ", ".join(f"{k}={v:g}" for k, v in traj.params.items())
    fig.suptitle(f"{system.title or system.name}\n{params}", fontsize=10)
    path = Path(path)
    fig.savefig(path, dpi=110)
    return path
