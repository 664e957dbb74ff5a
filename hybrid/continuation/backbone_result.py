"""The result of :func:`hybrid.backbone`: :class:`Backbone`, its points and events."""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from ..core.options import ContinuationOptions
from ..core.status import BranchStatus
from ..engine.io import to_json
from ..integrators.options import SolverOptions
from ..model.system import HybridSystem
from ..orbits.orbit import PeriodicOrbit

__all__ = ["Backbone", "BackbonePoint", "BackboneEvent"]


@dataclass
class BackbonePoint:
    """One point of a backbone.

    Attributes
    ----------
    amplitude : float
        ``max_t q(t)`` of the coordinate [its unit].
    omega : float
        ``2 pi / T`` [rad/s].
    xi : float
        The energy-feeding parameter (EPMC: the artificial damping ``xi`` [1/s]).
    damping_ratio : float
        ``xi / (2 omega)``.
    dissipated : float
        Energy dissipated per period [J] (the model's ``energy["dissipated"]`` over one period; NaN
        if the model declares none).
    energy_input : float
        Energy put in per period by the parameter's term [J] (``energy["input"]``; NaN if none).
    fractions : dict
        Fraction of the period in each local mode (``component.mode``; without components, each mode).
    orbit : PeriodicOrbit
        The orbit (start at the anchor, time origin 0).
    t_max : float
        Time of the maximum of the coordinate after the orbit's start [s].
    harmonics : dict
        Variable -> array (HARMONICS + 1, 2) of Fourier coefficients ``(c_k, s_k)`` of
        ``x(t) = sum_k c_k cos(k omega t) + s_k sin(k omega t)``, time from the maximum of the
        coordinate (trapezoid rule on the orbit's equidistant samples).
    residual : float
        Largest scaled residual of the corrector at the point.
    """

    amplitude: float
    omega: float
    xi: float
    damping_ratio: float
    dissipated: float
    energy_input: float
    fractions: dict
    orbit: PeriodicOrbit
    t_max: float
    harmonics: dict
    residual: float

    def as_dict(self, coordinate: str | None = None) -> dict:
        """The point as plain data (harmonics of ``coordinate`` only, if given)."""
        names = [coordinate] if coordinate else list(self.harmonics)
        return {
            "amplitude": self.amplitude,
            "omega": self.omega,
            "frequency_hz": self.omega / (2 * math.pi),
            "xi": self.xi,
            "damping_ratio": self.damping_ratio,
            "dissipated": self.dissipated,
            "energy_input": self.energy_input,
            "period": self.orbit.period,
            "fractions": dict(self.fractions),
            "mode_sequence": list(self.orbit.mode_sequence),
            "harmonics": {n: self.harmonics[n].tolist() for n in names if n in self.harmonics},
            "start_state": {
                n: float(v) for n, v in zip(self.orbit.system.variable_names, self.orbit.x0, strict=True)
            },
            "t_max": self.t_max,
            "residual": self.residual,
        }


@dataclass
class BackboneEvent:
    """A change of the orbit's modes along a backbone.

    Attributes
    ----------
    kind : str
        ``"first-switch"`` (the orbit first leaves the start mode) or ``"all-switched"`` (every
        component has left its start local mode somewhere in the period).
    amplitude : float
        Where it happens (the middle of ``interval``).
    interval : (float, float)
        Amplitudes that hold it: the last point before and the first after.
    status : str
        ``"located"`` (the interval is within ``locate_tol`` relative) or ``"bracketed"``.
    omega, damping_ratio : float
        At the point after it (the upper end of ``interval``).
    description : str
    """

    kind: str
    amplitude: float
    interval: tuple
    status: str
    omega: float
    damping_ratio: float
    description: str

    def as_dict(self) -> dict:
        return {
            "kind": self.kind,
            "amplitude": self.amplitude,
            "interval": list(self.interval),
            "status": self.status,
            "omega": self.omega,
            "damping_ratio": self.damping_ratio,
            "description": self.description,
        }


@dataclass
class Backbone:
    """A backbone: periodic orbits with ``parameter`` solved for, by amplitude of ``coordinate``.

    Attributes
    ----------
    system : HybridSystem
    params : dict
        Parameter values (``parameter`` at its start value).
    coordinate : str
    parameter : str
    mode : int
        Which linear mode (1: the lowest frequency).
    start_mode : str
        The model's mode the linear mode is taken in.
    linear_omega : float
        The linear mode's frequency [rad/s] in ``start_mode``.
    references : dict
        Label -> frequency [rad/s] of the same mode number linearised in other modes of the model
        (its ``linear_references`` plot hint).
    points : list of BackbonePoint
        In order along the curve.
    events : list of BackboneEvent
    status : BranchStatus
    reason, message : str
    options : SolverOptions
    settings : ContinuationOptions
    """

    system: HybridSystem
    params: dict
    coordinate: str
    parameter: str
    mode: int
    start_mode: str
    linear_omega: float
    references: dict = field(default_factory=dict)
    points: list = field(default_factory=list)
    events: list = field(default_factory=list)
    status: BranchStatus = BranchStatus.COMPLETED
    reason: str = ""
    message: str = ""
    options: SolverOptions | None = None
    settings: ContinuationOptions | None = None

    def column(self, name: str) -> np.ndarray:
        """One quantity of every point (``amplitude``, ``omega``, ``xi``, ``damping_ratio``, ...)."""
        return np.array([getattr(p, name) for p in self.points], dtype=float)

    def to_rows(self) -> list[dict]:
        """One flat dict per point (for CSV)."""
        rows = []
        for p in self.points:
            row = {
                "amplitude": p.amplitude,
                "omega": p.omega,
                "xi": p.xi,
                "damping_ratio": p.damping_ratio,
                "dissipated": p.dissipated,
                "energy_input": p.energy_input,
                "period": p.orbit.period,
            }
            for m in self.system.local_mode_names:
                row[f"fraction_{m}"] = p.fractions.get(m, 0.0)
            h = p.harmonics.get(self.coordinate)
            if h is not None:
                for k in range(1, min(h.shape[0], 6)):
                    row[f"harmonic_{k}"] = float(math.hypot(*h[k]))
            rows.append(row)
        return rows

    def as_dict(self) -> dict:
        """The backbone as plain data (the points' harmonics of the coordinate only)."""
        return {
            "model": self.system.name,
            "coordinate": self.coordinate,
            "parameter": self.parameter,
            "mode": self.mode,
            "start_mode": self.start_mode,
            "linear_omega": self.linear_omega,
            "references": dict(self.references),
            "params": dict(self.params),
            "status": str(self.status),
            "reason": self.reason,
            "message": self.message,
            "events": [e.as_dict() for e in self.events],
            "points": [p.as_dict(self.coordinate) for p in self.points],
        }

    def to_json(self) -> str:
        """:meth:`as_dict` as JSON text (non-finite numbers as null)."""
        return to_json(self.as_dict())

    def __repr__(self) -> str:
        if not self.points:
            return f"Backbone({self.system.name}, {self.coordinate}: no point; {self.status} {self.reason})"
        a = self.column("amplitude")
        return (
            f"Backbone({self.system.name}, {self.coordinate}: {len(self.points)} points, amplitude "
            f"{a.min():.6g} to {a.max():.6g}, events [{', '.join(e.kind for e in self.events)}]; {self.status}"
            + (f" ({self.reason})" if self.reason else "")
            + ")"
        )
