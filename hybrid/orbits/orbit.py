"""A periodic orbit and what is read off it: :class:`PeriodicOrbit`.

The orbit itself is found by the shooting core (:mod:`hybrid.orbits.shooting`); here it is finished:
amplitudes (extrema located on the flow, not read from samples), the time per mode, the Floquet
multipliers classified (Floquet, neutral on a family, structural from slave variables) with the
stability verdict, the energy balance, and the accuracy that the conditioning of ``I - M`` allows.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field, replace

import numpy as np

from ..core.balance import balance
from ..core.errors import InputError, InputTypeError, ModelError
from ..core.options import ShootingOptions
from ..core.plain import options_text, plain_data
from ..core.scalar import bounded_minimum
from ..core.status import SolveStatus
from ..engine.trajectory import Trajectory, sampled_trajectory
from ..integrators.ida import IDA
from ..integrators.options import SolverOptions
from ..model.compiled import CompiledSystem
from ..model.system import HybridSystem

__all__ = ["stability_text", "PeriodicOrbit", "ORBIT_OPTIONS", "with_options"]

#: Default tolerances for periodic orbits (tighter than for plain simulation:
#: the error of a weakly damped orbit is the integration error times cond(I - M)).
ORBIT_OPTIONS = SolverOptions(method=IDA(rtol=1e-10, atol=1e-12))


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
        Period of the orbit [s]: :attr:`periods` forcing periods.
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
        Modes in the order visited from the section (a mode passed through at one instant, in
        which no time is spent, is not one of them: see :attr:`Trajectory.switches`).
    switch_times : ndarray
        Switch times after the section [s], ``0 <= t - t0 < period``: one per switch (transitions
        taken at one instant through modes held for no time are one switch; issue 30).
    mode_fractions : dict
        Fraction of the period spent in each mode.
    state_names : tuple of str
        Variables of the monodromy (quadratures excluded).
    monodromy : ndarray
        ``dy(t0 + T)/dy(t0)`` over ``state_names`` (columns of the section
        mode's slave variables are zero: they are functions of the others).
    multipliers : ndarray of complex
        Floquet multipliers, one per entry of ``state_names``, by decreasing modulus.
    multiplier_kinds : tuple of str
        ``"floquet"``; ``"neutral"`` (a multiplier 1 of a family of orbits, one per free coordinate,
        e.g. the free offset of a stuck friction element); ``"structural"``
        (a zero from a slave variable, e.g. the massless point of a
        friction-spring element while it slips).
    stability : str
        ``"stable"`` (all Floquet multipliers inside the unit circle),
        ``"unstable"`` (one outside) or ``"neutral"`` (none outside, one on the
        circle, e.g. the undamped linear response of a stuck element).
    status : SolveStatus
        ``"converged"`` (Newton's method met its tolerance) or ``"failed"``; :attr:`converged`
        says the same as a bool.
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
        :func:`hybrid.periodic_orbit`: Newton from the transient failed, a continuation in the
        forcing parameter from that value reached the orbit, see :mod:`hybrid.continuation.coldstart`), or
        ``"none"`` (not found).
    reason : str
        Why it failed, a code of :data:`hybrid.core.status.SOLVE_REASONS` (``"budget"``,
        ``"grazing"``, ``"not-converged"``, ...); ``""`` if converged.
    options : SolverOptions or None
        The solver options it was computed with: those given to :func:`hybrid.periodic_orbit`
        (or :func:`hybrid.autonomous_orbit`), or :data:`ORBIT_OPTIONS` in their place; with
        :attr:`settings` and the same guess they repeat it. None for an orbit of a branch (the
        :class:`hybrid.Branch` holds them).
    settings : ShootingOptions or None
        The shooting options it was computed with (likewise).
    periods, attractor_periods : int, int or None
        Forcing periods the orbit spans (> 1: a subharmonic), and those of the orbit its transient
        settled on (:mod:`hybrid.orbits.subharmonic`; 0: none up to 8; None: no transient).
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
    state_names: tuple
    monodromy: np.ndarray
    multipliers: np.ndarray
    multiplier_kinds: tuple
    stability: str
    status: SolveStatus
    residual: float
    iterations: int
    condition: float
    family: bool
    message: str
    energy: dict = field(default_factory=dict)
    nfev: int = 0
    route: str = "newton"
    reason: str = ""
    options: SolverOptions | None = None
    settings: ShootingOptions | None = None
    periods: int = 1
    attractor_periods: int | None = None

    @property
    def converged(self) -> bool:
        """True if :attr:`status` is ``"converged"``."""
        return self.status == SolveStatus.CONVERGED

    @property
    def stable(self) -> bool | None:
        """True if stable, False if unstable, None if neutral (marginally stable)."""
        return {"stable": True, "unstable": False}.get(self.stability)

    @property
    def local_fractions(self) -> dict:
        """Fraction of the period each part of the system spends in each of its modes, over
        :attr:`hybrid.HybridSystem.local_mode_names` (``component.mode`` for a component's local
        mode); without components, :attr:`mode_fractions`."""
        return local_fractions(self.system, self.mode_fractions)

    transitions_per_period = property(lambda self: len(self.switch_times))

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
            "family": self.family,
            "converged": self.converged,
            "residual": self.residual,
            "iterations": self.iterations,
            "condition": self.condition,
            "energy": dict(self.energy),
            "route": self.route,
            "message": self.message,
            "options": plain_data(self.options),
            "settings": plain_data(self.settings),
            **{"periods": self.periods, "attractor_periods": self.attractor_periods},
        }

    def __repr__(self) -> str:
        given = [(n, getattr(self, n)) for n in ("options", "settings") if getattr(self, n) is not None]
        opts = "".join(f", {n}={options_text(v)}" for n, v in given)
        if not self.converged:
            return (
                f"PeriodicOrbit({self.system.name}, T={self.period:.6g} s, failed ({self.reason}) "
                f"after {self.iterations} iterations, residual {self.residual:.2g}{opts})"
            )
        mu = ", ".join(f"{abs(z):.6g}" for z in self.floquet_multipliers[:4])
        return (
            f"PeriodicOrbit({self.system.name}, T={self.period:.6g} s, {self.stability}, "
            f"{self.transitions_per_period} switches/period, |multipliers| {mu}, "
            f"converged, residual {self.residual:.2g}{opts})"
        )


def with_options(
    orbit: PeriodicOrbit, options: SolverOptions | None, settings: ShootingOptions | None
) -> PeriodicOrbit:
    """``orbit`` with the options it was computed with recorded (:attr:`PeriodicOrbit.options`,
    :attr:`PeriodicOrbit.settings`)."""
    return replace(orbit, options=options, settings=settings)


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


#: Monomial coefficients (rows: powers 0..5) of the quintic Hermite basis on [0, 1], columns in the
#: order y(0), y(1), y'(0), y'(1), y''(0), y''(1) (derivatives in s).
_HERMITE5 = np.array(
    [
        [1.0, 0.0, 0.0, 0.0, 0.0, 0.0],
        [0.0, 0.0, 1.0, 0.0, 0.0, 0.0],
        [0.0, 0.0, 0.0, 0.0, 0.5, 0.0],
        [-10.0, 10.0, -6.0, -4.0, -1.5, 0.5],
        [15.0, -15.0, 8.0, 7.0, 1.5, -1.0],
        [-6.0, 6.0, -3.0, -3.0, -0.5, 0.5],
    ]
)


class _Extrema:
    """Largest and smallest value of a variable or output over a sampled run, located on the flow.

    Between two samples of one mode the state is the quintic Hermite interpolant of the samples'
    states, derivatives (the vector field, slave variables from the differentiated constraints)
    and second derivatives (a central difference of the derivatives along the flow; with
    ``affine``, the modes' exact flows of the exact integrator, both exactly): its error is
    ``O(h^6 y^(6))``, at the level of rounding for a few hundred samples per period, where reading
    the samples (or a parabola through them) errs by ``O(h^2 y'')``. The extremum is located on
    that interpolant by a bounded scalar search on the two intervals around the extreme sample;
    an extremum at a switch (a kink) is a sample itself (both sides of a switch are sampled).
    """

    def __init__(self, cs: CompiledSystem, tr: Trajectory, affine: list | None = None):
        self.cs, self.tr = cs, tr
        self.affine = affine  # the modes' exact flows (the exact integrator): exact derivatives
        self._jets: dict[int, tuple] = {}
        self._polys: dict[int, np.ndarray] = {}
        self._outputs = tr.outputs

    def jet(self, k: int) -> tuple:
        """``(y, y', y'')`` at sample ``k``."""
        j = self._jets.get(k)
        if j is None:
            tr = self.tr
            cm = self.cs.modes[self.cs.mode_index[str(tr.mode[k])]]
            t, y = float(tr.t[k]), tr.y[k]
            if self.affine is not None:
                am = self.affine[cm.index]
                z = am.augment(t, y)
                j = self._jets[k] = (y, am.derivatives(z), am.second_derivatives(z))
                return j
            yp = cm.derivatives(t, y)
            dt = 1e-5 * max(float(tr.t[-1] - tr.t[0]), 1e-300) / max(len(tr.t), 1)
            ypp = (cm.derivatives(t + dt, y + dt * yp) - cm.derivatives(t - dt, y - dt * yp)) / (2 * dt)
            j = self._jets[k] = (y, yp, ypp)
        return j

    def poly(self, k: int) -> np.ndarray:
        """Monomial coefficients ``C`` (6 x n) of the quintic Hermite state between samples ``k`` and
        ``k + 1``: ``y = sum_m C[m] s^m``, ``s = (t - t_k) / (t_(k+1) - t_k)`` in [0, 1]."""
        C = self._polys.get(k)
        if C is None:
            h = float(self.tr.t[k + 1] - self.tr.t[k])
            y0, d0, e0 = self.jet(k)
            y1, d1, e1 = self.jet(k + 1)
            C = self._polys[k] = _HERMITE5 @ np.array([y0, y1, h * d0, h * d1, h * h * e0, h * h * e1])
        return C

    def state(self, k: int, t: float) -> np.ndarray:
        """Quintic Hermite state at ``t`` between samples ``k`` and ``k + 1``."""
        t0 = float(self.tr.t[k])
        s = (t - t0) / float(self.tr.t[k + 1] - t0)
        C = self.poly(k)
        y = C[5]
        for m in range(4, -1, -1):
            y = y * s + C[m]
        return y

    def value(self, name: str, k: int, t: float) -> float:
        names = self.cs.system.variable_names
        if name in names:
            return float(self.state(k, t)[names.index(name)])
        y = self.state(k, t)
        cm = self.cs.modes[self.cs.mode_index[str(self.tr.mode[k])]]
        return float(cm.outputs[name]([t, *y[: cm.n].tolist()]))

    def smooth(self, k: int) -> bool:
        """Samples ``k`` and ``k + 1`` lie in one mode, at distinct times (no switch between them)."""
        tr = self.tr
        return 0 <= k < len(tr.t) - 1 and tr.mode[k] == tr.mode[k + 1] and tr.t[k + 1] > tr.t[k]

    def refine(self, name: str, x: np.ndarray, k: int, sgn: float) -> float:
        """The extremum (``sgn`` 1: max, -1: min) next to sample ``k`` on the interpolant: for a
        variable, the largest of the quintic's values at the real roots of its derivative in the
        two intervals around ``k`` and at their ends; for an output, Newton's method on its
        derivative (finite differences of the interpolant, a few evaluations), or a bounded scalar
        search on each side of ``k`` where Newton does not settle."""
        names = self.cs.system.variable_names
        if name in names:
            return self._polynomial(names.index(name), x, k, sgn)
        v = self._newton(name, x, k, sgn)
        return v if v is not None else self._search(name, x, k, sgn)

    def _polynomial(self, i: int, x: np.ndarray, k: int, sgn: float) -> float:
        best = float(x[k])
        for a in (k - 1, k):
            if not self.smooth(a):
                continue
            c = self.poly(a)[:, i]
            roots = np.roots(np.arange(5, 0, -1) * c[:0:-1])  # p'(s), highest power first
            ss = [float(r.real) for r in roots if abs(r.imag) <= 1e-9 and 0.0 < r.real < 1.0]
            for s_ in [*ss, 0.0, 1.0]:
                v = (
                    float(np.polyval(c[::-1], s_))
                    if 0.0 < s_ < 1.0
                    else float(x[a] if s_ == 0.0 else x[a + 1])
                )
                best = max(best, v) if sgn > 0 else min(best, v)
        return best

    def _newton(self, name: str, x: np.ndarray, k: int, sgn: float) -> float | None:
        t = self.tr.t
        left, right = self.smooth(k - 1), self.smooth(k)
        if not (left or right):
            return float(x[k])  # between two switches: the sample is the extremum (a kink)
        lo = float(t[k - 1]) if left else float(t[k])
        hi = float(t[k + 1]) if right else float(t[k])
        h = hi - lo if not (left and right) else min(float(t[k]) - lo, hi - float(t[k]))
        tc = float(t[k])
        if left and right:  # start at the vertex of the parabola through the three samples
            d01 = (x[k] - x[k - 1]) / (t[k] - lo)
            c = ((x[k + 1] - x[k]) / (hi - t[k]) - d01) / (hi - lo)
            if sgn * c < 0:
                tc = min(max(float(0.5 * (lo + t[k]) - d01 / (2.0 * c)), lo), hi)
        delta = 1e-4 * h
        xk = float(x[k])

        def f(tt: float) -> float:
            tt = min(max(tt, lo), hi)
            return self.value(name, k - 1 if (tt < t[k] or not right) else k, tt)

        for _ in range(8):
            a, b = max(tc - delta, lo), min(tc + delta, hi)
            fm, f0, fp = f(a), f(0.5 * (a + b)), f(b)
            tc = 0.5 * (a + b)
            dd = 0.5 * (b - a)
            if max(abs(fm - xk), abs(f0 - xk), abs(fp - xk)) <= 1e-12 * max(abs(xk), 1e-300):
                return xk  # flat at rounding level (e.g. a constant force while slipping)
            d2 = (fp - 2.0 * f0 + fm) / (dd * dd)
            if not sgn * d2 < 0:
                return None
            step = -(fp - fm) / (2.0 * dd) / d2
            if tc + step < lo or tc + step > hi:
                if left and right:
                    return None
                # concave towards the switch: the extremum on this side is at the switch (a sample)
                edge = lo if tc + step < lo else hi
                if edge == float(t[k]):
                    return xk
                return None
            tc += step
            if abs(step) <= 1e-6 * h:
                v = f(tc)
                return max(xk, v) if sgn > 0 else min(xk, v)
        return None

    def _search(self, name: str, x: np.ndarray, k: int, sgn: float) -> float:
        best = float(x[k])
        for a in (k - 1, k):
            if not self.smooth(a):
                continue
            t0, t1 = float(self.tr.t[a]), float(self.tr.t[a + 1])
            try:
                _, fun = bounded_minimum(
                    lambda t, a=a: -sgn * self.value(name, a, t), t0, t1, 1e-10 * (t1 - t0)
                )
            except (ArithmeticError, ValueError, np.linalg.LinAlgError):
                continue
            v = -sgn * fun
            for tb in (t0, t1):  # the search does not evaluate its bounds
                v = max(v, self.value(name, a, tb)) if sgn > 0 else min(v, self.value(name, a, tb))
            best = max(best, v) if sgn > 0 else min(best, v)
        return best

    def twins(self, k: int) -> list[int]:
        """Sample ``k`` and the samples at the same instant (the other sides of a switch there)."""
        t = self.tr.t
        lo, hi = k, k
        while lo > 0 and t[lo - 1] == t[k]:
            lo -= 1
        while hi < len(t) - 1 and t[hi + 1] == t[k]:
            hi += 1
        return list(range(lo, hi + 1))

    def around(self, k: int) -> list[int]:
        """:meth:`twins` of ``k``, and of the other end of the period if ``k`` is its first or last sample."""
        last = len(self.tr.t) - 1
        ends = [0, last] if k in (0, last) else [k]
        return sorted({j for e in ends for j in self.twins(e)})

    def extremes(self, name: str, x: np.ndarray) -> tuple[float, float]:
        """Largest and smallest value. An extreme sample at a switch is refined on both sides of it:
        the extremum may lie just after the switch, in the interval next to the other side's sample.
        The run is one period: its first and last samples are the same state, so an extreme sample
        at either end is refined on both sides of the wrap (the extremum may lie in the other end's
        interval)."""
        try:
            hi = max(self.refine(name, x, j, 1.0) for j in self.around(int(np.argmax(x))))
            lo = min(self.refine(name, x, j, -1.0) for j in self.around(int(np.argmin(x))))
            return hi, lo
        except (ArithmeticError, ValueError, np.linalg.LinAlgError):  # e.g. a slave solve failed
            return _refined_extrema(self.tr.t, x)


def mode_fractions(tr: Trajectory, period: float) -> dict[str, float]:
    """Fraction of ``period`` that run ``tr`` spends in each mode (from its exact switch times)."""
    fr: dict[str, float] = {}
    for a, b, m in tr.mode_intervals():
        fr[m] = fr.get(m, 0.0) + (b - a) / period
    return fr


def local_fractions(system: HybridSystem, fractions: dict[str, float]) -> dict[str, float]:
    """Time fractions per mode (:func:`mode_fractions`) summed per mode of each part of the system
    (see :attr:`hybrid.HybridSystem.local_mode_names`); without components, a copy."""
    if not system.components:
        return dict(fractions)
    out: dict[str, float] = {}
    for m, f in fractions.items():
        for part in system.local_modes_of(m):
            out[part] = out.get(part, 0.0) + f
    return out


def _classify(
    mult: np.ndarray, n_struct: int, family: bool, tol: float, q: int = 1
) -> tuple[np.ndarray, tuple[str, ...], str]:
    """Multipliers by decreasing modulus, their kinds (``q`` neutral ones, those nearest 1, on a
    family of dimension ``q``), and the stability verdict."""
    order = np.argsort(-np.abs(mult), kind="stable")
    mult = mult[order]
    kinds = ["floquet"] * mult.size
    for k in range(mult.size - n_struct, mult.size):
        kinds[k] = "structural"
    if family:
        cand = [k for k in range(mult.size) if kinds[k] == "floquet"]
        for k in sorted(cand, key=lambda k: abs(mult[k] - 1.0))[: max(1, q)]:
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


def family_dimension(sv: np.ndarray) -> int:
    """The number of neutral directions the singular values ``sv`` (descending) of ``I - M`` show
    (the dimension of the family of orbits; 0 for an isolated orbit)."""
    if not sv.size:
        return 0
    return int(np.count_nonzero(sv <= FAMILY_TOL * max(1.0, sv[0])))


#: Coordinates whose balancing factors (:func:`balance_scales`) stay within this ratio of each other
#: are not rescaled: a model in consistent units (the shipped ones) keeps its numerics.
BALANCE_RATIO = 16.0


def balance_scales(J: np.ndarray, ratio: float = BALANCE_RATIO) -> np.ndarray:
    """Scales ``s`` (powers of 2) that balance ``J`` (:func:`hybrid.core.balance.balance`), all ones
    where the factors stay within ``ratio`` (:data:`BALANCE_RATIO`) of each other.

    A similarity: the multipliers do not change, but the singular values of ``I - M`` do, and so
    do the rank tests and truncated pseudo-inverses that read them. In the unscaled state they
    depend on the units: with the absorber's time scale shrunk 100 times (stiffnesses and forces
    times 1e4, a forcing period of 0.074 s) its velocities are 100 times its displacements,
    ``cond(I - M)`` rose from 1e5 to 1e7 and beyond the pseudo-inverse's cut-off, and Newton's
    method stalled where the balanced matrix has the same 1e5 as the unscaled one.
    """
    s = balance(J)
    if float(np.max(s) / np.min(s)) <= ratio:
        return np.ones(s.size)
    return s


def balanced(J: np.ndarray, ratio: float = BALANCE_RATIO) -> tuple[np.ndarray, np.ndarray]:
    """``(diag(s)^-1 J diag(s), s)`` with ``s`` from :func:`balance_scales`."""
    s = balance_scales(J, ratio)
    return J * s[None, :] / s[:, None], s


def check_orbit_inputs(system: HybridSystem, options, settings, *, forced: bool) -> None:
    """Refuse bad arguments of :func:`hybrid.periodic_orbit` (``forced``) or
    :func:`hybrid.autonomous_orbit` before any integration (``TypeError``/``ValueError``)."""
    if not isinstance(system, HybridSystem):
        raise InputTypeError(f"`system` must be a HybridSystem, got {type(system).__name__}")
    if forced and system.period is None:
        raise ModelError(f"model `{system.name}` declares no forcing `period`: periodic orbits need one")
    if not forced and system.period is not None:
        raise ModelError(
            f"model `{system.name}` is periodically forced (period {system.period!r}): use hybrid.periodic_orbit"
        )
    if not isinstance(options, SolverOptions):
        raise InputTypeError(f"`options` must be a SolverOptions, got {type(options).__name__}")
    if not isinstance(settings, ShootingOptions):
        raise InputTypeError(f"`settings` must be a ShootingOptions, got {type(settings).__name__}")
    # a transient is where an autonomous orbit's section and period come from: at least one
    if not forced and settings.transient_periods < 1:
        raise InputError(
            "ShootingOptions: `transient_periods` must be >= 1 for an autonomous orbit (its section and "
            f"period come from the transient), got {settings.transient_periods!r}"
        )


def failed_orbit(shooter, y, mode0, t0, it, res, msg: str, reason: str) -> PeriodicOrbit:
    """The failed result at the section state ``y`` (``reason``: a code of
    :data:`hybrid.core.status.SOLVE_REASONS`, ``msg`` the same in words)."""
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
        state_names=names,
        monodromy=np.full((ns, ns), nan),
        multipliers=np.full(ns, nan, dtype=complex),
        multiplier_kinds=("floquet",) * ns,
        stability="unknown",
        status=SolveStatus.FAILED,
        residual=float(res),
        iterations=it,
        condition=nan,
        family=False,
        message=msg,
        nfev=shooter.nfev,
        route="none",
        reason=reason,
    )


def finish_orbit(
    shooter, nw, y, mode0, t0, it, res_norm, tol, samples, note, tr=None, M=None, reason: str = ""
) -> PeriodicOrbit:
    """Build the orbit from its section state (``tr``, ``M``: its sampled run and monodromy, if known).

    ``note`` (text) heads its message; ``reason`` (a code of
    :data:`hybrid.core.status.SOLVE_REASONS`) marks a solution that is not accepted although its
    residual met ``tol`` (e.g. ``"mode-mismatch"``).
    """
    sys_ = shooter.system
    names = shooter.names
    tr = shooter.run_now(y, mode0, t0, samples) if tr is None else sampled_trajectory(tr)
    if M is None:
        M = shooter.monodromy(tr)
    s = shooter.s
    ns = s.size
    Ms = M[:ns, :ns]
    A = Ms[np.ix_(nw.pos, nw.pos)]
    IA = np.eye(nw.d.size) - A
    # the family test in balanced units, as Newton's method's; cond, the error bound reported, in
    # the state's own units (IDA controls each variable's error relative to its size: the balanced
    # cond, smaller where velocities are hundreds of times the displacements, could understate it)
    IAb, bsa = balanced(IA)
    g = shooter.gauge(y)
    svb = np.linalg.svd(IAb, compute_uv=False)
    family = is_family(svb)
    q = family_dimension(svb)
    picked = (
        g.pick(np.linalg.svd(IAb)[2], q, nw.d, bsa) if (family and g is not None) else np.zeros(0, dtype=int)
    )
    sv = np.linalg.svd(IA, compute_uv=False)
    # cond = largest / smallest singular value that counts (the family directions removed where
    # gauges fix them); inf where that one is 0, e.g. I - M = 0 (every state a periodic orbit).
    k = -1 - picked.size if sv.size > picked.size else -1
    cond = float(sv[0] / sv[k]) if sv.size and sv[k] > 0 else math.inf
    mult = np.concatenate([np.linalg.eigvals(A), np.zeros(ns - nw.d.size)])
    # Structural zeros: slave variables at the section, plus a dimension lost in any mode visited.
    nd = {m.name: sum(1 for i in s if m.is_diff[i]) for m in shooter.cs.modes}
    visited = {mode0} | {e.target for e in tr.events}
    n_struct = ns - min(nd[m] for m in visited)
    mtol = max(1e-6, 100.0 * shooter.noise_rtol)
    mult, kinds, verdict = _classify(mult, n_struct, family, mtol, q)
    # Amplitudes (variables and outputs): extrema located on the flow, not read from samples.
    amp, hpp = {}, {}
    ext = _Extrema(shooter.cs, tr, shooter.method.exact_flows(shooter.cs))
    series = {n: tr.y[:, i] for i, n in enumerate(names) if n not in sys_.quadratures}
    series.update({o: tr.outputs[o] for o in sys_.outputs})
    for n, x in series.items():
        hi, lo = ext.extremes(n, x)
        amp[n] = max(abs(hi), abs(lo))
        hpp[n] = 0.5 * (hi - lo)
    fr = mode_fractions(tr, shooter.period)
    # one switch per group of transitions at one instant (a mode passed through in no time is not
    # in the sequence; issue 30)
    sw = tr.switches
    seq = [mode0] + [e.target for e in sw]
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
        # the directions along the family (null vectors of I - M), named by their largest components
        V = np.abs(np.linalg.svd(IA)[2][-max(q, 1) :])
        mag = np.max(V, axis=0)
        along = [names[nw.d[i]] for i in np.flatnonzero(mag >= 0.3 * np.max(mag))]
        shown = ", ".join(along[:8]) + (", ..." if len(along) > 8 else "")
        msg += (
            f"a family of periodic orbits ({f'{q} neutral multipliers 1' if q > 1 else 'neutral multiplier 1'}; "
            f"the orbits differ along {shown}); "
        )
        if g is None:
            msg += (
                "the member nearest the guess is returned (the model declares no `[orbit] gauge`: an expression "
                "of the state that is 0 on the member wanted, e.g. a stuck element's offset, picks one; see README); "
            )
        elif not picked.size:
            msg += (
                f"none of the model's gauges ({g.describe(range(g.size))[:200]}) moves along it: the member "
                "nearest the guess is returned; "
            )
        else:
            msg += f"the member with {'gauges' if picked.size > 1 else 'gauge'} {g.describe(picked)} = 0 is returned; "
            if picked.size < q:
                msg += f"{q - picked.size} of its directions held by no gauge (nearest the guess there); "
    err = cond * shooter.noise_rtol
    if sv.size and sv[0] == 0.0:
        msg += (
            "I - M vanishes: every nearby state is periodic (the map leaves all of them unchanged), "
            "cond(I - M) is infinite; "
        )
    elif err > 1e-6:
        msg += f"I - M is ill-conditioned (cond {cond:.3g}): the orbit's state is accurate to about " + (
            f"cond x rtol = {err:.2g} (relative); tighten rtol for more; "
            if not shooter.method.flows_exact
            else f"cond x rounding = {err:.2g} (relative); "
        )
    if not reason and not res_norm <= tol:
        reason = "not-converged"
    conv = not reason
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
        switch_times=np.array([e.t - t0 for e in sw]),
        mode_fractions=fr,
        state_names=tuple(names[i] for i in s),
        monodromy=Ms,
        multipliers=mult,
        multiplier_kinds=kinds,
        stability=verdict,
        status=SolveStatus.CONVERGED if conv else SolveStatus.FAILED,
        residual=res_norm,
        iterations=it,
        condition=cond,
        family=family,
        message=msg.strip("; "),
        energy=energy,
        nfev=shooter.nfev,
        reason=reason,
    )


def stability_text(orbit) -> str:
    """The stability verdict in words, with the multipliers that decide it.

    A neutral orbit of a family has a multiplier exactly 1 that belongs to the family (kind
    ``"neutral"``), apart from its Floquet multipliers: the text says so, and gives the largest
    of the others, so that ``|mu| = 0.55`` is never read as the multiplier on the circle.

    Parameters
    ----------
    orbit : PeriodicOrbit

    Returns
    -------
    str
    """
    fl = np.abs(np.asarray(orbit.floquet_multipliers))
    n_family = sum(1 for k in orbit.multiplier_kinds if k == "neutral")
    largest = f"largest |mu| = {fl.max():.9g}" if fl.size else ""
    if orbit.stability == "stable":
        return "stable: every Floquet multiplier inside the unit circle" + (
            f" ({largest})" if largest else ""
        )
    if orbit.stability == "unstable":
        return "UNSTABLE: a Floquet multiplier outside the unit circle" + (f" ({largest})" if largest else "")
    if orbit.stability == "neutral":
        if n_family:
            rest = (
                f"; the other Floquet multipliers inside the unit circle ({largest})"
                if fl.size and fl.max() < 1.0 - 1e-6
                else (
                    f"; the other Floquet multipliers on the unit circle too ({largest})" if largest else ""
                )
            )
            return (
                f"neutral (marginally stable): {n_family} multiplier{'s' * (n_family > 1)} exactly 1 from the family "
                "of orbits (a free offset)" + rest
            )
        return "neutral (marginally stable): a Floquet multiplier on the unit circle" + (
            f" ({largest})" if largest else ""
        )
    return orbit.stability
