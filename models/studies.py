"""Parameter studies of Sec. 3 of [1] (Figs. 7-10, B1-B4) and the design values of Sec. 4.

One frequency-response curve of the event-driven model near one resonance is a :class:`Curve`,
computed by :func:`resonance_curve` (continuation with :func:`hybrid.frequency_response`, the
peak refined by Brent's method on periodic orbits). A :class:`Study` is the family of curves of
one figure pair (x1 in the main text, x2 in App. B). The design values are

* :func:`optimal_friction`: the breakaway force ``R`` [N] minimising the peak of ``x1`` near one
  resonance (bounded Brent on the peak of the continued branch), for comparison with
  ``rho_opt`` of :mod:`hybrid_models.averaging` (Eqs. (37), (44), (51));
* :func:`smallest_bounded_friction`: the smallest ``R`` with a bounded response near one
  resonance, bracketed by bisection, for comparison with ``rho_min`` (Eqs. (35), (43), (D.14)).

Parameters are the models' preset dicts (``m1, m2`` [kg], ``c1, c2, c3`` [N/m], ``R, F`` [N],
``Omega`` [rad/s]). Amplitudes are half the peak-to-peak excursion over the period [m]
(:attr:`hybrid.PeriodicOrbit.half_peak_to_peak`): the oscillation amplitude of the paper's
figures and of the averaging model, independent of the static offset of the friction element.
(``max |x|`` includes that offset, which is free for orbits that stick throughout, so a
continuation that drifts along such a family would show a spurious peak in it.)

References
----------
.. [1] Aramendiz et al., "Sequential friction-spring dampers" (``shared/seed``).
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np
from scipy.optimize import minimize_scalar

import hybrid

from . import BUILTIN
from .averaging import breakaway_force, rho_min, rho_opt
from .linear import slip_eigenfrequencies

__all__ = [
    "WINDOWS",
    "ZOOM",
    "CONTINUATION",
    "Curve",
    "Study",
    "STUDIES",
    "Optimum",
    "solver_options",
    "resonance_curve",
    "refine_peak",
    "study_params",
    "numerical_peak",
    "optimal_friction",
    "smallest_bounded_friction",
    "ida_peak",
]

#: Frequency windows [rad/s] of the continuation around the first and second resonance (stick
#: eigenfrequencies 0.8543 and 1.1705 rad/s). They start where the response is the unique linear
#: stick response: a branch started nearer the peak may start on another orbit (the isolator
#: with c3 = 0.1 N/m has a second branch of orbits of about 12 m there).
WINDOWS = {1: (0.80, 0.90), 2: (1.10, 1.25)}
#: The part of each window drawn (every peak of the studies lies inside).
ZOOM = {1: (0.845, 0.862), 2: (1.16, 1.18)}

#: A gap is a band of unbounded growth if a branch bordering it stopped as ``"unbounded"``, or
#: if it lies within this relative distance of a slip eigenfrequency (where first-order
#: averaging puts the unbounded peak, backbone of the slip system) ...
UNBOUNDED_NEAR_SLIP = 1e-3
#: ... with an amplitude at its edge over this many times the curve's median amplitude.
UNBOUNDED_GROWTH = 20.0

#: Continuation settings of the studies: special points are not located (only the curve and its
#: stability are drawn), the step may turn by 0.3 rad (the peak is refined separately).
CONTINUATION = hybrid.ContinuationOptions(
    locate=False, max_angle=0.3, ds=0.05, samples_per_period=32, transient_periods=5
)

#: Tolerances of the IDA cross-check (``SolverOptions(method=hybrid.IDA(rtol=1e-10))``, absolute 1e-12).
IDA_RTOL, IDA_ATOL = 1e-10, 1e-12


def solver_options(integrator: str) -> hybrid.SolverOptions:
    """Tolerances of every run: ``exact`` as the library default, ``ida`` with ``rtol = 1e-10``.

    Parameters
    ----------
    integrator : {"exact", "ida"}

    Returns
    -------
    hybrid.SolverOptions
    """
    if integrator == "ida":
        return hybrid.SolverOptions(method=hybrid.IDA(rtol=IDA_RTOL, atol=IDA_ATOL))
    return hybrid.SolverOptions(method=hybrid.method_named(integrator))


@dataclass
class Curve:
    """One frequency-response curve of the event-driven model near one resonance.

    Attributes
    ----------
    model : str
        ``"absorber"`` or ``"isolator"``.
    params : dict
        Parameter values (``Omega`` is varied over ``window``).
    window : (float, float)
        Frequency range [rad/s].
    omega : ndarray, shape (n,)
        Frequencies of the continued orbits [rad/s], branch after branch.
    x1, x2 : ndarray, shape (n,)
        Amplitudes (half peak-to-peak) [m].
    stable : ndarray of bool, shape (n,)
        Orbits not unstable: Floquet-stable, or neutral (a stuck orbit: a member of a family with
        a multiplier 1, as the linear stick response is).
    branch : ndarray of int, shape (n,)
        Branch index of each orbit.
    gaps : list of (float, float, str)
        Frequency bands [rad/s] without an orbit and why: ``"unbounded"`` (a branch bordering it
        grew without bound, or the band lies at a slip eigenfrequency with amplitudes at its edge
        over ``UNBOUNDED_GROWTH`` times the curve's median: the response grows without bound
        there) or ``"not converged"``.
    peak_omega, peak_x1, peak_x2 : float
        The maximum of ``x1`` (refined by :func:`refine_peak`) [rad/s, m, m], and the largest
        ``x2`` on the curve [m] (the largest continued point; refined only if asked).
    peak_start : tuple
        ``(t0, mode0, x0)`` of the orbit at the peak of ``x1`` (a start for Newton there).
    integrator : str
        ``"exact"`` or ``"ida"``.
    seconds : float
        Wall time of the computation [s].
    """

    model: str
    params: dict
    window: tuple
    omega: np.ndarray
    x1: np.ndarray
    x2: np.ndarray
    stable: np.ndarray
    branch: np.ndarray
    gaps: list = field(default_factory=list)
    peak_omega: float = math.nan
    peak_start: tuple = ()
    peak_x1: float = math.nan
    peak_x2: float = math.nan
    integrator: str = "exact"
    seconds: float = 0.0

    @property
    def turns(self) -> int:
        """Turning points (folds) of the branches: where ``Omega`` reverses along a branch."""
        n = 0
        for b in np.unique(self.branch):
            d = np.diff(self.omega[self.branch == b])
            d = d[d != 0]
            n += int(np.sum(np.sign(d[1:]) != np.sign(d[:-1])))
        return n

    @property
    def bounded(self) -> bool:
        """No band of the window where the response grows without bound."""
        return not any(why == "unbounded" for _, _, why in self.gaps)


def _gap_reasons(
    fr: hybrid.FrequencyResponse, slip: tuple[float, ...], typical: float
) -> list[tuple[float, float, str]]:
    out = []
    for lo, hi in fr.gaps:
        why = "not converged"
        near = any(abs(0.5 * (lo + hi) - w) <= UNBOUNDED_NEAR_SLIP * w for w in slip)
        for b in fr.branches:
            if not b.points:
                continue
            ends = (float(np.min(b.values)), float(np.max(b.values)))
            touches = math.isclose(ends[1], lo, rel_tol=0, abs_tol=1e-12) or math.isclose(
                ends[0], hi, rel_tol=0, abs_tol=1e-12
            )
            if not touches:
                continue
            edge = b.points[int(np.argmin(np.abs(b.values - (lo if ends[1] <= lo + 1e-12 else hi))))]
            if b.reason == "unbounded" or (
                near and edge.half_peak_to_peak["x1"] > UNBOUNDED_GROWTH * typical
            ):
                why = "unbounded"
        out.append((float(lo), float(hi), why))
    return out


def refine_peak(
    system: hybrid.HybridSystem,
    params: dict,
    orbits: list,
    k: int,
    coordinate: str,
    options: hybrid.SolverOptions,
) -> tuple[float, float, tuple]:
    """Maximum of ``amplitude[coordinate]`` near the orbit ``k`` of a branch, by bounded Brent.

    The amplitude is maximised over ``Omega`` between the neighbours ``k - 1`` and ``k + 1``;
    each evaluation is :func:`hybrid.periodic_orbit` started (without transient) from the nearest
    orbit of the branch.

    Parameters
    ----------
    system : hybrid.HybridSystem
    params : dict
        Parameter values (``Omega`` replaced).
    orbits : list of hybrid.PeriodicOrbit
        The orbits of one branch, in branch order.
    k : int
        Index of the largest computed amplitude.
    coordinate : str
        ``"x1"`` or ``"x2"``.
    options : hybrid.SolverOptions

    Returns
    -------
    omega, amplitude : float
        [rad/s], [m]. The computed orbit ``k`` if no neighbour brackets it or Newton fails.
    start : tuple
        ``(t0, mode0, x0)`` of that orbit: a start for Newton at ``omega``.
    """

    def state(o) -> tuple:
        return (float(o.t0), str(o.mode0), tuple(float(v) for v in o.x0))

    best = (
        float(orbits[k].params["Omega"]),
        float(orbits[k].half_peak_to_peak[coordinate]),
        state(orbits[k]),
    )
    if k == 0 or k == len(orbits) - 1:
        return best
    om = [float(o.params["Omega"]) for o in orbits]
    lo, hi = sorted((om[k - 1], om[k + 1]))
    found = {}

    def neg(w: float) -> float:
        guess = orbits[int(np.argmin(np.abs(np.asarray(om) - w)))]
        o = hybrid.periodic_orbit(
            system,
            {**params, "Omega": w},
            x0=guess.x0,
            mode0=guess.mode0,
            t0=guess.t0,
            options=options,
            settings=hybrid.ShootingOptions(transient_periods=0, samples_per_period=64),
        )
        if not o.converged:
            return -best[1]
        found[w] = o
        return -float(o.half_peak_to_peak[coordinate])

    res = minimize_scalar(neg, bounds=(lo, hi), method="bounded", options={"xatol": 1e-7 * hi})
    w = float(res.x)
    if w in found and -res.fun >= best[1]:
        return w, float(-res.fun), state(found[w])
    return best


def resonance_curve(
    model: str,
    params: dict,
    window: tuple[float, float],
    integrator: str = "exact",
    refine_x2: bool = False,
) -> Curve:
    """The frequency-response curve of the event-driven model over ``window``, its peak refined.

    Parameters
    ----------
    model : str
        ``"absorber"`` or ``"isolator"``.
    params : dict
        All parameter values [SI].
    window : (float, float)
        Frequency range [rad/s].
    integrator : {"exact", "ida"}, optional
        See :func:`solver_options`.
    refine_x2 : bool, optional
        Refine the peak of ``x2`` too (else it is the largest of the continued points).

    Returns
    -------
    Curve
    """
    import time

    t0 = time.perf_counter()
    system = BUILTIN[model]()
    options = solver_options(integrator)
    fr = hybrid.frequency_response(system, params, window, options=options, settings=CONTINUATION)
    om, x1, x2, st, br = [], [], [], [], []
    for j, b in enumerate(fr.branches):
        for o in b.points:
            om.append(float(o.params["Omega"]))
            x1.append(float(o.half_peak_to_peak["x1"]))
            x2.append(float(o.half_peak_to_peak["x2"]))
            st.append(o.stability != "unstable")
            br.append(j)
    x1a = np.asarray(x1)
    typical = float(np.median(x1a)) if x1a.size else math.nan
    curve = Curve(
        model,
        dict(params),
        tuple(window),
        np.asarray(om),
        x1a,
        np.asarray(x2),
        np.asarray(st, dtype=bool),
        np.asarray(br, dtype=int),
        _gap_reasons(fr, slip_eigenfrequencies(model, params), typical),
        integrator=integrator,
    )
    peaks = {}
    for coord in ("x1",) if not refine_x2 else ("x1", "x2"):
        best = (math.nan, -math.inf, ())
        for b in fr.branches:
            if not b.points:
                continue
            amps = [o.half_peak_to_peak[coord] for o in b.points]
            k = int(np.argmax(amps))
            cand = refine_peak(system, params, b.points, k, coord, options)
            if cand[1] > best[1]:
                best = cand
        peaks[coord] = best
    curve.peak_omega, curve.peak_x1, curve.peak_start = peaks["x1"]
    curve.peak_x2 = peaks["x2"][1] if refine_x2 else float(np.max(curve.x2)) if curve.x2.size else math.nan
    curve.seconds = time.perf_counter() - t0
    return curve


def ida_peak(model: str, params: dict, omega: float, start: tuple) -> tuple[float, float]:
    """Amplitude of ``x1`` by the IDA path (``rtol = 1e-10``) at another integrator's peak.

    Newton (no transient) from ``start``, the other integrator's orbit at its peak frequency
    ``omega``: the same orbit computed by the other path. At a smooth maximum this is the IDA
    path's peak up to a term of second order in the difference of the peak frequencies; where the
    peak is at a fold it is the same point of the branch (a search in ``Omega`` could land on the
    other branch there).

    Parameters
    ----------
    model : str
    params : dict
    omega : float
        Peak frequency of the other integrator [rad/s].
    start : tuple
        ``(t0, mode0, x0)`` of the other integrator's orbit at ``omega`` (:attr:`Curve.peak_start`).

    Returns
    -------
    omega, x1 : float
        [rad/s], [m]; ``x1`` is ``nan`` if Newton fails.
    """
    o = hybrid.periodic_orbit(
        BUILTIN[model](),
        {**params, "Omega": omega},
        t0=start[0],
        mode0=start[1],
        x0=np.asarray(start[2]),
        options=solver_options("ida"),
        settings=hybrid.ShootingOptions(transient_periods=0, samples_per_period=256),
    )
    return float(omega), float(o.half_peak_to_peak["x1"]) if o.converged else math.nan


@dataclass(frozen=True)
class Study:
    """A parameter study: one parameter varied, the others at the model's ``standard`` preset.

    Attributes
    ----------
    figures : (str, str)
        Figure ids for ``x1`` (main text) and ``x2`` (App. B).
    model : str
        ``"absorber"`` or ``"isolator"``.
    parameter : str
        ``"R"`` [N] or ``"c3"`` [N/m].
    values : tuple of float
        The paper's values, blue (first) to red (last).
    caption : str
        The range and steps as the paper gives them.
    """

    figures: tuple
    model: str
    parameter: str
    values: tuple
    caption: str


def _steps(*runs: tuple[float, float, float]) -> tuple[float, ...]:
    """Concatenated ``arange(start, stop + step/2, step)`` runs, rounded to 10 digits, unique."""
    vals = [round(float(v), 10) for a, b, s in runs for v in np.arange(a, b + s / 2, s)]
    return tuple(sorted(set(vals)))


#: The studies of Figs. 7-10 (x1) and B1-B4 (x2) with the paper's ranges and steps.
STUDIES = {
    "absorber-R": Study(
        ("7", "B1"), "absorber", "R", _steps((0.3, 0.8, 0.02)), "R in [0.3 N, 0.8 N], steps of 0.02 N"
    ),
    "absorber-c3": Study(
        ("8", "B2"),
        "absorber",
        "c3",
        _steps((0.01, 1.0, 0.01), (1.0, 10.0, 1.0)),
        "c3 in [0.01, 10] N/m, steps of 0.01 N/m to 1 N/m, then 1 N/m",
    ),
    "isolator-R": Study(
        ("9", "B3"), "isolator", "R", _steps((0.9, 2.0, 0.05)), "R in [0.9 N, 2.0 N], steps of 0.05 N"
    ),
    "isolator-c3": Study(
        ("10", "B4"),
        "isolator",
        "c3",
        _steps((0.1, 1.0, 0.1), (1.0, 10.0, 1.0), (10.0, 100.0, 10.0)),
        "c3 in [0.1, 100] N/m, steps of 0.1 to 1, 1 to 10, 10 to 100 N/m",
    ),
}


def study_params(model: str, **changes: float) -> dict:
    """The model's ``standard`` preset with ``changes`` applied.

    Parameters
    ----------
    model : str
    **changes : float
        Parameter values replacing the preset's.

    Returns
    -------
    dict
    """
    return {**BUILTIN[model]().preset("standard"), **changes}


@dataclass(frozen=True)
class Optimum:
    """Numerically optimal breakaway force near one resonance, beside the averaging model's.

    Attributes
    ----------
    model : str
    mode : int
        Resonance 1 or 2.
    R : float
        ``R`` minimising the peak of ``x1`` [N] (bounded Brent, ``xatol`` in the attribute
        ``xatol``).
    peak_x1 : float
        That minimal peak [m].
    R_averaging : float
        ``R_opt`` of the averaging model [N] (``breakaway_force(rho_opt)``).
    relative_difference : float
        ``(R - R_averaging)/R_averaging`` [-].
    evaluations : int
        Curves computed.
    xatol : float
        Absolute tolerance on ``R`` [N].
    """

    model: str
    mode: int
    R: float
    peak_x1: float
    R_averaging: float
    relative_difference: float
    evaluations: int
    xatol: float


def numerical_peak(model: str, mode: int, integrator: str = "exact") -> Callable[[float], float]:
    """``R -> peak of x1`` [N -> m] of the event-driven model near resonance ``mode`` (``standard`` preset).

    Each call is one :func:`resonance_curve` over ``WINDOWS[mode]``; an unbounded curve gives 1e12.

    Parameters
    ----------
    model : str
    mode : int
    integrator : {"exact", "ida"}, optional

    Returns
    -------
    callable
    """
    base = study_params(model)

    def peak(R: float) -> float:
        c = resonance_curve(model, {**base, "R": float(R)}, WINDOWS[mode], integrator)
        return c.peak_x1 if c.bounded and math.isfinite(c.peak_x1) else 1e12

    return peak


def optimal_friction(
    model: str,
    mode: int,
    integrator: str = "exact",
    bounds: tuple[float, float] | None = None,
    xatol: float = 1e-5,
    peak: Callable[[float], float] | None = None,
) -> Optimum:
    """The ``R`` [N] that minimises the peak of ``x1`` near resonance ``mode`` (``standard`` preset).

    The peak (by default :func:`numerical_peak`: one continued curve per evaluation) is minimised
    by :func:`scipy.optimize.minimize_scalar` (``method="bounded"``).

    Parameters
    ----------
    model : str
        ``"absorber"`` or ``"isolator"``.
    mode : int
        1 or 2.
    integrator : {"exact", "ida"}, optional
    bounds : (float, float), optional
        Search interval [N]; default ``(0.75, 1.4) x R_opt`` of the averaging model.
    xatol : float, optional
        Absolute tolerance on ``R`` [N] (1e-5: four significant digits or more for R > 0.1 N).
    peak : callable, optional
        ``peak(R) -> amplitude [m]`` to minimise instead of :func:`numerical_peak`.

    Returns
    -------
    Optimum
    """
    base = study_params(model)
    r_avg = breakaway_force(model, base, rho_opt(model, base, mode))
    lo, hi = bounds if bounds is not None else (0.75 * r_avg, 1.4 * r_avg)
    fn = peak if peak is not None else numerical_peak(model, mode, integrator)
    res = minimize_scalar(fn, bounds=(lo, hi), method="bounded", options={"xatol": xatol})
    R = float(res.x)
    return Optimum(model, mode, R, float(res.fun), r_avg, (R - r_avg) / r_avg, int(res.nfev), xatol)


def smallest_bounded_friction(
    model: str, mode: int, integrator: str = "exact", steps: int = 6
) -> dict[str, float]:
    """Bracket of the smallest ``R`` [N] with a bounded response near resonance ``mode``.

    Bisection on :attr:`Curve.bounded` over ``(0.8, 1.2) x R_min`` of the averaging model
    (``breakaway_force(rho_min)``); the bracket is widened if both ends agree.

    Parameters
    ----------
    model : str
    mode : int
    integrator : {"exact", "ida"}, optional
    steps : int, optional
        Bisection steps.

    Returns
    -------
    dict
        ``R_unbounded`` (largest R found unbounded), ``R_bounded`` (smallest found bounded) [N],
        ``R_averaging`` [N] (``R_min`` of the averaging model).
    """
    base = study_params(model)
    r_avg = breakaway_force(model, base, rho_min(model, base, mode))

    def bounded(R: float) -> bool:
        return resonance_curve(model, {**base, "R": R}, WINDOWS[mode], integrator).bounded

    lo, hi = 0.8 * r_avg, 1.2 * r_avg
    while bounded(lo) and lo > 1e-3 * r_avg:
        lo *= 0.8
    while not bounded(hi) and hi < 1e3 * r_avg:
        hi *= 1.25
    for _ in range(steps):
        mid = 0.5 * (lo + hi)
        if bounded(mid):
            hi = mid
        else:
            lo = mid
    return {"R_unbounded": lo, "R_bounded": hi, "R_averaging": r_avg}


@dataclass(frozen=True)
class BoundedLimit:
    """The smallest breakaway force with a bounded response at one resonance (:func:`bounded_response_limit`).

    Attributes
    ----------
    model : str
    mode : int
        Resonance 1 or 2 (of the slipping system).
    omega : float
        The slip eigenfrequency [rad/s] where the response is followed in ``R``.
    R_star : float
        Where the branch of orbits at ``omega`` turns vertical [N]: the least ``R`` it reached, an
        upper bound of ``R_min`` (a bounded orbit exists there).
    R_lower : float
        ``R_star - delta`` where a run from the last orbit grows without bound (NaN if not run):
        a lower bound.
    growth : (float, float)
        The amplitude's growth per forcing period [m] of the runs at ``R_star - delta`` and
        ``R_star + delta``.
    R_averaging : float
        ``R_min`` of the averaging model [N] (``breakaway_force(rho_min)``).
    amplitude : float
        Amplitude of ``x1`` of the last orbit of the branch [m].
    points : int
        Orbits of the branch.
    wall_time : float
        [s].
    """

    model: str
    mode: int
    omega: float
    R_star: float
    R_lower: float
    growth: tuple
    R_averaging: float
    amplitude: float
    points: int
    wall_time: float


def bounded_response_limit(
    model: str,
    mode: int,
    params: dict | None = None,
    integrator: str = "exact",
    delta: float = 1e-5,
    periods: int = 1500,
) -> BoundedLimit:
    """The smallest ``R`` [N] with a bounded response near resonance ``mode``, to ``delta``.

    The periodic orbits at the slip eigenfrequency ``omega`` (:func:`slip_eigenfrequencies`) are
    continued in ``R`` down from 1.5 x the averaging model's ``R_min``: the branch turns vertical,
    its amplitude growing at a constant ``R = R_star`` (a family of orbits of every large amplitude:
    the friction's work per cycle, like the forcing's, is then proportional to the amplitude), so
    ``R_star`` bounds ``R_min`` from above. Runs of ``periods`` forcing periods from the last orbit
    at ``R_star -+ delta``: if the amplitude grows at a steady rate below and not (or at most half
    as fast) above, ``R_star - delta`` bounds it from below.

    Parameters
    ----------
    model : str
        ``"absorber"`` or ``"isolator"``.
    mode : int
        1 or 2.
    params : dict, optional
        Default the ``standard`` preset.
    integrator : {"exact", "ida"}, optional
    delta : float, optional
        [N]; 0 skips the run.
    periods : int, optional

    Returns
    -------
    BoundedLimit
    """
    import time

    t0 = time.perf_counter()
    base = dict(study_params(model) if params is None else params)
    system = BUILTIN[model]()
    options = solver_options(integrator)
    w = float(slip_eigenfrequencies(model, base)[mode - 1])
    r_avg = breakaway_force(model, base, rho_min(model, base, mode))
    start = 1.5 * r_avg
    br = hybrid.continue_orbits(
        system, {**base, "Omega": w, "R": start}, "R", (start, 0.2 * r_avg), options=options
    )
    R = br.values
    k = int(np.argmin(R))
    R_star, last = float(R[k]), br.points[k]
    lower, growth = math.nan, (math.nan, math.nan)
    if delta > 0:
        rates = []
        for R in (R_star - delta, R_star + delta):
            rates.append(_growth(system, {**base, "Omega": w, "R": R}, last, periods, options))
        (below, steady), (above, _) = rates
        growth = (below, above)
        # growing at R_star - delta, steadily (both halves of the run alike), and not (or at most half
        # as fast) at R_star + delta: the response is unbounded below R_star - delta
        if below > 0 and steady and above < 0.5 * below:
            lower = R_star - delta
    return BoundedLimit(
        model,
        mode,
        w,
        R_star,
        lower,
        growth,
        r_avg,
        float(last.amplitude["x1"]),
        len(br.points),
        time.perf_counter() - t0,
    )


def _growth(system, params: dict, orbit, periods: int, options) -> tuple[float, bool]:
    """``(rate, steady)``: the growth of ``|x1|``'s peak per forcing period [m] over a run of
    ``periods`` from ``orbit``'s section state (peaks over blocks of 20 periods, a line fitted to
    the second half), and whether the first half grew at a rate within 30 % of it."""
    T = 2 * math.pi / params["Omega"]
    tr = hybrid.simulate(
        system,
        params,
        (orbit.t0, orbit.t0 + periods * T),
        dict(zip(system.variable_names, orbit.x0, strict=True)),
        mode0=orbit.mode0,
        options=options,
        samples_per_period=20,
        throw=False,
    )
    x1 = np.abs(np.asarray(tr["x1"]))
    n = x1.size // (20 * 20)
    peaks = x1[: n * 20 * 20].reshape(n, -1).max(axis=1)
    t = 20.0 * np.arange(n)
    h = n // 2
    second = float(np.polyfit(t[h:], peaks[h:], 1)[0])
    first = float(np.polyfit(t[:h], peaks[:h], 1)[0])
    return second, bool(second > 0 and abs(first - second) <= 0.3 * second)
