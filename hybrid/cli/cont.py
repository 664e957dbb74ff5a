"""``hybrid cont MODEL --param NAME --range A B``: equilibria and periodic orbits of an autonomous
model continued in one parameter.

What it computes, in order:

1. the equilibria of every mode over the range (those that exist and are admissible somewhere),
   their stability, and every loss of stability located (a Hopf point for a complex pair);
2. from each Hopf point, the branch of periodic orbits born there, followed until it leaves the
   range or meets a switch (a grazing);
3. the periodic orbit at the preset's value of the parameter (from a transient started at ``--x0``
   in ``--mode0``, by default all zero in the model's initial mode), continued both ways (e.g. the
   stick-slip cycle).

It writes ``cont.csv`` (one row per point), ``cont.json`` (the special points, as
:class:`hybrid.SpecialPoint` fields, and each branch's end: status, reason, range) and ``cont.png`` (amplitude and period against the parameter; stable solid, unstable dashed,
the losses of stability marked).
"""

from __future__ import annotations

import argparse
import csv
import math
import sys
import time
from dataclasses import replace

import numpy as np

from ..continuation.autonomous import AUTONOMOUS_CONTINUATION, equilibrium_branch, hopf_branch, orbit_branch
from ..continuation.branch import Branch
from ..core.budget import deadline_passed, time_limit
from ..core.errors import BudgetExceeded
from ..core.plain import plain_data
from ..core.progress import ProgressBar
from ..core.status import BranchStatus
from ..engine.io import to_json
from ..orbits.autonomous import autonomous_orbit, time_scale
from .common import (
    UsageError,
    add_budget,
    add_guess_args,
    add_locate_tol,
    add_model_args,
    add_tolerances,
    announce,
    guess,
    model,
    output_dir,
    parameters,
    results,
    solver_options,
    with_locate_tol,
)

__all__ = ["register", "run"]

#: The files `cont` writes in its output folder.
FILES = ("cont.csv", "cont.png", "cont.json")

#: Grid of the equilibrium branches (points over the range).
EQUILIBRIUM_POINTS = 41


def register(subparsers) -> None:
    """Add ``cont`` to the subparsers of ``hybrid``.

    Parameters
    ----------
    subparsers : argparse._SubParsersAction
    """
    p = subparsers.add_parser(
        "cont", help="autonomous model: equilibria, Hopf points and periodic orbits continued in a parameter"
    )
    add_model_args(p, omega=False)
    p.add_argument("--param", required=True, metavar="NAME", help="the parameter to continue")
    add_guess_args(p)
    p.add_argument("--range", nargs=2, type=float, required=True, metavar=("A", "B"), help="its range")
    p.add_argument(
        "--coordinate",
        default=None,
        metavar="NAME",
        help="variable or output whose amplitude "
        "(half peak-to-peak) is plotted (default: the first displacement of the model's [plot])",
    )
    add_tolerances(p, rtol=1e-10, atol=1e-12)
    add_locate_tol(p)
    p.add_argument("--out", default=None, help="output folder (default out/MODEL)")
    p.add_argument("--json", action="store_true", help="print the summary as JSON on stdout")
    p.add_argument("--no-plot", action="store_true", help="do not write the figure")
    p.add_argument(
        "--progress", action=argparse.BooleanOptionalAction, default=None, help="progress bar on stderr"
    )
    add_budget(p)
    p.set_defaults(handler=run)


def _special(sp, branch) -> dict:
    """A special point as JSON (an equilibrium's Hopf point with its frequency [rad/s])."""
    out = {
        "kind": sp.kind,
        "value": sp.parameter,
        "status": sp.status,
        "accuracy": sp.accuracy,
        "interval": list(sp.interval),
        "description": sp.description,
    }
    if branch.kind == "equilibria":
        out["frequency"] = abs(float(branch.points[sp.index].eigenvalues[0].imag))
    return out


def _rows_of_orbits(kind: str, k: int, branch, coord: str) -> list[dict]:
    rows = []
    for o in branch.points:
        triv = [m for m, kd in zip(o.multipliers, o.multiplier_kinds, strict=True) if kd == "trivial"]
        fl = np.abs(o.floquet_multipliers)
        rows.append(
            {
                "kind": kind,
                "branch": k,
                "parameter": o.params[branch.parameter],
                "amplitude": o.half_peak_to_peak[coord],
                "period": o.period,
                "stability": o.stability,
                "max_abs_multiplier": float(fl.max()) if fl.size else 0.0,
                "trivial_multiplier_error": float(abs(triv[0] - 1.0)) if triv else math.nan,
                "modes": "/".join(sorted(o.mode_fractions)),
            }
        )
    return rows


def run(args) -> int:
    """Handler of ``hybrid cont``."""
    system = model(args.model)
    lo, hi, preset, params, (x0, mode0), coord = _checked_args(args, system)
    options = solver_options(args)
    time_scale(system, params, None)  # a model without a period guess is refused here
    out = output_dir(system, args)
    bar = ProgressBar(f"cont {system.name}", enabled=args.progress)
    settings = with_locate_tol(
        replace(AUTONOMOUS_CONTINUATION, ds=0.02 * max(hi - lo, 1.0), ds_max=0.05 * max(hi - lo, 1.0)), args
    )
    t0 = time.perf_counter()
    rows: list[dict] = []
    summary: dict = {
        "model": system.name,
        "preset": preset,
        "parameters": params,
        "parameter": args.param,
        "range": [lo, hi],
        "coordinate": coord,
        # the options of the orbit branches (issue 29 item 6): hybrid.orbit_branch(..., options=, settings=)
        "options": plain_data(options),
        "settings": plain_data(settings),
        "equilibria": [],
        "orbit_branches": [],
    }
    eq_branches: list = []
    obranches: list = []
    stopped: BaseException | None = None  # a budget that ran out, or an interrupt
    with results(out, FILES) as files:
        announce(system, preset, params)  # (after the folder is locked and checked)
        try:
            with time_limit(args.max_time):
                _compute(
                    system,
                    params,
                    args,
                    lo,
                    hi,
                    options,
                    settings,
                    bar,
                    rows,
                    summary,
                    eq_branches,
                    obranches,
                    (x0, mode0),
                )
        except (BudgetExceeded, KeyboardInterrupt) as exc:  # what was computed is written below
            stopped = exc
        if stopped is None:
            late = [b for b in eq_branches if b.reason == "budget"]
            if late:
                stopped = BudgetExceeded("time", late[0].message)
        bar(1.0)
        for k, (kind, br) in enumerate(obranches):
            rows += _rows_of_orbits(kind, k, br, coord)
            summary["orbit_branches"].append(
                {
                    "start": kind,
                    "points": len(br.points),
                    "status": br.status,
                    "reason": br.reason,
                    "message": br.message,
                    "special": [_special(sp, br) for sp in br.special],
                    "ends": [float(br.values[0]), float(br.values[-1])] if br.points else [],
                }
            )
        wall = time.perf_counter() - t0
        summary["wall_time_s"] = wall
        if stopped is not None:
            summary["stopped"] = str(stopped) if isinstance(stopped, BudgetExceeded) else "interrupted"
        written = ["cont.csv"]
        with open(files.path("cont.csv"), "w", newline="") as fh:
            w = csv.DictWriter(fh, fieldnames=list(rows[0]) if rows else ["kind"])
            w.writeheader()
            w.writerows(rows)
        if not args.no_plot and not isinstance(stopped, KeyboardInterrupt):
            from ..plot.cont import plot_cont

            plot_cont(system, args.param, coord, eq_branches, obranches, files.path("cont.png"))
            written.append("cont.png")
        written.append("cont.json")
        summary["files"] = [str(files.final(n)) for n in written]
        files.path("cont.json").write_text(to_json(summary) + "\n")
        if isinstance(stopped, KeyboardInterrupt):
            raise stopped  # the files are put in place; hybrid.cli.main reports the interrupt
    if args.json:
        print(to_json(summary))
    else:
        print(_text(summary))
    for n in written:
        print(f"wrote {out / n}", file=sys.stderr)
    print(f"continuation in {wall:.1f} s", file=sys.stderr)
    if stopped is not None:
        print(f"hybrid: {stopped}; what was computed before is in {out}", file=sys.stderr)
        return 1
    return 0


def _compute(
    system, params, args, lo, hi, options, settings, bar, rows, summary, eq_branches, obranches, start
):
    """The three phases (module docstring), the orbit's search from ``start`` (``(x0, mode0)``);
    results appended to ``rows``, ``summary``,
    ``eq_branches`` and ``obranches`` as they come (an interrupt or a budget keeps them)."""
    grid = np.linspace(lo, hi, EQUILIBRIUM_POINTS)
    for j, mode in enumerate(m.name for m in system.modes):
        bar(0.3 * j / len(system.modes))
        if deadline_passed():
            eq_branches.append(_late(system, params, args.param, lo))
            return
        try:
            eb = equilibrium_branch(system, params, mode, args.param, grid)
        except (ValueError, RuntimeError):
            continue
        if not any(e.converged and e.admissible for e in eb.points) and eb.reason != "budget":
            continue
        eq_branches.append(eb)
        for e in eb.points:
            if e.converged and e.admissible:
                rows.append(
                    {
                        "kind": "equilibrium",
                        "branch": mode,
                        "parameter": e.params[args.param],
                        "amplitude": 0.0,
                        "period": math.nan,
                        "stability": e.stability,
                        "max_abs_multiplier": math.nan,
                        "trivial_multiplier_error": math.nan,
                        "modes": mode,
                    }
                )
        summary["equilibria"].append({"mode": mode, "special": [_special(sp, eb) for sp in eb.special]})
        if eb.reason == "budget":
            return
    for eb in list(eq_branches):
        for sp in eb.special:
            if sp.kind == "hopf":
                eq = eb.points[sp.index]
                obranches.append(
                    ("hopf", hopf_branch(eq, args.param, (lo, hi), options=options, settings=settings))
                )
    bar(0.5)
    orbit = autonomous_orbit(system, params, *start, options=options)
    summary["orbit_at_preset"] = {"converged": orbit.converged, "message": orbit.message}
    if orbit.converged and lo <= params[args.param] <= hi:
        for k, direction in enumerate((1, -1)):
            bar(0.6 + 0.2 * k)
            obranches.append(
                (
                    "orbit",
                    orbit_branch(
                        orbit,
                        args.param,
                        (lo, hi),
                        direction=direction,
                        options=options,
                        settings=settings,
                    ),
                )
            )


def _checked_args(args, system):
    """The arguments of ``hybrid cont`` checked against the model (each error says what to give):
    ``(lo, hi, preset, params, (x0, mode0), coordinate)``."""
    if system.period is not None:
        raise UsageError(
            f"model `{system.name}` is periodically forced: use `hybrid frc --parameter {args.param}`"
        )
    if args.param not in system.parameter_names:
        raise UsageError(
            f"model `{system.name}` has no parameter `{args.param}`; parameters: "
            f"{', '.join(system.parameter_names)}"
        )
    lo, hi = sorted(args.range)
    if not (math.isfinite(lo) and math.isfinite(hi) and hi > lo):
        raise UsageError(f"--range must be two different finite numbers, got {args.range}")
    preset, params = parameters(system, args)
    x0, mode0 = guess(system, args)
    system.parameter_values({**params, args.param: lo})  # a range outside the domain -> ValueError
    system.parameter_values({**params, args.param: hi})
    coord = args.coordinate or (list(system.plot.get("displacements", ())) or list(system.variable_names))[0]
    if coord not in system.variable_names and coord not in system.outputs:
        raise UsageError(f"--coordinate `{coord}` is neither a variable nor an output of `{system.name}`")
    return lo, hi, preset, params, (x0, mode0), coord


def _late(system, params, parameter: str, lo: float) -> Branch:
    """An empty branch of equilibria standing for the modes not reached before the deadline."""
    br = Branch("equilibria", system, {**params, parameter: lo}, parameter)
    br.status, br.reason = BranchStatus.STOPPED, "budget"
    br.message = "time limit reached (hybrid.time_limit; CLI --max-time) before the equilibria of every mode"
    return br


def _text(s: dict) -> str:
    lines = [f"{s['model']}: continuation in {s['parameter']} over [{s['range'][0]:g}, {s['range'][1]:g}]"]
    for e in s["equilibria"]:
        ch = (
            "; ".join(
                f"{c['kind']} at {s['parameter']} = {c['value']:.12g}"
                + (f" (frequency {c['frequency']:.9g} rad/s)" if c["kind"] == "hopf" else "")
                for c in e["special"]
            )
            or "no change of stability"
        )
        lines.append(f"  equilibria of mode `{e['mode']}`: {ch}")
    for b in s["orbit_branches"]:
        ends = " to ".join(f"{v:.9g}" for v in b["ends"])
        lines.append(
            f"  periodic orbits from the {b['start']}: {b['points']} points, {s['parameter']} from {ends}, "
            f"ended: {b['status']}" + (f" ({b['reason']})" if b["reason"] else "")
        )
    return "\n".join(lines)
