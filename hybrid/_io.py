"""Writing trajectories as data: CSV of the samples, CSV of the event log, JSON summaries."""

from __future__ import annotations

import csv
import json
import math
from pathlib import Path

import numpy as np

from ._trajectory import Trajectory

__all__ = ["write_trajectory_csv", "write_events_csv", "write_rows_csv", "trajectory_summary", "to_json"]


def _header(traj: Trajectory) -> list[str]:
    system = traj.system
    units = {v.name: v.unit for v in system.variables}
    cols = ["t [s]", "mode"]
    cols += [f"{n} [{units[n]}]" if units.get(n) else n for n in traj.names]
    out_units = system.plot.get("units", {})
    cols += [f"{o} [{out_units[o]}]" if out_units.get(o) else o for o in traj.outputs]
    return cols


def write_trajectory_csv(traj: Trajectory, path: str | Path) -> Path:
    """Write every sample (time, mode, variables, outputs) to a CSV file."""
    path = Path(path)
    with path.open("w", newline="") as fh:
        w = csv.writer(fh)
        w.writerow(_header(traj))
        outs = [traj.outputs[o] for o in traj.outputs]
        for i in range(traj.t.size):
            row = [repr(float(traj.t[i])), traj.mode[i]]
            row += [repr(float(v)) for v in traj.y[i]]
            row += [repr(float(o[i])) for o in outs]
            w.writerow(row)
    return path


def write_events_csv(traj: Trajectory, path: str | Path) -> Path:
    """Write the event log (one row per switch, states before and after) to a CSV file."""
    path = Path(path)
    with path.open("w", newline="") as fh:
        w = csv.writer(fh)
        w.writerow(
            ["t [s]", "source", "target", "transition", "guard_value", "chained"]
            + [f"{n}-" for n in traj.names]
            + [f"{n}+" for n in traj.names]
        )
        for ev in traj.events:
            w.writerow(
                [repr(ev.t), ev.source, ev.target, ev.guard, repr(ev.guard_value), int(ev.chained)]
                + [repr(float(v)) for v in ev.x_minus]
                + [repr(float(v)) for v in ev.x_plus]
            )
    return path


def _cell(v) -> str:
    if v is None:
        return ""
    if isinstance(v, bool | np.bool_):
        return str(bool(v)).lower()
    if isinstance(v, float | np.floating):
        return repr(float(v))
    return str(v)


def write_rows_csv(rows: list[dict], path: str | Path, columns: list[str] | None = None) -> Path:
    """Write dicts as CSV rows; the columns are ``columns`` or the union of the keys in first-seen order.

    Missing values and None are empty cells, floats are written exactly (``repr``).
    """
    path = Path(path)
    if columns is None:
        columns = list(dict.fromkeys(k for row in rows for k in row))
    with path.open("w", newline="") as fh:
        w = csv.writer(fh)
        w.writerow(columns)
        for row in rows:
            w.writerow([_cell(row.get(c)) for c in columns])
    return path


def trajectory_summary(traj: Trajectory) -> dict:
    """A JSON-ready summary: final state and mode, transitions, energy balance, counters."""
    system = traj.system
    out = {
        "model": system.name,
        "parameters": dict(traj.params),
        "t_start": traj.t_start,
        "t_final": traj.t_final,
        "status": traj.status.name,
        "success": traj.success,
        "message": traj.message,
        "final_mode": traj.mode_final,
        "final_state": {n: float(v) for n, v in zip(traj.names, traj.y_final, strict=True)},
        "transitions": traj.n_transitions,
        "nfev": traj.nfev,
        "njev": traj.njev,
    }
    en = system.energy
    if en and traj.t.size:

        def final_of(name: str) -> float:
            return traj.final(name) if name in traj.names else float(traj[name][-1])

        if "input" in en:
            out["input_work"] = final_of(en["input"]) - float(traj[en["input"]][0])
        if "dissipated" in en:
            out["dissipated_energy"] = final_of(en["dissipated"]) - float(traj[en["dissipated"]][0])
        if "mechanical" in en:
            mech = traj[en["mechanical"]]
            out["mechanical_energy_change"] = float(mech[-1] - mech[0])
        if {"input", "dissipated", "mechanical"} <= set(en) and traj.t[-1] == traj.t_final:
            out["energy_balance_residual"] = (
                out["input_work"] - out["dissipated_energy"] - out["mechanical_energy_change"]
            )
    return out


def to_json(obj) -> str:
    """JSON text; non-finite floats become null (strict JSON has no NaN/inf)."""

    def clean(o):
        if isinstance(o, dict):
            return {str(k): clean(v) for k, v in o.items()}
        if isinstance(o, list | tuple):
            return [clean(v) for v in o]
        if isinstance(o, np.generic):
            o = o.item()
        if isinstance(o, float) and not math.isfinite(o):
            return None
        return o

    return json.dumps(clean(obj), indent=2, allow_nan=False)
