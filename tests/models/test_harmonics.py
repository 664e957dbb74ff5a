"""Forcing as a sum of harmonics of one base frequency (issue 24, item 7): network and mode-level
files, both integrators, the period from the base frequency; against independent solutions."""

from __future__ import annotations

import copy
import tomllib
from pathlib import Path

import numpy as np
import pytest

import hybrid
from hybrid import IDA, Exact, HybridSystem, Mode, ModelError, SolverOptions
from hybrid_models.network import build

ROOT = Path(__file__).resolve().parents[2]
EXACT = SolverOptions(method=Exact())
IDA_TIGHT = SolverOptions(method=IDA(rtol=1e-12, atol=1e-14))

#: Two masses on springs and dampers, the first driven by F0 + F1 sin(W t) + F2 sin(2 W t + phi2).
LINEAR = """
[model]
format = "network"
name = "lin2"
[masses.x1]
mass = "m1"
[masses.x2]
mass = "m2"
[springs.k1]
between = ["ground", "x1"]
stiffness = "k1"
[springs.k2]
between = ["x1", "x2"]
stiffness = "k2"
[dampers.c1]
between = ["ground", "x1"]
coefficient = "c1"
[dampers.c2]
between = ["x1", "x2"]
coefficient = "c2"
[forces.drive]
on = "x1"
frequency = "Omega"
offset = "F0"
harmonics = [ { amplitude = "F1" }, { amplitude = "F2", multiple = 2, phase = "phi2" } ]
[parameters]
m1 = { domain = "positive" }
m2 = { domain = "positive" }
k1 = { domain = "positive" }
k2 = { domain = "positive" }
c1 = { domain = "positive" }
c2 = { domain = "positive" }
F0 = {}
F1 = {}
F2 = {}
phi2 = {}
Omega = { domain = "positive" }
[presets.standard]
m1 = 1.0
m2 = 0.5
k1 = 4.0
k2 = 2.0
c1 = 0.05
c2 = 0.1
F0 = 0.3
F1 = 1.0
F2 = 0.6
phi2 = 0.7
Omega = 1.1
"""


@pytest.fixture(scope="module")
def linear(tmp_path_factory):
    path = tmp_path_factory.mktemp("harmonics") / "lin2.toml"
    path.write_text(LINEAR)
    return hybrid.load_system(path)


def _closed_form(p: dict, t: np.ndarray) -> np.ndarray:
    """x1, x2 of the periodic response: K^-1 F0 plus, per harmonic n, Im[(K - (nW)^2 M + i nW C)^-1 F e^{i(nWt + phi)}]."""
    M = np.diag([p["m1"], p["m2"]])
    K = np.array([[p["k1"] + p["k2"], -p["k2"]], [-p["k2"], p["k2"]]])
    C = np.array([[p["c1"] + p["c2"], -p["c2"]], [-p["c2"], p["c2"]]])
    x = np.tile(np.linalg.solve(K, [p["F0"], 0.0]), (t.size, 1))
    for n, F, phase in ((1, p["F1"], 0.0), (2, p["F2"], p["phi2"])):
        w = n * p["Omega"]
        X = np.linalg.solve(K - w**2 * M + 1j * w * C, [F, 0.0])
        x += np.imag(np.outer(np.exp(1j * (w * t + phase)), X))
    return x


def test_a_force_of_harmonics_is_one_definition_and_the_period_is_the_base_frequencys(linear):
    assert linear.definitions["drive"] == "F0 + F1*sin(Omega*t) + F2*sin(2*Omega*t + phi2)"
    assert linear.period == "2*pi/Omega"
    assert "F2*sin(2*Omega*t + phi2)" in hybrid_models_describe(LINEAR)


def hybrid_models_describe(text: str) -> str:
    from hybrid_models.network import describe

    return describe(tomllib.loads(text))


@pytest.mark.parametrize(
    ("options", "tol"),
    [(EXACT, 1e-12), pytest.param(IDA_TIGHT, 1e-9, marks=pytest.mark.slow)],
    ids=["exact", "ida"],
)
def test_the_periodic_orbit_is_the_linear_response_to_both_harmonics(linear, options, tol):
    p = linear.preset("standard")
    orbit = hybrid.periodic_orbit(linear, p, options=options)
    assert orbit.converged
    assert orbit.period == pytest.approx(2 * np.pi / p["Omega"], rel=1e-15)
    tr = orbit.trajectory
    got = tr.y[:, [tr.names.index("x1"), tr.names.index("x2")]]
    want = _closed_form(p, tr.t)
    assert np.max(np.abs(got - want)) / np.max(np.abs(want)) < tol  # measured: 2.6e-15 exact, 5.8e-12 IDA


def test_the_exact_flow_of_a_mode_level_model_with_harmonics_is_the_closed_form():
    """A mode-level model: x'' + c x' + k x = a + b sin(W t) + d cos(3 W t + phi), simulated from the
    periodic response's own state: it stays on it (the flow is exact)."""
    osc = HybridSystem(
        name="osc3",
        variables=["x", "v"],
        parameters=["k", "c", "a", "b", "d", "phi", "W"],
        equations={"x": "v", "v": "a + b*sin(W*t) + d*cos(3*W*t + phi) - c*v - k*x"},
        modes=[Mode("free")],
        transitions=[],
        period="2*pi/W",
    )
    p = {"k": 2.0, "c": 0.3, "a": 0.5, "b": 1.0, "d": 0.4, "phi": 0.2, "W": 0.7}

    def response(t):
        x = np.full_like(t, p["a"] / p["k"], dtype=complex)
        for n, amp, phase, f in ((1, p["b"], 0.0, np.sin), (3, p["d"], p["phi"], np.cos)):
            w = n * p["W"]
            H = 1.0 / (p["k"] - w**2 + 1j * p["c"] * w)
            e = np.exp(1j * (w * t + phase))
            x = x + amp * (H * e if f is np.cos else -1j * H * e)  # cos: Re, sin: Re of -i e^{i..}
        return x

    t = np.linspace(0.0, 3 * 2 * np.pi / p["W"], 301)
    z = response(t)
    w_factor = np.zeros_like(t, dtype=complex)
    for n, amp, phase, f in ((1, p["b"], 0.0, np.sin), (3, p["d"], p["phi"], np.cos)):
        w = n * p["W"]
        H = 1.0 / (p["k"] - w**2 + 1j * p["c"] * w)
        e = np.exp(1j * (w * t + phase))
        w_factor += amp * 1j * w * (H * e if f is np.cos else -1j * H * e)
    x, v = z.real, w_factor.real
    tr = hybrid.simulate(osc, p, (0.0, t[-1]), {"x": x[0], "v": v[0]}, "free", t_eval=t, options=EXACT)
    assert np.max(np.abs(tr["x"] - x)) < 1e-12 * np.max(np.abs(x))
    assert np.max(np.abs(tr["v"] - v)) < 1e-12 * np.max(np.abs(v))


@pytest.mark.slow
def test_a_friction_damper_with_two_harmonics_against_ida_and_a_long_run():
    """The tutorial's damper shaken at Omega and 2 Omega (examples/tmd_harmonics.toml): the exact
    orbit against IDA's at rtol 1e-12 (amplitudes) and against 300 periods run from rest (state)."""
    tmd = hybrid.load_system(ROOT / "examples" / "tmd_harmonics.toml")
    p = tmd.preset("standard", Omega=55.0)
    exact = hybrid.periodic_orbit(tmd, p, options=EXACT)
    ida = hybrid.periodic_orbit(tmd, p, options=IDA_TIGHT)
    assert exact.converged
    assert ida.converged
    # two reversals per period, each one switch through the stuck mode held for no time (issue 30;
    # the event log has both transitions of each)
    assert exact.transitions_per_period == ida.transitions_per_period == 2
    assert len(exact.trajectory.events) == len(ida.trajectory.events) == 4
    assert [m for a, b, m in exact.trajectory.mode_intervals() if b > a][:2] == list(exact.mode_sequence[:2])
    scale = max(exact.amplitude[x] for x in ("x1", "x2"))
    for x in ("x1", "x2"):
        assert abs(exact.amplitude[x] - ida.amplitude[x]) < 1e-9 * scale  # measured 6.2e-10
    run = hybrid.simulate(
        tmd,
        p,
        (0.0, exact.t0 + 300 * exact.period),
        {"x1": 0.0, "v_x1": 0.0, "x2": 0.0, "v_x2": 0.0},
        options=EXACT,
        samples_per_period=4,
    )
    names = list(tmd.variable_names)
    keys = ("x1", "v_x1", "x2", "v_x2")
    orbit_state = np.array([exact.x0[names.index(k)] for k in keys])
    run_state = np.array([run.final_values[k] for k in keys])
    assert np.max(np.abs(run_state - orbit_state)) < 1e-9 * np.max(np.abs(orbit_state))  # measured 3.5e-12


def _contact_chain(n: int) -> dict:
    """``n`` blocks in a chain of springs, each on a friction contact with the ground, the last
    driven by F sin(Omega t) + F2 sin(3 Omega t + phi2)."""
    names = ("m", "k", "R", "F", "F2", "Omega", "phi2")
    data = {
        "model": {"name": "contact_chain", "format": "network"},
        "masses": {},
        "springs": {},
        "friction": {},
        "forces": {
            "drive": {
                "on": f"x{n}",
                "frequency": "Omega",
                "harmonics": [{"amplitude": "F"}, {"amplitude": "F2", "multiple": 3, "phase": "phi2"}],
            }
        },
        "parameters": {q: ({"domain": "positive"} if q in ("m", "R") else {}) for q in names},
        "presets": {
            "standard": {"m": 1.0, "k": 100.0, "R": 0.3, "F": 2.0, "F2": 1.0, "Omega": 7.0, "phi2": 0.4}
        },
    }
    for i in range(1, n + 1):
        data["masses"][f"x{i}"] = {"mass": "m"}
        data["springs"][f"k{i}"] = {
            "between": ["ground" if i == 1 else f"x{i - 1}", f"x{i}"],
            "stiffness": "k",
        }
        data["friction"][f"H{i}"] = {"between": ["ground", f"x{i}"], "sliding": "R"}
    return data


@pytest.mark.parametrize("n", [2, 30], ids=["dense", "sparse"])
def test_a_composed_network_with_two_harmonics_on_the_exact_integrator(n):
    """A network's modes are composed from its parts (one component per contact) and assembled by
    hybrid/integrators/assembly.py, densely or (more than DENSE_LIMIT states) sparsely: both carry
    the pairs S_n, C_n of multiples 1 and 3; the exact run from rest against IDA's."""
    from hybrid.integrators.assembly import DENSE_LIMIT

    system = build(_contact_chain(n))
    assert system.composed
    assert (len(system.variable_names) + 3 > DENSE_LIMIT) == (n == 30)
    p = system.preset("standard")
    x0 = np.zeros(len(system.variable_names))
    runs = [
        hybrid.simulate(system, p, (0.0, 2.0), x0, options=o, samples_per_period=8)
        for o in (EXACT, SolverOptions(method=IDA(rtol=1e-11, atol=1e-13)))
    ]
    assert len(runs[0].events) == len(runs[1].events) > 10
    scale = np.max(np.abs(runs[1].y[:, : 2 * n]))
    assert np.max(np.abs(runs[0].y[-1] - runs[1].y[-1])) < 1e-7 * scale  # measured 2.7e-8 (sparse)


def test_one_harmonic_written_as_harmonics_is_the_amplitude_form():
    data = tomllib.loads((ROOT / "examples" / "tmd.toml").read_text())
    force = data["forces"]["F_exc"]
    alt = copy.deepcopy(data)
    alt["forces"]["F_exc"] = {
        "on": force["on"],
        "frequency": force["frequency"],
        "harmonics": [{"amplitude": "F"}],
    }
    assert dict(build(alt).definitions) == dict(build(data).definitions)


@pytest.mark.parametrize(
    ("harmonics", "match"),
    [
        ([], r"`harmonics` must be a list of 1 to 64 tables"),
        (
            [{"amplitude": "F", "multiple": 1.5}],
            r"`harmonics\[0\]` `multiple` must be an integer from 1 to 1000",
        ),
        ([{"amplitude": "F", "multiple": 0}], r"`multiple` must be an integer from 1 to 1000"),
        ([{"amplitude": "F"}, {"amplitude": "F", "multiple": 1}], r"the multiple 1 is given twice"),
        ([{"amplitude": "F", "order": 2}], r"`harmonics\[0\]`.*order"),
        ([{"amplitude": "G"}], r"`harmonics\[0\]` `amplitude`"),
    ],
)
def test_bad_harmonics_are_refused_naming_the_entry(harmonics, match):
    data = tomllib.loads((ROOT / "examples" / "tmd.toml").read_text())
    data["forces"]["F_exc"] = {"on": "x1", "frequency": "Omega", "harmonics": harmonics}
    with pytest.raises(ModelError, match=match):
        build(data)


def test_amplitude_and_harmonics_together_are_refused():
    data = tomllib.loads((ROOT / "examples" / "tmd.toml").read_text())
    data["forces"]["F_exc"]["harmonics"] = [{"amplitude": "F", "multiple": 2}]
    with pytest.raises(
        ModelError, match=r"give `amplitude` \(one harmonic\) or `harmonics` \(several\), not both"
    ):
        build(data)


def test_a_cells_force_of_harmonics_and_element_names_shared_with_parameters():
    """A cell's force may be a sum of harmonics (the copy's index and per-copy parameters substituted
    in amplitudes and phases), and a cell's elements may be named as a parameter (the cell's own
    `R`, the top-level `k`): element names have a namespace of their own in cells too."""
    text = (ROOT / "models" / "bk_chain.toml").read_text().replace("count = 20", "count = 3")
    text = text.replace(
        '[cells.block.forces.drive]\non = "x"\namplitude = "F"\nfrequency = "Omega"',
        '[cells.block.forces.drive]\non = "x"\nfrequency = "Omega"\n'
        'harmonics = [ { amplitude = "F" }, { amplitude = "F*i", multiple = 2, phase = "0.1*i" } ]',
    )
    text = text.replace("[cells.block.friction.contact]", "[cells.block.friction.R]")
    text = text.replace("[cells.block.springs.anchor]", "[cells.block.springs.k]")
    system = build(tomllib.loads(text))
    assert [c.name for c in system.components] == ["R_1", "R_2", "R_3"]
    assert system.definitions["drive_2"] == "F*sin(Omega*t) + (F*(2))*sin(2*Omega*t + (0.1*(2)))"
    twice = text.replace("[cells.block.springs.k]", "[cells.block.springs.R]")
    with pytest.raises(
        ModelError, match=r"\[cells\.block\.friction\.R\]: the name `R` is already \[springs\.R\] of the cell"
    ):
        build(tomllib.loads(twice))


@pytest.mark.slow
def test_a_reversal_through_a_mode_held_for_no_time_is_one_switch():
    """Issue 30, part 3: one contact forced by F sin(W t) + F2 sin(3 W t + phi2) reverses its slip
    four times per period without sticking (slip -> stick -> slip at one instant: the stick
    condition does not hold there) and sticks twice: 8 switches, not the 12 transitions of the
    event log; no warning. The monodromy (the composite switch's saltation computed directly)
    against central differences of the period map."""
    import warnings

    system = build(_contact_chain(1))
    p = system.preset("standard", F=2.0, F2=1.0, R=0.8, Omega=4.0, phi2=0.4)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        orbit = hybrid.periodic_orbit(system, p, options=EXACT)
    assert orbit.converged
    tr = orbit.trajectory
    assert len(tr.events) == 12
    # independent of how transitions are grouped: the phases of positive length over the period,
    # each closed by one switch
    phases = [m for a, b, m in tr.mode_intervals() if b > a]
    if phases[0] == phases[-1]:  # the section lies inside a phase
        phases.pop()
    assert orbit.transitions_per_period == len(orbit.switch_times) == len(phases) == 8
    assert list(orbit.mode_sequence[:-1]) == phases or list(orbit.mode_sequence) == phases
    reversals = [s for s in tr.switches if s.steps]
    assert len(reversals) == 4
    for s in reversals:
        a, b = s.steps
        assert {s.source, s.target} == {"motion|slip+", "motion|slip-"}
        assert a.target == b.source == "motion|stick" and a.t == b.t == s.t
    names = list(system.variable_names)
    idx = [names.index("x1"), names.index("v_x1")]
    M = orbit.monodromy[np.ix_([0, 1], [0, 1])]
    assert orbit.state_names[:2] == ("x1", "v_x1")
    fd = np.empty((2, 2))
    for j, i in enumerate(idx):
        h = 1e-6 * max(1.0, abs(orbit.x0[i]))
        ends = []
        for sign in (1.0, -1.0):
            x0 = orbit.x0.copy()
            x0[i] += sign * h
            run = hybrid.simulate(
                system,
                p,
                (orbit.t0, orbit.t0 + orbit.period),
                dict(zip(names, x0.tolist(), strict=True)),
                orbit.mode0,
                options=EXACT,
            )
            ends.append(run.y_final[idx])
        fd[:, j] = (ends[0] - ends[1]) / (2 * h)
    assert np.max(np.abs(fd - M)) < 1e-7 * np.max(np.abs(M))  # measured 1.0e-8 (the differences' truncation)
