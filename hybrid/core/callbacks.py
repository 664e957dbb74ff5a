"""The callbacks a long computation takes, one signature per name.

``progress(fraction)`` (:data:`Progress`)
    Called with the fraction of the work done, a float from 0 to 1 that never decreases (the
    time span of :func:`hybrid.simulate`, the parameter range of
    :func:`hybrid.continue_orbits` and :func:`hybrid.frequency_response`, the points of
    :func:`hybrid.sweep`). A :class:`hybrid.ProgressBar` is one.

``on_point(index, point)`` (:data:`OnPoint`)
    Called with every result as it is produced, in order, and where it belongs: a periodic
    orbit and the index of its branch in the result (:func:`hybrid.continue_orbits`: always 0;
    :func:`hybrid.frequency_response`: the index in ``FrequencyResponse.branches``), or a
    sweep's point result (the dict of its file) and its index in the grid (an int on a grid of
    one axis, a tuple of ints on several). E.g. to
    write each at once, so that an interrupted computation keeps what it did.

An exception raised by a callback propagates unchanged.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

__all__ = ["Progress", "OnPoint"]

#: ``progress(fraction)``: the fraction of the work done, 0 to 1, non-decreasing.
Progress = Callable[[float], None]

#: ``on_point(index, point)``: a result as it is produced and where it belongs (a branch's index
#: for an orbit, a grid index for a sweep's point).
OnPoint = Callable[[Any, Any], None]
