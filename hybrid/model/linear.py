"""Linearisation of one mode at a state: Jacobian of the reduced ODE, natural frequencies, and
the periodic response of the linearised mode to the forcing.

Used to choose a default frequency range (``hybrid frc``) without model knowledge (the
resonances of the initial mode linearised at the zero state), and for the linear references
drawn over a frequency response (:func:`linear_response`: e.g. a friction damper with every
contact stuck, or every contact sliding).
"""

from __future__ import annotations

from collections.abc import Mapping

import numpy as np

from ..core.errors import AlgebraicSolveError, InputError
from .codegen import compile_many
from .compiled import CompiledSystem
from .expr import diff, num, substitute
from .system import HybridSystem

__all__ = ["reduced_jacobian", "natural_frequencies", "mode_eigenvalues", "linear_response"]

#: Samples of the forcing over one period in :func:`linear_response` (harmonics up to 31 resolved).
FORCING_SAMPLES = 64
#: Samples of the response over one period where it holds several harmonics (its maximum refined).
RESPONSE_SAMPLES = 512


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
    except (AlgebraicSolveError, ArithmeticError, ValueError):  # a diagnosis only (LinAlgError too)
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


def linear_response(
    system: HybridSystem,
    params: Mapping[str, float],
    mode: str,
    parameter: str,
    values,
    coordinates=None,
) -> dict[str, np.ndarray]:
    """Amplitude of the periodic response of a mode linearised at the zero state, over a parameter.

    The mode's DAE ``x' = f(t, x, z)``, ``0 = g(t, x, z)`` (``x`` its differential variables
    without the quadratures, ``z`` its slave variables) linearised at ``x = 0, z = 0``:
    ``x' = A x + b(t)`` with ``A = f_x - f_z g_z^{-1} g_x`` (as :func:`reduced_jacobian`) and
    ``b(t) = f(t, 0, 0) - f_z g_z^{-1} g(t, 0, 0)`` the forcing, sampled over the model's forcing
    period ``T`` and split into its harmonics ``k = 1, 2, ...`` of ``2 pi / T``. Each harmonic's
    response is ``(i k 2 pi / T - A)^{-1} B_k``; a slave variable follows as
    ``z = -g_z^{-1} (g(t, 0, 0) + g_x x)``. The constant part (``k = 0``: a static offset, free
    where ``A`` is singular, e.g. a stuck friction contact's) is left out: the amplitude is
    ``max_t |x_j(t)|`` of the oscillating part, ``|X_j|`` for a single harmonic (``2 |X_1j|``
    with the complex amplitude of ``e^{i Omega t}``), infinite at a resonance.

    Parameters
    ----------
    system : HybridSystem
        A periodically forced model (it declares a ``period``).
    params : mapping of str to float
        All parameter values (``parameter``'s is replaced by ``values``).
    mode : str
        The mode to linearise.
    parameter : str
        The parameter that varies (e.g. the forcing frequency).
    values : array_like, shape (n,)
        Its values.
    coordinates : sequence of str, optional
        Variables whose amplitude is returned (default: every non-quadrature variable).

    Returns
    -------
    dict of str to ndarray, shape (n,)
        ``{coordinate: amplitude}`` in the coordinate's unit.

    Raises
    ------
    InputError
        An unknown mode, parameter or coordinate, a coordinate that is a quadrature, or a model
        without a forcing period.

    Examples
    --------
    A mass on a spring forced by ``F sin(Omega t)``: ``|X| = F / |k - m Omega^2|``.

    >>> import numpy as np
    >>> from hybrid import HybridSystem, Mode
    >>> osc = HybridSystem(name="osc", variables=["x", "v"], parameters=["m", "k", "F", "Omega"],
    ...                    equations={"x": "v", "v": "(F*sin(Omega*t) - k*x)/m"}, modes=[Mode("free")],
    ...                    transitions=[],
    ...                    period="2*pi/Omega")
    >>> a = linear_response(osc, {"m": 1.0, "k": 4.0, "F": 1.0, "Omega": 1.0}, "free", "Omega", [1.0, 3.0])
    >>> np.allclose(a["x"], [1 / 3, 1 / 5], rtol=1e-13)
    True
    """
    if system.period is None:
        raise InputError(
            f"model `{system.name}` declares no forcing period: it has no forced linear response"
        )
    if parameter not in system.parameter_names:
        raise InputError(f"model `{system.name}` has no parameter `{parameter}`")
    derivs, alg = _mode_equations(system, mode)
    names = list(system.variable_names)
    quad = set(system.quadratures)
    d_names = [v for v in names if v in derivs and v not in quad]
    a_names = [v for v in names if v in alg]
    coords = list(coordinates) if coordinates is not None else d_names + a_names
    for c in coords:
        if c not in d_names and c not in a_names:
            raise InputError(
                f"`{c}` is not a state variable of mode `{mode}` of model `{system.name}` "
                f"(variables: {', '.join(d_names + a_names)})"
            )
    w = np.atleast_1d(np.asarray(values, dtype=float))
    constants = {k: num(v) for k, v in system.parameter_values(params).items() if k != parameter}
    slots = {"t": 0, parameter: 1, **{v: i + 2 for i, v in enumerate(names)}}
    rows = [substitute(derivs[v], constants) for v in d_names] + [
        substitute(alg[v], constants) for v in a_names
    ]
    cols = d_names + a_names
    jac = [diff(e, c) for e in rows for c in cols]
    nd, na = len(d_names), len(a_names)
    n_rows = nd + na
    fn_rows = compile_many(rows, slots, f"forcing_{mode}", vector=True) if rows else None
    fn_jac = compile_many(jac, slots, f"linear_{mode}", vector=True) if jac else None
    fn_period = compile_many([substitute(system.parsed.period, constants)], slots, "period", vector=True)

    zeros = [np.zeros(1)] * len(names)
    with np.errstate(all="ignore"):
        T = np.broadcast_to(np.asarray(fn_period([np.zeros(1), w, *zeros])[0], dtype=float), w.shape)
    N = FORCING_SAMPLES
    tt = T[:, None] * (np.arange(N)[None, :] / N)  # (n_w, N)
    ww = np.broadcast_to(w[:, None], tt.shape)
    zeros = [np.zeros(tt.shape)] * len(names)
    with np.errstate(all="ignore"):
        F0 = np.stack(
            [np.broadcast_to(np.asarray(r, dtype=float), tt.shape) for r in fn_rows([tt, ww, *zeros])]
        )
        zero_t = [np.zeros(w.shape)] * len(names)
        Jv = fn_jac([np.zeros(w.shape), w, *zero_t]) if fn_jac else ()
    J = np.stack([np.broadcast_to(np.asarray(e, dtype=float), w.shape) for e in Jv], axis=-1) if jac else None
    J = J.reshape(w.size, n_rows, n_rows) if J is not None else np.zeros((w.size, 0, 0))
    fx, fz = J[:, :nd, :nd], J[:, :nd, nd:]
    gx, gz = J[:, nd:, :nd], J[:, nd:, nd:]
    f0, g0 = F0[:nd], F0[nd:]  # (nd, n_w, N), (na, n_w, N)
    if na:
        S = np.linalg.solve(gz, np.concatenate([gx, np.moveaxis(g0, 0, 1)], axis=2))  # g_z^{-1} [g_x, g0(t)]
        Sx, Sg = S[:, :, :nd], S[:, :, nd:]  # (n_w, na, nd), (n_w, na, N)
        A = fx - fz @ Sx
        b = np.moveaxis(f0, 0, 1) - fz @ Sg  # (n_w, nd, N)
    else:
        A = fx
        b = np.moveaxis(f0, 0, 1)
    B = np.fft.rfft(b, axis=2) / N  # (n_w, nd, N//2 + 1): b = sum_k B_k e^{i k w0 t} + c.c.
    Bz = np.fft.rfft(-Sg, axis=2) / N if na else None
    scale = max(
        float(np.max(np.abs(B[:, :, 1:]))) if B.size else 0.0,
        float(np.max(np.abs(Bz[:, :, 1:]))) if na else 0.0,
    )
    ks = [
        k
        for k in range(1, N // 2)
        if scale > 0
        and (
            np.max(np.abs(B[:, :, k])) > 1e-13 * scale or (na and np.max(np.abs(Bz[:, :, k])) > 1e-13 * scale)
        )
    ]
    w0 = 2 * np.pi / T
    idx = {c: i for i, c in enumerate(cols)}
    amps = {c: np.zeros(w.size) for c in coords}
    if not ks:
        return amps
    X = np.zeros((w.size, len(ks), nd), dtype=complex)
    for j, k in enumerate(ks):
        M = 1j * k * w0[:, None, None] * np.eye(nd)[None] - A
        for i in range(w.size):
            try:
                X[i, j] = np.linalg.solve(M[i], B[i, :, k])
            except np.linalg.LinAlgError:  # exactly at a resonance
                X[i, j] = np.inf
    Z = None
    if na:
        Z = np.stack([Bz[:, :, k] for k in ks], axis=1) - np.einsum("wad,wkd->wka", Sx, X)
    for c in coords:
        i = idx[c]
        H = X[:, :, i] if i < nd else Z[:, :, i - nd]  # (n_w, n_k): x_c(t) = 2 Re sum_k H_k e^{i k w0 t}
        with np.errstate(all="ignore"):
            if len(ks) == 1:
                amps[c] = 2.0 * np.abs(H[:, 0])
            else:
                amps[c] = _max_abs_periodic(H, np.array(ks))
    return amps


def _mode_equations(system: HybridSystem, mode: str) -> tuple[dict, dict]:
    """The parsed derivatives and algebraic equations of mode ``mode`` (of a system with components:
    its own mode's and each component's local mode's, merged). InputError for an unknown mode."""
    if not system.components:
        if mode not in system.parsed.modes:
            raise InputError(
                f"model `{system.name}` has no mode `{mode}`; modes: {', '.join(m.name for m in system.modes)}"
            )
        data = system.parsed.modes[mode]
        return data["derivatives"], data["algebraic"]
    key = system.mode_key(mode)
    parsed = system.parsed
    parts = [parsed.modes[system.modes[key[0]].name]] + [
        cd["modes"][c.modes[k].name]
        for c, cd, k in zip(system.components, parsed.components, key[1:], strict=True)
    ]
    derivs = {n: e for p in parts for n, e in p["derivatives"].items()}
    alg = {n: e for p in parts for n, e in p["algebraic"].items()}
    return derivs, alg


def _max_abs_periodic(H: np.ndarray, ks: np.ndarray) -> np.ndarray:
    """``max over theta of |2 Re sum_k H_k e^{i k theta}|`` per row of ``H`` (samples, then a parabola
    through the largest sample and its neighbours)."""
    M = RESPONSE_SAMPLES
    th = 2 * np.pi * np.arange(M) / M
    x = 2.0 * np.real(H @ np.exp(1j * np.outer(ks, th)))  # (n_w, M)
    a = np.abs(x)
    j = np.argmax(a, axis=1)
    rows = np.arange(a.shape[0])
    y0, y1, y2 = a[rows, (j - 1) % M], a[rows, j], a[rows, (j + 1) % M]
    den = y0 - 2 * y1 + y2
    with np.errstate(all="ignore"):
        d = np.where(den < 0, 0.5 * (y0 - y2) / den, 0.0)
    d = np.clip(np.nan_to_num(d), -0.5, 0.5)
    tj = th[j] + d * (2 * np.pi / M)
    val = np.abs(2.0 * np.real(np.sum(H * np.exp(1j * np.outer(tj, ks)), axis=1)))
    return np.where(np.isfinite(y1), np.maximum(val, y1), y1)
