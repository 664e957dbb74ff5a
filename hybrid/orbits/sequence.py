"""Periodic orbits of affine modes on a fixed switching sequence: Newton in the switch times.

Where every mode is affine (:mod:`hybrid.integrators.exact`), a run of one period that
switches at times ``t_1 < ... < t_N`` through the modes ``m_0, m_1, ..., m_N = m_0``
is a product of exact linear maps of the augmented state ``z = [y_d, S, C, 1]``::

    z_k^- = expm(M_{k-1} (t_k - t_{k-1})) z_{k-1}^+,    z_k^+ = J_k z_k^-,

(``J_k``: the full state read in the old mode, the transition's reset applied,
the new mode's differential variables kept, its slave variables re-solved by
its flow; a chain of switches at one instant composes its steps). Resets must
be affine in the state and free of ``t``; their matrix is taken at the guess.
The periodic orbit with that sequence solves ``N + n_d`` equations in ``N + n_d`` unknowns, the
section state ``y_d`` and the switch times::

    W_k z_k^- = 0    (the guard that fired, k = 1..N),    z_T[:n_d] = y_d,

smooth in the unknowns (exponentials of the times, linear in the state), with an
exact Jacobian by forward propagation (``d z / d t_k = M z`` at a switch). One
Newton iteration costs ``N + 1`` small matrix exponentials (about 0.08 ms on
the absorber's stick-slip band, where it takes about 5 of them from a continuation
neighbour) instead of an event-driven run and a monodromy (about 1.1 and 0.23 ms;
:func:`hybrid.orbits.shooting.newton` alone took 4 to 6 of each there).

The result is a *candidate* only: a guard of the sequence that would fire in
the other direction, or a guard outside the sequence that fires first, is not
seen here. :func:`hybrid.orbits.shooting.newton` therefore accepts it only after an
ordinary event-driven run from it returns to it (and judges the correction with
the exact monodromy there), and otherwise goes on from its own iterate.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from functools import lru_cache

import numpy as np

from ..core.errors import NotAffineError
from ..engine.variational import ResetJacobians
from ..integrators.affine import AffineMode, affine_coefficients
from ..model.expr import Expr

__all__ = ["Switch", "sequence_events", "solve_sequence"]

#: Newton iterations allowed on the switch times and section state.
MAX_ITER = 12

#: Converged when the last Newton update is below this, relative to the state's size and the period.
STEP_TOL = 1e-12

#: Each Newton update at most this fraction of the one before (else the guess is given up).
CONTRACTION = 0.5

#: Largest condition number of the Newton matrix accepted (a family of orbits makes it singular).
MAX_COND = 1e11


def _jump(a: AffineMode, b: AffineMode, R_y: np.ndarray, r0: np.ndarray) -> np.ndarray | None:
    """``J`` with ``z_b = J z_a`` at a switch with the affine reset ``y+ = R_y y- + r0`` (None
    where the forcing parts of the two modes differ)."""
    nfa, nfb = a.nz - a.d.size, b.nz - b.d.size
    if nfa != nfb or a.harmonics != b.harmonics:
        return None  # the forcing parts differ (one mode forced, the other not; other harmonics)
    L = R_y @ a.P
    L[:, -1] += r0  # the last component of z is the constant 1
    J = np.zeros((b.nz, a.nz))
    J[: b.d.size] = L[b.d]
    J[b.d.size :, a.d.size :] = np.eye(nfa)
    return J


@dataclass(frozen=True)
class Switch:
    """One switch instant of the guess: its time [s] and the transitions taken there, in order
    (more than one for a chain), each as ``(source, guard index, target, R_y, r0)`` with the
    affine reset ``y+ = R_y y- + r0``."""

    t: float
    steps: tuple

    @property
    def source(self) -> int:
        return self.steps[0][0]

    @property
    def guard(self) -> int:
        return self.steps[0][1]

    @property
    def target(self) -> int:
        return self.steps[-1][2]


def _jumps(modes: list[AffineMode], switches: list[Switch]) -> list[np.ndarray] | None:
    """The jump matrix of every switch instant (a chain's steps composed), or None."""
    out = []
    for sw in switches:
        J = None
        for src, _, dst, R_y, r0 in sw.steps:
            Jk = _jump(modes[src], modes[dst], R_y, r0)
            if Jk is None:
                return None
            J = Jk if J is None else Jk @ J
        out.append(J)
    return out


def _sequence(mode0: int, switches: list[Switch]) -> list[int] | None:
    """The modes visited, ``[mode0, ..., mode0]``, or None where the switches do not chain."""
    if not switches:
        return None
    seq = [mode0] + [sw.target for sw in switches]
    if seq[-1] != mode0 or any(sw.source != seq[k] for k, sw in enumerate(switches)):
        return None
    return seq


def solve_sequence(
    modes: list[AffineMode],
    mode0: int,
    t0: float,
    period: float,
    y0: np.ndarray,
    switches: list[Switch],
) -> np.ndarray | None:
    """The section state ``y_d`` of the periodic orbit that follows a switching sequence, or None.

    Parameters
    ----------
    modes : list of AffineMode
        Every mode's exact flow (index = mode index).
    mode0 : int
        Mode at the section (the sequence returns to it at ``t0 + period``).
    t0, period : float
        Section time and period [s].
    y0 : ndarray
        Guess of the full state at the section (its differential variables of ``mode0`` are read).
    switches : list of Switch
        The guess's switch instants within ``(t0, t0 + period)``, in order
        (:func:`sequence_events`).

    Returns
    -------
    ndarray or None
        ``y_d`` (the differential variables of ``mode0``, in its order), or None when the sequence
        does not apply (forcing parts that differ, a switch time leaving its order, a singular or
        ill-conditioned Newton matrix, no convergence within :data:`MAX_ITER` iterations).
    """
    seq = _sequence(mode0, switches)
    jumps = _jumps(modes, switches) if seq is not None else None
    if jumps is None:
        return None
    a0 = modes[mode0]
    nd = a0.d.size
    u = np.concatenate([np.asarray(y0, dtype=float)[a0.d], [sw.t for sw in switches]])
    forcing0 = a0.augment(t0, np.zeros(a0.P.shape[0]))[nd:]

    def equations(u):
        times = np.concatenate([[t0], u[nd:], [t0 + period]])
        if not np.all(np.diff(times) > 0.0):
            return None
        return _residual(modes, seq, jumps, switches, u, nd, forcing0, times)

    u = _newton(equations, u, nd, period)
    return None if u is None else u[:nd]


def _newton(equations, u: np.ndarray, nd: int, period: float) -> np.ndarray | None:
    """Newton's method on ``equations(u) -> (F, dF/du)`` (None: out of its domain) to an update
    below :data:`STEP_TOL` relative (the state to its size, the switch times to the period).

    Each update must be at most :data:`CONTRACTION` times the one before (in that relative
    measure): a guess outside Newton's region of contraction is given up (None) rather than
    followed, since the iteration may then reach another orbit with the same switching
    sequence, far from the guess (an impact oscillator 19 % away in the forcing frequency went
    to an unstable orbit while Newton's method on the period map stayed on the stable branch)."""
    last = math.inf
    for _ in range(MAX_ITER):
        out = equations(u)
        if out is None:
            return None
        F, JF = out
        if not (np.all(np.isfinite(F)) and np.all(np.isfinite(JF))):
            return None
        try:
            du = np.linalg.solve(JF, -F)
        except np.linalg.LinAlgError:
            return None
        if not np.all(np.isfinite(du)) or np.linalg.cond(JF) > MAX_COND:
            return None
        size = np.full(u.size, period)
        size[:nd] = max(float(np.max(np.abs(u[:nd]))) if nd else 0.0, 1e-300)
        step = float(np.max(np.abs(du) / size))
        if step > CONTRACTION * last and step > STEP_TOL:
            return None
        last = step
        u = u + du
        if step <= STEP_TOL:
            return u if equations(u) is not None else None
    return None


def _residual(modes, seq, jumps, switches, u, nd, forcing0, times) -> tuple[np.ndarray, np.ndarray]:
    """The equations (guards, then periodicity) and their Jacobian in ``u = [y_d, t_1..t_N]``."""
    n = len(switches)
    nu = nd + n
    z = np.concatenate([u[:nd], forcing0])
    D = np.zeros((z.size, nu))
    D[:nd, :nd] = np.eye(nd)
    F = np.empty(nu)
    JF = np.empty((nu, nu))
    for k in range(n + 1):
        am = modes[seq[k]]
        E = am.flow().matrix(float(times[k + 1] - times[k]))
        z = E @ z
        D = E @ D
        v = am.M @ z  # d z / d (end of the segment); minus it for its start
        if k < n:
            D[:, nd + k] += v
        if k > 0:
            D[:, nd + k - 1] -= v
        if k < n:
            w = am.W[switches[k].guard]
            F[k] = float(w @ z)
            JF[k] = w @ D
            z = jumps[k] @ z
            D = jumps[k] @ D
    F[n:] = z[:nd] - u[:nd]
    JF[n:] = D[:nd]
    JF[n:, :nd] -= np.eye(nd)
    return F, JF


@lru_cache(maxsize=256)
def _affine(e: Expr, names: tuple[str, ...]) -> bool:
    """True if ``e`` is affine in the variables ``names`` (the exact integrator's test)."""
    try:
        affine_coefficients(e, list(names), frozenset(e.free - set(names)), "a reset")
    except NotAffineError:
        return False
    return True


def sequence_events(tr, cs, t0: float, period: float) -> list[Switch] | None:
    """The switch instants of a one-period run for :func:`solve_sequence`; None where it does not
    apply (a switch at the ends of the period, a reset that is not affine in the state or that
    depends on ``t`` or on a quadrature)."""

    quads = set(cs.system.quadratures)
    resets = ResetJacobians()
    out: list[Switch] = []
    for ev in tr.events:
        if not t0 < ev.t < t0 + period:
            return None
        src, dst = cs.mode_id(ev.source), cs.mode_id(ev.target)
        cm = cs.modes[src]
        k = cm.guard_slot(ev.guard)
        if k is None or cm.guards[k].target != dst:
            return None
        reset = cm.guards[k].reset_expr
        if any(("t" in e.free) or (e.free & quads) or not _affine(e, cm.names) for _, e in reset):
            return None
        R_y, _ = resets(cm, k, ev.t, ev.x_minus)  # the identity without a reset
        # the reset's constant part from the logged states (exact for an affine reset on the target
        # mode's differential variables, the only rows the jump reads: its slave rows are re-solved)
        r0 = np.asarray(ev.x_plus, dtype=float) - R_y @ np.asarray(ev.x_minus, dtype=float)
        step = (src, k, dst, R_y, r0)
        if ev.chained and not ev.coincident:
            if not out or out[-1].target != src:
                return None
            out[-1] = Switch(out[-1].t, (*out[-1].steps, step))
        else:
            out.append(Switch(float(ev.t), (step,)))
    return out or None
