"""Branches of an autonomous system in one parameter: equilibria, Hopf points, periodic orbits.

* :func:`equilibrium_branch`: the equilibria of one mode over a grid of parameter values (each
  from its neighbour), with every loss of stability located (:func:`hybrid.orbits.equilibria.locate_hopf`);
* :func:`hopf_branch`: the periodic orbits born at a Hopf point, started from the critical
  eigenvector (the predictor is a small displacement along ``Re q``, the corrector the
  pseudo-arclength one of :mod:`hybrid.continuation.palc`), period along the branch;
* :func:`orbit_branch`: a branch of autonomous orbits from a computed one (any phase
  condition).

A branch of orbits that meets a switch it did not have (a grazing: e.g. a smooth cycle that
touches a switching surface) stops there when asked (``stop_on_mode_change``): beyond it the
orbit is another kind (a stick-slip cycle), computed as its own branch.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field

import numpy as np

from ..core.errors import InputError, ParameterOutOfDomain
from ..core.options import SolverOptions
from ..model.system import HybridSystem
from ..orbits.autonomous import AutonomousSolver, finish, resolve_phase
from ..orbits.equilibria import Equilibrium, equilibrium, locate_hopf
from ..orbits.flowmap import FlowMap
from ..orbits.orbit import ORBIT_OPTIONS, PeriodicOrbit
from .palc import RETRY, PalcSettings, follow

__all__ = ["EquilibriumBranch", "OrbitBranch", "equilibrium_branch", "hopf_branch", "orbit_branch"]


@dataclass
class EquilibriumBranch:
    """Equilibria of one mode along a parameter.

    Attributes
    ----------
    parameter : str
    values : ndarray
        Parameter values of ``points``.
    points : list of Equilibrium
    changes : list of dict
        Each loss or gain of stability: ``kind`` (``"hopf"`` for a complex pair, ``"real"`` for a
        real eigenvalue), ``value`` (located), ``frequency`` [rad/s] (Hopf), ``equilibrium``.
    """

    parameter: str
    values: np.ndarray
    points: list
    changes: list = field(default_factory=list)


@dataclass
class OrbitBranch:
    """Autonomous periodic orbits along a parameter.

    Attributes
    ----------
    parameter : str
    values : ndarray
    orbits : list of PeriodicOrbit
        Their ``period`` varies along the branch.
    reason : str
        Why the branch ended (``"range"``, ``"max_points"``, ``"stalled"``, ``"mode change"``).
    special : list of dict
        ``kind`` (``"fold"``, ``"mode change"``), ``interval`` (the bracket of parameter values).
    """

    parameter: str
    values: np.ndarray
    orbits: list
    reason: str
    special: list = field(default_factory=list)


def equilibrium_branch(
    system: HybridSystem,
    params: Mapping[str, float],
    mode: str,
    parameter: str,
    values: Sequence[float],
    x0=None,
) -> EquilibriumBranch:
    """Equilibria of ``mode`` at each of ``values`` of ``parameter`` (each Newton from the last),
    with every change of stability between two values located.

    Raises
    ------
    ValueError
        Unknown parameter or mode, fewer than two values.
    """
    if parameter not in system.parameter_names:
        raise InputError(
            f"model `{system.name}` has no parameter `{parameter}`; parameters: {', '.join(system.parameter_names)}"
        )
    values = np.asarray(values, dtype=float)
    if values.ndim != 1 or values.size < 2:
        raise InputError("`values` must hold at least two parameter values")
    points: list[Equilibrium] = []
    guess = x0
    for v in values:
        eq = equilibrium(system, {**params, parameter: float(v)}, mode, guess)
        points.append(eq)
        if eq.converged:
            guess = eq.x
    changes = []
    for a, b in zip(points, points[1:], strict=False):
        if not (a.converged and b.converged):
            continue
        ra, rb = a.eigenvalues[0].real, b.eigenvalues[0].real
        if ra * rb < 0:
            p, eq = locate_hopf(
                system, params, mode, parameter, (a.params[parameter], b.params[parameter]), a.x
            )
            om = abs(float(eq.eigenvalues[0].imag))
            changes.append(
                {"kind": "hopf" if om > 1e-9 else "real", "value": p, "frequency": om, "equilibrium": eq}
            )
    return EquilibriumBranch(parameter, values, points, changes)


def _branch(
    fm: FlowMap,
    solver: AutonomousSolver,
    mode: str,
    y_base: np.ndarray,
    u0: np.ndarray,
    t0: np.ndarray,
    bounds,
    settings: PalcSettings,
    stop_on_mode_change: bool,
    samples: int,
    period: float,
    stop_on_mode_loss: bool = True,
) -> OrbitBranch:
    d, pos = solver.unknowns(mode)
    nd = d.size
    anchored = solver.phase == "anchor"
    cm = fm.mode(mode)
    state = {"anchor": None, "T": period, "modes": None}

    def unpack(u):
        y = y_base.copy()
        y[d] = u[:nd]
        fm.set_parameter(u[-1])
        return cm.solve_algebraic(0.0, y)

    def evaluate(u):
        y = unpack(u)
        if anchored:
            if not u[nd] > 0:
                raise ParameterOutOfDomain("nonpositive period")
            if state["anchor"] is None:
                f = fm.field(mode, y)[d]
                state["anchor"] = (y.copy(), f / np.linalg.norm(f))
            ev = fm.timed(y, mode, float(u[nd]))
        else:
            ev = fm.returned(y, mode, solver.phase, 3.0 * state["T"])
        anchor = state["anchor"] if anchored else None
        return solver.residual(ev, y, d, anchor), solver.jacobian(ev, d, pos, anchor), (y, ev)

    orbits: list[PeriodicOrbit] = []
    special: list[dict] = []

    def accept(u, info):
        y, ev = info
        T = float(u[nd]) if anchored else ev.time
        orbit = finish(solver, y, mode, T, ev, 0, 0.0, samples)
        modes = frozenset(orbit.mode_sequence)
        if orbits and modes != state["modes"]:
            # an orbit of another kind (a switch met, or a phase lost: with IDA also a switch missed
            # inside its guard's noise band near a grazing): approach the boundary instead
            if stop_on_mode_change or (state["modes"] - modes and stop_on_mode_loss):
                return RETRY
            special.append(
                {
                    "kind": "mode change",
                    "interval": sorted([orbits[-1].params[fm.free], orbit.params[fm.free]]),
                }
            )
        if orbits and orbit.period > PERIOD_JUMP * orbits[-1].period:
            return "period jump"  # a switch missed at a grazing (or an orbit of another kind): not kept
        orbits.append(orbit)
        state["modes"], state["T"] = modes, T
        if anchored:
            f = fm.field(mode, y)[d]
            state["anchor"] = (y.copy(), f / np.linalg.norm(f))
        if len(orbits) >= 3:
            p = [o.params[fm.free] for o in orbits[-3:]]
            if (p[1] - p[0]) * (p[2] - p[1]) < 0:
                special.append({"kind": "fold", "interval": sorted([p[0], p[2]])})
        return None

    points, reason = follow(evaluate, u0, t0, settings, index=len(u0) - 1, bounds=bounds, accept=accept)
    if orbits and (
        reason == "boundary"
        or (reason in ("stalled", "period jump") and guard_margin(fm, orbits[-1]) <= GRAZING_MARGIN)
    ):
        reason = "grazing"
        special.append({"kind": "grazing", "interval": [orbits[-1].params[fm.free]] * 2})
    values = np.array([o.params[fm.free] for o in orbits])
    return OrbitBranch(fm.free, values, orbits, reason, special)


#: A point whose period exceeds this multiple of its predecessor's ends the branch.
PERIOD_JUMP = 1.5

#: A branch that stalls with a guard within this distance (relative to the state) of firing
#: (or an orbit that touches a switch with a vanishing phase) ends at a grazing.
GRAZING_MARGIN = 1e-3


def guard_margin(fm: FlowMap, orbit: PeriodicOrbit) -> float:
    """How near the orbit comes to a switch it does not take, relative to ``max |y|``: the least
    distance from zero of each mode's guards on the fire side of their direction over the
    samples, or the shortest mode phase's fraction of the period (a phase about to vanish)."""
    tr = orbit.trajectory
    scale = max(float(np.max(np.abs(tr.y))), 1e-300)
    best = min(orbit.mode_fractions.values()) if len(orbit.mode_fractions) > 1 else math.inf
    for cm in fm.cs.modes:
        at_switch = np.isin(tr.t, [0.0, tr.t[-1], *(e.t for e in tr.events)])  # where guards are 0 anyway
        rows = np.flatnonzero((tr.mode == cm.name) & ~at_switch)
        if not rows.size or not cm.guards:
            continue
        dirs = np.array([g.direction for g in cm.guards], dtype=float)
        h = np.array([cm.guard_values(0.0, tr.y[k]) for k in rows])
        gap = np.where(dirs != 0, -dirs * h, np.abs(h))
        best = min(best, float(np.min(gap)) / scale)
    return best


def orbit_branch(
    orbit: PeriodicOrbit,
    parameter: str,
    bounds: tuple[float, float],
    *,
    direction: int = 1,
    phase: str = "auto",
    options: SolverOptions | None = None,
    settings: PalcSettings | None = None,
    stop_on_mode_change: bool = False,
    samples_per_period: int = 256,
) -> OrbitBranch:
    """Continue the autonomous orbit ``orbit`` in ``parameter`` (``direction`` +1: increasing).

    The branch goes on through a mode that an orbit gains (a new phase, e.g. both contacts stuck
    at once; noted in ``special``), and ends at a grazing where a phase vanishes (a mode lost) or,
    with ``stop_on_mode_change``, at any change of the modes visited.

    ``phase`` as in :func:`hybrid.orbits.autonomous.autonomous_orbit`; the orbit's own section state is
    the start (for a switch section, ``orbit`` must have been computed on that section).
    """
    system = orbit.system
    if parameter not in system.parameter_names:
        raise InputError(
            f"model `{system.name}` has no parameter `{parameter}`; parameters: {', '.join(system.parameter_names)}"
        )
    if direction not in (1, -1):
        raise InputError(f"`direction` must be 1 or -1, got {direction!r}")
    phase = resolve_phase(system, phase)
    options = ORBIT_OPTIONS if options is None else options
    settings = settings or PalcSettings()
    fm = FlowMap(system, orbit.params, options, orbit.period, free=parameter)
    solver = AutonomousSolver(fm, phase, settings.tol, settings.max_iter)
    d, _ = solver.unknowns(orbit.mode0)
    extra = [orbit.period] if phase == "anchor" else []
    u0 = np.concatenate([orbit.x0[d], extra, [orbit.params[parameter]]])
    t0 = np.zeros(u0.size)
    t0[-1] = direction
    return _branch(
        fm,
        solver,
        orbit.mode0,
        orbit.x0.copy(),
        u0,
        t0,
        bounds,
        settings,
        stop_on_mode_change,
        samples_per_period,
        orbit.period,
    )


def hopf_branch(
    eq: Equilibrium,
    parameter: str,
    bounds: tuple[float, float],
    *,
    options: SolverOptions | None = None,
    settings: PalcSettings | None = None,
    stop_on_mode_change: bool = True,
    samples_per_period: int = 256,
) -> OrbitBranch:
    """The periodic orbits born at the Hopf point ``eq`` (an equilibrium at the critical value).

    The first orbit is corrected from ``eq.x + ds Re(q)`` (``q`` the critical eigenvector,
    normalised) with period ``2 pi / omega``, on the hyperplane orthogonal to ``Re(q)``; the
    branch follows with the anchor phase condition, and (by default) stops where the orbit meets
    a switch (a grazing).
    """
    system = eq.system
    settings = settings or PalcSettings()
    options = ORBIT_OPTIONS if options is None else options
    lam, vec = np.linalg.eig(eq.jacobian)
    k = int(np.argmax(lam.real))
    om = abs(float(lam[k].imag))
    if not om > 0:
        raise InputError("the critical eigenvalue of `eq` is real: not a Hopf point")
    q = vec[:, k]
    q = q * np.exp(-1j * np.angle(q[np.argmax(np.abs(q))]))  # largest component real
    qr = q.real / np.linalg.norm(q.real)
    T = 2.0 * math.pi / om
    fm = FlowMap(system, eq.params, options, T, free=parameter)
    solver = AutonomousSolver(fm, "anchor", settings.tol, settings.max_iter)
    d, _ = solver.unknowns(eq.mode)
    x_eq = eq.x[d]
    u0 = np.concatenate([x_eq + settings.ds * qr, [T, eq.params[parameter]]])
    t0 = np.concatenate([qr, [0.0, 0.0]])
    return _branch(
        fm, solver, eq.mode, eq.x.copy(), u0, t0, bounds, settings, stop_on_mode_change, samples_per_period, T
    )
