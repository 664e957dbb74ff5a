"""The ``hybrid`` command: ``hybrid models|show|simulate|orbit|frc|cont|locus|sweep|chart ...``.

Models are found by name among the installed ``hybrid.models`` entry points
(the project's built-ins: absorber, isolator, coulomb, ...) or given as the path of
a model file (``.toml``). Curves drawn over a frequency-response curve come
from the ``hybrid.frc_overlays`` entry points, by model name; installed packages
add subcommands through the ``hybrid.commands`` entry points. Bad input is
reported in one line on stderr with exit code 2, before any integration; a
failed simulation or a periodic orbit not found with exit code 1; no tracebacks.

Each subcommand is a module of this package with a ``register(subparsers)`` that adds its
parser and sets its ``handler``; the helpers they share are in :mod:`hybrid.cli.common`.
"""

from __future__ import annotations

import argparse
import sys
from collections.abc import Sequence
from importlib.metadata import entry_points

from ..core.errors import ModelError, SimulationError
from . import cont, frc, locus, orbit, show, simulate, sweep
from .common import UsageError

__all__ = ["main", "build_parser"]

#: Entry points adding subcommands: ``name = "package.module:register"``, ``register(subparsers)``.
COMMAND_GROUP = "hybrid.commands"
#: The subcommands of this package, in the order of ``hybrid --help``.
BUILTIN = (simulate, orbit, frc, show, sweep, cont, locus)


def build_parser() -> argparse.ArgumentParser:
    """The parser of ``hybrid`` with every subcommand (those of installed packages included)."""
    parser = argparse.ArgumentParser(
        prog="hybrid", description="Event-driven simulation of stick-slip (hybrid) systems on SUNDIALS IDA."
    )
    sub = parser.add_subparsers(dest="command", required=True)
    for module in BUILTIN:
        module.register(sub)
    # Subcommands of installed packages: `register(subparsers)` adds one and sets its `handler`.
    for ep in entry_points(group=COMMAND_GROUP):
        if ep.name not in sub.choices:
            ep.load()(sub)
    return parser


def main(argv: Sequence[str] | None = None) -> int:
    """Entry point of the ``hybrid`` command."""
    parser = build_parser()
    args = parser.parse_args(argv)
    try:
        return args.handler(args)
    except (UsageError, ModelError, ValueError, TypeError) as exc:
        print(f"hybrid: error: {exc}", file=sys.stderr)
        return 2
    except SimulationError as exc:  # pragma: no cover - runs use throw=False
        print(f"hybrid: simulation failed: {exc}", file=sys.stderr)
        return 1
