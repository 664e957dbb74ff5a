"""Command line: ``hybrid simulate MODEL ...`` and ``hybrid models``.

Models are found by name among the installed ``hybrid.models`` entry points
(the project's built-ins: absorber, isolator, coulomb) or given as the path of
a model file (``.toml``). Bad input is reported in one line on stderr with
exit code 2, a failed simulation with exit code 1; no tracebacks.
"""

from __future__ import annotations

import argparse
import math
import sys
import time
from collections.abc import Sequence
from importlib.metadata import entry_points
from pathlib import Path

from ._expr import ExpressionError
from ._io import to_json, trajectory_summary, write_events_csv, write_trajectory_csv
from ._loader import load_system
from ._options import SolverOptions
from ._progress import ProgressBar
from ._simulate import SimulationError, simulate
from ._system import HybridSystem, ModelError

__all__ = ["main", "resolve_model"]

ENTRY_POINT_GROUP = "hybrid.models"


class UsageError(ValueError):
    """Bad command-line input."""


def builtin_models() -> dict[str, object]:
    """Installed model entry points by name."""
    return {ep.name: ep for ep in entry_points(group=ENTRY_POINT_GROUP)}


def resolve_model(name: str) -> HybridSystem:
    """A built-in model by name, or a model file by path."""
    eps = builtin_models()
    if name.endswith(".toml") or "/" in name or (name not in eps and Path(name).exists()):
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
    if preset is not None:
        return preset
    if "standard" in system.presets:
        return "standard"
    return next(iter(system.presets), None)


def _parameters(system: HybridSystem, args) -> tuple[str | None, dict[str, float]]:
    preset = _choose_preset(system, args.preset)
    values = _pairs(args.set, "--set")
    if args.omega is not None:
        if "Omega" not in system.parameter_names:
            raise UsageError(f"model `{system.name}` has no parameter `Omega` for --omega")
        values["Omega"] = args.omega
    return preset, system.parameter_values(values, preset=preset)


def _positive_float(text: str) -> float:
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"{text!r} is not a number") from None
    if not (math.isfinite(value) and value > 0):
        raise argparse.ArgumentTypeError(f"must be a finite number > 0, got {text}")
    return value


def _positive_int(text: str) -> int:
    try:
        value = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"{text!r} is not an integer") from None
    if value < 1:
        raise argparse.ArgumentTypeError(f"must be an integer >= 1, got {text}")
    return value


def _add_model_args(p: argparse.ArgumentParser) -> None:
    p.add_argument("model", help="built-in model name (see `hybrid models`) or path of a model file (.toml)")
    p.add_argument("--preset", help="named parameter set of the model (default: `standard` if it has one)")
    p.add_argument("--set", action="append", metavar="NAME=VALUE", help="override a parameter (repeatable)")
    p.add_argument(
        "--omega", type=_positive_float, help="excitation frequency [rad/s] (sets parameter Omega)"
    )


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
    p.add_argument("--samples-per-period", type=_positive_int, default=100, help="output samples per period")
    p.add_argument("--out", default=None, help="output folder (default out/MODEL)")
    p.add_argument("--json", action="store_true", help="print a JSON summary on stdout")
    p.add_argument("--no-plot", action="store_true", help="do not write the figure")
    p.add_argument(
        "--progress", action=argparse.BooleanOptionalAction, default=None, help="progress bar on stderr"
    )
    sub.add_parser("models", help="list the built-in models")
    return parser


def _info(msg: str) -> None:
    print(msg, file=sys.stderr)


def cmd_models(args) -> int:
    for name, ep in sorted(builtin_models().items()):
        system = ep.load()()
        presets = ", ".join(system.presets) or "-"
        print(f"{name:10s} {system.title}  [presets: {presets}]")
    return 0


def cmd_simulate(args) -> int:
    system = resolve_model(args.model)
    preset, params = _parameters(system, args)
    period = system.period_value(params)
    if args.t_end is not None:
        t_end = args.t_end
    else:
        if period is None:
            raise UsageError(f"model `{system.name}` has no forcing period: give --t-end")
        t_end = (args.periods if args.periods is not None else 200.0) * period
    x0 = {n: 0.0 for n in system.variable_names}
    x0.update(_pairs(args.x0, "--x0"))
    options = SolverOptions(rtol=args.rtol, atol=args.atol)
    out = Path(args.out if args.out is not None else Path("out") / system.name)
    if preset:
        _info(
            f"model `{system.name}`, preset `{preset}`: " + ", ".join(f"{k}={v:g}" for k, v in params.items())
        )
    bar = ProgressBar(f"simulating {system.name}", enabled=args.progress)
    kwargs = {"samples_per_period": args.samples_per_period, "include_events": True} if period else {}
    t0 = time.perf_counter()
    traj = simulate(
        system, params, (0.0, t_end), x0, args.mode0, options=options, throw=False, progress=bar, **kwargs
    )
    wall = time.perf_counter() - t0
    out.mkdir(parents=True, exist_ok=True)
    files = [write_trajectory_csv(traj, out / "trajectory.csv"), write_events_csv(traj, out / "events.csv")]
    if not args.no_plot and traj.t.size > 1:
        from ._plot import plot_trajectory  # matplotlib only when a figure is wanted

        files.append(plot_trajectory(traj, out / "trajectory.png"))
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
    at_start = [ev for ev in traj.events if ev.t == traj.t_start]
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


def main(argv: Sequence[str] | None = None) -> int:
    """Entry point of the ``hybrid`` command."""
    parser = build_parser()
    args = parser.parse_args(argv)
    try:
        if args.command == "models":
            return cmd_models(args)
        return cmd_simulate(args)
    except (UsageError, ModelError, ExpressionError, ValueError, TypeError) as exc:
        print(f"hybrid: error: {exc}", file=sys.stderr)
        return 2
    except SimulationError as exc:  # pragma: no cover - runs use throw=False
        print(f"hybrid: simulation failed: {exc}", file=sys.stderr)
        return 1


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
