"""The integrators by name: :func:`integrator` (``SolverOptions.integrator`` -> :class:`Integrator`).

``SolverOptions.integrator`` is a name (validated against :data:`hybrid.core.options.INTEGRATORS`,
which equals :data:`NAMES`: :mod:`hybrid.core` does not import this layer); everything that
depends on it asks the :class:`~hybrid.integrators.base.Integrator` found here.

>>> from hybrid import SolverOptions
>>> from hybrid.integrators.registry import integrator
>>> opts = SolverOptions(rtol=1e-9, integrator="exact")
>>> integ = integrator(opts.integrator)
>>> integ.exact, integ.noise_rtol(opts), integrator("ida").noise_rtol(opts)
(True, 1e-15, 1e-09)
"""

from __future__ import annotations

from ..core.errors import InputError
from .base import Integrator
from .exact import ExactIntegrator
from .ida import IDAIntegrator

__all__ = ["integrator", "NAMES", "Integrator", "IDAIntegrator", "ExactIntegrator"]

_REGISTRY: dict[str, Integrator] = {i.name: i for i in (IDAIntegrator(), ExactIntegrator())}

#: The integrators' names, the default first.
NAMES: tuple[str, ...] = tuple(_REGISTRY)


def integrator(name: str) -> Integrator:
    """The integrator called ``name`` (one of :data:`NAMES`).

    Raises
    ------
    hybrid.core.errors.InputError
        An unknown name.
    """
    try:
        return _REGISTRY[name]
    except (KeyError, TypeError):
        raise InputError(f"no integrator `{name}`; integrators: {', '.join(NAMES)}") from None
