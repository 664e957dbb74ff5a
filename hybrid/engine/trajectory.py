"""Results of a simulation: :class:`Trajectory`, :class:`TransitionRecord`, :class:`Status`."""

from __future__ import annotations

import enum
from collections.abc import Mapping
from dataclasses import dataclass, field

import numpy as np

from ..core.plain import options_text
from ..core.tables import Tabular
from ..integrators.options import SolverOptions

__all__ = ["Status", "TransitionRecord", "Trajectory", "switch_groups", "switches"]


class Status(enum.IntEnum):
    """Why a simulation stopped (negative: failure)."""

    COMPLETED = 0
    SOLVER_FAILED = -1
    ZENO = -2
    NO_ADMISSIBLE_MODE = -3
    ALGEBRAIC_FAILED = -4
    MAX_TRANSITIONS = -5
    EVALUATION_FAILED = -6
    STEP_LIMIT = -7
    TIME_LIMIT = -8
    MAX_SAMPLES = -9
    HALTED = -10  # entered a mode declared `halt` (e.g. repulsive sliding of a Filippov system)


@dataclass(frozen=True)
class TransitionRecord:
    """One switch of the event log.

    Attributes
    ----------
    t : float
        Time of the switch [s].
    source, target : str
        Modes before and after.
    guard : str
        Name of the transition whose guard fired (for a chained switch at the
        same instant, the transition taken at entry of the intermediate mode).
    guard_value : float
        Value of that guard at the located state (its residual).
    x_minus, x_plus : ndarray, shape (n_vars,)
        State just before and just after (reset applied, slave variables
        re-solved in the new mode).
    chained : bool
        True if the switch was taken at entry of a mode, at the same instant
        as the previous one.
    coincident : bool
        A chained switch whose own guard reached zero at that instant too (decided within its
        noise band: e.g. two symmetric contacts stopping together), not one the previous switches
        caused (a guard they pushed beyond zero or put at zero). Only a component's transition can
        be coincident, and only where none of the instant's earlier switches is of that component:
        a system without components cannot tell, and takes every chained switch as caused. Perturbed, it moves with its own guard, so a
        monodromy matrix takes it as a switch of its own (:func:`switch_groups`).
    steps : tuple of TransitionRecord
        Empty for a transition of the event log. A *switch* of :attr:`Trajectory.switches` that
        took several transitions at one instant (through modes in which no time is spent, e.g.
        a reversal that passes through a mode held for no time) holds them here, in order; its
        ``source`` is the first one's, its ``target`` the last one's, ``guard`` the transition
        whose guard fired (issue 30).
    """

    t: float
    source: str
    target: str
    guard: str
    guard_value: float
    x_minus: np.ndarray
    x_plus: np.ndarray
    chained: bool = False
    coincident: bool = False
    steps: tuple = ()


def switch_groups(events) -> list[list[TransitionRecord]]:
    """The switches of an event log grouped by cause: a switch with the switches its new mode took
    at once as consequences (chained, not coincident), in order. A coincident switch at the same
    instant starts a group of its own."""
    groups: list[list[TransitionRecord]] = []
    for ev in events:
        if groups and ev.chained and not ev.coincident and ev.t == groups[-1][-1].t:
            groups[-1].append(ev)
        else:
            groups.append([ev])
    return groups


def switches(events) -> tuple[TransitionRecord, ...]:
    """The switches of an event log: each group of :func:`switch_groups` (a transition and the
    transitions it caused at the same instant, through modes in which no time is spent) as one
    record, from the first transition's mode and state to the last one's (issue 30: a reversal
    through a mode held for no time is one switch, not two). A group of one transition is that
    transition; a longer one holds its transitions in :attr:`TransitionRecord.steps`."""
    out = []
    for group in switch_groups(events):
        first, last = group[0], group[-1]
        if len(group) == 1:
            out.append(first)
            continue
        out.append(
            TransitionRecord(
                first.t,
                first.source,
                last.target,
                first.guard,
                first.guard_value,
                first.x_minus,
                last.x_plus,
                first.chained,
                first.coincident,
                tuple(group),
            )
        )
    return tuple(out)


@dataclass(frozen=True)
class Trajectory(Tabular):
    """A simulated trajectory of a hybrid system.

    A run streamed to a sink keeps only its last samples and switches (a
    *window* from :attr:`kept_from` to :attr:`t_final`); the counts of what it
    dropped, and the values at the start and at the end of the run, stay.

    Attributes
    ----------
    t : ndarray, shape (n,)
        Sample times [s] (of the kept window); a switch appears twice (before
        and after) when events are sampled.
    y : ndarray, shape (n, n_vars)
        All variables at the samples, time-major; a slave variable's role in a
        sample follows from its mode.
    mode : ndarray of str, shape (n,)
        Mode at each sample.
    names : tuple of str
        Variable names (columns of ``y``).
    outputs : dict of str to ndarray, shape (n,)
        The system's output definitions at the samples.
    events : tuple of TransitionRecord
        Every transition (of the kept window), in order: a switch that takes several transitions
        at one instant (through modes held for no time) appears as each of them; :attr:`switches`
        has it once.
    status : Status
    message : str
    success : bool
    nfev, njev : int
        Residual and Jacobian evaluations of IDA.
    n_steps : int
        Calls into IDA.
    params : dict of str to float
        Parameter values used.
    system : HybridSystem
        The system simulated.
    t_final : float
        Time reached.
    y_final : ndarray, shape (n_vars,)
        State at ``t_final``.
    mode_final : str
        Mode at ``t_final``.
    t_start : float
        Start of the run [s].
    mode_start : str
        Mode given at ``t_start`` (before any switch the initial state forces).
    start_values, final_values : dict of str to float, or None
        Every variable and output at ``t_start`` (after the initial state is
        made consistent and its forced switches taken) and at ``t_final``
        (slave variables re-solved), in model units; None if the run failed
        before they could be evaluated.
    samples_dropped, events_dropped : int
        Samples and switches not kept (handed to a sink only).
    kept_from : float or None
        Start of the kept window [s]; None: ``t_start`` (nothing dropped).
    kept_from_mode : str or None
        Mode at ``kept_from`` (before a switch at that instant); None: ``mode_start``.
    reason : str
        Which budget stopped the run (``Status.STEP_LIMIT``: ``"steps"`` or ``"projected"``;
        ``Status.TIME_LIMIT``: ``"time"``), ``""`` otherwise
        (:data:`hybrid.core.status.TRAJECTORY_REASONS`).
    options : SolverOptions or None
        The solver options of the run (for :func:`hybrid.simulate`: those given, or
        ``SolverOptions()`` in their place); with the same start they repeat it.
    """

    t: np.ndarray
    y: np.ndarray
    mode: np.ndarray
    names: tuple
    outputs: dict
    events: tuple
    status: Status
    message: str
    nfev: int
    njev: int
    n_steps: int
    params: Mapping[str, float]
    system: object = field(repr=False)
    t_final: float = 0.0
    y_final: np.ndarray = None
    mode_final: str = ""
    t_start: float = 0.0
    mode_start: str = ""
    start_values: Mapping[str, float] | None = None
    final_values: Mapping[str, float] | None = None
    samples_dropped: int = 0
    events_dropped: int = 0
    kept_from: float | None = None
    kept_from_mode: str | None = None
    reason: str = ""
    options: SolverOptions | None = None

    @property
    def success(self) -> bool:
        return self.status >= 0

    def __getitem__(self, name: str) -> np.ndarray:
        """A variable's or output's samples by name."""
        if name in self.names:
            return self.y[:, self.names.index(name)]
        if name in self.outputs:
            return self.outputs[name]
        raise KeyError(f"no variable or output `{name}`; have: {', '.join(self.names + tuple(self.outputs))}")

    @property
    def n_transitions(self) -> int:
        """Switches of the whole run (kept and dropped)."""
        return len(self.events) + self.events_dropped

    @property
    def switches(self) -> tuple[TransitionRecord, ...]:
        """The switches of the kept window (:func:`switches`): the transitions taken at one instant
        through modes in which no time is spent make one switch."""
        return switches(self.events)

    @property
    def n_samples(self) -> int:
        """Samples of the whole run (kept and dropped)."""
        return self.t.size + self.samples_dropped

    def final(self, name: str) -> float:
        """Value of variable ``name`` at ``t_final``."""
        return float(self.y_final[self.names.index(name)])

    def table(self) -> dict[str, np.ndarray]:
        """One row per sample: ``t``, ``mode``, every variable, every output (the columns of
        ``trajectory.csv``; for :meth:`to_numpy`, :meth:`to_pandas`)."""
        cols: dict[str, np.ndarray] = {
            "t": np.asarray(self.t, dtype=float),
            "mode": np.asarray(self.mode, dtype=str),
        }
        cols.update({n: np.asarray(self.y[:, i], dtype=float) for i, n in enumerate(self.names)})
        cols.update({k: np.asarray(v, dtype=float) for k, v in self.outputs.items() if k not in cols})
        return cols

    def mode_intervals(self) -> list[tuple[float, float, str]]:
        """``(t_start, t_end, mode)`` of every phase of the kept window, from the event log (exact switch times)."""
        out = []
        t0 = self.t_start if self.kept_from is None else self.kept_from
        m = self.mode_start if self.kept_from_mode is None else self.kept_from_mode
        for ev in self.events:
            if ev.t > t0 or not out:
                out.append((t0, ev.t, m))
            t0, m = ev.t, ev.target
        out.append((t0, self.t_final, m))
        return [iv for iv in out if iv[1] > iv[0]]

    def __repr__(self) -> str:
        return (
            f"Trajectory(status={self.status.name}, success={self.success}, message={self.message!r}, "
            f"t=[{self.t_start:g}, {self.t_final:g}], samples={self.n_samples}, transitions={self.n_transitions}, "
            f"mode_final={self.mode_final!r}, nfev={self.nfev}, njev={self.njev}, "
            f"options={options_text(self.options)})"
        )


class DeferredTrajectory:
    """An unsampled one-period run standing for the sampled one: its start, end, events, status
    and counts are the run's own; the samples (``t``, ``y``, ``mode``, ``outputs``, ``tr[name]``)
    come from the sampled run, made on first use (:meth:`materialize`)."""

    _SAMPLED = frozenset({"t", "y", "mode", "outputs", "n_samples"})

    def __init__(self, base: Trajectory, make):
        self.base = base
        self._make = make
        self._full: Trajectory | None = None

    def materialize(self) -> Trajectory:
        if self._full is None:
            self._full = self._make()
        return self._full

    def __getattr__(self, name: str):
        if name in DeferredTrajectory._SAMPLED:
            return getattr(self.materialize(), name)
        return getattr(self.base, name)

    def __getitem__(self, name: str) -> np.ndarray:
        return self.materialize()[name]


def sampled_trajectory(tr):
    return tr.materialize() if isinstance(tr, DeferredTrajectory) else tr
