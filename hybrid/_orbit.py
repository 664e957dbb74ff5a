"""Periodic orbits of periodically forced hybrid systems: shooting with an exact monodromy.

The stroboscopic map ``P: y(t0) -> y(t0 + T)`` over one forcing period is
evaluated by an event-driven run (:func:`hybrid.simulate`); its Jacobian, the
monodromy matrix, by the variational equations of each mode and the
saltation matrix of each switch (:mod:`hybrid._variational`). Newton's method
solves ``P(y) = y`` on the differential variables of the section's mode (its
slave variables are solved from their algebraic equations at the section).

Choices that make this work for stick-slip systems:

* the section phase is put in the middle of the longest mode interval of the
  guess, so that the map is smooth near the orbit and the mode at ``t0 + T``
  equals the mode at ``t0`` (a converged orbit is checked for it);
* Newton steps are least-squares steps: ``I - M`` is singular on a family of
  orbits (a neutral multiplier 1, e.g. the free offset of a stuck friction
  element) and nearly singular for weakly damped orbits (multipliers 0.99 and
  above). On a family the model's ``orbit.gauge`` expression (= 0 at the
  section) picks the member; without one the member nearest the guess is kept;
* the accuracy is reported: the Newton residual and the condition number of
  ``I - M``, whose product with the integration tolerance bounds the error
  of the orbit's state.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass, field

import numpy as np
from scipy.optimize import minimize_scalar

from ._budget import BudgetExceeded, deadline_passed
from ._compiled import CompiledSystem
from ._expr import compile_scalar, diff
from ._options import SolverOptions
from ._simulate import check_initial_state, check_time_range, initial_state, run_compiled
from ._system import HybridSystem
from ._trajectory import Status, Trajectory
from ._variational import Sensitivity

__all__ = ["PeriodicOrbit", "periodic_orbit", "ORBIT_OPTIONS"]

#: Default tolerances for periodic orbits (tighter than for plain simulation:
#: the error of a weakly damped orbit is the integration error times cond(I - M)).
ORBIT_OPTIONS = SolverOptions(rtol=1e-10, atol=1e-12)


@dataclass(frozen=True)
class PeriodicOrbit:
    """A periodic orbit of a periodically forced hybrid system, with its Floquet multipliers.

    Attributes
    ----------
    system : HybridSystem
        The model.
    params : dict
        Parameter values used.
    t0 : float
        Section time [s] (``0 <= t0 < period``; the forcing phase of the section).
    period : float
        Forcing period [s].
    x0 : ndarray, shape (n_vars,)
        State at the section (quadratures 0), over ``system.variable_names``.
    mode0 : str
        Mode at the section (and at ``t0 + period``).
    trajectory : Trajectory
        One period from the section, sampled, with both sides of each switch.
    amplitude : dict
        Per variable and output: ``max |x|`` over the period.
    half_peak_to_peak : dict
        Per variable and output: ``(max x - min x) / 2``.
    mode_sequence : tuple of str
        Modes in the order visited from the section.
    switch_times : ndarray
        Switch times after the section [s], ``0 <= t - t0 < period``.
    mode_fractions : dict
        Fraction of the period spent in each mode.
    stick_fraction : float or None
        Fraction of the period in the model's ``orbit.stick_modes``.
    state_names : tuple of str
        Variables of the monodromy (quadratures excluded).
    monodromy : ndarray
        ``dy(t0 + T)/dy(t0)`` over ``state_names`` (columns of the section
        mode's slave variables are zero: they are functions of the others).
    multipliers : ndarray of complex
        Floquet multipliers, one per entry of ``state_names``, by decreasing modulus.
    multiplier_kinds : tuple of str
        ``"floquet"``; ``"neutral"`` (the multiplier 1 of a family of orbits,
        e.g. the free offset of a stuck friction element); ``"structural"``
        (a zero from a slave variable, e.g. the massless point of a
        friction-spring element while it slips).
    stability : str
        ``"stable"`` (all Floquet multipliers inside the unit circle),
        ``"unstable"`` (one outside) or ``"neutral"`` (none outside, one on the
        circle, e.g. the undamped linear response of a stuck element).
    converged : bool
        Newton's method met its tolerance.
    residual : float
        ``max |P(x0) - x0|`` relative to ``max |x0|`` (differential variables).
    iterations : int
        Newton iterations.
    condition : float
        Condition number of ``I - M`` on the section's differential
        variables (the family direction removed when a gauge fixes it).
    family : bool
        The orbit belongs to a family (a neutral multiplier 1).
    message : str
        What happened, including accuracy limits.
    energy : dict
        ``input``, ``dissipated`` [J] over the period and their balance
        residual, if the model declares its energy names.
    nfev : int
        Residual evaluations of all runs of the Newton iteration.
    route : str
        How the orbit was found: ``"newton"`` (Newton's method from the guess, after its
        transient), ``"continuation in <parameter> from <value>"`` (the cold-start fallback of
        :func:`periodic_orbit`: Newton from the transient failed, a continuation in the forcing
        parameter from that value reached the orbit, see :mod:`hybrid._coldstart`), or
        ``"none"`` (not found).
    """

    system: HybridSystem
    params: dict
    t0: float
    period: float
    x0: np.ndarray
    mode0: str
    trajectory: Trajectory
    amplitude: dict
    half_peak_to_peak: dict
    mode_sequence: tuple
    switch_times: np.ndarray
    mode_fractions: dict
    stick_fraction: float | None
    state_names: tuple
    monodromy: np.ndarray
    multipliers: np.ndarray
    multiplier_kinds: tuple
    stability: str
    converged: bool
    residual: float
    iterations: int
    condition: float
    family: bool
    message: str
    energy: dict = field(default_factory=dict)
    nfev: int = 0
    route: str = "newton"

    @property
    def stable(self) -> bool | None:
        """True if stable, False if unstable, None if neutral (marginally stable)."""
        return {"stable": True, "unstable": False}.get(self.stability)

    @property
    def transitions_per_period(self) -> int:
        return len(self.switch_times)

    @property
    def floquet_multipliers(self) -> np.ndarray:
        """The multipliers that decide stability (neutral and structural ones removed)."""
        keep = [k == "floquet" for k in self.multiplier_kinds]
        return self.multipliers[np.array(keep, dtype=bool)]

    def state(self, name: str) -> float:
        """Value of variable ``name`` at the section."""
        return float(self.x0[self.system.variable_names.index(name)])

    def to_dict(self) -> dict:
        """JSON-ready summary."""
        return {
            "model": self.system.name,
            "parameters": dict(self.params),
            "period": self.period,
            "t0": self.t0,
            "mode0": self.mode0,
            "x0": {n: float(v) for n, v in zip(self.system.variable_names, self.x0, strict=True)},
            "amplitude": dict(self.amplitude),
            "half_peak_to_peak": dict(self.half_peak_to_peak),
            "multipliers": [[float(z.real), float(z.imag)] for z in self.multipliers],
            "multiplier_kinds": list(self.multiplier_kinds),
            "stability": self.stability,
            "stable": self.stable,
            "transitions_per_period": self.transitions_per_period,
            "mode_sequence": list(self.mode_sequence),
            "switch_times": [float(t) for t in self.switch_times],
            "mode_fractions": dict(self.mode_fractions),
            "stick_fraction": self.stick_fraction,
            "family": self.family,
            "converged": self.converged,
            "residual": self.residual,
            "iterations": self.iterations,
            "condition": self.condition,
            "energy": dict(self.energy),
            "route": self.route,
            "message": self.message,
        }

    def __repr__(self) -> str:
        mu = ", ".join(f"{abs(z):.6g}" for z in self.floquet_multipliers[:4])
        return (
            f"PeriodicOrbit({self.system.name}, T={self.period:.6g} s, {self.stability}, "
            f"{self.transitions_per_period} switches/period, |multipliers| {mu}, "
            f"{'converged' if self.converged else 'NOT converged'}, residual {self.residual:.2g})"
        )


# ----------------------------------------------------------------------
#: Compiled systems kept per model (the most recent parameter sets).
COMPILED_CACHE = 4


def compiled(
    system: HybridSystem,
    params: Mapping[str, float],
    runtime: tuple[str, ...] = (),
    *,
    reuse_runtime: bool = True,
) -> CompiledSystem:
    """A compiled system for ``params``, reused from the model's recent ones where possible.

    With ``runtime`` parameters the result is private (its run-time values change). Otherwise:
    the same parameter set as a recent one reuses it; a set that differs from a recent one in a
    single parameter gets a system compiled with that parameter read at run time (a sweep or a
    continuation neighbour compiles once), set to the requested value at every reuse (so a
    system returned here is only valid until the next call; ``reuse_runtime=False``, e.g. for the
    exact integrator, which needs every parameter folded, never returns such a one).
    """
    if runtime:
        return CompiledSystem(system, params, runtime=runtime)
    params = system.parameter_values(params)
    cache: list = system._cache.setdefault("compiled", [])
    # Parameters in a reset stay folded (the saltation code compiles reset derivatives on its own).
    resets = set().union(*(e.free for td in system._cache["transitions"] for e in td["reset"].values()))
    best = None
    for k, cs in enumerate(cache):
        differ = [p for p, v in params.items() if v != cs.params[p]]
        if (not differ and (reuse_runtime or not cs.runtime)) or (
            reuse_runtime and cs.runtime and set(differ) <= set(cs.runtime)
        ):
            best = k
            break
        if reuse_runtime and not cs.runtime and len(differ) == 1 and best is None and differ[0] not in resets:
            best = (differ[0],)
    if isinstance(best, int):
        cs = cache.pop(best)
        if cs.runtime:
            cs.set_runtime(params)
    elif best is not None:
        cs = CompiledSystem(system, params, runtime=best)
    else:
        cs = CompiledSystem(system, params)
    while len(cache) >= COMPILED_CACHE:
        cache.pop(0)
    cache.append(cs)  # most recent last
    return cs


class _Deferred:
    """An unsampled one-period run standing for the sampled one: its start, end, events, status
    and counts are the run's own; the samples (``t``, ``y``, ``mode``, ``outputs``, ``tr[name]``)
    come from the sampled run, made on first use (:meth:`materialize`)."""

    _SAMPLED = frozenset({"t", "y", "mode", "outputs", "n_samples"})

    def __init__(self, base: Trajectory, make):
        self.base = base
        self._make = make
        self._full: Trajectory | None = None

    def materialize(self) -> Trajectory:
        if self._full is None:
            self._full = self._make()
        return self._full

    def __getattr__(self, name: str):
        if name in _Deferred._SAMPLED:
            return getattr(self.materialize(), name)
        return getattr(self.base, name)

    def __getitem__(self, name: str) -> np.ndarray:
        return self.materialize()[name]


def _sampled(tr):
    return tr.materialize() if isinstance(tr, _Deferred) else tr


class ParameterOutOfDomain(ValueError, RuntimeError):
    """An iteration (e.g. a continuation's corrector) reached a parameter value outside its domain:
    a failed iteration (a RuntimeError to the caller's recovery), not bad input."""


class Shooter:
    """The stroboscopic map of one system and its derivatives (state and, optionally, one parameter).

    Parameters
    ----------
    system : HybridSystem
    params : mapping
        Parameter values (checked).
    options : SolverOptions
    free : str, optional
        A parameter to differentiate the map by (for continuation).
    """

    def __init__(
        self,
        system: HybridSystem,
        params: Mapping[str, float],
        options: SolverOptions,
        free: str | None = None,
    ):
        self.system = system
        self.options = options
        self.free = free
        self.names = system.variable_names
        self.set_params(params)
        if options.integrator == "exact":
            self.cs.affine()  # refused before any run if not affine (NotAffineError)
        # Without a free parameter the variational runs use the same compiled system.
        self.ext = CompiledSystem(system, self.params, (free,)) if free else self.cs
        T = self.period
        self.sens = Sensitivity(self.ext, options, options.max_step or T / 16.0)
        nb = len(self.names)
        self.s = self.sens.s[self.sens.s < nb]  # state part of the sensitivity variables
        gauge = system._cache.get("gauge")
        if gauge is not None:
            slots = {"t": 0, **{nm: i + 1 for i, nm in enumerate(self.names)}}
            pconst = dict(self.params)
            self._gauge = compile_scalar(gauge, slots, pconst)
            self._gauge_grad = [compile_scalar(diff(gauge, nm), slots, pconst) for nm in self.names]
        else:
            self._gauge = None
        pe = system._cache["period"]
        self._dT = diff(pe, free) if free else None
        self.nfev = 0

    def set_params(self, params: Mapping[str, float]) -> None:
        cs = getattr(self, "cs", None)
        try:
            self.params = self.system.parameter_values(params)
        except ValueError as exc:
            if cs is None:
                raise  # the caller's input
            raise ParameterOutOfDomain(str(exc)) from None
        if (
            cs is not None
            and cs.runtime
            and all(v == cs.params[k] for k, v in self.params.items() if k not in cs.runtime)
        ):
            cs.set_runtime(self.params)  # only run-time parameters changed: no compilation
        elif self.free is None and self.options.integrator == "exact":
            # every parameter read at call time: the exact flows come from the affine analysis
            self.cs = CompiledSystem.borrow(self.system, self.params, self)
        else:
            # The free parameter is read at run time (set_runtime), except by the exact integrator.
            runtime = (self.free,) if self.free is not None and self.options.integrator != "exact" else ()
            self.cs = compiled(
                self.system, self.params, runtime, reuse_runtime=self.options.integrator != "exact"
            )
        self.period = self.cs.period
        if self.period is None:
            raise ValueError(
                f"model `{self.system.name}` declares no forcing `period`: periodic orbits need one"
            )
        if self.free is not None:
            self.ext_values = np.array([self.params[self.free]])
        else:
            self.ext_values = np.zeros(0)

    def dT(self) -> float:
        """d(period)/d(free parameter)."""
        return float(compile_scalar(self._dT, {}, self.params)(())) if self._dT is not None else 0.0

    # ------------------------------------------------------------------
    def run(self, y0: np.ndarray, mode0: str, t0: float, *, samples: int | None = None) -> Trajectory:
        """One period from ``(t0, y0, mode0)`` (quadratures reset to 0).

        With ``samples`` the run is made without them and returned as a :class:`_Deferred`: the
        sampled run (about twice as costly) is made only if its samples are used, e.g. for an
        accepted orbit, not at every iteration of a corrector.

        A run that exhausts its budget raises :class:`hybrid._budget.BudgetExceeded`.
        """
        tr = self._run(y0, mode0, t0, None)
        if samples and tr.success:
            return _Deferred(tr, lambda: self._run(y0, mode0, t0, samples))
        return tr

    def _run(self, y0: np.ndarray, mode0: str, t0: float, samples: int | None) -> Trajectory:
        y = np.array(y0, dtype=float)
        for q in self.system.quadratures:
            y[self.names.index(q)] = 0.0
        T = self.period
        grid = np.linspace(t0, t0 + T, samples + 1) if samples else np.array([t0, t0 + T])
        tr = run_compiled(self.cs, self.options, t0, t0 + T, y, self.cs.mode_id(mode0), grid, bool(samples))
        self.nfev += tr.nfev
        if tr.status in (Status.STEP_LIMIT, Status.TIME_LIMIT):
            raise BudgetExceeded("steps" if tr.status == Status.STEP_LIMIT else "time", tr.message)
        return tr

    def monodromy(self, tr: Trajectory) -> np.ndarray:
        """Fundamental matrix over one period along ``tr`` (sensitivity variables, free parameter last)."""
        base = tr.base if isinstance(tr, _Deferred) else tr
        return self.sens.fundamental(
            base.t_start, base.y[0], base.mode_start, base.t_final, base.events, self.ext_values
        )

    def gauge(self, y: np.ndarray) -> tuple[float, np.ndarray] | None:
        if self._gauge is None:
            return None
        v = [0.0, *y.tolist()]
        return float(self._gauge(v)), np.array([g(v) for g in self._gauge_grad])


# ----------------------------------------------------------------------
def _choose_section(tr: Trajectory, T: float) -> tuple[float, np.ndarray, str]:
    """Section time/state/mode in the middle of the longest mode interval of the run's last period.

    The interval across the period boundary counts as one (its first and last pieces joined).
    """
    t_end = tr.t_final
    t_start = t_end - T
    ivs = [(max(a, t_start), b, m) for a, b, m in tr.mode_intervals() if b > t_start]
    if len(ivs) <= 1:
        return t_end, tr.y_final, tr.mode_final
    first, last = ivs[0], ivs[-1]
    cands = list(ivs[1:-1])
    if first[2] == last[2]:
        cands.append((last[0], first[1] + T, last[2]))  # wrapped interval
    else:
        cands += [first, last]
    a, b, m = max(cands, key=lambda iv: iv[1] - iv[0])
    tm = 0.5 * (a + b)
    if tm > t_end:
        tm -= T
    k = int(np.argmin(np.abs(tr.t - tm)))
    return float(tr.t[k]), tr.y[k].copy(), str(tr.mode[k])


def _refined_extrema(t: np.ndarray, x: np.ndarray) -> tuple[float, float]:
    """Max and min of sampled ``x``, refined by the parabola through the three samples around each."""

    def refine(k: int, sgn: float) -> float:
        if 0 < k < x.size - 1 and t[k - 1] < t[k] < t[k + 1]:
            t0, t1, t2 = t[k - 1], t[k], t[k + 1]
            d01 = (x[k] - x[k - 1]) / (t1 - t0)
            a = ((x[k + 1] - x[k]) / (t2 - t1) - d01) / (t2 - t0)
            if sgn * a < 0:
                ts = 0.5 * (t0 + t1) - d01 / (2.0 * a)
                if t0 <= ts <= t2:
                    return float(x[k - 1] + (ts - t0) * d01 + (ts - t0) * (ts - t1) * a)
        return float(x[k])

    return refine(int(np.argmax(x)), 1.0), refine(int(np.argmin(x)), -1.0)


class _Extrema:
    """Largest and smallest value of a variable or output over a sampled run, located on the flow.

    Between two samples of one mode the state is the quintic Hermite interpolant of the samples'
    states, derivatives (the vector field, slave variables from the differentiated constraints)
    and second derivatives (a central difference of the derivatives along the flow): its error is
    ``O(h^6 y^(6))``, at the level of rounding for a few hundred samples per period, where reading
    the samples (or a parabola through them) errs by ``O(h^2 y'')``. The extremum is located on
    that interpolant by a bounded scalar search on the two intervals around the extreme sample;
    an extremum at a switch (a kink) is a sample itself (both sides of a switch are sampled).
    """

    def __init__(self, cs: CompiledSystem, tr: Trajectory):
        self.cs, self.tr = cs, tr
        self.mid = {name: k for k, name in enumerate(cs.mode_index)}
        self._jets: dict[int, tuple] = {}
        self._outputs = tr.outputs

    def jet(self, k: int) -> tuple:
        """``(y, y', y'')`` at sample ``k``."""
        j = self._jets.get(k)
        if j is None:
            tr = self.tr
            cm = self.cs.modes[self.cs.mode_index[str(tr.mode[k])]]
            t, y = float(tr.t[k]), tr.y[k]
            yp = cm.derivatives(t, y)
            dt = 1e-5 * max(float(tr.t[-1] - tr.t[0]), 1e-300) / max(len(tr.t), 1)
            ypp = (cm.derivatives(t + dt, y + dt * yp) - cm.derivatives(t - dt, y - dt * yp)) / (2 * dt)
            j = self._jets[k] = (y, yp, ypp)
        return j

    def state(self, k: int, t: float) -> np.ndarray:
        """Quintic Hermite state at ``t`` between samples ``k`` and ``k + 1``."""
        t0, t1 = float(self.tr.t[k]), float(self.tr.t[k + 1])
        h = t1 - t0
        s = (t - t0) / h
        y0, d0, e0 = self.jet(k)
        y1, d1, e1 = self.jet(k + 1)
        s2, s3, s4, s5 = s * s, s**3, s**4, s**5
        h00 = 1 - 10 * s3 + 15 * s4 - 6 * s5
        h01 = 1 - h00
        h10 = s - 6 * s3 + 8 * s4 - 3 * s5
        h11 = -4 * s3 + 7 * s4 - 3 * s5
        h20 = 0.5 * (s2 - 3 * s3 + 3 * s4 - s5)
        h21 = 0.5 * (s3 - 2 * s4 + s5)
        return h00 * y0 + h01 * y1 + h * (h10 * d0 + h11 * d1) + h * h * (h20 * e0 + h21 * e1)

    def value(self, name: str, k: int, t: float) -> float:
        y = self.state(k, t)
        names = self.cs.system.variable_names
        if name in names:
            return float(y[names.index(name)])
        cm = self.cs.modes[self.cs.mode_index[str(self.tr.mode[k])]]
        return float(cm.outputs[name]([t, *y[: cm.n].tolist()]))

    def smooth(self, k: int) -> bool:
        """Samples ``k`` and ``k + 1`` lie in one mode, at distinct times (no switch between them)."""
        tr = self.tr
        return 0 <= k < len(tr.t) - 1 and tr.mode[k] == tr.mode[k + 1] and tr.t[k + 1] > tr.t[k]

    def refine(self, name: str, x: np.ndarray, k: int, sgn: float) -> float:
        best = float(x[k])
        for a in (k - 1, k):
            if not self.smooth(a):
                continue
            t0, t1 = float(self.tr.t[a]), float(self.tr.t[a + 1])
            try:
                r = minimize_scalar(
                    lambda t, a=a: -sgn * self.value(name, a, t),
                    bounds=(t0, t1),
                    method="bounded",
                    options={"xatol": 1e-10 * (t1 - t0)},
                )
            except (ArithmeticError, ValueError, np.linalg.LinAlgError):
                continue
            v = -sgn * float(r.fun)
            for tb in (t0, t1):  # the search does not evaluate its bounds
                v = max(v, self.value(name, a, tb)) if sgn > 0 else min(v, self.value(name, a, tb))
            best = max(best, v) if sgn > 0 else min(best, v)
        return best

    def extremes(self, name: str, x: np.ndarray) -> tuple[float, float]:
        try:
            return self.refine(name, x, int(np.argmax(x)), 1.0), self.refine(name, x, int(np.argmin(x)), -1.0)
        except (ArithmeticError, ValueError, np.linalg.LinAlgError):  # e.g. a slave solve failed
            return _refined_extrema(self.tr.t, x)


def _classify(
    mult: np.ndarray, n_struct: int, family: bool, tol: float
) -> tuple[np.ndarray, tuple[str, ...], str]:
    order = np.argsort(-np.abs(mult), kind="stable")
    mult = mult[order]
    kinds = ["floquet"] * mult.size
    for k in range(mult.size - n_struct, mult.size):
        kinds[k] = "structural"
    if family:
        cand = [k for k in range(mult.size) if kinds[k] == "floquet"]
        k = min(cand, key=lambda k: abs(mult[k] - 1.0))
        kinds[k] = "neutral"
    fl = np.array([abs(m) for m, kd in zip(mult, kinds, strict=True) if kd == "floquet"])
    if fl.size and fl.max() > 1.0 + tol:
        verdict = "unstable"
    elif family or (fl.size and fl.max() >= 1.0 - tol):
        verdict = "neutral"
    else:
        verdict = "stable"
    return mult, tuple(kinds), verdict


#: A singular value of I - M below this (relative) marks a family of orbits (a multiplier 1 to the
#: accuracy of the monodromy); weakly damped isolated orbits (multipliers 0.99999) stay above it.
FAMILY_TOL = 1e-8


def is_family(sv: np.ndarray) -> bool:
    """True if the singular values ``sv`` (descending) of ``I - M`` show a neutral direction."""
    return bool(sv[-1] <= FAMILY_TOL * max(1.0, sv[0]))


#: Fewest samples per period of an orbit's trajectory (its amplitudes are taken from the samples).
MIN_SAMPLES = 16

#: What to try when Newton's method fails where an orbit may exist.
HINT = (
    "an orbit may still exist: try a longer transient (transient_periods; CLI --transient, e.g. 1000), "
    "another guess (x0; --x0) or a continuation from a nearby parameter value (hybrid frc)"
)


def check_samples(samples_per_period) -> None:
    if (
        isinstance(samples_per_period, bool)
        or not isinstance(samples_per_period, int)
        or samples_per_period < MIN_SAMPLES
    ):
        raise ValueError(
            f"`samples_per_period` must be an integer >= {MIN_SAMPLES} (the amplitudes are taken from the "
            f"samples), got {samples_per_period!r}"
        )


def _check_inputs(system: HybridSystem, options, tol: float, max_iter: int, transient_periods: int) -> None:
    if not isinstance(system, HybridSystem):
        raise TypeError(f"`system` must be a HybridSystem, got {type(system).__name__}")
    if system.period is None:
        raise ValueError(f"model `{system.name}` declares no forcing `period`: periodic orbits need one")
    if not isinstance(options, SolverOptions):
        raise TypeError(f"`options` must be a SolverOptions, got {type(options).__name__}")
    if not (isinstance(tol, int | float) and math.isfinite(tol) and tol > 0):
        raise ValueError(f"`tol` must be a number > 0, got {tol!r}")
    for name, v, lo in (("max_iter", max_iter, 1), ("transient_periods", transient_periods, 0)):
        if isinstance(v, bool) or not isinstance(v, int) or v < lo:
            raise ValueError(f"`{name}` must be an integer >= {lo}, got {v!r}")


def periodic_orbit(
    system: HybridSystem,
    params: Mapping[str, float],
    x0=None,
    mode0: str | None = None,
    *,
    t0: float | None = None,
    transient_periods: int = 10,
    options: SolverOptions | None = None,
    tol: float = 1e-9,
    max_iter: int = 30,
    samples_per_period: int = 512,
) -> PeriodicOrbit:
    """Periodic orbit by Newton shooting, with its monodromy matrix and Floquet multipliers.

    Parameters
    ----------
    system : HybridSystem
        A periodically forced model (it declares a ``period``).
    params : mapping of str to float
        All parameter values.
    x0 : mapping or array_like, optional
        Guess of the state (default: all 0 in the initial mode).
    mode0 : str, optional
        Mode of the guess (default: the model's initial mode).
    t0 : float, optional
        Time of the guess [s]. If given with ``transient_periods=0``, the
        section is ``(t0, x0, mode0)`` as given (e.g. the previous point of a
        continuation); otherwise a transient of ``transient_periods`` forcing
        periods is run from the guess and the section is put in the middle of
        the longest mode interval of its last period.
    transient_periods : int
        Forcing periods simulated from the guess before Newton's method. If Newton's method
        from the transient fails (``transient_periods > 0``), the orbit is sought by a route
        that cannot wander: a continuation in the forcing parameter from a value where a cold
        start converges, then a correction at exactly the requested value
        (:mod:`hybrid._coldstart`); ``route`` says which route found it.
    options : SolverOptions, optional
        Tolerances (default :data:`ORBIT_OPTIONS`, rtol 1e-10).
    tol : float
        Newton tolerance on ``max |P(x) - x| / max |x|``.
    max_iter : int
        Newton iterations allowed.
    samples_per_period : int
        Samples of the returned one-period trajectory.

    Returns
    -------
    PeriodicOrbit
        ``converged`` is False (with the reason in ``message``) if Newton's
        method failed, e.g. when the response grows without bound (no bounded
        periodic orbit) or a run failed, and the fallback did not find it either
        (what it tried is in ``message``).

    Raises
    ------
    ValueError
        Bad input (before any integration).
    """
    options = ORBIT_OPTIONS if options is None else options
    _check_inputs(system, options, tol, max_iter, transient_periods)
    check_samples(samples_per_period)
    mode0 = mode0 if mode0 is not None else system.initial_mode
    if mode0 is None:
        raise ValueError(f"`mode0` is required: model `{system.name}` declares no initial mode")
    system.mode(mode0)
    shooter = Shooter(system, params, options)
    if x0 is None:
        x0 = np.zeros(len(system.variable_names))
    y = initial_state(system, x0, mode0)
    start = 0.0 if t0 is None else float(t0)
    if not math.isfinite(start):
        raise ValueError(f"`t0` must be finite, got {t0!r}")
    check_time_range(shooter.cs, options, start, start + (transient_periods + 1) * shooter.period)
    check_initial_state(shooter.cs, mode0, start, y)
    orbit = solve_orbit(shooter, y, mode0, start, transient_periods, tol, max_iter, samples_per_period)
    if orbit.converged or transient_periods == 0 or deadline_passed():
        return orbit
    # Newton from the transient failed: a route that cannot wander (a layer above this module).
    from ._coldstart import find_by_continuation

    return find_by_continuation(
        system,
        params,
        orbit,
        options=options,
        tol=tol,
        max_iter=max_iter,
        transient_periods=transient_periods,
        samples_per_period=samples_per_period,
    )


def solve_orbit(
    shooter: Shooter,
    y: np.ndarray,
    mode0: str,
    t_start: float,
    transient_periods: int,
    tol: float,
    max_iter: int,
    samples: int,
) -> PeriodicOrbit:
    """Newton shooting from a guess (see :func:`periodic_orbit`).

    A budget exhausted (``SolverOptions.max_steps``, ``max_wall_time``, :func:`hybrid.time_limit`)
    or a grazing switch comes back as ``converged=False`` with the reason.
    """
    at = [y, mode0, t_start, 0]  # last section state, mode, time and iteration (for a failure report)
    try:
        return _solve_orbit(shooter, y, mode0, t_start, transient_periods, tol, max_iter, samples, at)
    except BudgetExceeded as exc:
        return _failed(shooter, at[0], at[1], at[2], at[3], math.inf, str(exc))
    except ZeroDivisionError as exc:  # a grazing switch: no saltation matrix, no monodromy
        return _failed(
            shooter,
            at[0],
            at[1],
            at[2],
            at[3],
            math.inf,
            f"{exc}; write the guard to cross zero at a nonzero rate "
            "(e.g. `v` rather than `sign(v)`), or, at a true grazing, try a nearby parameter value",
        )
    except RuntimeError as exc:  # IDA failed in the variational equations
        return _failed(shooter, at[0], at[1], at[2], at[3], math.inf, f"monodromy failed: {exc}")


def _solve_orbit(shooter, y, mode0, t_start, transient_periods, tol, max_iter, samples, at) -> PeriodicOrbit:
    T = shooter.period
    t_sec, mode = t_start, mode0
    if transient_periods > 0:
        tr = run_compiled(
            shooter.cs,
            shooter.options,
            t_start,
            t_start + transient_periods * T,
            y,
            shooter.cs.mode_id(mode0),
            np.linspace(t_start + (transient_periods - 1) * T, t_start + transient_periods * T, 257),
            True,
        )
        shooter.nfev += tr.nfev
        if tr.status == Status.STEP_LIMIT and "at its rate" in tr.message:
            return _failed(
                shooter,
                y,
                mode0,
                t_start,
                0,
                math.inf,
                f"transient failed: {tr.message}; fewer transient periods (transient_periods; CLI --transient) "
                "or a better guess (--x0) cost less",
            )
        if not tr.success:
            return _failed(shooter, y, mode0, t_start, 0, math.inf, f"transient failed: {tr.message}")
        t_sec, y, mode = _choose_section(tr, T)
    t_sec = t_sec - math.floor(t_sec / T) * T
    at[:] = [y, mode, t_sec, 0]
    return newton(shooter, y, mode, t_sec, tol, max_iter, samples, at)


def _failed(shooter, y, mode0, t0, it, res, msg) -> PeriodicOrbit:
    nan = float("nan")
    names = tuple(n for n in shooter.names if n not in shooter.system.quadratures)
    ns = len(names)
    return PeriodicOrbit(
        system=shooter.system,
        params=dict(shooter.params),
        t0=float(t0),
        period=shooter.period,
        x0=np.asarray(y, dtype=float),
        mode0=mode0,
        trajectory=None,
        amplitude={},
        half_peak_to_peak={},
        mode_sequence=(),
        switch_times=np.zeros(0),
        mode_fractions={},
        stick_fraction=None,
        state_names=names,
        monodromy=np.full((ns, ns), nan),
        multipliers=np.full(ns, nan, dtype=complex),
        multiplier_kinds=("floquet",) * ns,
        stability="unknown",
        converged=False,
        residual=float(res),
        iterations=it,
        condition=nan,
        family=False,
        message=msg,
        nfev=shooter.nfev,
        route="none",
    )


def _scale(y: np.ndarray, d: np.ndarray) -> float:
    return max(float(np.max(np.abs(y[d]))) if d.size else 0.0, 1e-300)


class _Newton:
    """One section mode's Newton system: unknowns are its differential (non-quadrature) variables."""

    def __init__(self, shooter: Shooter, mode: str):
        self.sh = shooter
        cm = shooter.cs.modes[shooter.cs.mode_id(mode)]
        s = shooter.s
        self.d = np.array([i for i in s if cm.is_diff[i]], dtype=int)  # unknowns (state indices)
        self.pos = np.array([int(np.flatnonzero(s == i)[0]) for i in self.d], dtype=int)  # in s
        self.cm = cm

    def residual(self, tr: Trajectory, y0: np.ndarray) -> np.ndarray:
        return tr.y_final[self.d] - y0[self.d]

    def project(self, t: float, y: np.ndarray) -> np.ndarray:
        return self.cm.solve_algebraic(t, y)


def newton(
    shooter: Shooter,
    y: np.ndarray,
    mode0: str,
    t0: float,
    tol: float,
    max_iter: int,
    samples: int,
    at: list | None = None,
) -> PeriodicOrbit:
    """Newton's method on ``P(y) = y`` from a section state (see :func:`periodic_orbit`).

    ``at`` (a list) receives the current section state, mode, time and iteration.
    """
    at = [] if at is None else at
    nw = _Newton(shooter, mode0)
    d = nw.d
    rcond = 1e-7
    try:
        y = nw.project(t0, np.array(y, dtype=float))
    except Exception as exc:  # AlgebraicSolveError
        return _failed(shooter, y, mode0, t0, 0, math.inf, f"guess is not consistent: {exc}")
    scale0 = _scale(y, d)
    res_norm = math.inf
    note = ""
    family = False
    it = 0
    rephased = 0
    resonant = False  # I - M singular with the mismatch outside its range, at the last iteration
    tr = None  # the run from y, when the line search already has it
    J = None  # M_dd - I: exact after a monodromy, then Broyden-updated (None: recompute)
    uphill = 0  # steps far from the orbit accepted without a decrease (reported)
    stalled = False  # the exact Newton step vanishes while the residual does not
    J_here = False  # J is the exact one at the current iterate
    # Broyden's updates save variational runs of IDA; the exact integrator's monodromy is cheap
    # and its exact Newton steps reach rounding.
    broyden = BROYDEN and shooter.options.integrator != "exact"
    # Relative accuracy of one run of the map (the exact integrator's is rounding).
    noise_rtol = shooter.options.rtol if shooter.options.integrator != "exact" else 1e-15
    settle = False  # the residual met the tolerance and a further correction found no decrease
    while True:
        at[:] = [y, mode0, t0, it]
        if tr is None:
            tr = shooter.run(y, mode0, t0)
        if not tr.success:
            return _failed(shooter, y, mode0, t0, it, res_norm, f"run failed at iteration {it}: {tr.message}")
        r = nw.residual(tr, y)
        scale = _scale(y, d)
        res_norm = float(np.max(np.abs(r))) / scale
        g = shooter.gauge(y)
        gauge_bad = family and g is not None and abs(g[0]) > tol * scale
        if res_norm <= tol and not gauge_bad and J is None and noise_rtol < 1e-14 and 0 < it < max_iter:
            # the exact integrator: judge the correction with the exact Jacobian here (cheap)
            M = shooter.monodromy(tr)
            J, J_here = M[np.ix_(nw.pos, nw.pos)] - np.eye(d.size), True
        if (
            res_norm <= tol
            and not gauge_bad
            and (settle or _settled(J, r, tol, scale, rcond, noise_rtol, it, max_iter))
        ):
            if tr.mode_final == mode0:
                break
            if rephased < 3:  # converged onto a section at a switch: move the section
                rephased += 1
                trx = shooter.run(y, mode0, t0, samples=256)
                t1, y1, m1 = _choose_section_period(trx, shooter.period)
                t0, y, mode0 = t1, y1, m1
                nw = _Newton(shooter, mode0)
                d = nw.d
                tr, J = None, None
                continue
            note = "the mode at t0 + T differs from the section's mode; "
            break
        if it >= max_iter or stalled:
            grows = scale > 1e3 * max(scale0, 1e-300)
            if grows:
                why = "the response grows without bound: no bounded periodic orbit"
            elif resonant and res_norm > 1e-4:
                why = (
                    "no bounded periodic orbit near the guess: a Floquet multiplier is 1 and the mismatch "
                    "P(x) - x lies outside the range of I - M (a resonance: the response grows by the same "
                    "amount every period); if something limits that growth at larger amplitude, " + HINT
                )
            else:
                why = "Newton's method did not converge; " + HINT
            return _failed(
                shooter, y, mode0, t0, it, res_norm, f"{why} ({it} iterations, residual {res_norm:.3g})"
            )
        if not np.all(np.isfinite(tr.y_final)) or scale > 1e6 * max(scale0, 1.0):
            return _failed(
                shooter,
                y,
                mode0,
                t0,
                it,
                res_norm,
                "the response grows without bound: no bounded periodic orbit "
                f"(max |x| = {scale:.3g} after {it} Newton iterations)",
            )
        it += 1
        while True:  # a Newton direction, then an Armijo line search along it
            exact = J is None or J_here
            if J is None:
                M = shooter.monodromy(tr)
                J = M[np.ix_(nw.pos, nw.pos)] - np.eye(d.size)
            J_here = False
            sv = np.linalg.svd(J, compute_uv=False)
            family = is_family(sv)
            A = np.vstack([J, g[1][d]]) if (family and g is not None) else J
            rhs = _rhs(r, g, family)
            pinv = np.linalg.pinv(A, rcond=rcond)
            step = pinv @ rhs
            if exact:  # judged on the exact I - M only; once seen, kept for the diagnosis
                rn = float(np.linalg.norm(rhs))
                resonant = resonant or bool(
                    (
                        sv[-1] <= 1e-6 * max(sv[0], 1e-300)
                        and rn > 0
                        and np.linalg.norm(A @ step - rhs) > 0.5 * rn
                    )
                    # a Newton step thousands of times the state: I - M nearly singular, mismatch outside
                    # its range (the line search then keeps the iterates from growing)
                    or float(np.max(np.abs(step))) > 1e3 * max(scale, scale0)
                )
            # The linear model corrects almost none of the mismatch (it lies outside the range of
            # the matrix): no progress is possible along Newton's step.
            if float(np.linalg.norm(A @ step)) <= 1e-3 * float(np.linalg.norm(rhs)):
                if exact:
                    stalled = True  # the mismatch lies outside the range of I - M
                    break
                J = None
                continue
            found, best = _line_search(
                shooter, nw, y, mode0, t0, step, pinv, family, float(np.linalg.norm(rhs))
            )
            if found is not None or exact:
                break
            J = None  # the updated Jacobian gave no descent: recompute it exactly at y
        if stalled:
            continue
        if found is None and res_norm <= tol:
            settle = True  # the correction asked for by _settled is below what the runs resolve
            continue
        if found is None:
            if res_norm <= 0.1:
                return _failed(
                    shooter,
                    y,
                    mode0,
                    t0,
                    it,
                    res_norm,
                    "Newton's method found no decrease of the residual along its direction (the map is "
                    f"not smooth here, or not accurate enough for the tolerance); {HINT} "
                    f"({it} iterations, residual {res_norm:.3g})",
                )
            # Far from the orbit (a transient's guess): take the best point tried, uphill, and say so.
            found = best
            if found is None:
                return _failed(
                    shooter, y, mode0, t0, it, res_norm, f"every run along the Newton step failed ({HINT})"
                )
            uphill += 1
        y_new, tr, lam = found
        # Broyden's update of J from the step taken (exact again whenever the line search cut it).
        r_new = nw.residual(tr, y_new)
        s_d = y_new[d] - y[d]
        ss = float(s_d @ s_d)
        if lam == 1.0 and ss > 0 and not family and broyden:
            J = J + np.outer((r_new - r) - J @ s_d, s_d) / ss
        else:
            J = None
        y = y_new
    if uphill:
        note += f"{uphill} Newton step(s) far from the orbit accepted without a decrease of the residual; "
    at[:] = [y, mode0, t0, it]
    return _finish(shooter, nw, y, mode0, t0, it, res_norm, tol, samples, note)


def _settled(J, r, tol: float, scale: float, rcond: float, rtol: float, it: int, max_iter: int) -> bool:
    """A residual below the tolerance is not yet an accurate state when ``I - M`` is ill-conditioned:
    with a Jacobian at hand, the Newton correction it gives must be below the tolerance too (or at
    the noise level of the map, ``10 cond x rtol``, relative to ``scale``), else one more step is
    taken (Broyden's iterates stop earlier than quadratic ones would)."""
    if J is None or it >= max_iter:
        return True
    sv = np.linalg.svd(J, compute_uv=False)
    if not sv.size or sv[0] == 0.0:
        return True
    corr = np.linalg.lstsq(J, -r, rcond=rcond)[0]
    noise = 10.0 * sv[0] / max(sv[-1], rcond * sv[0]) * rtol
    return float(np.max(np.abs(corr))) <= max(tol, noise) * scale


#: Broyden's updates of I - M between exact monodromies on the IDA path (False: exact Newton).
BROYDEN = True
#: Armijo's sufficient-decrease constant.
ARMIJO = 1e-4
#: Step halvings of the line search.
MAX_BACKTRACKS = 8


def _rhs(r: np.ndarray, g, family: bool) -> np.ndarray:
    """Right-hand side of the Newton system: ``-r``, and ``-gauge`` on a family with a gauge."""
    return np.concatenate([-r, [-g[0]]]) if (family and g is not None) else -r


def _line_search(shooter, nw, y, mode0, t0, step, pinv, family, res0):
    """Armijo backtracking along the Newton step ``step = pinv @ rhs(y)``.

    The first ``lam = 1, 1/2, ...`` is taken where the residual norm ``|rhs|`` decreases
    sufficiently, ``|rhs(y + lam step)| <= (1 - c lam) res0`` (``res0 = |rhs(y)|``), or the
    residual in Newton's natural norm does, ``|pinv @ rhs(y + lam step)| <= (1 - c lam) |step|``
    (``pinv``: the pseudo-inverse of the iteration's own matrix). The natural norm is invariant
    under a rescaling of the equations: far from a weakly damped orbit the plain residual of a
    nearly singular ``I - M`` decreases only along steps thousands of times shorter than
    Newton's; near the orbit it is the plain residual that is reliable (the natural norm
    amplifies the integration noise by ``cond(I - M)``).

    Returns ``(found, best)``: ``found = (y_new, run, lam)`` or None (the run is kept for the
    next iteration: nothing is integrated twice); without one, ``best`` is the tried point of
    least merit in the same form (for a step far from the orbit, reported by the caller), or None.
    """
    d = nw.d
    phi0 = float(np.linalg.norm(step))
    lam = 1.0
    best = None
    for _ in range(MAX_BACKTRACKS):
        y_new = y.copy()
        y_new[d] += lam * step
        try:
            y_new = nw.project(t0, y_new)
        except Exception:  # AlgebraicSolveError: no consistent point there
            lam *= 0.5
            continue
        tr = shooter.run(y_new, mode0, t0)
        if tr.success and np.all(np.isfinite(tr.y_final)):
            rhs = _rhs(nw.residual(tr, y_new), shooter.gauge(y_new), family)
            phi = float(np.linalg.norm(pinv @ rhs))
            if (
                phi <= (1.0 - ARMIJO * lam) * phi0
                or float(np.linalg.norm(rhs)) <= (1.0 - ARMIJO * lam) * res0
            ):
                return (y_new, tr, lam), None
            if best is None or phi < best[0]:
                best = (phi, y_new, tr, lam)
        lam *= 0.5
    return None, (best[1:] if best is not None else None)


def _choose_section_period(tr: Trajectory, T: float) -> tuple[float, np.ndarray, str]:
    t, y, m = _choose_section(_sampled(tr), T)
    return t - math.floor(t / T) * T, y, m


def _finish(shooter, nw, y, mode0, t0, it, res_norm, tol, samples, note, tr=None, M=None) -> PeriodicOrbit:
    """Build the orbit from its section state (``tr``, ``M``: its sampled run and monodromy, if known)."""
    sys_ = shooter.system
    names = shooter.names
    tr = shooter._run(y, mode0, t0, samples) if tr is None else _sampled(tr)
    if M is None:
        M = shooter.monodromy(tr)
    s = shooter.s
    ns = s.size
    Ms = M[:ns, :ns]
    A = Ms[np.ix_(nw.pos, nw.pos)]
    IA = np.eye(nw.d.size) - A
    sv = np.linalg.svd(IA, compute_uv=False)
    family = is_family(sv)
    g = shooter.gauge(y)
    # cond = largest / smallest singular value that counts (the family direction removed when
    # the gauge fixes it); inf where that one is 0, e.g. I - M = 0 (every state a periodic orbit).
    k = -2 if (family and g is not None and sv.size > 1) else -1
    cond = float(sv[0] / sv[k]) if sv.size and sv[k] > 0 else math.inf
    mult = np.concatenate([np.linalg.eigvals(A), np.zeros(ns - nw.d.size)])
    # Structural zeros: slave variables at the section, plus a dimension lost in any mode visited.
    nd = {m.name: sum(1 for i in s if m.is_diff[i]) for m in shooter.cs.modes}
    visited = {mode0} | {e.target for e in tr.events}
    n_struct = ns - min(nd[m] for m in visited)
    mtol = max(1e-6, 100.0 * shooter.options.rtol)
    mult, kinds, verdict = _classify(mult, n_struct, family, mtol)
    # Amplitudes (variables and outputs): extrema located on the flow, not read from samples.
    amp, hpp = {}, {}
    ext = _Extrema(shooter.cs, tr)
    series = {n: tr.y[:, i] for i, n in enumerate(names) if n not in sys_.quadratures}
    series.update({o: tr.outputs[o] for o in sys_.outputs})
    for n, x in series.items():
        hi, lo = ext.extremes(n, x)
        amp[n] = max(abs(hi), abs(lo))
        hpp[n] = 0.5 * (hi - lo)
    ivs = tr.mode_intervals()
    fr: dict[str, float] = {}
    for a, b, m in ivs:
        fr[m] = fr.get(m, 0.0) + (b - a) / shooter.period
    sm = tuple(sys_.orbit.get("stick_modes", ()))
    stick = sum(fr.get(m, 0.0) for m in sm) if sm else None
    seq = [mode0] + [e.target for e in tr.events]
    energy = {}
    en = sys_.energy
    if "input" in en and "dissipated" in en:
        W, D = tr.final(en["input"]), tr.final(en["dissipated"])
        dE = tr[en["mechanical"]][-1] - tr[en["mechanical"]][0] if "mechanical" in en else 0.0
        res = float(W - D - dE)
        exchanged = max(abs(W), abs(D))
        emax = float(np.max(np.abs(tr[en["mechanical"]]))) if "mechanical" in en else 0.0
        energy = {
            "input": float(W),
            "dissipated": float(D),
            "mechanical_change": float(dE),
            "residual": res,
            # Relative to the energy exchanged per period; None when nothing is exchanged
            # (an undamped stuck orbit), where the ratio would be noise over noise.
            "relative_residual": res / exchanged if exchanged > 1e-6 * emax else None,
        }
    msg = note
    if family:
        msg += "a family of periodic orbits (neutral multiplier 1); " + (
            "the member with gauge `" + str(sys_.orbit.get("gauge")) + "` = 0 is returned; "
            if g is not None
            else "the member nearest the guess is returned; "
        )
    err = cond * shooter.options.rtol
    if sv.size and sv[0] == 0.0:
        msg += (
            "I - M vanishes: every nearby state is periodic (the map leaves all of them unchanged), "
            "cond(I - M) is infinite; "
        )
    elif err > 1e-6:
        msg += (
            f"I - M is ill-conditioned (cond {cond:.3g}): the orbit's state is accurate to about "
            f"cond x rtol = {err:.2g} (relative); tighten rtol for more; "
        )
    conv = res_norm <= tol and not note
    msg += "converged" if conv else "converged in the residual, see above"
    return PeriodicOrbit(
        system=sys_,
        params=dict(shooter.params),
        t0=float(t0),
        period=shooter.period,
        x0=tr.y[0].copy(),
        mode0=mode0,
        trajectory=tr,
        amplitude=amp,
        half_peak_to_peak=hpp,
        mode_sequence=tuple(seq),
        switch_times=np.array([e.t - t0 for e in tr.events]),
        mode_fractions=fr,
        stick_fraction=stick,
        state_names=tuple(names[i] for i in s),
        monodromy=Ms,
        multipliers=mult,
        multiplier_kinds=kinds,
        stability=verdict,
        converged=conv,
        residual=res_norm,
        iterations=it,
        condition=cond,
        family=family,
        message=msg.strip("; "),
        energy=energy,
        nfev=shooter.nfev,
    )
