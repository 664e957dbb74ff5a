"""Parameter sweeps: a grid of frequency-response curves, run on any executor, resumable.

:func:`sweep` computes one :func:`hybrid.frequency_response` per point of a grid of parameter
values (the product of :class:`Axis` objects) and reduces each curve to its figure of merit:
the largest amplitude (half peak-to-peak over the period) of one coordinate over the continued
branches, with the stability of the orbit there, or ``"unbounded"`` where a branch grows without
bound. The points run on any executor with ``submit(fn, *args)`` whose futures have
``add_done_callback``, ``result`` and ``exception`` (``concurrent.futures.ProcessPoolExecutor``,
a Dask ``distributed.Client``), or in the calling process without one.

Every finished point is written at once to its own JSON file in the output folder (written to a
temporary file and renamed: a file is either whole or absent), beside a ``manifest.json`` that
holds what fixes the results: the grid, the other parameter values, the frequency range, the
coordinate, the solver options, the per-point time limit, the software version and a hash of
the model's content. A sweep started again on the same folder with ``resume=True`` computes
only the points that have no file, and refuses to go on if anything in the manifest changed.

A point that raises, or whose curve runs out of its time limit (:func:`hybrid.time_limit`,
checked by every integration), is recorded with its status and reason; the sweep goes on.
Nothing here knows the model: the coordinate and the parameters are names in it.
"""

from __future__ import annotations

import json
import math
import os
import socket
import time
import traceback
import warnings
from collections.abc import Callable, Mapping, Sequence
from contextlib import nullcontext
from itertools import product
from pathlib import Path

import numpy as np

from ..continuation.branch import forcing_parameter
from ..continuation.frc import default_range, frequency_response
from ..core.budget import current_deadline, deadline_passed, limit_text, restore_deadline, time_limit
from ..core.callbacks import OnPoint, Progress
from ..core.errors import InputError, InputTypeError, ModelError
from ..core.files import FolderLock, write_atomic
from ..core.notices import collected
from ..core.options import ContinuationOptions
from ..core.status import PointStatus, ResponseStatus
from ..core.version import __version__
from ..core.workers import run_calls
from ..engine.io import to_json
from ..integrators.options import SolverOptions
from ..model.plot_hints import plot_hints
from ..model.system import HybridSystem
from .axes import MAX_POINTS, Axis, linear_axis, log_axis
from .folder import (
    _POINT_NAME,
    LAYOUT,
    MANIFEST,
    STATUSES,
    SweepResult,
    _identity,
    _options_dict,
    _point_name,
    load_sweep,
)
from .modeldata import _hash, _system, model_data, model_hash, system_from_data

__all__ = [
    "Axis",
    "linear_axis",
    "log_axis",
    "SweepResult",
    "sweep",
    "load_sweep",
    "model_hash",
    "model_data",
    "system_from_data",
    "MANIFEST",
    "STATUSES",
    "PointStatus",
]

#: The statuses of a point that did not finish its curve.
FAILED = (PointStatus.FAILED, PointStatus.TIME_LIMIT)
#: Continuation settings of a sweep by default: special points bracketed, not located (only the
#: peak and the stability along the curve are kept).
SWEEP_CONTINUATION = ContinuationOptions(locate=False)


def _curve_summary(fr, coordinate: str) -> dict:
    """Figure of merit and the curve of ``coordinate`` from a FrequencyResponse."""
    par = fr.parameter
    om, amp, stab, branch = [], [], [], []
    for k, b in enumerate(fr.branches):
        for o in b.points:
            om.append(float(o.params[par]))
            amp.append(float(o.half_peak_to_peak[coordinate]))
            stab.append(o.stability)
            branch.append(k)
    unbounded = [list(sp.interval) for b in fr.branches for sp in b.special if sp.kind == "unbounded"]
    ends = [
        (float(np.min(b.values)), float(np.max(b.values)))
        for b in fr.branches
        if b.points and b.reason == "unbounded"
    ]
    for lo, hi in fr.gaps:  # a gap bordered by a branch that grew without bound
        if any(math.isclose(e, lo, abs_tol=1e-12) or math.isclose(s, hi, abs_tol=1e-12) for s, e in ends):
            unbounded.append([float(lo), float(hi)])
    if fr.reason == "time-limit":
        status, reason = PointStatus.TIME_LIMIT, "time-limit"
    elif any(b.reason == "unbounded" for b in fr.branches):
        status, reason = PointStatus.UNBOUNDED, "unbounded"
    elif fr.status == ResponseStatus.COMPLETE:
        status, reason = PointStatus.BOUNDED, ""
    else:
        status, reason = PointStatus.INCOMPLETE, fr.reason
    out = {
        "status": status,
        "reason": reason,
        "message": "; ".join(fr.messages()),
        "peak": None,
        "peak_at": None,
        "peak_stability": None,
        "gaps": [list(g) for g in fr.gaps],
        "unbounded": unbounded,
        "branches": [
            {"points": len(b.points), "status": b.status, "reason": b.reason, "message": b.message}
            for b in fr.branches
        ],
        "curve": {par: om, "amplitude": amp, "stability": stab, "branch": branch},
    }
    if amp and status in (PointStatus.BOUNDED, PointStatus.INCOMPLETE):
        # (an unbounded response has no peak: the largest orbit computed before a branch stopped,
        # 11570 m on the tutorial's damper at R = 4 N, is no figure of merit; issue 30)
        i = int(np.argmax(amp))
        out.update(peak=amp[i], peak_at=om[i], peak_stability=stab[i])
    return out


def run_point(
    data: Mapping,
    digest: str,
    params: Mapping[str, float],
    p_range: tuple[float, float],
    coordinate: str,
    options: SolverOptions,
    settings: ContinuationOptions,
    seconds: float | None,
    deadline: tuple | None = None,
) -> dict:
    """One point of a sweep: the frequency response at ``params`` and its figure of merit.

    Runs in a worker; never raises for a failure of the computation (it is the result's
    ``status`` ``"failed"``, ``reason`` ``"exception"``, with the exception as ``message``).

    Parameters
    ----------
    data : mapping
        :func:`model_data` of the model.
    digest : str
        Its :func:`model_hash` (the worker builds each model once).
    params : mapping
        All parameter values.
    p_range : (float, float)
        Range of the forcing frequency [rad/s].
    coordinate : str
        The variable whose amplitude is the figure of merit.
    options : SolverOptions
    settings : ContinuationOptions
    seconds : float or None
        Time limit of the point [s] (None: none).
    deadline : tuple, optional
        A deadline of the caller's (:func:`hybrid.core.budget.current_deadline`) in force too;
        by default none: a deadline inherited by a forked worker is not this point's.

    Returns
    -------
    dict
        ``status`` (a :class:`PointStatus`), ``reason`` (a code of
        :data:`hybrid.core.status.POINT_REASONS`), ``message`` (the same in words: what stopped
        a branch, the gaps, the exception), ``peak`` (largest half peak-to-peak
        amplitude of ``coordinate`` [its unit], None if no orbit), ``peak_at`` (the forcing
        frequency there [rad/s]), ``peak_stability``, ``gaps`` and ``unbounded`` (intervals
        [rad/s]), ``branches``, ``curve`` (every orbit: frequency, amplitude, stability, branch),
        ``warnings``, ``seconds`` (wall time), ``cpu_seconds`` (CPU time of the worker), ``pid`` and
        ``host``.
    """
    t0, c0 = time.perf_counter(), time.process_time()
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        try:
            system = _system(data, digest)
            with restore_deadline(deadline):
                with time_limit(seconds, "--point-time-limit") if seconds is not None else nullcontext():
                    fr = frequency_response(system, params, p_range, options=options, settings=settings)
            out = _curve_summary(fr, coordinate)
        except Exception as exc:  # recorded as the point's result: the sweep goes on
            tb = traceback.extract_tb(exc.__traceback__)
            where = f" (at {tb[-1].filename}:{tb[-1].lineno})" if tb else ""
            out = {
                "status": PointStatus.FAILED,
                "reason": "exception",
                "message": f"{type(exc).__name__}: {exc}{where}",
                "peak": None,
            }
    out["warnings"] = sorted({str(w.message) for w in caught})
    out.update(seconds=time.perf_counter() - t0, cpu_seconds=time.process_time() - c0)
    out.update(pid=os.getpid(), host=socket.gethostname())
    return out


def _grid_params(system: HybridSystem, params: Mapping[str, float], axes: Sequence[Axis]) -> dict:
    """``{index: all parameter values}`` of every grid point, each checked against the model."""
    names = [a.name for a in axes]
    if len(set(names)) != len(names):
        raise InputError(f"sweep: a parameter appears on two axes: {names}")
    for a in axes:
        if a.name not in system.parameter_names:
            raise InputError(
                f"sweep: model `{system.name}` has no parameter `{a.name}`; parameters: "
                + ", ".join(system.parameter_names)
            )
    total = math.prod(len(a.values) for a in axes)
    if total > MAX_POINTS:
        raise InputError(f"sweep: the grid has {total} points, more than {MAX_POINTS}")
    out = {}
    for index in product(*(range(len(a.values)) for a in axes)):
        values = {a.name: a.values[i] for a, i in zip(axes, index, strict=True)}
        out[index] = system.parameter_values({**params, **values})  # names and domains checked
    return out


# ----------------------------------------------------------------------------------------------
@collected
def sweep(
    system: HybridSystem,
    params: Mapping[str, float],
    axes: Sequence[Axis],
    folder: str | Path,
    *,
    p_range: tuple[float, float] | None = None,
    coordinate: str | None = None,
    options: SolverOptions | None = None,
    settings: ContinuationOptions = SWEEP_CONTINUATION,
    point_time_limit: float | None = None,
    executor=None,
    resume: bool = False,
    progress: Progress | None = None,
    on_point: OnPoint | None = None,
    heartbeat: Callable[[], None] | None = None,
) -> SweepResult:
    """Frequency responses over a grid of parameter values, each point written as it finishes.

    Parameters
    ----------
    system : HybridSystem
        A periodically forced model.
    params : mapping
        Values of the parameters on no axis (those on an axis may be given: they are replaced).
    axes : sequence of Axis
        The grid is their product (first axis slowest).
    folder : str or Path
        Output folder: ``manifest.json`` and one ``point-IIII-JJJJ.json`` per point.
    p_range : (float, float), optional
        Range of the forcing frequency [rad/s] (default: the union of
        :func:`hybrid.continuation.frc.default_range` over the grid).
    coordinate : str, optional
        Variable whose amplitude is the figure of merit (default: the first coordinate of the
        model's plot hints).
    options : SolverOptions, optional
        Solver options of every curve (default ``SolverOptions()``).
    settings : ContinuationOptions, optional
        Continuation settings (default :data:`SWEEP_CONTINUATION`: special points not located).
    point_time_limit : float, optional
        Wall-clock limit of one point [s]: a point that reaches it is recorded as
        ``"time limit"`` (default: none).
    executor : object, optional
        Runs the points: ``executor.submit(fn, *args)`` returning futures with
        ``add_done_callback``, ``result`` and ``exception`` (a ``ProcessPoolExecutor``, a
        ``distributed.Client``). Default: one after the other in this process.
    resume : bool, optional
        Go on with the sweep in ``folder`` (its manifest must match this call): only the
        points without a file are computed. Without it, a folder holding a sweep is refused.
    progress : callable, optional
        ``progress(fraction)``: the fraction of the grid's points done (those found finished
        too), once before the first point is computed and after every point.
    on_point : callable, optional
        ``on_point(index, result)`` with every point computed here, as it is written (its grid
        index: an int on a grid of one axis, else a tuple of ints, one per axis; and the dict of
        its file), before ``progress`` (:mod:`hybrid.core.callbacks`).
    heartbeat : callable, optional
        With an executor: called here about once a second while points are computed (e.g. to
        check that a cluster still has workers); an exception it raises stops the sweep (the
        points finished are on disk).

    Returns
    -------
    SweepResult
        Inside a :func:`hybrid.time_limit` whose deadline passes, the sweep stops there: the
        points finished are kept, those in progress are not written (``stopped`` says so; with
        an executor, its workers are the caller's to stop).

    Raises
    ------
    ValueError
        Bad input (an unknown parameter or coordinate, an axis of the forcing frequency, a value
        outside a parameter's domain, a folder that is a file or holds another sweep, a resumed
        sweep whose manifest or files differ from what it wrote), before any run.
    TypeError
        ``options``, ``settings`` or ``executor`` of the wrong type.
    hybrid.core.errors.FolderInUse
        Another run holds the folder (:class:`hybrid.core.files.FolderLock`).
    hybrid.core.errors.OutputError
        A file cannot be written (a full disk, ...): the points finished before are on disk.

    Examples
    --------
    >>> import hybrid, tempfile
    >>> from hybrid import resolve_model
    >>> system = resolve_model("coulomb")
    >>> params = system.presets["forced"]
    >>> axis = hybrid.linear_axis("F", 0.1, 0.2, 0.1)
    >>> res = hybrid.sweep(system, params, [axis], tempfile.mkdtemp(), p_range=(0.6, 0.7))  # doctest: +SKIP
    """
    options = SolverOptions() if options is None else options
    if not isinstance(options, SolverOptions) or not isinstance(settings, ContinuationOptions):
        raise InputTypeError("sweep: `options` must be a SolverOptions and `settings` a ContinuationOptions")
    if executor is not None and not callable(getattr(executor, "submit", None)):
        raise InputTypeError(
            f"sweep: `executor` must have a method submit(fn, *args) returning futures (a "
            f"ProcessPoolExecutor, a distributed.Client), got {type(executor).__name__}"
        )
    if system.period is None:
        raise ModelError(
            f"sweep: model `{system.name}` declares no forcing `period`: periodic orbits need one"
        )
    if not axes:
        raise InputError("sweep: give at least one axis")
    if point_time_limit is not None and (
        isinstance(point_time_limit, bool)
        or not isinstance(point_time_limit, int | float)
        or not (math.isfinite(point_time_limit) and point_time_limit > 0)
    ):
        raise InputError(
            f"sweep: `point_time_limit` must be a number of seconds > 0, got {point_time_limit!r}"
        )
    if not isinstance(folder, str | os.PathLike) or not str(folder).strip():
        raise InputError(
            f"sweep: `folder` must name a folder (a str or a Path), got {folder!r}: the sweep writes its "
            "manifest and point files there"
        )
    folder = Path(folder)
    if folder.exists() and not folder.is_dir():
        raise InputError(f"sweep: {str(folder)!r} exists and is not a folder; choose another folder")
    params = dict(params)
    forcing = forcing_parameter(system)
    if any(a.name == forcing for a in axes):
        raise InputError(
            f"sweep: `{forcing}` is the forcing frequency each point's curve runs over (its range is "
            "p_range, CLI --omega-range): it cannot be an axis of the grid"
        )
    grid = _grid_params(system, params, axes)
    coords = list(plot_hints(system)["displacements"])
    if coordinate is None:
        if not coords:
            raise InputError(f"sweep: model `{system.name}` names no coordinate; give `coordinate`")
        coordinate = coords[0]
    allowed = [v for v in system.variable_names if v not in system.quadratures] + list(system.outputs)
    if coordinate not in allowed:
        why = (
            f"`{coordinate}` is a quadrature (an integral over the run, not an oscillating coordinate)"
            if coordinate in system.quadratures
            else f"model `{system.name}` has no variable or output `{coordinate}`"
        )
        raise InputError(f"sweep: {why}; coordinates: " + ", ".join(allowed))
    if p_range is None:
        ranges = [default_range(system, p) for p in grid.values()]
        p_range = (min(r[0] for r in ranges), max(r[1] for r in ranges))
    lo, hi = (float(v) for v in p_range)
    if not (math.isfinite(lo) and math.isfinite(hi) and 0 < lo < hi):
        raise InputError(f"sweep: the frequency range must satisfy 0 < A < B, got {lo!r}, {hi!r}")

    data = model_data(system)
    digest = _hash(data)
    manifest = {
        "layout": LAYOUT,
        "model": system.name,
        "model_hash": digest,
        "version": __version__,
        "parameter": forcing_parameter(system),
        "coordinate": coordinate,
        "p_range": [lo, hi],
        "axes": [
            {"name": a.name, "values": list(a.values), "spacing": a.spacing, "spec": list(a.spec)}
            for a in axes
        ],
        "params": {k: v for k, v in next(iter(grid.values())).items() if k not in {a.name for a in axes}},
        "options": _options_dict(options),
        "settings": _options_dict(settings),
        "point_time_limit": point_time_limit,
        # units of the swept parameters and of the coordinate, for the charts' labels
        "units": {
            **{q.name: q.unit for q in system.parameters if q.name in {a.name for a in axes} and q.unit},
            **{v.name: v.unit for v in system.variables if v.name == coordinate and v.unit},
        },
    }
    with FolderLock(folder, f"hybrid.sweep of `{system.name}`"):
        return _run(
            system,
            grid,
            axes,
            folder,
            manifest,
            resume,
            executor,
            progress,
            on_point,
            heartbeat,
            data,
            digest,
            (p_range, coordinate, options, settings, point_time_limit),
        )


#: Seconds between two calls of a sweep's ``heartbeat``.
HEARTBEAT = 1.0


def _run(
    system, grid, axes, folder, manifest, resume, executor, progress, on_point, heartbeat, data, digest, rest
):
    """The sweep of :func:`sweep` once its input is checked, its folder locked."""
    path = folder / MANIFEST
    if os.path.lexists(path):
        if not resume:
            raise InputError(
                f"{str(folder)!r} already holds a sweep ({MANIFEST}): resume it (--resume) or choose another folder"
            )
        old = load_sweep(folder).manifest
        if old.get("layout") != LAYOUT or any(k not in old for k in _identity(manifest)):
            raise InputError(
                f"cannot resume the sweep in {str(folder)!r}: it was written by another version of hybrid "
                f"(layout {old.get('layout')!r}, this one writes {LAYOUT}); start a new sweep in another folder"
            )
        new = json.loads(to_json(manifest))  # as it would read back
        changed = [k for k, v in _identity(new).items() if _identity(old)[k] != v]
        if changed:
            raise InputError(
                f"cannot resume the sweep in {str(folder)!r}: its "
                + ", ".join(f"`{k}`" for k in changed)
                + (" differ" if len(changed) > 1 else " differs")
                + " from this run's"
                + (" (the model changed since it started)" if "model_hash" in changed else "")
                + "; its results would not be comparable: start a new sweep in another folder"
            )
        started = old.get("started")
    elif any(_POINT_NAME.fullmatch(e.name) for e in os.scandir(folder)):
        raise InputError(
            f"{str(folder)!r} holds point files but no {MANIFEST}: their grid and model are unknown; "
            "choose another folder"
        )
    else:
        started = time.time()
    manifest["started"] = started
    write_atomic(path, to_json(manifest) + "\n")

    res = load_sweep(folder)
    res.options, res.settings = rest[2], rest[3]  # (p_range, coordinate, options, settings, limit)
    res.reused = sorted(res.points)
    todo = [i for i in grid if i not in res.points]
    total = len(grid)

    def finish(index: tuple, result: dict) -> None:
        result = {"index": list(index), "values": {a.name: grid[index][a.name] for a in axes}, **result}
        write_atomic(folder / _point_name(index), to_json(result) + "\n")
        res.points[index] = json.loads(to_json(result))
        res.computed.append(index)
        if on_point is not None:  # a one-axis grid's index as an int (issue 33), as numpy's
            on_point(index[0] if len(index) == 1 else index, res.points[index])
        if progress is not None:
            progress(len(res.points) / total)

    if progress is not None:
        progress(len(res.points) / total)
    calls = [(data, digest, grid[index], *rest) for index in todo]
    if executor is None:
        _run_here(calls, todo, finish, res)
    else:
        _run_on(executor, calls, todo, finish, res, heartbeat)
    return res


def _run_here(calls: list, todo: list, finish, res: SweepResult) -> None:
    """The points ``todo`` computed one after the other in this process (the deadline in force
    passed on to each); a point cut by the deadline is not kept."""
    deadline = current_deadline()
    for index, args in zip(todo, calls, strict=True):
        if deadline_passed():
            res.stopped = _stopped_text(len(todo) - len(res.computed))
            break
        result = run_point(*args, deadline=deadline)
        if deadline_passed() and result["status"] == PointStatus.TIME_LIMIT:
            res.stopped = _stopped_text(len(todo) - len(res.computed))  # cut by the deadline: not kept
            break
        finish(index, result)


def _run_on(executor, calls: list, todo: list, finish, res: SweepResult, heartbeat) -> None:
    """The points ``todo`` computed on ``executor`` (:func:`hybrid.core.workers.run_calls`), each
    written as it comes; a point the executor lost is recorded in ``res.lost``; the deadline in
    force stops the sweep (the points in progress dropped)."""
    beat = [time.monotonic()]

    def stop() -> bool:
        if deadline_passed():
            return True
        if heartbeat is not None and time.monotonic() - beat[0] >= HEARTBEAT:
            beat[0] = time.monotonic()
            heartbeat()
        return False

    def lost(k: int, exc: Exception) -> None:  # (a worker died, ...): no file, computed on resume
        res.lost.append((todo[k], f"{type(exc).__name__}: {exc}"))

    left = run_calls(
        executor,
        run_point,
        calls,
        on_result=lambda k, result: finish(todo[k], result),
        on_error=lost,
        stop=stop,
    )
    if left:
        res.stopped = _stopped_text(len(left))


def _stopped_text(left: int) -> str:
    return (
        f"time limit reached ({limit_text()}): {left} points not computed (those in progress dropped); "
        "--resume computes them"
    )
