"""Units of work of ``hybrid reproduce``: picklable, hashable jobs run in worker processes.

A figure asks for jobs (curves, orbits, optima, cross-checks); equal jobs of different figures
are run once (e.g. the absorber's curve at R = 0.5 N serves Figs. 7, 11 and B1).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

import hybrid

from . import BUILTIN
from .studies import ida_peak as _ida_peak
from .studies import (
    optimal_friction,
    resonance_curve,
    smallest_bounded_friction,
    solver_options,
)

__all__ = ["Job", "run_job", "curve", "orbit", "optimum", "bounded_limit", "ida_peak"]


@dataclass(frozen=True)
class Job:
    """One computation (hashable: parameters as a sorted tuple of items).

    Attributes
    ----------
    kind : str
        ``"curve"``, ``"orbit"``, ``"optimum"``, ``"bounded-limit"`` or ``"ida-peak"``.
    model : str
        ``"absorber"`` or ``"isolator"``.
    params : tuple of (str, float)
        Parameter values [SI] (empty for the design values, which use the ``standard`` preset).
    window : tuple of float
        Frequency range [rad/s] of a curve.
    mode : int
        Resonance (1 or 2) of a design value; 0 otherwise.
    omega : float
        Frequency [rad/s] of the peak to cross-check.
    start : tuple
        ``(t0, mode0, x0)`` of the orbit there (:attr:`~hybrid_models.studies.Curve.peak_start`).
    integrator : str
        ``"exact"`` or ``"ida"``.
    """

    kind: str
    model: str
    params: tuple = ()
    window: tuple = ()
    mode: int = 0
    omega: float = 0.0
    start: tuple = ()
    integrator: str = "exact"

    @property
    def weight(self) -> float:
        """Rough cost in curves (for the progress bar)."""
        return {"optimum": 14.0, "bounded-limit": 9.0, "ida-peak": 0.5, "orbit": 0.3}.get(self.kind, 1.0)


def _items(params: dict) -> tuple:
    return tuple(sorted((k, float(v)) for k, v in params.items()))


def curve(model: str, params: dict, window: tuple, integrator: str) -> Job:
    """Job of :func:`hybrid_models.studies.resonance_curve`."""
    return Job("curve", model, _items(params), tuple(window), integrator=integrator)


def orbit(model: str, params: dict, integrator: str) -> Job:
    """Job of a steady periodic orbit at ``params["Omega"]`` (512 samples)."""
    return Job("orbit", model, _items(params), integrator=integrator)


def optimum(model: str, mode: int, integrator: str) -> Job:
    """Job of :func:`hybrid_models.studies.optimal_friction`."""
    return Job("optimum", model, mode=mode, integrator=integrator)


def bounded_limit(model: str, mode: int, integrator: str) -> Job:
    """Job of :func:`hybrid_models.studies.smallest_bounded_friction`."""
    return Job("bounded-limit", model, mode=mode, integrator=integrator)


def ida_peak(model: str, params: dict, omega: float, start: tuple) -> Job:
    """Job of :func:`hybrid_models.studies.ida_peak` (the IDA path's peak of ``x1`` near ``omega``)."""
    return Job("ida-peak", model, _items(params), omega=float(omega), start=start, integrator="ida")


def _orbit(model: str, params: dict, integrator: str) -> dict:
    system = BUILTIN[model]()
    o = hybrid.periodic_orbit(
        system,
        params,
        options=solver_options(integrator),
        settings=hybrid.ShootingOptions(samples_per_period=512),
    )
    tr = o.trajectory
    return {
        "converged": o.converged,
        "message": o.message,
        "period": o.period,
        "t": np.asarray(tr.t) - tr.t[0],
        "H": np.asarray(tr["H"]),
        "v_rel": np.asarray(tr["v_rel"]),
        "mode": [str(m) for m in tr.mode],
        "mode_sequence": list(o.mode_sequence),
        "mode_fractions": dict(o.mode_fractions),
        "amplitude": {k: float(v) for k, v in o.half_peak_to_peak.items()},
        "stability": o.stability,
    }


def run_job(job: Job):
    """Run one job (in a worker process).

    Parameters
    ----------
    job : Job

    Returns
    -------
    object
        :class:`~hybrid_models.studies.Curve`, an orbit dict, an
        :class:`~hybrid_models.studies.Optimum`, a bracket dict, or ``(omega, x1)``.
    """
    params = dict(job.params)
    if job.kind == "curve":
        return resonance_curve(job.model, params, job.window, job.integrator)
    if job.kind == "orbit":
        return _orbit(job.model, params, job.integrator)
    if job.kind == "optimum":
        return optimal_friction(job.model, job.mode, job.integrator)
    if job.kind == "bounded-limit":
        return smallest_bounded_friction(job.model, job.mode, job.integrator)
    if job.kind == "ida-peak":
        return _ida_peak(job.model, params, job.omega, job.start)
    raise ValueError(f"unknown job kind {job.kind!r}")
