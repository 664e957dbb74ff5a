"""Structures at growing size: set-up and exact-orbit time against size (issue 32, item 6).

Two families of the cantilever of ``models/data/make_beam.py`` (steel, 1 m, 40 x 10 mm, 0.5 %
modal damping) with Jenkins contacts (``kt`` 5000 N/m, slip force 1 N, a slider each) and the
force ``0.5 sin(90 t)`` N at the tip (near the stuck resonance: the tip contact sticks and slips):

* **beam**: one contact at the tip; Craig-Bampton-reduced (the tip as boundary DOF) with 10, 20,
  40, 80 elements and 6 modes, the 80 elements also with 12 and 24 modes; and in full where an
  orbit finishes in the time allowed (10 and 20 elements);
* **contacts**: the beam of 40 elements with 1, 2, 4, 8, 16 contacts at nodes spread along it
  (the blade/ring model of issue 32 is not on main: beams with growing numbers of contacts stand
  in for the ring), reduced to the contact DOFs and 6 modes.

For each: the set-up time (``system_from_dict``: reading the matrices, the reduction, the
equations, the system's checks), the time of :func:`hybrid.periodic_orbit` on the exact integrator
from rest (a transient of 10 forcing periods, then Newton's method with the monodromy matrix),
its state count and whether it converged; best of ``REPEAT`` set-ups, one orbit. The table goes to
``docs/structures/structures_scale.csv``, the log-log plot to ``docs/structures/structures_scale.png``,
the growth exponents (least squares of log time against log size) are printed.

Run: ``python benchmarks/structures.py`` (``--plot``: the plot again from the table).
"""

from __future__ import annotations

import csv
import importlib.util
import os
import sys
import time
from pathlib import Path

import numpy as np

import hybrid_models
from hybrid import Exact, SolverOptions, periodic_orbit, system_from_dict, time_limit
from hybrid_models.structures import Structure

ROOT = Path(__file__).resolve().parents[1]
OUT = ROOT / "docs" / "structures"
REPEAT = 3
#: Wall time allowed for one orbit [s] (a longer one is recorded as not finished).
ORBIT_LIMIT = 300.0
PARAMS = {"kt": 5000.0, "R": 1.0, "F": 0.5, "Omega": 90.0}


def beam_matrices(n: int):
    spec = importlib.util.spec_from_file_location(
        "make_beam", Path(hybrid_models.__file__).parent / "data" / "make_beam.py"
    )
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod.beam_matrices(n)


def network(n: int, contacts: int, modes: int | None) -> dict:
    """The beam of ``n`` elements with ``contacts`` Jenkins contacts (the last at the tip), forced at
    the tip; reduced to the contact DOFs and ``modes`` modes (None: in full)."""
    M, K, dofs = beam_matrices(n)
    structure = Structure.from_arrays(M, K, dofs, modal_damping=[0.005])
    nodes = sorted({round(n * (i + 1) / contacts) for i in range(contacts)})
    spec = {"matrices": structure} | ({"reduce": {"modes": modes}} if modes is not None else {})
    data = {
        "model": {"name": "beam_scale", "format": "network"},
        "structures": {"beam": spec},
        "nodes": {},
        "springs": {},
        "friction": {},
        "forces": {"force": {"on": f"beam.w{n}", "amplitude": "F", "frequency": "Omega"}},
        "parameters": {"kt": {"domain": "positive"}, "R": {"domain": "positive"}, "F": {}, "Omega": {}},
        "presets": {"standard": dict(PARAMS)},
    }
    for j in nodes:
        data["nodes"][f"s{j}"] = {}
        data["springs"][f"k{j}"] = {"between": [f"beam.w{j}", f"s{j}"], "stiffness": "kt"}
        data["friction"][f"c{j}"] = {"between": [f"s{j}", "ground"], "sliding": "R"}
    return data


def measure(family: str, n: int, contacts: int, modes: int | None) -> dict:
    best = np.inf
    for _ in range(REPEAT):
        data = network(n, contacts, modes)
        start = time.perf_counter()
        system = system_from_dict(data)
        best = min(best, time.perf_counter() - start)
    p = system.preset("standard")
    start = time.perf_counter()
    try:
        with time_limit(ORBIT_LIMIT):
            orbit = periodic_orbit(system, p, options=SolverOptions(method=Exact()))
        converged, wall = bool(orbit.converged), time.perf_counter() - start
    except Exception as exc:  # noqa: BLE001 - recorded in the table (e.g. the time limit)
        converged, wall = False, time.perf_counter() - start
        print(f"  {family} n={n} contacts={contacts} modes={modes}: {type(exc).__name__}: {exc}"[:200])
    row = {
        "family": family,
        "elements": n,
        "contacts": contacts,
        "modes": "full" if modes is None else modes,
        "states": len(system.variable_names),
        "setup_s": round(best, 4),
        "orbit_s": round(wall, 3),
        "converged": converged,
        "load": round(os.getloadavg()[0], 2),
    }
    print(row, flush=True)
    return row


#: What "size" is in each family: the DOFs of the full structure (2 per element) for the beam
#: reduced to 6 modes and for the full beam, the system's states for the modes kept, the contacts
#: for the beam with many contacts.
SIZE = {
    "beam-cb": ("structure DOFs", lambda r: 2 * int(r["elements"])),
    "beam-full": ("structure DOFs", lambda r: 2 * int(r["elements"])),
    "beam-cb-modes": ("states", lambda r: int(r["states"])),
    "contacts-cb": ("contacts", lambda r: int(r["contacts"])),
}
LABELS = {
    "beam-cb": "beam CB (6 modes) vs elements' DOFs",
    "beam-full": "beam, full, vs DOFs",
    "beam-cb-modes": "beam CB (80 el.) vs states (6/12/24 modes)",
    "contacts-cb": "beam CB (40 el.) vs contacts",
}


def exponent(rows: list[dict], y: str) -> float:
    """Slope of ``log y`` against ``log size`` (least squares) over the converged rows of a family."""
    pts = [(SIZE[r["family"]][1](r), float(r[y])) for r in rows if str(r["converged"]) == "True"]
    if len(pts) < 2 or len({p[0] for p in pts}) < 2:
        return float("nan")
    X, Y = np.log([p[0] for p in pts]), np.log([p[1] for p in pts])
    return float(np.polyfit(X, Y, 1)[0])


def plot(rows: list[dict]) -> None:
    """The log-log plot of set-up and orbit time against size, one line per family; the growth
    exponents printed."""
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    fig = Figure(figsize=(11, 4.4))
    FigureCanvasAgg(fig)
    axes = fig.subplots(1, 2)
    for fam, label in LABELS.items():
        rs = [r for r in rows if r["family"] == fam]
        size = SIZE[fam][1]
        ok = [r for r in rs if str(r["converged"]) == "True"]
        axes[0].loglog([size(r) for r in rs], [float(r["setup_s"]) for r in rs], "o-", label=label)
        axes[1].loglog([size(r) for r in ok], [float(r["orbit_s"]) for r in ok], "o-", label=label)
        print(
            f"{label}: set-up ~ size^{exponent(rs, 'setup_s'):.2f}, orbit ~ size^{exponent(rs, 'orbit_s'):.2f}"
        )
    axes[0].set(xlabel="size (see legend)", ylabel="set-up time [s]", title="set-up (system_from_dict)")
    axes[1].set(xlabel="size (see legend)", ylabel="orbit time [s]", title="exact periodic orbit from rest")
    for ax in axes:
        ax.grid(True, which="both", alpha=0.3)
    axes[1].legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(OUT / "structures_scale.png", dpi=110)
    print(f"wrote {OUT / 'structures_scale.png'}")


def main() -> list[dict]:
    runs = [("beam-cb", n, 1, 6) for n in (10, 20, 40, 80)]
    runs += [("beam-cb-modes", 80, 1, m) for m in (6, 12, 24)]
    runs += [("beam-full", n, 1, None) for n in (10, 20)]
    runs += [("contacts-cb", 40, k, 6) for k in (1, 2, 4, 8, 16)]
    rows = [measure(*c) for c in runs]
    OUT.mkdir(parents=True, exist_ok=True)
    with (OUT / "structures_scale.csv").open("w", newline="") as fh:
        w = csv.DictWriter(fh, fieldnames=list(rows[0]))
        w.writeheader()
        w.writerows(rows)
    print(f"wrote {OUT / 'structures_scale.csv'}")
    plot(rows)
    return rows


if __name__ == "__main__":
    if sys.argv[1:] == ["--plot"]:  # the plot again from the table
        with (OUT / "structures_scale.csv").open() as fh:
            plot(list(csv.DictReader(fh)))
    else:
        main()
