"""A branch of periodic orbits of a forced system (:class:`Branch`), one orbit as a CSV row
(:func:`orbit_row`), and the parameter a forcing frequency is (:func:`forcing_parameter`)."""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from ..core.errors import InputError, ModelError
from ..model.expr import free_symbols
from ..model.system import HybridSystem
from ..orbits.orbit import (
    PeriodicOrbit,
)

__all__ = ["Branch", "forcing_parameter", "orbit_row"]


@dataclass
class Branch:
    """A branch of periodic orbits.

    Attributes
    ----------
    system : HybridSystem
    params : dict
        Parameter values (the continued one at its start value).
    parameter : str
        The continued parameter.
    points : list of PeriodicOrbit
        Orbits in branch order (located special points included).
    special : list of SpecialPoint
    status : str
        ``"completed"`` (left the range or reached ``max_points``) or ``"stopped"``.
    message : str
    reason : str
        Why a stopped branch stopped: ``"unbounded"`` (the response grows without bound),
        ``"stalled"`` (the corrector failed ``max_failures`` times in a row), ``"no-start"``
        (no first orbit), ``"degenerate"`` (``I - M`` vanishes at the first orbit: every nearby
        state is periodic, e.g. an unforced system at rest, so there is no branch to follow),
        ``"budget"`` (a run's budget or the deadline), ``"interrupted"``; ``""`` if completed.
    """

    system: HybridSystem
    params: dict
    parameter: str
    points: list = field(default_factory=list)
    special: list = field(default_factory=list)
    status: str = "completed"
    message: str = ""
    reason: str = ""

    @property
    def p(self) -> np.ndarray:
        """Parameter value of every point."""
        return np.array([o.params[self.parameter] for o in self.points])

    def amplitude(self, name: str) -> np.ndarray:
        """``max |x|`` of ``name`` at every point."""
        return np.array([o.amplitude[name] for o in self.points])

    def half_peak_to_peak(self, name: str) -> np.ndarray:
        return np.array([o.half_peak_to_peak[name] for o in self.points])

    @property
    def stability(self) -> list[str]:
        return [o.stability for o in self.points]

    def to_rows(self) -> list[dict]:
        """One dict per point (for CSV)."""
        return [orbit_row(self.parameter, o) for o in self.points]

    def __repr__(self) -> str:
        kinds = ", ".join(f"{s.kind}@{s.parameter:.6g}" for s in self.special)
        if not self.points:
            return f"Branch({self.system.name}, {self.parameter}, no point, {self.status}: {self.message})"
        return (
            f"Branch({self.system.name}, {self.parameter} in [{self.p.min():.6g}, {self.p.max():.6g}], "
            f"{len(self.points)} points, special: [{kinds}], {self.status})"
        )


def orbit_row(parameter: str, o: PeriodicOrbit) -> dict:
    """One orbit of a branch as a flat dict (a CSV row): parameter, stability, amplitudes, ..."""
    row = {
        parameter: o.params[parameter],
        "stability": o.stability,
        "transitions_per_period": o.transitions_per_period,
        "mode_sequence": " ".join(o.mode_sequence),
        "max_abs_multiplier": float(np.max(np.abs(o.floquet_multipliers)))
        if o.floquet_multipliers.size
        else float("nan"),
        "residual": o.residual,
    }
    for m in o.system.mode_names:  # every mode, so that all rows have the same columns
        row[f"fraction_{m}"] = o.mode_fractions.get(m, 0.0)
    for n, v in o.amplitude.items():
        row[f"amplitude_{n}"] = v
    for n, v in o.half_peak_to_peak.items():
        row[f"half_peak_to_peak_{n}"] = v
    return row


def forcing_parameter(system: HybridSystem) -> str:
    """The one parameter the forcing period depends on (e.g. a forcing frequency).

    Raises
    ------
    ValueError
        If the model declares no period, or its period depends on no parameter or on several.
    """
    pe = system.parsed.period
    if pe is None:
        raise ModelError(
            f"model `{system.name}` declares no forcing `period`: this continuation of forced orbits needs "
            "one (an autonomous model's orbits: hybrid.orbit_branch, hybrid.hopf_branch, `hybrid cont`)"
        )
    names = sorted(free_symbols(pe) & set(system.parameter_names))
    if len(names) != 1:
        raise InputError(
            f"model `{system.name}`: its period depends on {len(names)} parameters "
            f"({', '.join(names) or 'none'}); name the parameter to continue in"
        )
    return names[0]
