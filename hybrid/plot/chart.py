"""Design charts of a sweep: the peak amplitude over the parameter plane and along one parameter.

Data first: :func:`chart_rows` is one row per grid point (the parameter values, the status, the
peak, where it lies and its stability), written as ``chart.csv``; the figures draw those rows.

* :func:`plot_plane` (two parameters): filled contours of the peak over the plane, the lowest
  bounded peak marked, the points where the response is unbounded shaded and labelled, points
  without a value (failed, time limit, missing) crossed out.
* :func:`plot_lines`: the peak over one parameter, one line per value of the other (if any);
  unbounded points drawn as triangles at the top of the axes.

Peaks spanning more than a factor :data:`LOG_SPAN` are drawn on a log scale.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from ..core.errors import InputError
from ..engine.io import to_json, write_rows_csv
from ..studies.sweep import SweepResult
from .trajectory import _new_figure

__all__ = ["chart_rows", "optimum", "plot_plane", "plot_lines", "write_charts"]

#: Peaks spanning more than this factor are drawn on a log scale (colours of the plane, y of the lines).
LOG_SPAN = 20.0


def optimum(res: SweepResult) -> dict | None:
    """The design optimum of a sweep: the point with the lowest peak among the ``bounded`` ones.

    Parameters
    ----------
    res : SweepResult
        A sweep read back (:func:`hybrid.load_sweep`) or returned by :func:`hybrid.sweep`.

    Returns
    -------
    dict or None
        The point's result (``values``, ``peak`` [the coordinate's unit], ``peak_at`` [rad/s],
        ...), or None where no point is ``bounded`` (an unbounded point has no peak).
    """
    ok = [r for r in res.points.values() if r["status"] == "bounded" and r.get("peak") is not None]
    return min(ok, key=lambda r: r["peak"]) if ok else None


def chart_rows(res: SweepResult) -> list[dict]:
    """One dict per grid point, in grid order (first axis slowest).

    Keys: the axes' parameters, ``status`` (``"missing"`` for a point without a file),
    ``peak`` [the coordinate's unit] (empty unless the curve has orbits), ``peak_at`` [rad/s],
    ``peak_stability``, ``optimum`` (1 at the lowest bounded peak), ``seconds``, ``reason`` (a
    code, :data:`hybrid.core.status.POINT_REASONS`) and ``message`` (the same in words).
    """
    axes = res.axes
    best = optimum(res)
    rows = []
    for index in np.ndindex(*res.shape):
        row = {a.name: a.values[i] for a, i in zip(axes, index, strict=True)}
        r = res.points.get(tuple(index))
        if r is None:
            row.update(status="missing")
        else:
            row.update(
                status=r["status"],
                peak=r.get("peak"),
                peak_at=r.get("peak_at"),
                peak_stability=r.get("peak_stability"),
                optimum=int(r is best),
                seconds=r.get("seconds"),
                reason=r.get("reason", ""),
                message=r.get("message", ""),
            )
        rows.append(row)
    return rows


def _order(res: SweepResult, x: str | None) -> tuple[int, int | None]:
    """Indices of the horizontal axis and the other one (None for a one-parameter sweep)."""
    names = [a.name for a in res.axes]
    if len(names) > 2:
        raise InputError(f"charts draw sweeps of one or two parameters; this one has {len(names)}: {names}")
    if x is None:
        x = names[0]
    if x not in names:
        raise InputError(f"`--x {x}`: the sweep's parameters are {', '.join(names)}")
    ix = names.index(x)
    return ix, (1 - ix if len(names) == 2 else None)


def _grid(res: SweepResult, ix: int, iy: int | None) -> tuple[np.ndarray, np.ndarray]:
    """Peak and status code over the plane, shape (ny, nx) (one parameter: shape (nx,)).

    Codes: 0 a value, 1 unbounded, 2 no value (failed, time limit, missing, no orbit), 3 a value
    from an incomplete curve (a lower bound of the peak).
    """
    shape = res.shape
    peak = np.full((shape[ix],) if iy is None else (shape[iy], shape[ix]), np.nan)
    code = np.full(peak.shape, 2)
    for index, r in res.points.items():
        at = (index[ix],) if iy is None else (index[iy], index[ix])
        if r["status"] == "unbounded":
            code[at] = 1
        elif r.get("peak") is not None and r["status"] in ("bounded", "incomplete"):
            peak[at], code[at] = r["peak"], 0 if r["status"] == "bounded" else 3
    return peak, code


def _method_name(options: dict) -> str:
    """The integration method's name in a manifest's options (``integrator`` in folders written
    before methods were objects, issue 29)."""
    method = options.get("method")
    return method.get("name", "?") if isinstance(method, dict) else str(options.get("integrator", "?"))


def _title(res: SweepResult) -> str:
    m = res.manifest
    lo, hi = m["p_range"]
    fixed = ", ".join(f"{k}={v:g}" for k, v in m["params"].items() if k != m["parameter"])
    return (
        f"{m['model']}: peak of {m['coordinate']} (half peak-to-peak) for {m['parameter']} in "
        f"[{lo:.4g}, {hi:.4g}]\n{fixed}; integrator {_method_name(m['options'])}"
    )


def plot_plane(res: SweepResult, path: str | Path, x: str | None = None) -> Path:
    """Contours of the peak over the plane of a two-parameter sweep (PNG).

    Parameters
    ----------
    res : SweepResult
    path : str or Path
    x : str, optional
        The parameter on the horizontal axis (default the first axis).

    Returns
    -------
    Path
    """
    from matplotlib.colors import LogNorm
    from matplotlib.patches import Patch

    ix, iy = _order(res, x)
    if iy is None:
        raise InputError("a plane needs a sweep of two parameters")
    ax_x, ax_y = res.axes[ix], res.axes[iy]
    X, Y = np.meshgrid(ax_x.values, ax_y.values)
    peak, code = _grid(res, ix, iy)
    fig = _new_figure((7.5, 5.6))  # (no pyplot: the user's backend is left alone)
    ax = fig.add_subplot()
    handles = []
    finite = peak[np.isfinite(peak)]
    if finite.size >= 2 and finite.max() > finite.min():
        lo, hi = float(finite.min()), float(finite.max())
        log = lo > 0 and hi > LOG_SPAN * lo
        levels = np.geomspace(lo, hi, 15) if log else np.linspace(lo, hi, 15)
        masked = np.ma.masked_invalid(peak)
        cs = ax.contourf(X, Y, masked, levels=levels, cmap="viridis", norm=LogNorm(lo, hi) if log else None)
        ax.contour(X, Y, masked, levels=levels[::2], colors="k", linewidths=0.4, alpha=0.5)
        bar = fig.colorbar(
            cs, ax=ax, label=_label(res, res.manifest["coordinate"], "peak of "), format="%.3g"
        )
        bar.set_ticks(levels[::2])
        bar.minorticks_off()
    if (code == 1).any():
        ax.contourf(X, Y, (code == 1).astype(float), levels=[0.5, 1.5], colors="none", hatches=["///"])
        ax.scatter(X[code == 1], Y[code == 1], marker="^", color="crimson", s=18, zorder=3)
        handles.append(Patch(facecolor="none", edgecolor="crimson", hatch="///", label="unbounded response"))
        jy, jx = np.argwhere(code == 1)[len(np.argwhere(code == 1)) // 2]
        ax.annotate(
            "unbounded",
            (X[jy, jx], Y[jy, jx]),
            color="crimson",
            fontsize=10,
            weight="bold",
            xytext=(6, 6),
            textcoords="offset points",
        )
    if (code == 2).any():
        h = ax.scatter(
            X[code == 2],
            Y[code == 2],
            marker="x",
            color="0.3",
            s=30,
            zorder=3,
            label="no value (failed, time limit or missing)",
        )
        handles.append(h)
    if (code == 3).any():
        h = ax.scatter(
            X[code == 3],
            Y[code == 3],
            marker="o",
            facecolor="none",
            edgecolor="k",
            s=40,
            zorder=3,
            label="curve with gaps (incomplete): the peak is a lower bound",
        )
        handles.append(h)
    ax.scatter(X[code == 0], Y[code == 0], marker=".", color="w", s=6, zorder=2)
    best = optimum(res)
    if best is not None:
        bx, by = best["values"][ax_x.name], best["values"][ax_y.name]
        h = ax.scatter(
            [bx],
            [by],
            marker="*",
            s=260,
            color="gold",
            edgecolor="k",
            zorder=5,
            clip_on=False,
            label=f"lowest peak {best['peak']:.4g} at {ax_x.name}={bx:.4g}, {ax_y.name}={by:.4g}",
        )
        handles.append(h)
    for a, setx in ((ax_x, ax.set_xscale), (ax_y, ax.set_yscale)):
        if a.spacing == "log":
            setx("log")
    ax.set_xlabel(_label(res, ax_x.name))
    ax.set_ylabel(_label(res, ax_y.name))
    ax.set_title(_title(res), fontsize=9)
    if handles:
        ax.legend(handles=handles, loc="upper center", bbox_to_anchor=(0.5, -0.12), fontsize=8, ncol=1)
    fig.savefig(path, dpi=130)
    return Path(path)


def _label(res: SweepResult, name: str, prefix: str = "") -> str:
    """``prefix name [unit]`` (the unit from the manifest, where the sweep recorded one)."""
    unit = res.manifest.get("units", {}).get(name)
    return f"{prefix}{name} [{unit}]" if unit else f"{prefix}{name}"


def plot_lines(res: SweepResult, path: str | Path, x: str | None = None) -> Path:
    """The peak over one parameter, one line per value of the other (PNG).

    Parameters
    ----------
    res : SweepResult
    path : str or Path
    x : str, optional
        The parameter on the horizontal axis (default the first axis).

    Returns
    -------
    Path
    """
    from matplotlib import colormaps

    ix, iy = _order(res, x)
    ax_x = res.axes[ix]
    peak, code = _grid(res, ix, iy)
    if iy is None:
        series = [(None, peak, code)]
    else:
        series = [(v, peak[j], code[j]) for j, v in enumerate(res.axes[iy].values)]
    fig = _new_figure((7.5, 5.0))
    ax = fig.add_subplot()
    cmap = colormaps["plasma"]
    xs = np.asarray(ax_x.values)
    top = np.nanmax(peak) if np.isfinite(peak).any() else 1.0
    for k, (v, p, c) in enumerate(series):
        color = cmap(k / max(1, len(series) - 1) * 0.9)
        label = None if v is None else f"{res.axes[iy].name} = {v:.4g}"
        ax.plot(xs, p, "o-", ms=3, color=color, label=label)
        if (c == 3).any():
            ax.plot(xs[c == 3], p[c == 3], "o", ms=8, mfc="none", mec=color)
        if (c == 1).any():
            ax.plot(xs[c == 1], np.full((c == 1).sum(), 1.05 * top), "^", color=color, ms=7, clip_on=False)
    if (code == 1).any():
        ax.text(
            0.01,
            0.99,
            "triangles at the top: unbounded response",
            transform=ax.transAxes,
            va="top",
            fontsize=8,
            color="crimson",
        )
    best = optimum(res)
    if best is not None:
        ax.plot(
            [best["values"][ax_x.name]],
            [best["peak"]],
            "*",
            ms=16,
            color="gold",
            mec="k",
            clip_on=False,
            zorder=5,
            label=f"lowest peak {best['peak']:.4g}",
        )
    if ax_x.spacing == "log":
        ax.set_xscale("log")
    finite = peak[np.isfinite(peak)]
    if finite.size and finite.min() > 0 and finite.max() > LOG_SPAN * finite.min():
        from matplotlib.ticker import FormatStrFormatter

        ax.set_yscale("log")
        ax.yaxis.set_major_formatter(FormatStrFormatter("%g"))
        ax.yaxis.set_minor_formatter(FormatStrFormatter("%g"))
    ax.set_xlabel(_label(res, ax_x.name))
    ax.set_ylabel(_label(res, res.manifest["coordinate"], "peak of "))
    ax.set_title(_title(res), fontsize=9)
    ax.grid(alpha=0.3)
    ax.legend(fontsize=7, ncol=2 if len(series) > 6 else 1)
    fig.savefig(path, dpi=130)
    return Path(path)


def write_charts(res: SweepResult, out: str | Path, x: str | None = None) -> tuple[list[Path], list[str]]:
    """``chart.csv``, ``chart.json``, ``chart_lines.png`` and (two parameters) ``chart_plane.png``.

    Returns
    -------
    files : list of Path
    lines : list of str
        A summary: the points per status and the lowest bounded peak.
    """
    out = Path(out)
    _order(res, x)  # one or two parameters, a known --x: before writing anything
    rows = chart_rows(res)
    files = [write_rows_csv(rows, out / "chart.csv")]
    best = optimum(res)
    counts = res.counts()
    summary = {
        "model": res.manifest["model"],
        "coordinate": res.manifest["coordinate"],
        "p_range": res.manifest["p_range"],
        "counts": counts,
        "optimum": None
        if best is None
        else {k: best[k] for k in ("values", "peak", "peak_at", "peak_stability")},
        "unbounded": [r["values"] for r in res.points.values() if r["status"] == "unbounded"],
    }
    (out / "chart.json").write_text(to_json(summary) + "\n")
    files.append(out / "chart.json")
    files.append(plot_lines(res, out / "chart_lines.png", x))
    if len(res.axes) == 2:
        files.append(plot_plane(res, out / "chart_plane.png", x))
    lines = [f"{res.manifest['model']}: " + ", ".join(f"{v} {k}" for k, v in counts.items() if v)]
    if best is not None:
        at = ", ".join(f"{k} = {v:.6g}" for k, v in best["values"].items())
        lines.append(f"lowest bounded peak of {res.manifest['coordinate']}: {best['peak']:.6g} at {at}")
    else:
        lines.append("no bounded point")
    if summary["unbounded"]:
        lines.append(f"unbounded response at {len(summary['unbounded'])} points")
    return files, lines
