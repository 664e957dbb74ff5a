"""The elements a hybrid system is made of: :class:`Variable`, :class:`Parameter`, :class:`Mode`,
:class:`Transition` (frozen dataclasses whose expressions are strings, parsed and checked by
:class:`hybrid.HybridSystem`), and the limits on names and texts of a model."""

from __future__ import annotations

import math
import re
from collections.abc import Mapping
from dataclasses import dataclass, field
from decimal import ROUND_FLOOR, ROUND_HALF_EVEN, Decimal, localcontext
from types import MappingProxyType

from ..core.errors import InputError, ModelError

__all__ = ["Component", "Mode", "Parameter", "Transition", "Variable"]


_NAME = re.compile(r"[A-Za-z_][A-Za-z0-9_]{0,63}")


_MODE_NAME = re.compile(r"[A-Za-z_][A-Za-z0-9_+\-]{0,63}")


#: Model and preset names: they name output folders and files, so no path separators or dots.
_MODEL_NAME = re.compile(r"[A-Za-z_][A-Za-z0-9_\-]{0,63}")


MAX_TEXT = 500  # characters of a title, reference, unit, description or transition name


def _shown(name: object) -> str:
    """A name for a message: in backticks if it is short printable text, else its cut ``repr``."""
    if isinstance(name, str) and name.isprintable() and len(name) <= 64:
        return f"`{name}`"
    text = repr(name)
    return text if len(text) <= 40 else text[:37] + "..."


def _frozen_map(m: Mapping | None, what: str) -> Mapping[str, str]:
    if m is None:
        return MappingProxyType({})
    if not isinstance(m, Mapping):
        raise ModelError(f"{what} must be a mapping of names to expression strings, got {m!r}")
    return MappingProxyType(dict(m))


@dataclass(frozen=True)
class Variable:
    """A state variable.

    Attributes
    ----------
    name : str
        Identifier used in expressions.
    unit : str
        Physical unit (for documentation, CSV headers and plots).
    description : str
        One line saying what the variable is.
    """

    name: str
    unit: str = ""
    description: str = ""


#: Units that mark a parameter as an angle (a phase): its value is reduced mod 2 pi on input.
ANGLE_UNITS = frozenset({"rad", "radian", "radians"})

#: Largest angle [rad] accepted: beyond it the spacing of doubles (1.2e-10 rad at 1e6) makes the
#: angle meaningless, and a phase of 1e300 gave 2.82 J per period on the exact integrator against
#: 0.00067 J on IDA (which lost the time in ``Omega t + phi``; issue 30).
MAX_ANGLE = 1e6

_TWO_PI = Decimal("6.283185307179586476925286766559005768394338798750211641949889184615632812572417997")


def reduce_angle(value: float, domain: str = "real") -> float:
    """``value`` [rad] reduced mod 2 pi, exactly (decimal arithmetic): into (-pi, pi] for a
    parameter of domain ``real``, [0, 2 pi) otherwise ((0, 2 pi] if ``positive``)."""
    with localcontext() as ctx:
        ctx.prec = 60
        v = Decimal(value)
        n = (v / _TWO_PI).to_integral_value(rounding=ROUND_HALF_EVEN if domain == "real" else ROUND_FLOOR)
        r = float(v - n * _TWO_PI)
    if domain == "real" and r <= -math.pi:
        r += 2.0 * math.pi
    if domain == "positive" and r == 0.0:
        r = 2.0 * math.pi
    return r


@dataclass(frozen=True)
class Parameter:
    """A model parameter.

    Attributes
    ----------
    name : str
        Identifier used in expressions.
    unit : str
        Physical unit.
    description : str
        One line saying what the parameter is.
    domain : {"real", "positive", "nonnegative"}
        Values allowed; every value must also be finite.

    A parameter whose unit is an angle's (:data:`ANGLE_UNITS`) is reduced mod 2 pi on input
    (:func:`reduce_angle`), the same for every integrator; one beyond :data:`MAX_ANGLE` is refused.
    """

    name: str
    unit: str = ""
    description: str = ""
    domain: str = "real"

    def check(self, value: object) -> float:
        """Return ``value`` as a float, or raise a ValueError naming the parameter."""
        what = f"parameter `{self.name}`" + (f" ({self.description})" if self.description else "")
        if isinstance(value, bool):
            raise InputError(f"{what} must be a real number, got {value!r}")
        if not isinstance(value, int | float):
            try:
                value = float(value)  # numpy scalars, strings of numbers from a CLI
            except (TypeError, ValueError):
                raise InputError(f"{what} must be a real number, got {value!r}") from None
        value = float(value)
        if not math.isfinite(value):
            raise InputError(f"{what} must be finite, got {value!r}")
        if self.unit.strip() in ANGLE_UNITS:
            if abs(value) > MAX_ANGLE:
                raise InputError(
                    f"{what} is an angle of {value!r} rad: at most {MAX_ANGLE:g} rad is accepted (the "
                    "spacing of doubles makes a larger one meaningless); give it mod 2 pi"
                )
            value = reduce_angle(value, self.domain)
        if self.domain == "positive" and not value > 0:
            raise InputError(f"{what} must be > 0, got {value!r}")
        if self.domain == "nonnegative" and not value >= 0:
            raise InputError(f"{what} must be >= 0, got {value!r}")
        return value


@dataclass(frozen=True)
class Mode:
    """One discrete state of a hybrid system.

    Attributes
    ----------
    name : str
        Mode name (letters, digits, ``_``, ``+``, ``-``).
    derivatives : mapping of str to str
        ``{variable: expression of its time derivative}`` for the variables
        that are differential in this mode (merged over the system's shared
        ``equations``).
    algebraic : mapping of str to str
        ``{variable: residual}``: the slave variables of this mode, each fixed
        by ``0 = residual``.
    definitions : mapping of str to str
        Named expressions valid in this mode; they override the system's
        definitions of the same name.
    halt : str
        Empty for an ordinary mode. Otherwise the run may not stay in this
        mode: entering it either passes on at once through a guard already
        beyond its level, or ends the run with ``Status.HALTED`` and this
        message (e.g. a state where a discontinuous right-hand side has no
        unique continuation, see :mod:`hybrid.model.filippov`).
    """

    name: str
    derivatives: Mapping[str, str] = field(default_factory=dict)
    algebraic: Mapping[str, str] = field(default_factory=dict)
    definitions: Mapping[str, str] = field(default_factory=dict)
    halt: str = ""

    def __post_init__(self):
        if not isinstance(self.halt, str) or len(self.halt) > 4 * MAX_TEXT or not self.halt.isprintable():
            raise ModelError(f"mode `{self.name}`: `halt` must be printable text, got {self.halt!r:.60}")
        object.__setattr__(
            self, "derivatives", _frozen_map(self.derivatives, f"mode `{self.name}` derivatives")
        )
        object.__setattr__(self, "algebraic", _frozen_map(self.algebraic, f"mode `{self.name}` algebraic"))
        object.__setattr__(
            self, "definitions", _frozen_map(self.definitions, f"mode `{self.name}` definitions")
        )


@dataclass(frozen=True)
class Transition:
    """A guarded switch between two modes.

    Attributes
    ----------
    source, target : str
        Mode names.
    guard : str
        Expression whose zero crossing triggers the switch.
    direction : {-1, 0, 1}
        Crossing direction that fires: +1 rising, -1 falling, 0 either.
    name : str
        Identifier in event logs (default ``"source->target"``).
    reset : mapping of str to str
        ``{variable: expression}`` applied at the switch (other variables are
        continuous).
    """

    source: str
    target: str
    guard: str
    direction: int = 0
    name: str = ""
    reset: Mapping[str, str] = field(default_factory=dict)

    def __post_init__(self):
        if not self.name:
            object.__setattr__(self, "name", f"{self.source}->{self.target}")
        object.__setattr__(self, "reset", _frozen_map(self.reset, f"transition `{self.name}` reset"))
        if (
            isinstance(self.direction, bool)
            or not isinstance(self.direction, int)
            or self.direction not in (-1, 0, 1)
        ):
            raise ModelError(
                f"transition `{self.name}`: direction must be -1, 0 or 1, got {self.direction!r}"
            )


def _as_variables(items) -> tuple[Variable, ...]:
    out = []
    for it in items:
        out.append(it if isinstance(it, Variable) else Variable(str(it)))
    return tuple(out)


def _as_parameters(items) -> tuple[Parameter, ...]:
    out = []
    for it in items:
        out.append(it if isinstance(it, Parameter) else Parameter(str(it)))
    return tuple(out)


@dataclass(frozen=True)
class Component:
    """A part of a hybrid system with discrete states of its own: a small automaton over the
    system's shared variables.

    The system's mode is the tuple of its own mode and one local mode per component; nothing
    enumerates that product (a system of ``k`` components with three local modes each has
    ``3**k`` modes): a mode's equations are assembled from the parts when the mode is first
    entered. A component *owns* some of the system's variables: each of its local modes gives
    each owned variable either a derivative or an algebraic (slave) equation, so that the role of
    a variable may change from one local mode to another, while the system's own modes (and its
    shared ``equations``) give the variables no component owns. Its transitions switch its local
    mode alone; when one component switches, the others are checked at once against their own
    guards (see :mod:`hybrid.engine.eventloop`), so that simultaneous switches are decided for all
    components together.

    Attributes
    ----------
    name : str
        Component name (letters, digits, ``_``; unique in the system).
    modes : tuple of Mode
        Local modes; each gives an equation (``derivatives`` or ``algebraic``) for exactly the
        variables the component owns, and may add ``definitions`` visible in its own equations,
        guards and resets.
    transitions : tuple of Transition
        Guarded switches between local modes (``source`` and ``target`` name local modes); the
        guard and reset may read every variable and definition of the system.
    initial_mode : str, optional
        Local mode of the system's default initial mode (default: the first).
    description : str
        One line saying what the component is.
    """

    name: str
    modes: tuple = ()
    transitions: tuple = ()
    initial_mode: str | None = None
    description: str = ""

    def __post_init__(self):
        object.__setattr__(self, "modes", tuple(self.modes))
        object.__setattr__(self, "transitions", tuple(self.transitions))

    @property
    def mode_names(self) -> tuple[str, ...]:
        """Names of the local modes."""
        return tuple(m.name for m in self.modes)
