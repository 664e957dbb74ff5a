"""The linear references of a frequency response (issue 24): a mode linearised at rest by the engine,
its periodic response to the forcing, against closed forms."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

import hybrid
import hybrid_models
from hybrid import HybridSystem, InputError, Mode
from hybrid.model.linear import linear_response
from hybrid_models.linear import stick_amplitudes

ROOT = Path(__file__).resolve().parents[2]


def test_a_forced_oscillator_is_f_over_k_minus_m_omega_squared():
    osc = HybridSystem(
        name="osc",
        variables=["x", "v"],
        parameters=["m", "k", "F", "Omega"],
        equations={"x": "v", "v": "(F*sin(Omega*t) + 3 - k*x)/m"},  # a constant force: no oscillation
        modes=[Mode("free")],
        transitions=[],
        period="2*pi/Omega",
    )
    p = {"m": 2.0, "k": 8.0, "F": 0.5, "Omega": 1.0}
    w = np.array([0.5, 1.0, 1.9, 2.1, 3.0, 10.0])
    a = linear_response(osc, p, "free", "Omega", w)
    assert np.max(np.abs(a["x"] / (0.5 / np.abs(8.0 - 2.0 * w**2)) - 1)) < 1e-13
    assert np.max(np.abs(a["v"] / (w * 0.5 / np.abs(8.0 - 2.0 * w**2)) - 1)) < 1e-13


def test_the_absorber_stuck_is_appendix_a_and_its_slave_node_follows_x2():
    absorber = hybrid_models.absorber()
    p = absorber.preset("standard")
    w = np.linspace(0.6, 1.5, 901)
    a = linear_response(absorber, p, "stick", "Omega", w, ["x1", "x2", "u"])
    a1, a2 = np.abs(stick_amplitudes(p, w))
    assert np.max(np.abs(a["x1"] - a1)) < 1e-10 * np.max(a1)  # x1 vanishes at the antiresonance, 1 rad/s
    assert np.max(np.abs(a["x2"] / a2 - 1)) < 1e-10
    # u is a slave variable while stuck (u = x2 - offset): its oscillation is x2's
    assert np.max(np.abs(a["u"] / a["x2"] - 1)) < 1e-12


def _tmd():
    return hybrid.load_system(ROOT / "examples" / "tmd.toml")


def test_the_tutorial_damper_stuck_and_sliding_against_closed_forms():
    tmd = _tmd()
    q = tmd.preset("standard")
    m1, m2, k1, k2, F = (q[k] for k in ("m1", "m2", "k1", "k2", "F"))
    w = np.linspace(40.0, 80.0, 801)
    refs = hybrid.plot_hints(tmd)["linear_references"]
    # the network's modes are composed: its own mode `motion`, then the one contact's local mode
    assert refs == {
        "linear: all contacts stuck": "motion|stick",
        "linear: all contacts sliding": "motion|slip+",
    }
    stuck = linear_response(tmd, q, refs["linear: all contacts stuck"], "Omega", w)
    one = F / np.abs(k1 - (m1 + m2) * w**2)  # the two masses as one
    for x in ("x1", "x2"):
        assert np.max(np.abs(stuck[x] / one - 1)) < 1e-10
    slide = linear_response(tmd, q, refs["linear: all contacts sliding"], "Omega", w)
    det = (k1 + k2 - m1 * w**2) * (k2 - m2 * w**2) - k2**2  # the friction force R is constant: no oscillation
    x1, x2 = np.abs(F * (k2 - m2 * w**2) / det), np.abs(F * k2 / det)
    assert np.max(np.abs(slide["x1"] - x1)) < 1e-10 * np.max(x1)
    assert np.max(np.abs(slide["x2"] / x2 - 1)) < 1e-10


@pytest.mark.slow
def test_the_six_block_chain_sliding_is_the_six_dof_chain_and_stuck_is_rest():
    chain = hybrid.load_system(ROOT / "examples" / "chain6.toml")  # 729 modes
    q = chain.preset("standard")
    refs = hybrid.plot_hints(chain)["linear_references"]
    w = np.linspace(5.0, 25.0, 401)
    stuck = linear_response(chain, q, refs["linear: all contacts stuck"], "Omega", w)
    assert all(np.all(stuck[f"x{i}"] == 0.0) for i in range(1, 7))  # every block held by the floor
    slide = linear_response(chain, q, refs["linear: all contacts sliding"], "Omega", w)
    m, k, k0 = q["m"], q["k"], q["k0"]
    K = np.diag([k0 + 2 * k] * 6) - k * np.eye(6, k=1) - k * np.eye(6, k=-1)
    K[0, 0] -= k
    K[-1, -1] -= k
    f = np.array([q[f"F{i}"] for i in range(1, 7)])
    X = np.abs([np.linalg.solve(K - om**2 * m * np.eye(6), f) for om in w])
    for i in range(6):
        assert np.max(np.abs(slide[f"x{i + 1}"] - X[:, i])) < 1e-10 * np.max(X[:, i])


def test_bad_requests_say_what_is_wrong():
    tmd = _tmd()
    q = tmd.preset("standard")
    with pytest.raises(InputError, match="mode `glide` has 1 parts; a mode of this model names its own mode"):
        linear_response(tmd, q, "glide", "Omega", [50.0])
    with pytest.raises(InputError, match="component `H` has no mode `glide`; its modes: stick, slip"):
        linear_response(tmd, q, "motion|glide", "Omega", [50.0])
    with pytest.raises(InputError, match=r"`W` is not a state variable of mode `motion\|stick`"):
        linear_response(tmd, q, "motion|stick", "Omega", [50.0], ["W"])  # a quadrature
    with pytest.raises(InputError, match="declares no forcing period"):
        linear_response(hybrid_models.belt(), hybrid_models.belt().preset("standard"), "stick", "v_b", [1.0])


def test_a_reference_naming_no_mode_is_refused_when_the_model_is_built():
    with pytest.raises(hybrid.ModelError, match="`linear_references` must map labels to modes"):
        HybridSystem(
            name="osc",
            variables=["x", "v"],
            parameters=["k"],
            equations={"x": "v", "v": "-k*x"},
            modes=[Mode("free")],
            transitions=[],
            plot={"linear_references": {"stuck": "stick"}},
        )
