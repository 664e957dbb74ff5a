"""The ``hybrid`` command: ``hybrid models|show|simulate|orbit|frc|cont|sweep|chart ...``.

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
from . import cont, frc, orbit, show, simulate, sweep
from .common import UsageError

__all__ = ["main", "build_parser"]

#: Entry points adding subcommands: ``name = "package.module:register"``, ``register(subparsers)``.
COMMAND_GROUP = "hybrid.commands"
#: The subcommands of this package, in the order of ``hybrid --help``.
BUILTIN = (simulate, orbit, frc, show, sweep, cont)


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


#: A warning of one kind (its text with the numbers left out) is shown this many times per process.
WARNINGS_SHOWN = 3


class _Warnings:
    """Warnings on stderr as one line each, ``hybrid: warning: ...`` (no file name, no source line:
    they are about the model and the run, not about the code), each kind at most
    :data:`WARNINGS_SHOWN` times, then counted."""

    def __init__(self) -> None:
        self.seen: dict[str, int] = {}

    def show(self, message, category, filename, lineno, file=None, line=None) -> None:
        import re

        text = str(message)
        kind = re.sub(r"[-+]?\d[\d.e+-]*", "#", text)
        n = self.seen[kind] = self.seen.get(kind, 0) + 1
        if n <= WARNINGS_SHOWN:
            print(f"hybrid: warning: {text}", file=sys.stderr)

    def summary(self) -> None:
        more = sum(n - WARNINGS_SHOWN for n in self.seen.values() if n > WARNINGS_SHOWN)
        if more:
            print(f"hybrid: warning: {more} more warnings like those above were not shown", file=sys.stderr)


def main(argv: Sequence[str] | None = None) -> int:
    """Entry point of the ``hybrid`` command."""
    import warnings

    parser = build_parser()
    args = parser.parse_args(argv)
    shown = _Warnings()
    with warnings.catch_warnings():
        warnings.showwarning = shown.show
        try:
            return _run(args)
        finally:
            shown.summary()


def _run(args) -> int:
    try:
        return args.handler(args)
    except (UsageError, ModelError, ValueError, TypeError) as exc:
        print(f"hybrid: error: {exc}", file=sys.stderr)
        return 2
    except SimulationError as exc:  # pragma: no cover - runs use throw=False
        print(f"hybrid: simulation failed: {exc}", file=sys.stderr)
        return 1
