"""Command line: ``hybrid simulate|orbit|frc|show MODEL ...`` and ``hybrid models``.

Models are found by name among the installed ``hybrid.models`` entry points
(the project's built-ins: absorber, isolator, coulomb) or given as the path of
a model file (``.toml``). Curves drawn over a frequency-response curve come
from the ``hybrid.frc_overlays`` entry points, by model name; installed packages
add subcommands through the ``hybrid.commands`` entry points. Bad input is
reported in one line on stderr with exit code 2, before any integration; a
failed simulation or a periodic orbit not found with exit code 1; no tracebacks.
"""

from __future__ import annotations

import argparse
import importlib
import math
import os
import sys
import threading
import time
from collections.abc import Callable, Sequence
from importlib.metadata import entry_points
from pathlib import Path

import numpy as np

from ._budget import time_limit
from ._expr import ExpressionError
from ._filippov import surfaces
from ._io import (
    EventsCSVWriter,
    TrajectoryCSVWriter,
    to_json,
    trajectory_summary,
    write_rows_csv,
    write_trajectory_csv,
)
from ._loader import describe_model_file, draw_model_file, load_system
from ._options import INTEGRATORS, SolverOptions
from ._orbit import ORBIT_OPTIONS, PeriodicOrbit
from ._plothints import plot_hints
from ._progress import ProgressBar
from ._record import MAX_STREAMED_SAMPLES, Envelope, Sink, Tee
from ._shooting import periodic_orbit
from ._simulate import SimulationError, initial_state, simulate
from ._system import HybridSystem, ModelError

__all__ = ["main", "resolve_model", "writable_folder"]

ENTRY_POINT_GROUP = "hybrid.models"
#: Entry points adding subcommands: ``name = "package.module:register"``, ``register(subparsers)``.
COMMAND_GROUP = "hybrid.commands"
#: Largest `--samples-per-period` (a period of `orbit` is held in memory; `simulate` keeps 4 of them).
MAX_SAMPLES_PER_PERIOD = 100_000
#: Help of `--out` (see `default_output_dir`).
OUT_HELP = "output folder (default out/NAME: the built-in model's name, or the stem of the model file)"
#: Forcing periods at the end of a `simulate` run kept in memory for its figure.
PLOT_PERIODS = 4.0
#: Time buckets of the whole-run panel of the `simulate` figure.
HISTORY_BUCKETS = 2000


class UsageError(ValueError):
    """Bad command-line input."""


def builtin_models() -> dict[str, object]:
    """Installed model entry points by name."""
    return {ep.name: ep for ep in entry_points(group=ENTRY_POINT_GROUP)}


def _is_model_file(name: str, builtin: dict | None = None) -> bool:
    """Whether MODEL names a model file (a path) rather than a built-in model."""
    eps = builtin_models() if builtin is None else builtin
    return name.endswith(".toml") or "/" in name or (name not in eps and Path(name).exists())


def resolve_model(name: str) -> HybridSystem:
    """A built-in model by name, or a model file by path."""
    eps = builtin_models()
    if _is_model_file(name, eps):
        return load_system(Path(name))
    if name not in eps:
        have = ", ".join(sorted(eps)) or "none installed"
        raise UsageError(
            f"unknown model `{name}`; built-in models: {have}; or give the path of a model file (.toml)"
        )
    system = eps[name].load()()
    if not isinstance(system, HybridSystem):
        raise UsageError(f"entry point `{name}` did not return a HybridSystem")
    return system


def _pairs(items: Sequence[str] | None, option: str) -> dict[str, float]:
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


def _choose_preset(system: HybridSystem, preset: str | None) -> str | None:
    """The preset asked for, else ``standard`` if the model has one, else its first (None if none)."""
    if preset is not None:
        return preset
    if "standard" in system.presets:
        return "standard"
    return next(iter(system.presets), None)


def _parameters(system: HybridSystem, args) -> tuple[str | None, dict[str, float]]:
    preset = _choose_preset(system, args.preset)
    values = _pairs(args.set, "--set")
    omega = getattr(args, "omega", None)  # `frc` has no --omega
    if omega is not None:
        if "Omega" not in system.parameter_names:
            raise UsageError(f"model `{system.name}` has no parameter `Omega` for --omega")
        values["Omega"] = omega
    return preset, system.parameter_values(values, preset=preset)


def _positive_float(text: str) -> float:
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"{text!r} is not a number") from None
    if not (math.isfinite(value) and value > 0):
        raise argparse.ArgumentTypeError(f"must be a finite number > 0, got {text}")
    return value


def _int_at_least(lo: int):
    def parse(text: str) -> int:
        try:
            value = int(text)
        except ValueError:
            raise argparse.ArgumentTypeError(f"{text!r} is not an integer") from None
        if value < lo:
            raise argparse.ArgumentTypeError(f"must be an integer >= {lo}, got {text}")
        return value

    return parse


_positive_int = _int_at_least(1)
_nonnegative_int = _int_at_least(0)


def _add_model_args(p: argparse.ArgumentParser, omega: bool = True) -> None:
    p.add_argument("model", help="built-in model name (see `hybrid models`) or path of a model file (.toml)")
    p.add_argument(
        "--preset",
        help="named parameter set of the model (default: `standard` if it has one, else its first)",
    )
    p.add_argument("--set", action="append", metavar="NAME=VALUE", help="override a parameter (repeatable)")
    if omega:
        p.add_argument(
            "--omega", type=_positive_float, help="excitation frequency [rad/s] (sets parameter Omega)"
        )


def _add_tolerances(p: argparse.ArgumentParser) -> None:
    p.add_argument(
        "--rtol",
        type=_positive_float,
        default=ORBIT_OPTIONS.rtol,
        help=f"relative tolerance (default {ORBIT_OPTIONS.rtol:g})",
    )
    p.add_argument(
        "--atol",
        type=_positive_float,
        default=ORBIT_OPTIONS.atol,
        help=f"absolute tolerance (default {ORBIT_OPTIONS.atol:g})",
    )


def _add_budget(p: argparse.ArgumentParser) -> None:
    p.add_argument(
        "--max-time",
        type=_positive_float,
        default=SolverOptions.max_wall_time,
        metavar="SECONDS",
        help=f"wall-clock limit of the whole command (default {SolverOptions.max_wall_time:g} s)",
    )
    _add_work_limits(p)


def _add_work_limits(p: argparse.ArgumentParser) -> None:
    """``--max-steps`` (the work of each integration) and ``--integrator``."""
    p.add_argument(
        "--max-steps",
        type=_positive_int,
        default=SolverOptions.max_steps,
        metavar="N",
        help="work limit of each integration, in IDA residual evaluations "
        f"(default {SolverOptions.max_steps:g})",
    )
    p.add_argument(
        "--integrator",
        choices=INTEGRATORS,
        default="ida",
        help="ida (default, any model) or exact (matrix exponentials: models affine in the state, "
        "forced at one frequency)",
    )


def _check_integrator(system: HybridSystem, params: dict[str, float], options: SolverOptions) -> None:
    """Refuse, before any run, a model the chosen integrator cannot take (NotAffineError, exit 2)."""
    if options.integrator == "exact":
        from ._compiled import CompiledSystem

        CompiledSystem(system, params).affine()


def _budget_options(args) -> dict:
    """The :class:`SolverOptions` fields set by the run options (budget and integrator)."""
    return {"max_steps": args.max_steps, "max_wall_time": args.max_time, "integrator": args.integrator}


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="hybrid", description="Event-driven simulation of stick-slip (hybrid) systems on SUNDIALS IDA."
    )
    sub = parser.add_subparsers(dest="command", required=True)
    p = sub.add_parser("simulate", help="simulate a model and write CSV, figure and summary")
    _add_model_args(p)
    span = p.add_mutually_exclusive_group()
    span.add_argument(
        "--periods", type=_positive_float, help="length of the run in forcing periods (default 200)"
    )
    span.add_argument("--t-end", type=_positive_float, help="length of the run [s] (models without a period)")
    p.add_argument(
        "--x0", action="append", metavar="NAME=VALUE", help="initial value of a variable (default 0)"
    )
    p.add_argument("--mode0", help="initial mode (default: the model's initial mode)")
    p.add_argument("--rtol", type=_positive_float, default=1e-8, help="relative tolerance (default 1e-8)")
    p.add_argument("--atol", type=_positive_float, default=1e-10, help="absolute tolerance (default 1e-10)")
    p.add_argument(
        "--samples-per-period",
        type=_positive_int,
        default=100,
        help="output samples per period (default 100, at most 100000)",
    )
    p.add_argument("--out", default=None, help=OUT_HELP)
    p.add_argument("--json", action="store_true", help="print a JSON summary on stdout")
    p.add_argument("--no-plot", action="store_true", help="do not write the figure")
    p.add_argument(
        "--progress", action=argparse.BooleanOptionalAction, default=None, help="progress bar on stderr"
    )
    _add_budget(p)

    p = sub.add_parser("orbit", help="periodic orbit at one forcing frequency, with its Floquet multipliers")
    _add_model_args(p)
    p.add_argument(
        "--x0", action="append", metavar="NAME=VALUE", help="initial guess of a variable (default 0)"
    )
    p.add_argument("--mode0", help="mode of the guess (default: the model's initial mode)")
    p.add_argument(
        "--transient",
        type=_nonnegative_int,
        default=10,
        metavar="N",
        help="forcing periods simulated from the guess before Newton's method (default 10); if Newton "
        "fails from there, the orbit is sought by continuation in the forcing frequency (0: no fallback)",
    )
    _add_tolerances(p)
    p.add_argument(
        "--samples-per-period",
        type=_positive_int,
        default=512,
        help="samples of the period (default 512, at most 100000)",
    )
    p.add_argument("--out", default=None, help=OUT_HELP)
    p.add_argument("--json", action="store_true", help="print the orbit as JSON on stdout")
    p.add_argument("--no-plot", action="store_true", help="do not write the figure")
    _add_budget(p)

    p = sub.add_parser(
        "frc", help="frequency-response curve: periodic orbits continued in the forcing frequency"
    )
    _add_model_args(p, omega=False)
    p.add_argument(
        "--parameter",
        default=None,
        metavar="NAME",
        help="parameter to continue in (default: the forcing frequency, the parameter the period depends on)",
    )
    p.add_argument(
        "--omega-range",
        nargs=2,
        type=_positive_float,
        metavar=("A", "B"),
        help="range of the continued parameter (default, for the forcing frequency: 0.8 x lowest to "
        "1.2 x highest natural frequency of the initial mode linearised at rest)",
    )
    _add_tolerances(p)
    p.add_argument("--out", default=None, help=OUT_HELP)
    p.add_argument("--json", action="store_true", help="print a JSON summary on stdout")
    p.add_argument("--no-plot", action="store_true", help="do not write the figure")
    p.add_argument(
        "--workers",
        type=_positive_int,
        default=None,
        metavar="N",
        help="pieces of the range (one per resonance) computed at once, in forked processes (default: "
        "the number of CPUs; 1: one after the other; the result is the same)",
    )
    p.add_argument(
        "--progress", action=argparse.BooleanOptionalAction, default=None, help="progress bar on stderr"
    )
    _add_budget(p)

    sub.add_parser("models", help="list the built-in models")
    _add_show_parser(sub)
    from ._cli_sweep import add_parsers  # here: it imports this module's helpers

    add_parsers(sub)  # `sweep` and `chart`
    # Subcommands of installed packages: `register(subparsers)` adds one and sets its `handler`.
    for ep in entry_points(group=COMMAND_GROUP):
        if ep.name not in COMMANDS:
            ep.load()(sub)
    return parser


def _add_show_parser(sub) -> None:
    p = sub.add_parser("show", help="print a model's modes, guards and transitions (and its network, if any)")
    p.add_argument("model", help="built-in model name (see `hybrid models`) or path of a model file (.toml)")
    p.add_argument(
        "--out", default=None, metavar="PNG", help="also draw the network of a network file to PNG"
    )


def _info(msg: str) -> None:
    print(msg, file=sys.stderr)


def cmd_models(args) -> int:
    models = sorted(builtin_models().items())
    width = max((len(name) for name, _ in models), default=0)
    for name, ep in models:
        system = ep.load()()
        presets = ", ".join(system.presets) or "-"
        print(f"{name:{width}s}  {system.title}  [presets: {presets}]")
    return 0


def _samples_per_period(args) -> int:
    if args.samples_per_period > MAX_SAMPLES_PER_PERIOD:
        raise UsageError(
            f"`--samples-per-period` is at most {MAX_SAMPLES_PER_PERIOD}, got {args.samples_per_period}"
        )
    return args.samples_per_period


class _SwitchesAt(Sink):
    """Sink keeping the switches at one instant (those the initial state forces at the start)."""

    def __init__(self, t: float):
        self.t = t
        self.events = []

    def event(self, record) -> None:
        if record.t == self.t:
            self.events.append(record)


def cmd_simulate(args) -> int:
    system = resolve_model(args.model)
    spp = _samples_per_period(args)
    preset, params = _parameters(system, args)
    period = system.period_value(params)
    if args.t_end is not None:
        t_end = args.t_end
    else:
        if period is None:
            raise UsageError(f"model `{system.name}` has no forcing period: give --t-end")
        t_end = (args.periods if args.periods is not None else 200.0) * period
    if period and t_end / period * spp > MAX_STREAMED_SAMPLES:
        raise UsageError(
            f"{t_end / period:.6g} periods at {spp} samples per period make more than {MAX_STREAMED_SAMPLES} "
            "samples, the most a run may write: shorten the run or lower --samples-per-period"
        )
    x0 = {n: 0.0 for n in system.variable_names}
    x0.update(_pairs(args.x0, "--x0"))
    options = SolverOptions(rtol=args.rtol, atol=args.atol, **_budget_options(args))
    _check_integrator(system, params, options)
    out = _output_dir(system, args)
    _announce(system, preset, params)
    bar = ProgressBar(f"simulating {system.name}", enabled=args.progress)
    kwargs = {"samples_per_period": spp, "include_events": True} if period else {}
    # Samples and switches go to the CSV files as the run goes on; memory holds the figure's window
    # (the last periods; the whole run, up to the in-memory cap, for a model without a period) and a
    # min/max envelope of the displacements for its whole-run panel.
    keep_last = min(PLOT_PERIODS * period, t_end) if period else t_end
    displacements = list(plot_hints(system)["displacements"])
    history = (
        None
        if args.no_plot
        else Envelope(displacements, system.variable_names, (0.0, t_end), HISTORY_BUCKETS)
    )
    at_start = _SwitchesAt(0.0)
    out.mkdir(parents=True, exist_ok=True)
    t0 = time.perf_counter()
    with (
        TrajectoryCSVWriter(out / "trajectory.csv", system) as samples_csv,
        EventsCSVWriter(out / "events.csv", system) as events_csv,
        time_limit(args.max_time),
    ):
        sink = Tee(samples_csv, events_csv, at_start, *([history] if history is not None else []))
        traj = simulate(
            system,
            params,
            (0.0, t_end),
            x0,
            args.mode0,
            options=options,
            throw=False,
            progress=bar,
            sink=sink,
            keep_last=keep_last,
            **kwargs,
        )
    wall = time.perf_counter() - t0
    files = [samples_csv.path, events_csv.path]
    if history is not None and traj.t.size > 1:
        from ._plot import plot_trajectory  # matplotlib only when a figure is wanted

        files.append(
            plot_trajectory(traj, out / "trajectory.png", last_periods=PLOT_PERIODS, history=history)
        )
    summary = trajectory_summary(traj)
    summary.update(
        {
            "preset": preset,
            "omega": params.get("Omega"),
            "periods": round(t_end / period, 9) if period else None,
            "wall_time_s": wall,
            "files": [str(f) for f in files],
        }
    )
    summary_path = out / "summary.json"
    summary["files"].append(str(summary_path))
    summary_path.write_text(to_json(summary) + "\n")
    if args.json:
        print(to_json(summary))
    for f in files + [summary_path]:
        _info(f"wrote {f}")
    at_start = at_start.events
    if at_start:
        _info(
            f"note: the initial state is not admissible in mode `{at_start[0].source}`; at t = {traj.t_start:g} "
            + ", then ".join(f"{ev.source} -> {ev.target} ({ev.guard})" for ev in at_start)
        )
    if not traj.success:
        _info(f"hybrid: simulation stopped early: {traj.message}")
        return 1
    _info(
        f"{traj.n_transitions} transitions, final mode `{traj.mode_final}`, {wall:.2f} s"
        + (f", input work {summary['input_work']:.6g} J" if "input_work" in summary else "")
        + (f", dissipated {summary['dissipated_energy']:.6g} J" if "dissipated_energy" in summary else "")
    )
    return 0


def _announce(system: HybridSystem, preset: str | None, params: dict[str, float]) -> None:
    if preset:
        _info(
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
    folder = Path(model).stem if _is_model_file(model) else system.name
    out = Path("out") / folder
    if not folder.isprintable() or folder in ("", ".", "..") or out.resolve().parent != Path("out").resolve():
        raise UsageError(
            f"{folder!r} does not name a folder inside out/: rename the model file or give --out"
        )
    return out


def _output_dir(system: HybridSystem, args) -> Path:
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


def writable_folder(out: Path) -> Path:
    """``out`` (the folder of ``--out``), created and checked writable before any computation.

    Raises
    ------
    UsageError
        It exists and is not a folder, or cannot be created or written.
    """
    if out.exists() and not out.is_dir():
        raise UsageError(f"`--out {out}`: exists and is not a folder")
    try:
        out.mkdir(parents=True, exist_ok=True)
        probe = out / f".hybrid-write-test-{os.getpid()}"
        probe.write_bytes(b"")
        probe.unlink()
    except OSError as exc:
        raise UsageError(f"output folder {str(out)!r} cannot be written: {exc.strerror or exc}") from None
    return out


def _unit(system: HybridSystem, name: str) -> str:
    units = {v.name: v.unit for v in system.variables}
    return units.get(name) or plot_hints(system)["units"].get(name, "")


def _orbit_text(orbit: PeriodicOrbit, preset: str | None) -> str:
    """A readable summary of a periodic orbit (the stdout of ``hybrid orbit`` without ``--json``)."""
    system = orbit.system
    omega = orbit.params.get("Omega")
    head = f"{system.name}" + (f", preset `{preset}`" if preset else "")
    head += (f", Omega = {omega:g} rad/s" if omega is not None else "") + f": period T = {orbit.period:.9g} s"
    head += " (autonomous: the period is an unknown, found with the orbit)" if system.period is None else ""
    lines = [head]
    if not orbit.converged:
        lines.append(f"  NO periodic orbit: {orbit.message}")
        return "\n".join(lines)
    lines.append(
        f"  converged: residual {orbit.residual:.2g} after {orbit.iterations} Newton iterations, "
        f"cond(I - M) = {orbit.condition:.3g}"
    )
    route = {"newton": "Newton's method from the guess (after its transient)"}.get(orbit.route, orbit.route)
    lines.append(f"  found by: {route}")
    fl = np.abs(orbit.floquet_multipliers)
    verdict = {
        "stable": "stable (all Floquet multipliers inside the unit circle)",
        "unstable": "UNSTABLE (a Floquet multiplier outside the unit circle)",
        "neutral": "neutral (marginally stable: a multiplier on the unit circle)",
    }.get(orbit.stability, orbit.stability)
    lines.append(f"  stability: {verdict}" + (f", max |mu| = {fl.max():.9g}" if fl.size else ""))
    seq = " -> ".join(orbit.mode_sequence)
    lines.append(
        f"  {orbit.transitions_per_period} switches per period; modes from t0 = {orbit.t0:.6g} s: {seq}"
    )
    if orbit.mode_fractions:
        fr = ", ".join(f"{m} {f:.4f}" for m, f in orbit.mode_fractions.items())
        lines.append(f"  fraction of the period per mode: {fr}")
    lines.append("  multipliers (Re, Im, |mu|, kind):")
    for mu, kind in zip(orbit.multipliers, orbit.multiplier_kinds, strict=True):
        lines.append(f"    {mu.real:+.9f} {mu.imag:+.9f}i   |mu| = {abs(mu):.9f}   {kind}")
    lines.append("  amplitudes (max |x| and half peak-to-peak over the period):")
    width = max(len(n) for n in orbit.amplitude)
    for name, amp in orbit.amplitude.items():
        unit = _unit(system, name)
        lines.append(
            f"    {name:{width}s}  {amp:.9g}  {orbit.half_peak_to_peak[name]:.9g}"
            + (f" {unit}" if unit else "")
        )
    lines.append(f"  {orbit.message}")
    return "\n".join(lines)


def cmd_orbit(args) -> int:
    system = resolve_model(args.model)
    spp = _samples_per_period(args)
    preset, params = _parameters(system, args)
    mode0 = args.mode0 if args.mode0 is not None else system.initial_mode
    if mode0 is None:
        raise UsageError(f"model `{system.name}` declares no initial mode: give --mode0")
    system.mode(mode0)  # unknown mode -> ModelError
    guess = {n: 0.0 for n in system.variable_names}
    guess.update(_pairs(args.x0, "--x0"))
    initial_state(system, guess, mode0)  # unknown or non-finite values -> ValueError
    options = SolverOptions(rtol=args.rtol, atol=args.atol, **_budget_options(args))
    _check_integrator(system, params, options)
    out = _output_dir(system, args)
    _announce(system, preset, params)
    t0 = time.perf_counter()
    with time_limit(args.max_time):
        orbit = periodic_orbit(
            system,
            params,
            guess,
            mode0,
            transient_periods=args.transient,
            options=options,
            samples_per_period=spp,
        )
    wall = time.perf_counter() - t0
    summary = {"omega": params.get("Omega"), "preset": preset, **orbit.to_dict()}
    summary["multiplier_moduli"] = [float(abs(z)) for z in orbit.multipliers]
    summary["wall_time_s"] = wall
    files: list[Path] = []
    if orbit.converged:
        out.mkdir(parents=True, exist_ok=True)
        files.append(write_trajectory_csv(orbit.trajectory, out / "orbit.csv"))
        if not args.no_plot:
            from ._plot import plot_orbit  # matplotlib only when a figure is wanted

            files.append(plot_orbit(orbit, out / "orbit.png"))
        summary["files"] = [str(f) for f in files] + [str(out / "orbit.json")]
        files.append(out / "orbit.json")
        (out / "orbit.json").write_text(to_json(summary) + "\n")
    print(to_json(summary) if args.json else _orbit_text(orbit, preset))
    for f in files:
        _info(f"wrote {f}")
    if not orbit.converged:
        _info(f"hybrid: no periodic orbit: {orbit.message}")
        return 1
    _info(f"periodic orbit in {wall:.2f} s")
    return 0


FRC_OVERLAY_GROUP = "hybrid.frc_overlays"


def frc_overlays(system: HybridSystem, params: dict[str, float], omega: np.ndarray) -> dict:
    """Overlay curves of a model (``hybrid.frc_overlays`` entry point named like it), or ``{}``.

    A failing overlay function is reported on stderr and drawn as nothing.
    """
    eps = {ep.name: ep for ep in entry_points(group=FRC_OVERLAY_GROUP)}
    if system.name not in eps:
        return {}
    try:
        curves = eps[system.name].load()(dict(params), omega)
        return {
            str(c): {
                str(n): np.broadcast_to(np.asarray(v, dtype=float), omega.shape) for n, v in coords.items()
            }
            for c, coords in curves.items()
        }
    except Exception as exc:  # model code: report, do not stop the run
        _info(
            f"hybrid: warning: overlays of `{system.name}` failed ({type(exc).__name__}: {exc}); none drawn"
        )
        return {}


def _frc_text(fr, preset: str | None) -> str:
    """A readable summary of a frequency response (stdout of ``hybrid frc`` without ``--json``)."""
    system = fr.system
    par = fr.parameter
    lo, hi = fr.p_range
    lines = [
        f"{system.name}"
        + (f", preset `{preset}`" if preset else "")
        + f": {par} from {lo:.6g} to {hi:.6g} rad/s",
        "  natural frequencies of the linearised initial mode: "
        + (", ".join(f"{w:.6g}" for w in fr.resonances) or "none")
        + " rad/s",
    ]
    coords = list(plot_hints(system)["displacements"])
    for k, b in enumerate(fr.branches):
        if not b.points:
            lines.append(f"  branch {k}: no point ({b.message})")
            continue
        p = b.p
        stab = {s: b.stability.count(s) for s in dict.fromkeys(b.stability)}
        lines.append(
            f"  branch {k}: {len(p)} orbits, {par} {p[0]:.6g} -> {p[-1]:.6g}, "
            + ", ".join(f"{n} {s}" for s, n in stab.items())
            + (f"; {b.status}: {b.message}" if b.status != "completed" else "")
        )
        for name in coords:
            a = b.amplitude(name)
            i = int(np.argmax(a))
            lines.append(f"    max |{name}| = {a[i]:.6g} at {par} = {p[i]:.6g}")
    for row in fr.special_rows():
        where = (
            f"{par} = {row[par]:.10g} (located, +-{row['accuracy']:.2g})"
            if row["status"] == "located"
            else f"{par} in [{row['interval_lo']:.10g}, {row['interval_hi']:.10g}] (bracketed)"
        )
        lines.append(
            f"  {row['kind']} at {where} (branch {row['branch']}, {row['stability']}): " + row["description"]
        )
    for a, b in fr.gaps:
        lines.append(f"  GAP: no periodic orbit computed for {par} in ({a:.8g}, {b:.8g})")
    return "\n".join(lines)


def _import_in_background(module: str) -> Callable[[], None]:
    """A function that starts importing ``module`` in a daemon thread (a later import waits for it),
    at the lowest scheduling priority where the platform sets one per thread (Linux): it then
    takes a core the workers leave idle (the piece that finishes first) rather than slow them."""

    def load() -> None:
        try:
            os.setpriority(os.PRIO_PROCESS, threading.get_native_id(), 19)  # this thread only (Linux)
        except (AttributeError, OSError):
            pass
        importlib.import_module(module)

    def start() -> None:
        threading.Thread(target=load, daemon=True).start()

    return start


def cmd_frc(args) -> int:
    import csv

    from ._continuation import forcing_parameter, orbit_row
    from ._frc import default_range, frequency_response
    from ._io import _cell

    system = resolve_model(args.model)
    if system.period is None:
        raise UsageError(
            f"model `{system.name}` declares no forcing `period`: a frequency response needs one; an "
            f"autonomous model's periodic orbits and equilibria are continued with "
            f"`hybrid cont {system.name} --param NAME --range A B`"
        )
    forcing = forcing_parameter(system)
    par = args.parameter if args.parameter is not None else forcing
    if par not in system.parameter_names:
        raise UsageError(
            f"model `{system.name}` has no parameter `{par}` to continue in; "
            f"parameters: {', '.join(system.parameter_names)}"
        )
    preset, params = _parameters(system, args)
    if args.omega_range is not None:
        lo, hi = args.omega_range
        if not lo < hi:
            raise UsageError(f"`--omega-range A B` needs A < B, got {lo:g} {hi:g}")
    elif par == forcing:
        lo, hi = default_range(system, params)
    else:
        raise UsageError(f"give the range of `{par}` (--omega-range A B)")
    options = SolverOptions(rtol=args.rtol, atol=args.atol, **_budget_options(args))
    _check_integrator(system, params, options)
    out = _output_dir(system, args)
    _announce(system, preset, params)
    _info(f"continuation in {par} from {lo:.6g} to {hi:.6g}")
    out.mkdir(parents=True, exist_ok=True)
    # Every orbit is written to frc.csv as it is accepted: an interrupt keeps what was done.
    csv_path = out / "frc.csv"
    written = {"rows": 0}
    fh = csv_path.open("w", newline="")
    writer = csv.writer(fh)
    columns: list[str] = []

    def on_point(k: int, orbit) -> None:
        row = {"branch": k, **orbit_row(par, orbit)}
        if not columns:
            columns.extend(row)
            writer.writerow(columns)
        writer.writerow([_cell(row.get(c)) for c in columns])
        fh.flush()
        written["rows"] += 1

    bar = ProgressBar(f"frc {system.name}", enabled=args.progress)
    t0 = time.perf_counter()
    try:
        with time_limit(args.max_time):
            fr = frequency_response(
                system,
                params,
                (lo, hi),
                parameter=par,
                options=options,
                progress=bar,
                on_point=on_point,
                workers=args.workers or os.cpu_count() or 1,
                # matplotlib is imported (0.4 s) while the workers compute
                while_computing=None if args.no_plot else _import_in_background("hybrid._plot_frc"),
            )
    except KeyboardInterrupt:
        _info(
            f"hybrid: interrupted after {time.perf_counter() - t0:.1f} s: "
            f"{written['rows']} periodic orbits kept in {csv_path}"
        )
        return 130
    finally:
        fh.close()
    bar(1.0)
    wall = time.perf_counter() - t0

    from ._plot_frc import zoom_windows

    files = [csv_path]
    special = fr.special_rows()
    files.append(
        write_rows_csv(
            special,
            out / "frc_special.csv",
            None
            if special
            else ["branch", "row", "kind", par, "status", "accuracy", "stability", "description"],
        )
    )
    overlays, grid = {}, None
    if par == forcing:  # the models' overlays are curves over the forcing frequency
        zooms = zoom_windows(fr)
        grid = np.unique(
            np.concatenate([np.linspace(lo, hi, 2001)] + [np.linspace(a, b, 801) for a, b, _ in zooms])
        )
        overlays = frc_overlays(system, params, grid)
        ov_rows = [{par: float(w)} for w in grid]
        for curve, coords in overlays.items():
            for name, values in coords.items():
                for row, v in zip(ov_rows, values, strict=True):
                    row[f"{curve}: {name}"] = float(v)
        files.append(write_rows_csv(ov_rows, out / "frc_overlays.csv"))
    if not args.no_plot:
        from ._plot_frc import plot_frc

        files.append(plot_frc(fr, out / "frc.png", overlays=overlays, grid=grid))
    summary = {
        "model": system.name,
        "preset": preset,
        "parameter": par,
        "parameters": {k: v for k, v in params.items() if k != par},
        "omega_range": [lo, hi],
        "natural_frequencies": [float(w) for w in fr.resonances],
        "branches": [
            {
                "points": len(b.points),
                "omega_start": float(b.p[0]) if b.points else None,
                "omega_end": float(b.p[-1]) if b.points else None,
                "status": b.status,
                "reason": b.reason,
                "message": b.message,
            }
            for b in fr.branches
        ],
        "special": special,
        "gaps": [list(g) for g in fr.gaps],
        "complete": fr.complete,
        "overlays": list(overlays),
        "wall_time_s": wall,
        "files": [str(f) for f in files] + [str(out / "frc.json")],
    }
    (out / "frc.json").write_text(to_json(summary) + "\n")
    files.append(out / "frc.json")
    print(to_json(summary) if args.json else _frc_text(fr, preset))
    for f in files:
        _info(f"wrote {f}")
    n = sum(len(b.points) for b in fr.branches)
    _info(f"{n} periodic orbits in {wall:.1f} s")
    family = sum(1 for b in fr.branches for o in b.points if o.family)
    if family and system._cache.get("gauge") is None:
        _info(
            f"hybrid: {family} orbits belong to families of periodic orbits (a neutral multiplier 1) and the "
            "model declares no `[orbit] gauge`: the branch keeps the member nearest its first orbit (found "
            "from a transient), which may be off-centre, e.g. touching a guard on one side only (slip setting "
            "in early); a gauge (an expression of the state that is 0 on the member wanted, e.g. a stuck "
            "element's offset) picks the member (README, docs/models.md)"
        )
    if not fr.complete:
        for m in fr.messages():
            _info(f"hybrid: {m}")
        return 1
    return 0


def _table(header: Sequence[str], rows: list[Sequence[str]]) -> list[str]:
    """Rows as text columns, each as wide as its widest cell (the last one left ragged)."""
    widths = [max(len(str(r[k])) for r in [header, *rows]) for k in range(len(header) - 1)]
    lines = []
    for r in [header, *rows]:
        cells = [str(c).ljust(w) for c, w in zip(r[:-1], widths, strict=True)] + [str(r[-1])]
        lines.append("  " + "  ".join(cells).rstrip())
    return lines


def show_text(system: HybridSystem, description: str | None = None) -> str:
    """A model as text: its network (if given), then its modes and its transitions as tables."""
    lines = [description, ""] if description else []
    lines.append(f"model `{system.name}`" + (f": {system.title}" if system.title else ""))
    lines.append(
        f"  {len(system.variables)} variables, {len(system.modes)} modes, {len(system.transitions)} transitions, "
        f"initial mode {system.initial_mode or system.mode_names[0]}"
    )
    lines.append("")
    lines.append("modes:")
    rows = []
    for m in system.modes:
        differential = [v for v in system.variable_names if v not in m.algebraic]
        rows.append((m.name, ", ".join(differential), ", ".join(m.algebraic) or "-"))
    lines += _table(("mode", "differential", "slave (algebraic)"), rows)
    found = surfaces(system)
    if found:
        lines.append("")
        lines.append("discontinuity surfaces h = 0 of sign(h) (Filippov's convention, docs/filippov.md):")
        rows = [
            (s.h, s.mode, s.coefficient, "sliding" if s.slides else "crossing only", ", ".join(s.modes))
            for s in found
        ]
        lines += _table(("h", "in mode", "sign(h) is", "on h = 0", "derived modes"), rows)
    lines.append("")
    lines.append("transitions:")
    arrow = {1: "rising", -1: "falling", 0: "either"}
    rows = [
        (
            t.name,
            t.source,
            t.target,
            arrow[t.direction],
            t.guard,
            ", ".join(f"{k} = {v}" for k, v in t.reset.items()) or "-",
        )
        for t in system.transitions
    ]
    lines += _table(("name", "from", "to", "crossing", "guard", "reset"), rows)
    return "\n".join(lines)


def cmd_show(args) -> int:
    system = resolve_model(args.model)
    is_file = _is_model_file(args.model) or Path(args.model).exists()
    description = describe_model_file(Path(args.model)) if is_file else None
    if args.out is not None:
        out = Path(args.out)
        if not args.out.strip() or out.is_dir() or not out.parent.is_dir():
            raise UsageError(f"`--out {args.out}` must name a PNG file in an existing folder")
        if description is None or not draw_model_file(Path(args.model), out):
            raise UsageError(f"model `{system.name}` is not a network file: there is no network to draw")
    print(show_text(system, description))
    if args.out is not None:
        _info(f"wrote {args.out}")
    return 0


COMMANDS = {
    "models": cmd_models,
    "simulate": cmd_simulate,
    "orbit": cmd_orbit,
    "frc": cmd_frc,
    "show": cmd_show,
}


def main(argv: Sequence[str] | None = None) -> int:
    """Entry point of the ``hybrid`` command."""
    parser = build_parser()
    args = parser.parse_args(argv)
    try:
        handler = COMMANDS.get(args.command) or args.handler
        return handler(args)
    except (UsageError, ModelError, ExpressionError, ValueError, TypeError) as exc:
        print(f"hybrid: error: {exc}", file=sys.stderr)
        return 2
    except SimulationError as exc:  # pragma: no cover - runs use throw=False
        print(f"hybrid: simulation failed: {exc}", file=sys.stderr)
        return 1


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
