"""Options of every computation (frozen, validated at construction), nested where they nest.

* :class:`hybrid.SolverOptions` (in :mod:`hybrid.integrators.options`, since it holds the
  integration method): one integration; every function that integrates takes it as ``options=``;
* the algorithm's own options, as ``settings=``: :class:`NewtonOptions` (one Newton iteration:
  an equilibrium, a Hopf point), :class:`ShootingOptions` (one periodic orbit: its Newton
  options, transient and samples), :class:`ContinuationOptions` (a branch: steps, special
  points, limits, and its corrector's Newton options).

A wrong value raises :class:`ValueError` naming the class, the field and the value; a keyword
that belongs in one of these objects, passed loose to a function, raises :class:`TypeError`
saying which object takes it (:func:`reject_keywords`).
"""

from __future__ import annotations

import math
import numbers
from collections.abc import Mapping
from dataclasses import MISSING, dataclass, fields, is_dataclass, replace

from .errors import InputError, InputTypeError

__all__ = [
    "check_positive",
    "plain_number",
    "NewtonOptions",
    "ShootingOptions",
    "ContinuationOptions",
    "check_samples",
    "reject_keywords",
    "MIN_SAMPLES",
]


def _plain(value):
    """A numpy scalar as the Python number it holds (``np.float32(1e-8)`` -> ``1e-08``, ``np.int64(1)``
    -> ``1``; issue 33): the checks below and every reader of an option see plain numbers. A numpy
    bool stays as it is (it is not a number here); anything else is returned unchanged."""
    if isinstance(value, numbers.Number) and type(value).__module__ == "numpy":
        return value.item()
    if isinstance(value, Mapping):
        return {k: _plain(v) for k, v in value.items()}
    return value


def plain_number(value):
    """``value`` with numpy scalars turned into the Python numbers they hold (``np.float32(1e-8)``
    -> ``1e-08``; mappings entry by entry), for options classes outside this module (issue 33)."""
    return _plain(value)


def _plain_fields(obj) -> None:
    """Every field of the frozen dataclass ``obj`` through :func:`_plain`."""
    for f in fields(obj):
        if f.init:
            v = getattr(obj, f.name)
            w = _plain(v)
            if w is not v:
                object.__setattr__(obj, f.name, w)


def _positive(name: str, value, *, allow_none: bool = False, owner: str = "SolverOptions") -> None:
    if value is None and allow_none:
        return
    if (
        isinstance(value, bool)
        or not isinstance(value, int | float)
        or not math.isfinite(value)
        or value <= 0
    ):
        raise InputError(f"{owner}: `{name}` must be a finite number > 0, got {value!r}")


def check_positive(owner: str, name: str, value, *, allow_none: bool = False) -> None:
    """Refuse ``value`` unless it is a finite number > 0 (or None, with ``allow_none``), naming the
    options class ``owner`` and the field ``name``.

    Raises
    ------
    hybrid.core.errors.InputError
    """
    _positive(name, value, allow_none=allow_none, owner=owner)


def _integer(owner: str, name: str, value, lo: int) -> None:
    if isinstance(value, bool) or not isinstance(value, int) or value < lo:
        raise InputError(f"{owner}: `{name}` must be an integer >= {lo}, got {value!r}")


def _nested(owner: str, name: str, value, cls: type) -> None:
    if not isinstance(value, cls):
        raise InputTypeError(f"{owner}: `{name}` must be a {cls.__name__}, got {type(value).__name__}")


#: Most forcing periods of a subharmonic orbit (:attr:`ShootingOptions.periods`).
MAX_SUBHARMONIC = 64

#: Fewest samples per period of an orbit's trajectory (its amplitudes are taken from the samples).
MIN_SAMPLES = 16


def check_samples(samples_per_period, owner: str = "") -> None:
    """Refuse a number of samples per period that is not an integer >= :data:`MIN_SAMPLES`
    (``owner``: the options class named in the message)."""
    if (
        isinstance(samples_per_period, bool)
        or not isinstance(samples_per_period, int)
        or samples_per_period < MIN_SAMPLES
    ):
        raise InputError(
            (f"{owner}: " if owner else "")
            + f"`samples_per_period` must be an integer >= {MIN_SAMPLES} (the amplitudes are taken from the "
            f"samples), got {samples_per_period!r}"
        )


@dataclass(frozen=True)
class NewtonOptions:
    """Tolerance and iteration cap of one Newton iteration (frozen, validated).

    What ``tol`` bounds is the iteration's own measure, given by the function that takes it:
    the residual of the period map relative to the state (periodic orbits, a continuation's
    corrector), ``max |f|`` relative to ``max(1, max |x|)`` (equilibria), the bracket's width
    relative to the parameter (:func:`hybrid.locate_hopf`'s secant).

    Attributes
    ----------
    tol : float
        Tolerance (> 0, dimensionless).
    max_iter : int
        Iterations allowed (>= 1).
    """

    tol: float = 1e-9
    max_iter: int = 30

    def __post_init__(self):
        _plain_fields(self)
        _positive("tol", self.tol, owner="NewtonOptions")
        _integer("NewtonOptions", "max_iter", self.max_iter, 1)


@dataclass(frozen=True)
class ShootingOptions:
    """Options of one periodic orbit (:func:`hybrid.periodic_orbit`, :func:`hybrid.autonomous_orbit`).

    Attributes
    ----------
    newton : NewtonOptions
        Newton's method on the period map: ``tol`` on ``max |P(x) - x| / max |x|``, ``max_iter``
        iterations (default 1e-9, 30).
    transient_periods : int
        Forcing periods (autonomous orbits: period guesses, at least 1) simulated from the guess
        before Newton's method (>= 0). ``0`` with a given ``t0``: the section is the guess itself.
    samples_per_period : int
        Samples of the returned one-period trajectory (>= :data:`MIN_SAMPLES`).
    periods : int
        Forcing periods the orbit spans (1 to :data:`MAX_SUBHARMONIC`): ``N > 1`` seeks a
        subharmonic orbit of ``N`` forcing periods, its monodromy over all ``N`` (issue 32). Forced
        models only.
    """

    newton: NewtonOptions = NewtonOptions(tol=1e-9, max_iter=30)
    transient_periods: int = 10
    samples_per_period: int = 512
    periods: int = 1

    def __post_init__(self):
        _plain_fields(self)
        _nested("ShootingOptions", "newton", self.newton, NewtonOptions)
        _integer("ShootingOptions", "transient_periods", self.transient_periods, 0)
        check_samples(self.samples_per_period, "ShootingOptions")
        _integer("ShootingOptions", "periods", self.periods, 1)
        if self.periods > MAX_SUBHARMONIC:
            raise InputError(
                f"ShootingOptions: `periods` = {self.periods!r}: a subharmonic orbit spans at most "
                f"{MAX_SUBHARMONIC} forcing periods"
            )


@dataclass(frozen=True)
class ContinuationOptions:
    """Options of a continuation (frozen, validated).

    Taken by :func:`hybrid.continue_orbits`, :func:`hybrid.frequency_response` and
    :func:`hybrid.sweep` (forced orbits) and by :func:`hybrid.orbit_branch` and
    :func:`hybrid.hopf_branch` (autonomous orbits). The defaults below are the forced branches';
    the autonomous ones default to
    :data:`hybrid.continuation.autonomous.AUTONOMOUS_CONTINUATION` (``ds_min`` 1e-6, ``ds_max``
    0.2, ``max_points`` 200, ``samples_per_period`` 256) and read only ``ds``, ``ds_min``,
    ``ds_max``, ``max_points``, ``newton`` and ``samples_per_period``.

    Forced branches step in scaled arclength: the state relative to its current size, the
    parameter relative to the width of the range ``|p_range[1] - p_range[0]|``; autonomous
    ones in the unknowns' own units (state, period, parameter).

    Attributes
    ----------
    ds, ds_min, ds_max : float
        Initial, smallest and largest step (``ds_min <= ds <= ds_max``).
    max_points : int
        Points computed at most per branch (located special points not counted).
    newton : NewtonOptions
        The corrector's Newton iteration: ``tol`` on the scaled residual of the period map,
        ``max_iter`` iterations per step (default 1e-9, 8). (A forced branch's first orbit is
        solved with the same ``tol`` and :data:`FIRST_ORBIT_MAX_ITER` iterations.)
    step_tol : float
        The corrector has converged when its scaled update is below this (or below the noise
        level of the map, ``10 cond rtol``, whichever is larger) and the residual below ``tol``.
    max_angle : float
        Largest turn [rad] of the branch's tangent (in scaled coordinates) from one point to the
        next: a sharper turn shrinks the next step, so that the curve is resolved where it bends
        (e.g. at a resonance peak), not only where the corrector needs it.
    locate : bool
        Locate special points (else they are reported ``bracketed`` by the step).
    locate_tol : float
        Accuracy of a located special point in the parameter, relative to the width of the range.
    locate_max_iter : int
        Corrector solves spent at most on locating one special point.
    max_growth : float
        A branch whose state grows by this factor over its first orbit is declared unbounded
        (``"unbounded"``): it stops there.
    max_failures : int
        Failed corrector steps in a row (each with a quarter of the step) before the branch is
        given up as stalled.
    transient_periods : int
        Periods simulated from the guess before the first orbit.
    samples_per_period : int
        Samples of each stored orbit's trajectory. The amplitudes are located on the quintic
        interpolant of the samples (its error is ``O((T/n)^6)``): with the default 64 they agree with
        those from 2048 samples to 2e-11 relative along the dampers' bands (256: 1.5e-14), at a
        quarter of the sampling cost.
    """

    ds: float = 0.02
    ds_min: float = 1e-7
    ds_max: float = 0.5
    max_points: int = 2000
    newton: NewtonOptions = NewtonOptions(tol=1e-9, max_iter=8)
    step_tol: float = 1e-9
    max_angle: float = 0.1
    locate: bool = True
    locate_tol: float = 1e-10
    locate_max_iter: int = 40
    max_growth: float = 1e6
    max_failures: int = 12
    transient_periods: int = 10
    samples_per_period: int = 64

    def __post_init__(self):
        _plain_fields(self)
        _nested("ContinuationOptions", "newton", self.newton, NewtonOptions)
        for name in ("ds", "ds_min", "ds_max", "step_tol", "locate_tol", "max_growth", "max_angle"):
            v = getattr(self, name)
            if isinstance(v, bool) or not isinstance(v, int | float) or not math.isfinite(v) or v <= 0:
                raise InputError(f"ContinuationOptions: `{name}` must be a number > 0, got {v!r}")
        if not self.ds_min <= self.ds <= self.ds_max:
            raise InputError(
                f"ContinuationOptions: need ds_min <= ds <= ds_max, got {self.ds_min}, {self.ds}, {self.ds_max}"
            )
        if self.max_growth <= 1:
            raise InputError(f"ContinuationOptions: `max_growth` must be > 1, got {self.max_growth!r}")
        check_samples(self.samples_per_period, "ContinuationOptions")
        for name in ("max_points", "locate_max_iter", "max_failures"):
            v = getattr(self, name)
            if isinstance(v, bool) or not isinstance(v, int) or v < 1:
                raise InputError(f"ContinuationOptions: `{name}` must be an integer >= 1, got {v!r}")
        v = self.transient_periods
        if isinstance(v, bool) or not isinstance(v, int) or v < 0:
            raise InputError(f"ContinuationOptions: `transient_periods` must be an integer >= 0, got {v!r}")
        if not isinstance(self.locate, bool):
            raise InputError(f"ContinuationOptions: `locate` must be True or False, got {self.locate!r}")


#: Newton iterations of a forced branch's first orbit (from its transient).
FIRST_ORBIT_MAX_ITER = 30


def _field_path(cls: type, name: str) -> list[str] | None:
    """The fields leading to ``name`` in the options class ``cls`` (``["newton", "tol"]`` for a
    field of a nested options object), or None if it has no such field."""
    for f in fields(cls):
        if f.name == name and f.init:
            return [name]
    for f in fields(cls):
        d = _default(f)
        if is_dataclass(d) and not isinstance(d, type):
            inner = _field_path(type(d), name)
            if inner is not None:
                return [f.name, *inner]
    return None


def _default(f):
    return f.default_factory() if f.default is MISSING and f.default_factory is not MISSING else f.default


def _constructor(obj, updates: Mapping) -> str:
    """``Cls(a=1, inner=Inner(b=2))``: the fields of the options object ``obj`` that differ from
    their defaults, with ``updates`` (nested by field) applied; a call that builds the object wanted."""
    cls = type(obj)
    items = []
    for f in fields(cls):
        if not f.init:
            continue
        current = getattr(obj, f.name)
        if is_dataclass(current) and not isinstance(current, type):
            nested = updates.get(f.name, {})
            if nested or current != _default(f):
                items.append(f"{f.name}={_constructor(current, nested)}")
        elif f.name in updates:
            items.append(f"{f.name}={updates[f.name]!r}")
        elif current != _default(f):
            items.append(f"{f.name}={current!r}")
    return f"{cls.__name__}({', '.join(items)})"


def reject_keywords(function: str, keywords: Mapping, **where: object) -> None:
    """Raise :class:`hybrid.core.errors.InputTypeError` (a :class:`TypeError`) for ``keywords`` that
    ``function`` does not take; its message is the fix: for the keywords that are fields of an
    options class in ``where`` (argument name -> the options object the caller passed, or the
    class), the arguments to pass instead, each one options object holding them all and what the
    caller had already set, e.g. ``options=SolverOptions(method=IDA(rtol=1e-09))``.

    An options class may take keywords that are not its fields, spelled as in earlier versions:
    it lists them in ``LOOSE_KEYWORDS`` and writes the fix itself with ``spelled_with(loose)``
    (``SolverOptions``: ``rtol=1e-9`` -> ``SolverOptions(method=IDA(rtol=1e-09))``).

    Raises
    ------
    hybrid.core.errors.InputTypeError
        If ``keywords`` is not empty.
    """
    if not keywords:
        return
    updates: dict[str, dict] = {}
    loose: dict[str, dict] = {}
    unknown = []
    for name, value in keywords.items():
        for arg, obj in where.items():
            if name in getattr(obj, "LOOSE_KEYWORDS", ()):
                loose.setdefault(arg, {})[name] = value
                break
            path = _field_path(obj if isinstance(obj, type) else type(obj), name)
            if path is not None:
                node = updates.setdefault(arg, {})
                for key in path[:-1]:
                    node = node.setdefault(key, {})
                node[path[-1]] = value
                break
        else:
            unknown.append(name)
    names = ", ".join(repr(k) for k in keywords)
    parts = []
    if updates or loose:
        fixes = []
        for arg, obj in where.items():
            if arg not in updates and arg not in loose:
                continue
            obj = obj() if isinstance(obj, type) else obj
            if arg in loose:
                obj = replace(obj, **updates.get(arg, {}))  # (the fields of such a class are flat)
                fixes.append(f"{arg}={obj.spelled_with(loose[arg])}")
            else:
                fixes.append(f"{arg}={_constructor(obj, updates[arg])}")
        fix = ", ".join(fixes)
        parts.append(f"options go in objects, not keywords: call {function}(..., {fix})")
    parts += [f"`{name}` is not an argument of {function}()" for name in unknown]
    raise InputTypeError(f"{function}() got unexpected keyword argument(s) {names}: " + "; ".join(parts))
