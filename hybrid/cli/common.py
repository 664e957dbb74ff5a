"""Helpers shared by the subcommands of ``hybrid``: arguments, parameters, output folders, messages.

Bad input is reported in one line on stderr with exit code 2, before any integration
(:class:`UsageError`, raised here and caught by :func:`hybrid.cli.main.main`). An output folder is
checked before any computation (:func:`writable_folder`) and written through
:func:`results` (:class:`hybrid.core.files.OutputFiles`: locked for the run, files renamed into
place at its end). Those two, the error, the argument types and :func:`info` are those of
:mod:`hybrid.core.commands` (what a subcommand of an installed package uses too), re-exported.
"""

from __future__ import annotations

import argparse
import errno
import os
from collections.abc import Sequence
from dataclasses import fields, replace
from pathlib import Path

from ..core.commands import UsageError as UsageError  # what any subcommand shares, re-exported
from ..core.commands import command_line as command_line
from ..core.commands import folder_note as folder_note
from ..core.commands import info as info
from ..core.commands import int_at_least as int_at_least
from ..core.commands import nonnegative_int as nonnegative_int
from ..core.commands import positive_float as positive_float
from ..core.commands import positive_int as positive_int
from ..core.commands import results as results
from ..core.commands import writable_folder as writable_folder
from ..core.errors import OutputError
from ..core.files import os_error_text
from ..core.options import ContinuationOptions
from ..engine.simulate import initial_state
from ..integrators.auto import resolve
from ..integrators.options import SolverOptions
from ..integrators.registry import METHODS, NAMES
from ..model.plot_hints import plot_hints
from ..model.registry import builtin_models, is_model_file, resolve_model
from ..model.system import HybridSystem
from ..orbits.orbit import ORBIT_OPTIONS

#: Largest `--samples-per-period` (a period of `orbit` is held in memory; `simulate` keeps 4 of them).
MAX_SAMPLES_PER_PERIOD = 100_000


#: Help of `--out` (see `default_output_dir`).
OUT_HELP = "output folder (default out/NAME: the built-in model's name, or the stem of the model file)"


def pairs(items: Sequence[str] | None, option: str) -> dict[str, float]:
    out: dict[str, float] = {}
    for item in items or ():
        if "=" not in item:
            raise UsageError(f"`{option}` takes NAME=VALUE, got {item!r}")
        key, _, value = item.partition("=")
        key = key.strip()
        try:
            out[key] = float(value)
        except ValueError:
            raise UsageError(f"`{option} {item}`: {value!r} is not a number") from None
    return out


def model(name: str) -> HybridSystem:
    """MODEL of the command line (:func:`hybrid.model.registry.resolve_model`), with a note on stderr
    when it names a built-in model and a file of that name lies in the working directory too: the
    built-in model is used (a file is read when MODEL is a path: ``./NAME`` or ``NAME.toml``)."""
    system = resolve_model(name)
    if not is_model_file(name) and name in builtin_models() and os.path.lexists(name):
        info(
            f"note: `{name}` is the built-in model; the file {name!r} in this folder is not read (give it as "
            f"a path, ./{name}, to use it)"
        )
    return system


def add_guess_args(p: argparse.ArgumentParser) -> None:
    """``--x0 NAME=VALUE`` (repeatable) and ``--mode0``: the start of a periodic orbit's search."""
    p.add_argument(
        "--x0", action="append", metavar="NAME=VALUE", help="initial guess of a variable (default 0)"
    )
    p.add_argument("--mode0", help="mode of the guess (default: the model's initial mode)")


def guess(system: HybridSystem, args) -> tuple[dict[str, float], str]:
    """The guess of ``--x0`` (every other variable 0) and its mode ``--mode0``, checked.

    Raises
    ------
    UsageError
        The model declares no initial mode and ``--mode0`` is not given.
    hybrid.core.errors.ModelError, hybrid.core.errors.InputError
        An unknown mode, an unknown variable or a value that is not finite.
    """
    mode0 = args.mode0 if args.mode0 is not None else system.default_mode
    if mode0 is None:
        raise UsageError(f"model `{system.name}` declares no initial mode: give --mode0")
    system.mode(mode0)  # unknown mode -> ModelError
    x0 = {n: 0.0 for n in system.variable_names}
    x0.update(pairs(args.x0, "--x0"))
    initial_state(system, x0, mode0)  # unknown or non-finite values -> ValueError
    return x0, mode0


def choose_preset(system: HybridSystem, preset: str | None) -> str | None:
    """The preset asked for, else ``standard`` if the model has one, else its first (None if none)."""
    if preset is not None:
        return preset
    if "standard" in system.presets:
        return "standard"
    return next(iter(system.presets), None)


def parameters(system: HybridSystem, args) -> tuple[str | None, dict[str, float]]:
    preset = choose_preset(system, args.preset)
    values = pairs(args.set, "--set")
    omega = getattr(args, "omega", None)  # `frc` has no --omega
    if omega is not None:
        if "Omega" not in system.parameter_names:
            raise UsageError(f"model `{system.name}` has no parameter `Omega` for --omega")
        values["Omega"] = omega
    return preset, system.parameter_values(values, preset=preset)


def add_model_args(p: argparse.ArgumentParser, omega: bool = True) -> None:
    p.add_argument("model", help="built-in model name (see `hybrid models`) or path of a model file (.toml)")
    p.add_argument(
        "--preset",
        help="named parameter set of the model (default: `standard` if it has one, else its first)",
    )
    p.add_argument("--set", action="append", metavar="NAME=VALUE", help="override a parameter (repeatable)")
    if omega:
        p.add_argument(
            "--omega", type=positive_float, help="excitation frequency [rad/s] (sets parameter Omega)"
        )


def add_tolerances(
    p: argparse.ArgumentParser,
    rtol: float = ORBIT_OPTIONS.method.rtol,
    atol: float = ORBIT_OPTIONS.method.atol,
) -> None:
    """``--rtol`` and ``--atol``: the tolerances of a method that has them (IDA), defaults
    ``rtol`` and ``atol``; refused with a method that has none (:func:`solver_options`)."""
    p.add_argument(
        "--rtol", type=positive_float, default=None, help=f"relative tolerance of IDA (default {rtol:g})"
    )
    p.add_argument(
        "--atol", type=positive_float, default=None, help=f"absolute tolerance of IDA (default {atol:g})"
    )
    p.set_defaults(tolerance_defaults={"rtol": rtol, "atol": atol})


def add_locate_tol(p: argparse.ArgumentParser) -> None:
    """``--locate-tol``: the accuracy of a located special point (ContinuationOptions.locate_tol)."""
    p.add_argument(
        "--locate-tol",
        type=positive_float,
        default=None,
        metavar="TOL",
        help="accuracy of a located special point, relative to the width of the range (default "
        f"{ContinuationOptions.locate_tol:g}); a point not located to it is reported `bracketed`",
    )


def with_locate_tol(settings, args):
    """``settings`` (ContinuationOptions, None for the defaults) with ``--locate-tol`` if given."""
    tol = getattr(args, "locate_tol", None)
    if tol is None:
        return settings
    return replace(settings if settings is not None else ContinuationOptions(), locate_tol=tol)


def add_budget(p: argparse.ArgumentParser) -> None:
    p.add_argument(
        "--max-time",
        type=positive_float,
        default=SolverOptions.max_wall_time,
        metavar="SECONDS",
        help=f"wall-clock limit of the whole command (default {SolverOptions.max_wall_time:g} s)",
    )
    add_work_limits(p)


def add_work_limits(p: argparse.ArgumentParser) -> None:
    """``--max-steps`` (the work of each integration) and ``--integrator``."""
    p.add_argument(
        "--max-steps",
        type=positive_int,
        default=SolverOptions.max_steps,
        metavar="N",
        help="work limit of each integration, in IDA residual evaluations "
        f"(default {SolverOptions.max_steps:g})",
    )
    p.add_argument(
        "--integrator",
        choices=NAMES,
        default="ida",
        help="ida (default, any model), exact (matrix exponentials: models affine in the state, "
        "forced by harmonics of one base frequency) or auto (exact where the model allows it, else ida; "
        "the choice and why are printed)",
    )


def check_integrator(system: HybridSystem, params: dict[str, float], options: SolverOptions) -> None:
    """Refuse, before any run, a model the chosen method cannot take (NotAffineError, exit 2); for
    ``--integrator auto``, say which method it takes for the model and why (the library's entry
    points make the same choice)."""
    options, choice = resolve(options, system, params)
    if choice is not None:
        info(f"integrator auto: {choice.describe()}")
    options.method.check_model(system, params)


def solver_options(args, *, wall_time: bool = True) -> SolverOptions:
    """The :class:`SolverOptions` of the run options: the method of ``--integrator`` with the
    tolerances given (``--rtol``, ``--atol``, else the command's defaults), the budget
    (``--max-steps``, and ``--max-time`` as each run's wall-clock limit where ``wall_time``).

    Raises
    ------
    UsageError
        A tolerance given for a method that has none (``--integrator exact --rtol ...``).
    """
    cls = METHODS[args.integrator]
    takes = {f.name for f in fields(cls)}
    given = {k: getattr(args, k) for k in ("rtol", "atol") if getattr(args, k, None) is not None}
    refused = [k for k in given if k not in takes]
    if refused:
        raise UsageError(
            f"{', '.join('--' + k for k in refused)} does not apply to --integrator {args.integrator}: its "
            "runs have no tolerances (they are exact to rounding); leave it out, or use --integrator ida"
        )
    defaults = getattr(args, "tolerance_defaults", {})
    settings = {k: given.get(k, v) for k, v in defaults.items() if k in takes}
    budget = {"max_steps": args.max_steps}
    if wall_time and getattr(args, "max_time", None) is not None:
        budget["max_wall_time"] = args.max_time
    return SolverOptions(method=cls(**settings), **budget)


def announce(system: HybridSystem, preset: str | None, params: dict[str, float]) -> None:
    if preset:
        info(
            f"model `{system.name}`, preset `{preset}`: " + ", ".join(f"{k}={v:g}" for k, v in params.items())
        )


def default_output_dir(system: HybridSystem, model: str) -> Path:
    """The default output folder of MODEL: ``out/<file stem>`` for a model file, else ``out/<name>``.

    A model given as a file is named after the file, not after its ``[model] name``: two files
    declaring the same name keep their results apart. The folder must lie directly inside ``out/``,
    so that neither a file name nor a model name can direct output elsewhere.

    Parameters
    ----------
    system : HybridSystem
        The resolved model.
    model : str
        MODEL as given on the command line (a built-in name or a path).

    Returns
    -------
    Path
        ``out/<folder>``, relative to the working directory.

    Raises
    ------
    UsageError
        The folder would not lie directly inside ``out/``.
    """
    folder = Path(model).stem if is_model_file(model) else system.name
    out = Path("out") / folder
    if not folder.isprintable() or folder in ("", ".", "..") or out.resolve().parent != Path("out").resolve():
        raise UsageError(
            f"{folder!r} does not name a folder inside out/: rename the model file or give --out"
        )
    return out


def output_dir(system: HybridSystem, args) -> Path:
    """The output folder, created and checked writable before any computation.

    ``--out`` if given, else :func:`default_output_dir` (``out/<file stem>`` for a model file,
    ``out/<model name>`` for a built-in model), checked to lie inside ``out/``, so a model
    file cannot direct output elsewhere.
    """
    if args.out is None:
        out = default_output_dir(system, args.model)
    else:
        if not args.out.strip():
            raise UsageError("`--out` needs a folder path, got an empty string")
        out = Path(args.out)
    return writable_folder(out)


class StreamClosed(OutputError):
    """Writing to stdout failed (its reader went away, ``| head``; a full device, ``> /dev/full``)."""


class GuardedStream:
    """A text stream whose failed writes raise :class:`StreamClosed` naming it (stdout)."""

    def __init__(self, stream, name: str):
        self._stream = stream
        self._name = name

    def _fail(self, exc: OSError):
        advice = (
            "its reader stopped reading (e.g. `| head`)"
            if exc.errno == errno.EPIPE
            else "redirect it elsewhere"
        )
        return StreamClosed(os_error_text(exc, self._name, advice), exc.errno)

    def write(self, text: str) -> int:
        try:
            return self._stream.write(text)
        except OSError as exc:
            raise self._fail(exc) from None

    def flush(self) -> None:
        try:
            self._stream.flush()
        except OSError as exc:
            raise self._fail(exc) from None

    def __getattr__(self, name):
        return getattr(self._stream, name)


def unit(system: HybridSystem, name: str) -> str:
    units = {v.name: v.unit for v in system.variables}
    return units.get(name) or plot_hints(system)["units"].get(name, "")


def samples_per_period(args) -> int:
    if args.samples_per_period > MAX_SAMPLES_PER_PERIOD:
        raise UsageError(
            f"`--samples-per-period` is at most {MAX_SAMPLES_PER_PERIOD}, got {args.samples_per_period}"
        )
    return args.samples_per_period
