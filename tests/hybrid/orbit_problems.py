"""Reference periodic orbits for the shooting, Floquet and continuation tests.

Every reference here is computed **without the hybrid engine**: from closed forms (linear
oscillators, exact piecewise solutions between switches) or from
:func:`scipy.integrate.solve_ivp` (DOP853, ``rtol`` 1e-13) of the state and its variational
equations. Each problem function returns ``(system, params, reference)``: the
:class:`~hybrid.HybridSystem` (built from a model-file dictionary by
:func:`hybrid.system_from_dict`, i.e. written as data), its parameter values, and an
:class:`OrbitReference` (or, for the Duffing oscillator, a :class:`DuffingReference`).

Conventions shared by all references
------------------------------------
* The Poincaré section is ``t = t0 = 0`` (mod the forcing period ``T = 2 pi/Omega``).
* ``x0`` is the full state at the section, ordered as ``system.variable_names``; quadratures
  (work ``W``, dissipated energy ``D``, ...) are 0 there, and their gain over one period is in
  ``increments``. Slave (algebraic) variables are included at their consistent value.
* ``monodromy`` is the derivative of the period map ``x(t0) -> x(t0 + T)`` restricted to the
  differential, non-quadrature variables ``state_names`` (for the friction and impact
  oscillators it is the derivative of the exact piecewise map, taken by Richardson-extrapolated
  central differences: it includes the saltation effects without computing any saltation
  matrix). ``multipliers`` are its eigenvalues sorted by decreasing modulus.
* ``accuracy`` gives, per quantity, the absolute error bound that the self-tests in
  ``test_orbit_references.py`` verify (or a stricter one).

Summary of the problems (default parameters)
--------------------------------------------
* :func:`forced_linear_2dof` (and :func:`forced_linear_2dof_slave`, the same chain through a
  massless node ``u``, i.e. a slave variable): steady state from complex amplitudes,
  monodromy ``expm(A T)``, multipliers ``exp(lambda_k T)``, ``W = D`` per period; exact to
  rounding (~1e-14).
* :func:`duffing` (``m = 1, c = 0.05, k = 1, k3 = 0.3, F = 0.1``): folds at
  ``Omega = 1.112711260452889`` and ``1.256394847149698`` rad/s (~1e-12, confirmed by two
  formulations); three orbits (stable, saddle, stable) at ``Omega = 1.18``; Liouville
  ``det M = exp(-c T/m)`` exactly.
* :func:`friction_oscillator` (``m = 1, c = 0.2, k = 1, R = 0.4, F = 1, Omega = 0.5``):
  symmetric stick-slip orbit with two stick phases, multipliers ``(0.0788, 0)``, ``x0`` to
  ~1e-13 from the exact piecewise solution, confirmed by a solve_ivp event loop; per period
  ``W = D``, ``Df = 4 R max|x|``. :func:`friction_stick_boundary`: stick lost at
  ``Omega = 0.58970847211665`` rad/s.
* :func:`impact_oscillator` (``m = 1, c = 0.1, k = 1, g = 0.2, r = 0.8, F = 0.5,
  Omega = 1.6``): one impact per period, ``det M = r^2 exp(-c T/m)`` exactly, ``W - D`` = the
  impact loss. :func:`impact_grazing_frequencies`: the non-impacting orbit grazes the wall at
  ``Omega = 1.86895805286`` rad/s.
"""

from __future__ import annotations

import cmath
import functools
import itertools
import math
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from types import MappingProxyType

import numpy as np
from numpy.typing import ArrayLike, NDArray
from scipy.integrate import solve_ivp
from scipy.linalg import expm
from scipy.optimize import brentq, root

from hybrid import HybridSystem, system_from_dict

__all__ = [
    "OrbitReference",
    "DuffingReference",
    "classify_multipliers",
    "multiplier_distance",
    "forced_linear_2dof",
    "forced_linear_2dof_slave",
    "duffing",
    "duffing_orbits",
    "duffing_folds",
    "duffing_fold_by_parabola",
    "duffing_harmonic_balance",
    "duffing_period_map",
    "friction_oscillator",
    "friction_period_map",
    "friction_simulate_ivp",
    "impact_oscillator",
    "impact_period_map",
    "impact_grazing_frequencies",
    "friction_stick_boundary",
]

#: Relative tolerance of the solve_ivp references (DOP853; ``atol = rtol/100``).
IVP_RTOL = 1e-13


# ----------------------------------------------------------------------------
# Result objects
# ----------------------------------------------------------------------------
@dataclass(frozen=True, eq=False)
class OrbitReference:
    """An independently computed periodic orbit.

    Attributes
    ----------
    system_name : str
        Name of the model it belongs to.
    variable_names : tuple of str
        Order of ``x0`` and of the columns of ``trajectory(t)`` (``system.variable_names``).
    params : mapping of str to float
        Parameter values of the orbit (for a fold, ``Omega`` is the fold frequency).
    t0 : float
        Section time [s] (always 0).
    period : float
        ``T = 2 pi / Omega`` [s].
    mode0 : str
        Mode at the section.
    x0 : ndarray, shape (n_vars,)
        Full state at the section, quadratures 0, slave variables consistent.
    state_names : tuple of str
        Differential, non-quadrature variables: the rows and columns of ``monodromy``.
    monodromy : ndarray, shape (n_states, n_states)
        Derivative of the period map at ``x0`` (over ``state_names``).
    multipliers : ndarray of complex, shape (n_states,)
        Floquet multipliers, sorted by decreasing modulus.
    stability : {"stable", "unstable", "neutral"}
        From :func:`classify_multipliers` (``"neutral"`` at a fold).
    amplitude : mapping of str to float
        ``max_t |q(t)|`` over one period for each displacement variable ``q`` [m].
    extrema : mapping of str to (float, float)
        ``(min_t q(t), max_t q(t))`` over one period for each displacement variable [m].
    increments : mapping of str to float
        Gain of each quadrature over one period [J].
    mode_sequence : tuple of str
        Modes of the successive segments of ``[t0, t0 + T)``, starting with ``mode0`` (the last
        entry is the mode in which the period ends).
    switches : tuple of (float, str, str)
        ``(time [s], source, target)`` of every switch in ``[t0, t0 + T)``.
    accuracy : mapping of str to float
        Absolute error bounds of ``x0``, ``monodromy``, ``multipliers``, ``increments``,
        ``amplitude``, ``period``/``Omega`` (where meaningful), verified by the self-tests.
    details : mapping of str to float
        Problem-specific exact numbers (documented by the problem function).
    trajectory : callable or None
        ``trajectory(t) -> ndarray, shape (len(t), n_vars)`` for ``t`` in ``[t0, t0 + T]``
        (quadratures counted from 0 at ``t0``).
    """

    system_name: str
    variable_names: tuple[str, ...]
    params: Mapping[str, float]
    t0: float
    period: float
    mode0: str
    x0: NDArray[np.float64]
    state_names: tuple[str, ...]
    monodromy: NDArray[np.float64]
    multipliers: NDArray[np.complex128]
    stability: str
    amplitude: Mapping[str, float]
    extrema: Mapping[str, tuple[float, float]]
    increments: Mapping[str, float]
    mode_sequence: tuple[str, ...]
    switches: tuple[tuple[float, str, str], ...]
    accuracy: Mapping[str, float]
    details: Mapping[str, float] = field(default_factory=dict)
    trajectory: Callable[[ArrayLike], NDArray[np.float64]] | None = field(default=None, repr=False)

    def __post_init__(self):
        object.__setattr__(self, "params", MappingProxyType(dict(self.params)))
        for name in ("amplitude", "extrema", "increments", "accuracy", "details"):
            object.__setattr__(self, name, MappingProxyType(dict(getattr(self, name))))

    @property
    def x0_dict(self) -> dict[str, float]:
        """``x0`` as ``{variable: value}`` (usable as the initial state of :func:`hybrid.simulate`)."""
        return {n: float(v) for n, v in zip(self.variable_names, self.x0, strict=True)}

    def mode_at(self, t: float) -> str:
        """Mode at time ``t`` in ``[t0, t0 + T)`` (the target of the last switch at or before ``t``)."""
        mode = self.mode0
        for ts, _, target in self.switches:
            if ts <= t:
                mode = target
        return mode

    def state(self, names: tuple[str, ...] | None = None) -> NDArray[np.float64]:
        """``x0`` restricted to ``names`` (default ``state_names``), shape (len(names),)."""
        names = self.state_names if names is None else names
        index = {n: i for i, n in enumerate(self.variable_names)}
        return np.array([self.x0[index[n]] for n in names])


@dataclass(frozen=True, eq=False)
class DuffingReference:
    """Folds and coexisting orbits of the forced Duffing oscillator.

    Attributes
    ----------
    folds : tuple of OrbitReference
        The two fold (saddle-node) orbits, by increasing ``Omega``: the lower fold (the
        non-resonant branch is born, jump-up point) and the upper fold (the resonant branch
        ends, jump-down point). Each has a multiplier 1 and ``stability == "neutral"``.
    band : (float, float)
        ``(Omega_lower_fold, Omega_upper_fold)`` [rad/s]: three orbits coexist strictly inside.
    orbits : tuple of OrbitReference
        The orbits at ``params["Omega"]``, by increasing amplitude (three inside the band:
        stable, unstable saddle, stable).
    harmonic_balance_folds : tuple of (float, float)
        ``(Omega, amplitude)`` of the folds from one-term harmonic balance (initial guesses;
        they differ from the exact folds by ~1e-3).
    """

    folds: tuple[OrbitReference, OrbitReference]
    band: tuple[float, float]
    orbits: tuple[OrbitReference, ...]
    harmonic_balance_folds: tuple[tuple[float, float], ...]


def classify_multipliers(mu: ArrayLike, tol: float = 1e-6) -> str:
    """Stability verdict from Floquet multipliers.

    Parameters
    ----------
    mu : array_like of complex
        Multipliers.
    tol : float
        Margin around the unit circle.

    Returns
    -------
    {"stable", "unstable", "neutral"}
        ``"stable"`` if ``max |mu| < 1 - tol``, ``"unstable"`` if ``> 1 + tol``, else ``"neutral"``.
    """
    r = float(np.max(np.abs(np.asarray(mu))))
    if r < 1.0 - tol:
        return "stable"
    if r > 1.0 + tol:
        return "unstable"
    return "neutral"


def multiplier_distance(mu: ArrayLike, mu_ref: ArrayLike) -> float:
    """Largest distance between two sets of multipliers, paired optimally.

    Parameters
    ----------
    mu, mu_ref : array_like of complex, shape (n,)
        The two sets (any order; ``n <= 6``).

    Returns
    -------
    float
        ``min over pairings of max_i |mu_i - mu_ref_pi(i)|``.
    """
    a = np.asarray(mu, dtype=complex).ravel()
    b = np.asarray(mu_ref, dtype=complex).ravel()
    if a.size != b.size:
        raise ValueError(f"`mu` has {a.size} multipliers, `mu_ref` has {b.size}")
    if a.size > 6:
        raise ValueError(f"at most 6 multipliers supported, got {a.size}")
    return min(float(np.max(np.abs(a - b[list(p)]))) for p in itertools.permutations(range(a.size)))


def _sorted_multipliers(M: NDArray) -> NDArray[np.complex128]:
    mu = np.linalg.eigvals(M).astype(complex)
    return mu[np.argsort(-np.abs(mu), kind="stable")]


def _richardson_jacobian(fun: Callable[[NDArray], NDArray], x: NDArray, h: float) -> NDArray:
    """Central differences with steps h and h/2, Richardson-extrapolated (error O(h^4))."""
    x = np.asarray(x, dtype=float)
    cols = []
    for e in np.eye(x.size):
        d1 = (fun(x + h * e) - fun(x - h * e)) / (2 * h)
        d2 = (fun(x + h / 2 * e) - fun(x - h / 2 * e)) / h
        cols.append((4 * d2 - d1) / 3)
    return np.column_stack(cols)


def _model(
    name: str,
    title: str,
    variables: dict[str, tuple[str, str]],
    parameters: dict[str, tuple[str, str, str]],
    *,
    modes: dict,
    transitions: list | None = None,
    equations: dict | None = None,
    definitions: dict | None = None,
    quadratures: list[str],
    outputs: list[str],
    initial_mode: str,
    preset: dict[str, float],
    energy: dict[str, str],
) -> HybridSystem:
    """A model-file dictionary (as read from TOML) turned into a system by the loader."""
    data = {
        "model": {
            "name": name,
            "title": title,
            "reference": "tests/hybrid/orbit_problems.py",
            "period": "2*pi/Omega",
            "initial_mode": initial_mode,
            "quadratures": quadratures,
            "outputs": outputs,
        },
        "variables": {n: {"unit": u, "description": d} for n, (u, d) in variables.items()},
        "parameters": {
            n: {"unit": u, "description": d, "domain": dom} for n, (u, d, dom) in parameters.items()
        },
        "presets": {"reference": dict(preset)},
        "definitions": definitions or {},
        "equations": equations or {},
        "modes": modes,
        "transitions": transitions or [],
        "energy": energy,
    }
    return system_from_dict(data)


def _check_positive(**values: float) -> None:
    for name, value in values.items():
        if not (math.isfinite(value) and value > 0):
            raise ValueError(f"`{name}` must be a finite number > 0, got {value!r}")


# ----------------------------------------------------------------------------
# 1. Linear two-degree-of-freedom oscillators (closed form)
# ----------------------------------------------------------------------------
def _mean_product_integral(a: complex, b: complex, Omega: float, t: NDArray) -> NDArray:
    """Exact ``int_0^t Im(a e^{i Omega s}) Im(b e^{i Omega s}) ds``."""
    t = np.asarray(t, dtype=float)
    osc = (a * b * (np.exp(2j * Omega * t) - 1.0) / (2j * Omega)).real
    return 0.5 * ((a * np.conj(b)).real * t - osc)


def _linear_2dof_reference(
    system: HybridSystem,
    params: Mapping[str, float],
    Mm: NDArray,
    Cm: NDArray,
    Km: NDArray,
    dampers: list[tuple[float, NDArray]],
    slave: NDArray | None,
) -> OrbitReference:
    """Closed-form steady state of M q'' + C q' + K q = f sin(Omega t), q = (x1, x2)."""
    Omega, F = params["Omega"], params["F"]
    T = 2 * math.pi / Omega
    f = np.array([F, 0.0], dtype=complex)
    X = np.linalg.solve(Km - Omega**2 * Mm + 1j * Omega * Cm, f)  # q = Im(X e^{i Omega t})
    V = 1j * Omega * X
    # First-order matrix in the variable order (x1, v1, x2, v2).
    Minv = np.linalg.inv(Mm)
    A_blocks = np.block([[np.zeros((2, 2)), np.eye(2)], [-Minv @ Km, -Minv @ Cm]])  # (x1, x2, v1, v2)
    perm = [0, 2, 1, 3]  # (x1, v1, x2, v2) <- (x1, x2, v1, v2)
    A = A_blocks[np.ix_(perm, perm)]
    lam = np.linalg.eigvals(A)
    mu = np.exp(lam * T)
    mu = mu[np.argsort(-np.abs(mu), kind="stable")]
    Phi = expm(A * T)
    # Work of the excitation (on x1) and viscous dissipation over one period, exact.
    W_T = 0.5 * T * (F * np.conj(V[0])).real
    D_T = 0.5 * T * sum(c * abs(w @ V) ** 2 for c, w in dampers)
    x1 = np.array([X[0].imag, V[0].imag, X[1].imag, V[1].imag])
    names = system.variable_names
    values = {"x1": x1[0], "v1": x1[1], "x2": x1[2], "v2": x1[3], "W": 0.0, "D": 0.0}
    amp = {"x1": abs(X[0]), "x2": abs(X[1])}
    if slave is not None:
        U = slave @ X
        values["u"] = U.imag
        amp["u"] = abs(U)
    x0 = np.array([values[n] for n in names])

    def trajectory(t: ArrayLike) -> NDArray:
        t = np.atleast_1d(np.asarray(t, dtype=float))
        e = np.exp(1j * Omega * t)
        cols = {
            "x1": (X[0] * e).imag,
            "v1": (V[0] * e).imag,
            "x2": (X[1] * e).imag,
            "v2": (V[1] * e).imag,
            "W": _mean_product_integral(F, V[0], Omega, t),
            "D": sum(c * _mean_product_integral(w @ V, w @ V, Omega, t) for c, w in dampers),
        }
        if slave is not None:
            cols["u"] = ((slave @ X) * e).imag
        return np.column_stack([cols[n] for n in names])

    return OrbitReference(
        system_name=system.name,
        variable_names=names,
        params=params,
        t0=0.0,
        period=T,
        mode0=system.mode_names[0],
        x0=x0,
        state_names=("x1", "v1", "x2", "v2"),
        monodromy=Phi,
        multipliers=mu,
        stability=classify_multipliers(mu),
        amplitude=amp,
        extrema={n: (-a, a) for n, a in amp.items()},
        increments={"W": float(W_T), "D": float(D_T)},
        mode_sequence=(system.mode_names[0],),
        switches=(),
        accuracy={
            "x0": 1e-14,
            "monodromy": 1e-13,
            "multipliers": 1e-13,
            "increments": 1e-13,
            "amplitude": 1e-14,
        },
        details={
            "det_monodromy": float(math.exp(np.trace(A) * T)),
            "eigenvalue_real_parts": tuple(sorted(float(v) for v in lam.real)),
        },
        trajectory=trajectory,
    )


def forced_linear_2dof(
    m1: float = 1.0,
    m2: float = 0.5,
    k1: float = 1.0,
    k2: float = 0.6,
    c1: float = 0.05,
    c2: float = 0.03,
    F: float = 0.2,
    Omega: float = 1.3,
) -> tuple[HybridSystem, dict[str, float], OrbitReference]:
    """Damped two-mass chain under harmonic forcing, one mode.

    ``ground --k1, c1-- m1 (x1) --k2, c2-- m2 (x2)``, force ``F sin(Omega t)`` on ``m1``::

        m1 x1'' = F sin(Omega t) - k1 x1 - c1 x1' - k2 (x1 - x2) - c2 (x1' - x2')
        m2 x2'' = -k2 (x2 - x1) - c2 (x2' - x1')

    with quadratures ``W' = F sin(Omega t) x1'`` (work of the excitation) and
    ``D' = c1 x1'^2 + c2 (x1' - x2')^2`` (viscous dissipation).

    Parameters
    ----------
    m1, m2 : float
        Masses [kg].
    k1, k2 : float
        Stiffnesses [N/m].
    c1, c2 : float
        Viscous damping coefficients [N s/m].
    F : float
        Excitation amplitude [N].
    Omega : float
        Excitation frequency [rad/s]. The default 1.3 lies between the two natural
        frequencies of the default set (0.70 and 1.39 rad/s), where the response is not
        resonant but both modes take part.

    Returns
    -------
    system : HybridSystem
        Variables ``x1 [m], v1 [m/s], x2 [m], v2 [m/s], W [J], D [J]``; mode ``linear``.
    params : dict of str to float
    reference : OrbitReference
        Exact in closed form: ``q(t) = Im(X e^{i Omega t})`` with
        ``X = (K - Omega^2 M + i Omega C)^{-1} f``; monodromy ``expm(A T)`` and multipliers
        ``exp(lambda_k T)`` from the eigenvalues of the first-order matrix ``A`` (state order
        ``x1, v1, x2, v2``), ``det = exp(trace(A) T)`` in ``details["det_monodromy"]``; per
        period ``W = D = (T/2) Re(F conj(V1))`` (mean power). All to rounding (~1e-14).
    """
    _check_positive(m1=m1, m2=m2, k1=k1, k2=k2, c1=c1, c2=c2, F=F, Omega=Omega)
    params = {"m1": m1, "m2": m2, "k1": k1, "k2": k2, "c1": c1, "c2": c2, "F": F, "Omega": Omega}
    system = _model(
        "linear_2dof",
        "Forced damped two-mass chain",
        {
            "x1": ("m", "displacement of m1"),
            "v1": ("m/s", "velocity of m1"),
            "x2": ("m", "displacement of m2"),
            "v2": ("m/s", "velocity of m2"),
            "W": ("J", "work done by the excitation"),
            "D": ("J", "energy dissipated by the dampers"),
        },
        {
            "m1": ("kg", "mass 1", "positive"),
            "m2": ("kg", "mass 2", "positive"),
            "k1": ("N/m", "spring ground-m1", "positive"),
            "k2": ("N/m", "spring m1-m2", "positive"),
            "c1": ("N s/m", "damper ground-m1", "nonnegative"),
            "c2": ("N s/m", "damper m1-m2", "nonnegative"),
            "F": ("N", "excitation amplitude", "nonnegative"),
            "Omega": ("rad/s", "excitation frequency", "positive"),
        },
        definitions={
            "force": "F*sin(Omega*t)",
            "E": "0.5*m1*v1**2 + 0.5*m2*v2**2 + 0.5*k1*x1**2 + 0.5*k2*(x2 - x1)**2",
        },
        equations={
            "x1": "v1",
            "v1": "(force - k1*x1 - c1*v1 - k2*(x1 - x2) - c2*(v1 - v2))/m1",
            "x2": "v2",
            "v2": "(-k2*(x2 - x1) - c2*(v2 - v1))/m2",
            "W": "force*v1",
            "D": "c1*v1**2 + c2*(v1 - v2)**2",
        },
        modes={"linear": {}},
        quadratures=["W", "D"],
        outputs=["E", "force"],
        initial_mode="linear",
        preset=params,
        energy={"input": "W", "dissipated": "D", "mechanical": "E"},
    )
    Mm = np.diag([m1, m2])
    Km = np.array([[k1 + k2, -k2], [-k2, k2]])
    Cm = np.array([[c1 + c2, -c2], [-c2, c2]])
    dampers = [(c1, np.array([1.0, 0.0])), (c2, np.array([1.0, -1.0]))]
    return system, params, _linear_2dof_reference(system, params, Mm, Cm, Km, dampers, None)


def forced_linear_2dof_slave(
    m1: float = 1.0,
    m2: float = 0.5,
    k1: float = 1.0,
    k2: float = 1.5,
    k3: float = 1.0,
    c1: float = 0.05,
    c2: float = 0.03,
    F: float = 0.2,
    Omega: float = 1.3,
) -> tuple[HybridSystem, dict[str, float], OrbitReference]:
    """Two masses joined through a massless node ``u``: a slave (algebraic) variable.

    ``ground --k1, c1-- m1 (x1) --k2-- u --k3-- m2 (x2)``, a damper ``c2`` between ``m1`` and
    ``m2`` (parallel to the spring chain), force ``F sin(Omega t)`` on ``m1``::

        m1 x1'' = F sin(Omega t) - k1 x1 - c1 x1' - k2 (x1 - u) - c2 (x1' - x2')
        m2 x2'' = -k3 (x2 - u) - c2 (x2' - x1')
        0       = (k2 + k3) u - k2 x1 - k3 x2          (balance of the massless node)

    so that ``u`` is algebraic in the (only) mode ``linear``: the engine's DAE path.

    Parameters
    ----------
    m1, m2 : float
        Masses [kg].
    k1, k2, k3 : float
        Stiffnesses [N/m]; ``k2`` and ``k3`` in series act between the masses as
        ``ke = k2 k3/(k2 + k3)`` (0.6 N/m by default, as ``k2`` of
        :func:`forced_linear_2dof`, so the two problems share the differential solution).
    c1, c2 : float
        Damping coefficients [N s/m].
    F : float
        Excitation amplitude [N].
    Omega : float
        Excitation frequency [rad/s].

    Returns
    -------
    system : HybridSystem
        Variables ``x1, v1, x2, v2, u [m], W, D [J]``.
    params : dict of str to float
    reference : OrbitReference
        As :func:`forced_linear_2dof` with ``u`` eliminated by hand; ``x0`` includes the
        consistent ``u = (k2 x1 + k3 x2)/(k2 + k3)``; the monodromy is over the differential
        variables ``x1, v1, x2, v2`` only. Exact to rounding (~1e-14).
    """
    _check_positive(m1=m1, m2=m2, k1=k1, k2=k2, k3=k3, c1=c1, c2=c2, F=F, Omega=Omega)
    params = {"m1": m1, "m2": m2, "k1": k1, "k2": k2, "k3": k3, "c1": c1, "c2": c2, "F": F, "Omega": Omega}
    system = _model(
        "linear_2dof_slave",
        "Forced two-mass chain with a massless node between two springs",
        {
            "x1": ("m", "displacement of m1"),
            "v1": ("m/s", "velocity of m1"),
            "x2": ("m", "displacement of m2"),
            "v2": ("m/s", "velocity of m2"),
            "u": ("m", "massless node between springs k2 and k3"),
            "W": ("J", "work done by the excitation"),
            "D": ("J", "energy dissipated by the dampers"),
        },
        {
            "m1": ("kg", "mass 1", "positive"),
            "m2": ("kg", "mass 2", "positive"),
            "k1": ("N/m", "spring ground-m1", "positive"),
            "k2": ("N/m", "spring m1-u", "positive"),
            "k3": ("N/m", "spring u-m2", "positive"),
            "c1": ("N s/m", "damper ground-m1", "nonnegative"),
            "c2": ("N s/m", "damper m1-m2", "nonnegative"),
            "F": ("N", "excitation amplitude", "nonnegative"),
            "Omega": ("rad/s", "excitation frequency", "positive"),
        },
        definitions={
            "force": "F*sin(Omega*t)",
            "E": "0.5*m1*v1**2 + 0.5*m2*v2**2 + 0.5*k1*x1**2 + 0.5*k2*(u - x1)**2 + 0.5*k3*(x2 - u)**2",
        },
        equations={
            "x1": "v1",
            "v1": "(force - k1*x1 - c1*v1 - k2*(x1 - u) - c2*(v1 - v2))/m1",
            "x2": "v2",
            "v2": "(-k3*(x2 - u) - c2*(v2 - v1))/m2",
            "W": "force*v1",
            "D": "c1*v1**2 + c2*(v1 - v2)**2",
        },
        modes={"linear": {"algebraic": {"u": "(k2 + k3)*u - k2*x1 - k3*x2"}}},
        quadratures=["W", "D"],
        outputs=["E", "force"],
        initial_mode="linear",
        preset=params,
        energy={"input": "W", "dissipated": "D", "mechanical": "E"},
    )
    ke = k2 * k3 / (k2 + k3)
    Mm = np.diag([m1, m2])
    Km = np.array([[k1 + ke, -ke], [-ke, ke]])
    Cm = np.array([[c1 + c2, -c2], [-c2, c2]])
    dampers = [(c1, np.array([1.0, 0.0])), (c2, np.array([1.0, -1.0]))]
    slave = np.array([k2, k3]) / (k2 + k3)
    return system, params, _linear_2dof_reference(system, params, Mm, Cm, Km, dampers, slave)


# ----------------------------------------------------------------------------
# 2. Forced Duffing oscillator (solve_ivp of state + variational equations)
# ----------------------------------------------------------------------------
_DUFFING_DEFAULTS = {"m": 1.0, "c": 0.05, "k": 1.0, "k3": 0.3, "F": 0.1}


def _duffing_system(params: Mapping[str, float]) -> HybridSystem:
    return _model(
        "duffing",
        "Forced damped hardening Duffing oscillator",
        {
            "x": ("m", "displacement"),
            "v": ("m/s", "velocity"),
            "W": ("J", "work done by the excitation"),
            "D": ("J", "energy dissipated by the damper"),
        },
        {
            "m": ("kg", "mass", "positive"),
            "c": ("N s/m", "viscous damping", "nonnegative"),
            "k": ("N/m", "linear stiffness", "positive"),
            "k3": ("N/m^3", "cubic stiffness (hardening if > 0)", "real"),
            "F": ("N", "excitation amplitude", "nonnegative"),
            "Omega": ("rad/s", "excitation frequency", "positive"),
        },
        definitions={"force": "F*sin(Omega*t)", "E": "0.5*m*v**2 + 0.5*k*x**2 + 0.25*k3*x**4"},
        equations={
            "x": "v",
            "v": "(force - c*v - k*x - k3*x**3)/m",
            "W": "force*v",
            "D": "c*v**2",
        },
        modes={"smooth": {}},
        quadratures=["W", "D"],
        outputs=["E", "force"],
        initial_mode="smooth",
        preset=params,
        energy={"input": "W", "dissipated": "D", "mechanical": "E"},
    )


def _duffing_rhs(t: float, y: NDArray, m, c, k, k3, F, Omega) -> NDArray:
    x, v = y[0], y[1]
    f = F * math.sin(Omega * t)
    a = (f - c * v - k * x - k3 * x**3) / m
    j21 = -(k + 3 * k3 * x * x) / m
    j22 = -c / m
    p11, p12, p21, p22 = y[2], y[3], y[4], y[5]
    return np.array(
        [v, a, p21, p22, j21 * p11 + j22 * p21, j21 * p12 + j22 * p22, f * v, c * v * v],
    )


def duffing_period_map(
    params: Mapping[str, float],
    y0: ArrayLike,
    *,
    rtol: float = IVP_RTOL,
    dense: bool = False,
    events: bool = False,
):
    """Period map of the Duffing oscillator and its exact derivative.

    Integrates ``(x, v)``, the variational equations ``Phi' = J Phi, Phi(0) = I`` and the
    quadratures ``W, D`` over ``[0, T]`` with solve_ivp (DOP853).

    Parameters
    ----------
    params : mapping
        ``m, c, k, k3, F, Omega`` (SI units, see :func:`duffing`).
    y0 : array_like, shape (2,)
        ``(x, v)`` at ``t = 0`` [m, m/s].
    rtol : float
        Relative tolerance (``atol = rtol/100``).
    dense, events : bool
        Keep the dense output; locate the turning points ``v = 0``.

    Returns
    -------
    y_T : ndarray, shape (2,)
        ``(x, v)`` at ``t = T``.
    M : ndarray, shape (2, 2)
        Monodromy ``d y_T / d y0``.
    quad : ndarray, shape (2,)
        ``(W, D)`` gained over the period [J].
    sol : OdeResult
        The solve_ivp result (for its dense output and events).
    """
    p = params
    T = 2 * math.pi / p["Omega"]
    y = np.concatenate([np.asarray(y0, dtype=float), [1.0, 0.0, 0.0, 1.0, 0.0, 0.0]])

    def turning(t, y, *args):
        return y[1]

    sol = solve_ivp(
        _duffing_rhs,
        (0.0, T),
        y,
        method="DOP853",
        rtol=rtol,
        atol=rtol * 1e-2,
        args=(p["m"], p["c"], p["k"], p["k3"], p["F"], p["Omega"]),
        dense_output=dense,
        events=turning if events else None,
    )
    if not sol.success:  # pragma: no cover - DOP853 does not fail on this smooth problem
        raise RuntimeError(sol.message)
    end = sol.y[:, -1]
    return end[:2], end[2:6].reshape(2, 2), end[6:8], sol


def duffing_harmonic_balance(params: Mapping[str, float]) -> list[tuple[float, NDArray]]:
    """One-term harmonic balance of the Duffing oscillator at ``params["Omega"]``.

    ``x ~ A sin(Omega t) + B cos(Omega t)``, ``a^2 = A^2 + B^2``:
    ``a^2 [(k - m Omega^2 + 3/4 k3 a^2)^2 + (c Omega)^2] = F^2`` (a cubic in ``a^2``).

    Parameters
    ----------
    params : mapping
        ``m, c, k, k3, F, Omega``.

    Returns
    -------
    list of (float, ndarray of shape (2,))
        ``(a [m], (x(0), v(0)) = (B, A Omega))`` per real root, by increasing ``a``: initial
        guesses for shooting (one-term harmonic balance is accurate to ~1e-3 here).
    """
    m, c, k, k3, F, W = (params[n] for n in ("m", "c", "k", "k3", "F", "Omega"))
    K0, beta = k - m * W * W, 0.75 * k3
    # beta^2 s^3 + 2 beta K0 s^2 + (K0^2 + c^2 W^2) s - F^2 = 0, s = a^2
    roots = np.roots([beta * beta, 2 * beta * K0, K0 * K0 + (c * W) ** 2, -(F**2)])
    out = []
    for s in sorted(r.real for r in roots if abs(r.imag) <= 1e-9 * abs(r) and r.real > 0):
        Kn = K0 + beta * s
        A, B = np.linalg.solve(np.array([[Kn, -c * W], [c * W, Kn]]), [F, 0.0])
        out.append((math.sqrt(s), np.array([B, A * W])))
    return out


def _duffing_hb_folds(params: Mapping[str, float]) -> tuple[tuple[float, float], ...]:
    """Folds of the harmonic-balance curve: d/ds of the cubic vanishes together with it."""
    m, c, k, k3, F = (params[n] for n in ("m", "c", "k", "k3", "F"))
    beta = 0.75 * k3
    w0 = math.sqrt(k / m)

    def branch(W: float, sign: int) -> float:
        K0 = k - m * W * W
        disc = K0 * K0 - 3 * (c * W) ** 2
        if disc < 0:
            return math.nan
        s = (-2 * K0 + sign * math.sqrt(disc)) / (3 * beta)
        if s <= 0:
            return math.nan
        return s * ((K0 + beta * s) ** 2 + (c * W) ** 2) - F * F

    out = []
    grid = np.linspace(w0, 3 * w0, 4001)
    for sign in (+1, -1):
        g = np.array([branch(W, sign) for W in grid])
        for i in range(len(grid) - 1):
            if np.isfinite(g[i]) and np.isfinite(g[i + 1]) and g[i] * g[i + 1] < 0:
                W = brentq(branch, grid[i], grid[i + 1], args=(sign,), xtol=1e-15)
                K0 = k - m * W * W
                s = (-2 * K0 + sign * math.sqrt(K0 * K0 - 3 * (c * W) ** 2)) / (3 * beta)
                out.append((W, math.sqrt(s)))
    return tuple(sorted(out))


def _duffing_newton(
    params: Mapping[str, float], y0: NDArray, tol: float = 1e-13, maxiter: int = 30
) -> NDArray:
    """Shooting with the exact monodromy at fixed Omega."""
    y = np.asarray(y0, dtype=float).copy()
    for _ in range(maxiter):
        yT, M, _, _ = duffing_period_map(params, y)
        dy = np.linalg.solve(M - np.eye(2), -(yT - y))
        y += dy
        if np.max(np.abs(dy)) < tol * (1 + np.max(np.abs(y))):
            return y
    raise RuntimeError(f"Duffing shooting did not converge from {y0!r} at Omega={params['Omega']!r}")


def _duffing_orbit_reference(
    system: HybridSystem, params: Mapping[str, float], y0: NDArray, neutral: bool = False
) -> OrbitReference:
    yT, M, q, sol = duffing_period_map(params, y0, dense=True, events=True)
    T = 2 * math.pi / params["Omega"]
    turning = sol.y_events[0][:, 0] if sol.t_events[0].size else np.empty(0)
    xs = np.concatenate([[y0[0], yT[0]], turning])
    lo, hi = float(np.min(xs)), float(np.max(xs))
    mu = _sorted_multipliers(M)
    dense = sol.sol

    def trajectory(t: ArrayLike) -> NDArray:
        t = np.atleast_1d(np.asarray(t, dtype=float))
        y = dense(t)
        return np.column_stack([y[0], y[1], y[6], y[7]])

    return OrbitReference(
        system_name=system.name,
        variable_names=system.variable_names,
        params=params,
        t0=0.0,
        period=T,
        mode0="smooth",
        x0=np.array([y0[0], y0[1], 0.0, 0.0]),
        state_names=("x", "v"),
        monodromy=M,
        multipliers=mu,
        stability="neutral" if neutral else classify_multipliers(mu),
        amplitude={"x": max(-lo, hi)},
        extrema={"x": (lo, hi)},
        increments={"W": float(q[0]), "D": float(q[1])},
        mode_sequence=("smooth",),
        switches=(),
        accuracy={
            "x0": 1e-11,
            "monodromy": 1e-11,
            "multipliers": 1e-11,
            "increments": 1e-12,
            "amplitude": 1e-12,
            "Omega": 1e-11,
            "trajectory": 1e-11,
        },
        details={"det_monodromy": math.exp(-params["c"] * T / params["m"])},
        trajectory=trajectory,
    )


def duffing_orbits(params: Mapping[str, float]) -> tuple[OrbitReference, ...]:
    """All period-1 orbits of the Duffing oscillator at ``params["Omega"]``.

    Found by shooting with the exact monodromy (solve_ivp, DOP853, rtol 1e-13) from every
    harmonic-balance root (:func:`duffing_harmonic_balance`).

    Parameters
    ----------
    params : mapping
        ``m, c, k, k3, F, Omega`` (see :func:`duffing`).

    Returns
    -------
    tuple of OrbitReference
        By increasing amplitude: one orbit outside the fold band, three inside it (stable low,
        unstable saddle with a real multiplier > 1, stable resonant). ``x0`` is accurate to
        ~1e-12, multipliers to ~1e-11 (bounds stated in ``accuracy``); exactly
        ``mu1 mu2 = exp(-c T/m)`` (Liouville), given as ``details["det_monodromy"]``.
    """
    params = dict(params)
    system = _duffing_system(params)
    found: list[NDArray] = []
    for _, guess in duffing_harmonic_balance(params):
        y = _duffing_newton(params, guess)
        if all(np.max(np.abs(y - z)) > 1e-6 for z in found):
            found.append(y)
    refs = [_duffing_orbit_reference(system, params, y) for y in found]
    return tuple(sorted(refs, key=lambda r: r.amplitude["x"]))


def _fold_residual(z: NDArray, params: Mapping[str, float]) -> NDArray:
    p = dict(params, Omega=z[2])
    yT, M, _, _ = duffing_period_map(p, z[:2])
    return np.concatenate([yT - z[:2], [np.linalg.det(np.eye(2) - M)]])


@functools.lru_cache(maxsize=8)
def _duffing_folds_cached(items: tuple[tuple[str, float], ...]) -> tuple[tuple[float, float, float], ...]:
    params = dict(items)
    out = []
    for W, a in _duffing_hb_folds(params):
        guesses = duffing_harmonic_balance(dict(params, Omega=W))
        _, g = min(guesses, key=lambda ag: abs(ag[0] - a))
        sol = root(
            _fold_residual, np.array([g[0], g[1], W]), args=(params,), method="hybr", options={"xtol": 1e-14}
        )
        if np.max(np.abs(_fold_residual(sol.x, params))) > 1e-12:
            raise RuntimeError(f"Duffing fold near Omega={W!r} not found: {sol.message}")
        out.append(tuple(float(v) for v in sol.x))
    return tuple(sorted(out, key=lambda z: z[2]))


def duffing_folds(params: Mapping[str, float]) -> tuple[OrbitReference, ...]:
    """The fold (saddle-node) orbits of the Duffing frequency response, by increasing Omega.

    Solves ``{P(y0, Omega) - y0 = 0, det(I - M(y0, Omega)) = 0}`` for ``(x0, v0, Omega)``
    (scipy.optimize.root, ``hybr``) with ``P`` and ``M`` from :func:`duffing_period_map`
    (DOP853, rtol 1e-13), started from the harmonic-balance folds.

    Parameters
    ----------
    params : mapping
        ``m, c, k, k3, F`` (``Omega`` is ignored).

    Returns
    -------
    tuple of OrbitReference
        The orbits at the folds; ``params["Omega"]`` is the fold frequency. The residual is
        <= 1e-12; a change of rtol from 1e-12 to 1e-13 moves Omega by < 1e-12 and ``x0`` by
        < 2e-12, and the independent parabola-vertex construction
        (:func:`duffing_fold_by_parabola`) agrees to < 1e-10. One multiplier is 1 (to
        ~1e-11), the other ``exp(-c T/m)``.
    """
    keys = ("m", "c", "k", "k3", "F")
    base = {n: float(params[n]) for n in keys}
    system = _duffing_system(dict(base, Omega=1.0))
    refs = []
    for x, v, W in _duffing_folds_cached(tuple(base.items())):
        p = dict(base, Omega=W)
        refs.append(_duffing_orbit_reference(system, p, np.array([x, v]), neutral=True))
    return tuple(refs)


def duffing_fold_by_parabola(fold: OrbitReference, h: float = 2e-3) -> float:
    """Fold frequency again, without the determinant condition (an independent check).

    Near the fold the branch is a graph ``Omega(xi)`` over one section coordinate ``xi``
    (``x(0)`` or ``v(0)``, whichever the null vector of ``M - I`` favours). For
    ``xi = xi_f - h, xi_f, xi_f + h`` the 2x2 system ``P(y0, Omega) - y0 = 0`` is solved for the
    other coordinate and ``Omega`` by Newton's method (derivative in ``Omega`` by central
    differences); the vertex value of the parabola through the three points is the fold
    frequency, with an error O(h^4).

    Parameters
    ----------
    fold : OrbitReference
        A fold from :func:`duffing_folds` (starting point).
    h : float
        Step in ``xi`` [m or m/s].

    Returns
    -------
    float
        The fold frequency [rad/s].
    """
    base = dict(fold.params)
    y_f = fold.state()
    W_f = base["Omega"]
    w, vecs = np.linalg.eig(fold.monodromy - np.eye(2))
    null = np.abs(vecs[:, int(np.argmin(np.abs(w)))])
    j = int(np.argmax(null))  # the fixed coordinate
    o = 1 - j  # the free one

    def residual(y0: NDArray, W: float) -> tuple[NDArray, NDArray]:
        yT, M, _, _ = duffing_period_map(dict(base, Omega=W), y0)
        return yT - y0, M

    pts = []
    for xi in (y_f[j] - h, y_f[j], y_f[j] + h):
        y0, W = y_f.copy(), W_f
        y0[j] = xi
        last = math.inf
        for _ in range(20):
            r, M = residual(y0, W)
            dW = 1e-6
            dr = (residual(y0, W + dW)[0] - residual(y0, W - dW)[0]) / (2 * dW)
            J = np.column_stack([M[:, o] - np.eye(2)[:, o], dr])
            step = np.linalg.solve(J, -r)
            y0[o] += step[0]
            W += step[1]
            size = float(np.max(np.abs(step)))
            if size < 1e-13 or size > 0.5 * last:  # converged, or stalled on rounding
                break
            last = size
        pts.append(W)
    W_m, W_0, W_p = pts
    a = (W_p + W_m - 2 * W_0) / (2 * h * h)
    b = (W_p - W_m) / (2 * h)
    return float(W_0 - b * b / (4 * a))


def duffing(
    Omega: float = 1.18,
    m: float = 1.0,
    c: float = 0.05,
    k: float = 1.0,
    k3: float = 0.3,
    F: float = 0.1,
) -> tuple[HybridSystem, dict[str, float], DuffingReference]:
    """Forced damped hardening Duffing oscillator with its two folds.

    ``m x'' + c x' + k x + k3 x^3 = F sin(Omega t)``, one mode ``smooth``, quadratures
    ``W' = F sin(Omega t) x'`` and ``D' = c x'^2``.

    Parameters
    ----------
    Omega : float
        Excitation frequency [rad/s] of ``params`` and of ``reference.orbits``; the default
        1.18 is inside the fold band, 0.067 rad/s from the lower and 0.076 from the upper fold.
    m : float
        Mass [kg].
    c : float
        Viscous damping [N s/m].
    k : float
        Linear stiffness [N/m] (natural frequency 1 rad/s by default).
    k3 : float
        Cubic stiffness [N/m^3].
    F : float
        Excitation amplitude [N].

    Returns
    -------
    system : HybridSystem
        Variables ``x [m], v [m/s], W [J], D [J]``.
    params : dict of str to float
    reference : DuffingReference
        With the default parameters (chosen so that the frequency response has two folds
        0.144 rad/s apart, amplitudes 0.6 to 1.6 m, away from superharmonic resonances):

        ===============  ===================  ====================  ==================
        fold             Omega [rad/s]        amplitude max|x| [m]  multipliers
        ===============  ===================  ====================  ==================
        lower (jump-up)  1.112711260452889    0.619097363174        1, 0.754019736208
        upper (jump-dn)  1.256394847149698    1.611191288988        1, 0.778763248667
        ===============  ===================  ====================  ==================

        (harmonic balance: 1.11260 and 1.25445). At the default ``Omega = 1.18`` the three
        orbits have amplitudes 0.262223294202 (stable, ``|mu| = 0.875361502``),
        1.226312583970 (saddle, ``mu = 1.314525496, 0.582915859``) and 1.398655400341
        (stable). Accuracy: fold frequencies ~1e-12 (see :func:`duffing_folds`); ``x0`` and
        multipliers ~1e-12 (a change of rtol from 1e-13 to 1e-12 moves them by < 1e-12).
        ``reference.folds[i].accuracy`` and ``reference.orbits[i].accuracy`` state the
        bounds the self-tests verify.
    """
    _check_positive(m=m, k=k, F=F, Omega=Omega)
    if not c > 0 or not k3 > 0:
        raise ValueError(f"`c` and `k3` must be > 0 (damped, hardening), got c={c!r}, k3={k3!r}")
    params = {"m": m, "c": c, "k": k, "k3": k3, "F": F, "Omega": Omega}
    folds = duffing_folds(params)
    if len(folds) != 2:
        raise ValueError(f"the frequency response has {len(folds)} folds for {params!r}; expected 2")
    system = _duffing_system(params)
    ref = DuffingReference(
        folds=(folds[0], folds[1]),
        band=(folds[0].params["Omega"], folds[1].params["Omega"]),
        orbits=duffing_orbits(params),
        harmonic_balance_folds=_duffing_hb_folds(params),
    )
    return system, params, ref


# ----------------------------------------------------------------------------
# Exact piecewise solutions of m x'' + c x' + k x = F sin(Omega t) + Q
# ----------------------------------------------------------------------------
class _Piece:
    """Closed-form solution of ``m x'' + c x' + k x = F sin(Omega t) + Q`` (underdamped)."""

    def __init__(self, m: float, c: float, k: float, F: float, Omega: float):
        if c * c >= 4 * m * k:
            raise ValueError(f"the reference needs an underdamped oscillator, got c^2 = {c * c!r} >= 4 m k")
        self.m, self.c, self.k, self.F, self.Omega = m, c, k, F, Omega
        self.X = F / complex(k - m * Omega**2, c * Omega)  # x_p = Im(X e^{i Omega t}) + Q/k
        self.sigma = c / (2 * m)
        self.wd = math.sqrt(k / m - self.sigma**2)

    def flow(self, t0: float, x0: float, v0: float, Q: float) -> Callable[[float], tuple[float, float]]:
        """``t -> (x(t), v(t))`` from ``(x0, v0)`` at ``t0`` (Q is a constant force [N])."""
        X, W, s, wd = self.X, self.Omega, self.sigma, self.wd
        e0 = cmath.exp(1j * W * t0)
        A = x0 - ((X * e0).imag + Q / self.k)
        B = (v0 - (1j * W * X * e0).imag + s * A) / wd

        def at(t: float) -> tuple[float, float]:
            tau = t - t0
            d, co, si = math.exp(-s * tau), math.cos(wd * tau), math.sin(wd * tau)
            e = cmath.exp(1j * W * t)
            x = (X * e).imag + Q / self.k + d * (A * co + B * si)
            v = (1j * W * X * e).imag + d * ((wd * B - s * A) * co - (s * B + wd * A) * si)
            return x, v

        return at


def _first_crossing(fun: Callable[[float], float], t0: float, t1: float, h: float) -> float | None:
    """First ``t`` in ``(t0, t1]`` with ``fun(t) <= 0``, given ``fun > 0`` just after ``t0``."""
    ta = t0
    while ta < t1:
        tb = min(ta + h, t1)
        if fun(tb) <= 0.0:
            lo = ta
            if ta == t0:  # fun(t0) = 0: find a point of the first cell where fun > 0
                j = 1
                while fun(t0 + (tb - t0) * 2.0**-j) <= 0.0:
                    j += 1
                    if j > 60:
                        raise RuntimeError(f"no positive value of the guard right after t = {t0!r}")
                lo = t0 + (tb - t0) * 2.0**-j
                # a crossing before lo would be a double crossing inside the first cell; refuse it
                if any(fun(lo * (1 - q) + t0 * q) <= 0.0 for q in (0.25, 0.5, 0.75)):
                    raise RuntimeError(f"ambiguous crossing right after t = {t0!r}")
            return brentq(fun, lo, tb, xtol=1e-15, rtol=4 * np.finfo(float).eps, maxiter=200)
        ta = tb
    return None


_GL_NODES, _GL_WEIGHTS = np.polynomial.legendre.leggauss(40)


def _quad(fun: Callable[[float], float], a: float, b: float) -> float:
    """Gauss-Legendre (40 nodes) on pieces of at most 0.5 s: exact to rounding for the smooth
    integrands here (frequencies up to ~50 rad/s)."""
    if b <= a:
        return 0.0
    n = max(1, math.ceil((b - a) / 0.5))
    edges = np.linspace(a, b, n + 1)
    total = 0.0
    for lo, hi in itertools.pairwise(edges):
        mid, half = 0.5 * (lo + hi), 0.5 * (hi - lo)
        total += half * sum(w * fun(mid + half * z) for z, w in zip(_GL_NODES, _GL_WEIGHTS, strict=True))
    return float(total)


# ----------------------------------------------------------------------------
# 3. Forced oscillator with viscous damping and Coulomb friction (stick-slip)
# ----------------------------------------------------------------------------
_SIGN = {"stick": 0, "slip+": 1, "slip-": -1}
_MODE = {0: "stick", 1: "slip+", -1: "slip-"}


def _friction_system(params: Mapping[str, float]) -> HybridSystem:
    return _model(
        "friction_oscillator",
        "Forced oscillator with viscous damping and Coulomb friction to ground",
        {
            "x": ("m", "displacement of the mass"),
            "v": ("m/s", "velocity of the mass"),
            "W": ("J", "work done by the excitation"),
            "D": ("J", "energy dissipated by friction and damper"),
            "Df": ("J", "energy dissipated by friction"),
        },
        {
            "m": ("kg", "mass", "positive"),
            "c": ("N s/m", "viscous damping", "nonnegative"),
            "k": ("N/m", "spring stiffness", "positive"),
            "R": ("N", "Coulomb friction force (static = kinetic)", "nonnegative"),
            "F": ("N", "excitation amplitude", "nonnegative"),
            "Omega": ("rad/s", "excitation frequency", "positive"),
        },
        definitions={"force": "F*sin(Omega*t)", "H": "k*x - force", "E": "0.5*m*v**2 + 0.5*k*x**2"},
        equations={
            "x": "v",
            "v": "(force - k*x - c*v + friction)/m",
            "W": "force*v",
            "D": "c*v**2 - friction*v",
            "Df": "-friction*v",
        },
        modes={
            "stick": {"derivatives": {"x": "0", "v": "0"}, "definitions": {"friction": "H"}},
            "slip+": {"definitions": {"friction": "-R"}},
            "slip-": {"definitions": {"friction": "R"}},
        },
        transitions=[
            {"name": "breakaway+", "source": "stick", "target": "slip+", "guard": "H + R", "direction": -1},
            {"name": "breakaway-", "source": "stick", "target": "slip-", "guard": "H - R", "direction": 1},
            {
                "name": "stop+",
                "source": "slip+",
                "target": "stick",
                "guard": "v",
                "direction": -1,
                "reset": {"v": "0"},
            },
            {
                "name": "stop-",
                "source": "slip-",
                "target": "stick",
                "guard": "v",
                "direction": 1,
                "reset": {"v": "0"},
            },
        ],
        quadratures=["W", "D", "Df"],
        outputs=["H", "E", "force", "friction"],
        initial_mode="stick",
        preset=params,
        energy={"input": "W", "dissipated": "D", "mechanical": "E"},
    )


@dataclass
class _Segment:
    t0: float
    t1: float
    mode: int
    x0: float
    v0: float
    flow: Callable[[float], tuple[float, float]] | None  # None in stick


def _friction_run(
    p: Mapping[str, float], t0: float, x0: float, v0: float, mode: int, t1: float
) -> tuple[float, float, int, list[_Segment], list[tuple[float, str, str]]]:
    """Exact event loop of the friction oscillator from t0 to t1.

    Stick exits solve ``k x_s - F sin(Omega t) = -+R`` by arcsin; slip ends are the zeros of the
    closed-form velocity (brentq to ~1e-15 s). At a slip end the mass sticks if
    ``|k x - F sin(Omega t)| <= R`` and reverses otherwise.
    """
    m, c, k, R, F, W = (p[n] for n in ("m", "c", "k", "R", "F", "Omega"))
    piece = _Piece(m, c, k, F, W)
    h = min(2 * math.pi / W, 2 * math.pi / piece.wd) / 400
    t, x, v = t0, x0, v0
    segs: list[_Segment] = []
    switches: list[tuple[float, str, str]] = []
    while True:
        if mode == 0:
            cands = []
            ph = W * t
            s1 = (k * x + R) / F if F > 0 else math.inf  # slip+ when sin(Omega t) rises through s1
            if abs(s1) < 1:
                a = math.asin(s1)
                n = math.ceil((ph - a) / (2 * math.pi))
                te = (a + 2 * math.pi * n) / W
                cands.append((te if te > t else te + 2 * math.pi / W, 1))
            s2 = (k * x - R) / F if F > 0 else math.inf  # slip- when sin(Omega t) falls through s2
            if abs(s2) < 1:
                a = math.pi - math.asin(s2)
                n = math.ceil((ph - a) / (2 * math.pi))
                te = (a + 2 * math.pi * n) / W
                cands.append((te if te > t else te + 2 * math.pi / W, -1))
            te, new = min(cands) if cands else (math.inf, 0)
            if te >= t1:
                segs.append(_Segment(t, t1, 0, x, 0.0, None))
                return x, 0.0, 0, segs, switches
            segs.append(_Segment(t, te, 0, x, 0.0, None))
            switches.append((te, "stick", _MODE[new]))
            t, v, mode = te, 0.0, new
        else:
            flow = piece.flow(t, x, v, -mode * R)
            te = _first_crossing(lambda q, f=flow, s=mode: s * f(q)[1], t, t1, h)
            if te is None:
                segs.append(_Segment(t, t1, mode, x, v, flow))
                x, v = flow(t1)
                return x, v, mode, segs, switches
            xe, _ = flow(te)
            segs.append(_Segment(t, te, mode, x, v, flow))
            new = 0 if abs(k * xe - F * math.sin(W * te)) <= R else -mode
            switches.append((te, _MODE[mode], _MODE[new]))
            t, x, v, mode = te, xe, 0.0, new


def friction_period_map(p: Mapping[str, float], x0: float, v0: float, mode0: str) -> tuple[float, float, str]:
    """Exact period map ``(x, v, mode)`` at ``t = 0 -> t = T`` of the friction oscillator.

    Parameters
    ----------
    p : mapping
        ``m, c, k, R, F, Omega`` (see :func:`friction_oscillator`).
    x0, v0 : float
        State at ``t = 0`` [m, m/s].
    mode0 : {"stick", "slip+", "slip-"}
        Mode at ``t = 0``.

    Returns
    -------
    (float, float, str)
        ``x(T), v(T)`` and the mode at ``T``. Exact to ~1e-14 (closed form between switches).
    """
    T = 2 * math.pi / p["Omega"]
    x, v, mode, _, _ = _friction_run(p, 0.0, x0, v0, _SIGN[mode0], T)
    return x, v, _MODE[mode]


def friction_simulate_ivp(
    p: Mapping[str, float], t_end: float, x0: float, v0: float, mode0: str, rtol: float = 1e-12
) -> tuple[float, float, str, list[tuple[float, str, str]]]:
    """Second, independent implementation: an event loop around solve_ivp (DOP853).

    Slip phases integrate ``m x'' = F sin(Omega t) - k x - c x' -+ R`` with a terminal event
    on ``v``; stick phases integrate nothing (``x`` fixed, ``v = 0``) and end at the first
    zero of ``H -+ R`` (``H = k x - F sin(Omega t)``) found by a terminal event of a dummy
    integration. Used to cross-check :func:`friction_period_map`.

    Parameters
    ----------
    p : mapping
        ``m, c, k, R, F, Omega``.
    t_end : float
        End time [s] (start at 0).
    x0, v0 : float
        Initial state [m, m/s].
    mode0 : str
        Initial mode.
    rtol : float
        Relative tolerance (``atol = rtol/100``).

    Returns
    -------
    (float, float, str, list)
        ``x, v`` and mode at ``t_end``, and the switches ``(t, source, target)``.
    """
    m, c, k, R, F, W = (p[n] for n in ("m", "c", "k", "R", "F", "Omega"))
    max_step = 2 * math.pi / W / 50
    t, x, v, mode = 0.0, x0, v0, _SIGN[mode0]
    log: list[tuple[float, str, str]] = []
    while t < t_end:
        if mode == 0:

            def exit_plus(s, y, x=x):
                return k * x - F * math.sin(W * s) + R

            def exit_minus(s, y, x=x):
                return k * x - F * math.sin(W * s) - R

            exit_plus.terminal, exit_plus.direction = True, -1
            exit_minus.terminal, exit_minus.direction = True, 1
            sol = solve_ivp(
                lambda s, y: [0.0],
                (t, t_end),
                [0.0],
                events=[exit_plus, exit_minus],
                max_step=max_step,
                rtol=rtol,
                atol=rtol * 1e-2,
            )
            if sol.status == 0:
                return x, 0.0, "stick", log
            new = 1 if sol.t_events[0].size else -1
            te = float(sol.t_events[0][0] if new == 1 else sol.t_events[1][0])
            log.append((te, "stick", _MODE[new]))
            t, v, mode = te, 0.0, new
        else:
            s_ = mode

            def rhs(s, y, s_=s_):
                return [y[1], (F * math.sin(W * s) - k * y[0] - c * y[1] - s_ * R) / m]

            def stop(s, y):
                return y[1]

            stop.terminal, stop.direction = True, -s_
            sol = solve_ivp(
                rhs,
                (t, t_end),
                [x, v],
                method="DOP853",
                events=stop,
                rtol=rtol,
                atol=rtol * 1e-2,
                max_step=max_step,
            )
            # (an event function that starts at 0 and leaves it does not fire in solve_ivp)
            if sol.status == 0:
                return float(sol.y[0, -1]), float(sol.y[1, -1]), _MODE[mode], log
            te = float(sol.t_events[0][0])
            xe = float(sol.y_events[0][0][0])
            new = 0 if abs(k * xe - F * math.sin(W * te)) <= R else -mode
            log.append((te, _MODE[mode], _MODE[new]))
            t, x, v, mode = te, xe, 0.0, new
    return x, v, _MODE[mode], log


def _friction_fixed_point(
    p: Mapping[str, float], transient_periods: int, start: tuple[float, float, str] | None = None
) -> tuple[float, float, str]:
    """Section state of the steady orbit: iterate the exact map, then polish the fixed point."""
    T = 2 * math.pi / p["Omega"]
    x, v, mode = (0.0, 0.0, 0) if start is None else (start[0], start[1], _SIGN[start[2]])
    for n in range(transient_periods):
        x, v, mode, _, _ = _friction_run(p, n * T, x, v, mode, (n + 1) * T)  # t = n T is t = 0 mod T
    if mode == 0:
        raise ValueError(f"the steady orbit sticks at t = 0 for {p!r}; choose parameters with t = 0 in slip")
    mode_name = _MODE[mode]
    for _ in range(100):
        xn, vn, mn = friction_period_map(p, x, v, mode_name)
        if mn != mode_name:
            raise ValueError(f"no period-1 orbit with a slip phase at t = 0 for {p!r}")
        done = max(abs(xn - x), abs(vn - v)) < 1e-14
        x, v = xn, vn
        if done:
            return x, v, mode_name
    raise ValueError(f"the iteration of the friction map did not settle on a period-1 orbit for {p!r}")


def _friction_turning_ratios(p: Mapping[str, float], segs: list[_Segment]) -> tuple[float, ...]:
    """``|H|/R`` at the velocity zeros (ends of slip phases: stick entries and reversals)."""
    out = []
    for seg, _ in itertools.pairwise(segs):
        if seg.flow is not None:
            xe = seg.flow(seg.t1)[0]
            out.append(abs(p["k"] * xe - p["F"] * math.sin(p["Omega"] * seg.t1)) / p["R"])
    return tuple(out)


def friction_stick_boundary(params: Mapping[str, float], bracket: tuple[float, float] = (0.55, 0.6)) -> float:
    """Excitation frequency at which the stick phases of the symmetric steady orbit vanish.

    At a velocity zero the mass sticks if ``|H| = |k x - F sin(Omega t)| <= R`` and reverses
    otherwise, so the stick phases shrink to zero length where ``|H|/R = 1`` at the velocity
    zeros: a "mode-lost" (increasing ``Omega``) or "mode-gained" (decreasing) point of a
    continuation in ``Omega``. The symmetric orbit (``x(t + T/2) = -x(t)``) is the fixed point
    of the reflected half-period map ``(x, v) -> -P_{T/2}(x, v)``, iterated on the exact
    piecewise solution; brentq finds the zero of ``|H|/R - 1`` at its velocity zero.

    Parameters
    ----------
    params : mapping
        ``m, c, k, R, F`` (``Omega`` is ignored).
    bracket : (float, float)
        Frequencies [rad/s] with stick below and none above (the default suits the default set).

    Returns
    -------
    float
        The boundary frequency [rad/s], to ~1e-12 (``|H|/R - 1`` has slope ~5.7 per rad/s and
        is computed to ~1e-14). For the default parameters 0.589704.. rad/s. Within ~1e-5 rad/s
        of it, trajectories from rest can settle on asymmetric orbits with one stick per period.
    """
    base = {n: float(params[n]) for n in ("m", "c", "k", "R", "F")}
    state = {"x": -1.0, "v": 0.5}

    def excess(W: float) -> float:
        p = dict(base, Omega=W)
        half = math.pi / W
        x, v = state["x"], state["v"]
        for _ in range(200):
            xh, vh, mode, segs, _ = _friction_run(p, 0.0, x, v, 1, half)
            if mode != -1:
                raise ValueError(f"the symmetric orbit is not in slip at t = 0 and T/2 for {p!r}")
            done = max(abs(xh + x), abs(vh + v)) < 1e-15
            x, v = -xh, -vh
            if done:
                break
        else:
            raise RuntimeError(f"the reflected half-period map did not converge for {p!r}")
        state["x"], state["v"] = x, v
        segs = _friction_run(p, 0.0, x, v, 1, half)[3]
        return max(_friction_turning_ratios(p, segs)) - 1.0

    return float(brentq(excess, bracket[0], bracket[1], xtol=1e-15, rtol=4 * np.finfo(float).eps))


def friction_oscillator(
    m: float = 1.0,
    c: float = 0.2,
    k: float = 1.0,
    R: float = 0.4,
    F: float = 1.0,
    Omega: float = 0.5,
    transient_periods: int = 60,
) -> tuple[HybridSystem, dict[str, float], OrbitReference]:
    """Forced stick-slip oscillator with viscous damping and Coulomb friction to ground.

    ``m x'' + c x' + k x = F sin(Omega t) + friction``, with ``friction = -R`` in ``slip+``
    (``x' > 0``), ``+R`` in ``slip-``, and in ``stick`` ``x' = 0`` with the friction force
    ``H = k x - F sin(Omega t)`` needed to hold the mass, as long as ``|H| <= R`` (as
    ``models/coulomb.toml``, with the damper). Quadratures: ``W' = F sin(Omega t) x'`` (work of
    the excitation), ``D' = c x'^2 - friction x'`` (all dissipation), ``Df' = -friction x'``
    (friction alone).

    Parameters
    ----------
    m : float
        Mass [kg].
    c : float
        Viscous damping [N s/m].
    k : float
        Stiffness [N/m].
    R : float
        Friction force [N] (static = kinetic).
    F : float
        Excitation amplitude [N].
    Omega : float
        Excitation frequency [rad/s].
    transient_periods : int
        Periods of the exact map iterated from rest in ``stick`` before the fixed point is
        polished (the default set contracts by 0.079 per period).

    Returns
    -------
    system : HybridSystem
        Variables ``x [m], v [m/s], W, D, Df [J]``; modes ``stick, slip+, slip-``.
    params : dict of str to float
    reference : OrbitReference
        The symmetric stick-slip orbit (``x(t + T/2) = -x(t)``). With the default parameters
        (chosen for two long stick phases, t = 0 in mid-slip and strong contraction): at
        ``t = 0`` the mass slips forwards (``slip+``, ``x0 = (-0.887552673, 0.456292591)``);
        slip+ -> stick at 0.2815 T, stick -> slip- at 0.3569 T, slip- -> stick at 0.7815 T,
        stick -> slip+ at 0.8569 T (two stick phases of 0.0754 T each, at
        ``x = +-1.182872539``; the friction force at stick entry is 0.506 R, so no reversal or
        grazing is near). Multipliers ``(0.0788, 0)``: the zero one is exact (entering stick
        collapses the velocity direction), the other makes a simulation from rest converge
        to 1e-13 in ~30 periods. Per period ``W = D = 2.48012114367`` J, of which friction
        ``Df = 1.89259606255`` J. Stick is lost at ``Omega = 0.58970847211665`` rad/s
        (:func:`friction_stick_boundary`).

        Exact numbers: ``x0`` from the closed-form piecewise map (switch times by arcsin and by
        brentq on the closed-form velocity), fixed point to ~1e-14; ``monodromy`` by
        Richardson-extrapolated central differences of that map (~1e-9);
        ``increments`` by Gauss-Legendre quadrature of the closed form (~1e-14), with
        ``Df = R * (total distance slid)`` exactly and ``W = D`` (energy balance over a
        period). ``details``: ``stick_fraction`` (of the period), ``x_stick`` [m] (the
        positions held, ``= -+amplitude``), ``H_turn_over_R`` (``|H|/R`` at the velocity
        zeros: < 1 where the mass sticks, > 1 where it reverses), ``Dv`` (viscous part of ``D``) [J].
    """
    _check_positive(m=m, c=c, k=k, R=R, F=F, Omega=Omega)
    p = {"m": m, "c": c, "k": k, "R": R, "F": F, "Omega": Omega}
    T = 2 * math.pi / Omega
    system = _friction_system(p)
    x, v, mode_name = _friction_fixed_point(p, transient_periods)
    mode = _SIGN[mode_name]
    xe, ve, _, segs, switches = _friction_run(p, 0.0, x, v, mode, T)

    def pmap(y: NDArray) -> NDArray:
        xn, vn, mn = friction_period_map(p, y[0], y[1], mode_name)
        if mn != mode_name:  # pragma: no cover - the step is far below the margins
            raise RuntimeError("finite-difference step changed the mode at the section")
        return np.array([xn, vn])

    M = _richardson_jacobian(pmap, np.array([x, v]), 1e-4)
    mu = _sorted_multipliers(M)
    W_T = Dv = Df = 0.0
    for s in segs:
        if s.flow is None:
            continue
        f = s.flow
        W_T += _quad(lambda q, f=f: F * math.sin(Omega * q) * f(q)[1], s.t0, s.t1)
        Dv += _quad(lambda q, f=f: c * f(q)[1] ** 2, s.t0, s.t1)
        Df += R * abs(f(s.t1)[0] - s.x0)
    stick_x = [s.x0 for s in segs if s.mode == 0]
    xs = [x, xe] + [s.x0 for s in segs[1:]]  # extrema of x: at the velocity zeros
    lo, hi = min(xs), max(xs)

    def trajectory(t: ArrayLike) -> NDArray:
        t = np.atleast_1d(np.asarray(t, dtype=float))
        out = np.zeros((t.size, 5))
        for i, ti in enumerate(t):
            acc = np.zeros(3)  # W, D, Df accumulated over the finished segments
            for s in segs:
                end = min(ti, s.t1)
                if s.flow is None:
                    xv = (s.x0, 0.0)
                else:
                    f = s.flow
                    acc[0] += _quad(lambda q, f=f: F * math.sin(Omega * q) * f(q)[1], s.t0, end)
                    dv = _quad(lambda q, f=f: c * f(q)[1] ** 2, s.t0, end)
                    xv = f(end)
                    df = R * abs(xv[0] - s.x0)
                    acc[1] += dv + df
                    acc[2] += df
                if ti <= s.t1:
                    break
            out[i] = xv[0], xv[1], acc[0], acc[1], acc[2]
        return out

    return (
        system,
        p,
        OrbitReference(
            system_name=system.name,
            variable_names=system.variable_names,
            params=p,
            t0=0.0,
            period=T,
            mode0=mode_name,
            x0=np.array([x, v, 0.0, 0.0, 0.0]),
            state_names=("x", "v"),
            monodromy=M,
            multipliers=mu,
            stability=classify_multipliers(mu),
            amplitude={"x": max(-lo, hi)},
            extrema={"x": (lo, hi)},
            increments={"W": W_T, "D": Dv + Df, "Df": Df},
            mode_sequence=tuple(_MODE[s.mode] for s in segs),
            switches=tuple(switches),
            accuracy={
                "x0": 1e-13,
                "monodromy": 1e-9,
                "multipliers": 1e-9,
                "increments": 1e-12,
                "amplitude": 1e-13,
                "switch_times": 1e-12,
                "trajectory": 1e-12,
            },
            details={
                "stick_fraction": sum(s.t1 - s.t0 for s in segs if s.mode == 0) / T,
                "x_stick": tuple(stick_x),
                "H_turn_over_R": _friction_turning_ratios(p, segs),
                "Dv": Dv,
            },
            trajectory=trajectory,
        ),
    )


# ----------------------------------------------------------------------------
# 4. Impact oscillator (reset map v+ = -r v-)
# ----------------------------------------------------------------------------
def _impact_system(params: Mapping[str, float]) -> HybridSystem:
    return _model(
        "impact_oscillator",
        "Forced damped oscillator impacting a rigid wall",
        {
            "x": ("m", "displacement of the mass"),
            "v": ("m/s", "velocity of the mass"),
            "W": ("J", "work done by the excitation"),
            "D": ("J", "energy dissipated by the damper"),
        },
        {
            "m": ("kg", "mass", "positive"),
            "c": ("N s/m", "viscous damping", "nonnegative"),
            "k": ("N/m", "spring stiffness", "positive"),
            "g": ("m", "position of the wall (gap)", "real"),
            "r": ("1", "coefficient of restitution", "nonnegative"),
            "F": ("N", "excitation amplitude", "nonnegative"),
            "Omega": ("rad/s", "excitation frequency", "positive"),
        },
        definitions={"force": "F*sin(Omega*t)", "E": "0.5*m*v**2 + 0.5*k*x**2"},
        equations={
            "x": "v",
            "v": "(force - k*x - c*v)/m",
            "W": "force*v",
            "D": "c*v**2",
        },
        modes={"free": {}},
        transitions=[
            {
                "name": "impact",
                "source": "free",
                "target": "free",
                "guard": "x - g",
                "direction": 1,
                "reset": {"v": "-r*v"},
            }
        ],
        quadratures=["W", "D"],
        outputs=["E", "force"],
        initial_mode="free",
        preset=params,
        energy={"input": "W", "dissipated": "D", "mechanical": "E"},
    )


def _impact_run(
    p: Mapping[str, float], t0: float, x0: float, v0: float, t1: float
) -> tuple[float, float, list[_Segment], list[tuple[float, float]]]:
    """Exact event loop of the impact oscillator; impacts ``(t, v_minus)``."""
    m, c, k, g, r, F, W = (p[n] for n in ("m", "c", "k", "g", "r", "F", "Omega"))
    piece = _Piece(m, c, k, F, W)
    h = min(2 * math.pi / W, 2 * math.pi / piece.wd) / 400
    t, x, v = t0, x0, v0
    segs: list[_Segment] = []
    impacts: list[tuple[float, float]] = []
    while True:
        flow = piece.flow(t, x, v, 0.0)
        te = _first_crossing(lambda q, f=flow: g - f(q)[0], t, t1, h)
        if te is None:
            segs.append(_Segment(t, t1, 1, x, v, flow))
            x, v = flow(t1)
            return x, v, segs, impacts
        _, ve = flow(te)
        if ve <= 0:
            raise RuntimeError(f"grazing impact at t = {te!r} (v = {ve!r})")
        segs.append(_Segment(t, te, 1, x, v, flow))
        impacts.append((te, ve))
        if len(impacts) > 10_000:
            raise RuntimeError("more than 10000 impacts: chattering")
        t, x, v = te, g, -r * ve


def impact_period_map(p: Mapping[str, float], x0: float, v0: float) -> tuple[float, float, int]:
    """Exact period map of the impact oscillator.

    Parameters
    ----------
    p : mapping
        ``m, c, k, g, r, F, Omega`` (see :func:`impact_oscillator`).
    x0, v0 : float
        State at ``t = 0`` [m, m/s].

    Returns
    -------
    (float, float, int)
        ``x(T), v(T)`` and the number of impacts in ``(0, T]``. Exact to ~1e-14.
    """
    T = 2 * math.pi / p["Omega"]
    x, v, _, impacts = _impact_run(p, 0.0, x0, v0, T)
    return x, v, len(impacts)


def impact_grazing_frequencies(params: Mapping[str, float]) -> tuple[float, ...]:
    """Frequencies at which the non-impacting orbit grazes the wall (closed form).

    Without impacts the steady orbit is ``x = Im(X e^{i Omega t})`` with
    ``|X| = F/|k - m Omega^2 + i c Omega|``; it touches the wall ``g > 0`` with zero velocity
    where ``|X| = g``, i.e. ``m^2 s^2 + (c^2 - 2 k m) s + k^2 - F^2/g^2 = 0`` for
    ``s = Omega^2``: "grazing" points of a continuation of the non-impacting branch.

    Parameters
    ----------
    params : mapping
        ``m, c, k, g, F`` (``g > 0``).

    Returns
    -------
    tuple of float
        The grazing frequencies [rad/s], increasing (exact to rounding). For the default set
        one, 1.86895805286 rad/s: above it the linear orbit misses the wall (and is the steady
        state), below it every orbit impacts.
    """
    m, c, k, g, F = (params[n] for n in ("m", "c", "k", "g", "F"))
    if not g > 0:
        raise ValueError(f"`g` must be > 0 for a grazing linear orbit, got {g!r}")
    roots = np.roots([m * m, c * c - 2 * k * m, k * k - (F / g) ** 2])
    return tuple(sorted(math.sqrt(s.real) for s in roots if abs(s.imag) < 1e-12 and s.real > 0))


def impact_oscillator(
    m: float = 1.0,
    c: float = 0.1,
    k: float = 1.0,
    g: float = 0.2,
    r: float = 0.8,
    F: float = 0.5,
    Omega: float = 1.6,
    transient_periods: int = 100,
) -> tuple[HybridSystem, dict[str, float], OrbitReference]:
    """Forced damped oscillator hitting a rigid wall: a reset map in the orbit.

    ``m x'' + c x' + k x = F sin(Omega t)`` for ``x < g``; when ``x`` reaches the wall ``g``
    moving forwards, ``v+ = -r v-`` (Newton's impact law). One mode ``free`` with a
    self-transition ``impact`` (guard ``x - g``, direction +1). Quadratures
    ``W' = F sin(Omega t) x'`` and ``D' = c x'^2`` (viscous only: the impact loss
    ``(1 - r^2) m v-^2/2`` is a jump, so per period ``W - D`` equals the impact loss).

    Parameters
    ----------
    m : float
        Mass [kg].
    c : float
        Viscous damping [N s/m].
    k : float
        Stiffness [N/m].
    g : float
        Wall position [m].
    r : float
        Coefficient of restitution [1].
    F : float
        Excitation amplitude [N].
    Omega : float
        Excitation frequency [rad/s].
    transient_periods : int
        Periods of the exact map iterated from rest before the fixed point is polished.

    Returns
    -------
    system : HybridSystem
        Variables ``x [m], v [m/s], W, D [J]``.
    params : dict of str to float
    reference : OrbitReference
        The period-1 orbit with one impact per period. ``x0`` exact to ~1e-14 (closed-form
        flights, impact times by brentq); ``monodromy`` by Richardson-extrapolated central
        differences of the exact map (~1e-9), with exactly ``det M = r^2 exp(-c T/m)``
        (``details["det_monodromy"]``: the saltation matrix of an impact with
        ``v+ = -r v-`` at a fixed wall has determinant ``r^2``). ``details``: ``t_impact``
        [s] (in ``[0, T)``), ``v_impact`` (the velocity before impact) [m/s],
        ``impact_loss`` [J] per period.
    """
    _check_positive(m=m, c=c, k=k, F=F, Omega=Omega)
    if not 0 < r <= 1:
        raise ValueError(f"`r` must be in (0, 1], got {r!r}")
    p = {"m": m, "c": c, "k": k, "g": g, "r": r, "F": F, "Omega": Omega}
    T = 2 * math.pi / Omega
    system = _impact_system(p)
    x, v = 0.0, 0.0
    for n in range(transient_periods):
        x, v, _, _ = _impact_run(p, n * T, x, v, (n + 1) * T)
    for _ in range(300):
        xn, vn, _ = impact_period_map(p, x, v)
        done = max(abs(xn - x), abs(vn - v)) < 1e-14
        x, v = xn, vn
        if done:
            break
    else:
        raise ValueError(f"the iteration of the impact map did not settle on a period-1 orbit for {p!r}")
    xe, ve, segs, impacts = _impact_run(p, 0.0, x, v, T)
    if len(impacts) != 1:
        raise ValueError(f"the period-1 orbit has {len(impacts)} impacts per period for {p!r}; expected 1")

    def pmap(y: NDArray) -> NDArray:
        xn, vn, ni = impact_period_map(p, y[0], y[1])
        if ni != 1:  # pragma: no cover
            raise RuntimeError("finite-difference step changed the number of impacts")
        return np.array([xn, vn])

    M = _richardson_jacobian(pmap, np.array([x, v]), 1e-4)
    mu = _sorted_multipliers(M)
    W_T = sum(_quad(lambda q, f=s.flow: F * math.sin(Omega * q) * f(q)[1], s.t0, s.t1) for s in segs)
    D_T = sum(_quad(lambda q, f=s.flow: c * f(q)[1] ** 2, s.t0, s.t1) for s in segs)
    t_imp, v_imp = impacts[0]
    loss = 0.5 * m * (1 - r * r) * v_imp**2
    # Extrema of x: the wall, and the turning points (v = 0) of the flights.
    xs = [x, xe, g]
    for s in segs:
        f = s.flow
        grid = np.linspace(s.t0, s.t1, 401)
        vs = np.array([f(q)[1] for q in grid])
        for i in range(400):
            if vs[i] * vs[i + 1] < 0:
                tz = brentq(lambda q, f=f: f(q)[1], grid[i], grid[i + 1], xtol=1e-15)
                xs.append(f(tz)[0])
    lo, hi = min(xs), max(xs)

    def trajectory(t: ArrayLike) -> NDArray:
        t = np.atleast_1d(np.asarray(t, dtype=float))
        out = np.zeros((t.size, 4))
        for i, ti in enumerate(t):
            acc = np.zeros(2)
            for s in segs:
                end = min(ti, s.t1)
                f = s.flow
                acc[0] += _quad(lambda q, f=f: F * math.sin(Omega * q) * f(q)[1], s.t0, end)
                acc[1] += _quad(lambda q, f=f: c * f(q)[1] ** 2, s.t0, end)
                xv = f(end)
                if ti <= s.t1:
                    break
            out[i] = xv[0], xv[1], acc[0], acc[1]
        return out

    return (
        system,
        p,
        OrbitReference(
            system_name=system.name,
            variable_names=system.variable_names,
            params=p,
            t0=0.0,
            period=T,
            mode0="free",
            x0=np.array([x, v, 0.0, 0.0]),
            state_names=("x", "v"),
            monodromy=M,
            multipliers=mu,
            stability=classify_multipliers(mu),
            amplitude={"x": max(-lo, hi)},
            extrema={"x": (lo, hi)},
            increments={"W": W_T, "D": D_T},
            mode_sequence=("free", "free"),
            switches=((t_imp, "free", "free"),),
            accuracy={
                "x0": 1e-13,
                "monodromy": 1e-9,
                "multipliers": 1e-9,
                "increments": 1e-12,
                "amplitude": 1e-13,
                "switch_times": 1e-12,
                "trajectory": 1e-12,
            },
            details={
                "det_monodromy": r * r * math.exp(-c * T / m),
                "t_impact": t_imp,
                "v_impact": v_imp,
                "impact_loss": loss,
            },
            trajectory=trajectory,
        ),
    )
