"""``hybrid backbone MODEL --coordinate NAME --amplitudes A1 A2 ... | --amplitude-range LO HI``.

The backbone of a model's nonlinear mode by the extended periodic motion concept
(:func:`hybrid.backbone`): for a model file whose format derives the EPMC system (a network: no
forcing, ``+ xi M v`` on each mass), that system; for another model (a mode-level file, a built-in
model), the model itself, which must be autonomous and have the parameter ``--parameter``
(default ``xi``).

It writes ``backbone.json`` (the points: ``amplitude``, ``omega``, ``xi``, ``damping_ratio``,
``dissipated``, ...; the events; the linear limits), ``backbone.csv`` (one row per point) and
``backbone.png`` (omega and D against the amplitude, log axis, the linear limits drawn).
"""

from __future__ import annotations

import csv
import sys
import time

from ..continuation.backbone import backbone
from ..core.budget import time_limit
from ..core.plain import plain_data
from ..engine.io import to_json
from ..model.loader import epmc_model_file
from ..model.registry import is_model_file
from .common import (
    UsageError,
    add_budget,
    add_model_args,
    add_tolerances,
    announce,
    model,
    output_dir,
    parameters,
    positive_float,
    results,
    solver_options,
)

__all__ = ["register", "run"]

#: The files `backbone` writes in its output folder.
FILES = ("backbone.json", "backbone.csv", "backbone.png")


def register(subparsers) -> None:
    """Add ``backbone`` to the subparsers of ``hybrid``."""
    p = subparsers.add_parser(
        "backbone", help="nonlinear mode by EPMC: frequency and damping ratio against amplitude"
    )
    add_model_args(p, omega=False)
    p.add_argument(
        "--coordinate", required=True, metavar="NAME", help="the variable whose maximum is the amplitude"
    )
    group = p.add_mutually_exclusive_group(required=True)
    group.add_argument(
        "--amplitudes", nargs="+", type=positive_float, metavar="A", help="amplitudes of the points"
    )
    group.add_argument(
        "--amplitude-range",
        nargs=2,
        type=positive_float,
        metavar=("LO", "HI"),
        help="every point of the continuation from LO to HI",
    )
    p.add_argument("--mode", type=int, default=1, metavar="K", help="linear mode to start from (1: lowest)")
    p.add_argument(
        "--parameter",
        default="xi",
        metavar="NAME",
        help="the parameter solved for (default xi, the EPMC term)",
    )
    add_tolerances(p, rtol=1e-10, atol=1e-12)
    p.add_argument("--out", default=None, help="output folder (default out/MODEL)")
    p.add_argument("--json", action="store_true", help="print the result as JSON on stdout")
    p.add_argument("--no-plot", action="store_true", help="do not write the figure")
    add_budget(p)
    p.set_defaults(handler=run)


def _system(name: str):
    if is_model_file(name):
        derived = epmc_model_file(name)
        if derived is not None:
            return derived
    return model(name)


def run(args) -> int:
    """Handler of ``hybrid backbone``."""
    system = _system(args.model)
    if system.period is not None:
        raise UsageError(
            f"model `{system.name}` is periodically forced and its format derives no free system: give the "
            "path of its network file (e.g. models/iwan.toml), whose format derives the EPMC system"
        )
    if args.parameter not in system.parameter_names:
        raise UsageError(
            f"model `{system.name}` has no parameter `{args.parameter}` (--parameter) to solve for"
        )
    if args.coordinate not in system.variable_names:
        raise UsageError(
            f"--coordinate `{args.coordinate}` is not a variable of `{system.name}`; variables: "
            f"{', '.join(system.variable_names)}"
        )
    if args.amplitude_range is not None and not args.amplitude_range[0] < args.amplitude_range[1]:
        raise UsageError(f"--amplitude-range LO HI needs LO < HI, got {args.amplitude_range}")
    if args.mode < 1:
        raise UsageError(f"--mode must be 1 or more, got {args.mode}")
    preset, params = parameters(system, args)
    options = solver_options(args)
    out = output_dir(system, args)
    t0 = time.perf_counter()
    with results(out, FILES) as files:
        announce(system, preset, params)
        with time_limit(args.max_time):
            bb = backbone(
                system,
                params,
                coordinate=args.coordinate,
                mode=args.mode,
                amplitudes=args.amplitudes,
                amplitude_range=tuple(args.amplitude_range) if args.amplitude_range else None,
                parameter=args.parameter,
                options=options,
            )
        wall = time.perf_counter() - t0
        summary = bb.as_dict()
        summary["preset"] = preset
        summary["options"] = plain_data(options)
        summary["wall_time_s"] = wall
        rows = bb.to_rows()
        with open(files.path("backbone.csv"), "w", newline="") as fh:
            w = csv.DictWriter(fh, fieldnames=list(rows[0]) if rows else ["amplitude"])
            w.writeheader()
            w.writerows(rows)
        written = ["backbone.csv"]
        if not args.no_plot:
            from ..plot.backbone import plot_backbone

            plot_backbone(bb, files.path("backbone.png"))
            written.append("backbone.png")
        written.append("backbone.json")
        summary["files"] = [str(files.final(n)) for n in written]
        files.path("backbone.json").write_text(to_json(summary) + "\n")
    if args.json:
        print(to_json(summary))
    else:
        print(_text(bb))
    for n in written:
        print(f"wrote {out / n}", file=sys.stderr)
    print(f"backbone in {wall:.1f} s", file=sys.stderr)
    if bb.reason:
        print(f"hybrid: {bb.message}", file=sys.stderr)
        return 1
    return 0


def _text(bb) -> str:
    lines = [
        f"{bb.system.name}: backbone of mode {bb.mode} in {bb.coordinate} (linear {bb.linear_omega:.10g} rad/s)",
        f"  {'amplitude':>14} {'omega [rad/s]':>16} {'D':>14} {'dissipated':>14}",
    ]
    for p in bb.points:
        lines.append(f"  {p.amplitude:14.8g} {p.omega:16.12g} {p.damping_ratio:14.8g} {p.dissipated:14.8g}")
    for e in bb.events:
        lines.append(
            f"  {e.kind} at amplitude {e.amplitude:.10g} ({e.status}, [{e.interval[0]:.10g}, {e.interval[1]:.10g}])"
        )
    if bb.reason:
        lines.append(f"  stopped ({bb.reason}): {bb.message}")
    elif bb.message:
        lines.append(f"  {bb.message}")
    return "\n".join(lines)
