"""Karnopp-friction reference model of both dampers (Aramendiz et al., Eqs. 10-13).

The paper's smoothed stick-slip model, read as one ODE that is integrated by
:func:`scipy.integrate.solve_ivp` without event location. All forces follow from the
integrated state, including the connecting point ``u`` of the friction-spring element:

* absorber: ``H = c2 (u - x1) - c3 (x2 - u)``, ``v_r = c2 (v2 - v1) / (c2 + c3)``;
  ``u' = v2`` while sticking and ``u' = (c2 v1 + c3 v2) / (c2 + c3)`` while slipping.
* isolator: ``H = c1 (x1 - u) - c3 u``, ``v_r = c1 v1 / (c1 + c3)``;
  ``u' = 0`` while sticking and ``u' = v_r`` while slipping.

The element slips iff ``|H| >= R`` and ``sign(H) v_r > nu``; while slipping ``H' = 0``, so the
friction force stays at the value where slipping began. ``v_r`` is the rate of the friction
element's relative displacement while slipping, so the dissipation rate is ``H v_r`` there
and 0 while sticking. Along exact solutions ``W - D = E(t) - E(0)`` with ``W`` the work of the
excitation, ``D`` the dissipated energy and ``E`` from :func:`mechanical_energy`.

Parameters are plain dicts with keys ``m1, m2`` [kg], ``c1, c2, c3`` [N/m], ``R, F`` [N] and
``Omega`` [rad/s]. States are ordered ``(x1, v1, x2, v2, u)`` [m, m/s, m, m/s, m].
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray
from scipy.integrate import solve_ivp

from models.linear import check_model, check_params

_KEYS = ("m1", "m2", "c1", "c2", "c3", "R", "F", "Omega")
Rhs = Callable[[float, NDArray[np.float64]], NDArray[np.float64]]


def _check_nu(nu: float) -> float:
    if not (isinstance(nu, (int, float, np.floating)) and nu > 0.0 and math.isfinite(nu)):
        raise ValueError(f"nu must be a finite float > 0 (Karnopp velocity band, m/s), got {nu!r}")
    return float(nu)


def _absorber_rhs(p: dict[str, float], nu: float) -> Rhs:
    m1, m2, c1, c2, c3, R, F, om = (float(p[k]) for k in _KEYS)
    c23 = c2 + c3
    a2 = c2 / c23
    a3 = c3 / c23
    sin = math.sin
    array = np.array

    def rhs(t: float, y: NDArray[np.float64]) -> NDArray[np.float64]:
        x1, v1, x2, v2, u, _, _ = y.tolist()
        h = c2 * (u - x1) - c3 * (x2 - u)
        vr = a2 * (v2 - v1)
        f = F * sin(om * t)
        s1 = c2 * (x1 - u)
        acc1 = (f - c1 * x1 - s1) / m1
        # slip iff |h| >= R and sign(h) * vr > nu (h == 0 never slips, even for R == 0)
        if (h >= R and h > 0.0 and vr > nu) or (h <= -R and h < 0.0 and vr < -nu):
            return array([v1, acc1, v2, s1 / m2, a2 * v1 + a3 * v2, f * v1, h * vr])
        return array([v1, acc1, v2, s1 / m2, v2, f * v1, 0.0])

    return rhs


def _isolator_rhs(p: dict[str, float], nu: float) -> Rhs:
    m1, m2, c1, c2, c3, R, F, om = (float(p[k]) for k in _KEYS)
    a1 = c1 / (c1 + c3)
    sin = math.sin
    array = np.array

    def rhs(t: float, y: NDArray[np.float64]) -> NDArray[np.float64]:
        x1, v1, x2, v2, u, _, _ = y.tolist()
        s1 = c1 * (x1 - u)
        h = s1 - c3 * u
        vr = a1 * v1
        f = F * sin(om * t)
        s2 = c2 * (x1 - x2)
        acc1 = (f - s1 - s2) / m1
        # slip iff |h| >= R and sign(h) * vr > nu (h == 0 never slips, even for R == 0)
        if (h >= R and h > 0.0 and vr > nu) or (h <= -R and h < 0.0 and vr < -nu):
            return array([v1, acc1, v2, s2 / m2, vr, f * v1, h * vr])
        return array([v1, acc1, v2, s2 / m2, 0.0, f * v1, 0.0])

    return rhs


def rhs(model: str, params: dict[str, float], nu: float) -> Rhs:
    """Right-hand side of the Karnopp model augmented with the energy integrals.

    Parameters
    ----------
    model : str
        ``"absorber"`` or ``"isolator"``.
    params : dict[str, float]
        Damper parameters.
    nu : float
        Half width of the Karnopp stick band of ``v_r`` [m/s], > 0.

    Returns
    -------
    callable
        ``f(t, y) -> dy/dt`` for the 7-vector ``y = (x1, v1, x2, v2, u, W, D)``, with ``t`` in
        [s], ``W`` the work done by the excitation [J] and ``D`` the dissipated energy [J].

    Raises
    ------
    ValueError
        For an unknown ``model``, a non-positive ``nu`` or invalid ``params``.
    """
    check_model(model)
    check_params(params)
    nu = _check_nu(nu)
    return _absorber_rhs(params, nu) if model == "absorber" else _isolator_rhs(params, nu)


def friction_state(
    model: str, params: dict[str, float], y: ArrayLike, nu: float
) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.bool_]]:
    """Friction force, slip-rate variable and stick flag for states ``y``.

    Parameters
    ----------
    model : str
        ``"absorber"`` or ``"isolator"``.
    params : dict[str, float]
        Damper parameters.
    y : array_like, shape (5,) or (n, 5)
        States ``(x1, v1, x2, v2, u)``.
    nu : float
        Karnopp band [m/s].

    Returns
    -------
    H : ndarray
        Force transmitted by the friction element [N] (``|H| <= R`` sticking, ``~R`` slipping).
    v_r : ndarray
        Slip rate of the friction element if it slips [m/s].
    sticking : ndarray of bool
        ``True`` where the Karnopp rule selects the stick phase.
    """
    check_model(model)
    check_params(params)
    nu = _check_nu(nu)
    yy = np.asarray(y, dtype=float)
    x1, v1, x2, v2, u = (yy[..., i] for i in range(5))
    c1, c2, c3, R = (params[k] for k in ("c1", "c2", "c3", "R"))
    if model == "absorber":
        h = c2 * (u - x1) - c3 * (x2 - u)
        vr = c2 * (v2 - v1) / (c2 + c3)
    else:
        h = c1 * (x1 - u) - c3 * u
        vr = c1 * v1 / (c1 + c3)
    slipping = (np.abs(h) >= R) & (np.sign(h) * vr > nu)
    return h, vr, ~slipping


def mechanical_energy(model: str, params: dict[str, float], y: ArrayLike) -> NDArray[np.float64]:
    """Kinetic energy of both masses plus the potential energy of the three springs.

    Parameters
    ----------
    model : str
        ``"absorber"`` (springs ``c1 x1^2/2``, ``c2 (u - x1)^2/2``, ``c3 (x2 - u)^2/2``) or
        ``"isolator"`` (``c1 (x1 - u)^2/2``, ``c3 u^2/2``, ``c2 (x1 - x2)^2/2``).
    params : dict[str, float]
        Damper parameters.
    y : array_like, shape (5,) or (n, 5)
        States ``(x1, v1, x2, v2, u)``.

    Returns
    -------
    ndarray, shape () or (n,)
        Mechanical energy [J].
    """
    check_model(model)
    check_params(params)
    yy = np.asarray(y, dtype=float)
    if yy.shape[-1] != 5 or yy.ndim > 2:
        raise ValueError(f"y must have shape (5,) or (n, 5), got {yy.shape}")
    x1, v1, x2, v2, u = (yy[..., i] for i in range(5))
    m1, m2, c1, c2, c3 = (params[k] for k in ("m1", "m2", "c1", "c2", "c3"))
    kinetic = 0.5 * (m1 * v1**2 + m2 * v2**2)
    if model == "absorber":
        springs = c1 * x1**2 + c2 * (u - x1) ** 2 + c3 * (x2 - u) ** 2
    else:
        springs = c1 * (x1 - u) ** 2 + c3 * u**2 + c2 * (x1 - x2) ** 2
    return kinetic + 0.5 * springs


@dataclass(frozen=True)
class KarnoppResult:
    """Output of :func:`simulate_karnopp`; arrays are time-major.

    Attributes
    ----------
    t : ndarray, shape (n,)
        Times [s].
    y : ndarray, shape (n, 5)
        States ``(x1, v1, x2, v2, u)`` [m, m/s, m, m/s, m].
    W : ndarray, shape (n,)
        Work done by the excitation since ``t[0]`` [J].
    D : ndarray, shape (n,)
        Energy dissipated by friction since ``t[0]`` [J].
    H : ndarray, shape (n,)
        Friction force of the element [N].
    v_r : ndarray, shape (n,)
        Slip rate variable of the Karnopp rule [m/s].
    sticking : ndarray of bool, shape (n,)
        Stick flag of the Karnopp rule.
    nfev : int
        Number of right-hand-side evaluations.
    success : bool
        Solver success flag.
    message : str
        Solver message.
    """

    t: NDArray[np.float64]
    y: NDArray[np.float64]
    W: NDArray[np.float64]
    D: NDArray[np.float64]
    H: NDArray[np.float64]
    v_r: NDArray[np.float64]
    sticking: NDArray[np.bool_]
    nfev: int
    success: bool
    message: str


def simulate_karnopp(
    model: str,
    params: dict[str, float],
    t_span: tuple[float, float],
    y0: ArrayLike,
    *,
    nu: float = 1e-6,
    method: str = "RK45",
    rtol: float = 1e-8,
    atol: float = 1e-10,
    t_eval: ArrayLike | None = None,
    max_step: float | None = None,
) -> KarnoppResult:
    """Integrate the Karnopp model with :func:`scipy.integrate.solve_ivp` (no events).

    Parameters
    ----------
    model : str
        ``"absorber"`` or ``"isolator"``.
    params : dict[str, float]
        Damper parameters.
    t_span : tuple of float
        Start and end time [s].
    y0 : array_like, shape (5,)
        Initial state ``(x1, v1, x2, v2, u)``; ``W`` and ``D`` start at 0.
    nu : float, optional
        Karnopp band [m/s], > 0.
    method : str, optional
        ``solve_ivp`` method.
    rtol, atol : float, optional
        ``solve_ivp`` tolerances (``atol`` applies to all 7 components).
    t_eval : array_like, optional
        Output times [s]; by default the solver's steps.
    max_step : float, optional
        Largest step [s]; by default a twentieth of the forcing period ``2 pi / Omega``.

    Returns
    -------
    KarnoppResult
        The trajectory with energies and friction diagnostics.

    Raises
    ------
    ValueError
        For an unknown ``model``, a non-positive ``nu``, invalid ``params`` or a ``y0`` that
        is not a 5-vector.
    """
    f = rhs(model, params, nu)
    y0_arr = np.asarray(y0, dtype=float)
    if y0_arr.shape != (5,):
        raise ValueError(f"y0 must have shape (5,) (x1, v1, x2, v2, u), got {y0_arr.shape}")
    if max_step is None:
        max_step = 2.0 * math.pi / abs(float(params["Omega"])) / 20.0
    sol = solve_ivp(
        f,
        t_span,
        np.concatenate([y0_arr, [0.0, 0.0]]),
        method=method,
        rtol=rtol,
        atol=atol,
        t_eval=t_eval,
        max_step=max_step,
    )
    ys = sol.y.T
    state = np.ascontiguousarray(ys[:, :5])
    h, vr, sticking = friction_state(model, params, state, nu)
    return KarnoppResult(
        t=sol.t,
        y=state,
        W=ys[:, 5].copy(),
        D=ys[:, 6].copy(),
        H=h,
        v_r=vr,
        sticking=sticking,
        nfev=int(sol.nfev),
        success=bool(sol.success),
        message=str(sol.message),
    )
