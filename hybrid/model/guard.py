"""A transition's guard compiled in its source mode: :class:`CompiledGuard`."""

from __future__ import annotations

from dataclasses import dataclass

from .expr import Expr

__all__ = ["CompiledGuard"]


@dataclass(frozen=True)
class CompiledGuard:
    """A transition's guard compiled in its source mode.

    Attributes
    ----------
    index : int
        Position among the source mode's guards (its slot).
    transition : int
        Position of the transition among its part's transitions (-1: a slot that never fires).
    name : str
        The transition's name in event logs.
    target : int
        The target mode's index in the compiled system.
    direction : int
        +1 rising, -1 falling, 0 either way.
    expr : Expr
        The guard, parameters folded.
    fn : callable
        ``v -> h`` with ``v = [t, y...]``.
    grad : tuple of (int, callable)
        ``dh/dy_j`` by state index ``j``, where not identically zero.
    grad_t : callable
        ``dh/dt``.
    reset : tuple of (int, callable)
        The reset: new value of state ``i`` from ``v`` before the switch.
    reset_expr : tuple of (int, Expr)
        The reset as expressions.
    """

    index: int
    transition: int
    name: str
    target: int
    direction: int
    expr: Expr
    fn: object
    grad: tuple
    grad_t: object
    reset: tuple
    reset_expr: tuple = ()
