"""Command line: `hybrid orbit` and `hybrid frc` (periodic orbits and frequency-response curves)."""

import csv
import json
import math
import re

import numpy as np
import pytest
from scipy.optimize import brentq

import hybrid
import hybrid_models
from hybrid import Exact, SolverOptions, periodic_orbit
from hybrid.cli import main
from hybrid_models.linear import limit_amplitude, stick_amplitudes, stick_eigenfrequencies


def run(argv, capsys):
    code = main(argv)
    out = capsys.readouterr()
    return code, out.out, out.err


ORBIT_KEYS = {
    "omega",
    "period",
    "amplitude",
    "half_peak_to_peak",
    "multipliers",
    "stable",
    "transitions_per_period",
    "mode_sequence",
    "mode_fractions",
    "converged",
    "residual",
    "parameters",
}


def test_orbit_pure_stick_matches_the_linear_closed_form(tmp_path, capsys):
    code, out, err = run(["orbit", "absorber", "--omega", "0.5", "--json", "--out", str(tmp_path)], capsys)
    assert code == 0, err
    d = json.loads(out)
    assert ORBIT_KEYS <= set(d)
    assert d["omega"] == 0.5
    assert d["parameters"]["Omega"] == 0.5
    assert d["parameters"]["R"] == 0.5
    assert d["converged"]
    assert d["transitions_per_period"] == 0
    assert d["mode_fractions"] == {"stick": 1.0}
    assert d["mode_sequence"] == ["stick"]
    assert math.isclose(d["period"], 2 * math.pi / 0.5, rel_tol=1e-12)
    a1, a2 = stick_amplitudes(hybrid_models.absorber().preset("standard", Omega=0.5))
    assert abs(d["amplitude"]["x1"] - abs(a1)) <= 1e-6 * abs(a1)
    assert abs(d["amplitude"]["x2"] - abs(a2)) <= 1e-6 * abs(a2)
    # undamped stuck response: every multiplier on the unit circle, marginally stable
    mu = np.array([complex(re_, im) for re_, im in d["multipliers"]])
    kinds = d["multiplier_kinds"]
    assert np.allclose(np.abs(mu[[k != "structural" for k in kinds]]), 1.0, atol=1e-6)
    assert d["stable"] is None
    assert d["stability"] == "neutral"
    rows = list(csv.reader((tmp_path / "orbit.csv").open()))
    assert rows[0][:3] == ["t [s]", "mode", "x1 [m]"]
    assert "H [N]" in rows[0]
    t = np.array([float(r[0]) for r in rows[1:]])
    assert math.isclose(t[-1] - t[0], d["period"], rel_tol=1e-12)
    assert (tmp_path / "orbit.png").stat().st_size > 0
    assert json.loads((tmp_path / "orbit.json").read_text())["converged"] is True


def test_orbit_stick_slip_at_the_first_resonance(tmp_path, capsys):
    """`hybrid orbit absorber --omega 0.854` (defaults: IDA, rtol 1e-8) against two independent routes.

    1. The exact integrator (SolverOptions(method=Exact()): matrix exponentials of the affine
       modes, guard roots of the exact flow; Newton to a residual of 1e-15) from the section the CLI
       reports. The CLI's orbit is accurate to about cond(I - M) x residual = 2.1e3 x 7.5e-10, i.e.
       1.6e-6 of the state: amplitudes to 2.5e-7 relative (measured 1.1e-7), switch times to 1e-6 s
       (measured 3.7e-7 s), multipliers to 1e-7 (measured 8e-9; they move with the state only at
       second order near a converged orbit).
    2. Energy over one period (E(T) = E(0)): the excitation's work W equals the friction's
       dissipation, and the latter is, without any quadrature, R times the element's total slip,
       2 R (max w - min w) for the element's extension w = x2 - u (constant while stuck, |H| = R
       while slipping forwards then backwards), read from orbit.csv. W to 5e-7 relative (measured
       2.2e-7, the quadrature's error at rtol 1e-8 plus the orbit's).
    The old checks (4 switches, 0 < stick fraction < 1, max |x1| > 1) were read off this output.
    """
    code, out, err = run(
        ["orbit", "absorber", "--omega", "0.854", "--json", "--no-plot", "--out", str(tmp_path)], capsys
    )
    assert code == 0, err
    d = json.loads(out)
    assert d["converged"]
    assert d["residual"] < 1e-8
    system = hybrid_models.absorber()
    p = system.preset("standard", Omega=0.854)
    assert d["parameters"] == p
    ex = periodic_orbit(
        system,
        p,
        d["x0"],
        d["mode0"],
        t0=d["t0"],
        options=SolverOptions(method=Exact()),
        settings=hybrid.ShootingOptions(newton=hybrid.NewtonOptions(tol=1e-12), transient_periods=0),
    )
    assert ex.converged, ex.message
    assert ex.residual <= 1e-12, ex.message
    assert d["mode_sequence"] == list(ex.mode_sequence)
    assert d["transitions_per_period"] == len(ex.switch_times)
    assert np.max(np.abs(np.array(d["switch_times"]) - ex.switch_times)) <= 1e-6
    for k in ("x1", "v1", "x2", "v2", "u"):
        assert abs(d["amplitude"][k] - ex.amplitude[k]) <= 2.5e-7 * ex.amplitude[k], k
    mu = np.array([complex(a, b) for a, b in d["multipliers"]])
    assert np.max(np.abs(np.sort_complex(mu) - np.sort_complex(ex.multipliers))) <= 1e-7
    assert d["stable"] is (ex.stability == "stable")
    assert d["stability"] == ex.stability
    assert max(d["multiplier_moduli"]) == pytest.approx(np.max(np.abs(ex.multipliers)), abs=1e-7)
    # the sequence stick, slip+, stick, slip-, stick: D = R (w_max - w_min) twice
    assert d["mode_sequence"] == ["stick", "slip+", "stick", "slip-", "stick"]
    rows = list(csv.DictReader((tmp_path / "orbit.csv").open()))
    w = np.array([float(r["x2 [m]"]) - float(r["u [m]"]) for r in rows])
    dissipated = 2 * p["R"] * (w.max() - w.min())
    assert abs(d["energy"]["input"] - dissipated) <= 5e-7 * dissipated
    assert abs(d["energy"]["dissipated"] - dissipated) <= 5e-7 * dissipated
    assert not (tmp_path / "orbit.png").exists()


def test_orbit_text_summary(tmp_path, capsys):
    """The printed amplitude of x1 and the multipliers of the pure-stick orbit at Omega = 0.5 against
    the closed forms: |A1| of Eq. (A.1) (printed to 9 significant digits; the orbit is right to ~1e-9,
    so 1e-8 relative), and the multipliers of the undamped stuck chain, exp(+-i w_k T) with its
    eigenfrequencies w_k and the family's 1 (printed to 9 decimals; IDA at rtol 1e-8 puts them 6.4e-8
    inside the unit circle: 2e-7)."""
    code, out, err = run(["orbit", "absorber", "--omega", "0.5", "--no-plot", "--out", str(tmp_path)], capsys)
    assert code == 0, err
    assert "stability: neutral" in out
    p = hybrid_models.absorber().preset("standard", Omega=0.5)
    a1 = abs(float(stick_amplitudes(p)[0]))
    (printed,) = re.findall(r"^\s+x1\s+(\S+)\s", out, re.MULTILINE)
    assert abs(float(printed) - a1) <= 1e-8 * a1, (printed, a1)
    mu = [
        complex(float(re_), float(im))
        for re_, im in re.findall(r"^\s+([+-]\d\.\d+) ([+-]\d\.\d+)i\s+\|mu\|", out, re.MULTILINE)
    ]
    T = 2 * math.pi / 0.5
    w1, w2 = stick_eigenfrequencies(p)
    ref = np.array([1.0, *np.exp([1j * w1 * T, -1j * w1 * T, 1j * w2 * T, -1j * w2 * T])])
    assert len(mu) == 5
    assert np.max(np.abs(np.sort_complex(np.array(mu)) - np.sort_complex(ref))) <= 2e-7
    assert "model `absorber`, preset `standard`" in err


@pytest.mark.slow
def test_orbit_without_bounded_solution_exits_1(tmp_path, capsys):
    # Coulomb oscillator forced at resonance with F/R = 5 > 4/pi: the response grows without bound.
    code, out, err = run(
        ["orbit", "coulomb", "--preset", "forced", "--omega", "1", "--json", "--out", str(tmp_path)], capsys
    )
    assert code == 1
    d = json.loads(out)
    assert d["converged"] is False
    assert "no bounded periodic orbit" in d["message"]
    assert "hybrid: no periodic orbit: " in err
    assert "Traceback" not in err
    assert not (tmp_path / "orbit.csv").exists()


BAD = [
    (["orbit", "absorber", "--omega", "0.5", "--set", "m1=0"], r"parameter `m1` .* must be > 0"),
    (["orbit", "absorber", "--omega", "0.5", "--set", "mass=1"], r"no parameter `mass`"),
    (["orbit", "absorber", "--omega", "0.5", "--preset", "fig9"], r"no preset `fig9`"),
    (["orbit", "absorber", "--omega", "0.5", "--mode0", "glide"], r"no mode `glide`"),
    (["orbit", "absorber", "--omega", "0.5", "--x0", "y=1"], r"unknown variable\(s\) y"),
    (["orbit", "damper9000", "--omega", "0.5"], r"unknown model `damper9000`"),
    (["frc", "absorber", "--omega-range", "1.2", "0.8"], r"needs A < B"),
    (["frc", "absorber", "--set", "R=-1"], r"parameter `R` .* must be >= 0"),
    (["frc", "coulomb", "--preset", "forced"], r"no natural frequency .*\(--omega-range A B\)"),
    # sample counts are capped before any run (issue 13): a period in memory, a run streamed to disk
    (
        ["orbit", "absorber", "--samples-per-period", "100001"],
        r"`--samples-per-period` is at most 100000, got 100001",
    ),
    (["simulate", "absorber", "--samples-per-period", "100001"], r"`--samples-per-period` is at most 100000"),
    (
        ["simulate", "absorber", "--periods", "1e8"],
        r"1e\+08 periods at 100 samples per period make more than 1000000000 samples, the most a run may write",
    ),
]


@pytest.mark.parametrize("argv,message", BAD)
def test_bad_input_one_line_exit_2(argv, message, tmp_path, capsys):
    code, out, err = run([*argv, "--out", str(tmp_path)], capsys)
    assert code == 2, err
    assert out == ""
    lines = err.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("hybrid: error: "), err
    assert re.search(message, lines[0]), lines[0]
    assert list(tmp_path.iterdir()) == []  # nothing integrated, nothing written


@pytest.mark.parametrize(
    "argv",
    [
        ["orbit", "absorber", "--omega", "0"],
        ["orbit", "absorber", "--omega", "0.5", "--transient", "-1"],
        ["orbit", "absorber", "--omega", "0.5", "--rtol", "0"],
        ["frc", "absorber", "--omega-range", "0.5", "nan"],
        ["frc", "absorber", "--omega-range", "0.5"],
    ],
)
def test_bad_option_values_exit_2(argv, capsys):
    with pytest.raises(SystemExit) as exc:
        main(argv)
    assert exc.value.code == 2
    assert "Traceback" not in capsys.readouterr().err


@pytest.mark.slow
def test_frc_small_range_through_the_end_of_a_stick_slip_band(tmp_path, capsys):
    # Upper end of the absorber's stick-slip band at the second resonance (about 6 s).
    code, out, err = run(
        ["frc", "absorber", "--omega-range", "1.1715", "1.1735", "--json", "--out", str(tmp_path)], capsys
    )
    assert code == 0, err
    d = json.loads(out)
    assert d["complete"]
    assert d["omega_range"] == [1.1715, 1.1735]
    assert d["gaps"] == []
    assert d["parameters"]["R"] == 0.5
    assert "Omega" not in d["parameters"]
    for name in ("frc.csv", "frc_special.csv", "frc_overlays.csv", "frc.png", "frc.json"):
        assert (tmp_path / name).stat().st_size > 0, name

    rows = list(csv.DictReader((tmp_path / "frc.csv").open()))
    cols = set(rows[0])
    assert {
        "branch",
        "Omega",
        "stability",
        "transitions_per_period",
        "fraction_stick",
        "fraction_slip+",
        "fraction_slip-",
        "mode_sequence",
    } <= cols
    assert {"max_abs_multiplier", "amplitude_x1", "amplitude_x2", "half_peak_to_peak_x1"} <= cols
    p = hybrid_models.absorber().preset("standard")
    w = np.array([float(r["Omega"]) for r in rows])
    n_sw = np.array([int(r["transitions_per_period"]) for r in rows])
    a1 = np.array([float(r["amplitude_x1"]) for r in rows])
    stuck = n_sw == 0
    assert stuck.any()
    assert (n_sw == 4).any()
    # stuck orbits are the linear stick response; stick-slip orbits lie above the limit A_L (Eq. 5)
    assert np.allclose(a1[stuck], np.abs(stick_amplitudes(p, w[stuck])[0]), rtol=1e-6)
    assert np.all(a1[~stuck] > limit_amplitude("absorber", p, w[~stuck]))
    assert {r["stability"] for r in rows if r["transitions_per_period"] == "0"} == {"neutral"}
    assert {r["stability"] for r in rows if r["transitions_per_period"] == "4"} == {"stable"}
    # slip stops where the stick curve falls below A_L, bracketed by the branch
    cross = brentq(
        lambda x: abs(float(stick_amplitudes(p, x)[0])) - float(limit_amplitude("absorber", p, x)),
        1.1715,
        1.1735,
    )
    last_slip, first_stick = w[~stuck].max(), w[stuck].min()
    assert last_slip < cross <= first_stick
    special = list(csv.DictReader((tmp_path / "frc_special.csv").open()))
    assert [s["kind"] for s in special] == ["mode-lost"]
    assert last_slip < float(special[0]["Omega"]) <= first_stick

    overlays = list(csv.DictReader((tmp_path / "frc_overlays.csv").open()))
    stick_col = "linear stick system (Eqs. A.1-A.2): x1"
    limit_col = "structural-change limit A_L (Eq. 5): x1"
    assert {"Omega", stick_col, limit_col} <= set(overlays[0])
    wo = np.array([float(r["Omega"]) for r in overlays])
    assert wo[0] == 1.1715
    assert wo[-1] == 1.1735
    assert np.allclose([float(r[limit_col]) for r in overlays], limit_amplitude("absorber", p, wo))
    # the linear references (issue 24): the engine's linearisation of the modes the model names,
    # against closed forms: stuck = Eqs. A.1-A.2; sliding = two masses joined by c2 and c3 in series
    stuck_a = np.abs(stick_amplitudes(p, wo))
    for i, x in enumerate(("x1", "x2")):
        got = np.array([float(r[f"linear: contact stuck: {x}"]) for r in overlays])
        assert np.max(np.abs(got / stuck_a[i] - 1)) < 1e-10
        assert np.allclose(
            got, [float(r[f"linear stick system (Eqs. A.1-A.2): {x}"]) for r in overlays], rtol=1e-10
        )
    c2s = p["c2"] * p["c3"] / (p["c2"] + p["c3"])
    K = np.array([[p["c1"] + c2s, -c2s], [-c2s, c2s]])
    M = np.diag([p["m1"], p["m2"]])
    slide = np.abs([np.linalg.solve(K - om**2 * M, [p["F"], 0.0]) for om in wo])
    for i, x in enumerate(("x1", "x2")):
        got = np.array([float(r[f"linear: contact sliding: {x}"]) for r in overlays])
        assert np.max(np.abs(got / slide[:, i] - 1)) < 1e-10
    assert d["linear_references"] == {"linear: contact stuck": "stick", "linear: contact sliding": "slip+"}
