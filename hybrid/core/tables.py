"""Results as tables: numpy structured arrays and pandas data frames (issue 33).

Every result with rows (:class:`hybrid.Branch`, :class:`hybrid.Locus`,
:class:`hybrid.FrequencyResponse`, :class:`hybrid.Trajectory`, the :class:`~hybrid.SweepResult` of
a sweep) has ``to_numpy()`` and ``to_pandas()`` through :class:`Tabular`: one row per point, the
columns of its CSV file. pandas is optional: ``to_pandas()`` without it raises
:class:`MissingDependency` saying how to install it (``to_numpy()`` needs numpy only).

A column of numbers (``None`` for a missing one) is ``float64`` (``bool`` if every value is one), any
other a column of text (``str``); a nested dict in a row becomes columns ``key.sub``, a list its
JSON text.
"""

from __future__ import annotations

import json
import math
import numbers
from collections.abc import Iterable, Mapping

import numpy as np

from .errors import HybridError, InputError

__all__ = ["Tabular", "MissingDependency", "table_columns", "to_numpy_table", "to_pandas_table"]


class MissingDependency(HybridError, ImportError):
    """An optional dependency is not installed (an :class:`ImportError`); the message says how to
    install it."""


def _flat(row: Mapping, prefix: str = "") -> dict:
    out = {}
    for k, v in row.items():
        key = f"{prefix}{k}"
        if isinstance(v, Mapping):
            out.update(_flat(v, key + "."))
        else:
            out[key] = v
    return out


def table_columns(rows: Iterable[Mapping]) -> dict[str, list]:
    """The columns of ``rows`` (dicts), in the order their keys first appear; a row without a key
    has ``None`` there; nested dicts flattened to ``key.sub``."""
    flat = [_flat(r) for r in rows]
    names = list(dict.fromkeys(k for r in flat for k in r))
    return {n: [r.get(n) for r in flat] for n in names}


def _is_number(v) -> bool:
    return v is None or (isinstance(v, numbers.Real | np.bool_) and not isinstance(v, str))


def _column(values) -> np.ndarray:
    if isinstance(values, np.ndarray) and values.dtype.kind in "fiub":
        return values.astype(bool if values.dtype.kind == "b" else float)
    values = list(values)
    if values and all(isinstance(v, bool | np.bool_) for v in values):
        return np.array(values, dtype=bool)
    if all(_is_number(v) for v in values):
        return np.array([math.nan if v is None else float(v) for v in values], dtype=float)
    text = ["" if v is None else json.dumps(v) if isinstance(v, list | tuple) else str(v) for v in values]
    return np.array(text, dtype=str)


def to_numpy_table(columns: Mapping[str, Iterable]) -> np.ndarray:
    """A numpy structured array of ``columns`` (name -> values, all of one length): one record per
    row, ``arr["name"]`` one column."""
    cols = {str(k): _column(v) for k, v in columns.items()}
    n = {len(c) for c in cols.values()}
    if len(n) > 1:
        raise InputError(f"to_numpy: columns of different lengths: {sorted(n)}")
    size = n.pop() if n else 0
    out = np.empty(size, dtype=[(k, c.dtype) for k, c in cols.items()])
    for k, c in cols.items():
        out[k] = c
    return out


def to_pandas_table(columns: Mapping[str, Iterable]):
    """A :class:`pandas.DataFrame` of ``columns`` (the same columns as :func:`to_numpy_table`).

    Raises
    ------
    MissingDependency
        pandas is not installed.
    """
    try:
        import pandas as pd
    except ImportError:
        raise MissingDependency(
            "to_pandas() needs pandas, which is not installed: `pip install 'pandas>=2'` (from a "
            "checkout of hybrid: `pip install '.[pandas]'`), or use to_numpy(), which needs numpy only"
        ) from None
    arr = to_numpy_table(columns)
    return pd.DataFrame({name: arr[name] for name in arr.dtype.names})


class Tabular:
    """``to_numpy()`` and ``to_pandas()`` of a result whose method ``table()`` gives its columns
    (name -> values, one per row; every subclass defines it)."""

    def to_numpy(self) -> np.ndarray:
        """The result as a numpy structured array: one record per row, ``a["name"]`` a column
        (``float64`` for numbers, ``bool`` for flags, ``str`` for text)."""
        return to_numpy_table(self.table())

    def to_pandas(self):
        """The result as a :class:`pandas.DataFrame`, the columns of :meth:`to_numpy`.

        Raises
        ------
        MissingDependency
            pandas is not installed (an :class:`ImportError`; the message says how to install it).
        """
        return to_pandas_table(self.table())
