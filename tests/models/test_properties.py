"""Property tests over random parameters of the shipped models (issue 10, item 3).

For random valid parameters of the absorber, the isolator and the Coulomb oscillator (each drawn
within its domain and a physical range around the paper's values), a short simulation from rest
and a periodic orbit:

* never raise: a run that cannot finish returns ``success=False`` with a message (a documented
  status), an orbit not found returns ``converged=False`` with a message;
* satisfy the energy balance of the model's ``[energy]`` table, input work = dissipated energy +
  change of mechanical energy, to 1e-6 of the energies involved (IDA at ``rtol`` 1e-10) or 1e-9
  (the exact integrator), over the run and over one period of the orbit.

Invalid values (outside a parameter's domain, non-finite, not numbers) are refused with a
``ValueError`` naming the parameter before any integration. Outcomes are counted with
``hypothesis.event`` (``pytest --hypothesis-show-statistics``).
"""

from __future__ import annotations

import math
import warnings
from collections import Counter

import numpy as np
import pytest
from hypothesis import HealthCheck, Phase, event, given, settings
from hypothesis import strategies as st

import hybrid
from hybrid import resolve_model
from hybrid.engine.io import trajectory_summary

#: Physical ranges drawn [SI]: around the paper's standard values (m1 = 1 kg, m2 = 0.1 kg,
#: c1 = 1 N/m, c2 = 0.1 N/m, c3 = 10 N/m, R = 0.5 N, F = 0.01 N), wide enough for stick, stick-slip
#: and slip; a range (lo, hi, "log") is drawn uniformly in log.
RANGES = {
    "absorber": {
        "m1": (0.5, 2.0, "log"),
        "m2": (0.02, 0.5, "log"),
        "c1": (0.5, 2.0, "log"),
        "c2": (0.02, 0.5, "log"),
        "c3": (0.01, 10.0, "log"),
        "R": (0.0, 0.5, "lin"),
        "F": (0.0, 0.2, "lin"),
        "Omega": (0.3, 2.0, "lin"),
    },
    "coulomb": {
        "m": (0.5, 2.0, "log"),
        "k": (0.5, 2.0, "log"),
        "R": (0.0, 1.0, "lin"),
        "F": (0.0, 1.0, "lin"),
        "Omega": (0.3, 2.0, "lin"),
    },
}
RANGES["isolator"] = RANGES["absorber"]
MODELS = {name: resolve_model(name) for name in RANGES}
TOLERANCE = {"ida": 1e-6, "exact": 1e-9}
#: Absolute floor of the balance [J]: 1000 x IDA's atol (energies of 1e-5 J are atol-limited: the
#: absorber stuck for 5 periods, W = 5.24e-5 J, balances to 3.9e-10 J on IDA at atol 1e-12, the
#: same before and after issues 29-33; a draw of the property restructured in issue 29 met it).
FLOOR = {"ida": 1e-9, "exact": 1e-14}
#: Derandomized (the same parameter sets on every run, so the counts reported are reproducible);
#: no shrinking (a failing set is printed as drawn: shrinking re-runs simulations for minutes).
PROPERTY = settings(
    deadline=None,
    suppress_health_check=[HealthCheck.too_slow],
    derandomize=True,
    phases=(Phase.explicit, Phase.generate),
)


def value(lo: float, hi: float, kind: str):
    if kind == "log":
        return st.floats(math.log(lo), math.log(hi)).map(math.exp)
    return st.floats(lo, hi)


def parameters(model: str):
    return st.fixed_dictionaries({k: value(*r) for k, r in RANGES[model].items()})


def options(integrator: str) -> hybrid.SolverOptions:
    if integrator == "ida":
        return hybrid.SolverOptions(method=hybrid.IDA(rtol=1e-10, atol=1e-12), max_wall_time=60.0)
    return hybrid.SolverOptions(method=hybrid.Exact(), max_wall_time=60.0)


def balance_ok(w: float, d: float, de: float, tol: float, floor: float = 1e-14) -> bool:
    """``|W - D - dE| <= tol * (|W| + |D| + |dE|) + floor`` [J]."""
    scale = abs(w) + abs(d) + abs(de)
    return abs(w - d - de) <= tol * scale + floor


#: The least fraction of the drawn cases that must reach the checks of a property (the others end
#: in a documented status): a property that no case reaches checks nothing (issue 29, item 4).
#: Measured (derandomized draws, at a load of 4 on 2 cores): the short simulations 25 of 25 per
#: model, the orbits 5 to 6 of 6. The draws follow the test's source (Hypothesis seeds from it), so
#: an edit draws other cases: half is far below both.
CHECKED_FRACTION = 0.5


def assert_checked(outcomes: Counter, what: str) -> None:
    """Fail unless at least :data:`CHECKED_FRACTION` of the cases run reached the checks."""
    run = sum(outcomes.values())
    assert run > 0
    assert outcomes["checked"] >= CHECKED_FRACTION * run, (
        f"only {outcomes['checked']} of {run} {what} reached the checks: {dict(outcomes)}"
    )


@pytest.mark.slow
@pytest.mark.parametrize("model", sorted(RANGES))
def test_short_simulation_never_crashes_and_balances_energy(model):
    system = MODELS[model]
    outcomes: Counter = Counter()

    @settings(PROPERTY, max_examples=25)
    @given(data=st.data())
    def case(data):
        p = data.draw(parameters(model), label="params")
        integrator = data.draw(st.sampled_from(["ida", "exact"]), label="integrator")
        params = system.parameter_values(p)
        t_end = 5.0 * system.period_value(params)
        x0 = {n: 0.0 for n in system.variable_names}
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            tr = hybrid.simulate(system, params, (0.0, t_end), x0, options=options(integrator), throw=False)
        if not tr.success:  # a documented stop: status and message, no exception
            event(f"{model} {integrator}: stopped ({tr.status.name})")
            outcomes["stopped"] += 1
            assert tr.message
            assert tr.status.name != "SUCCESS"
            return
        s = trajectory_summary(tr)
        assert np.isfinite(tr.y_final).all()
        w, d, de = s["input_work"], s["dissipated_energy"], s["mechanical_energy_change"]
        tol = TOLERANCE[integrator]
        late = [w_ for w_ in caught if "before it could be armed" in str(w_.message)]
        if late and not balance_ok(w, d, de, tol, FLOOR[integrator]):
            # The documented approximation (docs/engine.md): a guard found beyond zero at the end of
            # a step is taken there, with a RuntimeWarning; the balance is then as good as that step.
            event(f"{model} {integrator}: balance off after the late-crossing warning")
            outcomes["late crossing"] += 1
            return
        event(f"{model} {integrator}: finished, " + ("switching" if tr.n_transitions else "no switch"))
        assert d >= -tol * (abs(w) + abs(de)) - FLOOR[integrator], s  # friction only dissipates
        assert balance_ok(w, d, de, tol, FLOOR[integrator]), s
        outcomes["checked"] += 1

    case()
    assert_checked(outcomes, "simulations")


@pytest.mark.parametrize("model", sorted(RANGES))
def test_periodic_orbit_is_found_or_reported_and_balances_energy(model):
    system = MODELS[model]
    outcomes: Counter = Counter()

    @settings(PROPERTY, max_examples=6)
    @given(p=st.data())
    def case(p):
        params = system.parameter_values(p.draw(parameters(model), label="params"))
        o = hybrid.periodic_orbit(
            system, params, options=options("exact"), settings=hybrid.ShootingOptions(samples_per_period=64)
        )
        if not o.converged:
            event(f"{model}: orbit not found")
            outcomes["not found"] += 1
            assert o.message
            return
        event(f"{model}: orbit {o.stability}")
        e = o.energy
        floor = orbit_floor(system, o)
        assert balance_ok(e["input"], e["dissipated"], e.get("mechanical_change", 0.0), 1e-8, floor), e
        outcomes["checked"] += 1

    case()
    assert_checked(outcomes, "orbits")


def orbit_floor(system, o) -> float:
    """Absolute floor of an orbit's balance [J]: rounding of the energy stored, 1e-12 of its largest
    value on the orbit (plus 1e-14 J). Without friction nothing is exchanged over a period and the
    three terms are rounding of energies of that size (issue 29, item 4: a Coulomb oscillator with
    R = 1.5e-114 N stores 6.8 J and balances to 1.0e-14 J; the library reports no relative
    residual there)."""
    return 1e-14 + 1e-12 * o.amplitude[system.energy["mechanical"]]


def test_a_frictionless_orbit_balances_to_the_rounding_of_its_stored_energy():
    # The case drawn by the orbit property above: no friction to speak of, so the orbit is the
    # undamped linear one, amplitude F / |k - m Omega^2|; its balance is rounding of the energy stored.
    system = MODELS["coulomb"]
    p = {"F": 0.9217335083780087, "R": 1.5378809525635637e-114, "Omega": 1.4099662438729945}
    params = system.parameter_values({**p, "k": 1.6351763270450892, "m": 1.0})
    o = hybrid.periodic_orbit(
        system, params, options=options("exact"), settings=hybrid.ShootingOptions(samples_per_period=64)
    )
    assert o.converged, o.message
    x = params["F"] / abs(params["k"] - params["m"] * params["Omega"] ** 2)
    assert abs(o.amplitude["x"] - x) <= 1e-9 * x
    e = o.energy
    assert e["relative_residual"] is None  # nothing exchanged over a period
    assert balance_ok(e["input"], e["dissipated"], e["mechanical_change"], 1e-8, orbit_floor(system, o))


def test_the_checked_fraction_fails_a_property_that_no_case_reaches():
    with pytest.raises(AssertionError, match="only 0 of 6 orbits reached the checks"):
        assert_checked(Counter({"not found": 6}), "orbits")
    with pytest.raises(AssertionError, match="only 2 of 5"):
        assert_checked(Counter({"checked": 2, "stopped": 3}), "simulations")
    assert_checked(Counter({"checked": 3, "stopped": 3}), "simulations")


def invalid_values(domain: str):
    bad = [math.nan, math.inf, -math.inf, "abc", True, None]
    if domain == "positive":
        bad += [0.0, -1.0, -1e-300]
    elif domain == "nonnegative":
        bad += [-1.0, -1e-300]
    return st.sampled_from(bad)


@pytest.mark.parametrize("model", sorted(RANGES))
@settings(PROPERTY, max_examples=30)
@given(data=st.data())
def test_invalid_parameters_are_refused_with_a_message_before_any_run(model, data):
    system = MODELS[model]
    params = data.draw(parameters(model), label="params")
    par = data.draw(st.sampled_from(system.parameters), label="parameter")
    params[par.name] = data.draw(invalid_values(par.domain), label="value")
    event(f"{model}: {par.domain} parameter, {type(params[par.name]).__name__}")
    x0 = {n: 0.0 for n in system.variable_names}
    with pytest.raises(ValueError, match=rf"parameter `{par.name}`"):
        hybrid.simulate(system, params, (0.0, 1.0), x0)
    with pytest.raises(ValueError, match=rf"parameter `{par.name}`"):
        hybrid.periodic_orbit(system, params)


def test_a_guard_crossed_before_it_could_be_armed_is_located_and_the_energy_balances():
    # Found by the property test above (issue 10): the exact integrator on the Coulomb oscillator
    # with R = 0 from rest took its stick -> slip switches late (a guard that starts at zero, dips and
    # crosses back within one long step was logged at the step's end, docs/engine.md) and its
    # balance was off by 2.7 % of the input work. The crossing is now located (bisection from the last
    # point on the safe side, issue 12's fix). Issue 30: the exact flow finds the crossing itself, on
    # its polynomial over the step, and nothing is left to warn about. IDA balances too.
    system = MODELS["coulomb"]
    params = system.parameter_values({"m": 1.0, "k": 1.0, "R": 0.0, "F": 0.22326293276385695, "Omega": 0.3})
    t_end = 5.0 * system.period_value(params)
    x0 = {n: 0.0 for n in system.variable_names}
    with warnings.catch_warnings(record=True) as got:
        warnings.simplefilter("always")
        tr = hybrid.simulate(system, params, (0.0, t_end), x0, options=options("exact"), throw=False)
    assert not [w for w in got if "before it could be armed" in str(w.message)]
    s = trajectory_summary(tr)
    assert balance_ok(s["input_work"], s["dissipated_energy"], s["mechanical_energy_change"], 1e-10, 1e-14)
    tr = hybrid.simulate(system, params, (0.0, t_end), x0, options=options("ida"), throw=False)
    s = trajectory_summary(tr)
    assert balance_ok(s["input_work"], s["dissipated_energy"], s["mechanical_energy_change"], 1e-6, 1e-10)
