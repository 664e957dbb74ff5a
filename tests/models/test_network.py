"""Network files (issue 8): the derived automata against independent results.

* the network absorber, isolator and Coulomb oscillator against the hand-written mode-level files:
  the same switches (order, modes, times), trajectories and periodic orbits;
* a static friction level above the sliding level: a mass on a friction contact under a slowly
  rising force, against the closed form (break-away time, the sliding motion, the stop);
* an offset excitation: the per-period drift of a friction contact against its closed form, and the
  absorber's exact shift symmetry (its friction offset does not drift);
* a single mass with a sequential element: the stick-slip band found on the builder's model against
  the band derived by hand (docs/models.md).

Tolerances are stated at each assertion; the measured figures are printed at the end of the module
(run with ``-s``).
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest
from scipy.optimize import brentq

import hybrid
import hybrid_models
from hybrid import IDA, Exact, SolverOptions, load_system, periodic_orbit, simulate

MODEL_DIR = Path(hybrid_models.__file__).parent
TIGHT = SolverOptions(method=IDA(rtol=1e-10, atol=1e-12))
FIGURES: dict[str, float] = {}


@pytest.fixture(scope="module", autouse=True)
def _report():
    yield
    print("\nnetwork figures:")
    for k, v in FIGURES.items():
        print(f"  {k}: {v:.3g}")


def _record(key: str, value: float) -> float:
    FIGURES[key] = max(FIGURES.get(key, 0.0), float(value))
    return value


def _net(name: str):
    return load_system(MODEL_DIR / f"{name}.toml")


def _stick(*states: str) -> str:
    """The name of a network's mode: its own mode `motion`, then one state per friction element."""
    return "|".join(("motion", *(states or ("stick",))))


def _local(mode: str) -> str:
    """A network's mode name without its own mode (`motion|slip+` -> `slip+`): the hand-written name."""
    return mode.split("|", 1)[1]


def _columns(tr, names) -> np.ndarray:
    """The samples of the named variables (a network adds the slave variables f_NAME and vel_U)."""
    return np.column_stack([tr[n] for n in names])


def _hand_multipliers(hand_orbit, net_orbit) -> tuple[np.ndarray, np.ndarray]:
    """The network's Floquet multipliers without the zeros of its added slave variables (f_NAME,
    vel_U: projected out of the monodromy, as the hand-written u is in its slip modes), and the zeros
    dropped, sorted as the hand-written model's."""
    extra = len(net_orbit.multipliers) - len(hand_orbit.multipliers)
    by_size = np.asarray(net_orbit.multipliers)[np.argsort(np.abs(net_orbit.multipliers))]
    return np.sort_complex(by_size[extra:]), by_size[:extra]


# ----------------------------------------------------------------------------
# Network-built models against the hand-written ones
# ----------------------------------------------------------------------------
CASES = [
    ("absorber", "absorber_network", "fig3a", {}),
    ("absorber", "absorber_network", "fig3b", {}),
    ("isolator", "isolator_network", "fig4a", {}),
    ("isolator", "isolator_network", "fig4b", {}),
    ("coulomb", "coulomb_network", "forced", {}),
    ("coulomb", "coulomb_network", "free", {"x": 1.0}),
]


@pytest.mark.parametrize(("hand_name", "net_name", "preset", "start"), CASES)
def test_network_trajectory_equals_the_hand_written_model(hand_name, net_name, preset, start):
    hand, net = hybrid_models.BUILTIN[hand_name](), _net(net_name)
    # the hand-written variables, and the slave variables of the friction element (f_NAME, vel_U)
    added = [n for n in net.variable_names if n not in hand.variable_names]
    assert [n for n in net.variable_names if n not in added] == list(hand.variable_names)
    assert all(n.startswith(("f_", "vel_")) for n in added)
    # one own mode and the element's local modes: the hand-written modes
    assert net.mode_names == ("motion",)
    assert [c.mode_names for c in net.components] == [hand.mode_names]
    p = hand.preset(preset)
    T = 2 * math.pi / p["Omega"]
    x0 = {n: 0.0 for n in hand.variable_names} | start
    t_eval = np.linspace(0.0, 10 * T, 1001)
    a = simulate(hand, p, (0.0, 10 * T), x0, t_eval=t_eval, options=TIGHT)
    b = simulate(net, p, (0.0, 10 * T), x0, t_eval=t_eval, options=TIGHT)
    assert a.success, a.message
    assert b.success, b.message
    assert len(a.events) >= 10  # the runs stick and slip
    assert [(e.source, e.target) for e in a.events] == [
        (_local(e.source), _local(e.target)) for e in b.events
    ]
    dt = max(abs(e.t - f.t) for e, f in zip(a.events, b.events, strict=True))
    # switch times: 1e-7 s over ten periods of 7-9 s (rtol 1e-10)
    assert _record(f"{hand_name} switch time, largest difference [s]", dt) <= 1e-7
    scale = np.max(np.abs(a.y), axis=0)
    rel = np.max(np.abs(a.y - _columns(b, hand.variable_names)) / np.where(scale > 0, scale, 1.0))
    # states relative to their largest magnitude: 1e-7 (measured a few 1e-9)
    assert _record(f"{hand_name} trajectory, largest relative difference", rel) <= 1e-7
    d = np.max(np.abs(a["E"] - b["E"])) / np.max(np.abs(a["E"]))
    assert _record(f"{hand_name} mechanical energy E, largest relative difference", d) <= 1e-7


def test_network_friction_outputs_equal_the_hand_written_ones():
    """The element force and relative velocity of the absorber network are the paper's H and v_rel."""
    hand, net = hybrid_models.absorber(), _net("absorber_network")
    p = hand.preset("fig3a")
    T = 2 * math.pi / p["Omega"]
    x0 = {n: 0.0 for n in hand.variable_names}
    t_eval = np.linspace(0.0, 4 * T, 401)
    a = simulate(hand, p, (0.0, 4 * T), x0, t_eval=t_eval, options=TIGHT)
    b = simulate(net, p, (0.0, 4 * T), x0, t_eval=t_eval, options=TIGHT)
    for h, n in (("H", "f_H"), ("v_rel", "w_H"), ("D", "D"), ("W", "W")):
        d = np.max(np.abs(a[h] - b[n])) / np.max(np.abs(a[h]))
        assert _record("absorber outputs H, v_rel, W, D: largest relative difference", d) <= 1e-7, h


@pytest.mark.slow
@pytest.mark.parametrize(
    ("hand_name", "net_name", "preset"),
    [("absorber", "absorber_network", "fig3a"), ("isolator", "isolator_network", "fig4a")],
)
@pytest.mark.parametrize("integrator", ["exact", "ida"])
def test_network_periodic_orbit_equals_the_hand_written_one(hand_name, net_name, preset, integrator):
    """The two models' orbits agree to what each integrator resolves: the exact flows to rounding
    amplified by cond(I - M); IDA at rtol 1e-12 (at its default 1e-10 the two orbits differed by
    1.3e-7 on a machine whose BLAS rounds otherwise: each carries about 20 x cond x rtol)."""
    hand, net = hybrid_models.BUILTIN[hand_name](), _net(net_name)
    p = hand.preset(preset)
    if integrator == "exact":
        opts, tol, bound = SolverOptions(method=Exact()), 1e-12, 1e-9
    else:
        opts, tol, bound = SolverOptions(method=IDA(rtol=1e-12, atol=1e-14)), 1e-11, 1e-8
    a, b = (
        periodic_orbit(
            hand, p, options=opts, settings=hybrid.ShootingOptions(newton=hybrid.NewtonOptions(tol=tol))
        ),
        periodic_orbit(
            net, p, options=opts, settings=hybrid.ShootingOptions(newton=hybrid.NewtonOptions(tol=tol))
        ),
    )
    assert a.converged
    assert b.converged
    assert a.mode_sequence == tuple(_local(m) for m in b.mode_sequence)
    assert len(a.switch_times) >= 2
    dt = np.max(np.abs(a.switch_times - b.switch_times))
    assert _record(f"periodic orbit switch times ({integrator}), largest difference [s]", dt) <= bound
    scale = np.max(np.abs(a.trajectory.y), axis=0)
    yb = _columns(b.trajectory, hand.variable_names)
    rel = np.max(np.abs(a.trajectory.y - yb) / np.where(scale > 0, scale, 1.0))
    assert _record(f"periodic orbit states ({integrator}), largest relative difference", rel) <= bound
    mu, zeros = _hand_multipliers(a, b)
    dmu = np.max(np.abs(np.sort_complex(a.multipliers) - mu))
    assert _record(f"Floquet multipliers ({integrator}), largest difference", dmu) <= bound
    assert len(zeros) == 2  # f_H and vel_u
    assert np.max(np.abs(zeros)) <= bound


# ----------------------------------------------------------------------------
# Static level above the sliding level: closed form
# ----------------------------------------------------------------------------
def _sliding(p, t_b, x_b):
    """Velocity and position of a mass sliding forward from rest at t_b under F0 + F sin(Om t) - R."""
    m, R, F0, F, om = p["m"], p["R"], p["F0"], p["F"], p["Omega"]

    def v(t):
        return ((F0 - R) * (t - t_b) + F / om * (math.cos(om * t_b) - math.cos(om * t))) / m

    def x(t):
        s = t - t_b
        return (
            x_b
            + (
                (F0 - R) * s**2 / 2
                + F / om * (math.cos(om * t_b) * s - (math.sin(om * t) - math.sin(om * t_b)) / om)
            )
            / m
        )

    return v, x


def _stop_time(v, t_b, om):
    """First zero of the sliding velocity after t_b (it is positive just after)."""
    grid = t_b + np.linspace(1e-9, 2 * math.pi / om, 20001)
    vals = np.array([v(t) for t in grid])
    k = int(np.argmax(vals < 0))
    assert k > 0
    return brentq(v, grid[k - 1], grid[k], xtol=1e-14, rtol=1e-15)


def test_static_level_breakaway_and_sliding_against_the_closed_form():
    net = _net("friction_contact")
    p = net.preset("breakaway")  # F0 = 0, F = 0.6, R = 0.3 < Rs = 0.5, Omega = 0.5
    om, F, R, Rs = p["Omega"], p["F"], p["R"], p["Rs"]
    t_b = math.asin(Rs / F) / om  # sticks until the force reaches the static level
    v, x = _sliding(p, t_b, 0.0)
    t_s = _stop_time(v, t_b, om)
    assert abs(F * math.sin(om * t_s)) < Rs  # ... and sticks again when it stops
    t_b2 = (math.pi + math.asin(Rs / F)) / om  # breaks away backwards when F sin reaches -Rs
    assert t_s < t_b2
    t_eval = np.linspace(0.0, t_b2 - 1.0, 2001)
    tr = simulate(net, p, (0.0, t_b2 + 1.0), {"x": 0.0, "v": 0.0}, t_eval=t_eval, options=TIGHT)
    got = [(_local(e.source), _local(e.target)) for e in tr.events]
    assert got == [("stick", "slip+"), ("slip+", "stick"), ("stick", "slip-")]
    for e, exact in zip(tr.events, (t_b, t_s, t_b2), strict=True):
        _record("static level: event times vs closed form, largest difference [s]", abs(e.t - exact))
        assert abs(e.t - exact) <= 1e-8 * exact  # relative 1e-8
    # the motion: at rest, then sliding against R (not Rs), then at rest at x(t_s)
    exact_x = np.array([0.0 if t <= t_b else (x(t) if t <= t_s else x(t_s)) for t in t_eval])
    exact_v = np.array([v(t) if t_b < t <= t_s else 0.0 for t in t_eval])
    ex = np.max(np.abs(tr["x"] - exact_x)) / np.max(np.abs(exact_x))
    ev = np.max(np.abs(tr["v"] - exact_v)) / np.max(np.abs(exact_v))
    _record("static level: x and v vs closed form, largest relative difference", max(ex, ev))
    assert ex <= 1e-8
    assert ev <= 1e-8
    # with the static level equal to the sliding one it breaks away at R instead
    p2 = net.preset("breakaway", Rs=R)
    tr2 = simulate(net, p2, (0.0, t_b + 1.0), {"x": 0.0, "v": 0.0}, options=TIGHT)
    assert abs(tr2.events[0].t - math.asin(R / F) / om) <= 1e-8 * t_b


# ----------------------------------------------------------------------------
# Offset excitation: drift per period
# ----------------------------------------------------------------------------
def test_offset_excitation_drift_per_period_against_the_closed_form():
    net = _net("friction_contact")
    p = net.preset("drift")  # F0 = 0.2, F = 0.5, R = 0.3, Rs = 0.4: forward slips only
    om, F0, F, Rs = p["Omega"], p["F0"], p["F"], p["Rs"]
    T = 2 * math.pi / om
    assert F0 - F > -Rs  # never breaks away backwards
    t_b = math.asin((Rs - F0) / F) / om
    v, x = _sliding(p, t_b, 0.0)
    t_s = _stop_time(v, t_b, om)
    assert t_s < T + t_b
    assert abs(F0 + F * math.sin(om * t_s)) < Rs
    drift = x(t_s)  # the same slip every period: the force repeats and the mass starts from rest
    n = 6
    tr = simulate(net, p, (0.0, n * T), {"x": 0.0, "v": 0.0}, t_eval=np.arange(n + 1) * T, options=TIGHT)
    steps = np.diff(tr["x"])
    rel = np.max(np.abs(steps - drift)) / drift
    _record("offset drift per period vs closed form, largest relative difference", rel)
    FIGURES["offset drift per period (closed form) [m]"] = drift
    assert rel <= 1e-8
    assert len(tr.events) == 2 * n  # one break-away and one stop per period


def test_absorber_offset_shifts_the_chain_and_its_friction_offset_does_not_drift():
    """F0 on m1 only moves x1, u, x2 by F0/c1 (docs/models.md): the element's offset does not drift."""
    off, net = _net("absorber_offset"), _net("absorber_network")
    p = off.preset("standard")
    q = {k: v for k, v in p.items() if k != "F0"}
    shift = p["F0"] / p["c1"]
    T = 2 * math.pi / p["Omega"]
    t_eval = np.linspace(0.0, 10 * T, 1001)
    zero = {n: 0.0 for n in net.variable_names}
    a = simulate(
        off, p, (0.0, 10 * T), zero | {"x1": shift, "x2": shift, "u": shift}, t_eval=t_eval, options=TIGHT
    )
    b = simulate(net, q, (0.0, 10 * T), zero, t_eval=t_eval, options=TIGHT)
    assert len(a.events) > 10
    assert [(e.source, e.target) for e in a.events] == [(e.source, e.target) for e in b.events]
    dt = max(abs(e.t - f.t) for e, f in zip(a.events, b.events, strict=True))
    assert _record("absorber offset vs shifted zero-offset run: switch times [s]", dt) <= 1e-7
    for name in ("x1", "x2", "u"):
        d = np.max(np.abs(a[name] - shift - b[name])) / np.max(np.abs(b[name]))
        assert _record("absorber offset vs shifted zero-offset run: states, relative", d) <= 1e-7
    # hence its friction offset x2 - u does not drift: the periodic orbit is the shifted one
    orbit = periodic_orbit(off, p)
    assert orbit.converged
    y = orbit.trajectory
    mean_x1 = np.mean(y["x1"][:-1])
    ref = periodic_orbit(net, q)
    assert abs(mean_x1 - shift - np.mean(ref.trajectory["x1"][:-1])) <= 1e-6 * np.max(
        np.abs(ref.trajectory["x1"])
    )


# ----------------------------------------------------------------------------
# Single mass with a sequential element: the stick-slip band
# ----------------------------------------------------------------------------
def _band(p):
    """The band derived in docs/models.md: no orbit sticks throughout iff |c1 + c2 - m Om^2| <= c2 F / R."""
    m, c1, c2, R, F = p["m"], p["c1"], p["c2"], p["R"], p["F"]
    lo = math.sqrt((c1 + c2 - c2 * F / R) / m)
    hi = math.sqrt((c1 + c2 + c2 * F / R) / m)
    return lo, hi


def _slips_in_one_period(system, p, omega) -> bool:
    """Does the builder's model, started on the symmetric stuck orbit, break away within a period?"""
    q = dict(p, Omega=omega)
    a = q["F"] / (q["c1"] + q["c2"] - q["m"] * omega**2)  # stuck: x = a sin(Omega t), u = 0
    x0 = {"x": 0.0, "v": a * omega, "u": 0.0, "W": 0.0, "D": 0.0}
    tr = simulate(system, q, (0.0, 1.05 * 2 * math.pi / omega), x0, _stick(), options=TIGHT)
    return len(tr.events) > 0


@pytest.mark.slow
def test_sequential_element_stick_slip_band_against_the_hand_derivation():
    net = _net("sequential")
    p = net.preset("standard")
    lo, hi = _band(p)
    assert lo < p["Omega"] < hi
    found = []
    for inside, outside in ((1.01 * lo, 0.9 * lo), (0.99 * hi, 1.1 * hi)):
        assert _slips_in_one_period(net, p, inside)
        assert not _slips_in_one_period(net, p, outside)
        a, b = outside, inside
        for _ in range(24):  # bisection on the builder's model: 2**-24 of the bracket
            mid = 0.5 * (a + b)
            if _slips_in_one_period(net, p, mid):
                b = mid
            else:
                a = mid
        found.append(0.5 * (a + b))
    for edge, exact in zip(found, (lo, hi), strict=True):
        rel = abs(edge - exact) / exact
        _record("sequential band edges vs hand derivation, largest relative difference", rel)
        assert rel <= 1e-6  # the bisection resolves 0.1*edge/2**24 ~ 6e-9; the event tolerance less
    FIGURES["sequential band lower edge [rad/s]"] = found[0]
    FIGURES["sequential band upper edge [rad/s]"] = found[1]
    # the builder's periodic orbits: stuck throughout outside the band, sticking and slipping inside
    for omega, slips in ((0.97 * lo, False), (p["Omega"], True), (1.03 * hi, False)):
        orbit = periodic_orbit(net, dict(p, Omega=omega))
        assert orbit.converged
        assert (set(orbit.mode_sequence) != {_stick()}) == slips, (omega, orbit.mode_sequence)


# ----------------------------------------------------------------------------
# Derived dynamics of other topologies against closed forms
# ----------------------------------------------------------------------------
def _network(**tables) -> dict:
    params = tables.pop("params")
    return {
        "model": {"name": "probe", "format": "network"},
        "parameters": {p: {"domain": "positive"} for p in params},
        **tables,
    }


def test_damped_oscillator_without_friction_decays_as_the_closed_form():
    from hybrid import system_from_dict

    system = system_from_dict(
        _network(
            params=("m", "k", "c"),
            masses={"x": {"mass": "m", "velocity": "v"}},
            springs={"s": {"between": ["ground", "x"], "stiffness": "k"}},
            dampers={"d": {"between": ["x", "ground"], "coefficient": "c"}},
        )
    )
    assert system.mode_names == ("motion",)
    assert not system.components
    p = {"m": 2.0, "k": 3.0, "c": 0.4}
    w0 = math.sqrt(p["k"] / p["m"])
    zeta = p["c"] / (2 * math.sqrt(p["k"] * p["m"]))
    wd = w0 * math.sqrt(1 - zeta**2)
    t = np.linspace(0.0, 30.0, 601)
    exact = np.exp(-zeta * w0 * t) * (np.cos(wd * t) + zeta * w0 / wd * np.sin(wd * t))
    tr = simulate(system, p, (0.0, 30.0), {"x": 1.0, "v": 0.0, "W": 0.0, "D": 0.0}, t_eval=t, options=TIGHT)
    rel = np.max(np.abs(tr["x"] - exact))
    assert _record("damped oscillator vs closed form, largest difference [m] (x0 = 1 m)", rel) <= 1e-8
    # the damper's dissipation is the lost energy: D(t) = E(0) - E(t)
    assert np.max(np.abs(tr["D"] - (tr["E"][0] - tr["E"]))) <= 1e-8 * tr["E"][0]


def test_masses_glued_by_a_sticking_element_move_as_one_body():
    from hybrid import system_from_dict

    system = system_from_dict(
        _network(
            params=("m1", "m2", "k", "R"),
            masses={"a": {"mass": "m1"}, "b": {"mass": "m2"}},
            springs={"s": {"between": ["ground", "a"], "stiffness": "k"}},
            friction={"f": {"between": ["a", "b"], "sliding": "R"}},
        )
    )
    p = {"m1": 1.0, "m2": 3.0, "k": 2.0, "R": 10.0}
    w = math.sqrt(p["k"] / (p["m1"] + p["m2"]))
    t = np.linspace(0.0, 20.0, 401)
    x0 = 1.0
    state = {"a": x0, "v_a": 0.0, "b": x0, "v_b": 0.0, "W": 0.0, "D": 0.0}
    tr = simulate(system, p, (0.0, 20.0), state, _stick(), t_eval=t, options=TIGHT)
    assert not tr.events
    for name in ("a", "b"):  # 1e-7 of the 1 m amplitude (IDA's global error over 2.3 periods)
        d = np.max(np.abs(tr[name] - x0 * np.cos(w * t)))
        assert _record("glued masses vs closed form, largest difference [m] (x0 = 1 m)", d) <= 1e-7
    # the element pulls b along: f (on a) = -m2 * (acceleration of b) = k m2 a / (m1 + m2)
    f_exact = p["k"] * p["m2"] * x0 * np.cos(w * t) / (p["m1"] + p["m2"])
    assert np.max(np.abs(tr["f_f"] - f_exact)) <= 1e-7 * np.max(np.abs(f_exact))
    # with a level below the force it must carry at t = 0 (k m2 x0/(m1 + m2) = 1.5 N on a), it breaks
    # away at once, forwards: the spring pulls a back faster than the element can drag b (v_b > v_a)
    tr = simulate(system, dict(p, R=1.0), (0.0, 1.0), state, _stick(), options=TIGHT)
    assert tr.events[0].t == 0.0
    assert tr.events[0].target == _stick("slip+")
    assert tr["w_f"][-1] > 0
    assert tr.mode[-1] == _stick("slip+")


def test_mass_on_a_contact_with_a_moving_base_breaks_away_and_stops_as_the_closed_form():
    from hybrid import system_from_dict

    system = system_from_dict(
        _network(
            params=("m", "R", "Y", "Omega"),
            masses={"x": {"mass": "m", "velocity": "v"}},
            friction={"c": {"between": ["ground", "x"], "sliding": "R"}},
            base={"amplitude": "Y", "frequency": "Omega"},
        )
    )
    p = {"m": 1.0, "R": 0.5, "Y": 1.0, "Omega": 1.0}
    m, R, Y, om = p["m"], p["R"], p["Y"], p["Omega"]
    # stuck, the contact carries m * base acceleration: it slips when m Y Om^2 sin(Om t) reaches R
    t_b = math.asin(R / (m * Y * om**2)) / om
    # then the mass decelerates at R/m from the base's velocity until the base's velocity meets it
    v = lambda t: Y * om * math.cos(om * t_b) - R / m * (t - t_b)  # noqa: E731

    def gap(t):
        return v(t) - Y * om * math.cos(om * t)

    grid = np.linspace(t_b + 1e-6, t_b + 2 * math.pi / om, 2001)
    k = int(np.argmax(np.array([gap(s) for s in grid]) < 0))
    t_s = brentq(gap, grid[k - 1], grid[k], xtol=1e-14)
    state = {"x": 0.0, "v": Y * om, "W": 0.0, "D": 0.0}  # moving with the base at t = 0
    tr = simulate(system, p, (0.0, t_s + 0.5), state, _stick(), options=TIGHT)
    got = [(_local(e.source), _local(e.target)) for e in tr.events][:2]
    assert got == [("stick", "slip+"), ("slip+", "stick")]
    for e, exact in zip(tr.events[:2], (t_b, t_s), strict=True):
        assert _record("moving base: switch times vs closed form [s]", abs(e.t - exact)) <= 1e-8
    x_s = Y * math.sin(om * t_b) + Y * om * math.cos(om * t_b) * (t_s - t_b) - R / (2 * m) * (t_s - t_b) ** 2
    assert abs(tr.events[1].x_minus[0] - x_s) <= 1e-8
    # the energy balance holds with the base's work: W = D + change of E
    assert abs(tr["W"][-1] - tr["D"][-1] - (tr["E"][-1] - tr["E"][0])) <= 1e-8


def test_isolator_under_base_motion_with_a_stuck_element_is_the_linear_steady_state():
    net = _net("isolator_base")
    p = net.preset("standard", R=1e6, Omega=0.7)
    om, Y = p["Omega"], p["Y"]
    M = np.diag([p["m1"], p["m2"]])
    K = np.array([[p["c1"] + p["c2"], -p["c2"]], [-p["c2"], p["c2"]]])
    X = np.linalg.solve(K - om**2 * M, [p["c1"] * Y, 0.0])  # u = Y sin(Om t) drives m1 through c1
    T = 2 * math.pi / om
    t = np.linspace(0.0, 5 * T, 501)
    state = {"x1": 0.0, "v1": X[0] * om, "x2": 0.0, "v2": X[1] * om, "u": 0.0, "W": 0.0, "D": 0.0}
    tr = simulate(net, p, (0.0, 5 * T), state, _stick(), t_eval=t, options=TIGHT)
    assert not tr.events
    for name, amp in (("x1", X[0]), ("x2", X[1]), ("u", Y)):
        d = np.max(np.abs(tr[name] - amp * np.sin(om * t))) / abs(amp)
        assert _record("isolator under base motion, stuck: relative difference", d) <= 1e-8


@pytest.mark.parametrize(
    "name",
    ["sequential", "absorber_two_friction", "absorber_offset", "isolator_base", "friction_contact"],
)
def test_energy_balance_of_the_shipped_networks(name):
    net = _net(name)
    p = net.preset(next(iter(net.presets)))
    T = net.period_value(p)
    tr = simulate(
        net, p, (0.0, 10 * T), {n: 0.0 for n in net.variable_names}, samples_per_period=50, options=TIGHT
    )
    assert len(tr.events) >= 10
    residual = np.max(np.abs(tr["W"] - tr["D"] - (tr["E"] - tr["E"][0])))
    scale = np.max(np.abs(tr["W"])) + np.max(np.abs(tr["D"]))
    assert _record("energy balance W = D + dE, largest relative residual", residual / scale) <= 1e-7


def test_friction_between_two_massless_nodes_equals_the_springs_merged_in_series():
    """A chain spring c2 - friction R - spring c3 carries one force: it equals spring c2 c3/(c2 + c3) - R."""
    from hybrid import system_from_dict

    common = {
        "params": ("m", "c1", "c2", "c3", "cs", "R", "F", "Omega"),
        "masses": {"x": {"mass": "m", "velocity": "v"}},
        "forces": {"force": {"on": "x", "amplitude": "F", "frequency": "Omega"}},
    }
    chain = system_from_dict(
        _network(
            **common,
            nodes={"u1": {}, "u2": {}},
            springs={
                "k1": {"between": ["ground", "x"], "stiffness": "c1"},
                "k2": {"between": ["x", "u1"], "stiffness": "c2"},
                "k3": {"between": ["u2", "ground"], "stiffness": "c3"},
            },
            friction={"H": {"between": ["u1", "u2"], "sliding": "R"}},
        )
    )
    merged = system_from_dict(
        _network(
            **common,
            nodes={"u": {}},
            springs={
                "k1": {"between": ["ground", "x"], "stiffness": "c1"},
                "ks": {"between": ["x", "u"], "stiffness": "cs"},
            },
            friction={"H": {"between": ["u", "ground"], "sliding": "R"}},
        )
    )
    # while the element sticks u1 is the slave of the pair's balance and u2 keeps its offset to it
    assert chain.mode(_stick()).algebraic.keys() == {"u1", "vel_u1", "vel_u2", "f_H"}
    assert chain.mode(_stick()).derivatives["u2"] == "vel_u2"
    assert chain.mode(_stick("slip+")).algebraic.keys() == {"u1", "u2", "vel_u1", "vel_u2", "f_H"}
    p = {"m": 1.0, "c1": 1.0, "c2": 0.6, "c3": 1.5, "R": 0.2, "F": 0.3, "Omega": 1.1}
    p["cs"] = p["c2"] * p["c3"] / (p["c2"] + p["c3"])
    T = 2 * math.pi / p["Omega"]
    t = np.linspace(0.0, 10 * T, 1001)
    a = simulate(chain, p, (0.0, 10 * T), {n: 0.0 for n in chain.variable_names}, t_eval=t, options=TIGHT)
    b = simulate(merged, p, (0.0, 10 * T), {n: 0.0 for n in merged.variable_names}, t_eval=t, options=TIGHT)
    assert len(a.events) >= 10
    assert [(e.source, e.target) for e in a.events] == [(e.source, e.target) for e in b.events]
    dt = max(abs(e.t - f.t) for e, f in zip(a.events, b.events, strict=True))
    assert _record("friction between massless nodes vs merged springs: switch times [s]", dt) <= 1e-7
    for name in ("x", "v", "f_H", "w_H", "W", "D"):
        d = np.max(np.abs(a[name] - b[name])) / np.max(np.abs(b[name]))
        assert _record("friction between massless nodes vs merged springs: relative", d) <= 1e-7, name


def test_springs_in_series_through_massless_nodes_equal_one_spring():
    """x -c2- u1 -c4- u2 -]R[- ground equals x -cs- u -]R[- ground with cs = c2 c4/(c2 + c4): the coupled
    balances of u1, u2 and their velocities (slave variables vel_u1, vel_u2) against the merged spring."""
    from hybrid import system_from_dict

    common = {
        "params": ("m", "c1", "c2", "c4", "cs", "R", "F", "Omega"),
        "masses": {"x": {"mass": "m", "velocity": "v"}},
        "forces": {"force": {"on": "x", "amplitude": "F", "frequency": "Omega"}},
    }
    chain = system_from_dict(
        _network(
            **common,
            nodes={"u1": {}, "u2": {}},
            springs={
                "k1": {"between": ["ground", "x"], "stiffness": "c1"},
                "k2": {"between": ["x", "u1"], "stiffness": "c2"},
                "k4": {"between": ["u1", "u2"], "stiffness": "c4"},
            },
            friction={"H": {"between": ["u2", "ground"], "sliding": "R"}},
        )
    )
    merged = system_from_dict(
        _network(
            **common,
            nodes={"u": {}},
            springs={
                "k1": {"between": ["ground", "x"], "stiffness": "c1"},
                "ks": {"between": ["x", "u"], "stiffness": "cs"},
            },
            friction={"H": {"between": ["u", "ground"], "sliding": "R"}},
        )
    )
    assert chain.variable_names == ("x", "v", "u1", "u2", "vel_u1", "vel_u2", "f_H", "W", "D")
    p = {"m": 1.0, "c1": 1.0, "c2": 0.6, "c4": 1.5, "R": 0.2, "F": 0.3, "Omega": 1.1}
    p["cs"] = p["c2"] * p["c4"] / (p["c2"] + p["c4"])
    T = 2 * math.pi / p["Omega"]
    t = np.linspace(0.0, 10 * T, 1001)
    a = simulate(chain, p, (0.0, 10 * T), {n: 0.0 for n in chain.variable_names}, t_eval=t, options=TIGHT)
    b = simulate(merged, p, (0.0, 10 * T), {n: 0.0 for n in merged.variable_names}, t_eval=t, options=TIGHT)
    assert len(a.events) >= 10
    assert [(e.source, e.target) for e in a.events] == [(e.source, e.target) for e in b.events]
    dt = max(abs(e.t - f.t) for e, f in zip(a.events, b.events, strict=True))
    assert _record("springs in series through nodes vs one spring: switch times [s]", dt) <= 1e-7
    for name in ("x", "v", "f_H", "w_H", "W", "D"):
        d = np.max(np.abs(a[name] - b[name])) / np.max(np.abs(b[name]))
        assert _record("springs in series through nodes vs one spring: relative", d) <= 1e-7, name
    # the slave velocity of the node next to the contact is the contact's sliding velocity
    assert np.max(np.abs(a["vel_u2"] + a["w_H"])) <= 1e-12 * np.max(np.abs(a["w_H"]))


def test_a_node_between_two_friction_elements_is_refused_naming_the_node_and_why():
    """ground -[R1 || c3]- u1 -[R2 || c4]- u2 -c2- x: the node u1 is held by two friction elements.
    Each element is a component owning its massless ends (composed, never enumerated), so a node
    whose equations would depend on two elements' states is refused before anything runs."""
    from hybrid import ModelError, system_from_dict

    data = _network(
        params=("m", "c1", "c2", "c3", "c4", "R", "R2", "F", "Omega"),
        masses={"x": {"mass": "m", "velocity": "v"}},
        nodes={"u1": {}, "u2": {}},
        springs={
            "k1": {"between": ["ground", "x"], "stiffness": "c1"},
            "k2": {"between": ["x", "u2"], "stiffness": "c2"},
            "k3": {"between": ["ground", "u1"], "stiffness": "c3"},
            "k4": {"between": ["u1", "u2"], "stiffness": "c4"},
        },
        friction={
            "H": {"between": ["ground", "u1"], "sliding": "R"},
            "B": {"between": ["u1", "u2"], "sliding": "R2"},
        },
        forces={"force": {"on": "x", "amplitude": "F", "frequency": "Omega"}},
    )
    with pytest.raises(
        ModelError,
        match=r"^\[nodes\.u1\] is held by 2 friction elements \(H, B\): not supported\. Each friction element "
        r"is a component of the system that owns its massless ends",
    ):
        system_from_dict(data)


def test_maxwell_element_through_a_massless_node_is_the_linear_flow():
    """x -k2- u -c- ground (a Maxwell element) beside k1: u is differential (u' = vel_u from the node's
    balance k2 (x - u) = c u'), against the matrix exponential of the 3-state linear system."""
    from scipy.linalg import expm

    from hybrid import system_from_dict

    system = system_from_dict(
        _network(
            params=("m", "k1", "k2", "c"),
            masses={"x": {"mass": "m", "velocity": "v"}},
            nodes={"u": {}},
            springs={
                "s1": {"between": ["ground", "x"], "stiffness": "k1"},
                "s2": {"between": ["x", "u"], "stiffness": "k2"},
            },
            dampers={"d": {"between": ["u", "ground"], "coefficient": "c"}},
        )
    )
    mode = system.mode("motion")
    assert set(mode.algebraic) == {"vel_u"}
    assert system.equations["u"] == "vel_u"
    p = {"m": 1.0, "k1": 1.0, "k2": 2.0, "c": 0.7}
    m, k1, k2, c = p["m"], p["k1"], p["k2"], p["c"]
    A = np.array([[0.0, 1.0, 0.0], [-(k1 + k2) / m, 0.0, k2 / m], [k2 / c, 0.0, -k2 / c]])  # (x, v, u)
    z0 = np.array([1.0, 0.0, 0.0])
    t = np.linspace(0.0, 20.0, 201)
    exact = np.array([expm(A * s) @ z0 for s in t])
    start = {"x": 1.0, "v": 0.0, "u": 0.0, "vel_u": 0.0, "W": 0.0, "D": 0.0}
    tr = simulate(system, p, (0.0, 20.0), start, t_eval=t, options=TIGHT)
    d = max(np.max(np.abs(tr[n] - exact[:, k])) for k, n in enumerate(("x", "v", "u")))
    assert _record("Maxwell element vs matrix exponential, largest difference (x0 = 1 m)", d) <= 1e-8
    assert np.max(np.abs(tr["vel_u"] - k2 * (exact[:, 0] - exact[:, 2]) / c)) <= 1e-7
    # the damper dissipates what the springs and the mass lose
    assert np.max(np.abs(tr["D"] - (tr["E"][0] - tr["E"]))) <= 1e-8 * tr["E"][0]


def test_damped_node_with_a_friction_contact_keeps_the_energy_balance():
    """x -k2- u, u -c- ground, u -]R[- ground: sticking holds u, slipping lets the damper set its speed."""
    from hybrid import system_from_dict

    system = system_from_dict(
        _network(
            params=("m", "k1", "k2", "c", "R", "F", "Omega"),
            masses={"x": {"mass": "m", "velocity": "v"}},
            nodes={"u": {}},
            springs={
                "s1": {"between": ["ground", "x"], "stiffness": "k1"},
                "s2": {"between": ["x", "u"], "stiffness": "k2"},
            },
            dampers={"d": {"between": ["u", "ground"], "coefficient": "c"}},
            friction={"H": {"between": ["ground", "u"], "sliding": "R"}},
            forces={"force": {"on": "x", "amplitude": "F", "frequency": "Omega"}},
        )
    )
    p = {"m": 1.0, "k1": 1.0, "k2": 2.0, "c": 0.7, "R": 0.3, "F": 0.5, "Omega": 1.3}
    T = 2 * math.pi / p["Omega"]
    tr = simulate(
        system,
        p,
        (0.0, 20 * T),
        dict.fromkeys(system.variable_names, 0.0),
        samples_per_period=50,
        options=TIGHT,
    )
    assert {_stick(s) for s in ("stick", "slip+", "slip-")} <= set(tr.mode)
    assert len(tr.events) >= 10
    # while it slides, the node's balance k2 (x - u) - c u' -+ R = 0 fixes u' = w_H
    slipping = tr.mode != _stick()
    balance = p["k2"] * (tr["x"] - tr["u"]) - p["c"] * tr["w_H"] - tr["f_H"]
    assert np.max(np.abs(balance[slipping])) <= 1e-9
    residual = np.max(np.abs(tr["W"] - tr["D"] - (tr["E"] - tr["E"][0])))
    assert (
        _record("energy balance W = D + dE, largest relative residual", residual / np.max(np.abs(tr["W"])))
        <= 1e-7
    )
