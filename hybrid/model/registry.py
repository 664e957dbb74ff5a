"""Models by name: the installed ``hybrid.models`` entry points (the built-ins), or a model file by path."""

from __future__ import annotations

from importlib.metadata import entry_points
from pathlib import Path

from ..core.errors import ModelError
from .loader import load_system
from .system import HybridSystem

__all__ = ["ENTRY_POINT_GROUP", "builtin_models", "is_model_file", "resolve_model"]

ENTRY_POINT_GROUP = "hybrid.models"


def builtin_models() -> dict[str, object]:
    """Installed model entry points by name."""
    return {ep.name: ep for ep in entry_points(group=ENTRY_POINT_GROUP)}


def is_model_file(name: str, builtin: dict | None = None) -> bool:
    """Whether MODEL names a model file (a path) rather than a built-in model."""
    eps = builtin_models() if builtin is None else builtin
    return name.endswith(".toml") or "/" in name or (name not in eps and Path(name).exists())


def resolve_model(name: str) -> HybridSystem:
    """A built-in model by name, or a model file by path."""
    eps = builtin_models()
    if is_model_file(name, eps):
        return load_system(Path(name))
    if name not in eps:
        have = ", ".join(sorted(eps)) or "none installed"
        raise ModelError(
            f"unknown model `{name}`; built-in models: {have}; or give the path of a model file (.toml)"
        )
    system = eps[name].load()()
    if not isinstance(system, HybridSystem):
        raise ModelError(f"entry point `{name}` did not return a HybridSystem")
    return system
