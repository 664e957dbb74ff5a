"""The figures of [1], each a :class:`FigureSpec`: the jobs it needs and a builder of its data and plot.

``hybrid reproduce`` (:mod:`hybrid_models.reproduce`) runs the jobs of the figures asked for
(each job once, in parallel) and calls each builder with the results; the builder returns a
:class:`FigureResult`: the rows written to the figure's CSV, the key numbers written to its JSON
and to the report (``docs/reproduction.md``), the matplotlib figure, and a verdict computed from the numbers on
what the paper's text says the figure shows.

Figures: 3a, 3b (absorber) and 4a, 4b (isolator): structural-change limit against the stick
response (App. A); 5, 6: friction force of the steady periodic orbit; 7-10 and B1-B4: parameter
studies (:data:`hybrid_models.studies.STUDIES`); 11, 13: event-driven model against the averaging
model near both resonances; 12: peak of ``x1`` against ``R``, numerical and by averaging.

References
----------
.. [1] Aramendiz et al., "Sequential friction-spring dampers" (``shared/seed``).
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, field

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
from matplotlib.colors import LinearSegmentedColormap, LogNorm, Normalize  # noqa: E402
from matplotlib.ticker import MaxNLocator  # noqa: E402
from scipy.optimize import brentq  # noqa: E402

from . import jobs as J  # noqa: E402
from .averaging import breakaway_force, characteristic_amplitudes, physical_amplitudes, rho_min  # noqa: E402
from .averaging import frequency_response as averaged_response  # noqa: E402
from .linear import (  # noqa: E402
    limit_amplitude,
    slip_eigenfrequencies,
    stick_amplitudes,
    stick_eigenfrequencies,
)
from .studies import STUDIES, WINDOWS, ZOOM, Curve, study_params  # noqa: E402

__all__ = ["FigureResult", "FigureSpec", "FIGURES", "BLUE_RED", "intersections"]

#: The paper's colour scale of the studies, blue (first value) to red (last).
BLUE_RED = LinearSegmentedColormap.from_list("blue_red", ["#0000ff", "#ff0000"])
#: Figure size [in] and resolution [dpi] of the PNGs.
SIZE, DPI = (10.0, 4.2), 100


@dataclass
class FigureResult:
    """A built figure.

    Attributes
    ----------
    id : str
        The paper's figure id (``"7"``, ``"B1"``, ...).
    title : str
    rows : list of dict
        The plotted data (the CSV beside the PNG).
    numbers : dict
        Key numbers (JSON-serialisable).
    figure : matplotlib.figure.Figure
    claim : str
        What the paper's text says the figure shows.
    verdict : str
        Whether the numbers show it.
    integrator : str
        ``"exact"``, ``"ida"`` or ``"none"`` (closed forms only).
    ida_check : dict or None
        Peaks of x1 of up to three curves by the exact integrator, the same orbits by IDA
        (rtol 1e-10), and the largest relative difference.
    """

    id: str
    title: str
    rows: list
    numbers: dict
    figure: object
    claim: str
    verdict: str
    integrator: str
    ida_check: dict | None = None


@dataclass(frozen=True)
class FigureSpec:
    """How to make one figure.

    Attributes
    ----------
    id : str
    title : str
    jobs : callable
        ``jobs(integrator) -> list of Job``: the computations it needs.
    checks : callable
        ``checks(results, integrator) -> list of Job``: the IDA cross-checks, given the results.
    build : callable
        ``build(results, integrator) -> FigureResult``.
    """

    id: str
    title: str
    jobs: Callable = field(repr=False)
    checks: Callable = field(repr=False)
    build: Callable = field(repr=False)


def _none(*_args) -> list:
    return []


# --------------------------------------------------------------------------------------------
# Figs. 3 and 4: structural-change limit (App. A)
# --------------------------------------------------------------------------------------------

#: Frequency grid [rad/s] of Figs. 3-4 (avoids the antiresonance 1 rad/s, where both curves vanish).
LIMIT_GRID = np.linspace(0.02, 2.0, 19_801) + 1.234e-5


def intersections(model: str, params: dict, grid: np.ndarray = LIMIT_GRID) -> list[float]:
    """Frequencies [rad/s] where the stick amplitude ``|A1|`` equals the limit ``A_L`` (offset 0).

    Sign changes of ``log(|A1|/A_L)`` on ``grid``, refined by Brent's method.

    Parameters
    ----------
    model : str
    params : dict
    grid : ndarray, optional

    Returns
    -------
    list of float
    """

    def g(w):
        a1, _ = stick_amplitudes(params, w)
        return np.log(np.abs(a1) / limit_amplitude(model, params, w))

    v = g(grid)
    out = []
    for k in np.flatnonzero(np.isfinite(v[:-1]) & np.isfinite(v[1:]) & (np.sign(v[:-1]) != np.sign(v[1:]))):
        out.append(float(brentq(lambda w: float(g(np.asarray(w))), grid[k], grid[k + 1], xtol=1e-14)))
    return out


def _limit_figure(fig_id: str, model: str, preset: str, claim: str, expect: int | bool) -> FigureSpec:
    """Figs. 3a/3b (``expect``: the number of intersections) and 4a/4b (``expect``: whether both slip
    eigenfrequencies lie in linear ranges, the paper's condition for a bounded response)."""
    from . import BUILTIN

    def build(results, integrator):
        p = dict(BUILTIN[model]().preset(preset))
        w = LIMIT_GRID
        a1, _ = stick_amplitudes(p, w)
        lim = limit_amplitude(model, p, w)
        cross = intersections(model, p)
        linear = np.abs(a1) <= lim
        runs = int(np.sum(np.diff(linear.astype(int)) == 1) + (1 if linear[0] else 0))
        slip = slip_eigenfrequencies(model, p)
        slip_linear = [bool(np.abs(stick_amplitudes(p, s)[0]) <= limit_amplitude(model, p, s)) for s in slip]
        fig, ax = plt.subplots(figsize=(6.4, 4.2))
        ax.semilogy(w, np.abs(a1), "k-", lw=1.2, label="stick response |A1| (Eq. A.1)")
        ax.semilogy(w, lim, "b--", lw=1.2, label=f"limit A_L ({'Eq. 5' if model == 'absorber' else 'Eq. 9'})")
        ax.fill_between(w, 1e-4, 1e4, where=~linear, color="0.85", label="nonlinear range (|A1| > A_L)")
        for s in slip:
            ax.axvline(s, color="r", ls=":", lw=1)
        ax.plot([], [], "r:", label="slip eigenfrequencies")
        ax.plot(
            cross, [float(limit_amplitude(model, p, c)) for c in cross], "ko", ms=5, label="intersections"
        )
        ax.set(
            xlabel="Omega [rad/s]",
            ylabel="amplitude of x1 [m]",
            ylim=(1e-2, 1e2),
            xlim=(0, 2),
            title=f"Fig. {fig_id}: {model}, R = {p['R']:g} N, F = {p['F']:g} N, c3 = {p['c3']:g} N/m",
        )
        ax.legend(fontsize=7, loc="upper right")
        fig.tight_layout()
        rows = [
            {"Omega": float(x), "A1_stick": float(y), "A_L": float(z), "linear": bool(q)}
            for x, y, z, q in zip(w[::10], np.abs(a1)[::10], lim[::10], linear[::10], strict=True)
        ]
        numbers = {
            "parameters": p,
            "intersections_rad_s": cross,
            "n_intersections": len(cross),
            "n_linear_ranges": runs,
            "stick_eigenfrequencies_rad_s": list(stick_eigenfrequencies(p)),
            "slip_eigenfrequencies_rad_s": list(slip),
            "slip_eigenfrequency_in_linear_range": slip_linear,
        }
        if isinstance(expect, bool):
            ok = all(slip_linear) == expect
            what = f"slip eigenfrequencies {', '.join(f'{s:.4f}' for s in slip)} rad/s in a linear range: {slip_linear}"
        else:
            ok = len(cross) == expect
            what = f"{len(cross)} intersections (expected {expect})"
        verdict = (
            f"{'Confirmed' if ok else 'NOT confirmed'}: {what}; {len(cross)} intersections at "
            f"{', '.join(f'{c:.4f}' for c in cross)} rad/s, {runs} linear ranges."
        )
        return FigureResult(fig_id, fig.axes[0].get_title(), rows, numbers, fig, claim, verdict, "none")

    return FigureSpec(fig_id, f"structural-change limit, {model} preset {preset}", _none, _none, build)


# --------------------------------------------------------------------------------------------
# Figs. 5 and 6: friction force of the steady periodic orbit
# --------------------------------------------------------------------------------------------


def _orbit_figure(fig_id: str, model: str) -> FigureSpec:
    def job(integrator):
        return J.orbit(model, study_params(model), integrator)

    def build(results, integrator):
        o = results[job(integrator)]
        check = results.get(job("ida"))
        p = study_params(model)
        t, H, v = o["t"], o["H"], o["v_rel"]
        fig, (a, b) = plt.subplots(1, 2, figsize=SIZE)
        a.plot(t, H, "b-")
        a.axhline(p["R"], color="0.6", ls=":")
        a.axhline(-p["R"], color="0.6", ls=":")
        a.set(xlabel="t [s] (one period)", ylabel="friction force H [N]")
        b.plot(v, H, "b-")
        b.set(xlabel="relative velocity v_rel [m/s]", ylabel="friction force H [N]")
        fig.suptitle(f"Fig. {fig_id}: {model}, steady periodic orbit at Omega = {p['Omega']:g} rad/s")
        fig.tight_layout()
        seq = o["mode_sequence"]
        if len(seq) > 1 and seq[0] == seq[-1]:  # the sequence is cyclic: first and last are one phase
            seq = seq[:-1]
        stick = sum(1 for m in seq if m == "stick")
        slipn = len(seq) - stick
        rows = [
            {"t": float(x), "H": float(y), "v_rel": float(z), "mode": m}
            for x, y, z, m in zip(t, H, v, o["mode"], strict=True)
        ]
        jumps = float(np.max(np.abs(np.diff(H)))) if H.size > 1 else 0.0
        numbers = {
            "parameters": p,
            "period_s": o["period"],
            "stability": o["stability"],
            "mode_sequence": seq,
            "stick_phases": stick,
            "slip_phases": slipn,
            "mode_fractions": o["mode_fractions"],
            "max_abs_H_over_R": float(np.max(np.abs(H)) / p["R"]),
            "largest_step_of_H_between_samples_over_R": jumps / p["R"],
            "amplitude_x1_m": o["amplitude"]["x1"],
        }
        ida = None
        if check is not None:
            d = abs(check["amplitude"]["x1"] - o["amplitude"]["x1"]) / o["amplitude"]["x1"]
            ida = {
                "curves": [
                    {
                        "what": "x1 amplitude of the orbit",
                        "exact": o["amplitude"]["x1"],
                        "ida": check["amplitude"]["x1"],
                    }
                ],
                "max_relative_difference": d,
            }
        ok = stick == 2 and slipn == 2 and numbers["largest_step_of_H_between_samples_over_R"] < 0.2
        verdict = (
            f"{'Confirmed' if ok else 'NOT confirmed'}: {stick} stick and {slipn} slip phases per period "
            f"({' -> '.join(seq)}), |H| reaches {numbers['max_abs_H_over_R']:.4f} R, largest step of H "
            f"between samples {numbers['largest_step_of_H_between_samples_over_R']:.3f} R."
        )
        claim = "two stick phases and two slip phases per period, with continuous transitions"
        return FigureResult(
            fig_id, fig._suptitle.get_text(), rows, numbers, fig, claim, verdict, integrator, ida
        )

    def checks(results, integrator):
        return [job("ida")] if integrator == "exact" else []

    return FigureSpec(
        fig_id, f"friction force of the steady orbit, {model}", lambda i: [job(i)], checks, build
    )


# --------------------------------------------------------------------------------------------
# Figs. 7-10, B1-B4: parameter studies
# --------------------------------------------------------------------------------------------


def _study_jobs(key: str, integrator: str) -> list[J.Job]:
    st = STUDIES[key]
    return [
        J.curve(st.model, study_params(st.model, **{st.parameter: v}), WINDOWS[m], integrator)
        for m in (1, 2)
        for v in st.values
    ]


def _checked_curves(jobs: list[J.Job]) -> list[J.Job]:
    """Three curves of a list: the first, one in the middle of the second half, the last."""
    n = len(jobs)
    return [jobs[0], jobs[(3 * n) // 4], jobs[-1]] if n >= 3 else list(jobs)


def _ida_checks(curve_jobs: list[J.Job], results: dict, integrator: str) -> list[J.Job]:
    if integrator != "exact":
        return []
    out = []
    for j in _checked_curves(curve_jobs):
        c = results[j]
        if math.isfinite(c.peak_omega):
            out.append(J.ida_peak(j.model, dict(j.params), c.peak_omega, c.peak_start))
    return out


def _ida_summary(curve_jobs: list[J.Job], results: dict, integrator: str) -> dict | None:
    if integrator != "exact":
        return None
    rows = []
    for j in _checked_curves(curve_jobs):
        c = results[j]
        k = J.ida_peak(j.model, dict(j.params), c.peak_omega, c.peak_start)
        if k not in results:
            continue
        w, x = results[k]
        rows.append(
            {
                "model": j.model,
                "window": list(j.window),
                "R": c.params["R"],
                "c3": c.params["c3"],
                "exact_peak_x1": c.peak_x1,
                "exact_omega": c.peak_omega,
                "ida_peak_x1": x,
                "ida_omega": w,
                "relative_difference": abs(x - c.peak_x1) / c.peak_x1,
            }
        )
    return {
        "curves": rows,
        "max_relative_difference": max((r["relative_difference"] for r in rows), default=None),
    }


def _draw_curve(ax, c: Curve, coord: str, color, lw: float = 0.8) -> None:
    y = getattr(c, coord)
    for b in np.unique(c.branch):
        idx = np.flatnonzero(c.branch == b)
        start = 0
        for k in range(1, idx.size + 1):
            if k == idx.size or c.stable[idx[k]] != c.stable[idx[start]]:
                seg = idx[start : min(k + 1, idx.size)]
                ax.plot(c.omega[seg], y[seg], "-" if c.stable[idx[start]] else "--", color=color, lw=lw)
                start = k


def _mark_gaps(ax, c: Curve, seen: dict) -> None:
    for lo, hi, why in c.gaps:
        if why == "unbounded":
            ax.axvspan(lo, hi, color="0.7", alpha=0.6)
            ax.axvline(0.5 * (lo + hi), color="k", ls=":", lw=1.0)
            seen["unbounded"] = True
        else:
            seen["gap"] = True


def _study_rows(st, curves: dict) -> list[dict]:
    rows = []
    for (mode, value), c in curves.items():
        for k in range(c.omega.size):
            rows.append(
                {
                    "resonance": mode,
                    st.parameter: value,
                    "branch": int(c.branch[k]),
                    "Omega": float(c.omega[k]),
                    "x1": float(c.x1[k]),
                    "x2": float(c.x2[k]),
                    "stable": bool(c.stable[k]),
                }
            )
    return rows


def _study_figure(key: str, coord: str) -> FigureSpec:
    st = STUDIES[key]
    fig_id = st.figures[0 if coord == "x1" else 1]
    unit = "N" if st.parameter == "R" else "N/m"

    def build(results, integrator):
        cj = _study_jobs(key, integrator)
        curves = {}
        for j in cj:
            mode = 1 if j.window == WINDOWS[1] else 2
            curves[(mode, dict(j.params)[st.parameter])] = results[j]
        vals = np.asarray(st.values)
        norm = LogNorm(vals.min(), vals.max()) if st.parameter == "c3" else Normalize(vals.min(), vals.max())
        fig, axes = plt.subplots(1, 2, figsize=SIZE)
        seen: dict = {}
        for ax, mode in zip(axes, (1, 2), strict=True):
            for v in st.values:
                c = curves[(mode, v)]
                _draw_curve(ax, c, coord, BLUE_RED(norm(v)))
                _mark_gaps(ax, c, seen)
            ax.set(xlabel="Omega [rad/s]", ylabel=f"amplitude of {coord} [m]", xlim=ZOOM[mode])
            ax.xaxis.set_major_locator(MaxNLocator(5))
            ax.set_title(f"resonance {mode}", fontsize=9)
        for ax, mode in zip(axes, (1, 2), strict=True):
            _clip_outliers(ax, [getattr(curves[(mode, v)], f"peak_{coord}") for v in st.values], st)
        axes[0].plot([], [], "k-", label="stable (or neutral: stuck)")
        axes[0].plot([], [], "k--", label="unstable")
        if seen.get("unbounded"):
            axes[0].fill_between([], [], color="0.7", label="no bounded orbit: response grows without bound")
        if seen.get("gap"):
            axes[0].plot([], [], " ", label="(a band where continuation did not converge)")
        axes[0].legend(fontsize=7, loc="upper left")
        sm = plt.cm.ScalarMappable(norm=norm, cmap=BLUE_RED)
        fig.colorbar(sm, ax=axes, label=f"{st.parameter} [{unit}]", fraction=0.03, pad=0.02)
        fig.suptitle(f"Fig. {fig_id}: {st.model}, {st.caption}")
        peaks = {m: [float(getattr(curves[(m, v)], f"peak_{coord}")) for v in st.values] for m in (1, 2)}
        unbounded = [{"resonance": m, st.parameter: v} for (m, v), c in curves.items() if not c.bounded]
        folded = [{"resonance": m, st.parameter: v} for (m, v), c in curves.items() if c.turns]
        base = study_params(st.model)
        numbers = {
            "study": st.caption,
            "parameter": st.parameter,
            "values": list(st.values),
            "windows_rad_s": {str(m): list(WINDOWS[m]) for m in (1, 2)},
            "drawn_rad_s": {str(m): list(ZOOM[m]) for m in (1, 2)},
            f"peak_{coord}_resonance_1_m": peaks[1],
            f"peak_{coord}_resonance_2_m": peaks[2],
            "curves_unbounded": unbounded,
            "curves_with_a_fold": folded,
            "unstable_orbits": int(sum(int(np.sum(~c.stable)) for c in curves.values())),
            "stick_eigenfrequencies_rad_s": list(stick_eigenfrequencies(base)),
            "slip_eigenfrequencies_rad_s": {
                f"{st.parameter}={v:g}": list(slip_eigenfrequencies(st.model, {**base, st.parameter: v}))
                for v in (st.values[0], st.values[-1])
            },
            "compute_seconds_sum": float(sum(c.seconds for c in curves.values())),
        }
        claim, verdict = _study_verdict(st, coord, peaks, numbers, results, integrator)
        ida = _ida_summary(cj, results, integrator)
        return FigureResult(
            fig_id,
            fig._suptitle.get_text(),
            _study_rows(st, curves),
            numbers,
            fig,
            claim,
            verdict,
            integrator,
            ida,
        )

    def jobs(integrator):
        out = _study_jobs(key, integrator)
        if st.parameter == "R":
            out += [J.optimum(st.model, m, integrator) for m in (1, 2)]
        return out

    def checks(results, integrator):
        return _ida_checks(_study_jobs(key, integrator), results, integrator)

    return FigureSpec(fig_id, f"parameter study {key}, {coord}", jobs, checks, build)


def _clip_outliers(ax, peaks: list[float], st) -> None:
    """Limit the y-axis to 2.5 x the median peak and name the curves whose peak it cuts off."""
    top = 2.5 * float(np.median(peaks))
    cut = [(v, p) for v, p in zip(st.values, peaks, strict=True) if p > top]
    if not cut:
        return
    ax.set_ylim(0, top)
    text = "\n".join(f"{st.parameter} = {v:g}: peak {p:.3g} m (cut off)" for v, p in cut[:4])
    ax.text(0.98, 0.98, text, transform=ax.transAxes, ha="right", va="top", fontsize=7)


def _interior_min(vals, peaks) -> tuple[float, bool]:
    k = int(np.argmin(peaks))
    return float(vals[k]), 0 < k < len(peaks) - 1


def _study_verdict(st, coord, peaks, numbers, results, integrator) -> tuple[str, str]:
    vals = list(st.values)
    if st.parameter == "R":
        opts = {m: results[J.optimum(st.model, m, integrator)] for m in (1, 2)}
        numbers["optimum"] = {
            str(m): {
                "R_numerical_N": o.R,
                "peak_x1_m": o.peak_x1,
                "R_averaging_N": o.R_averaging,
                "relative_difference": o.relative_difference,
            }
            for m, o in opts.items()
        }
        mins = {m: _interior_min(vals, peaks[m]) for m in (1, 2)}
        numbers["grid_minimum"] = {str(m): {st.parameter: v, "interior": i} for m, (v, i) in mins.items()}
        ratio = [b / a for a, b in zip(peaks[1], peaks[2], strict=True)]
        numbers[f"peak_ratio_resonance_2_over_1_{coord}"] = ratio
        if coord == "x2":  # App. B: no claim of its own beyond showing x2 for the same studies
            claim = f"x2 (App. B) behaves as x1 in Fig. {st.figures[0]}: an optimal R at each resonance"
            ok = mins[1][1] and mins[2][1]
            verdict = (
                f"{'Confirmed' if ok else 'NOT confirmed'}: peak of x2 smallest at R = {mins[1][0]:g} N "
                f"(resonance 1) and {mins[2][0]:g} N (resonance 2) on the grid, inside the range: "
                f"{mins[1][1]} / {mins[2][1]}; peak ratio (resonance 2/1) {min(ratio):.3f} to {max(ratio):.3f}."
            )
        elif st.model == "absorber":
            claim = "an optimal R exists; the second resonance's peak is lower than the first's"
            ok1 = mins[1][1]
            lower = sum(r < 1 for r in ratio)
            verdict = (
                f"{'Confirmed' if ok1 and lower == len(ratio) else 'Partly confirmed'}: peak of {coord} at "
                f"resonance 1 smallest at R = {mins[1][0]:g} N on the grid (interior: {ok1}; optimiser "
                f"{opts[1].R:.5g} N); second peak lower than the first for {lower} of {len(ratio)} R."
            )
        else:
            claim = "both resonances damped equally; an optimal R exists"
            spread = max(abs(r - 1) for r in ratio)
            verdict = (
                f"{'Confirmed' if spread < 0.1 and mins[1][1] else 'NOT confirmed'}: peak ratio "
                f"(resonance 2/1) of {coord} between {min(ratio):.3f} and {max(ratio):.3f}; smallest peak at "
                f"R = {mins[1][0]:g} / {mins[2][0]:g} N on the grid (optimiser {opts[1].R:.5g} / {opts[2].R:.5g} N)."
            )
        return claim, verdict
    claim = "amplitudes fall with decreasing c3 (no optimal c3: the smallest c3 gives the smallest peaks)"
    parts, ok = [], True
    for m in (1, 2):
        pk = np.asarray(peaks[m])
        rising = int(np.sum(np.diff(pk) > 0))
        parts.append(
            f"resonance {m}: peak {pk[0]:.4g} m at c3 = {vals[0]:g} to {pk[-1]:.4g} m at c3 = {vals[-1]:g} N/m, "
            f"rising with c3 in {rising} of {pk.size - 1} steps"
        )
        ok = ok and pk[0] < pk[-1] and int(np.argmin(pk)) == 0
    numbers["smallest_peak_at_smallest_c3"] = ok
    return claim, ("Confirmed" if ok else "NOT confirmed") + ": " + "; ".join(parts) + "."


# --------------------------------------------------------------------------------------------
# Figs. 11-13: numerical against averaging
# --------------------------------------------------------------------------------------------


def _comparison_figure(fig_id: str, model: str) -> FigureSpec:
    def cjobs(integrator):
        return [J.curve(model, study_params(model), WINDOWS[m], integrator) for m in (1, 2)]

    def build(results, integrator):
        p = study_params(model)
        fig, axes = plt.subplots(1, 2, figsize=SIZE)
        rows, per = [], {}
        for ax, mode, j in zip(axes, (1, 2), cjobs(integrator), strict=True):
            c = results[j]
            fr = averaged_response(model, p, mode, n=600)
            _draw_curve(ax, c, "x1", "b", lw=1.2)
            for om in (fr.Omega_lo, fr.Omega_hi):
                ax.plot(om, fr.x1, "r--", lw=1.2)
            x1_avg = float(
                physical_amplitudes(model, p, mode, characteristic_amplitudes(model, p, mode).A_max)[0]
            )
            per[str(mode)] = {
                "peak_x1_numerical_m": c.peak_x1,
                "peak_omega_numerical_rad_s": c.peak_omega,
                "peak_x1_averaging_m": x1_avg,
                "relative_error_averaging": (x1_avg - c.peak_x1) / c.peak_x1,
                "peak_x2_numerical_m": c.peak_x2,
            }
            ax.set(xlabel="Omega [rad/s]", ylabel="amplitude of x1 [m]", xlim=ZOOM[mode])
            ax.xaxis.set_major_locator(MaxNLocator(5))
            ax.set_title(f"resonance {mode}", fontsize=9)
            for k in range(c.omega.size):
                rows.append(
                    {
                        "resonance": mode,
                        "source": "event-driven",
                        "Omega": float(c.omega[k]),
                        "x1": float(c.x1[k]),
                        "stable": bool(c.stable[k]),
                    }
                )
            for om, branch in ((fr.Omega_lo, "lo"), (fr.Omega_hi, "hi")):
                for w, x, s in zip(
                    om, fr.x1, fr.stability_lo if branch == "lo" else fr.stability_hi, strict=True
                ):
                    if np.isfinite(w):
                        rows.append(
                            {
                                "resonance": mode,
                                "source": f"averaging {branch}",
                                "Omega": float(w),
                                "x1": float(x),
                                "stable": s != "unstable",
                            }
                        )
        axes[0].plot([], [], "b-", label="event-driven (continuation)")
        axes[0].plot([], [], "r--", label="averaging (Eqs. 32/38, 47/48)")
        axes[0].legend(fontsize=7, loc="upper left")
        fig.suptitle(
            f"Fig. {fig_id}: {model}, R = {p['R']:g} N, c3 = {p['c3']:g} N/m: numerical vs averaging"
        )
        fig.tight_layout()
        errs = [abs(v["relative_error_averaging"]) for v in per.values()]
        numbers = {"parameters": p, "resonances": per, "max_abs_relative_error_averaging": max(errs)}
        claim = "the averaging model agrees with the numerical curves near both resonances (acceptable discrepancy)"
        verdict = (
            f"{'Confirmed' if max(errs) < 0.05 else 'NOT confirmed'}: averaging peak of x1 off by "
            + ", ".join(
                f"{100 * v['relative_error_averaging']:+.3f} % (resonance {m})" for m, v in per.items()
            )
            + "."
        )
        ida = _ida_summary(cjobs(integrator), results, integrator)
        return FigureResult(
            fig_id, fig._suptitle.get_text(), rows, numbers, fig, claim, verdict, integrator, ida
        )

    def checks(results, integrator):
        return _ida_checks(cjobs(integrator), results, integrator)

    return FigureSpec(fig_id, f"numerical vs averaging, {model}", cjobs, checks, build)


def _fig12() -> FigureSpec:
    st = STUDIES["absorber-R"]

    def cjobs(integrator):
        return _study_jobs("absorber-R", integrator)

    def jobs(integrator):
        return (
            cjobs(integrator)
            + [J.optimum("absorber", m, integrator) for m in (1, 2)]
            + [J.bounded_limit("absorber", m, integrator) for m in (1, 2)]
        )

    def build(results, integrator):
        base = study_params("absorber")
        Rs = np.linspace(0.2, 0.85, 400)
        fig, ax = plt.subplots(figsize=(7.0, 4.6))
        rows, numbers = [], {"resonances": {}}
        for mode, col in ((1, "b"), (2, "g")):
            peaks = [
                results[J.curve("absorber", study_params("absorber", R=v), WINDOWS[mode], integrator)].peak_x1
                for v in st.values
            ]
            ax.plot(st.values, peaks, col + "o", ms=4, label=f"event-driven, resonance {mode}")
            avg = []
            for R in Rs:
                a = characteristic_amplitudes("absorber", {**base, "R": float(R)}, mode).A_max
                avg.append(
                    float(physical_amplitudes("absorber", base, mode, a)[0]) if math.isfinite(a) else math.nan
                )
            ax.plot(Rs, avg, col + "-", lw=1, label=f"averaging, resonance {mode}")
            o = results[J.optimum("absorber", mode, integrator)]
            lim = results[J.bounded_limit("absorber", mode, integrator)]
            ax.axvline(o.R, color=col, ls=":", lw=1)
            ax.axvline(o.R_averaging, color=col, ls="-.", lw=0.8)
            for v, pk in zip(st.values, peaks, strict=True):
                rows.append({"resonance": mode, "source": "event-driven", "R": v, "peak_x1": pk})
            for R, a in zip(Rs, avg, strict=True):
                rows.append({"resonance": mode, "source": "averaging", "R": float(R), "peak_x1": a})
            numbers["resonances"][str(mode)] = {
                "R_opt_numerical_N": o.R,
                "peak_x1_at_R_opt_numerical_m": o.peak_x1,
                "R_opt_averaging_N": o.R_averaging,
                "R_opt_relative_difference": o.relative_difference,
                "R_min_numerical_bracket_N": [lim["R_unbounded"], lim["R_bounded"]],
                "R_min_averaging_N": lim["R_averaging"],
                "optimiser_curves": o.evaluations,
            }
        ax.plot([], [], "k:", label="optimal R, numerical")
        ax.plot([], [], "k-.", label="optimal R, averaging (Eqs. 37, 44)")
        ax.set(xlabel="R [N]", ylabel="peak amplitude of x1 [m]", ylim=(0, 15), xlim=(Rs[0], Rs[-1]))
        ax.legend(fontsize=7)
        ax.set_title("Fig. 12: absorber, maximum amplitude of x1 against R")
        fig.tight_layout()
        r = numbers["resonances"]
        claim = "two optimal friction values, one per resonance; numerical and averaging maxima agree"
        ok = all(abs(v["R_opt_relative_difference"]) < 0.05 for v in r.values())
        verdict = (
            f"{'Confirmed' if ok else 'NOT confirmed'}: optimal R numerical / averaging: {r['1']['R_opt_numerical_N']:.5g} / {r['1']['R_opt_averaging_N']:.5g} N "
            f"({100 * r['1']['R_opt_relative_difference']:+.2f} %) at resonance 1, "
            f"{r['2']['R_opt_numerical_N']:.5g} / {r['2']['R_opt_averaging_N']:.5g} N "
            f"({100 * r['2']['R_opt_relative_difference']:+.2f} %) at resonance 2."
        )
        ida = _ida_summary(cjobs(integrator), results, integrator)
        return FigureResult("12", ax.get_title(), rows, numbers, fig, claim, verdict, integrator, ida)

    def checks(results, integrator):
        return _ida_checks(cjobs(integrator), results, integrator)

    return FigureSpec("12", "maximum amplitude against R, absorber", jobs, checks, build)


def _isolator_design(spec: FigureSpec) -> FigureSpec:
    """Fig. 9 with the isolator's smallest bounded R (the optimum is already among its jobs)."""

    def jobs(integrator):
        return spec.jobs(integrator) + [J.bounded_limit("isolator", m, integrator) for m in (1, 2)]

    def build(results, integrator):
        res = spec.build(results, integrator)
        res.numbers["R_min"] = {
            str(m): {
                "numerical_bracket_N": [
                    results[J.bounded_limit("isolator", m, integrator)]["R_unbounded"],
                    results[J.bounded_limit("isolator", m, integrator)]["R_bounded"],
                ],
                "averaging_N": breakaway_force(
                    "isolator", study_params("isolator"), rho_min("isolator", study_params("isolator"), m)
                ),
            }
            for m in (1, 2)
        }
        return res

    return FigureSpec(spec.id, spec.title, jobs, spec.checks, build)


_CLAIM3 = "the limit curve meets the stick response {} times ({} linear ranges)"

#: Every figure of the paper, by id, in the paper's order.
FIGURES: dict[str, FigureSpec] = {
    "3a": _limit_figure("3a", "absorber", "fig3a", _CLAIM3.format("four", "three"), 4),
    "3b": _limit_figure("3b", "absorber", "fig3b", _CLAIM3.format("two", "two"), 2),
    "4a": _limit_figure(
        "4a", "isolator", "fig4a", "bounded case: the slip eigenfrequencies lie in linear ranges", True
    ),
    "4b": _limit_figure(
        "4b", "isolator", "fig4b", "unbounded case: a slip eigenfrequency lies in a nonlinear range", False
    ),
    "5": _orbit_figure("5", "absorber"),
    "6": _orbit_figure("6", "isolator"),
    "7": _study_figure("absorber-R", "x1"),
    "8": _study_figure("absorber-c3", "x1"),
    "9": _isolator_design(_study_figure("isolator-R", "x1")),
    "10": _study_figure("isolator-c3", "x1"),
    "11": _comparison_figure("11", "absorber"),
    "12": _fig12(),
    "13": _comparison_figure("13", "isolator"),
    "B1": _study_figure("absorber-R", "x2"),
    "B2": _study_figure("absorber-c3", "x2"),
    "B3": _study_figure("isolator-R", "x2"),
    "B4": _study_figure("isolator-c3", "x2"),
}
