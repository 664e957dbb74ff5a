"""Closed-form results for the linear (sticking) dampers, Appendix A of Aramendiz et al.

Both dampers behave as the same linear two-mass system while the friction element sticks:
mass ``m1`` is tied to the ground by ``c1`` and mass ``m2`` is tied to ``m1`` by ``c2``. For
the absorber the third spring ``c3`` is then rigid (``u = x2 - w0``); for the isolator the
connecting point is frozen at ``u = u0``.

Parameters are plain dicts with keys ``m1, m2`` [kg], ``c1, c2, c3`` [N/m], ``R, F`` [N] and
``Omega`` [rad/s]. State vectors are ordered ``(x1, v1, x2, v2, u)`` in [m, m/s, m, m/s, m].
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import ArrayLike, NDArray

MODELS = ("absorber", "isolator")
_REQUIRED = ("m1", "m2", "c1", "c2", "c3", "R", "F", "Omega")


def check_model(model: str) -> str:
    """Validate a damper name.

    Parameters
    ----------
    model : str
        ``"absorber"`` or ``"isolator"``.

    Returns
    -------
    str
        The validated name.

    Raises
    ------
    ValueError
        If ``model`` is not one of the allowed names.
    """
    if model not in MODELS:
        raise ValueError(f"model must be one of {MODELS!r}, got {model!r}")
    return model


def check_params(params: dict[str, float]) -> None:
    """Validate a parameter dict.

    Parameters
    ----------
    params : dict[str, float]
        Must contain ``m1, m2`` [kg] > 0, ``c1, c2, c3`` [N/m] > 0, ``R`` [N] >= 0,
        ``F`` [N] and ``Omega`` [rad/s].

    Raises
    ------
    ValueError
        If a key is missing or a mass/stiffness is not positive or ``R`` is negative.
    """
    missing = [k for k in _REQUIRED if k not in params]
    if missing:
        raise ValueError(f"params is missing keys {missing}; required keys are {_REQUIRED}")
    for key in ("m1", "m2", "c1", "c2", "c3"):
        if not params[key] > 0.0:
            raise ValueError(f"params[{key!r}] must be > 0, got {params[key]!r}")
    if not params["R"] >= 0.0:
        raise ValueError(f"params['R'] must be >= 0, got {params['R']!r}")


def _omega(params: dict[str, float], Omega: ArrayLike | None) -> NDArray[np.float64]:
    return np.asarray(params["Omega"] if Omega is None else Omega, dtype=float)


def stick_amplitudes(
    params: dict[str, float], Omega: ArrayLike | None = None
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Signed amplitudes of the forced stick response, Eqs. (A.1)-(A.2).

    ``x1 = A1 sin(Omega t)`` and ``x2 = A2 sin(Omega t)`` with
    ``Delta = m1 m2 Omega^4 - (c1 m2 + (m1 + m2) c2) Omega^2 + c1 c2``,
    ``A1 = (c2 - m2 Omega^2) F / Delta`` and ``A2 = c2 F / Delta``.

    Parameters
    ----------
    params : dict[str, float]
        Damper parameters (``m1, m2, c1, c2, F`` are used).
    Omega : array_like, optional
        Excitation frequency [rad/s]; defaults to ``params["Omega"]``.

    Returns
    -------
    A1, A2 : ndarray
        Amplitudes [m] with the shape of ``Omega`` (0-d for a scalar). They are infinite at
        the stick eigenfrequencies.
    """
    m1, m2, c1, c2, F = (params[k] for k in ("m1", "m2", "c1", "c2", "F"))
    w2 = _omega(params, Omega) ** 2
    delta = m1 * m2 * w2**2 - (c1 * m2 + (m1 + m2) * c2) * w2 + c1 * c2
    with np.errstate(divide="ignore", invalid="ignore"):
        a1 = (c2 - m2 * w2) * F / delta
        a2 = c2 * F / delta
    return a1, a2


def stick_response(
    model: str, params: dict[str, float], t: ArrayLike, w0: float = 0.0
) -> NDArray[np.float64]:
    """Forced periodic response of the sticking damper, Eqs. (A.1)-(A.3).

    The oscillating part is ``x1 = A1 sin(Omega t)``, ``x2 = A2 sin(Omega t)`` (see
    :func:`stick_amplitudes`). The constant offset of the friction element is ``w0``:

    * absorber: ``u = x2 - w0``; the static equilibrium shifts ``x2`` by ``+w0``, so
      ``x1 = A1 sin``, ``x2 = A2 sin + w0``, ``u = A2 sin``;
    * isolator: ``u = w0`` (the paper's ``u0``); both masses shift by ``+w0``, so
      ``x1 = A1 sin + w0``, ``x2 = A2 sin + w0``, ``u = w0``.

    For ``w0 = 0`` this is exactly Eqs. (A.1)-(A.3). For ``w0 != 0`` the paper writes the
    offset-free ``x1, x2`` of (A.1)-(A.2), which do not satisfy the stick equations of
    motion; the static shift above makes the returned state an exact solution.

    Parameters
    ----------
    model : str
        ``"absorber"`` or ``"isolator"``.
    params : dict[str, float]
        Damper parameters; ``params["Omega"]`` [rad/s] is the excitation frequency.
    t : array_like
        Times [s], any shape (flattened).
    w0 : float, optional
        Constant relative displacement of the friction element [m].

    Returns
    -------
    ndarray, shape (n, 5)
        States ``(x1, v1, x2, v2, u)`` [m, m/s, m, m/s, m] at the ``n`` times.
    """
    check_model(model)
    check_params(params)
    omega = float(params["Omega"])
    a1, a2 = (float(a) for a in stick_amplitudes(params))
    tt = np.asarray(t, dtype=float).reshape(-1)
    s = np.sin(omega * tt)
    c = np.cos(omega * tt)
    out = np.empty((tt.size, 5))
    out[:, 0] = a1 * s
    out[:, 1] = a1 * omega * c
    out[:, 2] = a2 * s + w0
    out[:, 3] = a2 * omega * c
    if model == "absorber":
        out[:, 4] = out[:, 2] - w0
    else:
        out[:, 0] += w0
        out[:, 4] = w0
    return out


def limit_amplitude(
    model: str,
    params: dict[str, float],
    Omega: ArrayLike | None = None,
    offset: float = 0.0,
) -> NDArray[np.float64]:
    """Limit amplitude ``A_L`` below which the damper surely sticks, Eqs. (5) and (9).

    * absorber: ``A_L = |(m2 Omega^2 - c2) / (m2 Omega^2 c2)| (R - (c2 + c3)|w0|)``;
    * isolator: ``A_L = (R - (c1 + c3)|u0|) / c1`` (independent of ``Omega``).

    Parameters
    ----------
    model : str
        ``"absorber"`` or ``"isolator"``.
    params : dict[str, float]
        Damper parameters.
    Omega : array_like, optional
        Excitation frequency [rad/s]; defaults to ``params["Omega"]``.
    offset : float, optional
        ``w0`` (absorber) or ``u0`` (isolator) [m].

    Returns
    -------
    ndarray
        ``A_L`` [m] with the shape of ``Omega``; ``inf`` at ``Omega = 0`` for the absorber.

    Raises
    ------
    ValueError
        If ``|offset|`` exceeds ``R/(c2 + c3)`` (absorber) or ``R/(c1 + c3)`` (isolator).
    """
    check_model(model)
    check_params(params)
    m2, c1, c2, c3, R = (params[k] for k in ("m2", "c1", "c2", "c3", "R"))
    stiff = c2 + c3 if model == "absorber" else c1 + c3
    if abs(offset) > R / stiff:
        names = "R/(c2 + c3)" if model == "absorber" else "R/(c1 + c3)"
        raise ValueError(f"|offset| must be <= {names} = {R / stiff!r} m, got {offset!r}")
    margin = R - stiff * abs(offset)
    w2 = _omega(params, Omega) ** 2
    if model == "isolator":
        return np.full_like(w2, margin / c1)
    with np.errstate(divide="ignore"):
        return np.abs((m2 * w2 - c2) / (m2 * w2 * c2)) * margin


def _two_mass_eigenfrequencies(m1: float, m2: float, k1: float, k2: float) -> tuple[float, float]:
    """Eigenfrequencies [rad/s] of ground--k1--m1--k2--m2, ascending."""
    # Roots lambda = omega^2 of m1 m2 l^2 - (k1 m2 + (m1 + m2) k2) l + k1 k2 = 0.
    b = k1 * m2 + (m1 + m2) * k2
    a = m1 * m2
    c = k1 * k2
    disc = math.sqrt(b * b - 4.0 * a * c)  # > 0 for positive parameters
    hi = (b + disc) / (2.0 * a)
    lo = c / (a * hi)  # Vieta, avoids cancellation
    return math.sqrt(lo), math.sqrt(hi)


def stick_eigenfrequencies(params: dict[str, float]) -> tuple[float, float]:
    """Eigenfrequencies of the sticking system (both dampers).

    Parameters
    ----------
    params : dict[str, float]
        Damper parameters (``m1, m2, c1, c2`` are used).

    Returns
    -------
    w1, w2 : float
        Eigenfrequencies [rad/s], ``w1 < w2``.
    """
    check_params(params)
    return _two_mass_eigenfrequencies(params["m1"], params["m2"], params["c1"], params["c2"])


def slip_eigenfrequencies(model: str, params: dict[str, float]) -> tuple[float, float]:
    """Eigenfrequencies of the slipping system.

    While slipping, the friction force is constant and the spring in series with the
    friction element (``c3``) acts in series with ``c2`` (absorber) or ``c1`` (isolator):
    ``c2 -> c2 c3 / (c2 + c3)`` or ``c1 -> c1 c3 / (c1 + c3)``.

    Parameters
    ----------
    model : str
        ``"absorber"`` or ``"isolator"``.
    params : dict[str, float]
        Damper parameters.

    Returns
    -------
    w1, w2 : float
        Eigenfrequencies [rad/s], ``w1 < w2``.
    """
    check_model(model)
    check_params(params)
    m1, m2, c1, c2, c3 = (params[k] for k in ("m1", "m2", "c1", "c2", "c3"))
    if model == "absorber":
        return _two_mass_eigenfrequencies(m1, m2, c1, c2 * c3 / (c2 + c3))
    return _two_mass_eigenfrequencies(m1, m2, c1 * c3 / (c1 + c3), c2)


def band_edges(model: str, params: dict[str, float], lo: float, hi: float) -> tuple[float, float]:
    """The two ends [rad/s] of the stick-slip band around the stick eigenfrequency inside ``(lo, hi)``.

    The centred stick orbit (offset 0) slips where its amplitude of ``x1`` reaches the structural-
    change limit: ``|A1(Omega)| = A_L(Omega)`` (Eqs. (A.1)-(A.2) against Eq. (5) or (9)); one
    crossing below the eigenfrequency, one above (brentq to rounding).

    Parameters
    ----------
    model : str
        ``"absorber"`` or ``"isolator"``.
    params : dict[str, float]
        Damper parameters.
    lo, hi : float
        A window [rad/s] holding one stick eigenfrequency and both ends of its band.

    Returns
    -------
    (float, float)
        The band's lower and upper end [rad/s].

    Raises
    ------
    ValueError
        No stick eigenfrequency in the window, or no crossing on one side of it.
    """
    from scipy.optimize import brentq

    check_model(model)
    check_params(params)

    def f(w: float) -> float:
        return abs(float(stick_amplitudes(params, w)[0])) - float(limit_amplitude(model, params, w))

    inside = [w for w in stick_eigenfrequencies(params) if lo < w < hi]
    if not inside:
        raise ValueError(f"no stick eigenfrequency in ({lo!r}, {hi!r})")
    w_res = inside[0]
    eps = 1e-9 * w_res
    return (
        brentq(f, lo, w_res - eps, xtol=1e-16, rtol=8.9e-16, maxiter=300),
        brentq(f, w_res + eps, hi, xtol=1e-16, rtol=8.9e-16, maxiter=300),
    )
