"""Tests of the averaging model (hybrid_models.averaging), Sec. 4 and App. D of [1].

Every expected value comes from an independent route, built here from the physical
parameters only:

* modal data from numpy eigenvectors of the physical stick system ``M_x x'' + K x = f`` and the
  projection of the physical force vectors (not from the paper's z-coordinates);
* the averaged equations by quadrature of the exact Van der Pol form over one cycle, with the
  friction coordinate produced by a play operator (stick while the element force is below R,
  follow the slip law otherwise), so neither Eq. (27) nor Eqs. (30)/(31) are used;
* the peak amplitude from the one-mode energy balance (work of the excitation at the optimal
  phase equals the friction work per cycle);
* eigenfrequencies by ``numpy.linalg.eigvals``; stability by ``scipy.integrate.solve_ivp``.

[1] Aramendiz et al., "Sequential friction-spring dampers" (``shared/seed``).
"""

from __future__ import annotations

import math

import numpy as np
import pytest
import scipy.linalg
from scipy.integrate import solve_ivp
from scipy.optimize import brentq, minimize_scalar, root

import hybrid_models
from hybrid_models import averaging as av

ABSORBER = hybrid_models.absorber().preset("standard")
ISOLATOR = hybrid_models.isolator().preset("standard")
PARAMS = {"absorber": ABSORBER, "isolator": ISOLATOR}
CASES = [(m, i) for m in ("absorber", "isolator") for i in (1, 2)]
N_QUAD = 2**16


# ------------------------------------------------------------------------------------------
# Independent reference: physical modes, play-operator loop, quadrature of the Van der Pol form
# ------------------------------------------------------------------------------------------


class Ref:
    """One mode of the physical stick system, mass-normalised as in the paper, from numpy only."""

    def __init__(self, model: str, p: dict[str, float], mode: int):
        m1, m2, c1, c2, c3, R, F = (p[k] for k in ("m1", "m2", "c1", "c2", "c3", "R", "F"))
        Mx = np.diag([m1, m2])
        K = np.array([[c1 + c2, -c2], [-c2, c2]])
        lam, vec = np.linalg.eig(np.linalg.solve(Mx, K))
        order = np.argsort(lam.real)
        lam, vec = lam.real[order], vec.real[:, order]
        k = math.sqrt(c1 / m1)
        phi = vec[:, mode - 1]
        # Reference mass: the paper divides the absorber by (m1 + m2) k^2, the isolator by m1 k^2.
        mref = m1 + m2 if model == "absorber" else m1
        phi = phi / math.sqrt(phi @ Mx @ phi / mref)
        cs = c2 if model == "absorber" else c1
        # Friction coordinate: z2 = x2 - x1 (absorber) or x1 (isolator), made positive.
        r = phi[1] - phi[0] if model == "absorber" else phi[0]
        phi = phi * np.sign(r)
        self.r = abs(r)
        self.eta = math.sqrt(lam[mode - 1]) / k
        self.x = phi
        # Modal forces per unit of eps f = F/c1 and of w [m], tau = k t: phi^T f / (mref k^2).
        self.Fc = phi[0] * c1 / (mref * k**2)
        w_force = cs * np.array([-1.0, 1.0]) if model == "absorber" else np.array([c1, 0.0])
        self.Wc = phi @ w_force / (mref * k**2)
        self.kap = cs / (cs + c3)  # eps kappa [-]
        self.rho = R / (cs + c3)  # eps rho [m]
        self.f = F / c1  # eps f [m]
        self.k = k
        self.cs, self.c3, self.F, self.R = cs, c3, F, R


def play_loop(amp: float, band: float, n: int = N_QUAD):
    """Steady friction coordinate over phi in [-pi/2, 3pi/2) for the input amp sin(phi).

    The element sticks while |input - w| < band and follows input -/+ band while slipping:
    w_k = clip(w_{k-1}, x_k - band, x_k + band), written per monotone half cycle.
    """
    half = n // 2
    ph_up = -np.pi / 2 + np.pi * np.arange(half + 1) / half  # both turning points included
    ph_dn = ph_up + np.pi
    x_up, x_dn = amp * np.sin(ph_up), amp * np.sin(ph_dn)
    x_up[[0, -1]], x_dn[[0, -1]] = (-amp, amp), (amp, -amp)  # exact turning points
    w = float(np.clip(0.0, -amp - band, -amp + band))
    for _ in range(2):
        w_up = np.maximum(w, np.maximum.accumulate(x_up - band))
        w_dn = np.minimum(w_up[-1], np.minimum.accumulate(x_dn + band))
        w = w_dn[-1]
    return np.concatenate([ph_up[:-1], ph_dn[:-1]]), np.concatenate([w_up[:-1], w_dn[:-1]])


def ref_rhs(ref: Ref, A: float, psi: float, eta: float) -> np.ndarray:
    """Averaged (A', psi') by quadrature of q'' + eta_i^2 q = eps Fc f sin(eta tau) + Wc w."""
    ph, w = play_loop(ref.kap * ref.r * A, ref.rho)
    g = ref.f * ref.Fc * np.sin(ph - psi) + ref.Wc * w
    dA = np.mean(g * np.cos(ph)) / ref.eta
    dpsi = ref.eta - eta - np.mean(g * np.sin(ph)) / (A * ref.eta)
    return np.array([dA, dpsi])


def ref_peak(ref: Ref) -> float:
    """Largest modal amplitude with a fixed point: 2 Wc |<w cos>| = |Fc| eps f (quadrature)."""
    a_min1 = ref.rho / (ref.kap * ref.r)

    def h(A):
        ph, w = play_loop(ref.kap * ref.r * A, ref.rho)
        return 2.0 * abs(ref.Wc * np.mean(w * np.cos(ph))) - abs(ref.Fc) * ref.f

    return brentq(h, a_min1 * (1 + 1e-9), 1e3 * a_min1, xtol=1e-14, rtol=1e-14)


def energy_balance_peak(ref: Ref, R: float | None = None) -> float:
    """Peak amplitude Z [m] of the friction coordinate from the work balance per cycle.

    pi F X1 = 4 R (cs Z - R)/(cs + c3), X1 = beta Z: Z = 4 R^2 / (4 R cs - pi F beta (cs + c3)).
    """
    R = ref.R if R is None else R
    beta = abs(ref.x[0]) / ref.r
    den = 4 * R * ref.cs - math.pi * ref.F * beta * (ref.cs + ref.c3)
    return 4 * R**2 / den if den > 0 else math.inf


# ------------------------------------------------------------------------------------------
# Nondimensional parameters: the captions of Figs. 11-13
# ------------------------------------------------------------------------------------------


def test_caption_values_figs_11_to_13():
    """Figs. 11/12 (absorber): eps = 0.01, kappa = 0.99, rho = 4.95, f = 1; Fig. 13 (isolator): rho = 1.49."""
    for model, rho in (("absorber", 4.95), ("isolator", 1.49)):
        nd = av.nondimensional(model, PARAMS[model])
        assert nd.eps == 0.01
        assert round(nd.kappa, 2) == 0.99
        assert round(nd.rho, 2) == rho
        assert nd.f == pytest.approx(1.0, rel=1e-15)
        # Exact values: kappa = c/(c + c3)/eps, rho = R/(c + c3)/eps.
        c = 0.1 if model == "absorber" else 1.0
        c3, R = PARAMS[model]["c3"], PARAMS[model]["R"]
        assert nd.kappa == pytest.approx(c / (c + c3) / 0.01, rel=1e-15)
        assert nd.rho == pytest.approx(R / (c + c3) / 0.01, rel=1e-15)
        # The captions' mu = 0.1 is m2/m1; Eq. (14) defines mu = m2/(m1 + m2) = 1/11 (erratum 17).
        assert nd.mu == pytest.approx(1 / 11, rel=1e-15)
        assert round(nd.mu, 2) == 0.09
        assert PARAMS[model]["m2"] / PARAMS[model]["m1"] == 0.1
        assert nd.p == pytest.approx(1.0)
        assert nd.k == pytest.approx(1.0)
        assert nd.eta == pytest.approx(0.854)


# ------------------------------------------------------------------------------------------
# Modal decoupling
# ------------------------------------------------------------------------------------------


@pytest.mark.parametrize("model", ["absorber", "isolator"])
@pytest.mark.parametrize("p", [None, {"m1": 2.5, "m2": 0.4, "c1": 3.0, "c2": 0.7, "c3": 0.9}])
def test_modal_matrix_diagonalises_the_stick_system(model, p):
    params = dict(PARAMS[model], **(p or {}))
    m1, m2, c1, c2 = (params[k] for k in ("m1", "m2", "c1", "c2"))
    M, C = av.system_matrices(model, params)
    R, eta = av.modal_matrix(model, params)
    np.testing.assert_allclose(R.T @ M @ R, np.eye(2), atol=1e-13)
    np.testing.assert_allclose(R.T @ C @ R, np.diag(eta**2), atol=1e-13)
    # M, C are the physical stick system in the paper's coordinates (independent construction).
    Mx, K = np.diag([m1, m2]), np.array([[c1 + c2, -c2], [-c2, c2]])
    k2 = c1 / m1
    if model == "absorber":
        mu = m2 / (m1 + m2)
        S = np.array([[1.0, -mu], [1.0, 1.0 - mu]])  # x = S z, z = (centre of mass, x2 - x1)
        np.testing.assert_allclose(M, S.T @ Mx @ S / (m1 + m2), rtol=1e-14, atol=1e-15)
        np.testing.assert_allclose(C, S.T @ K @ S / ((m1 + m2) * k2), rtol=1e-13, atol=1e-15)
    else:
        np.testing.assert_allclose(M, Mx / m1, rtol=1e-15)
        np.testing.assert_allclose(C, K / (m1 * k2), rtol=1e-14)
    # eta_i k are the stick eigenfrequencies of numpy's eigenvalues.
    w = np.sqrt(np.sort(np.linalg.eigvals(np.linalg.solve(Mx, K)).real))
    np.testing.assert_allclose(eta * math.sqrt(k2), w, rtol=1e-13)
    # The modal equation's coefficients equal the projection of the physical forces.
    for mode in (1, 2):
        eq = av.modal_equation(model, params, mode)
        ref = Ref(model, params, mode)
        got = [eq.eta_i, eq.Fc, eq.Wc, eq.r, eq.x1, eq.x2]
        want = [ref.eta, ref.Fc, ref.Wc, ref.r, ref.x[0], ref.x[1]]
        np.testing.assert_allclose(got, want, rtol=1e-12)


def test_standard_set_modal_values_of_theory_doc():
    """The values quoted in docs/theory.md Sec. 5.1 (4 significant digits)."""
    R, eta = av.modal_matrix("absorber", ABSORBER)
    np.testing.assert_allclose(eta, [0.8543, 1.171], rtol=5e-4)
    np.testing.assert_allclose(R, [[0.8486, -0.5291], [1.840, 2.952]], rtol=5e-4)
    g = [av.modal_equation("absorber", ABSORBER, i).Fc for i in (1, 2)]
    np.testing.assert_allclose(g, [0.6193, -0.7249], rtol=5e-4)
    R, _ = av.modal_matrix("isolator", ISOLATOR)
    np.testing.assert_allclose(R, [[0.6495, 0.7603], [2.404, -2.054]], rtol=5e-4)


@pytest.mark.parametrize(("model", "mode"), CASES)
def test_slip_limit_is_the_slip_eigenfrequency(model, mode):
    """For A -> inf (always slipping) eta_i + eps zeta_sin tends to the slip eigenfrequency/k.

    The modal matrix diagonalises the stick system exactly and the slip system to first order
    in eps kappa (first-order eigenvalue perturbation): the error is O((eps kappa)^2).
    """
    p = PARAMS[model]
    eq = av.modal_equation(model, p, mode)
    big = 1e9 * av.characteristic_amplitudes(model, p, mode).A_min1
    _, zs = av.zeta(model, p, mode, [big])
    m1, m2, c1, c2, c3 = (p[k] for k in ("m1", "m2", "c1", "c2", "c3"))
    Mx = np.diag([m1, m2])
    if model == "absorber":
        c2 = c2 * c3 / (c2 + c3)
    else:
        c1 = c1 * c3 / (c1 + c3)
    K = np.array([[c1 + c2, -c2], [-c2, c2]])
    slip = np.sqrt(np.sort(np.linalg.eigvals(np.linalg.solve(Mx, K)).real))[mode - 1] / eq.nd.k
    shift = slip - eq.eta_i
    err = eq.eta_i + eq.nd.eps * zs[0] - slip
    assert abs(err) < 0.05 * abs(shift)
    assert abs(err) < 2 * (eq.nd.eps * eq.nd.kappa) ** 2


# ------------------------------------------------------------------------------------------
# Averaged equations against the quadrature of the Van der Pol form
# ------------------------------------------------------------------------------------------


@pytest.mark.parametrize(("model", "mode"), CASES)
def test_averaged_rhs_equals_quadrature(model, mode):
    p = PARAMS[model]
    ref = Ref(model, p, mode)
    amps = av.characteristic_amplitudes(model, p, mode)
    eta = ref.eta - 0.0007
    for A in (0.5 * amps.A_min1, 1.3 * amps.A_min1, 0.9 * amps.A_max, 3 * amps.A_max):
        for psi in (-2.0, 0.3, 1.9):
            want = ref_rhs(ref, A, psi, eta)
            got = np.array(av.averaged_rhs(model, p, mode, A, psi, eta))
            # Size of the forcing plus friction terms; the quadrature error is O(h^2) ~ 1e-8.
            scale = (abs(ref.Fc) * ref.f + abs(ref.Wc) * ref.kap * ref.r * A) / ref.eta
            assert abs(got[0] - want[0]) < 1e-8 * scale
            assert abs(got[1] - want[1]) < 1e-8 * scale / A


@pytest.mark.parametrize(("model", "mode"), CASES)
def test_frequency_response_points_are_fixed_points(model, mode):
    """Points of Eqs. (32)/(38)/(47)/(48) solve the quadrature-averaged equations (scipy root)."""
    p = PARAMS[model]
    ref = Ref(model, p, mode)
    fr = av.frequency_response(model, p, mode, n=60)
    a_min1, a_max = fr.amplitudes.A_min1, fr.amplitudes.A_max
    picks = [0.3 * a_min1, 1.2 * a_min1, 0.5 * (a_min1 + a_max), 0.98 * a_max]
    curve = av.frequency_response(model, p, mode, A=picks)
    for A, e_lo, e_hi in zip(curve.A, curve.eta_lo, curve.eta_hi, strict=True):
        for eta in (e_lo, e_hi):
            fps = [f for f in av.fixed_points(model, p, mode, eta=eta) if abs(f.A / A - 1) < 1e-6]
            assert len(fps) == 1
            fp = fps[0]
            # Residual of the independent averaged equations at the claimed fixed point.
            res = ref_rhs(ref, fp.A, fp.psi, eta)
            assert np.abs(res).max() < 1e-9 * abs(ref.Fc * ref.f)  # quadrature error ~1e-10
            # And the root found by scipy from a perturbed start is the same point.
            sol = root(lambda y, eta=eta: ref_rhs(ref, y[0], y[1], eta), [1.03 * A, fp.psi + 0.05], tol=1e-11)
            assert sol.success, sol.message
            # The quadrature error (~1e-10 relative) is amplified by the conditioning of the
            # Jacobian (up to ~3e3 on the low branch just above the slip threshold).
            assert sol.x[0] == pytest.approx(A, rel=1e-6)
            assert math.remainder(sol.x[1] - fp.psi, 2 * math.pi) == pytest.approx(0.0, abs=1e-6)


def test_fixed_points_count_and_branches():
    """One fixed point per frequency (the curve is single-valued); stick far away, slip at the peak."""
    peak = av.frequency_response(
        "absorber", ABSORBER, 1, A=[av.characteristic_amplitudes("absorber", ABSORBER, 1).A_max]
    )
    for eta in np.linspace(0.80, 0.90, 21):
        fps = av.fixed_points("absorber", ABSORBER, 1, eta=eta)
        assert len(fps) == 1
        assert fps[0].branch == ("lo" if eta < peak.eta_lo[0] else "hi")
    far = av.fixed_points("absorber", ABSORBER, 1, eta=0.80)[0]
    assert not far.slipping
    assert far.stability == "neutral"
    # Linear stick resonance of the first-order model: A = eps |Fc| f / (2 eta_i |eta - eta_i|).
    ref = Ref("absorber", ABSORBER, 1)
    assert far.A == pytest.approx(ref.f * ref.Fc / (2 * ref.eta * (ref.eta - 0.80)), rel=1e-12)


# ------------------------------------------------------------------------------------------
# Characteristic values
# ------------------------------------------------------------------------------------------


@pytest.mark.parametrize(("model", "mode"), CASES)
def test_peak_amplitude_quadrature_and_energy_balance(model, mode):
    p = PARAMS[model]
    ref = Ref(model, p, mode)
    amps = av.characteristic_amplitudes(model, p, mode)
    assert amps.A_max == pytest.approx(ref_peak(ref), rel=1e-8)
    assert ref.r * amps.A_max == pytest.approx(energy_balance_peak(ref), rel=1e-12)
    # Slip threshold: the play loop is constant below A_min1 and not above it.
    for fac, slips in ((0.999, False), (1.001, True)):
        _, w = play_loop(ref.kap * ref.r * fac * amps.A_min1, ref.rho)
        assert (np.ptp(w) > 0) == slips
    assert amps.A_min == amps.A_min1 > amps.A_min2
    # Physical peak of x1 (Eqs. (45)-(46), (49)-(50)).
    x1, x2 = av.physical_amplitudes(model, p, mode, amps.A_max)
    assert x1 == pytest.approx(abs(ref.x[0]) * energy_balance_peak(ref) / ref.r, rel=1e-12)
    assert x2 / x1 == pytest.approx(abs(ref.x[1] / ref.x[0]), rel=1e-12)


def test_peak_values_of_theory_doc():
    """docs/theory.md Sec. 5.1: Z = 12.11, 8.750 (absorber), X1 = 3.184 m (isolator, both modes)."""
    z = [
        av.modal_equation("absorber", ABSORBER, i).r
        * av.characteristic_amplitudes("absorber", ABSORBER, i).A_max
        for i in (1, 2)
    ]
    np.testing.assert_allclose(z, [12.11, 8.750], rtol=5e-4)
    for i in (1, 2):
        x1, _ = av.physical_amplitudes(
            "isolator", ISOLATOR, i, av.characteristic_amplitudes("isolator", ISOLATOR, i).A_max
        )
        assert x1 == pytest.approx(3.184, rel=2e-4)


@pytest.mark.parametrize(("model", "mode"), CASES)
def test_rho_opt_minimises_the_peak(model, mode):
    p = PARAMS[model]
    ref = Ref(model, p, mode)
    r_opt = av.breakaway_force(model, p, av.rho_opt(model, p, mode))
    r_min = av.breakaway_force(model, p, av.rho_min(model, p, mode))
    # scipy's minimiser on the (independent) energy-balance peak, R in newtons.
    res = minimize_scalar(
        lambda R: energy_balance_peak(ref, R),
        bounds=(1.01 * r_min, 5 * r_min),
        method="bounded",
        options={"xatol": 1e-12},
    )
    assert res.x == pytest.approx(r_opt, rel=1e-6)
    # ... and on the module's A_max, perturbing rho around rho_opt.
    rho = av.rho_opt(model, p, mode)
    nd = av.nondimensional(model, p)

    def amax(rh):
        return av.characteristic_amplitudes(model, dict(p, R=av.breakaway_force(model, p, rh)), mode).A_max

    res = minimize_scalar(
        amax, bounds=(1.01 * rho / 2, 5 * rho / 2), method="bounded", options={"xatol": 1e-12}
    )
    assert res.x == pytest.approx(rho, rel=1e-6)
    for d in (1e-3, -1e-3, 0.1, -0.1):
        assert amax(rho * (1 + d)) > amax(rho)
    # The bounded range starts at rho_min: unbounded below (energy balance has no root).
    assert energy_balance_peak(ref, 0.999 * r_min) == math.inf
    assert math.isinf(av.characteristic_amplitudes(model, dict(p, R=0.999 * r_min), mode).A_max)
    assert math.isfinite(av.characteristic_amplitudes(model, dict(p, R=1.001 * r_min), mode).A_max)
    assert nd.eps * av.rho_min(model, p, mode) * (nd.c_series + p["c3"]) == pytest.approx(r_min, rel=1e-15)


def test_design_values_standard_sets():
    """R_opt: 0.5873 N, 0.4286 N (absorber modes 1, 2); pi f/2 for the isolator (Eq. (51))."""
    r = [av.breakaway_force("absorber", ABSORBER, av.rho_opt("absorber", ABSORBER, i)) for i in (1, 2)]
    np.testing.assert_allclose(r, [0.5873, 0.4286], rtol=2e-4)
    for i in (1, 2):
        assert av.rho_opt("isolator", ISOLATOR, i) == pytest.approx(math.pi / 2, rel=1e-14)
        assert av.rho_min("isolator", ISOLATOR, i) == pytest.approx(math.pi / 4, rel=1e-14)


def test_eps_is_bookkeeping_only():
    for model, mode in CASES:
        p = PARAMS[model]
        a = av.frequency_response(model, p, mode, n=50, eps=0.01)
        b = av.frequency_response(model, p, mode, n=50, eps=0.07)
        np.testing.assert_allclose(a.A, b.A, rtol=1e-12)
        np.testing.assert_allclose(a.Omega_lo, b.Omega_lo, rtol=1e-12)
        np.testing.assert_allclose(a.Omega_hi, b.Omega_hi, rtol=1e-12)
        r1 = av.breakaway_force(model, p, av.rho_opt(model, p, mode, eps=0.01), eps=0.01)
        r2 = av.breakaway_force(model, p, av.rho_opt(model, p, mode, eps=0.07), eps=0.07)
        assert r1 == pytest.approx(r2, rel=1e-14)


# ------------------------------------------------------------------------------------------
# Printed forms (errata of docs/theory.md) against the independent checks
# ------------------------------------------------------------------------------------------


def test_printed_slip_angle_eq27():
    """Erratum 8: only arcsin(2 rho/a - 1) makes w continuous and reproduces the play loop."""
    a, rho = 3.0, 1.0
    ph, w = play_loop(a, rho)
    good = av.friction_displacement(ph, a, rho)
    bad = av.friction_displacement(ph, a, rho, printed=True)
    np.testing.assert_allclose(good, w, rtol=0, atol=1e-12)
    assert np.abs(bad - w).max() > 1.0
    # Jump of w at phi_r: 0 (corrected); a sin(-phi_r) - rho - (rho - a) = 2 (a - 2 rho) (printed).
    for printed, jump in ((False, 0.0), (True, 2 * (a - 2 * rho))):
        pr = float(av.slip_angle(a, rho, printed))
        left, right = av.friction_displacement([pr - 1e-12, pr], a, rho, printed)
        assert right - left == pytest.approx(jump, abs=1e-9)
    assert float(av.slip_angle(a, rho)) == pytest.approx(-float(av.slip_angle(a, rho, printed=True)))


@pytest.mark.parametrize(("model", "mode"), CASES)
def test_printed_prefactor_eqs_28_29_energy_balance(model, mode):
    """Erratum 9: the slow flow is eps (...), not eps/eta_i (...).

    Energy balance of the modal oscillator: d/dtau (eta_i^2 A^2/2) = <q' g> over a cycle, i.e.
    eta_i^2 A <A'> = <A eta_i cos(phi) g>, evaluated by quadrature with the play loop.
    """
    p = PARAMS[model]
    ref = Ref(model, p, mode)
    A, psi = 1.5 * av.characteristic_amplitudes(model, p, mode).A_min1, -1.0
    ph, w = play_loop(ref.kap * ref.r * A, ref.rho)
    g = ref.f * ref.Fc * np.sin(ph - psi) + ref.Wc * w
    power = np.mean(A * ref.eta * np.cos(ph) * g)
    good, _ = av.averaged_rhs(model, p, mode, A, psi)
    bad, _ = av.averaged_rhs(model, p, mode, A, psi, printed=True)
    assert ref.eta**2 * A * good == pytest.approx(power, rel=1e-8)
    assert abs(ref.eta**2 * A * bad / power - 1) > 0.14
    assert float(bad / good) == pytest.approx(1 / ref.eta, rel=1e-12)
    # Same fixed points and stability: the Jacobian is only scaled by 1/eta_i.
    fp = av.fixed_points(model, p, mode, eta=ref.eta - 0.0005)[-1]
    j0 = av.averaged_jacobian(model, p, mode, fp.A, fp.psi, ref.eta - 0.0005)
    j1 = av.averaged_jacobian(model, p, mode, fp.A, fp.psi, ref.eta - 0.0005, printed=True)
    if (model, mode) == ("isolator", 2):  # the printed D.7 also changes zeta_sin' (erratum 11)
        assert abs(j1[1, 0] * ref.eta / j0[1, 0] - 1) > 0.5
    else:
        np.testing.assert_allclose(j1, j0 / ref.eta, rtol=1e-14)


def test_printed_zeta_d7_isolator_mode2():
    """Erratum 11: D.7's zeta_w2,sin has -2/(...) printed; only -1/(...) matches the quadrature."""
    p = ISOLATOR
    ref = Ref("isolator", p, 2)
    A = 2.0 * av.characteristic_amplitudes("isolator", p, 2).A_min1
    ph, w = play_loop(ref.kap * ref.r * A, ref.rho)
    want = -ref.Wc * np.mean(w * np.sin(ph)) / (0.01 * A * ref.eta)  # zeta_sin, eps = 0.01
    _, good = av.zeta("isolator", p, 2, A)
    _, bad = av.zeta("isolator", p, 2, A, printed=True)
    assert float(good) == pytest.approx(want, rel=1e-8)
    assert float(bad) == pytest.approx(2 * want, rel=1e-8)
    assert av.zeta("isolator", p, 1, A, printed=True) == av.zeta("isolator", p, 1, A)  # D.6 is right
    # The printed curve (D.9) fails the fixed-point check; the corrected one passes.
    A = [1.5 * av.characteristic_amplitudes("isolator", p, 2).A_min1]
    for printed, ok in ((False, True), (True, False)):
        eta = float(av.frequency_response("isolator", p, 2, A=A, printed=printed).eta_hi[0])
        fps = av.fixed_points("isolator", p, 2, eta=eta)
        assert (
            any(
                abs(f.A / A[0] - 1) < 1e-6 and np.abs(ref_rhs(ref, f.A, f.psi, eta)).max() < 1e-9 for f in fps
            )
            == ok
        )


def test_printed_eq23_coefficient_isolator_mode2():
    """Erratum 5: the second row of R^T (eps f sin + w, 0) is r12, not r21 as printed."""
    ref = Ref("isolator", ISOLATOR, 2)
    good = av.modal_equation("isolator", ISOLATOR, 2)
    bad = av.modal_equation("isolator", ISOLATOR, 2, printed=True)
    R, _ = av.modal_matrix("isolator", ISOLATOR)
    assert good.Fc == pytest.approx(ref.Fc, rel=1e-12)
    assert good.Wc == pytest.approx(ref.Wc, rel=1e-12)
    assert bad.Fc == R[1, 0]
    assert abs(bad.Fc - ref.Fc) > 1.0  # 2.404 vs 0.7603
    assert av.modal_equation("isolator", ISOLATOR, 1, printed=True) == av.modal_equation(
        "isolator", ISOLATOR, 1
    )


def test_printed_isolator_peak_d11_d13():
    """Errata 12, 13: the printed D.12 gives X1 = 1.273 m instead of 3.184 m; D.13 uses mode 2."""
    p = ISOLATOR
    for mode in (1, 2):
        ref = Ref("isolator", p, mode)
        good = av.characteristic_amplitudes("isolator", p, mode)
        bad = av.characteristic_amplitudes("isolator", p, mode, printed=True)
        assert good.A_max == pytest.approx(ref_peak(ref), rel=1e-8)
        assert abs(bad.A_max / ref_peak(ref) - 1) > 0.5
        assert bad.A_max < good.A_min1  # below the slip threshold: cannot be the peak
        if mode == 1:
            x_good = av.physical_amplitudes("isolator", p, 1, good.A_max)[0]
            x_bad = av.physical_amplitudes("isolator", p, 1, bad.A_max)[0]
            assert x_good == pytest.approx(3.1836, rel=1e-4)
            assert x_bad == pytest.approx(1.2729, rel=1e-4)
            other = av.characteristic_amplitudes("isolator", p, 2, printed=True)
            assert bad.A_min == max(other.A_min1, other.A_min2) != good.A_min
    # D.14/D.15 and Eq. (51) are correct as printed.
    assert av.rho_opt("isolator", p, 1, printed=True) == av.rho_opt("isolator", p, 1)


def test_printed_absorber_mode2_eqs_40_44():
    """Erratum 14: G2 < 0, so the printed Eq. (41) is the lower root and Eq. (44) is negative."""
    p = ABSORBER
    ref = Ref("absorber", p, 2)
    assert ref.Fc < 0
    good = av.characteristic_amplitudes("absorber", p, 2)
    bad = av.characteristic_amplitudes("absorber", p, 2, printed=True)
    assert good.A_max == pytest.approx(ref_peak(ref), rel=1e-8)
    assert bad.A_max == pytest.approx(good.A_min2, rel=1e-14)
    assert bad.A_max < good.A_min1
    assert av.rho_opt("absorber", p, 2, printed=True) == pytest.approx(
        -av.rho_opt("absorber", p, 2), rel=1e-14
    )
    assert av.rho_opt("absorber", p, 2) == pytest.approx(4.2436, rel=1e-4)
    # Mode 1 (G1 > 0): printed and corrected agree.
    assert av.characteristic_amplitudes("absorber", p, 1, printed=True) == av.characteristic_amplitudes(
        "absorber", p, 1
    )


@pytest.mark.parametrize(("model", "mode"), CASES)
def test_standard_form_eqs_25_26_d2_d3(model, mode):
    """Errata 6, 7, 10: the standard form is the modal oscillator in Van der Pol variables.

    Integrate q'' + eta_i^2 q = eps Fc f sin(eta tau) + Wc w with a smooth stand-in
    w = eps kappa r q directly, and the standard form in (A, psi, phi); compare q = A sin(phi).
    The printed forms (sign of the forcing, stray eps, cos for sin) do not reproduce q.
    """
    p = PARAMS[model]
    ref = Ref(model, p, mode)
    eta = ref.eta - 0.02
    k_w = ref.kap * ref.r

    def direct(t, y):
        return [y[1], -(ref.eta**2) * y[0] + ref.f * ref.Fc * math.sin(eta * t) + ref.Wc * k_w * y[0]]

    q0 = 1.0
    t_end = 30.0
    sol = solve_ivp(direct, (0, t_end), [q0, 0.0], rtol=1e-11, atol=1e-13, dense_output=True)
    q_end = sol.y[0, -1]
    out = {}
    for printed in (False, True):

        def sf(t, y, printed=printed):
            A, psi, phi = y
            return av.standard_form_rhs(
                model, p, mode, A, psi, phi, k_w * A * math.sin(phi), eta, printed=printed
            )

        # q = A sin(phi), q' = A eta_i cos(phi): (1, 0) -> A = 1, phi = pi/2, psi = phi - eta 0.
        s = solve_ivp(sf, (0, t_end), [q0, math.pi / 2, math.pi / 2], rtol=1e-11, atol=1e-13)
        out[printed] = s.y[0, -1] * math.sin(s.y[2, -1])
    assert out[False] == pytest.approx(q_end, abs=1e-7)
    assert abs(out[True] - q_end) > 1e-3


# ------------------------------------------------------------------------------------------
# Stability of the fixed points
# ------------------------------------------------------------------------------------------


@pytest.mark.parametrize(("model", "mode"), CASES)
def test_jacobian_matches_finite_differences(model, mode):
    p = PARAMS[model]
    eq = av.modal_equation(model, p, mode)
    A = 1.7 * av.characteristic_amplitudes(model, p, mode).A_min1
    psi, eta = -1.2, eq.eta_i - 0.001
    J = av.averaged_jacobian(model, p, mode, A, psi, eta)
    h = np.array([1e-6 * A, 1e-6])
    fd = np.empty((2, 2))
    for j in range(2):
        e = np.zeros(2)
        e[j] = h[j]
        up = np.array(av.averaged_rhs(model, p, mode, A + e[0], psi + e[1], eta))
        dn = np.array(av.averaged_rhs(model, p, mode, A - e[0], psi - e[1], eta))
        fd[:, j] = (up - dn) / (2 * h[j])
    np.testing.assert_allclose(J, fd, rtol=1e-6, atol=1e-9 * np.abs(J).max())


@pytest.mark.parametrize(("model", "mode"), CASES)
@pytest.mark.parametrize("r_factor", [1.0, 1.3, 0.5])
def test_slipping_fixed_points_are_stable(model, mode, r_factor):
    """Trace < 0 and det J = eps^2 (delta + zeta_sin + A zeta_sin'/2)^2 >= 0 at every slipping
    fixed point: the first-order model has no unstable periodic orbit (docs/averaging.md)."""
    p = dict(PARAMS[model])
    p["R"] *= r_factor  # 0.5: below R_min (unbounded resonance) except for the absorber's mode 2
    eq = av.modal_equation(model, p, mode)
    n = 0
    for eta in eq.eta_i + np.linspace(-0.004, 0.003, 15):
        for fp in av.fixed_points(model, p, mode, eta=eta):
            J = av.averaged_jacobian(model, p, mode, fp.A, fp.psi, eta)
            if not fp.slipping:
                assert fp.stability == "neutral"
                continue
            n += 1
            _, zs = av.zeta(model, p, mode, fp.A)
            h = 1e-6 * fp.A
            dzs = (av.zeta(model, p, mode, fp.A + h)[1] - av.zeta(model, p, mode, fp.A - h)[1]) / (2 * h)
            u = (eq.eta_i - eta) / 0.01 + zs
            assert np.linalg.det(J) / 0.01**2 == pytest.approx(
                float(u + fp.A * dzs / 2) ** 2, rel=1e-6, abs=1e-12
            )
            assert np.trace(J) < 0
            assert fp.stability == "stable"
    assert n > 3


@pytest.mark.parametrize(("model", "mode"), CASES)
def test_stability_agrees_with_simulation_of_averaged_flow(model, mode):
    """A perturbed slipping fixed point decays as expm(J t) predicts; a stick one circles (centre)."""
    p = PARAMS[model]
    eq = av.modal_equation(model, p, mode)
    amps = av.characteristic_amplitudes(model, p, mode)

    def flow(t, y, eta):
        return list(av.averaged_rhs(model, p, mode, y[0], y[1], eta))

    # Slipping fixed point near the peak.
    eta = eq.eta_i - 0.0005
    fp = next(f for f in av.fixed_points(model, p, mode, eta=eta) if f.slipping)
    assert fp.stability == "stable"
    J = av.averaged_jacobian(model, p, mode, fp.A, fp.psi, eta)
    decay = -max(fp.eigenvalues.real)
    t_end = 3.0 / decay
    d0 = np.array([1e-5 * fp.A, 1e-5])
    sol = solve_ivp(flow, (0, t_end), [fp.A + d0[0], fp.psi + d0[1]], args=(eta,), rtol=1e-12, atol=1e-15)
    d_end = sol.y[:, -1] - [fp.A, fp.psi]
    lin = scipy.linalg.expm(J * t_end) @ d0
    np.testing.assert_allclose(d_end, lin, rtol=0, atol=2e-3 * np.abs(d0).max())
    assert np.linalg.norm(d_end / [fp.A, 1]) < 0.1 * np.linalg.norm(d0 / [fp.A, 1])
    # Stick fixed point: the averaged stick flow is a centre; the distance in the plane
    # (A cos psi, A sin psi) is conserved.
    eta = eq.eta_i - 0.004
    fp = av.fixed_points(model, p, mode, eta=eta)[0]
    assert not fp.slipping
    assert fp.A < 0.8 * amps.A_min1
    assert fp.stability == "neutral"
    period = (
        2 * math.pi / abs(np.linalg.eigvals(av.averaged_jacobian(model, p, mode, fp.A, fp.psi, eta))[0].imag)
    )
    y0 = [fp.A * 1.05, fp.psi]
    sol = solve_ivp(flow, (0, 2.7 * period), y0, args=(eta,), rtol=1e-12, atol=1e-14, dense_output=True)
    assert sol.y[0].max() < amps.A_min1

    def xy(A, psi):
        return np.array([A * np.cos(psi), A * np.sin(psi)])

    centre = xy(fp.A, fp.psi)
    r = np.linalg.norm(xy(sol.y[0], sol.y[1]).T - centre, axis=1)
    np.testing.assert_allclose(r, r[0], rtol=1e-7)


# ------------------------------------------------------------------------------------------
# Curve shape and input checks
# ------------------------------------------------------------------------------------------


@pytest.mark.parametrize(("model", "mode"), CASES)
def test_frequency_response_curve_shape(model, mode):
    p = PARAMS[model]
    fr = av.frequency_response(model, p, mode)
    assert fr.A[-1] == fr.amplitudes.A_max
    assert fr.eta_lo[-1] == fr.eta_hi[-1]  # the branches meet at the peak
    assert np.all(fr.eta_lo <= fr.eta_hi)
    assert np.all(np.isfinite(fr.eta_lo))
    assert np.all(np.isfinite(fr.eta_hi))
    np.testing.assert_allclose(fr.Omega_lo, fr.eta_lo * math.sqrt(p["c1"] / p["m1"]))
    assert fr.slipping.any()
    assert (~fr.slipping).any()
    # Beyond A_max the radicand is negative: no point.
    beyond = av.frequency_response(model, p, mode, A=[1.01 * fr.amplitudes.A_max])
    assert np.isnan(beyond.eta_lo[0])
    assert beyond.stability_lo == ("none",)
    # Unbounded below rho_min: the curve runs to large A towards the slip frequency.
    low = dict(p, R=0.9 * av.breakaway_force(model, p, av.rho_min(model, p, mode)))
    fr = av.frequency_response(model, low, mode)
    assert math.isinf(fr.amplitudes.A_max)
    assert np.isfinite(fr.eta_lo[-1])


def test_bad_input():
    with pytest.raises(ValueError, match="mode"):
        av.modal_equation("absorber", ABSORBER, 3)
    with pytest.raises(ValueError, match="model"):
        av.nondimensional("damper", ABSORBER)
    with pytest.raises(ValueError, match="eps"):
        av.nondimensional("absorber", ABSORBER, eps=0.0)
    with pytest.raises(ValueError, match="missing"):
        av.frequency_response("isolator", {"m1": 1.0}, 1)
