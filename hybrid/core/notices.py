"""Warnings collected once per run of a public function: :func:`collected`.

A run of the library (a frequency response, a sweep, one orbit) may meet the same condition
hundreds of times (issue 30: ``hybrid.frequency_response`` on the tutorial's damper printed one
RuntimeWarning per guard crossing located after a step, about 150). :func:`collected` records the
warnings of the outermost public call and emits each kind once when it returns (its first text,
with how many times it occurred), so a script sees what it should act on, not a flood. Nested
public calls (a frequency response runs continuations, which solve orbits) pass their warnings to
the outermost one.
"""

from __future__ import annotations

import functools
import re
import threading
import warnings
from collections.abc import Callable
from typing import TypeVar

__all__ = ["collected", "kind_of"]

F = TypeVar("F", bound=Callable)

_state = threading.local()


def kind_of(text: str) -> str:
    """A warning's kind: its text with the numbers left out."""
    return re.sub(r"[-+]?\d[\d.e+-]*", "#", text)


def _emit(caught: list) -> None:
    groups: dict[tuple, list] = {}
    for w in caught:
        groups.setdefault((w.category, kind_of(str(w.message))), []).append(w)
    for (category, _), ws in groups.items():
        text = str(ws[0].message)
        if len(ws) > 1:
            text += f" ({len(ws)} times in this run; the first shown)"
        warnings.warn(text, category, stacklevel=3)


def collected(fn: F) -> F:
    """Decorate a public function: the warnings of a call are emitted once per kind on return
    (also when it raises), with their count; within another decorated call they go to that one."""

    @functools.wraps(fn)
    def wrapper(*args, **kwargs):
        if getattr(_state, "active", False):
            return fn(*args, **kwargs)
        _state.active = True
        caught: list = []
        try:
            with warnings.catch_warnings(record=True) as caught:
                warnings.simplefilter("always")
                return fn(*args, **kwargs)
        finally:
            _state.active = False
            _emit(caught)

    return wrapper  # type: ignore[return-value]
