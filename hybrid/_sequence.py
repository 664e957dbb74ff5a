"""Periodic orbits of affine modes on a fixed switching sequence: Newton in the switch times.

Where every mode is affine (:mod:`hybrid._exact`), a run of one period that
switches at times ``t_1 < ... < t_N`` through the modes ``m_0, m_1, ..., m_N = m_0``
is a product of exact linear maps of the augmented state ``z = [y_d, S, C, 1]``::

    z_k^- = expm(M_{k-1} (t_k - t_{k-1})) z_{k-1}^+,    z_k^+ = J_k z_k^-,

(``J_k``: the full state read in the old mode, the transition's reset applied,
the new mode's differential variables kept, its slave variables re-solved by
its flow; a chain of switches at one instant composes its steps). Resets must
be affine in the state and free of ``t``; their matrix is taken at the guess. The periodic orbit
with that sequence solves ``N + n_d`` equations in ``N + n_d`` unknowns, the
section state ``y_d`` and the switch times::

    W_k z_k^- = 0    (the guard that fired, k = 1..N),    z_T[:n_d] = y_d,

smooth in the unknowns (exponentials of the times, linear in the state), with an
exact Jacobian by forward propagation (``d z / d t_k = M z`` at a switch). One
Newton iteration costs ``N + 1`` small matrix exponentials instead of an
event-driven run and a monodromy, and the iteration does not re-locate
switches, so its convergence is not slowed by the switch times' implicit
dependence on the state (:func:`hybrid._shooting.newton` from a continuation
neighbour took 4 to 6 runs and monodromies on the absorber's stick-slip band).

The result is a *candidate* only: a guard of the sequence that would fire in
the other direction, or a guard outside the sequence that fires first, is not
seen here. :func:`hybrid._shooting.newton` therefore accepts it only after an
ordinary event-driven run from it returns to it (and judges the correction with
the exact monodromy there), and otherwise goes on from its own iterate.
"""

from __future__ import annotations

import numpy as np

from ._exact import AffineMode

__all__ = ["solve_sequence"]

#: Newton iterations allowed on the switch times and section state.
MAX_ITER = 12

#: Converged when the last Newton update is below this, relative to the state's size and the period.
STEP_TOL = 1e-12

#: Largest condition number of the Newton matrix accepted (a family of orbits makes it singular).
MAX_COND = 1e11


def _jump(a: AffineMode, b: AffineMode, R_y: np.ndarray, r0: np.ndarray) -> np.ndarray | None:
    """``J`` with ``z_b = J z_a`` at a switch with the affine reset ``y+ = R_y y- + r0`` (None
    where the forcing parts of the two modes differ)."""
    nfa, nfb = a.nz - a.d.size, b.nz - b.d.size
    if nfa != nfb:
        return None  # one mode forced, the other not: S and C are not linear in the switch time
    L = R_y @ a.P
    L[:, -1] += r0  # the last component of z is the constant 1
    J = np.zeros((b.nz, a.nz))
    J[: b.d.size] = L[b.d]
    J[b.d.size :, a.d.size :] = np.eye(nfa)
    return J


def solve_sequence(
    modes: list[AffineMode],
    mode0: int,
    t0: float,
    period: float,
    y0: np.ndarray,
    events: list[tuple[float, int, int, int, np.ndarray]],
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
    events : list of (t, source, guard index, target, J)
        The guess's switches within ``(t0, t0 + period)``, one per instant (a chain of switches
        at one instant as its first guard and the mode it ends in), with the jump matrices of
        :func:`sequence_events`.

    Returns
    -------
    ndarray or None
        ``y_d`` (the differential variables of ``mode0``, in its order), or None when the sequence
        does not apply (forcing parts that differ, a switch time leaving its order, a singular or
        ill-conditioned Newton matrix, no convergence within :data:`MAX_ITER` iterations).
    """
    n = len(events)
    if n == 0:
        return None
    seq = [mode0] + [e[3] for e in events]
    if seq[-1] != mode0 or any(e[1] != seq[k] for k, e in enumerate(events)):
        return None
    jumps = [e[4] for e in events]
    a0 = modes[mode0]
    nd = a0.d.size
    u = np.concatenate([np.asarray(y0, dtype=float)[a0.d], [e[0] for e in events]])
    forcing0 = a0.augment(t0, np.zeros(a0.P.shape[0]))[nd:]
    t_end = t0 + period
    scale_t = period
    for _ in range(MAX_ITER):
        times = np.concatenate([[t0], u[nd:], [t_end]])
        if not np.all(np.diff(times) > 0.0):
            return None
        F, JF = _residual(modes, seq, jumps, events, u, nd, forcing0, times)
        if not (np.all(np.isfinite(F)) and np.all(np.isfinite(JF))):
            return None
        try:
            du = np.linalg.solve(JF, -F)
        except np.linalg.LinAlgError:
            return None
        if not np.all(np.isfinite(du)) or np.linalg.cond(JF) > MAX_COND:
            return None
        u = u + du
        scale_y = max(float(np.max(np.abs(u[:nd]))) if nd else 0.0, 1e-300)
        if (not nd or float(np.max(np.abs(du[:nd]))) <= STEP_TOL * scale_y) and float(
            np.max(np.abs(du[nd:]))
        ) <= STEP_TOL * scale_t:
            times = np.concatenate([[t0], u[nd:], [t_end]])
            return u[:nd] if np.all(np.diff(times) > 0.0) else None
    return None


def _residual(modes, seq, jumps, events, u, nd, forcing0, times) -> tuple[np.ndarray, np.ndarray]:
    """The equations (guards, then periodicity) and their Jacobian in ``u = [y_d, t_1..t_N]``."""
    n = len(events)
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
            w = am.W[events[k][2]]
            F[k] = float(w @ z)
            JF[k] = w @ D
            z = jumps[k] @ z
            D = jumps[k] @ D
    F[n:] = z[:nd] - u[:nd]
    JF[n:] = D[:nd]
    JF[n:, :nd] -= np.eye(nd)
    return F, JF


def sequence_events(tr, cs, t0: float, period: float) -> list[tuple] | None:
    """The switches of a one-period run as ``(t, source, guard index, target, J)`` per instant for
    :func:`solve_sequence`; None where it does not apply (a switch at the ends of the period, a
    reset that depends on ``t`` or reads a quadrature, forcing parts that differ between modes)."""
    from ._variational import _ResetJacobians

    modes = cs.affine()
    quads = set(cs.system.quadratures)
    resets = _ResetJacobians()
    out: list[list] = []
    for ev in tr.events:
        if not t0 < ev.t < t0 + period:
            return None
        src, dst = cs.mode_id(ev.source), cs.mode_id(ev.target)
        cm = cs.modes[src]
        k = next((g.index for g in cm.guards if g.name == ev.guard), None)
        if k is None or cm.guards[k].target != dst:
            return None
        reset = cm.guards[k].reset_expr
        if any(("t" in e.free) or (e.free & quads) for _, e in reset):
            return None
        if reset:
            R_y, _ = resets(cm, k, ev.t, ev.x_minus)
            x = np.asarray(ev.x_minus, dtype=float)
            v = [ev.t, *x.tolist()]
            after = x.copy()
            for i, fn in cm.guards[k].reset:
                after[i] = fn(v)
            r0 = after - R_y @ x  # exact for an affine reset
        else:
            R_y, r0 = np.eye(cm.n), np.zeros(cm.n)
        J = _jump(modes[src], modes[dst], R_y, r0)
        if J is None:
            return None
        if ev.chained:
            if not out or out[-1][3] != src:
                return None
            out[-1][3] = dst
            out[-1][4] = J @ out[-1][4]
        else:
            out.append([float(ev.t), src, k, dst, J])
    return [tuple(e) for e in out] or None
