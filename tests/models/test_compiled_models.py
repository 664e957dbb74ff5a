"""Exact derivatives of the shipped models: IDA Jacobians and flow Taylor series vs independent numbers."""

import numpy as np
import pytest
from scipy.integrate import solve_ivp

import hybrid_models
from hybrid.model.compiled import CompiledSystem


@pytest.fixture(params=["absorber", "isolator", "coulomb"])
def compiled(request):
    system = hybrid_models.BUILTIN[request.param]()
    preset = "forced" if request.param == "coulomb" else "standard"
    return CompiledSystem(system, system.preset(preset))


def test_jacobian_matches_central_differences_of_the_residual(compiled):
    rng = np.random.default_rng(7)
    n = len(compiled.names)
    for cm in compiled.modes:
        for _ in range(3):
            t = rng.uniform(0, 10)
            y = rng.normal(size=n)
            yp = rng.normal(size=n)
            cj = rng.uniform(0.5, 50)
            J = np.empty((n, n))
            cm.jacobian(t, y, cj, J)
            fd = np.empty((n, n))
            for j in range(n):
                h = 1e-6 * (1 + abs(y[j]))
                r1, r2 = np.empty(n), np.empty(n)
                e = np.zeros(n)
                e[j] = h
                # dF/dy + cj dF/dy' via the combined perturbation (y + e, y' + cj e)
                cm.residual(t, y + e, yp + cj * e, r1)
                cm.residual(t, y - e, yp - cj * e, r2)
                fd[:, j] = (r1 - r2) / (2 * h)
            assert np.allclose(J, fd, rtol=1e-7, atol=1e-7 * (1 + cj)), (cm.name, J - fd)


def test_taylor_series_of_the_flow_matches_a_tight_integration(compiled):
    # Coefficients of the Taylor series at a consistent point vs the flow integrated by
    # scipy (differential variables; slave variables re-solved along it).
    rng = np.random.default_rng(3)
    n = len(compiled.names)
    for cm in compiled.modes:
        y0 = cm.solve_algebraic(0.4, rng.normal(size=n))
        X = cm.taylor(0.4, y0, 4)
        d = cm.diff_idx

        def f(t, yd, d=d, cm=cm, y0=y0):
            y = y0.copy()
            y[d] = yd
            y = cm.solve_algebraic(t, y)
            return cm.rhs(t, y)[d]

        h = 1e-2
        sol = solve_ivp(f, (0.4, 0.4 + h), y0[d], rtol=1e-13, atol=1e-15, method="DOP853")
        taylor = sum(X[d, k] * h**k for k in range(5))
        assert np.allclose(sol.y[:, -1], taylor, rtol=0, atol=1e-10 * (1 + np.max(np.abs(y0)))), cm.name
        # first-order coefficients are the consistent derivatives (slave variables included)
        assert np.allclose(X[:, 1], cm.derivatives(0.4, y0), rtol=1e-12, atol=1e-14)
