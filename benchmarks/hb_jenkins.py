"""A single oscillator with a Jenkins element: exact EPMC backbone and a minimal harmonic balance
(issue 31, item 3), written independently of the library (numpy and scipy only).

The oscillator: a mass ``m`` on a spring ``k`` to ground and a Jenkins element to ground (a spring
``kt`` in series with a Coulomb slider of slip force ``Fs``); optionally a viscous damper ``c`` and a
force ``F cos(Omega t)`` (the forced response). Its Jenkins force ``f`` obeys ``|f| <= Fs``:
``f' = kt x'`` while the slider sticks, ``f = +-Fs`` while it slides.

* :func:`exact_backbone`: the nonlinear mode by the extended periodic motion concept (EPMC, Krack
  2015): the free motion ``m x'' - xi m x' + k x + f = 0`` with the negative damping ``-xi m x'``
  that makes it periodic, at the amplitude ``a = max x``. Half-period shooting of the
  piecewise-linear motion: from the turning point ``x = a, v = 0`` (``f = Fs``) the slider sticks
  until ``f = -Fs`` (``x = a - 2 Fs/kt``), then slides until ``v = 0``, where the orbit must reach
  ``x = -a`` after half a period. Each phase is an affine flow of a damped oscillator, in closed form; the switch times by brentq; (omega, xi) by fsolve. ``D = xi/(2 omega)``.
* :func:`describing_function`: the single-harmonic equivalent stiffness and damping of the Jenkins
  element (Caughey 1960), closed form.
* :class:`HarmonicBalance`: harmonic balance on the odd harmonics 1, 3, ..., H with alternating
  frequency-time (AFT): the Jenkins force computed in time from the sampled displacement (the
  play operator over two periods, the second kept), back by the discrete Fourier transform; Newton
  on the Fourier coefficients with the exact Jacobian of the sampled play operator; for the
  backbone also on xi and omega, with the phase condition ``x'(0) = 0`` and the amplitude condition
  ``x(0) = a``.

Units: m [kg], k, kt [N/m], Fs, F [N], c [N s/m], omega [rad/s], xi [1/s], a [m].
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from scipy.optimize import brentq, fsolve


@dataclass(frozen=True)
class Jenkins:
    """The oscillator's parameters (SI units; ``c`` and ``F`` for the forced response only)."""

    m: float = 1.0
    k: float = 1.0
    kt: float = 1.0
    Fs: float = 1.0
    c: float = 0.0
    F: float = 0.0

    @property
    def slip_amplitude(self) -> float:
        """The amplitude of first slip ``Fs/kt`` [m]."""
        return self.Fs / self.kt


# --------------------------------------------------------------------------------------------------
# single-harmonic closed form


def describing_function(a: np.ndarray | float, kt: float, Fs: float) -> tuple[np.ndarray, np.ndarray]:
    """Equivalent stiffness and damping force of a Jenkins element under ``x = a cos(theta)``.

    The first harmonic of the element's force is ``a (K cos(theta) - C sin(theta))`` (Caughey 1960):
    with ``cos(phi) = 1 - 2 Fs/(kt a)``, ``K = kt (phi - sin(2 phi)/2)/pi`` and
    ``C = kt sin(phi)^2 / pi`` (``C = 4 Fs (a - Fs/kt)/(pi a^2)``: the dissipation per cycle is
    ``pi C a^2``); below first slip (``a <= Fs/kt``) ``K = kt``, ``C = 0``.

    Parameters
    ----------
    a : float or array
        Amplitude [m].
    kt, Fs : float
        Stiffness of the element's spring [N/m], slip force [N].

    Returns
    -------
    K, C : arrays
        Equivalent stiffness [N/m] and equivalent damping force per unit amplitude [N/m].
    """
    a = np.asarray(a, dtype=float)
    r = np.clip(1.0 - 2.0 * Fs / (kt * np.maximum(a, 1e-300)), -1.0, 1.0)
    phi = np.arccos(r)
    K = kt * (phi - np.sin(2.0 * phi) / 2.0) / math.pi
    C = kt * np.sin(phi) ** 2 / math.pi
    return K, C


def single_harmonic_backbone(amplitudes, osc: Jenkins = Jenkins()) -> dict:
    """EPMC backbone in the single-harmonic approximation (approximate; closed form).

    ``omega^2 = (k + K(a))/m``, ``xi = C(a)/(m omega)``, ``D = xi/(2 omega)``.
    """
    a = np.asarray(amplitudes, dtype=float)
    K, C = describing_function(a, osc.kt, osc.Fs)
    omega = np.sqrt((osc.k + K) / osc.m)
    xi = C / (osc.m * omega)
    return {"amplitude": a, "omega": omega, "xi": xi, "damping_ratio": xi / (2.0 * omega)}


# --------------------------------------------------------------------------------------------------
# exact EPMC backbone by half-period shooting


def _flow(w2: float, xi: float, g: float, t: float, y: tuple[float, float]) -> tuple[float, float]:
    """Exact flow of ``x'' = xi x' - w2 x + g`` over ``t`` from ``y = (x, v)`` (underdamped:
    ``xi^2 < 4 w2``): ``x - g/w2 = exp(xi t/2) (A cos(nu t) + B sin(nu t))``."""
    s = 0.5 * xi
    nu = math.sqrt(w2 - s * s)
    z0, v0 = y[0] - g / w2, y[1]
    e, c, sn = math.exp(s * t), math.cos(nu * t), math.sin(nu * t)
    x = g / w2 + e * (z0 * c + (v0 - s * z0) / nu * sn)
    v = e * (v0 * c + (s * v0 - w2 * z0) / nu * sn)
    return x, v


def _half_period(osc: Jenkins, a: float, omega: float, xi: float) -> tuple[float, float, float, float]:
    """From ``x = a, v = 0`` (slider just stuck, ``f = Fs``): (stick time, slide time, x, v) at the
    end of the slide (``v = 0`` again).

    In each phase the velocity is ``exp(xi t/2)`` times a sinusoid of half period ``pi/nu``: its
    next zero lies in ``(0, pi/nu]``, and so does the stick phase's end (``a > Fs/kt``), where
    ``x`` falls monotonically: each switch time is the only root of brentq's bracket.
    """
    m, k, kt, Fs = osc.m, osc.k, osc.kt, osc.Fs
    if xi * xi >= 4.0 * k / m:
        raise ValueError(f"exact_backbone: xi = {xi} is not underdamped for k/m = {k / m}")
    # stick: m x'' = xi m x' - (k + kt) x + (kt a - Fs); ends where f = Fs + kt (x - a) = -Fs
    w2s, gs = (k + kt) / m, (kt * a - Fs) / m
    target = a - 2.0 * Fs / kt
    y0 = (a, 0.0)
    t_end = math.pi / math.sqrt(w2s - xi * xi / 4.0)
    t1 = brentq(lambda t: _flow(w2s, xi, gs, t, y0)[0] - target, 0.0, t_end, xtol=1e-15, rtol=1e-15)
    y1 = _flow(w2s, xi, gs, t1, y0)
    # slide backwards (v < 0, f = -Fs): m x'' = xi m x' - k x + Fs, until v = 0
    w2, g = k / m, Fs / m
    s_end = math.pi / math.sqrt(w2 - xi * xi / 4.0)
    s = brentq(lambda s: _flow(w2, xi, g, s, y1)[1], 0.0, s_end, xtol=1e-15, rtol=1e-15)
    y2 = _flow(w2, xi, g, s, y1)
    return t1, s, float(y2[0]), float(y2[1])


def exact_backbone(amplitudes, osc: Jenkins = Jenkins()) -> dict:
    """Exact EPMC backbone of the Jenkins oscillator (independent of the library).

    Parameters
    ----------
    amplitudes : sequence of float
        Amplitudes ``a = max x`` [m]; at or below ``Fs/kt`` the mode is linear and stuck.
    osc : Jenkins
        The oscillator (``c`` and ``F`` are not used).

    Returns
    -------
    dict
        Arrays ``amplitude`` [m], ``omega`` [rad/s], ``xi`` [1/s], ``damping_ratio`` (``xi/(2
        omega)``), ``dissipated`` [J] (per period, ``4 Fs (a - Fs/kt)``), ``stick_fraction`` (of
        the period) and ``residual`` (the largest of the shooting residuals, [s] and [m]).
    """
    out = {key: [] for key in ("amplitude", "omega", "xi", "damping_ratio", "dissipated", "stick_fraction")}
    out["residual"] = []
    a_s = osc.slip_amplitude
    for a in np.asarray(amplitudes, dtype=float):
        if a <= a_s:
            w = math.sqrt((osc.k + osc.kt) / osc.m)
            vals = (a, w, 0.0, 0.0, 0.0, 1.0, 0.0)
        else:
            g = single_harmonic_backbone([a], osc)

            def res(z, a=a):
                omega, xi = z
                t1, s, x2, _ = _half_period(osc, a, omega, xi)
                return [t1 + s - math.pi / omega, (x2 + a) / a]

            z, info, ier, msg = fsolve(res, [g["omega"][0], g["xi"][0]], xtol=1e-15, full_output=True)
            r = float(np.max(np.abs(res(z))))
            if r > 1e-11:
                raise RuntimeError(
                    f"exact_backbone: shooting did not converge at a = {a}: {msg} (residual {r})"
                )
            omega, xi = float(z[0]), float(z[1])
            t1, _, _, _ = _half_period(osc, a, omega, xi)
            vals = (a, omega, xi, xi / (2 * omega), 4 * osc.Fs * (a - a_s), t1 * omega / math.pi, r)
        for key, v in zip(out, vals, strict=True):
            out[key].append(v)
    return {key: np.array(v) for key, v in out.items()}


# --------------------------------------------------------------------------------------------------
# harmonic balance with alternating frequency-time


class HarmonicBalance:
    """Harmonic balance of the Jenkins oscillator on the odd harmonics 1, 3, ..., H (AFT).

    Parameters
    ----------
    osc : Jenkins
        The oscillator.
    H : int
        Highest harmonic (odd).
    N : int, optional
        Time samples per period (default ``256 (H + 1)``, at least 1024): the sampled play
        operator's error is of order ``1/N^2`` (a turning point between two samples is cut off).
    """

    def __init__(self, osc: Jenkins, H: int, N: int | None = None):
        if H < 1 or H % 2 == 0:
            raise ValueError(f"HarmonicBalance: H must be odd and positive, got {H}")
        self.osc, self.H = osc, H
        self.N = N or max(1024, 256 * (H + 1))
        self.h = np.arange(1, H + 1, 2, dtype=float)
        tau = 2.0 * np.pi * np.arange(self.N) / self.N
        ht = np.outer(tau, self.h)
        E = np.empty((self.N, 2 * len(self.h)))
        E[:, 0::2], E[:, 1::2] = np.cos(ht), np.sin(ht)
        self.E = E  # x(tau_j) = E @ X, X = (a_1, b_1, a_3, b_3, ...)
        self.P = (2.0 / self.N) * E.T  # coefficients of a sampled signal
        rot = np.zeros((2 * len(self.h), 2 * len(self.h)))
        for i, h in enumerate(self.h):  # d/dtau: cos coefficient h b, sin coefficient -h a
            rot[2 * i, 2 * i + 1], rot[2 * i + 1, 2 * i] = h, -h
        self.D1 = rot
        self.h2 = np.repeat(self.h**2, 2)

    def jenkins(self, X: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """The Jenkins force's coefficients and their Jacobian for the displacement ``X``."""
        kt, Fs = self.osc.kt, self.osc.Fs
        x = (self.E @ X).tolist()
        n = self.N
        f = 0.0
        anchor = 0  # the sample where the current stick began (its force saturated or the start)
        fs = [0.0] * n
        anchors = [0] * n
        stuck = [True] * n
        xp = x[0]
        for it in range(2 * n):
            j = it % n
            xj = x[j]
            f += kt * (xj - xp)
            xp = xj
            if f >= Fs or f <= -Fs:
                f = Fs if f > 0 else -Fs
                anchor = j
                st = False
            else:
                st = True
            if it >= n:
                fs[j], anchors[j], stuck[j] = f, anchor, st
        F = self.P @ np.array(fs)
        st = np.array(stuck)
        dfdX = np.where(st[:, None], kt * (self.E - self.E[np.array(anchors)]), 0.0)
        return F, self.P @ dfdX

    def _linear(self, omega: float, c: float) -> np.ndarray:
        o = self.osc
        return np.diag(o.k - o.m * omega**2 * self.h2) + c * omega * self.D1

    def _newton(self, fun, z, tol: float = 1e-12, max_iter: int = 50):
        for it in range(max_iter):
            r, J = fun(z)
            dz = np.linalg.solve(J, -r)
            z = z + dz
            if np.max(np.abs(dz)) <= tol * max(1.0, np.max(np.abs(z))):
                r, _ = fun(z)
                res = float(np.max(np.abs(r)))
                if res > 1e-9 * max(1.0, np.max(np.abs(z))):
                    raise RuntimeError(f"HarmonicBalance(H={self.H}): Newton stalled at residual {res:.1e}")
                return z, it + 1, res
        raise RuntimeError(f"HarmonicBalance(H={self.H}): Newton did not converge in {max_iter} iterations")

    def pad(self, X: np.ndarray) -> np.ndarray:
        """Coefficients of another H padded with zeros (or cut) to this one's size."""
        out = np.zeros(2 * len(self.h))
        n = min(len(X), len(out))
        out[:n] = X[:n]
        return out

    def backbone_point(self, a: float, guess: tuple[np.ndarray, float, float] | None = None) -> dict:
        """EPMC point at amplitude ``a = x(0)`` with ``x'(0) = 0``: coefficients, omega, xi."""
        o = self.osc
        if guess is None:
            g = single_harmonic_backbone([a], o)
            X = np.zeros(2 * len(self.h))
            X[0] = a
            guess = (X, float(g["omega"][0]), float(g["xi"][0]))
        nX = 2 * len(self.h)
        amp_row = np.zeros(nX)
        amp_row[0::2] = 1.0
        phase_row = np.zeros(nX)
        phase_row[1::2] = self.h

        def fun(z):
            X, omega, xi = z[:nX], z[nX], z[nX + 1]
            L = self._linear(omega, -xi * o.m)
            FJ, dFJ = self.jenkins(X)
            r = np.concatenate([L @ X + FJ, [amp_row @ X - a, phase_row @ X]])
            J = np.zeros((nX + 2, nX + 2))
            J[:nX, :nX] = L + dFJ
            J[:nX, nX] = (-2.0 * o.m * omega * self.h2) * X - xi * o.m * (self.D1 @ X)
            J[:nX, nX + 1] = -o.m * omega * (self.D1 @ X)
            J[nX, :nX], J[nX + 1, :nX] = amp_row, phase_row
            return r, J

        z0 = np.concatenate([guess[0], [guess[1], guess[2]]])
        z, its, res = self._newton(fun, z0)
        X, omega, xi = z[:nX], float(z[nX]), float(z[nX + 1])
        return {"X": X, "omega": omega, "xi": xi, "damping_ratio": xi / (2 * omega), "iterations": its}

    def forced_point(self, Omega: float, guess: np.ndarray | None = None, amplitude: bool = True) -> dict:
        """Forced response to ``F cos(Omega t)``: coefficients and (``amplitude``) ``max x``.

        The default guess is the linear response with half the Jenkins stiffness.
        """
        o = self.osc
        nX = 2 * len(self.h)
        Fext = np.zeros(nX)
        Fext[0] = o.F
        L = self._linear(Omega, o.c)

        def fun(X):
            FJ, dFJ = self.jenkins(X)
            return L @ X + FJ - Fext, L + dFJ

        if guess is None:
            guess = np.zeros(nX)
            guess[0:2] = np.linalg.solve(L[:2, :2] + o.kt * np.eye(2) * 0.5, Fext[:2])
        X, its, res = self._newton(fun, guess)
        return {"X": X, "amplitude": self.max_of(X) if amplitude else None, "iterations": its}

    def max_of(self, X: np.ndarray) -> float:
        """Maximum over the period of the trigonometric polynomial ``X`` (sampled, then Newton)."""
        tau = np.linspace(0.0, 2 * np.pi, 8 * self.N, endpoint=False)
        h = self.h
        a, b = X[0::2], X[1::2]
        t = tau[int(np.argmax(np.cos(np.outer(tau, h)) @ a + np.sin(np.outer(tau, h)) @ b))]
        for _ in range(20):
            d1 = np.sum(h * (-a * np.sin(h * t) + b * np.cos(h * t)))
            d2 = np.sum(h * h * (-a * np.cos(h * t) - b * np.sin(h * t)))
            step = d1 / d2
            t -= step
            if abs(step) < 1e-15:
                break
        return float(np.sum(a * np.cos(h * t) + b * np.sin(h * t)))
