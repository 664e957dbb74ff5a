"""Event-driven simulation of a hybrid system: :func:`simulate`.

The input is checked here (the model, parameters, time span, initial state, sampling, sink),
the system compiled at the parameters, and the run made by the event loop of
:mod:`hybrid.engine.eventloop`, which returns a :class:`hybrid.Trajectory`.
"""

from __future__ import annotations

import math
import warnings
from collections.abc import Callable, Mapping, Sequence

import numpy as np

from ..core.callbacks import Progress
from ..core.errors import AlgebraicSolveError, InputError, InputTypeError
from ..core.notices import collected
from ..core.threads import with_blas_threads
from ..integrators.auto import resolve
from ..integrators.options import SolverOptions
from ..model.compiled import CompiledSystem
from ..model.system import HybridSystem
from .eventloop import Run, step_bound
from .record import MAX_SAMPLES, Recorder, Sink
from .sampling import check_sample_count, sample_times
from .trajectory import Trajectory

__all__ = ["simulate", "initial_state"]

#: The step bound must span at least this many float spacings of t over the run (else the steps
#: cannot be resolved: at t = 1e15 a step of a few seconds is a few spacings of 0.125 s).
RESOLVED_STEPS = 1e6
#: Smallest step bound [s]: IDA multiplies step-sized times (h x (tstop - t)), which must not underflow.
MIN_STEP = 1e-100


def initial_state(system: HybridSystem, x0, mode: str | None = None) -> np.ndarray:
    """State vector from a mapping ``{variable: value}`` or an array.

    Slave variables of ``mode`` may be omitted (they are solved), and so may
    quadratures (they start at 0); every other variable must be given.
    """
    names = system.variable_names
    if isinstance(x0, Mapping):
        unknown = [k for k in x0 if k not in names]
        if unknown:
            raise InputError(
                f"initial state names unknown variable(s) {', '.join(map(str, unknown))}; variables: {', '.join(names)}"
            )
        optional = set(system.quadratures) | (set(system.algebraic_variables(mode)) if mode else set())
        missing = [n for n in names if n not in x0 and n not in optional]
        if missing:
            raise InputError(f"initial state lacks variable(s) {', '.join(missing)}")
        y = np.array([float(x0.get(n, 0.0)) for n in names])
    else:
        y = np.array(x0, dtype=float).ravel()
        if y.size != len(names):
            raise InputError(
                f"initial state has {y.size} values; model `{system.name}` has {len(names)} variables ({', '.join(names)})"
            )
    if not np.all(np.isfinite(y)):
        bad = [n for n, v in zip(names, y, strict=True) if not math.isfinite(v)]
        raise InputError(f"initial state is not finite for {', '.join(bad)}")
    return y


@collected
def simulate(
    system: HybridSystem,
    params: Mapping[str, float],
    t_span: Sequence[float],
    x0,
    mode0: str | None = None,
    *,
    t_eval: Sequence[float] | None = None,
    samples_per_period: int | None = None,
    include_events: bool | None = None,
    options: SolverOptions | None = None,
    max_transitions: int = 1_000_000,
    throw: bool = True,
    progress: Progress | None = None,
    sink: Sink | None = None,
    keep_last: float = 0.0,
    max_kept: int | None = None,
) -> Trajectory:
    """Simulate a hybrid system, event-driven, with IDA.

    Parameters
    ----------
    system : HybridSystem
        The model.
    params : mapping of str to float
        Values of all parameters (see :meth:`HybridSystem.preset`); nothing is
        filled in silently.
    t_span : (float, float)
        Start and end time [s], ``t0 < t1``.
    x0 : mapping of str to float, or array_like, shape (n_vars,)
        Initial state. Slave variables of ``mode0`` are re-solved.
    mode0 : str, optional
        Initial mode (default: the system's ``initial_mode``). If it is not
        admissible at ``x0`` the switches it implies are taken at ``t0``.
    t_eval : array_like, optional
        Sample times in ``[t0, t1]``, increasing.
    samples_per_period : int, optional
        Sample the forcing period this many times (needs a system period).
    include_events : bool, optional
        Also sample both sides of every switch (default: when neither
        ``t_eval`` nor ``samples_per_period`` is given, then every internal
        step is sampled too).
    options : SolverOptions, optional
        Tolerances and limits.
    max_transitions : int
        Stop (status ``MAX_TRANSITIONS``) after this many switches.
    throw : bool
        Raise :class:`SimulationError` if the run stops early; otherwise the
        failure is returned as data (``status < 0``, ``success=False``).
    progress : callable, optional
        ``progress(fraction)`` with the fraction of the time span done (0..1), at most about
        200 times (:data:`hybrid.core.callbacks.Progress`).
    sink : Sink, optional
        Receives every sample (in blocks, with the outputs) and every switch
        while the run goes on (see :class:`hybrid.Sink`; e.g. CSV writers), so
        that a long run needs constant memory. The returned trajectory then
        keeps only the last ``keep_last`` seconds. Without a sink at most
        ``MAX_SAMPLES`` (2e6) samples are recorded, with one at most
        ``MAX_STREAMED_SAMPLES`` (1e9); both are checked before the run (for
        sampling on every step, against one sample per ``max_step``) and
        again while it runs (status ``MAX_SAMPLES``).
    keep_last : float
        With a ``sink``: seconds [s] at the end of the run (or before where it
        stopped) whose samples and switches the trajectory keeps; 0 keeps
        only the last sample. The trajectory still counts every switch
        (``n_transitions``) and carries the values at the start and the end
        of the run (``start_values``, ``final_values``).
    max_kept : int, optional
        With a ``sink``: at most this many samples are kept (the last ones of
        the ``keep_last`` window; default and largest ``MAX_SAMPLES``), so that
        the memory of a run sampled on every step (a model without a period)
        is bounded.

    Returns
    -------
    Trajectory

    Raises
    ------
    ValueError
        Bad input, or too many samples, before any integration.
    SimulationError
        With ``throw=True``, when the run stops early (solver failure, Zeno
        burst, no admissible mode, too many transitions).

    Examples
    --------
    A ball bouncing with restitution 0.5, dropped from 1 m:

    >>> from hybrid import HybridSystem, Mode, Transition, simulate
    >>> ball = HybridSystem(
    ...     name="ball", variables=["h", "v"], parameters=["g", "e"],
    ...     modes=[Mode("fly", derivatives={"h": "v", "v": "-g"})],
    ...     transitions=[Transition("fly", "fly", guard="h", direction=-1,
    ...                             name="impact", reset={"v": "-e*v"})],
    ... )
    >>> tr = simulate(ball, {"g": 9.81, "e": 0.5}, (0.0, 1.0), {"h": 1.0, "v": 0.0}, "fly")
    >>> round(tr.events[0].t, 6)  # sqrt(2/9.81)
    0.451524
    """
    if not isinstance(system, HybridSystem):
        raise InputTypeError(f"`system` must be a HybridSystem, got {type(system).__name__}")
    if params is None or not isinstance(params, Mapping):
        raise InputTypeError(
            "`params` must be a mapping of parameter names to values (see HybridSystem.preset)"
        )
    options = SolverOptions() if options is None else options
    if not isinstance(options, SolverOptions):
        raise InputTypeError(f"`options` must be a SolverOptions, got {type(options).__name__}")
    try:
        t0, t1 = (float(v) for v in t_span)
    except (TypeError, ValueError):
        raise InputError(f"`t_span` must be two numbers (t0, t1), got {t_span!r}") from None
    if not (math.isfinite(t0) and math.isfinite(t1) and t1 > t0):
        raise InputError(f"`t_span` must be finite with t1 > t0, got {t_span!r}")
    if isinstance(max_transitions, bool) or not isinstance(max_transitions, int) or max_transitions < 0:
        raise InputError(f"`max_transitions` must be an integer >= 0, got {max_transitions!r}")
    _check_sink(sink, keep_last)
    if max_kept is not None and (isinstance(max_kept, bool) or not isinstance(max_kept, int) or max_kept < 1):
        raise InputError(f"`max_kept` must be an integer >= 1, got {max_kept!r}")
    mode0 = mode0 if mode0 is not None else system.default_mode
    if mode0 is None:
        raise InputError(
            f"`mode0` is required: model `{system.name}` declares no initial mode; modes: {', '.join(system.mode_names)}"
        )
    system.mode(mode0)
    cs = CompiledSystem(system, params)
    options, _ = resolve(options, system, params, cs)  # Auto(): the method the model allows
    options.method.check(cs)  # a model the method cannot take is refused before the run
    y0 = initial_state(system, x0, mode0)
    samples = sample_times(t_eval, samples_per_period, cs.period, t0, t1)
    check_time_range(cs, options, t0, t1)
    check_initial_state(cs, mode0, t0, y0)
    if include_events is None:
        include_events = samples is None
    if cs.period is None and options.max_step is None and cs.depends_on_time():
        warnings.warn(
            f"model `{system.name}` depends on t but declares no forcing period; the step bound is "
            "span/50, which can step over a periodic forcing: set SolverOptions(max_step=...) or the "
            "model's `period`",
            RuntimeWarning,
            stacklevel=2,
        )
    return run_compiled(
        cs,
        options,
        t0,
        t1,
        y0,
        cs.mode_id(mode0),
        samples,
        include_events,
        max_transitions,
        throw,
        progress,
        sink=sink,
        keep_last=keep_last,
        max_kept=max_kept,
    )


@with_blas_threads
def run_compiled(
    cs: CompiledSystem,
    options: SolverOptions,
    t0: float,
    t1: float,
    y0: np.ndarray,
    mode0: int,
    samples: np.ndarray | None,
    include_events: bool,
    max_transitions: int = 1_000_000,
    throw: bool = False,
    progress: Callable[[float], None] | None = None,
    *,
    sink: Sink | None = None,
    keep_last: float = 0.0,
    outputs: bool = True,
    max_kept: int | None = None,
) -> Trajectory:
    """:func:`simulate` on an already compiled system and checked input (only the sample caps are checked).

    ``samples`` is an increasing array of sample times, or None to sample
    every internal step; ``sink``, ``keep_last`` and ``max_kept`` as in :func:`simulate`. Without ``outputs``
    the system's outputs are not evaluated (the trajectory has none, and no ``start_values`` or
    ``final_values``): a run of which only the states and switches are read, e.g. an iterate of
    Newton's method on the period map.
    """
    atol = options.method.atol_vector(cs.system.variable_names)
    run = Run(cs, options, atol, t0, t1, samples, include_events, max_transitions, progress, outputs)
    check_sample_count(samples, t1 - t0, run.max_step, streamed=sink is not None)
    recorder = Recorder(
        len(cs.names),
        cs.mode_names_of,
        run.outputs if outputs else _no_outputs,
        sink,
        keep_last,
        MAX_SAMPLES if max_kept is None else min(max_kept, MAX_SAMPLES),
    )
    try:
        return run.execute(np.asarray(y0, dtype=float), mode0, throw, recorder)
    except KeyboardInterrupt:  # the samples computed so far go to the sink (e.g. a CSV file) all the same
        if sink is not None:
            recorder.flush()
        raise


def _no_outputs(t: np.ndarray, y: np.ndarray, m: np.ndarray) -> dict[str, np.ndarray]:
    return {}


def check_time_range(cs: CompiledSystem, options: SolverOptions, t0: float, t1: float) -> None:
    """Refuse a time range whose steps cannot be resolved in floating point (``ValueError``)."""
    h = step_bound(cs, options, t0, t1)
    tmax = max(abs(t0), abs(t1))
    spacing = math.ulp(tmax)
    what = (
        f"the step bound {h:.3g} s (a sixteenth of the forcing period {cs.period:.3g} s)"
        if cs.period and not options.max_step
        else f"the step bound {h:.3g} s"
    )
    if h < MIN_STEP:
        raise InputError(
            f"{what} is below {MIN_STEP:g} s: too short to integrate in floating point "
            "(check the forcing frequency and the time scale of the model)"
        )
    if h < RESOLVED_STEPS * spacing:
        raise InputError(
            f"{what} is below {RESOLVED_STEPS:g} times the floating-point resolution of t near "
            f"t = {tmax:.3g} s ({spacing:.3g} s): the steps cannot be resolved there; start the time "
            f"span nearer 0 (e.g. shift it by a multiple of the period) or lengthen the steps"
        )


def check_initial_state(cs: CompiledSystem, mode: str, t0: float, y0: np.ndarray) -> None:
    """Refuse an initial state at which an output of ``mode`` cannot be evaluated (``ValueError``):
    the first sample would fail after the run. Failures of the equations are the run's to report."""
    cm = cs.modes[cs.mode_id(mode)]
    try:
        y = cm.solve_algebraic(t0, np.asarray(y0, dtype=float))
    except (AlgebraicSolveError, ArithmeticError, ValueError):
        return
    v = [t0, *y.tolist()]
    for o in cs.system.outputs:
        try:
            cm.outputs[o](v)
        except (ArithmeticError, ValueError) as exc:
            big = ", ".join(f"{n} = {x:.3g}" for n, x in zip(cs.names, y, strict=False) if abs(x) > 1e100)
            raise InputError(
                f"the initial state cannot be evaluated: output `{o}` of mode `{cm.name}` at t = {t0:g} "
                f"fails ({type(exc).__name__}: {exc})" + (f"; out of range: {big}" if big else "")
            ) from None


def _check_sink(sink, keep_last) -> None:
    if sink is not None and not (
        callable(getattr(sink, "samples", None)) and callable(getattr(sink, "event", None))
    ):
        raise InputTypeError(
            f"`sink` must have methods `samples` and `event` (see hybrid.Sink), got {type(sink).__name__}"
        )
    if isinstance(keep_last, bool) or not isinstance(keep_last, int | float) or not keep_last >= 0:
        raise InputError(f"`keep_last` must be a number >= 0 [s], got {keep_last!r}")
    if sink is None and keep_last != 0:
        raise InputError("`keep_last` needs a `sink`: without one the trajectory keeps every sample")
