"""Orbits and the frequency response of the FE beam with a tip Jenkins contact (issue 32).

References are independent of the library: scipy's LAPACK balancing and ``expm`` for the flow of
a badly scaled generator; the other integrator (IDA) for the orbits; the energy balance over a
period; the linear response of the stuck structure solved directly with numpy,
``(K + kt e e^T - Omega^2 M + i Omega C) X = F e``, for the stuck band of the frequency response and
(with scipy's ``brentq``) for the forcing frequency where the stuck contact's force reaches the
slip force.
"""

from __future__ import annotations

import time
import tomllib
from pathlib import Path

import numpy as np
import pytest
import scipy.linalg
import scipy.optimize

from hybrid import (
    IDA,
    Exact,
    SolverOptions,
    frequency_response,
    load_system,
    periodic_orbit,
    simulate,
    system_from_dict,
)
from hybrid.integrators import assembly
from hybrid.integrators.flow import Flow, matrix_exp
from hybrid.integrators.flows import exact_flows
from hybrid.model.compiled import CompiledSystem

MODELS = Path(__file__).resolve().parents[2] / "models"
EXACT = SolverOptions(method=Exact())


def _row_error(A: np.ndarray, B: np.ndarray) -> float:
    """Largest error of a row of ``A`` against ``B``, relative to that row's ``sum |B_ij|``."""
    return float(np.max(np.abs(A - B).sum(axis=1) / np.abs(B).sum(axis=1)))


@pytest.mark.parametrize("model", ["beam_tip.toml", "beam_tip_cb.toml"])
def test_the_flow_of_the_stuck_beam_equals_scipys_balanced_expm(model):
    # issue 32: the stuck beam's generator mixes displacements [m] and rotations [rad] through
    # M^-1 K (||M||_1 = 2.2e11 against a spectral radius of 8.9e4 for 10 elements); the unbalanced
    # Pade exponential was wrong by 5e-5 of a row and Newton's method on the orbit stalled at 2.7e-6
    system = load_system(MODELS / model)
    p = dict(system.preset("standard"), Omega=90.0)
    cs = CompiledSystem(system, p)
    M = exact_flows(cs)[cs.mode_id("motion|stick")].M
    flow = Flow(M, np.zeros((0,) + M.shape))
    Mb, T = scipy.linalg.matrix_balance(M, permute=False)  # LAPACK gebal: M = T Mb T^-1
    s = np.diag(T)
    ref = {
        h: scipy.linalg.expm(Mb * h) * (s[:, None] / s[None, :]) for h in (1e-5, 1e-4, 2 * np.pi / 90.0 / 16)
    }
    for h, E in ref.items():
        assert _row_error(flow.matrix(h), E) < 1e-10, h
    if model == "beam_tip.toml":  # what the balancing is for: the plain Pade exponential is not exact
        assert _row_error(matrix_exp(M * 1e-4), ref[1e-4]) > 1e-6


# ----------------------------------------------------------------------------
# The exact integrator's path: dense where the generator is stiff, sparse Taylor for large
# non-stiff networks (issue 32)
# ----------------------------------------------------------------------------
def _full_beam20() -> dict:
    """beam_tip_cb.toml without its reduction: the full beam of 20 elements (84 states)."""
    data = tomllib.loads((MODELS / "beam_tip_cb.toml").read_text())
    del data["structures"]["beam"]["reduce"]
    data["structures"]["beam"]["matrices"] = str(MODELS / "data" / "beam20.npz")
    return data


def test_a_stiff_structure_takes_the_dense_path_a_large_soft_chain_the_sparse_one():
    # issue 32: the 20-element beam (84 states > DENSE_LIMIT, ||M||_inf = 6.9e12) took Taylor steps
    # of 1.5 / ||M|| = 2e-13 s and never finished one period; a chain of 40 friction blocks
    # (||M||_inf about 4) steps a whole forcing period on the Taylor path
    beam = system_from_dict(_full_beam20())
    cs = CompiledSystem(beam, dict(beam.preset("standard"), Omega=90.0))
    assert len(cs.names) + 3 > assembly.DENSE_LIMIT
    am = exact_flows(cs)[cs.mode_id("motion|stick")]
    assert not isinstance(am, assembly.SparseAffineMode)
    data = tomllib.loads((MODELS / "bk_chain.toml").read_text())
    data["cells"]["block"]["count"] = 40
    chain = system_from_dict(data)
    cs = CompiledSystem(chain, chain.preset("standard"))
    assert isinstance(exact_flows(cs)[cs.mode_id(chain.default_mode)], assembly.SparseAffineMode)


@pytest.mark.slow
def test_the_full_beam_of_20_elements_exact_equals_ida():
    system = system_from_dict(_full_beam20())
    p = dict(system.preset("standard"), Omega=90.0, F=3.0)
    x0 = dict.fromkeys(system.variable_names, 0.0)
    span = (0.0, 0.25 * 2 * np.pi / p["Omega"])  # a quarter period: IDA needs 180 s for a whole one
    start = time.perf_counter()
    ex = simulate(system, p, span, x0, options=EXACT)
    print(f"full beam of 20 elements, a quarter period on Exact: {time.perf_counter() - start:.2f} s")
    start = time.perf_counter()
    ida = simulate(system, p, span, x0, options=SolverOptions(method=IDA(rtol=1e-9, atol=1e-12)))
    print(f"the same on IDA (rtol 1e-9): {time.perf_counter() - start:.2f} s")
    assert ex.n_transitions >= 1 and ex.n_transitions == ida.n_transitions  # it starts to slip
    a, b = ex.final_values, ida.final_values
    for name in ("beam_w20", "v_beam_w20", "beam_w10", "slider"):
        scale = max(abs(a[name]), 1e-3 * abs(a["beam_w20"]))
        assert abs(a[name] - b[name]) < 1e-5 * scale, (name, a[name], b[name])


# ----------------------------------------------------------------------------
# The linear response of the stuck structure, written here from the matrices
# ----------------------------------------------------------------------------
ZETA = 0.005  # the models' modal damping ratio (every mode)


def _modal_damping(M: np.ndarray, K: np.ndarray) -> np.ndarray:
    w2, phi = scipy.linalg.eigh(K, M)
    MP = M @ phi
    return MP @ np.diag(2 * ZETA * np.sqrt(w2)) @ MP.T


def _craig_bampton(M, K, C, tip: int, modes: int):
    """The reduction to the tip DOF and ``modes`` fixed-interface modes, written out here."""
    n = M.shape[0]
    inner = [k for k in range(n) if k != tip]
    T = np.zeros((n, 1 + modes))
    T[tip, 0] = 1.0
    T[inner, 0] = -np.linalg.solve(K[np.ix_(inner, inner)], K[inner, tip])
    _, phi = scipy.linalg.eigh(K[np.ix_(inner, inner)], M[np.ix_(inner, inner)])
    T[np.ix_(inner, range(1, 1 + modes))] = phi[:, :modes]
    return T.T @ M @ T, T.T @ K @ T, T.T @ C @ T, 0


def _stuck_structure(model: str):
    """``(M, K, C, tip index)`` of the structure the model holds (Craig-Bampton-reduced if it says)."""
    npz = "beam10.npz" if model == "beam_tip.toml" else "beam20.npz"
    z = np.load(MODELS / "data" / npz)
    M, K = z["M"], z["K"]
    dofs = [str(d) for d in z["dofs"]]
    tip = dofs.index("w10" if model == "beam_tip.toml" else "w20")
    C = _modal_damping(M, K)
    if model == "beam_tip_cb.toml":
        return _craig_bampton(M, K, C, tip, 6)
    return M, K, C, tip


def _tip_amplitude(structure, p: dict, omega: float) -> float:
    """``|X_tip|`` of ``(K + kt e e^T - Omega^2 M + i Omega C) X = F e``: the stuck structure's
    response to ``F sin(Omega t)`` at the tip (the slider at rest at 0)."""
    M, K, C, tip = structure
    e = np.zeros(M.shape[0])
    e[tip] = 1.0
    A = K + p["kt"] * np.outer(e, e) - omega**2 * M + 1j * omega * C
    return float(abs(np.linalg.solve(A, p["F"] * e)[tip]))


def _slip_edges(structure, p: dict) -> tuple[float, float]:
    """The forcing frequencies below and above the stuck resonance where the stuck contact's
    force amplitude ``kt |X_tip|`` reaches the slip force ``R`` (brentq on the linear response)."""
    M, K, C, tip = structure
    e = np.zeros(M.shape[0])
    e[tip] = 1.0
    peak = float(np.sqrt(scipy.linalg.eigh(K + p["kt"] * np.outer(e, e), M, eigvals_only=True)[0]))
    g = lambda w: p["kt"] * _tip_amplitude(structure, p, w) - p["R"]  # noqa: E731
    return (
        scipy.optimize.brentq(g, 0.3 * peak, peak, xtol=1e-13, rtol=1e-15),
        scipy.optimize.brentq(g, peak, 3.0 * peak, xtol=1e-13, rtol=1e-15),
    )


# ----------------------------------------------------------------------------
# Orbits across the first resonance: Exact against IDA, energy balance, the stuck ones linear
# ----------------------------------------------------------------------------
OMEGAS = (60.0, 75.0, 85.0, 95.0, 105.0, 120.0)  # rad/s; the stuck resonance is at 93 rad/s


def _orbit_checks(model: str, omega: float, system=None):
    system = load_system(MODELS / model) if system is None else system
    p = dict(system.preset("standard"), Omega=omega)
    start = time.perf_counter()
    orbit = periodic_orbit(system, p, options=EXACT)
    print(f"{model} exact orbit at Omega = {omega} rad/s: {time.perf_counter() - start:.3f} s")
    assert orbit.converged, orbit.message
    tip = [n for n in system.variable_names if n.startswith("beam_w")][-1]
    # the orbit's state, one period on IDA, returns there
    tr = simulate(
        system,
        p,
        (orbit.t0, orbit.t0 + orbit.period),
        orbit.x0,
        orbit.mode0,
        options=SolverOptions(method=IDA(rtol=1e-11, atol=1e-15)),
    )
    x0 = dict(zip(system.variable_names, orbit.x0, strict=True))
    for name in (tip, "v_" + tip, "slider"):
        scale = orbit.half_peak_to_peak[tip] * (omega if name.startswith("v_") else 1.0)
        assert abs(tr.final_values[name] - x0[name]) < 1e-7 * scale, (name, tr.final_values[name], x0[name])
    # over a period the work of the force equals what the contact and the damping dissipate
    assert abs(orbit.energy["relative_residual"]) < 1e-9, orbit.energy
    # a stuck orbit is the linear response of the stuck structure
    slip = orbit.mode_fractions.get("motion|slip+", 0.0) + orbit.mode_fractions.get("motion|slip-", 0.0)
    lo, hi = _slip_edges(_stuck_structure(model), p)
    if lo < omega < hi:
        assert slip > 0.05, orbit.mode_fractions  # stick-slip
    else:
        assert slip == 0.0, orbit.mode_fractions
        X = _tip_amplitude(_stuck_structure(model), p, omega)
        assert abs(orbit.half_peak_to_peak[tip] - X) < 1e-8 * X
    return orbit


@pytest.mark.slow
@pytest.mark.parametrize("omega", OMEGAS)
def test_reduced_beam_orbits_across_the_first_resonance(omega):
    _orbit_checks("beam_tip_cb.toml", omega)


@pytest.mark.slow
@pytest.mark.parametrize("omega", OMEGAS)
def test_full_beam_orbits_across_the_first_resonance(omega):
    # issue 32: Newton stalled at a residual of 2.7e-6 here before the exponential was balanced
    _orbit_checks("beam_tip.toml", omega)


# ----------------------------------------------------------------------------
# The frequency response across the first resonance, with its special points
# ----------------------------------------------------------------------------
#: The slip onset and loss of the reduced beam at the standard preset [rad/s], as the tutorial
#: (docs/tutorial_structures.md) states them, to the digits it gives.
TUTORIAL_EDGES = (76.345, 106.409)


def _frc_checks(model: str, span: tuple[float, float]):
    system = load_system(MODELS / model)
    p = dict(system.preset("standard"))
    structure = _stuck_structure(model)
    lo, hi = _slip_edges(structure, p)
    start = time.perf_counter()
    fr = frequency_response(system, p, span, options=EXACT)
    print(f"{model} frc over {span} rad/s on Exact: {time.perf_counter() - start:.1f} s")
    tip = [n for n in system.variable_names if n.startswith("beam_w")][-1]
    # the stuck band: every orbit without slip is the linear response of the stuck structure
    stuck = []
    for br in fr.branches:
        for orbit, w, a in zip(br.points, br.values, br.half_peak_to_peak(tip), strict=True):
            if set(orbit.mode_fractions) == {"motion|stick"}:
                X = _tip_amplitude(structure, p, w)
                assert abs(a - X) < 1e-8 * X, (w, a, X)
                assert not lo < w < hi  # stuck only where kt |X_tip| < R
                stuck.append(w)
    # stuck orbits below the slip onset and above the slip loss (on the reduced beam over 60 to
    # 125 rad/s: two branches, one from each end, 20 stuck orbits)
    assert min(stuck) < lo and max(stuck) > hi and len(stuck) >= 5, stuck
    # slip onset and loss: where the stuck contact's force amplitude equals the slip force. Each is
    # a change of the mode sequence of a branch (slip appears continuing from 60 rad/s up to the
    # onset, and from 125 rad/s down to the loss)
    changes = [s for br in fr.branches for s in br.special if s.kind in ("mode-gained", "mode-lost")]
    for edge in (lo, hi):
        (s,) = [s for s in changes if abs(s.parameter - edge) < 1e-3]
        print(f"  {s.kind} at {s.parameter!r} in {s.interval}; closed form {edge!r}")
        assert s.interval[0] <= edge <= s.interval[1], (s.kind, s.interval, edge)
        assert s.interval[1] - s.interval[0] < 1e-5
        assert abs(s.parameter - edge) < 1e-9  # measured 6e-11 and 2e-10
    kinds = [s.kind for br in fr.branches for s in br.special]
    assert not {"fold", "period-doubling", "neimark-sacker"} & set(kinds), kinds
    return lo, hi


@pytest.mark.slow
def test_reduced_beam_frequency_response_stuck_band_and_slip_edges():
    lo, hi = _frc_checks("beam_tip_cb.toml", (60.0, 125.0))
    assert abs(lo - TUTORIAL_EDGES[0]) < 5e-4 and abs(hi - TUTORIAL_EDGES[1]) < 5e-4


def test_the_tutorials_frequencies():
    # docs/tutorial_structures.md: the free beam's first natural frequency 52.497 rad/s (10 and 20
    # elements), the stuck resonance 93 rad/s (kt = 5000 N/m at the tip), by eigh of the matrices
    for model in ("beam_tip.toml", "beam_tip_cb.toml"):
        M, K, _, tip = _stuck_structure(model)
        free = np.sqrt(scipy.linalg.eigh(K, M, eigvals_only=True)[0])
        K[tip, tip] += 5000.0
        stuck = np.sqrt(scipy.linalg.eigh(K, M, eigvals_only=True)[0])
        assert abs(free - 52.497) < 5e-4 and abs(stuck - 93.0) < 0.5, (model, free, stuck)
