"""Options objects as plain data and as short text, for the records of a result (issue 29 item 6).

A result (a trajectory, a periodic orbit, a branch, a frequency response, a sweep) keeps the
options objects it was computed with; :func:`plain_data` writes them into the JSON files of the
command line and :func:`options_text` into their summaries. Both walk any frozen dataclass by its
fields, a field that holds another dataclass (``newton=NewtonOptions(...)``) included, so they need
no change when an options class gains a field or a nested object.
"""

from __future__ import annotations

import enum
from collections.abc import Mapping
from dataclasses import MISSING, fields, is_dataclass

import numpy as np

__all__ = ["plain_data", "options_text", "CLASS_KEY"]

#: Key of a dataclass's class name in :func:`plain_data` (a keyword: no field can be named so).
CLASS_KEY = "class"


def _is_instance(obj) -> bool:
    return is_dataclass(obj) and not isinstance(obj, type)


def plain_data(obj):
    """``obj`` as JSON-ready data: a dataclass as ``{"class": its name, field: value, ...}`` over the
    fields its constructor takes (nested dataclasses alike), a mapping as a dict, a list or tuple as
    a list, a numpy scalar as a number, an enum as its value; None and scalars as they are.

    Parameters
    ----------
    obj : object
        E.g. a :class:`hybrid.SolverOptions`, or None.

    Returns
    -------
    object
        ``SolverOptions(method=IDA(rtol=1e-9))`` gives ``{"class": "SolverOptions", "method":
        {"class": "IDA", "rtol": 1e-09, "atol": 1e-10, ...}, "max_step": None, ...}``; each
        field's value is what the constructor was given (e.g. ``atol`` a mapping stays a mapping).

    Examples
    --------
    >>> from hybrid.core.options import NewtonOptions
    >>> plain_data(NewtonOptions(tol=1e-8))
    {'class': 'NewtonOptions', 'tol': 1e-08, 'max_iter': 30}
    """
    if _is_instance(obj):
        out = {CLASS_KEY: type(obj).__name__}
        out.update({f.name: plain_data(getattr(obj, f.name)) for f in fields(obj) if f.init})
        return out
    if isinstance(obj, enum.Enum):
        return plain_data(obj.value)
    if isinstance(obj, Mapping):
        return {str(k): plain_data(v) for k, v in obj.items()}
    if isinstance(obj, list | tuple):
        return [plain_data(v) for v in obj]
    if isinstance(obj, np.generic):
        return obj.item()
    return obj


def _default(f):
    if f.default is not MISSING:
        return f.default
    if f.default_factory is not MISSING:
        return f.default_factory()
    return MISSING


def options_text(obj) -> str:
    """A dataclass as the call that builds it, naming only the fields that differ from their
    defaults, a nested dataclass that differs as its own such call (relative to its class's
    defaults): ``SolverOptions(method=Exact())``; ``SolverOptions()`` for the
    defaults; ``repr`` of anything else.

    Examples
    --------
    >>> from hybrid.core.options import ContinuationOptions, NewtonOptions
    >>> options_text(ContinuationOptions(ds=0.01, newton=NewtonOptions(tol=1e-8, max_iter=8)))
    'ContinuationOptions(ds=0.01, newton=NewtonOptions(tol=1e-08, max_iter=8))'
    """
    if not _is_instance(obj):
        return repr(obj)
    items = []
    for f in fields(obj):
        if not f.init:
            continue
        value, default = getattr(obj, f.name), _default(f)
        if default is not MISSING and _same(value, default):
            continue
        items.append(f"{f.name}={options_text(value)}")
    return f"{type(obj).__name__}({', '.join(items)})"


def _same(a, b) -> bool:
    try:
        return bool(a == b) and type(a) is type(b)
    except (TypeError, ValueError):  # e.g. arrays
        return False
