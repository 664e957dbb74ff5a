"""Statuses and reason codes of the results of :mod:`hybrid`, all in one place.

Every result says how its computation ended in two fields:

* ``status``: a :class:`enum.StrEnum` member. It compares equal to its value
  (``orbit.status == "converged"``), formats as it (``f"{branch.status}"`` is ``"completed"``)
  and is written to JSON and CSV as it, so the files keep their plain strings;
* ``reason``: a short code saying why, ``""`` when nothing went wrong. Code branches on it, never
  on the text of ``message`` (which says the same for a reader, with numbers and advice).

The codes each result may carry are the keys of the tables below (:data:`SOLVE_REASONS`,
:data:`BRANCH_REASONS`, :data:`RESPONSE_REASONS`, :data:`POINT_REASONS`,
:data:`TRAJECTORY_REASONS`), whose values say what each means.

* :class:`hybrid.PeriodicOrbit`, :class:`hybrid.Equilibrium`: :class:`SolveStatus`,
  :data:`SOLVE_REASONS`;
* :class:`hybrid.Branch`: :class:`BranchStatus`, :data:`BRANCH_REASONS`;
* :class:`hybrid.FrequencyResponse`: :class:`ResponseStatus`, :data:`RESPONSE_REASONS`;
* a point of :func:`hybrid.sweep`: :class:`PointStatus`, :data:`POINT_REASONS`;
* :class:`hybrid.Trajectory`: ``Status`` (an :class:`enum.IntEnum`), :data:`TRAJECTORY_REASONS`.

(A :class:`hybrid.Trajectory` keeps its integer ``Status``, which says which of its many ways a
run stopped; its ``reason`` refines the two budget statuses.)
"""

from __future__ import annotations

from enum import StrEnum

__all__ = [
    "SolveStatus",
    "BranchStatus",
    "ResponseStatus",
    "PointStatus",
    "SOLVE_REASONS",
    "BRANCH_REASONS",
    "RESPONSE_REASONS",
    "POINT_REASONS",
    "TRAJECTORY_REASONS",
    "LocateStatus",
    "SPECIAL_KINDS",
]


class SolveStatus(StrEnum):
    """How the solve of one periodic orbit or one equilibrium ended."""

    #: Newton's method met its tolerance (``reason`` is ``""``).
    CONVERGED = "converged"
    #: No solution was accepted (``reason`` says why, ``message`` in words).
    FAILED = "failed"


#: Reason codes of a :class:`hybrid.PeriodicOrbit` and a :class:`hybrid.Equilibrium`.
SOLVE_REASONS = {
    "": "converged",
    "budget": "a run's step or time budget (SolverOptions.max_steps, max_wall_time) or the computation's "
    "deadline (hybrid.time_limit) ran out",
    "grazing": "a guard crosses zero at a vanishing rate (a grazing switch): no saltation matrix, no monodromy",
    "transient-failed": "the transient from the guess, before Newton's method, failed",
    "no-section-crossing": "an autonomous orbit's transient never crossed the section's switch",
    "inconsistent-guess": "the slave variables of the guess cannot be solved from their equations",
    "run-failed": "a run of the period map failed during Newton's method",
    "monodromy-failed": "the variational equations (the monodromy matrix) failed",
    "evaluation-failed": "evaluating the model's equations failed where only the monodromy evaluates them "
    "(e.g. a division by zero in a reset's derivative)",
    "unbounded": "the response grows without bound: no bounded periodic orbit",
    "resonance": "a Floquet multiplier is 1 and the mismatch lies outside the range of I - M",
    "not-converged": "Newton's method used its iterations without meeting the tolerance",
    "no-decrease": "no decrease of the residual along Newton's direction",
    "mode-mismatch": "the mode at the end of the period differs from the section's mode",
    "uphill": "the residual met the tolerance after Newton steps accepted without a decrease: not trusted",
    "diverged": "an equilibrium's Newton iterates left the finite numbers",
    "solve-failed": "an equilibrium's Newton iteration raised (its slave variables, its Jacobian)",
    "singular": "the Jacobian is singular at the equilibrium: not an isolated one",
}


class BranchStatus(StrEnum):
    """How a :class:`hybrid.Branch` ended."""

    #: It left the parameter range or reached ``max_points`` (``reason`` is ``""``).
    COMPLETED = "completed"
    #: It ended inside the range (``reason`` says why).
    STOPPED = "stopped"


#: Reason codes of a :class:`hybrid.Branch`.
BRANCH_REASONS = {
    "": "completed: the branch left the range or reached max_points",
    "unbounded": "the response grows without bound beyond the last point (a special point 'unbounded')",
    "stalled": "the corrector failed max_failures times in a row (autonomous branches: down to ds_min)",
    "no-start": "no first orbit at the start of the range",
    "degenerate": "I - M vanishes at the first orbit: every nearby state is periodic (e.g. an unforced "
    "system at rest), so there is no branch to follow",
    "budget": "a run's budget or the computation's deadline (hybrid.time_limit) ran out",
    "grazing": "an autonomous branch met a switch it did not have, or a phase vanished (a special point "
    "'grazing'); beyond it the orbit is of another kind",
    "period-jump": "an autonomous orbit's period jumped by more than PERIOD_JUMP (a switch missed near a "
    "grazing, or an orbit of another kind): not kept",
}


class ResponseStatus(StrEnum):
    """How a :class:`hybrid.FrequencyResponse` ended."""

    #: Every part of the range is covered by a branch and every branch has a point.
    COMPLETE = "complete"
    #: Parts of the range were not computed (``reason`` says why; its ``gaps`` say where).
    INCOMPLETE = "incomplete"


#: Reason codes of a :class:`hybrid.FrequencyResponse`.
RESPONSE_REASONS = {
    "": "complete",
    "time-limit": "the deadline of hybrid.time_limit passed: what was not computed is a gap",
    "gaps": "branches stopped (see their reasons) and left parts of the range uncovered",
    "empty-branch": "a branch has no point (it found no first orbit), though the range is covered",
}


class PointStatus(StrEnum):
    """The status of one point of a :func:`hybrid.sweep` (its file's ``status``)."""

    #: Its curve covers the range.
    BOUNDED = "bounded"
    #: A branch grew without bound.
    UNBOUNDED = "unbounded"
    #: Parts of the range were not computed: the peak is a lower bound.
    INCOMPLETE = "incomplete"
    #: The computation raised (the exception is its ``message``).
    FAILED = "failed"
    #: It ran out of the per-point time limit.
    TIME_LIMIT = "time limit"


#: Reason codes of a sweep's point.
POINT_REASONS = {
    "": "bounded: the curve covers the range",
    "unbounded": "a branch grew without bound",
    "time-limit": "the per-point time limit ran out",
    "gaps": "branches stopped and left parts of the range uncovered",
    "empty-branch": "a branch has no point",
    "exception": "the computation raised: the exception is the point's message",
}


#: Reason codes of a :class:`hybrid.Trajectory` (``""`` unless a budget stopped it).
TRAJECTORY_REASONS = {
    "": "not stopped by a budget (its status says how it ended)",
    "steps": "Status.STEP_LIMIT: SolverOptions.max_steps residual evaluations were used",
    "projected": "Status.STEP_LIMIT: at its rate so far the run would need several times max_steps",
    "time": "Status.TIME_LIMIT: the wall-clock budget or the computation's deadline ran out",
}


class LocateStatus(StrEnum):
    """How well a :class:`hybrid.SpecialPoint` is known. Its ``interval`` holds the point in every
    case (of the branch as computed: the runs' integration error moves it further, which the exact
    integrator or a tighter ``rtol`` removes)."""

    #: ``parameter`` is within ``accuracy`` of the point, to the tolerance asked for
    #: (``ContinuationOptions.locate_tol``).
    LOCATED = "located"
    #: The point lies in ``interval``, which is wider than the tolerance (``description`` says why).
    BRACKETED = "bracketed"
    #: Only a side is known: ``interval`` is half-infinite (e.g. a branch that ended short of a
    #: grazing it could not reach).
    UNLOCATED = "not located"


#: The kinds of :class:`hybrid.SpecialPoint`: smooth bifurcations of periodic orbits, changes of
#: an orbit's switching (discontinuity-induced), ends of branches, and points of equilibria.
SPECIAL_KINDS = {
    "fold": "the branch turns back in the parameter (a multiplier crosses +1; a saddle-node)",
    "period-doubling": "a multiplier crosses -1 (a flip): an orbit of twice the period branches off",
    "neimark-sacker": "a complex pair of multipliers crosses the unit circle (a torus branches off)",
    "branch-point": "a multiplier crosses +1 without a fold: another branch of orbits of the same period "
    "crosses this one (a pitchfork, e.g. symmetry breaking, or a transcritical point)",
    "mode-gained": "a mode is occupied for a positive time on one side and not on the other: a phase "
    "(e.g. sticking or sliding) sets in",
    "mode-lost": "the same, the phase ends (the point is where its duration reaches zero)",
    "grazing": "the orbit's number of switches per period changes with the same modes occupied (a phase "
    "appears inside another, or an orbit touches a switch it does not take)",
    "sequence-change": "the cyclic order of the modes changes with the same modes and number of switches",
    "nonsmooth": "multipliers jump across -1 or the unit circle at a change of the mode sequence (the map "
    "is only piecewise smooth there: no smooth bifurcation is claimed)",
    "unbounded": "the response grows without bound beyond the branch's last orbit (its end)",
    "hopf": "a complex pair of an equilibrium's eigenvalues crosses the imaginary axis",
    "real-eigenvalue": "a real eigenvalue of an equilibrium crosses zero",
    "boundary-equilibrium": "an equilibrium of a mode reaches one of the mode's switching surfaces: beyond "
    "it the equilibrium is not admissible",
}
