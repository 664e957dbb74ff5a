"""One periodic orbit of the paper's absorber, with its Floquet multipliers.

The absorber (``hybrid_models.absorber()``, read from ``models/absorber.toml``) at its standard
parameters, forced at 0.854 rad/s, inside its first stick-slip band. The orbit is found by
shooting with the exact integrator; the script prints its summary, its multipliers and where the
element switches, and draws ``orbit.png`` (one period: friction force against time and against
the relative velocity, the displacements with the stick phases shaded, the multipliers).
"""

from pathlib import Path

import hybrid_models
from hybrid import Exact, SolverOptions, periodic_orbit
from hybrid.plot.trajectory import plot_orbit

out = Path("out") / "examples" / "absorber_orbit"
out.mkdir(parents=True, exist_ok=True)

absorber = hybrid_models.absorber()
params = absorber.preset("standard", Omega=0.854)  # rad/s
orbit = periodic_orbit(absorber, params, options=SolverOptions(method=Exact()))
print(orbit)
print("stability:", orbit.stability, "| multipliers:", [f"{abs(m):.6f}" for m in orbit.multipliers])
print("modes over one period:", " -> ".join(orbit.mode_sequence))
print("switch times [s]:", [f"{t:.4f}" for t in orbit.switch_times])
print("amplitude of x1 (half peak-to-peak) [m]:", f"{orbit.half_peak_to_peak['x1']:.6f}")
print("wrote", plot_orbit(orbit, out / "orbit.png"))
