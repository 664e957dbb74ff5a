"""The extended periodic motion concept (EPMC) on a network: its free system with ``+ xi M v``.

Free motion of a friction-damped network ``M q'' + C q' + K q + f_nl = f(t)`` decays, so it has no
periodic orbit. EPMC (Krack 2015) removes the forcing and adds a negative mass-proportional damping:
``M q'' + (C - xi M) q' + K q + f_nl = 0``; at each amplitude the periodic orbit and ``xi`` are
solved for (:func:`hybrid.backbone`), and ``D = xi / (2 omega)`` is the mode's damping ratio.

:func:`epmc_network` writes the term as one damper of coefficient ``-xi*m`` from the ground to each
mass (force ``+ xi m v`` on it), so that every equation the derivation writes (momentum balances,
the stick equations of the friction elements, the massless nodes) holds it; the forces and the base
motion are removed. A structure given by matrices (``[structures]``) gets the term in its
accelerations: ``M^-1 (xi M v) = xi v``, so ``+ xi*v_X`` on each coordinate's acceleration ``acc_X``
(:attr:`hybrid_models.network_structures.NetStructure.epmc`); a Craig-Bampton reduced structure's
``M`` is the mass matrix of its reduced coordinates, so the same holds for its modal coordinates. :func:`epmc_system` derives the system and rewrites its energy quadratures: ``D``
counts the network's own dissipation only (the artificial term is taken out again), ``W`` is the
energy the artificial term puts in, ``xi * (sum m v^2 + sum v' M v)``. Over a periodic orbit the
two are equal.
"""

from __future__ import annotations

import tomllib
from collections.abc import Mapping
from dataclasses import fields, replace
from pathlib import Path

from hybrid import HybridSystem, ModelError, Variable
from hybrid.model.loader import reading_model_file

from .network_read import GROUND, Element, Network, read_network
from .network_system import network_system

__all__ = ["EPMC_PARAMETER", "epmc", "epmc_network", "epmc_system"]

#: The name of the parameter of the artificial damping [1/s].
EPMC_PARAMETER = "xi"


#: The fields of a Network this transformation covers (a part with a mass of another kind, added to
#: networks later, must get its own ``xi M v`` term before its backbone is computed).
_COVERED = {
    "name",
    "title",
    "reference",
    "masses",
    "nodes",
    "elements",
    "forces",
    "base",
    "parameters",
    "presets",
    "plot",
    "orbit",
    "origins",
    "cells",
    "contacts",  # massless: their forces act on masses, which get their term
    "structures",  # + xi v on each coordinate's acceleration (NetStructure.epmc)
}


def _paren(text: str) -> str:
    return text if text.replace("_", "a").replace(".", "0").isalnum() else f"({text})"


def _damper_name(x: str) -> str:
    return f"epmc_{x}"


def epmc_network(net: Network, parameter: str = EPMC_PARAMETER) -> Network:
    """``net`` free (no forces, no base motion) with ``+ parameter M v`` on its masses and structures.

    A damper ``-parameter*m`` from the ground to each mass; ``+ parameter*v_X`` on the acceleration
    of each coordinate of a structure (``M^-1 (parameter M v)``).

    Parameters
    ----------
    net : Network
    parameter : str
        Name of the artificial damping's parameter [1/s] (added).

    Returns
    -------
    Network
        Named ``NAME_epmc``.

    Raises
    ------
    ModelError
        The network already has a parameter, or an item, of a name this adds.
    """
    extra = [f.name for f in fields(net) if f.name not in _COVERED and getattr(net, f.name)]
    if extra:
        raise ModelError(
            f"network `{net.name}` has {', '.join(extra)}: the EPMC transformation writes + xi M v for point "
            "masses and structures only, so its backbone would miss the term of those parts' masses; "
            "not supported yet"
        )
    taken = set(net.parameters) | set(net.masses) | set(net.nodes) | {e.name for e in net.elements}
    taken |= {v for _, v, _ in net.masses.values()} | {f.name for f in net.forces}
    taken |= set(net.structures) | set(net.coords) | set(net.coords.values())
    added = {parameter} | {_damper_name(x) for x in net.masses}
    clash = sorted(added & taken)
    if clash:
        raise ModelError(
            f"network `{net.name}`: the name(s) {', '.join(clash[:6])} are added by the EPMC transformation "
            "(the artificial damping's parameter and its dampers epmc_X); rename them in the file"
        )
    dampers = tuple(
        Element("damper", _damper_name(x), GROUND, x, f"-{parameter}*{_paren(m)}")
        for x, (m, _, _) in net.masses.items()
    )
    params = dict(net.parameters)
    params[parameter] = {
        "unit": "1/s",
        "description": "artificial negative mass-proportional damping of EPMC (solved for)",
        "domain": "real",
    }
    plot = net.plot
    return replace(
        net,
        name=f"{net.name}_epmc",
        title=f"{net.title} (free, with the EPMC term + {parameter} M v)" if net.title else net.title,
        elements=net.elements + dampers,
        forces=(),
        base=None,
        parameters=params,
        presets={k: {**v, parameter: 0.0} for k, v in net.presets.items()},
        plot=plot,
        structures={k: replace(s, epmc=parameter) for k, s in net.structures.items()},
    )


def epmc_system(source, parameter: str = EPMC_PARAMETER) -> HybridSystem:
    """The EPMC system of a network: free, ``+ xi m v`` on each mass, ``D`` and ``W`` rewritten.

    Parameters
    ----------
    source : Network, mapping or path
        A validated network, the parsed content of a network file, or its path.
    parameter : str
        Name of the artificial damping's parameter [1/s].

    Returns
    -------
    HybridSystem
        As :func:`hybrid_models.network_system` of :func:`epmc_network`, with ``D`` the energy
        dissipated by the network's friction elements and dampers [J] and ``W`` the energy the
        artificial term puts in, ``xi * (sum m v^2 + sum v' M v)`` integrated [J] (quadratures).

    Raises
    ------
    ModelError
        Not a network file, or a name clash (see :func:`epmc_network`).

    Examples
    --------
    >>> sys = epmc_system("models/jenkins_oscillator.toml")
    >>> sys.name, sys.period, "xi" in sys.parameter_names
    ('jenkins_oscillator_epmc', None, True)
    """
    net = _network(source)
    free = epmc_network(net, parameter)
    system = network_system(free)
    eq = dict(system.equations)
    power = " + ".join(f"{parameter}*{_paren(m)}*{v}**2" for m, v, _ in free.masses.values())
    # the artificial dampers' share of D is -xi m v^2 each: taken out again (the structures' term is
    # in their accelerations, not in D)
    if power:
        eq["D"] = f"{_paren(eq['D'])} + {_paren(power)}"
    inputs = [power] if power else []
    for s in free.structures.values():
        inputs.append(f"{parameter}*({' '.join(s.mass_terms())})")
    eq["W"] = " + ".join(inputs) if inputs else "0"
    variables = [
        Variable("W", "J", "energy put in by the EPMC term + xi M v")
        if v.name == "W"
        else Variable("D", "J", "energy dissipated by friction and dampers (the EPMC term excluded)")
        if v.name == "D"
        else v
        for v in system.variables
    ]
    return replace(system, equations=eq, variables=variables)


def _network(source) -> Network:
    if isinstance(source, Network):
        return source
    if isinstance(source, str | Path):
        path = Path(source)
        try:
            data = tomllib.loads(path.read_text())
        except (OSError, tomllib.TOMLDecodeError) as exc:
            raise ModelError(f"{path}: cannot read a network file: {exc}") from None
        with reading_model_file(path):  # the files it names (a structure's matrices) beside it
            return read_network(data)
    if isinstance(source, Mapping):
        return read_network(source)
    raise ModelError(
        f"epmc_system takes a Network, a parsed network file or its path, got {type(source).__name__}"
    )


def epmc(data: Mapping) -> HybridSystem:
    """The EPMC system of a parsed network file (the ``network`` model format's ``epmc`` method)."""
    return epmc_system(read_network(data))
