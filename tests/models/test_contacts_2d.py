"""The 2-D contact (normal load, lift-off, Jenkins slider) on one mass: models/contact_2d.toml (issue 32).

Every orbit the library finds is checked against an independent event-driven solution written here
(:class:`Reference`): its own piecewise-linear flows (``scipy.linalg.expm`` of each mode's matrix,
the forcing carried as harmonic-oscillator states), its own guards located by ``brentq``, its own
choice of the mode after closing, its own energy integrals (Gauss-Legendre on each step). Nothing
of ``hybrid`` is used in it.
"""

from __future__ import annotations

import copy
import json
import subprocess
import sys
import tomllib
import warnings
from functools import cache
from pathlib import Path

import numpy as np
import pytest
from scipy.linalg import expm
from scipy.optimize import brentq

import hybrid_models
from hybrid import IDA, Exact, ModelError, ShootingOptions, SolverOptions, periodic_orbit, system_from_dict
from hybrid.orbits.subharmonic import attractor_period

MODEL = Path(hybrid_models.__file__).parent / "contact_2d.toml"
EXACT = SolverOptions(method=Exact())
STATE = ("x", "vx", "y", "vy", "s_tip")
GL_X, GL_W = np.polynomial.legendre.leggauss(12)


# ----------------------------------------------------------------------------------------------
# The independent reference: z = [x, vx, y, vy, w, sin W t, cos W t, sin 2W t, cos 2W t, 1]
# ----------------------------------------------------------------------------------------------
class Reference:
    """Event-driven solution of the one-mass contact model, written from the equations alone."""

    def __init__(self, p: dict):
        self.p = p
        self.T = 2 * np.pi / p["Omega"]
        self.A = {m: self._matrix(m) for m in ("stick", "slip+", "slip-", "open")}
        self.h = self.T / 400
        self.E = {m: expm(A * self.h) for m, A in self.A.items()}
        self.Egl = {m: [expm(A * self.h * (1 + xg) / 2) for xg in GL_X] for m, A in self.A.items()}

    def _matrix(self, mode: str) -> np.ndarray:
        p = self.p
        m, kx, ky, c, N0, kn, kt, mu = (p[k] for k in ("m", "kx", "ky", "c", "N0", "kn", "kt", "mu"))
        W = p["Omega"]
        A = np.zeros((10, 10))
        A[0, 1] = A[2, 3] = 1.0
        A[1, 0], A[1, 1], A[1, 5] = -kx / m, -c / m, p["Fx"] / m
        A[3, 2], A[3, 3] = -ky / m, -c / m
        A[3, 5] = p["Fy1"] * np.cos(p["phy"]) / m
        A[3, 6] = p["Fy1"] * np.sin(p["phy"]) / m
        A[3, 7] = p["Fy2"] / m
        A[5, 6], A[6, 5], A[7, 8], A[8, 7] = W, -W, 2 * W, -2 * W
        if mode != "open":  # N = N0 - kn y on y
            A[3, 2] -= kn / m
            A[3, 9] += N0 / m
        if mode == "stick":  # T = kt (x - w) on x (as -T), w' = 0
            A[1, 0] -= kt / m
            A[1, 4] += kt / m
        elif mode == "open":
            A[4, 1] = 1.0  # w follows x
        else:
            sg = 1.0 if mode == "slip+" else -1.0  # T = sg mu N
            A[1, 9] -= sg * mu * N0 / m
            A[1, 2] += sg * mu * kn / m
            A[4, 1] = 1.0
            A[4, 3] = sg * mu * kn / kt
        return A

    # forces and guards ------------------------------------------------------------------------
    def N(self, z, mode):
        return 0.0 if mode == "open" else self.p["N0"] - self.p["kn"] * z[2]

    def T_(self, z, mode):
        p = self.p
        if mode == "open":
            return 0.0
        if mode == "stick":
            return p["kt"] * (z[0] - z[4])
        return (1.0 if mode == "slip+" else -1.0) * p["mu"] * self.N(z, mode)

    def wdot(self, z, mode):
        p = self.p
        if mode == "stick":
            return 0.0
        if mode == "open":
            return z[1]
        return z[1] + (1.0 if mode == "slip+" else -1.0) * p["mu"] * p["kn"] * z[3] / p["kt"]

    def guards(self, mode):
        """(function, direction, target) of each guard of ``mode``."""
        p = self.p
        load = lambda z: p["N0"] - p["kn"] * z[2]  # noqa: E731
        out = [(load, -1, "open")] if mode != "open" else [(load, 1, "close")]
        if mode == "stick":
            out += [
                (lambda z: p["kt"] * (z[0] - z[4]) - p["mu"] * load(z), 1, "slip+"),
                (lambda z: p["kt"] * (z[0] - z[4]) + p["mu"] * load(z), -1, "slip-"),
            ]
        elif mode != "open":
            out.append((lambda z: self.wdot(z, mode), -1 if mode == "slip+" else 1, "stick"))
        return out

    def consistent(self, z, mode):
        """The slider of a mode where it is a slave: w = x - T/kt."""
        z = z.copy()
        if mode != "stick":
            z[4] = z[0] - self.T_(z, mode) / self.p["kt"]
        return z

    def after_close(self, z):
        """Mode entered on closing (T = mu N = 0): by the rates of T -+ mu N in stick."""
        p = self.p
        up = p["kt"] * z[1] + p["mu"] * p["kn"] * z[3]  # (T - mu N)'
        down = p["kt"] * z[1] - p["mu"] * p["kn"] * z[3]  # (T + mu N)'
        return "slip+" if up > 0 else ("slip-" if down < 0 else "stick")

    def energy(self, z, mode):
        p = self.p
        T, N = self.T_(z, mode), self.N(z, mode)
        return (
            0.5 * p["m"] * (z[1] ** 2 + z[3] ** 2)
            + 0.5 * p["kx"] * z[0] ** 2
            + 0.5 * p["ky"] * z[2] ** 2
            + T**2 / (2 * p["kt"])
            + N**2 / (2 * p["kn"])
        )

    def powers(self, z, mode):
        """(input, slip, damper) powers [W]."""
        p = self.p
        fx = p["Fx"] * z[5]
        fy = p["Fy1"] * (np.cos(p["phy"]) * z[5] + np.sin(p["phy"]) * z[6]) + p["Fy2"] * z[7]
        return np.array(
            [fx * z[1] + fy * z[3], self.T_(z, mode) * self.wdot(z, mode), p["c"] * (z[1] ** 2 + z[3] ** 2)]
        )

    # the run ----------------------------------------------------------------------------------
    def run(self, t0: float, state: dict, mode: str, periods: int):
        """From ``t0`` over ``periods`` forcing periods: final state, mode, energies, times per mode."""
        W = self.p["Omega"]
        z = np.array([state[k] for k in STATE] + [np.sin(W * t0), np.cos(W * t0)])
        z = np.concatenate([z, [np.sin(2 * W * t0), np.cos(2 * W * t0), 1.0]])
        z = self.consistent(z, mode)
        t, t_end = t0, t0 + periods * self.T
        work = np.zeros(3)
        times = dict.fromkeys(self.A, 0.0)
        e0 = self.energy(z, mode)
        while t < t_end - 1e-13 * self.T:
            h = min(self.h, t_end - t)
            full = h == self.h
            A = self.A[mode]
            flow = (lambda tau, A=A, z=z: expm(A * tau) @ z) if not full else None
            z1 = self.E[mode] @ z if full else flow(h)
            hit = None
            for g, d, target in self.guards(mode):
                g0, g1 = g(z), g(z1)
                if (d > 0 and g0 < 0 <= g1) or (d < 0 and g0 > 0 >= g1):

                    def f(tau, g=g, A=A, z=z):
                        return g(expm(A * tau) @ z)

                    tau = brentq(f, 0.0, h, xtol=1e-15, rtol=1e-15, maxiter=200)
                    if hit is None or tau < hit[0]:
                        hit = (tau, target)
            step = h if hit is None else hit[0]
            # the energies over the step (Gauss-Legendre on the exact flow)
            if hit is None and full:
                zs = self.Egl[mode]
                pts = [E @ z for E in zs]
            else:
                pts = [expm(A * step * (1 + xg) / 2) @ z for xg in GL_X]
            work += 0.5 * step * sum(wg * self.powers(zz, mode) for wg, zz in zip(GL_W, pts, strict=True))
            times[mode] += step
            t += step
            if hit is None:
                z = z1
                continue
            z = expm(A * step) @ z
            target = hit[1]
            if target == "close":
                z[4] = z[0]  # the slider starts at the closing position
                target = self.after_close(z)
            mode = target
            z = self.consistent(z, mode)
        e1 = self.energy(z, mode)
        return {
            "state": dict(zip(STATE, z[:5], strict=True)),
            "mode": mode,
            "input": work[0],
            "slip": work[1],
            "damper": work[2],
            "dE": e1 - e0,
            "times": times,
        }


# ----------------------------------------------------------------------------------------------
@cache
def system():
    return system_from_dict(tomllib.loads(MODEL.read_text()))


REGIMES = {  # preset -> forcing periods of its stable steady orbit
    "constant": 1,
    "varying": 1,
    "liftoff": 1,
    "subharmonic": 2,
}


@cache
def exact_orbit(preset: str):
    S = system()
    n = REGIMES[preset]
    o = periodic_orbit(
        S, S.preset(preset), options=EXACT, settings=ShootingOptions(transient_periods=30, periods=n)
    )
    assert o.converged, o.message
    return o


def section(o) -> tuple[dict, str]:
    x0 = dict(zip(o.system.variable_names, o.x0, strict=True))
    return x0, o.mode0.split("|")[1]


def scale(o) -> float:
    return max(abs(o.state(k)) for k in STATE)


@pytest.mark.slow
@pytest.mark.parametrize("preset", list(REGIMES))
def test_exact_orbit_against_the_independent_solution(preset):
    # issue 32: state after N periods, energy balance, stick/slip/open fractions, all independent
    o = exact_orbit(preset)
    S = system()
    ref = Reference(S.preset(preset))
    x0, mode = section(o)
    r = ref.run(o.t0, x0, mode, o.periods)
    assert o.periods == REGIMES[preset]
    assert o.period == pytest.approx(o.periods * ref.T, rel=1e-14)
    # the library's orbit is periodic under the independent flow (Newton's tolerance 1e-9 relative)
    sc = scale(o)
    for k in STATE:
        assert abs(r["state"][k] - x0[k]) <= 1e-9 * sc, (k, r["state"][k], x0[k])
    # and the library's own run over the same span ends where the reference ends
    end = dict(zip(S.variable_names, o.trajectory.y[-1], strict=True))
    for k in STATE:
        assert abs(r["state"][k] - end[k]) <= 1e-11 * sc, (k, r["state"][k], end[k])
    assert r["mode"] == mode
    # energy: the work of the forces is dissipated by slip and the dampers (to the orbit's residual)
    assert abs(r["input"] - r["slip"] - r["damper"] - r["dE"]) <= 1e-12 * r["input"]
    assert abs(r["input"] - r["slip"] - r["damper"]) <= 1e-11 * r["input"]  # (measured <= 3e-13)
    assert r["slip"] > 0.01 * r["input"]
    assert o.energy["input"] == pytest.approx(r["input"], rel=1e-11)
    assert o.energy["dissipated"] == pytest.approx(r["slip"] + r["damper"], rel=1e-11)
    assert abs(o.energy["relative_residual"]) <= 1e-9
    # time fractions of the period in each local mode of the contact
    fr = o.local_fractions
    for m, t in r["times"].items():
        assert fr.get(f"tip.{m}", 0.0) == pytest.approx(t / o.period, abs=1e-11), m


@pytest.mark.slow
def test_the_regimes_are_what_their_names_say():
    # issue 32: constant N (no normal motion), varying N without opening, lift-off each period,
    # and a stable period-2 orbit whose period-1 orbit is unstable
    c, v, lo, sub = (exact_orbit(p) for p in REGIMES)
    S = system()
    p = S.preset("constant")
    assert c.half_peak_to_peak["N_tip"] <= 1e-10
    assert c.state("N_tip") == pytest.approx(p["N0"] * p["ky"] / (p["ky"] + p["kn"]), rel=1e-12)
    assert c.local_fractions.get("tip.open", 0.0) == 0.0
    assert v.half_peak_to_peak["N_tip"] > 0.1 and v.local_fractions.get("tip.open", 0.0) == 0.0
    assert 0.1 < lo.local_fractions["tip.open"] < 0.9
    for o in (c, v, lo, sub):
        assert o.stability == "stable"
        assert o.local_fractions.get("tip.slip+", 0) + o.local_fractions.get("tip.slip-", 0) > 0.01
    assert sub.periods == 2 and sub.local_fractions["tip.open"] > 0.1
    # period 2, not 1: the state after one forcing period is far from the section's
    ref = Reference(S.preset("subharmonic"))
    x0, mode = section(sub)
    half = ref.run(sub.t0, x0, mode, 1)["state"]
    assert max(abs(half[k] - x0[k]) for k in STATE) > 0.1 * scale(sub)
    one = periodic_orbit(
        S,
        S.preset("subharmonic"),
        sub.x0,
        sub.mode0,
        t0=sub.t0,
        options=EXACT,
        settings=ShootingOptions(transient_periods=0),
    )
    assert one.converged and one.stability == "unstable"
    assert max(abs(one.multipliers)) > 1.05


def fd_map(ref: Reference, o, h: float = 1e-6) -> np.ndarray:
    """Central differences of the independent period map on the section mode's differential states."""
    x0, mode = section(o)
    keys = STATE if mode == "stick" else STATE[:4]
    sc = scale(o)
    J = np.zeros((len(keys), len(keys)))
    for j, k in enumerate(keys):
        cols = []
        for sgn in (1, -1):
            x = dict(x0)
            x[k] += sgn * h * sc
            end = ref.run(o.t0, x, mode, o.periods)
            assert end["mode"] == mode
            cols.append(np.array([end["state"][q] for q in keys]))
        J[:, j] = (cols[0] - cols[1]) / (2 * h * sc)
    return J


@pytest.mark.slow
@pytest.mark.parametrize("preset", ["varying", "liftoff", "subharmonic"])
def test_multipliers_against_finite_differences(preset):
    # issue 32: the exact monodromy (saltation through open/close, stick/slip) against central
    # differences of the independent map over the orbit's N periods
    o = exact_orbit(preset)
    ref = Reference(system().preset(preset))
    lam = np.linalg.eigvals(fd_map(ref, o))
    mine = [z for z in o.multipliers if abs(z) > 1e-4]
    theirs = [z for z in lam if abs(z) > 1e-4]
    assert len(mine) == len(theirs), (mine, theirs)
    for z in mine:
        assert min(abs(z - w) for w in theirs) <= 1e-6, (z, theirs)


@pytest.mark.slow
@pytest.mark.parametrize("preset", list(REGIMES))
def test_ida_agrees_with_exact(preset):
    # issue 32: both integrators; IDA from the exact section converges to the same orbit
    o = exact_orbit(preset)
    S = system()
    i = periodic_orbit(
        S,
        S.preset(preset),
        o.x0,
        o.mode0,
        t0=o.t0,
        options=SolverOptions(method=IDA(rtol=1e-10, atol=1e-12)),
        settings=ShootingOptions(transient_periods=0, periods=o.periods),
    )
    assert i.converged, i.message
    sc = scale(o)
    for k in STATE:
        assert abs(i.state(k) - o.state(k)) <= 1e-6 * sc, k
    for m, f in o.local_fractions.items():
        assert i.local_fractions.get(m, 0.0) == pytest.approx(f, abs=1e-6)
    assert i.energy["input"] == pytest.approx(o.energy["input"], rel=1e-6)
    big = lambda o: sorted(abs(z) for z in o.multipliers if abs(z) > 1e-3)  # noqa: E731
    np.testing.assert_allclose(big(i), big(o), atol=1e-5)


@pytest.mark.slow
def test_the_transient_says_when_the_attractor_is_a_subharmonic():
    # issue 32: a transient that settles on a period-2 orbit is reported (field and notice); the
    # default transient (10 periods) has not settled, and the period-1 orbit found is unstable: the
    # run goes on 100 periods and says so
    S = system()
    for settings in (ShootingOptions(transient_periods=60), ShootingOptions()):
        with warnings.catch_warnings(record=True) as got:
            warnings.simplefilter("always")
            o = periodic_orbit(S, S.preset("subharmonic"), options=EXACT, settings=settings)
        assert o.stability == "unstable" and o.attractor_periods == 2
        assert any("orbit of 2 forcing periods" in str(w.message) for w in got)
        assert o.to_dict()["attractor_periods"] == 2
    with warnings.catch_warnings(record=True) as got:
        warnings.simplefilter("always")
        o = periodic_orbit(
            S, S.preset("liftoff"), options=EXACT, settings=ShootingOptions(transient_periods=60)
        )
    assert o.attractor_periods == 1 and not any("forcing periods" in str(w.message) for w in got)


def test_attractor_period_on_made_up_samples():
    # the detector itself: a sequence of period 3 (plus a decaying part), of period 1, and none
    T = 1.0
    t = np.arange(0.0, 20.5, 0.5)
    base = np.array([[1.0, 0.0], [0.0, 2.0], [-1.0, 1.0]])
    y3 = np.array([base[int(round(tt / T)) % 3] if tt % 1 == 0 else [9.0, 9.0] for tt in t])
    assert attractor_period(t, y3, T, np.array([0, 1]))[0] == 3
    assert attractor_period(t, np.ones((t.size, 2)), T, np.array([0, 1]))[0] == 1
    rng = np.random.default_rng(1)
    assert attractor_period(t, rng.normal(size=(t.size, 2)), T, np.array([0, 1]))[0] == 0


# ----------------------------------------------------------------------------------------------
def model_dict() -> dict:
    return tomllib.loads(MODEL.read_text())


@pytest.mark.parametrize(
    ("change", "message"),
    [
        (lambda d: d["contacts"]["tip"].pop("mu"), "[contacts.tip] lacks mu"),
        (lambda d: d["contacts"]["tip"].update(normal_stiffness=-1.0), "a normal stiffness must be > 0"),
        (lambda d: d["contacts"]["tip"].update(normal=["ground", "z"]), "unknown end `z`"),
        (lambda d: d["contacts"]["tip"].update(tangential="x"), "must be a list of two names"),
        (lambda d: d["contacts"]["tip"].update(normal=["ground", "x"]), "join the same two points"),
        (lambda d: d["contacts"]["tip"].update(stiffness=1.0), "unknown key(s) stiffness"),
        (lambda d: d["parameters"]["kt"].update(domain="real"), 'must have domain = "positive"'),
    ],
)
def test_bad_contacts_are_refused_clearly(change, message):
    d = model_dict()
    change(d)
    with pytest.raises(ModelError) as exc:
        system_from_dict(d)
    assert message in str(exc.value)


def test_a_contact_on_a_massless_node_is_refused():
    d = model_dict()
    d["nodes"] = {"u": {}}
    d["springs"]["ku"] = {"between": ["u", "x"], "stiffness": 1.0}
    d["contacts"]["tip"]["tangential"] = ["ground", "u"]
    with pytest.raises(ModelError, match="massless node"):
        system_from_dict(d)


def test_the_cli_refuses_a_bad_contact_without_a_traceback(tmp_path):
    text = MODEL.read_text().replace('normal = ["ground", "y"]', 'normal = ["ground", "q"]')
    bad = tmp_path / "bad.toml"
    bad.write_text(text)
    r = subprocess.run(
        [sys.executable, "-m", "hybrid.cli", "show", str(bad)], capture_output=True, text=True, timeout=120
    )
    assert r.returncode != 0
    assert "unknown end `q`" in r.stderr and "Traceback" not in r.stderr


@pytest.mark.slow
def test_a_cell_of_contacts_equals_one_contact():
    # issue 32: an array of contacts through cells; three copies each carrying a third of N0, kn, kt
    # (same mu) move as one: the orbit of the single contact
    d = model_dict()
    d["contacts"] = {}
    d["cells"] = {
        "patch": {
            "count": 3,
            "contacts": {
                "c": {
                    "tangential": ["ground", "x"],
                    "normal": ["ground", "y"],
                    "preload": "N0c",
                    "normal_stiffness": "knc",
                    "tangential_stiffness": "ktc",
                    "mu": "mu",
                }
            },
            "parameters": {k: {"unit": "N/m", "domain": "positive"} for k in ("N0c", "knc", "ktc")},
        }
    }
    p = d["presets"]["liftoff"]
    p["patch"] = {"N0c": p["N0"] / 3, "knc": p["kn"] / 3, "ktc": [p["kt"] / 3] * 3}
    d["plot"] = {"displacements": ["x", "y"]}
    S3 = system_from_dict(copy.deepcopy(d))
    o = exact_orbit("liftoff")
    x0 = dict(zip(o.system.variable_names, o.x0, strict=True))
    guess = {k: x0[k] for k in ("x", "vx", "y", "vy")}
    local = o.mode0.split("|")[1]
    o3 = periodic_orbit(
        S3,
        S3.preset("liftoff"),
        guess,
        "|".join(["motion"] + [local] * 3),
        t0=o.t0,
        options=EXACT,
        settings=ShootingOptions(transient_periods=0),
    )
    assert o3.converged, o3.message
    for k in ("x", "vx", "y", "vy"):
        assert o3.state(k) == pytest.approx(o.state(k), abs=1e-9 * scale(o))
    assert o3.state("N_c_1") * 3 == pytest.approx(o.state("N_tip"), abs=1e-9)
    assert o3.energy["dissipated"] == pytest.approx(o.energy["dissipated"], rel=1e-9)


@pytest.mark.slow
def test_the_cli_finds_the_subharmonic_orbit(tmp_path):
    # issue 32: `hybrid orbit ... --subharmonic 2`: an orbit of two forcing periods, stable, its JSON
    # saying so; the multipliers those of the library's periods=2 orbit
    r = subprocess.run(
        [sys.executable, "-m", "hybrid.cli", "orbit", str(MODEL), "--preset", "subharmonic", "--subharmonic", "2",
         "--integrator", "exact", "--json", "--no-plot", "--out", str(tmp_path / "o")],
        capture_output=True, text=True, timeout=300,
    )  # fmt: skip
    assert r.returncode == 0, r.stderr
    out = json.loads(r.stdout)
    assert out["periods"] == 2 and out["stability"] == "stable"
    assert out["period"] == pytest.approx(2 * 2 * np.pi / 4.7, rel=1e-14)
    o = exact_orbit("subharmonic")
    np.testing.assert_allclose(sorted(out["multiplier_moduli"]), sorted(abs(o.multipliers)), atol=1e-9)
