"""The contract between the event loop (:mod:`hybrid.engine`) and an integrator of one mode's flow.

A *mode solver* integrates one compiled mode from a consistent state and stops at the first
crossing of an armed guard in its direction. Its interface (the one the event loop calls):

1. ``armed`` (bool array, one per guard of the mode) and ``safe`` (float array): a disarmed
   guard is reported as the constant ``safe`` until the loop arms it again;
2. ``start(t, y, yp)``: (re)start at a consistent point (``yp`` may be None where the solver
   does not need it);
3. ``step(tout, tstop, one_step=...) -> StepResult``: advance towards ``tout`` (one internal step
   if ``one_step``), never past ``tstop``, stopping at a crossing (status :data:`ROOT`, the
   guards in ``fired``);
4. ``interpolate(t) -> (y, yp)``: the state inside the last step;
5. ``nfev_last``, ``njev_last``: evaluations of the last call (charged to the run's budget);
6. ``dense`` (optional, default False): outputs anywhere in the last ``step`` call are exact and
   ``interpolate_many(ts)`` returns them all at once.

Status codes of a step: :data:`SUCCESS` (reached ``tout``), :data:`TSTOP` (reached ``tstop``),
:data:`ROOT` (a guard crossed); negative values are failures (IDA's flags).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

__all__ = ["StepResult", "SUCCESS", "TSTOP", "ROOT"]

SUCCESS, TSTOP, ROOT = 0, 1, 2


@dataclass
class StepResult:
    """One call of a mode solver: where it stopped and why.

    Attributes
    ----------
    status : int
        :data:`SUCCESS`, :data:`TSTOP`, :data:`ROOT`, or < 0 (a failure).
    t : float
        Where it stopped [s].
    y, yp : ndarray, shape (n,)
        State and its derivative there.
    fired : tuple of int
        Guards (indices in the mode) that crossed (status :data:`ROOT`).
    message : str
        The solver's words on a failure.
    """

    status: int
    t: float
    y: np.ndarray
    yp: np.ndarray
    fired: tuple[int, ...]
    message: str
