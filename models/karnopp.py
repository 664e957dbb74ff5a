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

Periodic orbits: :func:`shoot_karnopp`, the paper's shooting method with numerically computed
derivatives (a finite-difference monodromy), kept as the reference for the exact-monodromy
shooting of :func:`hybrid.periodic_orbit`.

Parameters are plain dicts with keys ``m1, m2`` [kg], ``c1, c2, c3`` [N/m], ``R, F`` [N] and
``Omega`` [rad/s]. States are ordered ``(x1, v1, x2, v2, u)`` [m, m/s, m, m/s, m].
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray
from scipy.integrate import OdeSolution, solve_ivp
from scipy.optimize import brentq

from hybrid_models.linear import check_model, check_params

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


@dataclass(frozen=True)
class KarnoppOrbit:
    """Periodic orbit of the Karnopp model found by :func:`shoot_karnopp`.

    Attributes
    ----------
    model : str
        ``"absorber"`` or ``"isolator"``.
    params : dict[str, float]
        Damper parameters used (a copy).
    nu : float
        Karnopp band [m/s].
    y0 : ndarray, shape (5,)
        State ``(x1, v1, x2, v2, u)`` [m, m/s, m, m/s, m] at ``t0`` on the orbit (the last Newton
        iterate if ``converged`` is ``False``).
    period : float
        Forcing period ``T = 2 pi / Omega`` [s]; the orbit has period ``T`` (period-1 orbits only).
    t0 : float
        Phase of the Poincare section: time [s] at which the orbit passes through ``y0``.
    multipliers : ndarray of complex, shape (5,)
        Floquet multipliers: eigenvalues of ``monodromy``, by decreasing modulus. A pure-stick
        orbit has one equal to 1 (the offset of the friction element is free); an orbit that
        slips has one near 0 (slipping erases that offset).
    monodromy : ndarray, shape (5, 5)
        Central-difference Jacobian ``dP/dy`` of the stroboscopic map ``P`` at ``y0``
        (dimensionless entries mixing [m] and [m/s]; all NaN if a solve failed).
    iterations : int
        Newton corrections applied (0 if ``y0_guess`` already met ``tol``).
    non_monotone : int
        Corrections taken although no trial step decreased ``max |P(y) - y|``.
    residual : float
        ``max_i |P(y0)_i - y0_i| / s`` with ``s = max(max_i |y0_i|, max_i |P(y0)_i|)``, the
        max-norm of the state at the section, ``P`` the map over one period (dimensionless;
        the components mix [m] and [m/s], comparable for ``Omega`` near 1 rad/s). 0 if
        ``P(y0) = y0`` exactly.
    condition : float
        2-norm condition number of ``M - I`` (``M`` = ``monodromy``; NaN if it failed). The
        error of ``y0`` relative to the state's scale is up to ``residual * condition`` (plus the
        integration error times ``condition``): ~1.8e3 for the standard stick-slip absorber, so
        ``tol = 1e-9`` bounds it by ~2e-6 (measured error 3e-7). Huge (> 1e9, or inf) on a
        pure-stick family.
    converged : bool
        ``True`` iff ``residual <= tol``.
    message : str
        What happened, and what to try next if it did not converge.
    n_solves : int
        Number of :func:`scipy.integrate.solve_ivp` calls, each over one period: 1 at the guess,
        10 per monodromy (central differences) and 1 per trial step (the accepted one is the
        next base solve), i.e. ``11 (iterations + 1)`` plus the rejected trials.
    nfev : int
        Right-hand-side evaluations summed over all calls.
    amplitude_x1, amplitude_x2 : float
        ``max |x1(t)|`` and ``max |x2(t)|`` [m] over ``[t0, t0 + T]`` from the dense output of the
        final solve (extrema located at the zeros of ``v1``, ``v2``); they include any static
        offset of the orbit.
    """

    model: str
    params: dict[str, float]
    nu: float
    y0: NDArray[np.float64]
    period: float
    t0: float
    multipliers: NDArray[np.complex128]
    monodromy: NDArray[np.float64]
    iterations: int
    non_monotone: int
    residual: float
    condition: float
    converged: bool
    message: str
    n_solves: int
    nfev: int
    amplitude_x1: float
    amplitude_x2: float


def _max_abs(sol: OdeSolution, t0: float, T: float, i_pos: int, i_vel: int, n_grid: int = 400) -> float:
    """``max |y[i_pos]|`` over ``[t0, t0 + T]``: grid maximum, refined at the zeros of ``y[i_vel]``."""
    t = np.linspace(t0, t0 + T, n_grid + 1)
    y = sol(t)
    best = float(np.abs(y[i_pos]).max())
    v = y[i_vel]
    for k in np.flatnonzero(np.sign(v[:-1]) * np.sign(v[1:]) < 0):
        tz = brentq(lambda s: float(sol(s)[i_vel]), t[k], t[k + 1], xtol=1e-14 * T, rtol=1e-15)
        best = max(best, abs(float(sol(tz)[i_pos])))
    return best


def shoot_karnopp(
    model: str,
    params: dict[str, float],
    y0_guess: ArrayLike,
    *,
    nu: float = 1e-5,
    method: str = "DOP853",
    rtol: float = 1e-10,
    atol: float = 1e-12,
    tol: float = 1e-9,
    max_iter: int = 30,
    fd_step: float = 1e-5,
    rcond: float = 1e-7,
    max_backtracks: int = 4,
    max_step_ratio: float = 0.5,
    t0: float = 0.0,
    max_step: float | None = None,
) -> KarnoppOrbit:
    """Periodic orbit of the Karnopp model by shooting with a finite-difference Jacobian.

    The paper's approach (Section 3: "a shooting method is implemented in which the necessary
    derivatives are calculated numerically"): Newton's method on ``G(y) = P(y) - y``, with ``P``
    the stroboscopic map over one forcing period ``T = 2 pi / Omega``, ``P(y) = y(t0 + T)`` for
    ``y(t0) = y`` (the Karnopp ODE of :func:`rhs` through :func:`scipy.integrate.solve_ivp`), and
    its Jacobian ``M = dP/dy`` by central differences, one ``solve_ivp`` call per perturbed state.
    The Floquet multipliers are the eigenvalues of the ``M`` of the last iterate.

    Parameters
    ----------
    model : str
        ``"absorber"`` or ``"isolator"``.
    params : dict[str, float]
        Damper parameters; ``Omega`` [rad/s] > 0 sets the period.
    y0_guess : array_like, shape (5,)
        Guess of the state ``(x1, v1, x2, v2, u)`` [m, m/s, m, m/s, m] at ``t0``.
    nu : float, optional
        Half width of the Karnopp stick band [m/s], > 0.
    method : str, optional
        ``solve_ivp`` method.
    rtol, atol : float, optional
        ``solve_ivp`` tolerances (``atol`` in [m] and [m/s] alike).
    tol : float, optional
        Convergence threshold on ``residual`` (see :class:`KarnoppOrbit`), > 0. Keep it above
        the integration error of one period (a few ``rtol``).
    max_iter : int, optional
        Largest number of Newton corrections, >= 0.
    fd_step : float, optional
        Relative finite-difference step, > 0: column ``j`` of ``M`` is
        ``(P(y + h e_j) - P(y - h e_j)) / (2 h)`` with ``h = fd_step * s``, ``s`` the state's
        max-norm at the section (``h = fd_step`` [m or m/s] if ``s = 0``). The default balances
        the integration noise of ``P`` (~``5e-12 s`` at ``rtol = 1e-10``; it enters as
        noise / ``h``) against the one-sided curvature of the map at a kink (error ``~ h``).
    rcond : float, optional
        Relative cut-off of the singular values of ``M - I`` in the least-squares Newton step
        (:func:`numpy.linalg.lstsq`), > 0. Directions with smaller singular values get no
        correction; this fixes the free offset of a pure-stick orbit (the step is the
        minimum-norm one, orthogonal to the family). Keep it below the smallest genuine singular
        value (``~ 1 - |mu|`` of the least damped multiplier, ~``5e-3`` for the standard
        absorber) and above the error of ``M`` (~``1e-8`` on linear orbits, ~``1e-5`` with
        stick-slip).
    max_backtracks : int, optional
        Halvings of a Newton step tried when it does not decrease ``max |P(y) - y|``, >= 0.
    max_step_ratio : float, optional
        Largest Newton correction as a fraction of ``s`` (max-norm), > 0; ``inf`` disables the cap.
    t0 : float, optional
        Time of the section [s]; the forcing is ``F sin(Omega t)``.
    max_step : float, optional
        Largest ``solve_ivp`` step [s]; by default ``T / 20`` as in :func:`simulate_karnopp`.

    Returns
    -------
    KarnoppOrbit
        The orbit (the last iterate), its multipliers, amplitudes and counters. Failure to
        converge is returned as data (``converged=False`` with a message), never raised.

    Raises
    ------
    ValueError
        For an unknown ``model``, invalid ``params``, ``Omega <= 0``, a non-positive ``nu``,
        ``tol``, ``fd_step``, ``rcond``, ``max_step_ratio`` or ``max_step``, a negative
        ``max_iter`` or ``max_backtracks``, a non-finite ``t0``, or a ``y0_guess`` that is not a
        finite 5-vector.

    Notes
    -----
    Each iteration solves ``(M - I) dy = -(P(y) - y)`` in the least-squares sense with the
    singular values below ``rcond * sigma_max`` discarded, so the step is defined where
    ``I - M`` is singular (pure-stick orbits form a family: the friction offset is free, a
    multiplier is exactly 1) or nearly so (weakly damped stick-slip orbits, multipliers 0.99
    and above). The step is capped at ``max_step_ratio * s`` and halved up to
    ``max_backtracks`` times until ``max |P(y) - y|`` decreases; if none does, the smallest
    trial is taken anyway (the map is only piecewise smooth and a monotone search stalls near
    grazing orbits, where slip is just starting). The iteration stops at ``residual <= tol``,
    after ``max_iter`` corrections, or when a solve fails (also for non-finite states).

    Central, not forward, differences: if the section cuts a slip phase, the orbit lies on the
    surface ``|H| = R`` at ``t0``, where ``P`` has a kink (a perturbation that lowers ``|H|``
    sticks at once, one that raises it keeps slipping). Each central column averages both
    sides, so ``M`` is the mean of the two one-sided Jacobians, whose eigenvalues agree;
    forward columns mix sides per coordinate and gave multipliers off by ``7e-2`` on the
    standard absorber. Every solve starts with the same first step (``1e-4 T``), so the step
    sequences of the perturbed solves stay close to the base one.

    Cost: ``11`` solves of one period per iteration (10 for the monodromy, 1 for the accepted
    step), plus one per rejected trial step; base solves keep their dense output for the
    amplitudes. On the standard absorber (Omega = 0.854 rad/s) one solve takes ~0.02 s.

    References
    ----------
    .. [1] Aramendiz et al., "Sequential friction-spring dampers", Section 3.1, Eqs. (10)-(13),
       and the shooting method cited there.

    Examples
    --------
    A damper that never slips (``R`` huge) has the linear stick response of
    :func:`hybrid_models.linear.stick_response`, with a free offset and so a multiplier 1:

    >>> import numpy as np
    >>> import hybrid_models
    >>> from hybrid_models.karnopp import shoot_karnopp
    >>> from hybrid_models.linear import stick_amplitudes
    >>> p = dict(hybrid_models.absorber().preset("standard"), R=1e6, Omega=0.5)
    >>> orbit = shoot_karnopp("absorber", p, np.zeros(5))
    >>> orbit.converged, orbit.iterations
    (True, 1)
    >>> bool(np.isclose(orbit.amplitude_x1, abs(stick_amplitudes(p)[0]), rtol=1e-9))
    True
    >>> bool(np.abs(orbit.multipliers - 1).min() < 1e-6)
    True
    """
    check_model(model)
    check_params(params)
    nu = _check_nu(nu)
    omega = float(params["Omega"])
    if not (omega > 0.0 and math.isfinite(omega)):
        raise ValueError(f"params['Omega'] must be a finite float > 0 (rad/s), got {params['Omega']!r}")
    y = np.asarray(y0_guess, dtype=float)
    if y.shape != (5,) or not np.all(np.isfinite(y)):
        raise ValueError(f"y0_guess must be a finite array of shape (5,) (x1, v1, x2, v2, u), got {y!r}")
    for name, value in (("tol", tol), ("fd_step", fd_step), ("rcond", rcond)):
        if not (value > 0.0 and math.isfinite(value)):
            raise ValueError(f"{name} must be a finite float > 0, got {value!r}")
    if not max_step_ratio > 0.0:
        raise ValueError(f"max_step_ratio must be > 0 (inf disables the cap), got {max_step_ratio!r}")
    for name, value in (("max_iter", max_iter), ("max_backtracks", max_backtracks)):
        if isinstance(value, bool) or not isinstance(value, (int, np.integer)) or value < 0:
            raise ValueError(f"{name} must be an int >= 0, got {value!r}")
    T = 2.0 * math.pi / omega
    t0 = float(t0)
    if not math.isfinite(t0):
        raise ValueError(f"t0 must be finite (s), got {t0!r}")
    if max_step is None:
        max_step = T / 20.0
    elif not (max_step > 0.0):
        raise ValueError(f"max_step must be > 0 (s), got {max_step!r}")
    # A fixed first step: solve_ivp's own choice depends on |y0| / atol, which would change the step
    # sequence between the base solve and a finite-difference column (badly so near y = 0).
    first_step = min(max_step, 1e-4 * T)
    f = rhs(model, params, nu)
    counters = {"solves": 0, "nfev": 0}

    def flow(y_start: NDArray[np.float64], dense: bool):
        sol = solve_ivp(
            f,
            (t0, t0 + T),
            np.concatenate([y_start, [0.0, 0.0]]),
            method=method,
            rtol=rtol,
            atol=atol,
            max_step=max_step,
            first_step=first_step,
            dense_output=dense,
        )
        counters["solves"] += 1
        counters["nfev"] += int(sol.nfev)
        return sol

    def evaluate(y_start: NDArray[np.float64]):
        """Base solve at ``y_start``: (dense solution, P(y), P(y) - y, scale) or the failure message."""
        sol = flow(y_start, dense=True)
        if not sol.success:
            return str(sol.message)
        p_y = sol.y[:5, -1]
        r = p_y - y_start
        if not np.all(np.isfinite(r)):
            return "non-finite state after one period"
        scale = max(float(np.abs(y_start).max()), float(np.abs(p_y).max()))
        return sol.sol, p_y, r, scale

    def note() -> str:
        return f" ({non_monotone} of them without a decrease of the residual)" if non_monotone else ""

    def relative(err: float, scale: float) -> float:
        return 0.0 if err == 0.0 else (err / scale if scale > 0.0 else math.inf)

    eye = np.eye(5)
    monodromy = np.full((5, 5), np.nan)
    residual = math.inf
    converged = False
    dense = None
    iterations = 0
    non_monotone = 0
    base = evaluate(y)
    while True:
        if isinstance(base, str):
            message = f"solve_ivp failed at the guess: {base}. Try a better guess or other tolerances."
            break
        dense, p_y, r, scale = base
        err = float(np.abs(r).max())
        residual = relative(err, scale)
        h = fd_step * scale if scale > 0.0 else fd_step
        failed = None
        for j in range(5):
            plus = flow(y + h * eye[j], dense=False)
            minus = flow(y - h * eye[j], dense=False)
            if not (plus.success and minus.success):
                failed = plus.message if not plus.success else minus.message
                break
            monodromy[:, j] = (plus.y[:5, -1] - minus.y[:5, -1]) / (2.0 * h)
        if failed is not None:
            monodromy[:] = np.nan
            message = f"solve_ivp failed in a finite-difference column after {iterations} Newton corrections: {failed}"
            break
        if residual <= tol:
            converged = True
            message = f"converged: residual {residual:.2e} <= tol {tol:.2e} after {iterations} Newton corrections{note()}."
            break
        if iterations >= max_iter:
            message = (
                f"not converged: residual {residual:.2e} > tol {tol:.2e} after max_iter = {max_iter} "
                f"Newton corrections{note()}. Try a better guess, a larger max_iter, or a tol above the "
                "integration error."
            )
            break
        step = np.linalg.lstsq(monodromy - eye, -r, rcond=rcond)[0]
        # Globalisation: cap the step at max_step_ratio times the state's scale, then halve it
        # until the max-norm of P(y) - y decreases (absolute, so that a step cannot "converge" by
        # inflating the scale). If no halving decreases it, the smallest step is taken anyway:
        # the map is only piecewise smooth, and near a grazing orbit (slip just starting) a
        # monotone line search stalls. max_iter bounds the iteration either way.
        alpha = 1.0
        step_norm = float(np.abs(step).max())
        if step_norm > max_step_ratio * scale:
            alpha = max_step_ratio * scale / step_norm
        trial = None
        fallback = None
        for _ in range(max_backtracks + 1):
            candidate = evaluate(y + alpha * step)
            if not isinstance(candidate, str):
                fallback = (alpha, candidate)
                if float(np.abs(candidate[2]).max()) < err:
                    trial = fallback
                    break
            alpha *= 0.5
        if trial is None:
            if fallback is None:
                message = (
                    f"not converged: solve_ivp failed on every trial step after {iterations} Newton "
                    f"corrections (residual {residual:.2e}). Try a better guess."
                )
                break
            trial = fallback
            non_monotone += 1
        y = y + trial[0] * step
        base = trial[1]
        iterations += 1

    if np.all(np.isfinite(monodromy)):
        mu = np.linalg.eigvals(monodromy).astype(np.complex128)
        mu = mu[np.argsort(-np.abs(mu), kind="stable")]
        condition = float(np.linalg.cond(monodromy - eye))
    else:
        mu = np.full(5, np.nan, dtype=np.complex128)
        condition = math.nan
    if dense is not None:
        amp1 = _max_abs(dense, t0, T, 0, 1)
        amp2 = _max_abs(dense, t0, T, 2, 3)
    else:
        amp1 = amp2 = math.nan
    return KarnoppOrbit(
        model=model,
        params=dict(params),
        nu=nu,
        y0=y.copy(),
        period=T,
        t0=t0,
        multipliers=mu,
        monodromy=monodromy.copy(),
        iterations=iterations,
        non_monotone=non_monotone,
        residual=residual,
        condition=condition,
        converged=converged,
        message=message,
        n_solves=counters["solves"],
        nfev=counters["nfev"],
        amplitude_x1=amp1,
        amplitude_x2=amp2,
    )
