"""Built-in models: the paper's two sequential friction-spring dampers [1]_, a Coulomb oscillator, belts,
and three friction networks of many contacts (a Burridge-Knopoff chain, an Iwan joint, a bladed disk).

Each model is a data file (``*.toml`` beside this module) read by
:func:`hybrid.load_system`; the functions below return them, cached.

References
----------
.. [1] Aramendiz et al., "Sequential friction-spring dampers" (the paper in
   ``shared/seed``); equations re-derived in ``docs/theory.md``.
"""

from __future__ import annotations

from functools import cache
from importlib import resources

from hybrid import HybridSystem, load_system

from .epmc import epmc_system

__all__ = [
    "absorber",
    "isolator",
    "coulomb",
    "coulomb_sign",
    "friction_oscillator",
    "belt",
    "belt_stribeck",
    "belt_damper",
    "belt_sign",
    "bk_chain",
    "iwan",
    "bladed_disk",
    "BUILTIN",
    "epmc_system",
]


@cache
def _load(name: str) -> HybridSystem:
    with resources.as_file(resources.files(__name__) / f"{name}.toml") as path:
        return load_system(path)


def absorber() -> HybridSystem:
    """Dynamic vibration absorber (paper Fig. 1, Eqs. 1-2); presets ``standard``, ``fig3a``, ``fig3b``."""
    return _load("absorber")


def isolator() -> HybridSystem:
    """Dynamic vibration isolator (paper Fig. 2, Eqs. 7-8); presets ``standard``, ``fig4a``, ``fig4b``."""
    return _load("isolator")


def coulomb() -> HybridSystem:
    """1-DOF oscillator with Coulomb friction to ground; presets ``forced`` (the default), ``free``."""
    return _load("coulomb")


def coulomb_sign() -> HybridSystem:
    """The Coulomb oscillator written as one equation with ``sign(v)`` (Filippov); presets as ``coulomb``."""
    return _load("coulomb_sign")


def friction_oscillator() -> HybridSystem:
    """1-DOF oscillator with viscous damping, Coulomb friction and stiction; presets ``denhartog``
    (Den Hartog 1931, the default), ``shaw`` (Shaw 1986: static friction above kinetic, no damping)."""
    return _load("friction_oscillator")


def belt_sign() -> HybridSystem:
    """Mass on a moving belt written with ``sign(v - v_b)`` (Filippov); presets ``standard``, ``damped``."""
    return _load("belt_sign")


def belt() -> HybridSystem:
    """Mass on a moving belt, Coulomb friction with stiction (autonomous); presets ``standard``, ``damped``."""
    return _load("belt")


def belt_stribeck() -> HybridSystem:
    """Mass on a moving belt, Stribeck friction (autonomous); preset ``standard``."""
    return _load("belt_stribeck")


def belt_damper() -> HybridSystem:
    """The Stribeck belt oscillator with the sequential friction-spring damper attached (autonomous); preset ``standard``."""
    return _load("belt_damper")


def bk_chain() -> HybridSystem:
    """Burridge-Knopoff chain of 20 blocks on friction contacts, all forced (network file, one cell
    repeated); preset ``standard`` (the chain of the Siconos benchmark)."""
    return _load("bk_chain")


def iwan() -> HybridSystem:
    """Iwan joint: a mass on 50 Jenkins elements with slip forces spread uniformly (network file, one
    cell repeated); preset ``standard``."""
    return _load("iwan")


def bladed_disk() -> HybridSystem:
    """Bladed disk: a ring of 24 blades with friction dampers between neighbours, forced by a
    travelling wave (network file, one cell repeated); presets ``tuned``, ``mistuned``."""
    return _load("bladed_disk")


#: Built-in model factories by name.
BUILTIN = {
    "absorber": absorber,
    "isolator": isolator,
    "coulomb": coulomb,
    "coulomb_sign": coulomb_sign,
    "friction_oscillator": friction_oscillator,
    "belt_sign": belt_sign,
    "belt": belt,
    "belt_stribeck": belt_stribeck,
    "belt_damper": belt_damper,
    "bk_chain": bk_chain,
    "iwan": iwan,
    "bladed_disk": bladed_disk,
}
