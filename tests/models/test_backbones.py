"""EPMC backbones (issue 31): hybrid.backbone on the EPMC systems of networks (hybrid_models.epmc).

Each expected number comes from outside the library: the linear modes of scipy.linalg.eigh, a
mass-proportional damper's closed form, an independent half-period shooting of the Jenkins
oscillator (tests/models/jenkins_reference.py) and Masing's rule for the Iwan joint.
"""

from __future__ import annotations

import dataclasses
import json
import math
import re
import tomllib
from pathlib import Path

import numpy as np
import pytest
import scipy.linalg as sla
from jenkins_reference import describing_function, jenkins_epmc

import hybrid
import hybrid_models
from hybrid import IDA, Exact, SolverOptions
from hybrid_models.epmc import epmc_network
from hybrid_models.network_read import read_network

MODELS = Path(hybrid_models.__file__).parent
EXACT = SolverOptions(method=Exact())

CHAIN = """
[model]
format = "network"
name = "chain2"
[masses.x1]
mass = "m1"
velocity = "v1"
[masses.x2]
mass = "m2"
velocity = "v2"
[springs.k1]
between = ["ground", "x1"]
stiffness = "k1"
[springs.k12]
between = ["x1", "x2"]
stiffness = "k2"
[springs.k3]
between = ["x2", "ground"]
stiffness = 0.7
[parameters.m1]
domain = "positive"
[parameters.m2]
domain = "positive"
[parameters.k1]
[parameters.k2]
[parameters.alpha]
"""

DAMPED = """
[dampers.c1]
between = ["ground", "x1"]
coefficient = "alpha*m1"
[dampers.c2]
between = ["ground", "x2"]
coefficient = "alpha*m2"
"""

PARAMS = {"m1": 1.0, "m2": 2.0, "k1": 3.0, "k2": 1.5, "alpha": 0.0}


def _chain(tmp_path, text=CHAIN):
    path = tmp_path / "chain2.toml"
    path.write_text(text)
    return hybrid_models.epmc_system(path)


def _eig():
    M = np.diag([PARAMS["m1"], PARAMS["m2"]])
    k1, k2 = PARAMS["k1"], PARAMS["k2"]
    K = np.array([[k1 + k2, -k2], [-k2, k2 + 0.7]])
    lam, _ = sla.eigh(K, M)
    return np.sqrt(lam)


@pytest.mark.slow
@pytest.mark.parametrize("mode", [1, 2])
def test_conservative_backbone_is_the_linear_mode(tmp_path, mode):
    # issue 31: no friction, no damper: omega = the linear mode's (scipy.linalg.eigh), D = 0
    system = _chain(tmp_path)
    bb = hybrid.backbone(
        system, PARAMS, coordinate="x1", mode=mode, amplitudes=[0.01, 1.0, 30.0], options=EXACT
    )
    assert [p.amplitude for p in bb.points] == pytest.approx([0.01, 1.0, 30.0], rel=1e-12)
    w = _eig()[mode - 1]
    for p in bb.points:
        assert p.omega == pytest.approx(w, rel=1e-10)
        assert abs(p.damping_ratio) <= 1e-10
        assert abs(p.dissipated) <= 1e-10 * p.amplitude**2
    assert bb.linear_omega == pytest.approx(w, rel=1e-12)
    assert bb.events == []


@pytest.mark.slow
def test_mass_proportional_damper_gives_xi_alpha(tmp_path):
    # C = alpha M: the EPMC term cancels it exactly, xi = alpha, omega = the undamped mode's,
    # D = alpha / (2 omega); the energy the term puts in is what the dampers dissipate
    system = _chain(tmp_path, CHAIN + DAMPED)
    params = {**PARAMS, "alpha": 0.05}
    bb = hybrid.backbone(system, params, coordinate="x2", amplitudes=[0.5, 2.0], options=EXACT)
    w = _eig()[0]
    for p in bb.points:
        assert p.xi == pytest.approx(0.05, rel=1e-10)
        assert p.omega == pytest.approx(w, rel=1e-10)
        assert p.damping_ratio == pytest.approx(0.05 / (2 * w), rel=1e-10)
        assert p.dissipated > 0
        assert p.dissipated == pytest.approx(p.energy_input, rel=1e-9)


JENKINS = {"m": 1.0, "k": 1.0, "kt": 1.0, "Fs": 0.1}
#: From just above first slip (a = Fs/kt = 0.1) to 50 Fs/kt.
JENKINS_AMPLITUDES = [0.1001, 0.101, 0.12, 0.15, 0.2, 0.3, 0.5, 0.8, 1.0, 2.0, 3.0, 5.0]


@pytest.fixture(scope="module")
def jenkins_exact():
    system = hybrid_models.epmc_system(MODELS / "jenkins_oscillator.toml")
    return hybrid.backbone(system, JENKINS, coordinate="x", amplitudes=JENKINS_AMPLITUDES, options=EXACT)


@pytest.mark.slow
def test_jenkins_backbone_against_independent_shooting(jenkins_exact):
    # issue 31 (must show): omega(a), D(a) against a half-period shooting written in the test
    # (expm flows, MINPACK), to 1e-9 on the exact integrator
    bb = jenkins_exact
    assert [p.amplitude for p in bb.points] == pytest.approx(JENKINS_AMPLITUDES, rel=1e-12)
    guess = None
    for p in bb.points:
        w, xi, guess = jenkins_epmc(p.amplitude, guess=guess)
        assert p.omega == pytest.approx(w, rel=1e-9)
        assert p.xi == pytest.approx(xi, rel=1e-9)
        assert p.damping_ratio == pytest.approx(xi / (2 * w), rel=1e-9)
        # Masing: the slider slides 2 (a - Fs/kt) each half period under the force Fs
        assert p.dissipated == pytest.approx(4 * 0.1 * (p.amplitude - 0.1), rel=1e-9)
        assert p.energy_input == pytest.approx(p.dissipated, rel=1e-9)
        assert p.fractions["slider.slip+"] == pytest.approx(p.fractions["slider.slip-"], rel=1e-9)


@pytest.mark.slow
def test_jenkins_first_slip_located_and_limits(jenkins_exact):
    bb = jenkins_exact
    first = next(e for e in bb.events if e.kind == "first-switch")
    assert first.status == "located"
    assert first.interval[0] <= 0.1 <= first.interval[1]
    assert first.interval[1] - first.interval[0] <= 1e-9
    assert bb.linear_omega == pytest.approx(math.sqrt(2.0), rel=1e-14)
    assert bb.references == pytest.approx(
        {"linear: all contacts stuck": math.sqrt(2.0), "linear: all contacts sliding": 1.0}, rel=1e-12
    )
    # omega falls from the stuck towards the slipped limit; D rises then falls
    w = bb.column("omega")
    assert np.all(np.diff(w) < 0) and 1.0 < w[-1] < w[0] < math.sqrt(2.0)
    D = bb.column("damping_ratio")
    k = int(np.argmax(D))
    assert 0 < k < D.size - 1


@pytest.mark.slow
def test_jenkins_single_harmonic_is_only_approximate(jenkins_exact):
    # the describing function (one harmonic) errs on D by 1 to 2 % at its worst (near a = 5 Fs/kt),
    # on omega by less than 0.1 %, and on D by less than 0.2 % at 50 Fs/kt: what harmonic balance
    # with one harmonic misses (docs/backbones.md)
    err_w, err_D = [], []
    for p in jenkins_exact.points:
        w1, xi1 = describing_function(p.amplitude)
        err_w.append(abs(w1 / p.omega - 1))
        err_D.append(abs(xi1 / (2 * w1) / p.damping_ratio - 1))
    assert 0.01 < max(err_D) < 0.02
    assert max(err_w) < 1e-3
    assert err_D[-1] < 2e-3


@pytest.mark.slow
def test_jenkins_backbone_on_ida():
    # both integrators: IDA at rtol 1e-10 agrees with the independent shooting to 1e-6
    system = hybrid_models.epmc_system(MODELS / "jenkins_oscillator.toml")
    options = SolverOptions(method=IDA(rtol=1e-10, atol=1e-12))
    bb = hybrid.backbone(system, JENKINS, coordinate="x", amplitudes=[0.2, 1.0], options=options)
    assert len(bb.points) == 2
    for p in bb.points:
        w, xi, _ = jenkins_epmc(p.amplitude)
        assert p.omega == pytest.approx(w, rel=1e-6)
        assert p.damping_ratio == pytest.approx(xi / (2 * w), rel=1e-6)


def test_backbone_json_fields(tmp_path):
    system = _chain(tmp_path)
    bb = hybrid.backbone(system, PARAMS, coordinate="x1", amplitudes=[1.0], options=EXACT)
    data = json.loads(bb.to_json())
    p = data["points"][0]
    assert {"amplitude", "omega", "xi", "damping_ratio", "dissipated"} <= set(p)
    assert p["omega"] == pytest.approx(_eig()[0], rel=1e-10)
    # the first harmonic of x1 is its amplitude (a linear mode), time from its maximum
    c1, s1 = p["harmonics"]["x1"][1]
    assert c1 == pytest.approx(1.0, rel=1e-9) and abs(s1) < 1e-9


def test_backbone_bad_input(tmp_path):
    system = _chain(tmp_path)
    with pytest.raises(hybrid.InputError, match="one of them"):
        hybrid.backbone(system, PARAMS, coordinate="x1")
    with pytest.raises(hybrid.InputError, match="not a state variable"):
        hybrid.backbone(system, PARAMS, coordinate="nope", amplitudes=[1.0])
    with pytest.raises(hybrid.InputError, match="lo < hi"):
        hybrid.backbone(system, PARAMS, coordinate="x1", amplitude_range=(2.0, 1.0))
    with pytest.raises(hybrid.InputError, match="mode"):
        hybrid.backbone(system, PARAMS, coordinate="x1", mode=3, amplitudes=[1.0])
    forced = hybrid_models.iwan()
    with pytest.raises(hybrid.ModelError, match="forcing period"):
        hybrid.backbone(forced, forced.preset("standard"), coordinate="x", amplitudes=[1.0])


def _iwan(n: int):
    """models/iwan.toml with ``n`` elements, slip displacements R_i N/K from 0.1 to 1 m (as
    benchmarks/iwan_masing.py), as its EPMC system."""
    data = tomllib.loads((MODELS / "iwan.toml").read_text())
    data["cells"]["jenkins"]["count"] = n
    data["presets"]["standard"]["jenkins"]["R"] = {"linear": [0.1 / n, 1.0 / n]}
    system = hybrid_models.epmc_system(data)
    return system, system.preset("standard")


def masing(X: float, R: np.ndarray, n: int, K: float = 1.0) -> float:
    """Masing's rule: the energy the joint dissipates per period at amplitude X [J]."""
    return float(np.sum(4 * R * np.clip(X - R * n / K, 0.0, None)))


@pytest.mark.slow
def test_iwan_dissipation_follows_masing():
    # issue 31 (must show, with N = 10 here; benchmarks/backbones.py runs the file's 50): the
    # energy dissipated per period on the backbone is Masing's sum_i 4 R_i (X - R_i N/K); first
    # slip at the smallest R_i N/K = 0.1, every element slipping from the largest, 1.0
    n = 10
    system, params = _iwan(n)
    R = np.array([params[f"R_{i}"] for i in range(1, n + 1)])
    bb = hybrid.backbone(system, params, coordinate="x", amplitudes=[0.35, 1.5], options=EXACT)
    assert len(bb.points) == 2
    for p in bb.points:
        assert p.dissipated == pytest.approx(masing(p.amplitude, R, n), rel=1e-9)
        assert p.energy_input == pytest.approx(p.dissipated, rel=1e-9)
    first = next(e for e in bb.events if e.kind == "first-switch")
    full = next(e for e in bb.events if e.kind == "all-switched")
    assert first.status == full.status == "located"
    assert first.interval[0] <= 0.1 <= first.interval[1] and first.interval[1] - first.interval[0] < 1e-8
    assert full.interval[0] <= 1.0 <= full.interval[1] and full.interval[1] - full.interval[0] < 1e-8
    # the linear limits: all stuck sqrt((k0 + K)/m), all sliding sqrt(k0/m)
    assert bb.references == pytest.approx(
        {"linear: all contacts stuck": math.sqrt(1.5), "linear: all contacts sliding": math.sqrt(0.5)},
        rel=1e-12,
    )
    assert math.sqrt(0.5) < bb.points[-1].omega < bb.points[0].omega < math.sqrt(1.5)


def test_the_docs_table_is_the_independent_reference():
    # docs/backbones.md promises these points of the Jenkins backbone: they are the independent
    # shooting's (and test_jenkins_backbone_against_independent_shooting ties the library to it)
    text = (Path(__file__).resolve().parents[2] / "docs" / "backbones.md").read_text()
    table = text.split("<!-- jenkins-table -->")[1].split("<!-- /jenkins-table -->")[0]
    rows = re.findall(r"^\| ([\d.]+) \| ([\d.]+) \| ([\d.]+) \|$", table, re.M)
    assert len(rows) == 3
    for a, w_doc, D_doc in rows:
        w, xi, _ = jenkins_epmc(float(a))
        assert float(w_doc) == pytest.approx(w, rel=1e-9)
        assert float(D_doc) == pytest.approx(xi / (2 * w), rel=1e-9)


def test_backbone_stops_at_the_deadline_with_what_it_has():
    # a computation's deadline (hybrid.time_limit) ends the backbone with reason "budget", not an
    # exception; the points computed before are kept
    system = hybrid_models.epmc_system(MODELS / "jenkins_oscillator.toml")
    with hybrid.time_limit(1e-6):
        bb = hybrid.backbone(system, JENKINS, coordinate="x", amplitudes=[0.2, 5.0], options=EXACT)
    assert bb.status == "stopped" and bb.reason == "budget"
    assert "time" in bb.message


def test_epmc_refuses_a_network_part_it_does_not_cover():
    # a part of a network with a mass of another kind (a field added to Network later) would miss
    # its + xi M v term: refused by name rather than computed wrong (structures are covered since
    # issue 31: + xi v on their accelerations, tests/models/test_backbones_structures.py)
    net = read_network(tomllib.loads((MODELS / "jenkins_oscillator.toml").read_text()))
    wider = dataclasses.make_dataclass(
        "WiderNetwork",
        [("joints", dict, dataclasses.field(default_factory=dict))],
        bases=(type(net),),
        frozen=True,
    )
    extended = wider(**{f.name: getattr(net, f.name) for f in dataclasses.fields(net)}, joints={"j": 1})
    with pytest.raises(hybrid.ModelError, match="joints"):
        epmc_network(extended)
    assert epmc_network(net).forces == ()
