"""Mechanical networks with Coulomb friction: a file describes the mechanism, the system is derived.

A *network file* is a model file (TOML) with ``format = "network"`` in its
``[model]`` table. Instead of modes, slave equations and guards it lists the
parts of a one-dimensional mechanism:

* ``[masses.X]``: a point mass whose displacement variable is ``X`` [m];
  ``mass`` (a number > 0 or a parameter of domain positive) [kg], ``velocity`` (name of its
  velocity variable, default ``v_X``) [m/s], ``description``;
* ``[nodes.U]``: a massless node (connecting point) of displacement ``U`` [m];
* ``ground``: the fixed point (or the moving base, with ``[base]``);
* ``[springs.NAME]``: ``between = [A, B]``, ``stiffness`` [N/m];
* ``[dampers.NAME]``: ``between = [A, B]``, ``coefficient`` [N s/m] (not
  between two massless nodes);
* ``[friction.NAME]``: a Coulomb friction element, ``between = [A, B]``,
  ``sliding`` level R [N] (> 0), optional ``static`` level R_s >= R [N]:
  the element sticks while the force it must carry stays inside
  ``(-R_s, R_s)`` and slides with the force ``+-R``;
* ``[forces.NAME]``: ``on = X`` (a mass), ``offset`` F0 [N], ``amplitude``
  F [N], ``frequency`` Omega [rad/s], ``phase`` phi [rad]: the force
  ``F0 + F sin(Omega t + phi)``, named ``NAME`` among the model's definitions; or
  ``harmonics = [{amplitude, multiple, phase}, ...]`` with ``frequency`` the base
  frequency: ``F0 + sum F_k sin(n_k Omega t + phi_k)``;
* ``[base]``: ``amplitude`` Y [m], ``frequency`` Omega [rad/s]: the ground
  moves as ``y(t) = Y sin(Omega t)``;
* ``[cells.NAME]``: a cell of masses, nodes, elements and forces declared once
  and repeated ``count`` times as a ``chain`` or a ``ring``, with parameters
  that take one value per copy (:mod:`hybrid_models.network_cells`).

``[parameters]``, ``[presets]``, and optionally ``[plot]`` and ``[orbit]``, are
those of a mode-level file (:mod:`hybrid.model.loader`).

The system (see ``docs/models.md`` and :mod:`hybrid_models.network_system`) has
one own mode, ``motion`` (the masses' momentum balances, the free nodes, the
energy quadratures), and one component per friction element with the local
modes ``stick``, ``slip+`` (``v_B > v_A``) and ``slip-``: its modes are
composed on demand, never enumerated, so a network may have thousands of
contacts. Each element's force ``f_NAME`` (on its first end ``A``) [N] is a
slave variable; ``w_NAME = v_B - v_A`` [m/s], ``E`` (kinetic + spring energy)
[J] and the excitation forces are outputs; ``W`` (work of the excitations,
base motion included) [J] and ``D`` (energy dissipated by friction and
dampers) [J] are quadratures.

This module is the ``network`` model format (entry point group
``hybrid.model_formats``): :func:`build`, :func:`describe`, :func:`draw`.
"""

from __future__ import annotations

from collections.abc import Mapping

from hybrid import HybridSystem

from .epmc import epmc_system
from .network_draw import draw_network, force_text
from .network_read import GROUND, Network, read_network
from .network_structures import describe_structures
from .network_system import network_system

__all__ = [
    "GROUND",
    "Network",
    "build",
    "describe",
    "describe_network",
    "draw",
    "draw_network",
    "epmc",
    "network_system",
    "read_network",
]


def describe_network(net: Network) -> str:
    """The network as text: its cells, its points, then one line per element and excitation."""
    lines = [f"network `{net.name}`" + (f": {net.title}" if net.title else "")]
    for name, count, layout in net.cells:
        lines.append(f"  cell   {name:<10} {count} copies as a {layout} (items NAME_1 ... NAME_{count})")
    for x, (m, v, desc) in net.masses.items():
        lines.append(f"  mass   {x:<10} m = {m}, velocity {v}" + (f"  ({desc})" if desc else ""))
    for u, desc in net.nodes.items():
        lines.append(f"  node   {u:<10} massless" + (f"  ({desc})" if desc else ""))
    lines += describe_structures(net.structures)
    ground = "ground (moving: y = " + f"{net.base[0]}*sin({net.base[1]}*t))" if net.base else "ground"
    lines.append(f"  {ground}")
    symbols = {"spring": "/\\/\\", "damper": "[==]", "friction": "]||["}
    for e in net.elements:
        what = {"spring": f"k = {e.coef}", "damper": f"c = {e.coef}", "friction": f"R = {e.coef}"}[e.kind]
        if e.static:
            what += f", R_s = {e.static}"
        lines.append(f"  {e.a:>10} --{symbols[e.kind]}-- {e.b:<10} {e.kind} {e.name}: {what}")
    for c in net.contacts:
        (ta, tb), (na, nb) = c.tangential, c.normal
        lines.append(
            f"  contact {c.name}: tangential {tb} - {ta}, gap {nb} - {na}; N = max(0, {c.preload} - {c.kn} g), "
            f"T = {c.kt} (x - w), |T| <= {c.mu} N"
        )
    for f in net.forces:
        lines.append(f"  force  {f.name} = {force_text(f)} on {f.on}")
    return "\n".join(lines)


def build(data: Mapping) -> HybridSystem:
    """The system of a parsed network file (the ``network`` model format's builder).

    Parameters
    ----------
    data : mapping
        The file as :func:`tomllib.loads` returns it.

    Returns
    -------
    HybridSystem
        One own mode and one component per friction element; see :func:`network_system`.

    Raises
    ------
    ModelError
        See :func:`read_network`.
    """
    return network_system(read_network(data))


def describe(data: Mapping) -> str:
    """The network of a parsed network file as text (the ``network`` model format's description)."""
    return describe_network(read_network(data))


def epmc(data: Mapping) -> HybridSystem:
    """The free system of a parsed network file with the EPMC term ``+ xi M v`` (the ``network``
    format's ``epmc``, for ``hybrid backbone``; :func:`hybrid_models.epmc.epmc_system`)."""
    return epmc_system(read_network(data))


def draw(data: Mapping, path) -> None:
    """Draw the network of a parsed network file as a PNG (the ``network`` format's figure)."""
    draw_network(read_network(data), path)
