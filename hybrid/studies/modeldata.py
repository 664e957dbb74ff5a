"""A model as plain data: its hash, and how it travels to worker processes and back
(:func:`model_data`, :func:`system_from_data`, :func:`model_hash`)."""

from __future__ import annotations

import hashlib
import json
from collections.abc import Mapping
from dataclasses import fields, is_dataclass

import numpy as np

from ..model.elements import Component, Mode, Parameter, Transition, Variable
from ..model.expr import Expr, from_data, to_data
from ..model.system import HybridSystem

# ----------------------------------------------------------------------------------------------
# The model as plain data: its hash, and how it travels to worker processes
#: Key of an expression in :func:`model_data` (``{EXPR_KEY: hybrid.model.expr.to_data(e)}``): a model
#: built by a front end (a Filippov system, :func:`hybrid.filippov_system`) holds expressions, not
#: text, in its modes. No name of a model can be this key.
EXPR_KEY = "$expr"

__all__ = ["model_data", "system_from_data", "model_hash", "EXPR_KEY"]


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
