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

import hashlib
import json
import math
import numbers
import os
import re
import socket
import stat
import time
import traceback
import warnings
from collections.abc import Callable, Mapping, Sequence
from contextlib import nullcontext
from dataclasses import dataclass, field, fields, is_dataclass
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
from ..core.plain import options_text
from ..core.status import PointStatus, ResponseStatus
from ..core.tables import Tabular, table_columns
from ..core.version import __version__
from ..core.workers import run_calls
from ..engine.io import to_json
from ..integrators.base import Method
from ..integrators.options import SolverOptions
from ..model.elements import Component, Mode, Parameter, Transition, Variable
from ..model.expr import Expr, from_data, to_data
from ..model.plot_hints import plot_hints
from ..model.system import HybridSystem

__all__ = [
    "Axis",
    "linear_axis",
    "log_axis",
    "SweepResult",
    "sweep",
    "load_sweep",
    "model_hash",
    "MANIFEST",
    "STATUSES",
    "PointStatus",
]

#: Name of the manifest in a sweep's folder.
MANIFEST = "manifest.json"
#: Version of the folder's layout (manifest and point files). 2: a point's ``reason`` is a code and
#: its ``message`` the text; the settings' Newton options nested (``settings.newton``). A folder
#: of layout 1 is still read (:func:`load_sweep`), not resumed.
LAYOUT = 2
#: Layouts :func:`load_sweep` reads.
READABLE_LAYOUTS = (1, 2)
#: Most points of one grid.
MAX_POINTS = 100_000
#: A point's status (:class:`PointStatus`): its curve covers the range (``bounded``), a branch grew
#: without bound (``unbounded``), parts of the range were not computed (``incomplete``: the peak
#: is a lower bound), the computation raised (``failed``) or ran out of the per-point limit
#: (``time limit``).
STATUSES = tuple(s.value for s in PointStatus)
#: The statuses of a point that did not finish its curve.
FAILED = (PointStatus.FAILED, PointStatus.TIME_LIMIT)
#: Continuation settings of a sweep by default: special points bracketed, not located (only the
#: peak and the stability along the curve are kept).
SWEEP_CONTINUATION = ContinuationOptions(locate=False)


# ----------------------------------------------------------------------------------------------
# The grid
@dataclass(frozen=True)
class Axis:
    """One parameter's values in a grid.

    Attributes
    ----------
    name : str
        The parameter.
    values : tuple of float
        Its values, increasing [the parameter's unit].
    spacing : {"linear", "log"}
        How they were made (:func:`linear_axis`, :func:`log_axis`).
    spec : tuple of float
        ``(start, stop, step)`` of a linear axis, ``(start, stop, num)`` of a log axis.
    """

    name: str
    values: tuple
    spacing: str = "linear"
    spec: tuple = ()

    def __post_init__(self):
        vals = tuple(float(v) for v in self.values)
        if not vals or not all(math.isfinite(v) for v in vals):
            raise InputError(f"axis `{self.name}`: needs at least one finite value, got {self.values!r}")
        if any(b <= a for a, b in zip(vals, vals[1:], strict=False)):
            raise InputError(f"axis `{self.name}`: values must increase, got {vals!r}")
        if self.spacing not in ("linear", "log"):
            raise InputError(f"axis `{self.name}`: spacing must be 'linear' or 'log', got {self.spacing!r}")
        object.__setattr__(self, "values", vals)
        object.__setattr__(self, "spec", tuple(float(v) for v in self.spec))


def _finite(name: str, what: str, v: float) -> float:
    # any real number, numpy's scalars included (np.float32, np.int64: issue 33)
    if isinstance(v, bool | np.bool_) or not isinstance(v, numbers.Real) or not math.isfinite(v):
        raise InputError(f"axis `{name}`: {what} must be a finite number, got {v!r}")
    return float(v)


def _tidy(values) -> tuple[float, ...]:
    """Values rounded to 15 significant digits (``0.3 + 3 * 0.1`` is 0.6, not 0.6000000000000001)."""
    return tuple(float(f"{float(v):.15g}") for v in values)


def linear_axis(name: str, start: float, stop: float, step: float) -> Axis:
    """``start, start + step, ...`` up to ``stop`` (included if it lies on the grid to 1e-9 step),
    each rounded to 15 significant digits.

    Parameters
    ----------
    name : str
    start, stop : float
        ``start <= stop`` [the parameter's unit].
    step : float
        ``> 0``.

    Returns
    -------
    Axis

    Raises
    ------
    ValueError
        Non-finite numbers, ``stop < start``, ``step <= 0`` or more than :data:`MAX_POINTS` values.

    Examples
    --------
    >>> linear_axis("R", 0.3, 0.8, 0.1).values
    (0.3, 0.4, 0.5, 0.6, 0.7, 0.8)
    """
    start, stop, step = (_finite(name, w, v) for w, v in (("START", start), ("STOP", stop), ("STEP", step)))
    if step <= 0:
        raise InputError(f"axis `{name}`: STEP must be > 0, got {step!r}")
    if stop < start:
        raise InputError(f"axis `{name}`: needs START <= STOP, got {start!r} > {stop!r}")
    n = (stop - start) / step
    if not n + 1 <= MAX_POINTS:  # (n may be inf: a tiny step)
        many = f"{math.floor(n) + 1}" if n < 1e9 else f"about {n:.3g}" if math.isfinite(n) else "too many"
        raise InputError(f"axis `{name}`: {many} values, more than {MAX_POINTS}")
    k = round(n)
    if abs(n - k) <= 1e-9 * max(1.0, n):
        values = np.linspace(start, stop, k + 1) if k > 0 else np.array([start])
    else:
        values = start + step * np.arange(math.floor(n) + 1)
    return Axis(name, _tidy(values), "linear", (start, stop, step))


def log_axis(name: str, start: float, stop: float, num: int) -> Axis:
    """``num`` values from ``start`` to ``stop`` (both included), equally spaced in ``log`` (to 15
    significant digits).

    Parameters
    ----------
    name : str
    start, stop : float
        ``0 < start < stop`` (or ``start == stop`` with ``num == 1``).
    num : int
        ``>= 1``.

    Returns
    -------
    Axis

    Raises
    ------
    ValueError
        Non-positive or non-finite bounds, ``stop <= start``, ``num`` not an integer >= 2.

    Examples
    --------
    >>> log_axis("c3", 0.01, 10, 4).values
    (0.01, 0.1, 1.0, 10.0)
    """
    start, stop = _finite(name, "START", start), _finite(name, "STOP", stop)
    if isinstance(num, bool) or not isinstance(num, int | np.integer) or not 2 <= num <= MAX_POINTS:
        raise InputError(f"axis `{name}`: NUM must be an integer from 2 to {MAX_POINTS}, got {num!r}")
    if not 0 < start < stop:
        raise InputError(f"axis `{name}`: a log axis needs 0 < START < STOP, got {start!r}, {stop!r}")
    values = np.geomspace(start, stop, int(num))
    values[0], values[-1] = start, stop
    return Axis(name, _tidy(values), "log", (start, stop, float(num)))


def _point_name(index: tuple[int, ...]) -> str:
    return "point-" + "-".join(f"{i:04d}" for i in index) + ".json"


#: A point file's name (its indices along the axes).
_POINT_NAME = re.compile(r"point-(\d{4,6}(?:-\d{4,6})*)\.json")


# ----------------------------------------------------------------------------------------------
# The model as plain data: its hash, and how it travels to worker processes
#: Key of an expression in :func:`model_data` (``{EXPR_KEY: hybrid.model.expr.to_data(e)}``): a model
#: built by a front end (a Filippov system, :func:`hybrid.filippov_system`) holds expressions, not
#: text, in its modes. No name of a model can be this key.
EXPR_KEY = "$expr"


def _plain(obj):
    """A dataclass (a HybridSystem and its parts) as nested dicts, lists and scalars; an expression
    as ``{EXPR_KEY: nodes}``."""
    if isinstance(obj, Expr):
        return {EXPR_KEY: to_data(obj)}
    if is_dataclass(obj) and not isinstance(obj, type):
        return {f.name: _plain(getattr(obj, f.name)) for f in fields(obj)}
    if isinstance(obj, Mapping):
        return {str(k): _plain(v) for k, v in obj.items()}
    if isinstance(obj, list | tuple):
        return [_plain(v) for v in obj]
    if isinstance(obj, np.generic):
        return obj.item()
    return obj


def model_data(system: HybridSystem) -> dict:
    """The content of a model as plain data (names, expressions, presets, hints).

    Parameters
    ----------
    system : HybridSystem

    Returns
    -------
    dict
        JSON-ready; :func:`system_from_data` builds the same system from it.
    """
    return _plain(system)


def _unplain(obj):
    """The inverse of :func:`_plain` for expressions: ``{EXPR_KEY: nodes}`` back to an Expr."""
    if isinstance(obj, Mapping):
        if len(obj) == 1 and EXPR_KEY in obj:
            return from_data(obj[EXPR_KEY])
        return {k: _unplain(v) for k, v in obj.items()}
    if isinstance(obj, list):
        return [_unplain(v) for v in obj]
    return obj


def system_from_data(data: Mapping) -> HybridSystem:
    """The :class:`HybridSystem` of :func:`model_data` (validated again).

    Raises
    ------
    ModelError
        ``data`` is not the data of a model.
    """
    d = _unplain(dict(data))
    d["variables"] = [Variable(**v) for v in d["variables"]]
    d["parameters"] = [Parameter(**p) for p in d["parameters"]]
    d["modes"] = [Mode(**m) for m in d["modes"]]
    d["transitions"] = [Transition(**t) for t in d["transitions"]]
    d["components"] = [
        Component(
            **{
                **c,
                "modes": [Mode(**m) for m in c["modes"]],
                "transitions": [Transition(**t) for t in c["transitions"]],
            }
        )
        for c in d.get("components", ())
    ]
    return HybridSystem(**d)


def _hash(data) -> str:
    return hashlib.sha256(json.dumps(data, sort_keys=True, allow_nan=False).encode()).hexdigest()


def model_hash(system: HybridSystem) -> str:
    """SHA-256 of the model's content (:func:`model_data` as canonical JSON), hex.

    Any change of an equation, guard, reset, parameter, preset or hint changes it; two loads of
    the same model file give the same hash.
    """
    return _hash(model_data(system))


# ----------------------------------------------------------------------------------------------
# One point (runs in a worker)
_SYSTEMS: dict[str, HybridSystem] = {}  # per worker process: systems by hash (compiled once)


def _system(data: Mapping, digest: str) -> HybridSystem:
    if digest not in _SYSTEMS:
        _SYSTEMS.clear()
        _SYSTEMS[digest] = system_from_data(data)
    return _SYSTEMS[digest]


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


# ----------------------------------------------------------------------------------------------
# The folder: manifest and point files
def _identity(manifest: Mapping) -> dict:
    """The entries of a manifest that fix the results (a resumed sweep must match them all)."""
    keys = ("layout", "model", "model_hash", "version", "parameter", "coordinate", "p_range")
    keys += ("axes", "params", "options", "settings", "point_time_limit")
    return {k: manifest[k] for k in keys}


def _options_dict(o) -> dict:
    """Options as plain data; a method as its settings (``{"name": "ida", "rtol": ...}``)."""
    out = {}
    for f in fields(o):
        v = getattr(o, f.name)
        out[f.name] = v.settings() if isinstance(v, Method) else _plain(v)
    return out


@dataclass
class SweepResult(Tabular):
    """A sweep's folder as read back: its manifest and the result of every finished point.

    Attributes
    ----------
    folder : Path
    manifest : dict
        Model, hash, version, axes (``name``, ``values``, ``spacing``, ``spec``), other
        parameter values, frequency range, coordinate, options.
    points : dict
        ``{index tuple: result dict}`` (:func:`run_point` plus ``index`` and ``values``).
    computed, reused : list of tuple
        Indices computed by this call of :func:`sweep`, and those found finished in the folder.
    lost : list of (tuple, str)
        Points the executor did not return (a worker died, the cluster went away) and why; they
        have no file and are computed by a resumed sweep.
    stopped : str
        Why the sweep stopped before its last point (its deadline passed), ``""`` if it did not.
    options : SolverOptions or None
        The solver options of every point, as :func:`sweep` was given them (or its default); None
        for a sweep read back by :func:`load_sweep`, whose manifest holds them as data
        (``manifest["options"]``).
    settings : ContinuationOptions or None
        The continuation options of every point (likewise; ``manifest["settings"]``).
    """

    folder: Path
    manifest: dict
    points: dict = field(default_factory=dict)
    computed: list = field(default_factory=list)
    reused: list = field(default_factory=list)
    lost: list = field(default_factory=list)
    stopped: str = ""
    options: SolverOptions | None = None
    settings: ContinuationOptions | None = None

    @property
    def axes(self) -> list[Axis]:
        return [Axis(a["name"], a["values"], a["spacing"], a["spec"]) for a in self.manifest["axes"]]

    @property
    def shape(self) -> tuple[int, ...]:
        return tuple(len(a["values"]) for a in self.manifest["axes"])

    @property
    def complete(self) -> bool:
        """Every point of the grid has a result."""
        return len(self.points) == math.prod(self.shape)

    def table(self) -> dict[str, list]:
        """One row per finished point, in grid order: ``index`` (one column per axis, e.g.
        ``index.R``), the axes' ``values`` (``values.R``) and the rest of its file (for
        :meth:`to_numpy`, :meth:`to_pandas`)."""
        names = [a["name"] for a in self.manifest["axes"]]
        rows = []
        for index in sorted(self.points):
            r = dict(self.points[index])
            r["index"] = dict(zip(names, (int(i) for i in index), strict=True))
            rows.append(r)
        return table_columns(rows)

    def counts(self) -> dict[str, int]:
        """Points per status (:data:`STATUSES`), and ``missing``."""
        out = {s: 0 for s in STATUSES}
        for r in self.points.values():
            out[r["status"]] = out.get(r["status"], 0) + 1
        out["missing"] = math.prod(self.shape) - len(self.points)
        return out

    def __repr__(self) -> str:
        m = self.manifest
        grid = " x ".join(f"{a['name']} ({len(a['values'])})" for a in m["axes"])
        counts = ", ".join(f"{v} {k}" for k, v in self.counts().items() if v)
        given = [(n, getattr(self, n)) for n in ("options", "settings") if getattr(self, n) is not None]
        opts = "; " + ", ".join(f"{n}={options_text(v)}" for n, v in given) if given else ""
        return f"SweepResult({m['model']} over {grid} in {str(self.folder)!r}: {counts}{opts})"


#: Largest manifest read [bytes] (a grid of MAX_POINTS values takes about 3 MB).
MAX_MANIFEST_BYTES = 32 * 1024 * 1024
#: Largest point file read [bytes].
MAX_POINT_BYTES = 64 * 1024 * 1024
#: The entries of a manifest every reader needs, and their types.
_MANIFEST_KEYS = {
    "layout": int,
    "model": str,
    "parameter": str,
    "coordinate": str,
    "p_range": list,
    "axes": list,
    "params": dict,
    "options": dict,
    "settings": dict,
}


class _Bad(InputError):
    """A sweep file that is not what the sweep wrote."""


def _read_json(path: Path, limit: int, what: str):
    """The JSON of a regular file of at most ``limit`` bytes (NaN and infinities refused)."""
    try:
        st = os.stat(path)
    except OSError as exc:
        raise _Bad(f"{str(path)!r} cannot be read: {exc.strerror or exc}") from None
    if not stat.S_ISREG(st.st_mode):
        kind = "a folder" if stat.S_ISDIR(st.st_mode) else "not a regular file"
        raise _Bad(f"{str(path)!r} is {kind}, not a {what}")
    if st.st_size > limit:
        raise _Bad(f"{str(path)!r} has {st.st_size} bytes, more than a {what} may ({limit})")

    def refuse(name):
        raise InputError(f"{name} is not a number JSON allows")

    try:
        with open(path, "rb") as fh:
            return json.loads(fh.read(limit + 1), parse_constant=refuse)
    except (OSError, ValueError, RecursionError) as exc:  # (JSONDecodeError is a ValueError)
        raise _Bad(f"{str(path)!r} cannot be read as a {what}: {exc}") from None


def _number(v, finite: bool = True) -> bool:
    return isinstance(v, int | float) and not isinstance(v, bool) and (not finite or math.isfinite(v))


def _check_manifest(path: Path, m) -> None:
    """Raise :class:`_Bad` naming the key if ``m`` is not a manifest a sweep wrote; the grid's size
    is checked before anything is made of it."""

    def bad(key: str, what: str):
        return _Bad(
            f"{str(path)!r}: `{key}` {what}: this is not the manifest a sweep wrote; restore it, or start "
            "the sweep again in another folder"
        )

    if not isinstance(m, dict):
        raise bad("(the whole file)", f"is a JSON {type(m).__name__}, not an object")
    if m.get("layout") not in READABLE_LAYOUTS:
        raise InputError(
            f"{str(path)!r}: sweep layout {m.get('layout')!r}, this version reads "
            + ", ".join(str(v) for v in READABLE_LAYOUTS)
        )
    for key, kind in _MANIFEST_KEYS.items():
        if key not in m:
            raise bad(key, "is missing")
        if not isinstance(m[key], kind) or (kind is int and isinstance(m[key], bool)):
            raise bad(key, f"must be a JSON {'number' if kind is int else kind.__name__}, got {m[key]!r:.60}")
    lo_hi = m["p_range"]
    if not (len(lo_hi) == 2 and all(_number(v) for v in lo_hi) and 0 < lo_hi[0] < lo_hi[1]):
        raise bad("p_range", f"must be two numbers 0 < A < B, got {lo_hi!r:.60}")
    axes = m["axes"]
    if not axes:
        raise bad("axes", "is empty")
    sizes = []
    for k, a in enumerate(axes):
        key = f"axes[{k}]"
        if not isinstance(a, dict):
            raise bad(key, f"must be an object, got {a!r:.60}")
        for sub in ("name", "values", "spacing", "spec"):
            if sub not in a:
                raise bad(f"{key}.{sub}", "is missing")
        if not isinstance(a["name"], str) or not a["name"]:
            raise bad(f"{key}.name", f"must be a parameter name, got {a['name']!r:.60}")
        vals = a["values"]
        if not isinstance(vals, list) or not vals:
            raise bad(f"{key}.values", "must be a non-empty list")
        if len(vals) > MAX_POINTS:
            raise bad(f"{key}.values", f"has {len(vals)} values, more than a sweep has ({MAX_POINTS})")
        sizes.append(len(vals))
        if math.prod(sizes) > MAX_POINTS:
            raise bad("axes", f"make a grid of more than {MAX_POINTS} points")
        if not all(_number(v) for v in vals) or any(b <= a_ for a_, b in zip(vals, vals[1:], strict=False)):
            raise bad(f"{key}.values", "must be finite numbers, increasing")
        if a["spacing"] not in ("linear", "log"):
            raise bad(f"{key}.spacing", f"must be 'linear' or 'log', got {a['spacing']!r:.60}")
        if not isinstance(a["spec"], list) or not all(_number(v) for v in a["spec"]):
            raise bad(f"{key}.spec", "must be a list of numbers")
    names = [a["name"] for a in axes]
    if len(set(names)) != len(names):
        raise bad("axes", f"name a parameter twice: {names}")


def _check_point(path: Path, r, index: tuple, axes: list) -> None:
    """Raise :class:`_Bad` naming the key if ``r`` is not the point file a sweep wrote at ``index``."""

    def bad(key: str, what: str):
        return _Bad(
            f"{str(path)!r}: `{key}` {what}: this is not a point file the sweep wrote; remove it and run "
            "the sweep again with --resume to compute the point again"
        )

    if not isinstance(r, dict):
        raise bad("(the whole file)", f"is a JSON {type(r).__name__}, not an object")
    for key in ("index", "values", "status"):
        if key not in r:
            raise bad(key, "is missing")
    if r["index"] != list(index):
        raise bad("index", f"is {r['index']!r:.60}, not {list(index)} as its name says")
    want = {a["name"]: a["values"][i] for a, i in zip(axes, index, strict=True)}
    if r["values"] != want:
        raise bad("values", f"are {r['values']!r:.80}, not the grid's {want}")
    if r["status"] not in STATUSES:
        raise bad("status", f"is {r['status']!r:.60}, not one of {', '.join(STATUSES)}")
    for key in ("peak", "peak_at"):
        v = r.get(key)
        if v is not None and not _number(v):
            raise bad(key, f"must be a finite number or null, got {v!r:.60}")
    if (
        r["status"] in (PointStatus.BOUNDED, PointStatus.INCOMPLETE)
        and r.get("peak") is None
        and r.get("curve")
    ):
        raise bad("peak", "is missing where the curve has orbits")
    for key in ("reason", "message"):
        if key in r and not isinstance(r[key], str):
            raise bad(key, f"must be text, got {r[key]!r:.60}")
    if "curve" in r and not isinstance(r["curve"], dict):
        raise bad("curve", f"must be an object, got {r['curve']!r:.60}")


def load_sweep(folder: str | Path) -> SweepResult:
    """Read a sweep's folder (the manifest and every point file), each file checked.

    Raises
    ------
    InputError
        No manifest, a manifest of another layout, or a manifest or point file that is not what a
        sweep wrote (not JSON, a value that is not a number, NaN, a key missing or of the wrong
        type, a grid larger than :data:`MAX_POINTS`, a point file whose index or values are not its
        grid point's, a folder or FIFO in place of a file, a file in the folder named like a point
        of no grid point): the message names the file and the key. Checked before any work.
    """
    folder = Path(folder)
    path = folder / MANIFEST
    if not os.path.lexists(path):
        raise InputError(
            f"{str(folder)!r} holds no sweep: no {MANIFEST} (run `hybrid sweep ... --out` first)"
        )
    manifest = _read_json(path, MAX_MANIFEST_BYTES, "sweep manifest")
    _check_manifest(path, manifest)
    res = SweepResult(folder, manifest)
    shape = res.shape
    axes = manifest["axes"]
    try:
        entries = sorted(os.scandir(folder), key=lambda e: e.name)
    except OSError as exc:
        raise InputError(f"{str(folder)!r} cannot be read: {exc.strerror or exc}") from None
    for e in entries:
        m = _POINT_NAME.fullmatch(e.name)
        if m is None:
            continue
        index = tuple(int(i) for i in m.group(1).split("-"))
        p = folder / e.name
        if len(index) != len(shape) or any(i >= n for i, n in zip(index, shape, strict=False)):
            raise _Bad(
                f"{str(p)!r} is named like a point of no grid point of this sweep ({' x '.join(map(str, shape))}): "
                "remove it"
            )
        r = _read_json(p, MAX_POINT_BYTES, "point file")
        _check_point(p, r, index, axes)
        res.points[index] = r
    return res


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
