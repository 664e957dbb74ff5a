"""The ``hybrid`` command: ``hybrid models|show|simulate|orbit|frc|cont|locus|sweep|chart ...``.

Models are found by name among the installed ``hybrid.models`` entry points
(the project's built-ins: absorber, isolator, coulomb, ...) or given as the path of
a model file (``.toml``). Curves drawn over a frequency-response curve come
from the ``hybrid.frc_overlays`` entry points, by model name; installed packages
add subcommands through the ``hybrid.commands`` entry points. Bad input is
reported in one line on stderr with exit code 2, before any integration; a
failed simulation or a periodic orbit not found with exit code 1; no tracebacks.

A failed write (a full disk, no permission, stdout closed by its reader) is one line
naming the path, the cause and what to do, with exit code 1 (2 where it is found before
the computation); Ctrl-C, ``SIGTERM`` and ``SIGHUP`` stop the command within a second or
two, keep what it finished and exit with 130, 143 and 129. With stderr closed the command
runs as usual (its messages are lost; the exit code tells the outcome); with stdout closed
it is refused (exit 2).

Each subcommand is a module of this package with a ``register(subparsers)`` that adds its
parser and sets its ``handler``; the helpers they share are in :mod:`hybrid.cli.common`.
"""

from __future__ import annotations

import argparse
import contextlib
import os
import sys
import time
from collections.abc import Sequence
from importlib.metadata import entry_points

from ..core.budget import time_limit
from ..core.errors import BudgetExceeded, ModelError, OutputError, SimulationError, WorkerError
from ..core.files import os_error_text
from ..core.workers import Terminated, signals_as_interrupts
from . import backbone, cont, frc, locus, orbit, show, simulate, sweep
from .common import GuardedStream, StreamClosed, UsageError

__all__ = ["main", "build_parser"]

#: Entry points adding subcommands: ``name = "package.module:register"``, ``register(subparsers)``.
COMMAND_GROUP = "hybrid.commands"
#: The subcommands of this package, in the order of ``hybrid --help``.
BUILTIN = (simulate, orbit, frc, show, sweep, cont, locus, backbone)


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
            _say(f"hybrid: warning: {text}")

    def summary(self) -> None:
        more = sum(n - WARNINGS_SHOWN for n in self.seen.values() if n > WARNINGS_SHOWN)
        if more:
            _say(f"hybrid: warning: {more} more warnings like those above were not shown")


def _usable(stream) -> bool:
    try:
        return stream is not None and not stream.closed and stream.fileno() >= 0
    except (AttributeError, OSError, ValueError):
        return stream is not None and not getattr(stream, "closed", False)  # (a test's capture)


def main(argv: Sequence[str] | None = None) -> int:
    """Entry point of the ``hybrid`` command."""
    stdout, stderr = sys.stdout, sys.stderr
    if not _usable(stderr):  # closed by the caller (2>&-): messages are lost, the run goes on
        sys.stderr = open(os.devnull, "w")  # noqa: SIM115 - restored below
    try:
        if not _usable(stdout):
            print(
                "hybrid: error: stdout is closed: hybrid prints its results there; redirect it "
                "(> FILE, or > /dev/null)",
                file=sys.stderr,
            )
            return 2
        sys.stdout = GuardedStream(stdout, "stdout")
        return _run(argv)
    finally:
        sys.stdout = stdout
        if sys.stderr is not stderr:
            sys.stderr.close()
            sys.stderr = stderr


def _say(text: str) -> None:
    """One line on stderr (nothing if stderr fails too)."""
    try:
        print(text, file=sys.stderr)
    except (OSError, ValueError):
        pass


def _run(argv: Sequence[str] | None) -> int:
    import warnings

    parser = build_parser()
    args = parser.parse_args(argv)
    shown = _Warnings()
    with warnings.catch_warnings():
        warnings.showwarning = shown.show
        try:
            return _handle(args)
        finally:
            shown.summary()


def _handle(args) -> int:
    t0 = time.perf_counter()
    try:
        with signals_as_interrupts(), _whole_command_limit(args):
            code = args.handler(args)
            sys.stdout.flush()
            return code
    except KeyboardInterrupt as exc:
        what = exc.name if isinstance(exc, Terminated) else "Ctrl-C"
        kept = getattr(exc, "hybrid_kept", None)
        _say(
            f"hybrid: interrupted ({what}) after {time.perf_counter() - t0:.1f} s"
            + (
                f": kept in {kept[0]}: {', '.join(kept[1])}"
                if kept and kept[1]
                else ": nothing finished to keep"
            )
        )
        return exc.exit_code if isinstance(exc, Terminated) else 130
    except (UsageError, ModelError, ValueError, TypeError) as exc:
        _say(f"hybrid: error: {exc}")
        return 2
    except StreamClosed as exc:
        _say(f"hybrid: error: {exc}")
        _silence(sys.stdout)
        return 1
    except OutputError as exc:
        _say(f"hybrid: error: {exc}")
        return 1
    except BudgetExceeded as exc:
        _say(f"hybrid: {exc}")
        return 1
    except WorkerError as exc:
        _say(f"hybrid: error: {exc}")
        return 1
    except OSError as exc:  # a failure of the system not met where files are written
        _say(f"hybrid: error: {os_error_text(exc)}")
        return 1
    except SimulationError as exc:  # pragma: no cover - runs use throw=False
        _say(f"hybrid: simulation failed: {exc}")
        return 1


def _whole_command_limit(args):
    """``--max-time`` over the whole command, the reading and set-up of its model included (issue
    33: a model of 3000 contacts took 587 s to set up under ``--max-time 20``); the limit the
    command sets again around its computation is the same or later, so this one holds."""
    seconds = getattr(args, "max_time", None)
    return time_limit(seconds) if seconds is not None else contextlib.nullcontext()


def _silence(stream) -> None:
    """After stdout failed: point its descriptor at /dev/null, so that the interpreter's last flush
    at exit does not fail again (Python's advice for a broken pipe)."""
    inner = getattr(stream, "_stream", stream)
    try:
        fd = inner.fileno()
        devnull = os.open(os.devnull, os.O_WRONLY)
        os.dup2(devnull, fd)
        os.close(devnull)
    except (AttributeError, OSError, ValueError):
        pass
