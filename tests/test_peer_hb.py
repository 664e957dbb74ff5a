"""The references of ``benchmarks/peer_hb.py`` (issue 31, item 3) against closed forms.

``benchmarks/hb_jenkins.py`` holds the benchmark's exact EPMC backbone of the Jenkins oscillator
(half-period shooting) and its minimal harmonic balance (AFT). Checked here:

* below first slip the backbone is the stuck linear mode, and just above it the shooting tends to
  the single-harmonic closed form (the orbit is harmonic in that limit);
* the shooting's xi balances the energy: ``xi m int v^2 dt = 4 Fs (a - Fs/kt)`` over a period (the
  slider's dissipation, a relation the shooting does not use), integrated by quadrature;
* the AFT Jenkins force of ``x = a cos(theta)`` against the describing function (Caughey 1960),
  and the AFT backbone at H = 1 against the closed-form single-harmonic backbone, to 1e-8;
* the AFT backbone at H = 15 against the exact shooting, to the truncation error of H = 15;
* the benchmark runs without pyHarm, saying so (slow).
"""

from __future__ import annotations

import importlib.util
import math
import sys
from pathlib import Path

import numpy as np
import pytest
from scipy.integrate import quad

ROOT = Path(__file__).resolve().parents[1]


def _load():
    name = "hb_jenkins"
    if name in sys.modules:
        return sys.modules[name]
    spec = importlib.util.spec_from_file_location(name, ROOT / "benchmarks" / "hb_jenkins.py")
    mod = importlib.util.module_from_spec(spec)
    sys.modules[name] = mod
    spec.loader.exec_module(mod)
    return mod


hb = _load()
OSC = hb.Jenkins(m=1.0, k=1.0, kt=2.0, Fs=0.5)  # first slip at a = 0.25 m


def test_backbone_below_first_slip_is_the_stuck_linear_mode():
    # issue 31: omega = sqrt((k + kt)/m), xi = 0 up to a = Fs/kt
    r = hb.exact_backbone([0.1, 0.25], OSC)
    assert np.allclose(r["omega"], math.sqrt(3.0), rtol=1e-15, atol=0)
    assert np.all(r["xi"] == 0.0) and np.all(r["dissipated"] == 0.0)


def test_backbone_just_above_first_slip_tends_to_the_single_harmonic_closed_form():
    # the shooting path (not the linear branch) at a = (1 + 1e-6) Fs/kt: the orbit is nearly harmonic
    a = 0.25 * (1.0 + 1e-6)
    ex = hb.exact_backbone([a], OSC)
    sh = hb.single_harmonic_backbone([a], OSC)
    assert ex["omega"][0] < math.sqrt(3.0)
    assert abs(ex["omega"][0] / sh["omega"][0] - 1.0) < 1e-12
    assert abs(ex["damping_ratio"][0] / sh["damping_ratio"][0] - 1.0) < 1e-8


@pytest.mark.parametrize("a", [0.3, 1.0, 12.5])
def test_shooting_xi_balances_the_slider_dissipation(a):
    # energy over a period: the negative damping feeds xi m int v^2 dt, the slider takes 4 Fs (a - Fs/kt)
    r = hb.exact_backbone([a], OSC)
    omega, xi = r["omega"][0], r["xi"][0]
    t1, s, x2, v2 = hb._half_period(OSC, a, omega, xi)
    assert abs(x2 + a) < 1e-12 * a and abs(v2) < 1e-12 * a * omega
    w2s, gs = (OSC.k + OSC.kt) / OSC.m, (OSC.kt * a - OSC.Fs) / OSC.m
    y1 = hb._flow(w2s, xi, gs, t1, (a, 0.0))
    stick = quad(lambda t: hb._flow(w2s, xi, gs, t, (a, 0.0))[1] ** 2, 0.0, t1, epsabs=0, epsrel=1e-13)[0]
    slide = quad(
        lambda t: hb._flow(OSC.k / OSC.m, xi, OSC.Fs / OSC.m, t, y1)[1] ** 2, 0.0, s, epsabs=0, epsrel=1e-13
    )[0]
    fed = 2.0 * xi * OSC.m * (stick + slide)
    assert fed == pytest.approx(4.0 * OSC.Fs * (a - OSC.Fs / OSC.kt), rel=1e-11)
    assert r["dissipated"][0] == pytest.approx(fed, rel=1e-11)


@pytest.mark.slow
def test_aft_at_one_harmonic_is_the_describing_function():
    # Caughey 1960: first harmonic of the Jenkins force under a cos(theta) is a (K cos - C sin); the
    # sampled play operator is exact at the samples (turning points on samples 0 and N/2), so the
    # AFT differs from it by the aliasing of a kinked signal only, O(1/N^2): below 1e-8 Fs at N = 2^16
    N = 2**16
    aft = hb.HarmonicBalance(OSC, 1, N)
    for a in (0.3, 1.0, 12.5):
        K, C = hb.describing_function(a, OSC.kt, OSC.Fs)
        F, _ = aft.jenkins(np.array([a, 0.0]))
        assert abs(F[0] - K * a) < 1e-8 * OSC.Fs and abs(F[1] + C * a) < 1e-8 * OSC.Fs
        p = aft.backbone_point(a)
        sh = hb.single_harmonic_backbone([a], OSC)
        assert p["omega"] == pytest.approx(sh["omega"][0], rel=1e-8)
        assert p["xi"] == pytest.approx(sh["xi"][0], rel=1e-8)


def test_aft_jacobian_is_the_derivative_of_the_sampled_play_operator():
    aft = hb.HarmonicBalance(OSC, 5, 512)
    X = np.array([1.0, 0.2, -0.05, 0.03, 0.01, -0.004])
    F, J = aft.jenkins(X)
    h = 1e-7
    for i in range(len(X)):
        d = np.zeros_like(X)
        d[i] = h
        fd = (aft.jenkins(X + d)[0] - aft.jenkins(X - d)[0]) / (2 * h)
        assert np.allclose(J[:, i], fd, rtol=0, atol=1e-6)


def test_aft_backbone_converges_to_the_exact_shooting():
    # two independent codes: harmonic balance at H = 15 (N = 1024) against the shooting; the
    # truncation error at H = 15 is below 2e-6 on omega and 4e-5 on D on this oscillator
    amps = [0.3, 1.0, 12.5]
    ex = hb.exact_backbone(amps, OSC)
    aft = hb.HarmonicBalance(OSC, 15, 1024)
    for i, a in enumerate(amps):
        p = aft.backbone_point(a)
        assert p["omega"] == pytest.approx(ex["omega"][i], rel=2e-6)
        assert p["damping_ratio"] == pytest.approx(ex["damping_ratio"][i], rel=4e-5)


@pytest.mark.slow
def test_benchmark_runs_and_skips_pyharm_cleanly_where_it_is_absent(tmp_path, monkeypatch, capsys):
    # issue 31: without pyHarm the benchmark says so and still runs its own harmonic balance
    spec = importlib.util.spec_from_file_location("peer_hb", ROOT / "benchmarks" / "peer_hb.py")
    peer = importlib.util.module_from_spec(spec)
    monkeypatch.setitem(sys.modules, "peer_hb", peer)  # its dataclasses look their module up
    monkeypatch.setattr(sys, "path", list(sys.path))  # it puts benchmarks/ on the path
    spec.loader.exec_module(peer)
    monkeypatch.setattr(peer, "pyharm_available", lambda: "pyHarm is not installed (test)")
    result = peer.main(["--hmax", "3", "--no-plot", "--out", str(tmp_path / "hb")])
    assert "pyHarm skipped: pyHarm is not installed (test)" in capsys.readouterr().out
    rows = result["backbone"]["rows"] + result["forced"]["jenkins_forced"]["rows"]
    assert [r["H"] for r in result["backbone"]["rows"]] == [1, 3]
    assert not any(k.startswith("pyharm") for r in rows for k in r)
    # H = 1 and 3 are far from the exact results (truncation), and closer at 3 than at 1
    bb = result["backbone"]["rows"]
    assert 1e-4 < bb[1]["aft_omega"] < bb[0]["aft_omega"] < 1e-2
    assert (tmp_path / "hb.json").exists() and (tmp_path / "hb.csv").exists()
