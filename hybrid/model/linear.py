"""Linearisation of one mode at a state: Jacobian of the reduced ODE and natural frequencies.

Used to choose a default frequency range (``hybrid frc``) without model knowledge:
the resonances of the initial mode linearised at the zero state.
"""

from __future__ import annotations

from collections.abc import Mapping

import numpy as np

from ..core.errors import InputError
from .compiled import CompiledSystem
from .system import HybridSystem

__all__ = ["reduced_jacobian", "natural_frequencies", "mode_eigenvalues"]


def reduced_jacobian(
    system: HybridSystem,
    params: Mapping[str, float],
    mode: str | None = None,
    y=None,
    t: float = 0.0,
) -> tuple[tuple[str, ...], np.ndarray]:
    """Jacobian of a mode's vector field with its slave variables eliminated.

    The mode's DAE is ``x' = f(t, x, z)``, ``0 = g(t, x, z)`` (``x`` its
    differential variables without the quadratures, ``z`` its slave variables).
    Along the constraint ``dz/dx = -g_z^{-1} g_x``, so the linearised flow is
    ``x' = A x`` with ``A = f_x - f_z g_z^{-1} g_x``.

    Parameters
    ----------
    system : HybridSystem
    params : mapping of str to float
        All parameter values.
    mode : str, optional
        Mode (default: the model's initial mode).
    y : array_like, shape (n_vars,), optional
        State over ``system.variable_names`` (default: all 0); its slave
        variables are solved from the mode's algebraic equations first.
    t : float
        Time of the linearisation [s] (matters only for explicitly
        time-dependent Jacobians; the forcing term of a linear model does not enter).

    Returns
    -------
    names : tuple of str
        The differential variables of ``A``, in state order.
    A : ndarray, shape (n, n)
    """
    mode = mode if mode is not None else system.default_mode
    if mode is None:
        raise InputError(f"model `{system.name}` declares no initial mode: name the mode to linearise")
    cs = CompiledSystem(system, params)
    cm = cs.modes[cs.mode_id(mode)]
    y = np.zeros(cm.n) if y is None else np.asarray(y, dtype=float)
    y = cm.solve_algebraic(t, y)
    d, A = _reduced(cm, t, y, {system.variable_names.index(q) for q in system.quadratures})
    return tuple(system.variable_names[i] for i in d), A


def _reduced(cm, t: float, y: np.ndarray, quad: set[int]) -> tuple[np.ndarray, np.ndarray]:
    d = np.array([i for i in cm.diff_idx if i not in quad], dtype=int)
    a = cm.alg_idx
    J = cm.dFdy(t, y)  # rows: -f_y (differential), g_y (slave)
    A = -J[np.ix_(d, d)]
    if a.size:
        A = A + J[np.ix_(d, a)] @ np.linalg.solve(J[np.ix_(a, a)], J[np.ix_(a, d)])
    return d, A


def fast_dynamics(
    cm, t: float, y: np.ndarray, quad: set[int], *, period: float | None, per_eval: float, max_step: float
) -> str:
    """Why a run is slow, as a clause for a message: the time it advances per residual evaluation
    and, when that is far below the step bound, the fastest eigenvalue of ``cm`` linearised at ``y``."""
    msg = f"; the run advanced {per_eval:.3g} s per evaluation (step bound {max_step:.3g} s)"
    if per_eval >= 1e-3 * max_step:
        return msg
    try:
        lam = mode_eigenvalues(cm, t, cm.solve_algebraic(t, y), quad)
    except Exception:  # a diagnosis only
        return msg
    if not (lam.size and np.all(np.isfinite(lam))):
        return msg
    w = float(np.max(np.abs(lam)))
    ratio = w * period / (2 * np.pi) if period else None
    if ratio is not None and ratio < 100:
        return msg
    msg += f": mode `{cm.name}` linearised here has an eigenvalue of modulus {w:.3g} 1/s"
    if ratio is not None:
        msg += f", {ratio:.3g} times the forcing frequency"
    return msg + " (dynamics far faster than the forcing: check the parameters)"


def mode_eigenvalues(cm, t: float, y: np.ndarray, quad: set[int]) -> np.ndarray:
    """Eigenvalues of a compiled mode's reduced Jacobian at a consistent state (quadratures ``quad`` left out)."""
    _, A = _reduced(cm, t, y, quad)
    return np.linalg.eigvals(A) if A.size else np.zeros(0, dtype=complex)


def natural_frequencies(
    system: HybridSystem,
    params: Mapping[str, float],
    mode: str | None = None,
    y=None,
    t: float = 0.0,
) -> np.ndarray:
    """Undamped natural frequencies [rad/s] of a mode linearised at a state (default: zero state).

    The moduli ``|lambda|`` of the eigenvalues of :func:`reduced_jacobian`
    with a positive imaginary part (one per oscillating pair; ``|lambda| = omega``
    for an undamped mode, the undamped natural frequency for a damped one).

    Parameters
    ----------
    system, params, mode, y, t
        As for :func:`reduced_jacobian`.

    Returns
    -------
    ndarray, shape (n_osc,)
        Ascending; empty if the linearisation has no oscillating mode.

    Examples
    --------
    >>> import hybrid_models
    >>> from hybrid.model.linear import natural_frequencies
    >>> absorber = hybrid_models.absorber()
    >>> natural_frequencies(absorber, absorber.preset("standard")).round(4)
    array([0.8543, 1.1705])
    """
    _, A = reduced_jacobian(system, params, mode, y, t)
    if A.size == 0:
        return np.zeros(0)
    lam = np.linalg.eigvals(A)
    scale = max(float(np.max(np.abs(lam))), 1e-300)
    osc = lam[lam.imag > 1e-9 * scale]
    return np.sort(np.abs(osc))
