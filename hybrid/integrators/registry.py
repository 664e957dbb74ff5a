"""The integration methods by name, for the command line's ``--integrator``: :func:`method_named`.

In Python a method is passed as an object (``SolverOptions(method=IDA(rtol=1e-9))``); the name
serves where only text is at hand (the command line, a job description, a result file).

>>> from hybrid.integrators.registry import method_named, NAMES
>>> NAMES
('ida', 'exact', 'auto')
>>> method_named("ida", rtol=1e-9)
IDA(rtol=1e-09, atol=1e-10, atol_default=1e-10, max_num_steps=50000, guard_noise=10.0)
>>> method_named("exact").noise_rtol
1e-15
"""

from __future__ import annotations

from ..core.errors import InputError
from .auto import Auto
from .base import Method
from .exact import Exact
from .ida import IDA

__all__ = ["method_named", "NAMES", "METHODS"]

#: The methods' classes by name, the default first.
METHODS: dict[str, type[Method]] = {cls.name: cls for cls in (IDA, Exact, Auto)}

#: The methods' names, the default first.
NAMES: tuple[str, ...] = tuple(METHODS)


def method_named(name: str, **settings) -> Method:
    """The method called ``name`` (one of :data:`NAMES`) with ``settings`` (its own: IDA's
    tolerances; a setting the method does not take is refused).

    Raises
    ------
    hybrid.core.errors.InputError
        An unknown name.
    hybrid.core.errors.InputTypeError
        A setting the method does not take (e.g. ``rtol`` for ``"exact"``).
    """
    try:
        cls = METHODS[name]
    except (KeyError, TypeError):
        raise InputError(f"no integration method `{name}`; methods: {', '.join(NAMES)}") from None
    return cls(**settings)
