"""The IDA backend: the only module that imports scikit-sundae.

One :class:`ModeSolver` per mode wraps one ``sksundae.ida.IDA`` object (the
slave-variable indices and the number of guards are fixed per object) and is
re-entered with ``init_step`` at every switch. Backend conventions (in-place
callbacks, integer flags, the event bookkeeping kept on the events function)
stay here.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from sksundae.ida import IDA

from ._compiled import CompiledMode

__all__ = ["ModeSolver", "StepResult", "SUCCESS", "TSTOP", "ROOT"]

SUCCESS, TSTOP, ROOT = 0, 1, 2


@dataclass
class StepResult:
    """One call into IDA: where it stopped and why."""

    status: int  # 0 reached tout, 1 reached tstop, 2 guard root, < 0 failure
    t: float
    y: np.ndarray
    yp: np.ndarray
    fired: tuple[int, ...]  # guards that crossed (status 2)
    message: str


class ModeSolver:
    """IDA integrator for one compiled mode.

    Parameters
    ----------
    mode : CompiledMode
        The mode's equations and guards.
    rtol, atol : float or ndarray
        Tolerances (``atol`` per variable, shape (n,)).
    max_step : float
        Bound on IDA's step (a fraction of the forcing period: without it IDA
        can step over the forcing one period at a time).
    max_num_steps : int
        Internal steps allowed per call.
    """

    def __init__(self, mode: CompiledMode, *, rtol: float, atol, max_step: float, max_num_steps: int):
        self.mode = mode
        ng = len(mode.guards)
        self.armed = np.ones(ng, dtype=bool)
        self.safe = np.zeros(ng)
        self.nfev_last = 0
        self.njev_last = 0
        self._guard_fns = [g.fn for g in mode.guards]

        def resfn(t, y, yp, res):
            mode.residual(t, y, yp, res)

        def jacfn(t, y, yp, res, cj, JJ):
            mode.jacobian(t, y, cj, JJ)

        opts = dict(
            rtol=rtol,
            atol=atol,
            max_step=max_step,
            max_num_steps=max_num_steps,
            jacfn=jacfn,
            calc_initcond=None,
        )
        if mode.alg_idx.size:
            opts["algebraic_idx"] = mode.alg_idx.tolist()
        if ng:
            armed, safe, fns = self.armed, self.safe, self._guard_fns

            def eventsfn(t, y, yp, out):
                v = [t, *y.tolist()]
                for k, fn in enumerate(fns):
                    out[k] = fn(v) if armed[k] else safe[k]

            eventsfn.terminal = [True] * ng
            eventsfn.direction = [g.direction for g in mode.guards]
            opts["eventsfn"] = eventsfn
            opts["num_events"] = ng
            self._events = eventsfn
        else:
            self._events = None
        self._ida = IDA(resfn, **opts)

    def start(self, t: float, y: np.ndarray, yp: np.ndarray) -> None:
        """(Re)initialise at a consistent point ``(t, y, y')``."""
        self._ida.init_step(float(t), np.asarray(y, dtype=float), np.asarray(yp, dtype=float))
        self.nfev_last = self.njev_last = 0

    def _clear_events(self) -> None:
        # sksundae keeps every event ever found on the events function and
        # rebuilds arrays of all of them after each call: keep it empty.
        ev = self._events
        if ev is not None:
            ev._i.clear()
            ev._t.clear()
            ev._y.clear()
            ev._yp.clear()
            ev._i_cnt[:] = 0

    def step(self, tout: float, tstop: float, *, one_step: bool) -> StepResult:
        """Advance towards ``tout`` (one internal step if ``one_step``), never past ``tstop``."""
        r = self._ida.step(float(tout), "onestep" if one_step else "normal", tstop=float(tstop))
        fired: tuple[int, ...] = ()
        if r.status == ROOT and r.i_events is not None:
            fired = tuple(int(k) for k in np.flatnonzero(r.i_events[-1]))
        self._clear_events()
        self.nfev_last, self.njev_last = int(r.nfev), int(r.njev)
        return StepResult(int(r.status), float(r.t), np.array(r.y), np.array(r.yp), fired, str(r.message))

    def interpolate(self, t: float) -> tuple[np.ndarray, np.ndarray]:
        """State at ``t`` inside the last internal step (no advance)."""
        r = self._ida.step(float(t), "normal")
        self._clear_events()
        if r.status < 0:
            raise RuntimeError(f"IDA could not interpolate at t={t!r}: {r.message}")
        return np.array(r.y), np.array(r.yp)
