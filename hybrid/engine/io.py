"""Writing trajectories as data: CSV of the samples, CSV of the event log, JSON summaries."""

from __future__ import annotations

import csv
import json
import math
from collections.abc import Iterable, Iterator, Sequence
from pathlib import Path

import numpy as np

from .record import Sink
from .trajectory import Trajectory, TransitionRecord

__all__ = [
    "write_trajectory_csv",
    "write_events_csv",
    "TrajectoryCSVWriter",
    "EventsCSVWriter",
    "write_rows_csv",
    "trajectory_summary",
    "to_json",
]


def _header(system, names: Sequence[str], outputs: Iterable[str]) -> list[str]:
    units = {v.name: v.unit for v in system.variables}
    cols = ["t [s]", "mode"]
    cols += [f"{n} [{units[n]}]" if units.get(n) else n for n in names]
    out_units = system.plot.get("units", {})
    cols += [f"{o} [{out_units[o]}]" if out_units.get(o) else o for o in outputs]
    return cols


def _sample_rows(t: np.ndarray, mode: np.ndarray, y: np.ndarray, outputs: list[np.ndarray]) -> Iterator[list]:
    """CSV rows of samples: time, mode, variables, outputs; floats written exactly (``repr``)."""
    columns = [np.asarray(t, dtype=float).tolist(), *np.asarray(y, dtype=float).T.tolist()]
    columns += [np.asarray(o, dtype=float).tolist() for o in outputs]
    for m, row in zip(mode, zip(*columns, strict=True), strict=True):
        yield [repr(row[0]), m, *map(repr, row[1:])]


def _events_header(names: Sequence[str]) -> list[str]:
    return (
        ["t [s]", "source", "target", "transition", "guard_value", "chained"]
        + [f"{n}-" for n in names]
        + [f"{n}+" for n in names]
    )


def _event_row(ev: TransitionRecord) -> list:
    return (
        [repr(float(ev.t)), ev.source, ev.target, ev.guard, repr(float(ev.guard_value)), int(ev.chained)]
        + [repr(float(v)) for v in ev.x_minus]
        + [repr(float(v)) for v in ev.x_plus]
    )


def write_trajectory_csv(traj: Trajectory, path: str | Path) -> Path:
    """Write every sample of a trajectory (time, mode, variables, outputs) to a CSV file.

    Parameters
    ----------
    traj : Trajectory
        The samples it holds (for a streamed run, its kept window).
    path : str or Path
        CSV file to write (replaced).

    Returns
    -------
    Path
    """
    path = Path(path)
    with path.open("w", newline="") as fh:
        w = csv.writer(fh)
        w.writerow(_header(traj.system, traj.names, traj.outputs))
        w.writerows(_sample_rows(traj.t, traj.mode, traj.y, list(traj.outputs.values())))
    return path


def write_events_csv(traj: Trajectory, path: str | Path) -> Path:
    """Write the event log of a trajectory (one row per switch, states before and after) to a CSV file.

    Parameters
    ----------
    traj : Trajectory
        The switches it holds (for a streamed run, those of its kept window).
    path : str or Path
        CSV file to write (replaced).

    Returns
    -------
    Path
    """
    path = Path(path)
    with path.open("w", newline="") as fh:
        w = csv.writer(fh)
        w.writerow(_events_header(traj.names))
        w.writerows(_event_row(ev) for ev in traj.events)
    return path


class _CSVSink(Sink):
    """A sink writing CSV rows as they come. The file is created at the first row or at :meth:`close`
    (so that a run refused before it starts leaves no file); use it as a context manager."""

    def __init__(self, path: str | Path, header: list[str]):
        self.path = Path(path)
        self.header = header
        self._fh = None
        self._writer = None
        self.rows = 0

    def _rows(self, rows: Iterable[list]) -> None:
        try:
            if self._writer is None:
                self._fh = self.path.open("w", newline="")
                self._writer = csv.writer(self._fh)
                self._writer.writerow(self.header)
            for row in rows:
                self._writer.writerow(row)
                self.rows += 1
        except OSError as exc:  # (a full disk: the error names the file)
            exc.filename = exc.filename or str(self.path)
            raise

    def close(self) -> Path:
        """Finish the file (header only if no row came) and return its path."""
        if self._writer is None:
            self._rows(())
        try:
            self._fh.close()
        except OSError as exc:
            exc.filename = exc.filename or str(self.path)
            raise
        return self.path

    def __enter__(self):
        return self

    def __exit__(self, exc_type, exc, tb) -> None:
        if exc_type is None or issubclass(exc_type, KeyboardInterrupt):  # (an interrupt keeps the rows)
            self.close()
        elif self._fh is not None:
            try:
                self._fh.close()
            except OSError:  # (the error that stopped the run is the one to report)
                pass


class TrajectoryCSVWriter(_CSVSink):
    """Sink writing the samples of a run to a CSV file as they come, in constant memory.

    The file has the columns and format of :func:`write_trajectory_csv`
    (time [s], mode, every variable, every output, in model units).

    Parameters
    ----------
    path : str or Path
        CSV file to write (replaced).
    system : HybridSystem
        The system simulated (names and units of the columns).

    Examples
    --------
    >>> with TrajectoryCSVWriter("trajectory.csv", system) as w:  # doctest: +SKIP
    ...     simulate(system, params, t_span, x0, sink=w)
    """

    def __init__(self, path: str | Path, system):
        self.outputs = list(system.outputs)
        super().__init__(path, _header(system, system.variable_names, self.outputs))

    def samples(self, t, y, mode, outputs) -> None:
        self._rows(_sample_rows(t, mode, y, [outputs[o] for o in self.outputs]))


class EventsCSVWriter(_CSVSink):
    """Sink writing the switches of a run to a CSV file as they come (format of :func:`write_events_csv`).

    Parameters
    ----------
    path : str or Path
        CSV file to write (replaced).
    system : HybridSystem
        The system simulated (variable names of the columns).
    """

    def __init__(self, path: str | Path, system):
        super().__init__(path, _events_header(system.variable_names))

    def event(self, record: TransitionRecord) -> None:
        self._rows((_event_row(record),))


def csv_cell(v) -> str:
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
            w.writerow([csv_cell(row.get(c)) for c in columns])
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
        "samples": traj.n_samples,
        "nfev": traj.nfev,
        "njev": traj.njev,
    }
    en = system.energy
    start, final = traj.start_values, traj.final_values
    if en and start is not None and final is not None:
        # from the values at the start and the end of the run: no sample needed (a streamed run keeps few)
        if "input" in en:
            out["input_work"] = final[en["input"]] - start[en["input"]]
        if "dissipated" in en:
            out["dissipated_energy"] = final[en["dissipated"]] - start[en["dissipated"]]
        if "mechanical" in en:
            out["mechanical_energy_change"] = final[en["mechanical"]] - start[en["mechanical"]]
        if {"input", "dissipated", "mechanical"} <= set(en):
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
