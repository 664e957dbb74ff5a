"""The axes of a sweep's grid: :class:`Axis`, :func:`linear_axis`, :func:`log_axis`."""

from __future__ import annotations

import math
import numbers
from dataclasses import dataclass

import numpy as np

from ..core.errors import InputError

__all__ = ["Axis", "linear_axis", "log_axis", "MAX_POINTS"]

#: Most points of one grid.
MAX_POINTS = 100_000


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
