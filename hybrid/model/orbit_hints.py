"""The ``[orbit]`` hints of a model without forcing: where its periodic orbits are cut, and their
rough period.

* ``section``: the name of a transition. Autonomous periodic orbits are then computed on the
  Poincare section of that switch (the orbit starts just after it and ends when it fires again);
  without one, on a hyperplane through the guess orthogonal to the flow.
* ``period_guess``: an expression of the parameters [s], the time scale of the orbits (the
  transient before Newton's method and the search for the return to the section use it).
"""

from __future__ import annotations

import math
from collections.abc import Mapping

from ..core.errors import ExpressionError, ModelError
from .codegen import compile_scalar
from .expr import Expr, parse

__all__ = ["validate_hints", "period_guess"]


def validate_hints(system, pre: str) -> dict:
    """Check ``system.orbit``'s autonomous keys; ``{"section": str | None, "period_guess": Expr | None}``.

    Raises
    ------
    hybrid.ModelError
        ``section`` is not a transition's name, or ``period_guess`` is not an expression of the
        parameters.
    """
    out: dict = {"section": None, "period_guess": None}
    section = system.orbit.get("section")
    if section is not None:
        names = [tr.name for tr in system.transitions]
        if section not in names:
            raise ModelError(
                f"{pre}: [orbit] `section` = {section!r} is not a transition; transitions: {', '.join(names)}"
            )
        out["section"] = section
    guess = system.orbit.get("period_guess")
    if guess is not None:
        if not isinstance(guess, str):
            raise ModelError(f"{pre}: [orbit] `period_guess` must be an expression string, got {guess!r}")
        try:
            out["period_guess"] = parse(
                guess, {p.name for p in system.parameters}, f"{pre}: orbit period_guess"
            )
        except ExpressionError as exc:
            raise ModelError(f"{exc} (`period_guess` may use parameters only)") from None
    return out


def period_guess(system, params: Mapping[str, float]) -> float | None:
    """The model's ``[orbit] period_guess`` at ``params`` [s] (None without one).

    Raises
    ------
    ValueError
        It does not evaluate to a finite positive number.
    """
    e: Expr | None = system.parsed.autonomous["period_guess"]
    if e is None:
        return None
    try:
        value = float(compile_scalar(e, {}, params)(()))
    except (ArithmeticError, ValueError) as exc:
        raise ModelError(f"model `{system.name}`: `period_guess` cannot be evaluated: {exc}") from None
    if not (math.isfinite(value) and value > 0):
        raise ModelError(
            f"model `{system.name}`: `period_guess` evaluates to {value!r}; it must be finite and > 0"
        )
    return value
