"""The method chosen by the model: :class:`Auto` (issue 34, item 3).

``Auto`` takes the exact integrator (:class:`hybrid.integrators.exact.Exact`: matrix exponentials,
exact guard roots, no tolerances) where the model allows it at its parameters, i.e. every mode and
guard is affine in the state and time enters only through sines and cosines of harmonics of the
forcing, and IDA (:class:`hybrid.integrators.ida.IDA`, with ``Auto``'s own tolerances) otherwise.
It is resolved once per model and parameter set, before any run, by the entry points
(:func:`hybrid.simulate`, the period maps of the orbits): :func:`resolve` replaces it in the options
by the method chosen, and :meth:`Auto.choose` says which and why. It is not the default of any
function or command.

>>> from hybrid.integrators.auto import Auto
>>> import hybrid_models
>>> belt = hybrid_models.belt_stribeck()
>>> Auto(rtol=1e-9).choose(belt, belt.preset("standard")).method
IDA(rtol=1e-09, atol=1e-10, atol_default=1e-10, max_num_steps=50000, guard_noise=10.0)
>>> absorber = hybrid_models.absorber()
>>> Auto().choose(absorber, absorber.preset("standard")).method.name
'exact'
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import TYPE_CHECKING

from ..core.errors import InputError, NotAffineError
from ..model.compiled import CompiledSystem
from ..model.system import HybridSystem
from .base import Method
from .exact import Exact
from .ida import IDA

if TYPE_CHECKING:
    from .options import SolverOptions

__all__ = ["Auto", "Choice", "resolve"]


@dataclass(frozen=True)
class Choice:
    """The method :class:`Auto` chose for a model, and why (one sentence, for an output)."""

    method: Method
    reason: str

    def describe(self) -> str:
        """``"exact (every mode ...)"``: the method's name and the reason."""
        return f"{self.method.name} ({self.reason})"


#: Why the exact integrator was taken.
EXACT_REASON = (
    "every mode and guard is affine in the state and the forcing a sum of harmonics: the exact flow "
    "(matrix exponentials, exact guard roots) is exact to rounding and faster"
)


@dataclass(frozen=True, init=False)
class Auto(Method):
    """The exact integrator where the model allows it, IDA otherwise (see the module).

    Attributes
    ----------
    rtol, atol, atol_default, max_num_steps, guard_noise
        IDA's settings where IDA is chosen (:class:`hybrid.integrators.ida.IDA`, same defaults and
        checks); the exact integrator has none.
    """

    rtol: float = 1e-8
    atol: float | Mapping[str, float] = 1e-10
    atol_default: float = 1e-10
    max_num_steps: int = 50_000
    guard_noise: float = 10.0
    _ida: IDA = field(default=None, init=False, repr=False, compare=False)  # type: ignore[assignment]

    name = "auto"
    # (the chosen method's capabilities apply: Auto is replaced by it before any run)
    flows_exact = False
    needs_derivatives = True
    resolves_slaves = True
    runtime_parameters = False

    def __init__(self, **settings):
        ida = IDA(**settings)  # IDA's checks and messages (a setting it does not take is refused)
        for k in ("rtol", "atol", "atol_default", "max_num_steps", "guard_noise"):
            object.__setattr__(self, k, getattr(ida, k))
        object.__setattr__(self, "_ida", ida)

    def __hash__(self) -> int:
        return hash(("auto", self._ida))

    def __eq__(self, other) -> bool:
        return isinstance(other, Auto) and other._ida == self._ida

    def settings(self) -> dict:
        """Its settings as plain data (IDA's, named ``auto``)."""
        return {**self._ida.settings(), "name": self.name}

    @property
    def ida(self) -> IDA:
        """The IDA method taken where the exact one cannot be."""
        return self._ida

    def choose(self, system: HybridSystem, params: Mapping[str, float]) -> Choice:
        """The method for ``system`` at ``params`` (compiled at them for the test), and why."""
        return self.choose_compiled(CompiledSystem(system, params))

    def choose_compiled(self, cs: CompiledSystem) -> Choice:
        """:meth:`choose` for a compiled system (its parameters)."""
        try:
            Exact().check(cs)
        except NotAffineError as exc:
            return Choice(self._ida, f"the exact integrator cannot take it: {exc}")
        return Choice(Exact(), EXACT_REASON)

    # -- not a method of a run: resolved before any (see resolve) -----------------------------
    def _unresolved(self):
        raise InputError(
            "Auto() is resolved per model before a run (hybrid.integrators.auto.resolve); this entry "
            "point does not: pass the method it chooses, Auto().choose(system, params).method"
        )

    @property
    def noise_rtol(self) -> float:
        """IDA's ``rtol`` (the chosen method's applies to a run)."""
        return self.rtol

    def guard_band(self, atol, grad, ht, t, y, size) -> float:
        """Not defined before the method is chosen (raises InputError)."""
        self._unresolved()

    def guard_bands(self, cm, atol, t, y, size):
        """Not defined before the method is chosen (raises InputError)."""
        self._unresolved()

    def mode_solver(self, cs, mode, options, *, max_step, first_step=0.0):
        """Not defined before the method is chosen (raises InputError)."""
        self._unresolved()

    def guard_series(self, cs, mode, t, y, order):
        """Not defined before the method is chosen (raises InputError)."""
        self._unresolved()

    def variational(self, cs, s, options, max_step):
        """Not defined before the method is chosen (raises InputError)."""
        self._unresolved()


def resolve(
    options: SolverOptions,
    system: HybridSystem,
    params: Mapping[str, float],
    cs: CompiledSystem | None = None,
) -> tuple[SolverOptions, Choice | None]:
    """``options`` with an :class:`Auto` method replaced by the one it chooses for the model (and
    the choice); other options unchanged (and None). ``cs``: the model compiled at ``params``, if at
    hand (else compiled for the test)."""
    method = options.method
    if not isinstance(method, Auto):
        return options, None
    choice = method.choose_compiled(cs) if cs is not None else method.choose(system, params)
    return options.with_method(choice.method), choice
