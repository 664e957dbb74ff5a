"""Record the periodic orbits of the shipped network files as the enumerating builder gave them.

The reference of ``test_network_orbits.py``: the network builder before issue 22 (commit 0247ea9,
which enumerated the ``3**k`` modes of ``k`` friction elements) computed these orbits with the exact
integrator; the composed builder must give the same. Produced by running this script with that
commit's ``models/`` importable as ``hybrid_models``::

    git archive 0247ea9 | tar -x -C /tmp/old
    mkdir -p /tmp/oldpkgs && ln -s /tmp/old/models /tmp/oldpkgs/hybrid_models
    PYTHONPATH=/tmp/oldpkgs python tests/models/data/network_orbits_before.py

It writes ``network_orbits_before.json`` beside itself: per file and preset, the section time and
mode, the mode sequence (in the old names), the switch times after the section [s], the state at
the section (every variable of the old model), the Floquet multipliers and the period [s].
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np

import hybrid_models
from hybrid import Exact, SolverOptions, load_system, periodic_orbit

FILES = [
    "absorber_network",
    "isolator_network",
    "coulomb_network",
    "sequential",
    "absorber_two_friction",
    "absorber_offset",
    "isolator_base",
    "friction_contact",
]
CASES = {  # file -> presets (and parameter changes) whose orbits converge
    "absorber_network": ["standard", "fig3a", "fig3b"],
    "isolator_network": ["standard", "fig4a"],
    "coulomb_network": ["forced"],
    "sequential": ["standard"],
    "absorber_two_friction": ["standard"],
    "absorber_offset": ["standard"],
    "isolator_base": ["standard"],
    "friction_contact": ["breakaway"],
}


def main() -> None:
    folder = Path(hybrid_models.__file__).parent
    out = {}
    for name, presets in CASES.items():
        system = load_system(folder / f"{name}.toml")
        for preset in presets:
            p = system.preset(preset)
            orbit = periodic_orbit(system, p, options=SolverOptions(method=Exact()))
            key = f"{name}/{preset}"
            out[key] = {
                "converged": bool(orbit.converged),
                "t0": float(orbit.t0),
                "mode0": orbit.mode0,
                "mode_sequence": list(orbit.mode_sequence),
                "switch_times": [float(t) for t in orbit.switch_times],
                "state": dict(zip(system.variable_names, map(float, orbit.trajectory.y[0]), strict=True)),
                "multipliers": [[float(z.real), float(z.imag)] for z in np.sort_complex(orbit.multipliers)],
                "period": float(orbit.period),
            }
            print(key, orbit.converged, orbit.mode_sequence[:6])
    Path(__file__).with_suffix(".json").write_text(json.dumps(out, indent=1) + "\n")


if __name__ == "__main__":
    main()
