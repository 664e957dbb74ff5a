"""One branch result for every continuation (:class:`Branch`), one orbit as a CSV row
(:func:`orbit_row`), and the parameter a forcing frequency is (:func:`forcing_parameter`)."""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from ..core.errors import InputError, ModelError
from ..core.options import ContinuationOptions
from ..core.plain import options_text
from ..core.status import BranchStatus
from ..core.tables import Tabular, table_columns
from ..integrators.options import SolverOptions
from ..model.expr import free_symbols
from ..model.system import HybridSystem
from ..orbits.equilibria import Equilibrium
from ..orbits.orbit import (
    PeriodicOrbit,
)

__all__ = ["Branch", "BRANCH_KINDS", "forcing_parameter", "orbit_row", "with_options"]

#: What a branch holds: periodic orbits of a forced model (:func:`hybrid.continue_orbits`), of an
#: autonomous one (:func:`hybrid.orbit_branch`, :func:`hybrid.hopf_branch`), or equilibria of one
#: mode (:func:`hybrid.equilibrium_branch`).
BRANCH_KINDS = ("forced-orbits", "autonomous-orbits", "equilibria")


@dataclass
class Branch(Tabular):
    """A branch of solutions continued in one parameter: periodic orbits or equilibria.

    Attributes
    ----------
    kind : str
        One of :data:`BRANCH_KINDS`: ``"forced-orbits"``, ``"autonomous-orbits"`` or
        ``"equilibria"``.
    system : HybridSystem
    params : dict
        Parameter values (the continued one at the branch's start).
    parameter : str
        The continued parameter.
    points : list of PeriodicOrbit or Equilibrium
        In branch order; the solution at a located special point is one of them.
    special : list of SpecialPoint
        Bifurcations, changes of the mode sequence, losses of stability and ends of the branch
        (:class:`hybrid.SpecialPoint`; ``index`` is a position in ``points``).
    status : BranchStatus
        ``"completed"`` (it left the range or reached ``max_points``) or ``"stopped"``.
    reason : str
        Why a stopped branch stopped, a code of :data:`hybrid.core.status.BRANCH_REASONS`
        (``"unbounded"``, ``"stalled"``, ``"no-start"``, ``"degenerate"``, ``"budget"``,
        ``"grazing"``, ``"period-jump"``); ``""`` if completed.
    message : str
        The same in words, with the parameter value where it happened.
    options : SolverOptions or None
        The solver options it was computed with (those given to the function that computed it, or
        its default in their place); with :attr:`settings`, :attr:`params` and the range they repeat
        the computation. None where no options were used (a branch of equilibria).
    settings : ContinuationOptions or None
        The continuation options it was computed with (likewise).
    """

    kind: str
    system: HybridSystem
    params: dict
    parameter: str
    points: list = field(default_factory=list)
    special: list = field(default_factory=list)
    status: BranchStatus = BranchStatus.COMPLETED
    reason: str = ""
    message: str = ""
    options: SolverOptions | None = None
    settings: ContinuationOptions | None = None

    def __post_init__(self):
        if self.kind not in BRANCH_KINDS:
            raise InputError(f"Branch: `kind` must be one of {', '.join(BRANCH_KINDS)}, got {self.kind!r}")
        self.status = BranchStatus(self.status)

    def stop(self, reason: str, message: str) -> None:
        """Mark the branch stopped with ``reason`` (a code) and ``message``."""
        self.status, self.reason, self.message = BranchStatus.STOPPED, reason, message

    @property
    def values(self) -> np.ndarray:
        """The continued parameter's value at every point."""
        return np.array([o.params[self.parameter] for o in self.points], dtype=float)

    def amplitude(self, name: str) -> np.ndarray:
        """``max |x|`` of ``name`` at every point (an equilibrium's: ``|x|``)."""
        return np.array([_amplitudes(o)[0][name] for o in self.points], dtype=float)

    def half_peak_to_peak(self, name: str) -> np.ndarray:
        """``(max x - min x) / 2`` of ``name`` at every point (an equilibrium's: 0)."""
        return np.array([_amplitudes(o)[1][name] for o in self.points], dtype=float)

    @property
    def stability(self) -> list[str]:
        return [o.stability for o in self.points]

    def table(self) -> dict[str, list]:
        """The columns of :meth:`to_rows` (for :meth:`to_numpy`, :meth:`to_pandas`)."""
        return table_columns(self.to_rows())

    def to_rows(self) -> list[dict]:
        """One dict per point (for CSV)."""
        if self.kind == "equilibria":
            return [equilibrium_row(self.parameter, e) for e in self.points]
        return [orbit_row(self.parameter, o) for o in self.points]

    def __repr__(self) -> str:
        what = f"Branch({self.kind} of {self.system.name} in {self.parameter}"
        end = f"{self.status}" + (f" ({self.reason})" if self.reason else "")
        end += self._options_text()
        if not self.points:
            return f"{what}: no point; {end})"
        v = self.values
        kinds = [f"{s.kind}@{s.parameter:.6g}" for s in self.special[:4]]
        if len(self.special) > 4:
            kinds.append(f"+{len(self.special) - 4} more")
        return (
            f"{what}: {len(self.points)} point{'' if len(self.points) == 1 else 's'} from {v[0]:.6g} to {v[-1]:.6g}, "
            f"special: [{', '.join(kinds)}]; {end})"
        )

    def _options_text(self) -> str:
        """``"; options=SolverOptions(...), settings=ContinuationOptions(...)"`` (those set)."""
        given = [(n, getattr(self, n)) for n in ("options", "settings") if getattr(self, n) is not None]
        return "; " + ", ".join(f"{n}={options_text(v)}" for n, v in given) if given else ""


def with_options(
    branch: Branch, options: SolverOptions | None, settings: ContinuationOptions | None
) -> Branch:
    """``branch`` with the options it was computed with recorded (:attr:`Branch.options`,
    :attr:`Branch.settings`)."""
    branch.options, branch.settings = options, settings
    return branch


def _amplitudes(o) -> tuple[dict, dict]:
    """``(amplitude, half_peak_to_peak)`` of an orbit, or of an equilibrium (``|x|`` and 0 per
    variable)."""
    if isinstance(o, Equilibrium):
        names = o.system.variable_names
        return (
            {n: abs(float(x)) for n, x in zip(names, o.x, strict=True)},
            dict.fromkeys(names, 0.0),
        )
    return o.amplitude, o.half_peak_to_peak


def equilibrium_row(parameter: str, e: Equilibrium) -> dict:
    """One equilibrium of a branch as a flat dict (a CSV row): parameter, stability, state, ..."""
    row = {
        parameter: e.params[parameter],
        "stability": e.stability,
        "admissible": e.admissible,
        "converged": e.converged,
        "residual": e.residual,
        "max_real_eigenvalue": float(np.max(e.eigenvalues.real)) if e.eigenvalues.size else float("nan"),
    }
    for n, x in zip(e.system.variable_names, e.x, strict=True):
        row[n] = float(x)
    return row


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
    fractions = o.local_fractions
    for m in o.system.local_mode_names:  # every mode, so that all rows have the same columns
        row[f"fraction_{m}"] = fractions.get(m, 0.0)
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
