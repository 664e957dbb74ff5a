"""The averaging model of Sec. 4 and App. D of [1]: modal decoupling and first-order averaging.

Each damper is reduced, near its stick eigenfrequency ``i`` (``mode = 1`` or ``2``), to one
modal oscillator ([2], Sec. 5.1)::

    q'' + eta_i^2 q = eps Fc f sin(eta tau) + Wc w,    w = eps (kappa r q - rho sgn(r q'))  (slip)

with ``w`` frozen while the friction element sticks. The coefficients are

* absorber (Eq. (19) of [1]): ``Fc = G_i = (mu - 1)(mu r2i - r1i)``, ``Wc = mu p r2i``,
  friction coordinate ``z2 = x2 - x1 = r2i q`` (``r = r2i``);
* isolator (Eq. (23) of [1], corrected): ``Fc = Wc = r = r1i``, friction coordinate ``x1 = r1i q``.

The Van der Pol transformation ``q = A sin(phi)``, ``q' = A eta_i cos(phi)``,
``psi = phi - eta tau`` (Eq. (24)) and averaging over ``phi`` give the slow flow of ``(A, psi)``;
its fixed points are the frequency-response curves, its Jacobian their stability.

Conventions
-----------
* Parameters are the models' preset dicts: ``m1, m2`` [kg], ``c1, c2, c3`` [N/m], ``R, F`` [N],
  ``Omega`` [rad/s] (e.g. ``hybrid_models.absorber().preset("standard")``).
* Time is scaled by ``k = sqrt(c1/m1)`` (``tau = k t``, ``eta = Omega/k``); lengths are **not**
  scaled: ``x1, x2, z1, z2, q, A`` are in metres, and so are ``eps rho`` and ``eps f``
  (``rho``, ``f`` are metres divided by ``eps``). ``mu, p, kappa, eta`` are dimensionless.
* ``eps`` is bookkeeping only (default 0.01, the paper's value in Figs. 11-13): every physical
  result (frequencies, amplitudes in m, forces in N) is independent of it.
* Modal matrix: columns mass-normalised, ``R^T M R = I`` with the symmetrised mass matrices
  ``M = diag(1, mu (1 - mu))`` (absorber, Eq. (15) line 2 multiplied by ``mu (1 - mu)``) and
  ``M = diag(1, mu/(1 - mu))`` (isolator, Eq. (22) line 2 multiplied by ``mu/(1 - mu)``); the
  sign of each column is chosen so that the friction coordinate's entry is positive
  (``r2i > 0`` absorber, ``r1i > 0`` isolator), as Eq. (27) assumes. The modal amplitude ``A``
  depends on this normalisation; the amplitudes of ``x1, x2`` do not.
* The corrections listed in ``docs/theory.md`` (Sec. 5.2, errata 5-14) are applied. Where the
  paper's printed form differs, ``printed=True`` evaluates it as printed, so the difference
  can be shown.
* Below the slip threshold (``kappa r A <= rho``, i.e. ``A <= A_min1``) the element sticks for
  the whole cycle, ``w`` is constant and the friction terms ``zeta_cos, zeta_sin`` vanish (the
  linear stick resonance); Eqs. (30)/(31) are used only above it.

References
----------
.. [1] Aramendiz et al., "Sequential friction-spring dampers" (``shared/seed``).
.. [2] ``docs/theory.md`` (derivation, errata) and ``docs/averaging.md`` (function map).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import scipy.linalg
from numpy.typing import ArrayLike, NDArray
from scipy.optimize import brentq

from .linear import check_model, check_params

__all__ = [
    "EPS",
    "Nondimensional",
    "ModalEquation",
    "FixedPoint",
    "FrequencyResponse",
    "CharacteristicAmplitudes",
    "nondimensional",
    "system_matrices",
    "modal_matrix",
    "modal_equation",
    "slip_angle",
    "friction_displacement",
    "zeta",
    "standard_form_rhs",
    "averaged_rhs",
    "averaged_jacobian",
    "stability",
    "fixed_points",
    "frequency_response",
    "characteristic_amplitudes",
    "rho_min",
    "rho_opt",
    "breakaway_force",
    "physical_amplitudes",
]

#: The paper's small parameter in Figs. 11-13 (bookkeeping only; results do not depend on it).
EPS = 0.01


def _check(model: str, params: dict[str, float], mode: int | None = None) -> None:
    check_model(model)
    check_params(params)
    if mode is not None and mode not in (1, 2):
        raise ValueError(f"mode must be 1 or 2, got {mode!r}")


# --------------------------------------------------------------------------------------------
# Nondimensional parameters and modal decoupling
# --------------------------------------------------------------------------------------------


@dataclass(frozen=True)
class Nondimensional:
    """Nondimensional parameters of Eq. (14) (absorber) or Eq. (20) (isolator) of [1].

    Attributes
    ----------
    mu : float
        Mass ratio ``m2/(m1 + m2)`` [-].
    k : float
        Time scale ``sqrt(c1/m1)`` [rad/s]; ``tau = k t``.
    lam : float
        ``sqrt(c2/m2)`` [rad/s] (the antiresonance frequency).
    p : float
        ``lam^2/k^2`` [-].
    eta : float
        Excitation frequency ``Omega/k`` [-] of ``params["Omega"]``.
    eps : float
        Small bookkeeping parameter [-].
    kappa : float
        ``eps kappa = c2/(c2 + c3)`` (absorber) or ``c1/(c1 + c3)`` (isolator) [-].
    rho : float
        ``eps rho = R/(c2 + c3)`` or ``R/(c1 + c3)`` [m]: the friction force as a length.
    f : float
        ``eps f = F/(m1 k^2) = F/c1`` [m]: the excitation as a static deflection.
    c_series : float
        Stiffness in series with ``c3`` [N/m]: ``c2`` (absorber) or ``c1`` (isolator); so
        ``R = eps rho (c_series + c3)``.
    """

    mu: float
    k: float
    lam: float
    p: float
    eta: float
    eps: float
    kappa: float
    rho: float
    f: float
    c_series: float


def nondimensional(model: str, params: dict[str, float], eps: float = EPS) -> Nondimensional:
    """Nondimensional parameters, Eq. (14) (absorber) and Eq. (20) (isolator) of [1].

    Parameters
    ----------
    model : str
        ``"absorber"`` or ``"isolator"``.
    params : dict[str, float]
        ``m1, m2`` [kg], ``c1, c2, c3`` [N/m], ``R, F`` [N], ``Omega`` [rad/s].
    eps : float, optional
        The small parameter (default 0.01, as in Figs. 11-13).

    Returns
    -------
    Nondimensional

    Examples
    --------
    >>> import hybrid_models
    >>> nd = nondimensional("absorber", hybrid_models.absorber().preset("standard"))
    >>> round(nd.kappa, 2), round(nd.rho, 2), nd.f
    (0.99, 4.95, 1.0)
    """
    _check(model, params)
    if not eps > 0.0:
        raise ValueError(f"eps must be > 0, got {eps!r}")
    m1, m2, c1, c2, c3, R, F, Om = (params[k] for k in ("m1", "m2", "c1", "c2", "c3", "R", "F", "Omega"))
    k = math.sqrt(c1 / m1)
    lam = math.sqrt(c2 / m2)
    cs = c2 if model == "absorber" else c1
    return Nondimensional(
        mu=m2 / (m1 + m2),
        k=k,
        lam=lam,
        p=lam**2 / k**2,
        eta=Om / k,
        eps=eps,
        kappa=cs / (cs + c3) / eps,
        rho=R / (cs + c3) / eps,
        f=F / (m1 * k**2) / eps,
        c_series=cs,
    )


def system_matrices(model: str, params: dict[str, float]) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Symmetrised mass and stiffness matrices of the unperturbed (stick) system, Eqs. (15)-(16), (22).

    Absorber, coordinates ``z = (z1, z2)`` of Eq. (14) (``z1`` centre of mass, ``z2 = x2 - x1``),
    Eq. (15) with its second line multiplied by ``mu (1 - mu)``::

        M = diag(1, mu (1 - mu)),  C = [[1 - mu, -mu (1 - mu)], [-mu (1 - mu), mu^2 (1 - mu) + mu p]]

    Isolator, coordinates ``(x1, x2)``, Eq. (22) with its second line multiplied by ``mu/(1 - mu)``::

        M = diag(1, mu/(1 - mu)),  C = [[1 + p mu/(1 - mu), -p mu/(1 - mu)], [-p mu/(1 - mu), p mu/(1 - mu)]]

    Both are the physical stick system (``c3`` rigid or ``u`` frozen) scaled by ``m1 + m2``
    resp. ``m1`` and ``k^2``; the printed Eqs. (15)/(22) have the same eigenvalues but
    non-symmetric stiffness matrices.

    Parameters
    ----------
    model : str
        ``"absorber"`` or ``"isolator"``.
    params : dict[str, float]
        Damper parameters.

    Returns
    -------
    M, C : ndarray, shape (2, 2)
        Dimensionless, symmetric, positive definite.
    """
    nd = nondimensional(model, params)
    mu, p = nd.mu, nd.p
    if model == "absorber":
        M = np.diag([1.0, mu * (1.0 - mu)])
        C = np.array([[1.0 - mu, -mu * (1.0 - mu)], [-mu * (1.0 - mu), mu**2 * (1.0 - mu) + mu * p]])
    else:
        g = p * mu / (1.0 - mu)
        M = np.diag([1.0, mu / (1.0 - mu)])
        C = np.array([[1.0 + g, -g], [-g, g]])
    return M, C


def modal_matrix(model: str, params: dict[str, float]) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Modal matrix ``R`` and the eigenfrequencies ``eta_1 < eta_2``, Eqs. (17), (19), (23) of [1].

    ``R`` solves ``C R = M R diag(eta_1^2, eta_2^2)`` for the matrices of
    :func:`system_matrices`, normalised by ``R^T M R = I`` (so ``R^T C R = diag(eta_i^2)``), with
    the sign of column ``i`` chosen so that ``r2i > 0`` (absorber: friction coordinate
    ``z2 = r2i q_i``) or ``r1i > 0`` (isolator: ``x1 = r1i q_i``).

    Parameters
    ----------
    model : str
        ``"absorber"`` or ``"isolator"``.
    params : dict[str, float]
        Damper parameters.

    Returns
    -------
    R : ndarray, shape (2, 2)
        ``[[r11, r12], [r21, r22]]`` [-]; column ``i`` is mode ``i``.
    eta : ndarray, shape (2,)
        ``(eta_1, eta_2)`` [-], the stick eigenfrequencies divided by ``k``.
    """
    M, C = system_matrices(model, params)
    lam, R = scipy.linalg.eigh(C, M)
    row = 1 if model == "absorber" else 0
    R = R * np.sign(R[row])
    return R, np.sqrt(lam)


@dataclass(frozen=True)
class ModalEquation:
    """One decoupled modal oscillator, Eq. (19) (absorber) or Eq. (23) (isolator) of [1].

    ``q'' + eta_i^2 q = eps Fc f sin(eta tau) + Wc w(q)``, ``w = eps (kappa r q - rho sgn(q'))``
    while slipping.

    Attributes
    ----------
    model : str
        ``"absorber"`` or ``"isolator"``.
    mode : int
        1 or 2.
    eta_i : float
        Eigenfrequency of the mode [-].
    Fc : float
        Forcing coefficient [-]: ``(mu - 1)(mu r2i - r1i)`` (absorber), ``r1i`` (isolator).
    Wc : float
        Friction coefficient [-]: ``mu p r2i`` (absorber), ``r1i`` (isolator).
    r : float
        Friction coordinate per unit ``q`` [-], ``> 0``: ``r2i`` (absorber), ``r1i`` (isolator).
    x1, x2 : float
        Signed displacement of ``x1``, ``x2`` per unit ``q`` [-] (Eqs. (45)-(46), (49)-(50)).
    nd : Nondimensional
        The parameters of Eq. (14)/(20).
    """

    model: str
    mode: int
    eta_i: float
    Fc: float
    Wc: float
    r: float
    x1: float
    x2: float
    nd: Nondimensional


def modal_equation(
    model: str, params: dict[str, float], mode: int, eps: float = EPS, printed: bool = False
) -> ModalEquation:
    """Coefficients of the decoupled modal equation, Eqs. (18)-(19) and (23) of [1].

    The other mode is neglected (Eq. (18)), valid for ``eta_2 - eta_1 = O(1)`` (App. C).
    Absorber: ``R^T`` applied to Eq. (15) (symmetrised) gives
    ``q_i'' + eta_i^2 q_i = eps f (mu - 1)(mu r2i - r1i) sin(eta tau) + mu p r2i w`` (Eq. (19));
    ``x1 = z1 - mu z2 = (r1i - mu r2i) q_i``, ``x2 = z1 + (1 - mu) z2 = (r1i + (1 - mu) r2i) q_i``.
    Isolator: ``R^T (eps f sin + w, 0)^T`` gives ``r1i (eps f sin(eta tau) + w)`` for both modes;
    ``x1 = r1i q_i``, ``x2 = r2i q_i``.

    Parameters
    ----------
    model : str
        ``"absorber"`` or ``"isolator"``.
    params : dict[str, float]
        Damper parameters.
    mode : int
        1 or 2.
    eps : float, optional
        Small parameter.
    printed : bool, optional
        Isolator, mode 2: use Eq. (23) line 2 as printed, with ``r21`` in place of ``r12`` as
        forcing and friction coefficient (erratum 5 of ``docs/theory.md``).

    Returns
    -------
    ModalEquation
    """
    _check(model, params, mode)
    nd = nondimensional(model, params, eps)
    R, eta = modal_matrix(model, params)
    i = mode - 1
    r1, r2 = float(R[0, i]), float(R[1, i])
    if model == "absorber":
        Fc = (nd.mu - 1.0) * (nd.mu * r2 - r1)
        x1, x2 = r1 - nd.mu * r2, r1 + (1.0 - nd.mu) * r2
        return ModalEquation(model, mode, float(eta[i]), Fc, nd.mu * nd.p * r2, r2, x1, x2, nd)
    c = float(R[1, 0]) if (printed and mode == 2) else r1
    return ModalEquation(model, mode, float(eta[i]), c, c, r1, r1, r2, nd)


# --------------------------------------------------------------------------------------------
# The friction coordinate over one cycle and the averaged friction terms
# --------------------------------------------------------------------------------------------


def slip_angle(a: ArrayLike, rho: float, printed: bool = False) -> NDArray[np.float64]:
    """Phase at which the element starts to slip, ``phi_r`` of Eq. (27) of [1].

    Continuity of ``w`` at ``phi_r`` (stuck value ``eps (rho - a)`` from ``phi = -pi/2``, slip
    value ``eps (a sin(phi) - rho)``) gives ``sin(phi_r) = 2 rho/a - 1`` (erratum 8).

    Parameters
    ----------
    a : array_like
        ``kappa r A`` [m/eps], the amplitude of the friction coordinate times ``kappa``; ``a > rho``.
    rho : float
        Nondimensional friction [m/eps].
    printed : bool, optional
        Evaluate the printed ``arcsin(1 - 2 rho/a)`` (the negative).

    Returns
    -------
    ndarray
        ``phi_r`` [rad] in ``(-pi/2, pi/2)``.
    """
    x = 2.0 * rho / np.asarray(a, dtype=float) - 1.0
    return np.arcsin(-x if printed else x)


def friction_displacement(phi: ArrayLike, a: float, rho: float, printed: bool = False) -> NDArray[np.float64]:
    """Steady friction coordinate ``w/eps`` over one cycle, Eq. (27) of [1].

    ``w/eps = rho - a`` on ``[-pi/2, phi_r)`` (stuck), ``a sin(phi) - rho`` on ``[phi_r, pi/2)``
    (slip), ``a - rho`` on ``[pi/2, pi + phi_r)`` (stuck), ``a sin(phi) + rho`` on
    ``[pi + phi_r, 3 pi/2)`` (slip), ``phi`` taken modulo ``2 pi`` into ``[-pi/2, 3 pi/2)``. For
    ``a <= rho`` the element sticks throughout and the steady ``w`` is a constant offset, set
    to 0 here (it does not enter the averages).

    Parameters
    ----------
    phi : array_like
        Phase [rad].
    a : float
        ``kappa r A`` [m/eps].
    rho : float
        Nondimensional friction [m/eps].
    printed : bool, optional
        Use the printed ``phi_r`` of Eq. (27): ``w`` then jumps at ``phi_r`` and ``pi + phi_r``.

    Returns
    -------
    ndarray
        ``w/eps`` [m/eps] with the shape of ``phi``.
    """
    ph = np.mod(np.asarray(phi, dtype=float) + np.pi / 2, 2 * np.pi) - np.pi / 2
    if a <= rho:
        return np.zeros_like(ph)
    pr = float(slip_angle(a, rho, printed))
    s = a * np.sin(ph)
    return np.select(
        [ph < pr, ph < np.pi / 2, ph < np.pi + pr],
        [np.full_like(ph, rho - a), s - rho, np.full_like(ph, a - rho)],
        s + rho,
    )


def _zeta(eq: ModalEquation, A: NDArray[np.float64], printed: bool):
    """zeta_cos, zeta_sin and their A-derivatives (0 where a <= rho)."""
    nd = eq.nd
    rho, kap = nd.rho, nd.kappa
    a = kap * eq.r * A
    slip = a > rho
    asafe = np.where(slip, a, 2.0 * rho)
    Asafe = asafe / (kap * eq.r)
    Q = np.sqrt(rho * (asafe - rho))
    wr = eq.Wc / eq.r  # mu p (absorber) or 1 (isolator)
    zc = -2.0 * wr * rho * (asafe - rho) / (kap * Asafe * eq.eta_i * np.pi)
    S = np.pi + 2.0 * np.arcsin(1.0 - 2.0 * rho / asafe) + 4.0 * (asafe - 2.0 * rho) * Q / asafe**2
    pre = -eq.Wc * kap * eq.r / (4.0 * np.pi * eq.eta_i)
    if printed:
        pre = pre * (2.0 if (eq.model == "isolator" and eq.mode == 2) else 1.0)  # D.7
    zs = pre * S
    dzc = -2.0 * wr * rho**2 / (kap * Asafe**2 * eq.eta_i * np.pi)
    dzs = pre * 16.0 * rho * Q / asafe**3 * kap * eq.r  # dS/da = 16 rho sqrt(rho (a - rho))/a^3
    z = np.zeros_like(a)
    return (np.where(slip, zc, z), np.where(slip, zs, z), np.where(slip, dzc, z), np.where(slip, dzs, z))


def zeta(
    model: str, params: dict[str, float], mode: int, A: ArrayLike, eps: float = EPS, printed: bool = False
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Averaged friction terms ``zeta_cos``, ``zeta_sin``, Eqs. (30)-(31), (D.6)-(D.7) of [1].

    With ``a = kappa r A`` (``r = r2i`` absorber, ``r1i`` isolator) and ``Wc/r = mu p``
    (absorber) or 1 (isolator)::

        zeta_cos = -2 (Wc/r) rho (a - rho) / (kappa A eta_i pi)
        zeta_sin = -(Wc/r) / (4 kappa A^2 pi eta_i) [a^2 (pi + 2 arcsin(1 - 2 rho/a))
                                                    + (4 a - 8 rho) sqrt(rho (a - rho))]

    i.e. ``Wc <w cos(phi)>/(eps eta_i)`` and ``-Wc <w sin(phi)>/(eps A eta_i)`` over the loop of
    Eq. (27); both vanish for ``a <= rho`` (no slip). ``zeta_cos`` is a damping term (< 0),
    ``zeta_sin`` the softening frequency shift.

    Parameters
    ----------
    model : str
        ``"absorber"`` or ``"isolator"``.
    params : dict[str, float]
        Damper parameters.
    mode : int
        1 or 2.
    A : array_like
        Modal amplitude [m].
    eps : float, optional
        Small parameter.
    printed : bool, optional
        Isolator mode 2: printed D.7, whose ``zeta_w2,sin`` has ``-2/(...)`` in place of
        ``-1/(...)`` (erratum 11). (D.3-D.9 use ``r12``; the ``r21`` of the printed Eq. (23) is
        shown by :func:`modal_equation` only.)

    Returns
    -------
    zeta_cos, zeta_sin : ndarray
        [-], with the shape of ``A``.
    """
    eq = modal_equation(model, params, mode, eps)  # D.3-D.9 use r12 even as printed
    zc, zs, _, _ = _zeta(eq, np.asarray(A, dtype=float), printed)
    return zc, zs


# --------------------------------------------------------------------------------------------
# Standard form, averaged equations, Jacobian and stability
# --------------------------------------------------------------------------------------------


def standard_form_rhs(
    model: str,
    params: dict[str, float],
    mode: int,
    A: float,
    psi: float,
    phi: float,
    w: float,
    eta: float | None = None,
    eps: float = EPS,
    printed: bool = False,
) -> tuple[float, float, float]:
    """Right-hand side of the standard form, Eqs. (25)-(26) and (D.2)-(D.3) of [1].

    Exact Van der Pol form of the modal oscillator (``g = eps Fc f sin(phi - psi) + Wc w``)::

        A'   = g cos(phi)/eta_i
        psi' = eta_i - eta - g sin(phi)/(A eta_i)
        phi' = eta_i - g sin(phi)/(A eta_i)

    Parameters
    ----------
    model, params, mode, eps
        As for :func:`modal_equation`.
    A, psi, phi : float
        Modal amplitude [m], phase lag [rad], phase [rad].
    w : float
        Friction coordinate ``w`` [m] (includes its factor ``eps``).
    eta : float, optional
        Excitation frequency [-]; default ``params["Omega"]/k``.
    printed : bool, optional
        As printed: forcing ``sin(psi - phi)`` with ``(1 - mu)`` (Eqs. (25)-(26), erratum 6; the
        opposite sign), ``eps`` on the friction term of ``phi2'`` (Eq. (26) line 3, erratum 7),
        and ``cos(phi)`` in place of ``sin(phi)`` in the ``psi'``, ``phi'`` lines of the isolator
        (D.2-D.3, erratum 10).

    Returns
    -------
    dA, dpsi, dphi : float
        Derivatives with respect to ``tau``.
    """
    eq = modal_equation(model, params, mode, eps)  # D.3-D.9 use r12 even as printed
    et = eq.nd.eta if eta is None else float(eta)
    force = eps * eq.Fc * eq.nd.f * math.sin(phi - psi)
    fric = eq.Wc * w
    s = math.sin(phi)
    fric_phi = fric
    if printed and model == "absorber":
        force = -force  # erratum 6: sin(psi - phi) with (1 - mu)
        if mode == 2:
            fric_phi = eps * fric  # erratum 7: stray eps in Eq. (26) line 3
    elif printed:
        s = math.cos(phi)  # erratum 10: cos in the psi', phi' lines of (D.2)-(D.3)
    dA = (force + fric) * math.cos(phi) / eq.eta_i
    dpsi = eq.eta_i - et - (force + fric) * s / (A * eq.eta_i)
    dphi = eq.eta_i - (force + fric_phi) * s / (A * eq.eta_i)
    return dA, dpsi, dphi


def averaged_rhs(
    model: str,
    params: dict[str, float],
    mode: int,
    A: ArrayLike,
    psi: ArrayLike,
    eta: float | None = None,
    eps: float = EPS,
    printed: bool = False,
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Averaged (slow) equations, Eqs. (28)-(29) (absorber) and (D.4)-(D.5) (isolator) of [1].

    ::

        A'   = eps zeta_cos - eps Fc f sin(psi)/(2 eta_i)
        psi' = eps (delta_i + zeta_sin) - eps Fc f cos(psi)/(2 A eta_i),   eps delta_i = eta_i - eta

    with ``zeta`` of :func:`zeta` and ``Fc`` of :func:`modal_equation` (``' = d/dtau``).

    Parameters
    ----------
    model : str
        ``"absorber"`` or ``"isolator"``.
    params : dict[str, float]
        Damper parameters.
    mode : int
        1 or 2.
    A : array_like
        Modal amplitude [m], ``> 0``.
    psi : array_like
        Phase ``psi = phi - eta tau`` [rad]: ``q = A sin(eta tau + psi)``.
    eta : float, optional
        Excitation frequency ``Omega/k`` [-]; default from ``params["Omega"]``.
    eps : float, optional
        Small parameter.
    printed : bool, optional
        As printed: prefactor ``eps/eta_i`` in place of ``eps`` (erratum 9; same fixed points and
        stability, slow time scaled by ``1/eta_i``), and the printed D.7 for the isolator's
        mode 2 (erratum 11).

    Returns
    -------
    dA, dpsi : ndarray
        ``dA/dtau`` [m], ``dpsi/dtau`` [rad].
    """
    eq = modal_equation(model, params, mode, eps)  # D.3-D.9 use r12 even as printed
    et = eq.nd.eta if eta is None else float(eta)
    A = np.asarray(A, dtype=float)
    psi = np.asarray(psi, dtype=float)
    zc, zs, _, _ = _zeta(eq, A, printed)
    ff = eq.Fc * eq.nd.f
    scale = eps / eq.eta_i if printed else eps
    dA = scale * (zc - ff * np.sin(psi) / (2.0 * eq.eta_i))
    dpsi = scale * ((eq.eta_i - et) / eps + zs - ff * np.cos(psi) / (2.0 * A * eq.eta_i))
    return dA, dpsi


def averaged_jacobian(
    model: str,
    params: dict[str, float],
    mode: int,
    A: float,
    psi: float,
    eta: float | None = None,
    eps: float = EPS,
    printed: bool = False,
) -> NDArray[np.float64]:
    """Jacobian ``d(A', psi')/d(A, psi)`` of the averaged equations (28)-(29), (D.4)-(D.5) of [1].

    ::

        J = eps [[zeta_cos'(A),                          -Fc f cos(psi)/(2 eta_i)],
                 [zeta_sin'(A) + Fc f cos(psi)/(2 A^2 eta_i), Fc f sin(psi)/(2 A eta_i)]]

    with ``zeta_cos' = -2 (Wc/r) rho^2/(kappa A^2 eta_i pi)`` and
    ``zeta_sin' = -(Wc kappa^2 r^2/(4 pi eta_i)) 16 rho sqrt(rho (a - rho))/a^3`` above the slip
    threshold (both 0 below; one-sided at ``A = A_min1``, where the flow is not smooth).

    Parameters
    ----------
    As for :func:`averaged_rhs`, with scalar ``A`` [m] and ``psi`` [rad].

    Returns
    -------
    ndarray, shape (2, 2)
        [1/1, m; 1/m, 1] per unit ``tau``.
    """
    eq = modal_equation(model, params, mode, eps)  # D.3-D.9 use r12 even as printed
    _, _, dzc, dzs = _zeta(eq, np.asarray([A], dtype=float), printed)
    ff = eq.Fc * eq.nd.f
    e = eq.eta_i
    J = np.array(
        [
            [dzc[0], -ff * math.cos(psi) / (2.0 * e)],
            [dzs[0] + ff * math.cos(psi) / (2.0 * A**2 * e), ff * math.sin(psi) / (2.0 * A * e)],
        ]
    )
    return (eps / e if printed else eps) * J


def stability(eigenvalues: ArrayLike, tol: float = 1e-12) -> str:
    """Classify a fixed point of the averaged equations by its Jacobian eigenvalues.

    Parameters
    ----------
    eigenvalues : array_like
        Eigenvalues of :func:`averaged_jacobian` [1 per unit tau].
    tol : float, optional
        Real parts within ``tol`` times the largest modulus count as zero.

    Returns
    -------
    str
        ``"stable"`` (all real parts < 0), ``"unstable"`` (one > 0) or ``"neutral"`` (largest
        real part zero: the undamped stick solutions, a centre of the averaged flow).
    """
    ev = np.asarray(eigenvalues)
    big = float(np.max(np.abs(ev))) if ev.size else 0.0
    re = float(np.max(ev.real))
    if re > tol * big:
        return "unstable"
    if re < -tol * big:
        return "stable"
    return "neutral"


# --------------------------------------------------------------------------------------------
# Frequency-response curves and fixed points
# --------------------------------------------------------------------------------------------


def _branches(eq: ModalEquation, A: NDArray[np.float64], printed: bool, a_max: float = math.nan):
    """eta of the two branches of Eq. (32) at amplitudes A (nan where the root is imaginary).

    The radicand is exactly zero at ``A = a_max``; it is set so there (its rounding error
    would otherwise be amplified by the square root).
    """
    zc, zs, _, _ = _zeta(eq, A, printed)
    eps = eq.nd.eps
    ff2 = (eq.Fc * eq.nd.f) ** 2
    disc = ff2 - 4.0 * zc**2 * eq.eta_i**2
    disc = np.where(((disc < 0.0) & (disc > -1e-13 * ff2)) | (A == a_max), 0.0, disc)
    root = np.sqrt(np.where(disc >= 0.0, disc, np.nan))
    centre = eq.eta_i + eps * zs
    half = eps * root / (2.0 * A * eq.eta_i)
    return centre - half, centre + half


@dataclass(frozen=True)
class CharacteristicAmplitudes:
    """Characteristic modal amplitudes [m] of one resonance, Eqs. (33)-(36), (39)-(42), (D.10)-(D.13), (D.16)-(D.19).

    Attributes
    ----------
    A_min1 : float
        Slip threshold ``rho/(kappa r)``: below it the element sticks (Eqs. (33), (39), (D.10), (D.16)).
    A_min2 : float
        The second root of the radicand of Eq. (32), from the no-slip branch ``a < rho`` where
        Eq. (30) does not apply (always ``< A_min1``).
    A_min : float
        ``max(A_min1, A_min2)`` (Eqs. (36), (42), (D.13), (D.19)).
    A_max : float
        Peak of the frequency-response curve (radicand zero); ``inf`` when
        ``rho <= rho_min`` (unbounded response).
    """

    A_min1: float
    A_min2: float
    A_min: float
    A_max: float


def characteristic_amplitudes(
    model: str, params: dict[str, float], mode: int, eps: float = EPS, printed: bool = False
) -> CharacteristicAmplitudes:
    """Characteristic amplitudes, Eqs. (33)-(36), (39)-(42) (absorber), (D.10)-(D.13), (D.16)-(D.19) (isolator).

    The radicand of Eq. (32) vanishes where ``4 (Wc/r) rho |a - rho| = pi |Fc| f kappa A``::

        A_min1 = rho/(kappa r)
        A_min2 = 4 (Wc/r) rho^2 / (kappa (4 Wc rho + pi |Fc| f))
        A_max  = 4 (Wc/r) rho^2 / (kappa (4 Wc rho - pi |Fc| f))     (inf if the denominator <= 0)

    absorber ``Wc/r = mu p``, ``Wc = mu p r2i``, ``Fc = G_i``; isolator ``Wc = Fc = r = r1i``.

    Parameters
    ----------
    model, params, mode, eps
        As for :func:`modal_equation`.
    printed : bool, optional
        As printed. Absorber: signed ``G_i`` in place of ``|G_i|`` (Eqs. (34), (40)-(41); differs
        for mode 2, where ``G_2 < 0``, erratum 14: the printed ``A_max`` is then the lower root).
        Isolator: Eqs. (D.11)-(D.12)/(D.17)-(D.18) with the ``pi f`` signs swapped and the extra
        ``r1i`` on ``rho`` (erratum 12), and (D.13) taking mode 2's values for mode 1 (erratum 13).

    Returns
    -------
    CharacteristicAmplitudes
    """
    eq = modal_equation(model, params, mode, eps)  # D.3-D.9 use r12 even as printed
    nd = eq.nd
    rho, kap, f = nd.rho, nd.kappa, nd.f
    wr = eq.Wc / eq.r
    a_min1 = rho / (kap * eq.r)
    G = abs(eq.Fc)
    if printed and model == "absorber":
        G = eq.Fc
    if printed and model == "isolator":
        r = eq.r
        a_min2 = 4 * rho**2 / (kap * r * (4 * r * rho - np.pi * f))
        den = kap * r * (4 * r * rho + np.pi * f)
        a_max = 4 * rho**2 / den
        if mode == 1:
            other = characteristic_amplitudes(model, params, 2, eps, printed=True)
            return CharacteristicAmplitudes(a_min1, a_min2, max(other.A_min1, other.A_min2), a_max)
        return CharacteristicAmplitudes(a_min1, a_min2, max(a_min1, a_min2), a_max)
    a_min2 = 4 * wr * rho**2 / (kap * (4 * eq.Wc * rho + np.pi * G * f))
    den = kap * (4 * eq.Wc * rho - np.pi * G * f)
    a_max = 4 * wr * rho**2 / den if den > 0 else math.inf
    return CharacteristicAmplitudes(a_min1, a_min2, max(a_min1, a_min2), a_max)


def rho_min(
    model: str, params: dict[str, float], mode: int, eps: float = EPS, printed: bool = False
) -> float:
    """Smallest friction with a bounded resonance, Eqs. (35), (43), (D.14), (D.20) of [1].

    ``A_max > 0`` requires ``rho > pi |Fc| f/(4 Wc)``: absorber ``pi f |G_i|/(4 mu p r2i)``, isolator
    ``pi f/4``. Below it the response grows without bound at resonance (first-order averaging).

    Parameters
    ----------
    model, params, mode, eps
        As for :func:`modal_equation`.
    printed : bool, optional
        Absorber mode 2: the printed Eq. (43) with the signed ``G_2 < 0`` (negative, erratum 14).

    Returns
    -------
    float
        ``rho_min`` [m/eps]; :func:`breakaway_force` converts it to ``R_min`` [N].
    """
    eq = modal_equation(model, params, mode, eps)  # D.3-D.9 use r12 even as printed
    G = eq.Fc if printed else abs(eq.Fc)
    return float(np.pi * G * eq.nd.f / (4.0 * eq.Wc))


def rho_opt(
    model: str, params: dict[str, float], mode: int, eps: float = EPS, printed: bool = False
) -> float:
    """Friction that minimises ``A_max``, Eqs. (37), (44), (51), (D.15), (D.21) of [1].

    ``d A_max/d rho = 0`` at ``rho = pi |Fc| f/(2 Wc) = 2 rho_min``: absorber
    ``pi f |G_i|/(2 mu p r2i)``, isolator ``pi f/2`` for both modes (Eq. (51)).

    Parameters
    ----------
    model, params, mode, eps
        As for :func:`modal_equation`.
    printed : bool, optional
        Absorber mode 2: the printed Eq. (44) with the signed ``G_2 < 0`` (negative, erratum 14).

    Returns
    -------
    float
        ``rho_opt`` [m/eps]; :func:`breakaway_force` converts it to ``R_opt`` [N].
    """
    return 2.0 * rho_min(model, params, mode, eps, printed)


def breakaway_force(model: str, params: dict[str, float], rho: float, eps: float = EPS) -> float:
    """Breakaway force ``R`` [N] of a nondimensional friction ``rho``, inverting Eq. (14)/(20) of [1].

    ``R = eps rho (c2 + c3)`` (absorber) or ``eps rho (c1 + c3)`` (isolator).

    Parameters
    ----------
    model : str
        ``"absorber"`` or ``"isolator"``.
    params : dict[str, float]
        Damper parameters (``c1, c2, c3`` used).
    rho : float
        Nondimensional friction [m/eps].
    eps : float, optional
        The small parameter ``rho`` was computed with.

    Returns
    -------
    float
        ``R`` [N].
    """
    nd = nondimensional(model, params, eps)
    return eps * rho * (nd.c_series + params["c3"])


def physical_amplitudes(
    model: str, params: dict[str, float], mode: int, A: ArrayLike
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Amplitudes of ``x1``, ``x2`` from the modal amplitude, Eqs. (45)-(46), (49)-(50), (D.22)-(D.23) of [1].

    Absorber: ``A_x1 = A |mu r2i - r1i|``, ``A_x2 = A |mu r2i - r1i - r2i|``; isolator:
    ``A_x1 = A |r1i|``, ``A_x2 = A |r2i|`` (the other mode neglected). Independent of the
    normalisation of ``R``, since ``A`` scales inversely.

    Parameters
    ----------
    model, params, mode
        As for :func:`modal_equation`.
    A : array_like
        Modal amplitude [m].

    Returns
    -------
    A_x1, A_x2 : ndarray
        [m], with the shape of ``A``.
    """
    eq = modal_equation(model, params, mode)
    A = np.asarray(A, dtype=float)
    return abs(eq.x1) * A, abs(eq.x2) * A


@dataclass(frozen=True)
class FrequencyResponse:
    """One resonance of the averaging model, both branches of Eq. (32)/(38)/(47)/(48)/(D.8)/(D.9).

    Along the curve, parametrised by the modal amplitude ``A`` (ascending up to ``A_max``),
    ``eta_lo < eta_hi`` are the two frequencies with that amplitude (they meet at ``A_max``).

    Attributes
    ----------
    A : ndarray
        Modal amplitude [m].
    eta_lo, eta_hi : ndarray
        Frequencies ``Omega/k`` [-] of the two branches; ``nan`` where the radicand is negative.
    Omega_lo, Omega_hi : ndarray
        The same in [rad/s].
    x1, x2 : ndarray
        Amplitudes [m] of ``x1``, ``x2`` (Eqs. (45)-(46), (49)-(50)).
    stability_lo, stability_hi : tuple of str
        :func:`stability` of each point.
    slipping : ndarray of bool
        ``A > A_min1`` (stick-slip); else the element sticks (linear stick resonance).
    amplitudes : CharacteristicAmplitudes
    """

    A: NDArray[np.float64]
    eta_lo: NDArray[np.float64]
    eta_hi: NDArray[np.float64]
    Omega_lo: NDArray[np.float64]
    Omega_hi: NDArray[np.float64]
    x1: NDArray[np.float64]
    x2: NDArray[np.float64]
    stability_lo: tuple[str, ...]
    stability_hi: tuple[str, ...]
    slipping: NDArray[np.bool_]
    amplitudes: CharacteristicAmplitudes


def _psi(eq: ModalEquation, A: float, eta: float, printed: bool) -> float:
    zc, zs, _, _ = _zeta(eq, np.asarray([A]), printed)
    ff = eq.Fc * eq.nd.f
    s = 2.0 * eq.eta_i * zc[0] / ff
    c = 2.0 * A * eq.eta_i * ((eq.eta_i - eta) / eq.nd.eps + zs[0]) / ff
    return math.atan2(s, c)


def frequency_response(
    model: str,
    params: dict[str, float],
    mode: int,
    A: ArrayLike | None = None,
    n: int = 400,
    window: float = 0.1,
    eps: float = EPS,
    printed: bool = False,
) -> FrequencyResponse:
    """Implicit frequency-response curve, Eqs. (32), (38) (absorber), (47)-(48), (D.8)-(D.9) (isolator) of [1].

    The fixed points of :func:`averaged_rhs` satisfy::

        eta = eta_i + eps zeta_sin(A) -/+ eps/(2 A eta_i) sqrt(Fc^2 f^2 - 4 zeta_cos(A)^2 eta_i^2)

    Below ``A_min1`` this is the linear stick resonance ``eta_i -/+ eps |Fc| f/(2 A eta_i)``.

    Parameters
    ----------
    model, params, mode, eps
        As for :func:`modal_equation`.
    A : array_like, optional
        Modal amplitudes [m] at which to evaluate the curve. Default: ``n`` points, geometric
        from where the stick branch is ``window eta_i`` away from ``eta_i`` up to ``A_max``
        (to ``1e3 A_min1`` if unbounded), including ``A_min1`` and ``A_max``.
    n : int, optional
        Number of default amplitudes.
    window : float, optional
        Relative half-width in ``eta`` at which the default grid starts.
    printed : bool, optional
        Evaluate with the printed ``zeta`` of D.7 (isolator mode 2, erratum 11).

    Returns
    -------
    FrequencyResponse
    """
    eq = modal_equation(model, params, mode, eps)  # D.3-D.9 use r12 even as printed
    amps = characteristic_amplitudes(model, params, mode, eps, printed=False)
    if A is None:
        lo = eps * abs(eq.Fc) * eq.nd.f / (2.0 * eq.eta_i * window * eq.eta_i)
        hi = amps.A_max if math.isfinite(amps.A_max) else 1e3 * amps.A_min1
        lo = min(lo, 0.5 * amps.A_min1)
        grid = np.geomspace(lo, hi, n)
        Aa = np.unique(np.concatenate([grid, [amps.A_min1, hi]]))
        Aa = Aa[Aa <= hi]
    else:
        Aa = np.asarray(A, dtype=float).reshape(-1)
    peak = amps.A_max if not printed else math.nan
    elo, ehi = _branches(eq, Aa, printed, peak)
    stab = []
    for etas in (elo, ehi):
        row = []
        for a, e in zip(Aa, etas, strict=True):
            if not np.isfinite(e):
                row.append("none")
                continue
            ps = _psi(eq, float(a), float(e), printed)
            J = averaged_jacobian(model, params, mode, float(a), ps, float(e), eps, printed)
            row.append(stability(np.linalg.eigvals(J)))
        stab.append(tuple(row))
    x1, x2 = physical_amplitudes(model, params, mode, Aa)
    k = eq.nd.k
    return FrequencyResponse(Aa, elo, ehi, elo * k, ehi * k, x1, x2, stab[0], stab[1], Aa > amps.A_min1, amps)


@dataclass(frozen=True)
class FixedPoint:
    """A fixed point of the averaged equations and its stability.

    Attributes
    ----------
    A : float
        Modal amplitude [m].
    psi : float
        Phase ``phi - eta tau`` [rad].
    branch : str
        ``"lo"`` or ``"hi"``: the sign of the root in Eq. (32).
    slipping : bool
        ``A > A_min1``.
    eigenvalues : ndarray
        Of :func:`averaged_jacobian` [per unit tau].
    stability : str
        See :func:`stability`.
    x1, x2 : float
        Physical amplitudes [m].
    """

    A: float
    psi: float
    branch: str
    slipping: bool
    eigenvalues: NDArray[np.complex128]
    stability: str
    x1: float
    x2: float


def fixed_points(
    model: str,
    params: dict[str, float],
    mode: int,
    eta: float | None = None,
    eps: float = EPS,
    printed: bool = False,
) -> list[FixedPoint]:
    """All fixed points of the averaged equations at one frequency, with their stability.

    Roots in ``A`` of ``eta_lo(A) = eta`` and ``eta_hi(A) = eta`` (Eqs. (32), (38), (47),
    (48), (D.8), (D.9)) on ``(0, A_max]``, bracketed on a dense geometric grid and refined by
    Brent's method; ``psi`` from ``sin(psi) = 2 eta_i zeta_cos/(Fc f)``,
    ``cos(psi) = 2 A eta_i (delta_i + zeta_sin)/(Fc f)``; stability from the eigenvalues of
    :func:`averaged_jacobian`.

    Parameters
    ----------
    model, params, mode, eps, printed
        As for :func:`averaged_rhs`.
    eta : float, optional
        ``Omega/k`` [-]; default from ``params["Omega"]``.

    Returns
    -------
    list of FixedPoint
        Sorted by ``A``.
    """
    eq = modal_equation(model, params, mode, eps)  # D.3-D.9 use r12 even as printed
    et = eq.nd.eta if eta is None else float(eta)
    amps = characteristic_amplitudes(model, params, mode, eps)
    zs_inf = abs(eq.Wc * eq.nd.kappa * eq.r / (2.0 * eq.eta_i))  # |zeta_sin| <= its limit a -> inf
    lo = eps * abs(eq.Fc) * eq.nd.f / (2.0 * eq.eta_i * (abs(et - eq.eta_i) + eps * zs_inf + eq.eta_i)) / 2.0
    top = amps.A_max if math.isfinite(amps.A_max) else 1e6 * amps.A_min1
    grid = np.geomspace(lo, top, 4001)
    tail = top * (1.0 - np.geomspace(1e-2, 1e-13, 60))
    grid = np.unique(np.concatenate([grid, tail, [amps.A_min1, top]]))
    grid = grid[grid <= top]
    out: list[FixedPoint] = []
    for b, name in ((0, "lo"), (1, "hi")):

        def g(a: float, b: int = b) -> float:
            return float(_branches(eq, np.asarray([a]), printed)[b][0]) - et

        vals = _branches(eq, grid, printed)[b] - et
        for j in range(grid.size - 1):
            v0, v1 = vals[j], vals[j + 1]
            if not (np.isfinite(v0) and np.isfinite(v1)):
                continue
            if v0 == 0.0:
                roots = [grid[j]]
            elif v0 * v1 < 0.0:
                roots = [brentq(g, grid[j], grid[j + 1], xtol=1e-15 * grid[j + 1], rtol=1e-15)]
            else:
                continue
            for a in roots:
                ps = _psi(eq, a, et, printed)
                ev = np.linalg.eigvals(averaged_jacobian(model, params, mode, a, ps, et, eps, printed))
                x1, x2 = physical_amplitudes(model, params, mode, a)
                out.append(
                    FixedPoint(
                        float(a), ps, name, bool(a > amps.A_min1), ev, stability(ev), float(x1), float(x2)
                    )
                )
    out.sort(key=lambda p: p.A)
    return out
