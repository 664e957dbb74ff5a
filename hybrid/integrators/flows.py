"""The exact flows of a compiled system's modes: :func:`exact_flows` (every mode analysed at once
for a system without components, each assembled when first used for one with components)."""

from __future__ import annotations

from ..core.errors import NotAffineError
from ..model.compiled import CompiledSystem
from .affine import AffineMode, affine_system
from .assembly import ComposedFlows

__all__ = ["exact_flows"]


def exact_flows(cs: CompiledSystem) -> list[AffineMode]:
    """Every mode of ``cs`` as an exact affine flow (:func:`affine_system`), analysed once per
    parameter set (kept in ``cs.derived`` until its parameters change).

    Raises
    ------
    NotAffineError
        Naming the model, the first mode and the term that is not affine.
    """
    hit = cs.derived.get("exact_flows")
    if hit is None:
        try:
            hit = affine_system(cs) if cs.form is None else _composed_flows(cs)
        except ValueError as exc:
            raise type(exc)(f"model `{cs.system.name}`: {exc}") from None
        cs.derived["exact_flows"] = hit
    return hit


def _composed_flows(cs: CompiledSystem) -> ComposedFlows:
    if cs.free:
        raise NotAffineError(
            "the exact integrator does not differentiate by a parameter in the state; "
            f"free parameters: {', '.join(cs.free)}"
        )
    return ComposedFlows(cs)
