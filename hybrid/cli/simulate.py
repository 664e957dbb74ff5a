"""``hybrid simulate``: a run written to CSV as it goes, with its figure and summary."""

from __future__ import annotations

import argparse
import time

import numpy as np

from ..core.budget import time_limit
from ..core.plain import plain_data
from ..core.progress import ProgressBar
from ..engine.io import EventsCSVWriter, TrajectoryCSVWriter, to_json, trajectory_summary
from ..engine.record import MAX_STREAMED_SAMPLES, Envelope, Sink, Tee
from ..engine.simulate import simulate
from ..model.plot_hints import plot_hints
from .common import (
    OUT_HELP,
    UsageError,
    add_budget,
    add_model_args,
    add_tolerances,
    announce,
    check_integrator,
    info,
    model,
    output_dir,
    pairs,
    parameters,
    positive_float,
    positive_int,
    results,
    samples_per_period,
    solver_options,
)

#: Forcing periods at the end of a `simulate` run kept in memory for its figure.
PLOT_PERIODS = 4.0

#: Samples at the end of a `simulate` run kept in memory for its figure, at most (a model without a
#: period is sampled on every step: its window is the last samples, not the last periods).
PLOT_SAMPLES = 100_000

#: Time buckets of the whole-run panel of the `simulate` figure.
HISTORY_BUCKETS = 2000

#: The files `simulate` writes in its output folder.
FILES = ("trajectory.csv", "events.csv", "trajectory.png", "summary.json")


def register(sub) -> None:
    """Add this subcommand to the subparsers of ``hybrid``."""
    p = sub.add_parser("simulate", help="simulate a model and write CSV, figure and summary")
    add_model_args(p)
    span = p.add_mutually_exclusive_group()
    span.add_argument(
        "--periods", type=positive_float, help="length of the run in forcing periods (default 200)"
    )
    span.add_argument("--t-end", type=positive_float, help="length of the run [s] (models without a period)")
    p.add_argument(
        "--x0", action="append", metavar="NAME=VALUE", help="initial value of a variable (default 0)"
    )
    p.add_argument("--mode0", help="initial mode (default: the model's initial mode)")
    add_tolerances(p, rtol=1e-8, atol=1e-10)
    p.add_argument(
        "--samples-per-period",
        type=positive_int,
        default=100,
        help="output samples per period (default 100, at most 100000)",
    )
    p.add_argument(
        "--samples",
        type=positive_int,
        default=None,
        metavar="N",
        help="models without a period: N output samples evenly spaced over the run, the integrator "
        "going from one to the next in one call (default: every internal step is a sample)",
    )
    p.add_argument("--out", default=None, help=OUT_HELP)
    p.add_argument("--json", action="store_true", help="print a JSON summary on stdout")
    p.add_argument("--no-plot", action="store_true", help="do not write the figure")
    p.add_argument(
        "--progress", action=argparse.BooleanOptionalAction, default=None, help="progress bar on stderr"
    )
    add_budget(p)
    p.set_defaults(handler=cmd_simulate)


class SwitchesAt(Sink):
    """Sink keeping the switches at one instant (those the initial state forces at the start)."""

    def __init__(self, t: float):
        self.t = t
        self.events = []

    def event(self, record) -> None:
        if record.t == self.t:
            self.events.append(record)


def cmd_simulate(args) -> int:
    system = model(args.model)
    spp = samples_per_period(args)
    preset, params = parameters(system, args)
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
    x0.update(pairs(args.x0, "--x0"))
    options = solver_options(args)
    check_integrator(system, params, options)
    out = output_dir(system, args)
    bar = ProgressBar(f"simulating {system.name}", enabled=args.progress)
    kwargs = {"samples_per_period": spp, "include_events": True} if period else {}
    if args.samples is not None:
        if period:
            raise UsageError(
                f"--samples is for models without a forcing period; model `{system.name}` has one: "
                "use --samples-per-period"
            )
        if not 2 <= args.samples <= MAX_STREAMED_SAMPLES:
            raise UsageError(f"--samples must lie in [2, {MAX_STREAMED_SAMPLES}], got {args.samples}")
        # (issue 34: IDA steps between the samples inside SUNDIALS, no Python call per internal step)
        kwargs = {"t_eval": np.linspace(0.0, t_end, args.samples), "include_events": True}
    # Samples and switches go to the CSV files as the run goes on; memory holds the figure's window
    # (the last periods; for a model without a period, sampled on every step, the last PLOT_SAMPLES
    # samples) and a min/max envelope of the displacements for its whole-run panel: memory is
    # bounded whatever the length of the run. Without a figure only the last sample is kept.
    keep_last = 0.0 if args.no_plot else min(PLOT_PERIODS * period, t_end) if period else t_end
    displacements = list(plot_hints(system)["displacements"])
    history = (
        None
        if args.no_plot
        else Envelope(displacements, system.variable_names, (0.0, t_end), HISTORY_BUCKETS)
    )
    at_start = SwitchesAt(0.0)
    with results(out, FILES) as files:
        announce(system, preset, params)  # (after the folder is locked and checked)
        t0 = time.perf_counter()
        with (
            TrajectoryCSVWriter(files.path("trajectory.csv"), system) as samples_csv,
            EventsCSVWriter(files.path("events.csv"), system) as events_csv,
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
                max_kept=PLOT_SAMPLES,
                **kwargs,
            )
        wall = time.perf_counter() - t0
        written = ["trajectory.csv", "events.csv"]
        if history is not None and traj.t.size > 1:
            from ..plot.trajectory import plot_trajectory  # matplotlib only when a figure is wanted

            plot_trajectory(traj, files.path("trajectory.png"), last_periods=PLOT_PERIODS, history=history)
            written.append("trajectory.png")
        summary = trajectory_summary(traj)
        summary.update(
            {
                "preset": preset,
                "omega": params.get("Omega"),
                "periods": round(t_end / period, 9) if period else None,
                "options": plain_data(traj.options),  # what repeats the run (issue 29 item 6)
                "wall_time_s": wall,
                "files": [str(files.final(n)) for n in written],
            }
        )
        written.append("summary.json")
        summary["files"].append(str(files.final("summary.json")))
        files.path("summary.json").write_text(to_json(summary) + "\n")
    if args.json:
        print(to_json(summary))
    for n in written:
        info(f"wrote {out / n}")
    at_start = at_start.events
    if at_start:
        info(
            f"note: the initial state is not admissible in mode `{at_start[0].source}`; at t = {traj.t_start:g} "
            + ", then ".join(f"{ev.source} -> {ev.target} ({ev.guard})" for ev in at_start)
        )
    if not traj.success:
        info(f"hybrid: simulation stopped early: {traj.message}")
        return 1
    info(
        f"{traj.n_transitions} transitions, final mode `{traj.mode_final}`, {wall:.2f} s"
        + (f", input work {summary['input_work']:.6g} J" if "input_work" in summary else "")
        + (f", dissipated {summary['dissipated_energy']:.6g} J" if "dissipated_energy" in summary else "")
    )
    return 0
