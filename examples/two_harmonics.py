"""Forcing as a sum of harmonics: the tutorial's damper shaken at Omega and 2 Omega at once.

``tmd_harmonics.toml`` gives its force as ``harmonics = [{ amplitude = "F" }, { amplitude = "F2",
multiple = 2, phase = "phi2" }]``: ``F sin(Omega t) + F2 sin(2 Omega t + phi2)``, of period
``2 pi / Omega``. The script finds the periodic orbit with the exact integrator and with IDA at a
tight tolerance, and runs a long exact simulation from rest; the three agree (the script prints
by how much), and draws the orbit.
"""

from pathlib import Path

import numpy as np

import hybrid
from hybrid import IDA, Exact, SolverOptions
from hybrid.plot.trajectory import plot_orbit

out = Path("out") / "examples" / "two_harmonics"
out.mkdir(parents=True, exist_ok=True)

tmd = hybrid.load_system(Path(__file__).with_name("tmd_harmonics.toml"))
params = tmd.preset("standard", Omega=55.0)
print("force:", tmd.definitions["F_exc"], "| period:", tmd.period)
exact = hybrid.periodic_orbit(tmd, params, options=SolverOptions(method=Exact()))
ida = hybrid.periodic_orbit(tmd, params, options=SolverOptions(method=IDA(rtol=1e-12, atol=1e-14)))
print("exact:", exact)
print("IDA:  ", ida)
scale = max(exact.amplitude[x] for x in ("x1", "x2"))
diff = max(abs(exact.amplitude[x] - ida.amplitude[x]) for x in ("x1", "x2")) / scale
print(f"amplitudes, exact against IDA (rtol 1e-12): {diff:.2e} relative")

# a long exact run from rest settles onto the orbit (multipliers 0.83 and less: 300 periods)
T = exact.period
run = hybrid.simulate(
    tmd,
    params,
    (0.0, exact.t0 + 300 * T),
    {"x1": 0.0, "v_x1": 0.0, "x2": 0.0, "v_x2": 0.0},
    options=SolverOptions(method=Exact()),
    samples_per_period=4,
)
names = list(tmd.variable_names)
keys = ("x1", "v_x1", "x2", "v_x2")
orbit_state = np.array([exact.x0[names.index(k)] for k in keys])
run_state = np.array([run.final_values[k] for k in keys])
gap = np.max(np.abs(run_state - orbit_state)) / np.max(np.abs(orbit_state))
print(f"state after 300 periods from rest against the orbit's: {gap:.2e} relative")
assert diff < 1e-9, diff
assert gap < 1e-9, gap
print("wrote", plot_orbit(exact, out / "orbit.png"))
