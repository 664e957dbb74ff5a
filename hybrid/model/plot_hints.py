"""What a model's figures draw: its ``[plot]`` hints, with the missing ones derived from the model.

A model file need not say what to plot. The figures of :mod:`hybrid.plot.trajectory` draw
a *switching quantity* against time and against a *rate*, above the history of
the model's *coordinates*; :func:`plot_hints` finds them from the structure of
the automaton alone (variables, equations, outputs, modes and guards), and any
key the model's ``plot`` mapping gives wins over the derived one.
"""

from __future__ import annotations

from collections.abc import Mapping

from ..core.errors import ExpressionError
from .expr import free_symbols, parse
from .system import HybridSystem

__all__ = ["plot_hints", "derived_plot_hints", "unit_of"]

#: At most this many coordinates are derived (the first ones in state order).
MAX_DERIVED_COORDINATES = 6


def _names_in(text: object, known: set[str]) -> set[str]:
    """The names an expression uses (empty if it is not a valid expression)."""
    if not isinstance(text, str):
        return set()
    try:
        return free_symbols(parse(text, known, "plot hints"))
    except ExpressionError:  # pragma: no cover - the model's expressions were checked when it was built
        return set()


def _is_zero(text: object) -> bool:
    try:
        return float(str(text).strip()) == 0.0
    except ValueError:
        return False


def derived_plot_hints(system: HybridSystem) -> dict[str, object]:
    """Plot hints derived from a model's structure, ignoring its ``plot`` mapping.

    - ``displacements`` (coordinates): the non-quadrature variables, slave
      (algebraic) in no mode, whose derivative, shared or in some mode, is
      another such variable (``x' = v``); without any, the first
      non-quadrature variables. At most
      :data:`MAX_DERIVED_COORDINATES`.
    - ``velocity`` (the rate of the switching element): the first output that
      some mode defines as 0; else the first variable or output that is the
      whole guard of a transition; else the first rate variable (the ``v``
      of ``x' = v``); absent if none.
    - ``force`` (the switching quantity): the first output, other than the
      rate, that some mode redefines; else the first one a guard uses;
      absent if none (the figure then has no panels for it).
    - ``shade_modes``: the modes in which the rate is held at 0 (the output
      defined as 0, or the variable's derivative 0). A model's own ``[plot]``
      may also give patterns with ``*`` (``motion|stick|*``: every mode of a
      system with components whose first component sticks).
    - ``linear_references`` (curves drawn over a frequency response, ``{label: mode}``, see
      :func:`hybrid.model.linear.linear_response`): the initial mode, for a forced model.

    Parameters
    ----------
    system : HybridSystem

    Returns
    -------
    dict
        Keys ``displacements`` (always, non-empty), ``shade_modes`` (always),
        ``force`` and ``velocity`` (when found), ``linear_references`` (a forced model with an
        initial mode).

    Examples
    --------
    >>> from hybrid import HybridSystem, Mode, Transition
    >>> osc = HybridSystem(
    ...     name="bouncer", variables=["x", "v"], parameters=["k"], equations={"x": "v"},
    ...     modes=[Mode("up", derivatives={"v": "-k*x"}), Mode("rest", derivatives={"x": "0", "v": "0"})],
    ...     transitions=[Transition("up", "rest", "v", -1)],
    ... )
    >>> derived_plot_hints(osc)
    {'displacements': ['x'], 'velocity': 'v', 'shade_modes': ['rest']}
    """
    variables = list(system.variable_names)
    quad = set(system.quadratures)
    energy = {n for n in system.energy.values() if isinstance(n, str)}
    states = [v for v in variables if v not in quad]
    slaves = {n for m in system.modes for n in m.algebraic}
    outputs = [o for o in system.outputs if o not in energy and o not in quad]
    all_derivs = [dict(system.equations)] + [dict(m.derivatives) for m in system.modes]

    coords: list[str] = []
    rates: list[str] = []
    for x in states:
        if x in slaves:  # it follows the others (solved from them in some mode)
            continue
        for derivs in all_derivs:
            rhs = derivs.get(x)
            r = rhs.strip() if isinstance(rhs, str) else None
            if r in states and r != x:
                coords.append(x)
                if r not in rates:
                    rates.append(r)
                break
    if not coords:
        coords = states[:MAX_DERIVED_COORDINATES] or variables[:1]
    hints: dict[str, object] = {"displacements": coords[:MAX_DERIVED_COORDINATES]}

    known = set(variables) | set(system.parameter_names) | set(system.definitions) | {"t", "pi"}
    for m in system.modes:
        known |= set(m.definitions)
    guards = [str(tr.guard).strip() for tr in system.transitions]

    rate = next((o for o in outputs if any(_is_zero(m.definitions.get(o)) for m in system.modes)), None)
    if rate is None:
        rate = next((g for g in guards if g in states or g in outputs), None)
    if rate is None and rates:
        rate = rates[0]
    if rate is not None:
        hints["velocity"] = rate

    redefined = [o for o in outputs if o != rate and any(o in m.definitions for m in system.modes)]
    in_guards: set[str] = set()
    for g in guards:
        in_guards |= _names_in(g, known)
    force = next(iter(redefined), None) or next((o for o in outputs if o != rate and o in in_guards), None)
    if force is not None:
        hints["force"] = force

    shade = []
    if rate is not None:
        for m in system.modes:
            held = m.definitions.get(rate) if rate in outputs else m.derivatives.get(rate)
            if _is_zero(held):
                shade.append(m.name)
    hints["shade_modes"] = shade
    if system.default_mode is not None and system.period is not None:
        hints["linear_references"] = {f"linear: mode `{system.default_mode}`": system.default_mode}
    return hints


def plot_hints(system: HybridSystem) -> dict[str, object]:
    """The hints the figures use: the model's ``plot`` mapping, each missing key derived.

    A model that declares ``displacements`` but no ``force`` gets a derived
    ``force`` (and so on for each key); ``units`` are never derived.

    Parameters
    ----------
    system : HybridSystem

    Returns
    -------
    dict
        ``displacements`` (non-empty list), ``shade_modes`` (list), ``units``
        (mapping), ``linear_references`` (mapping of label to mode; empty for an autonomous
        model), and ``force`` and ``velocity`` if given or found.
    """
    given: Mapping = system.plot
    hints = derived_plot_hints(system)
    for key, value in given.items():
        if key in ("displacements", "shade_modes") and not value:
            continue
        hints[key] = list(value) if key in ("displacements", "shade_modes") else value
    hints.setdefault("units", {})
    hints["linear_references"] = dict(hints.get("linear_references", {})) if system.period is not None else {}
    return hints


def unit_of(system: HybridSystem, name: str) -> str:
    """The unit of a variable, parameter or output of a model (``""`` if it declares none).

    Parameters
    ----------
    system : HybridSystem
    name : str

    Returns
    -------
    str
    """
    for v in system.variables:
        if v.name == name:
            return v.unit
    for q in system.parameters:
        if q.name == name:
            return q.unit
    return str(dict(system.plot).get("units", {}).get(name, ""))
