"""A self-excited stick-slip cycle: a mass on a moving belt with Coulomb stiction.

The built-in ``belt`` model has no forcing period: the orbit's period is an unknown, found with
the orbit. The script prints the period and amplitude at one belt speed and compares the period
with the closed form of ``docs/selfexcited.md``: a stick phase at the belt speed, then a slip
half-cycle of the undamped oscillator.
"""

import numpy as np

import hybrid_models
from hybrid import Exact, SolverOptions, periodic_orbit

belt = hybrid_models.belt()
params = belt.preset(belt.presets and next(iter(belt.presets)))
orbit = periodic_orbit(belt, params, options=SolverOptions(method=Exact()))
print(orbit)
print(f"period {orbit.period:.6f} s, multipliers {[f'{abs(m):.4f}' for m in orbit.multipliers]}")
assert orbit.converged
assert np.isfinite(orbit.period)
