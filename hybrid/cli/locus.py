"""``hybrid locus MODEL --param NAME --range A B --param2 NAME2 --range2 C D --point N``: special
points followed in two parameters (:func:`hybrid.continue_locus`).

1. The one-parameter branch in ``--param`` over ``--range``: for a forced model the periodic orbits
   from ``--x0``/``--mode0`` at ``A`` (:func:`hybrid.continue_orbits`); for an autonomous one the
   equilibria of every mode and the periodic orbit at the preset's value continued both ways (as
   ``hybrid cont``). Its special points are numbered in the order printed (``--list`` prints them
   and stops).
2. The loci of the points ``--point N`` (repeatable) or of every point of ``--kind K``, followed in
   ``--param2`` over ``--range2``.

Writes ``locus.csv`` (one row per point of every locus), ``locus_branch.csv`` (the branch),
``locus.json`` (the special points of the branch, each locus's end, status and wall time) and
``locus.png`` (the branch above, the parameter plane below).

A point is reported ``located`` when its interval's half-width is at most ``--locate-tol`` times
the range of the parameter it was located in (``--range`` or ``--range2``), else ``bracketed``
with its interval; the locators work to the library's tolerance (1e-10 of the range) or a finer
``--locate-tol``.
"""

from __future__ import annotations

import argparse
import math
import time
from dataclasses import is_dataclass, replace

import numpy as np

from ..continuation.autonomous import AUTONOMOUS_CONTINUATION, equilibrium_branch, orbit_branch
from ..continuation.forced import continue_orbits
from ..continuation.locus import LOCUS_KINDS, continue_locus
from ..core.budget import deadline_passed, time_limit
from ..core.errors import BudgetExceeded
from ..core.options import ContinuationOptions
from ..core.progress import ProgressBar
from ..core.status import LocateStatus
from ..engine.io import to_json, write_rows_csv
from ..orbits.autonomous import autonomous_orbit
from .common import (
    OUT_HELP,
    UsageError,
    add_budget,
    add_guess_args,
    add_model_args,
    add_tolerances,
    announce,
    check_integrator,
    guess,
    info,
    model,
    output_dir,
    parameters,
    positive_float,
    positive_int,
    results,
    solver_options,
)

#: The files ``hybrid locus`` writes in its folder.
FILES = ("locus.csv", "locus_branch.csv", "locus.png", "locus.json")

__all__ = ["register", "run"]

#: Default of ``--locate-tol`` (issue 33: the library's ContinuationOptions.locate_tol, 1e-10 of the
#: range, is finer than the exact flow's rounding margin on a narrow range: the absorber's band edge
#: over Omega in [0.852, 0.858], known to 1.5e-12, was reported "bracketed, not located to the
#: tolerance", that tolerance 6e-13).
LOCATE_TOL = 1e-9

#: Grid of the equilibrium branches of an autonomous model (points over the range).
EQUILIBRIUM_POINTS = 41


def register(sub) -> None:
    """Add ``locus`` to the subparsers of ``hybrid``."""
    p = sub.add_parser(
        "locus", help="special points (folds, period doublings, grazings, ...) followed in two parameters"
    )
    add_model_args(p, omega=False)
    p.add_argument("--param", required=True, metavar="NAME", help="the branch's parameter")
    p.add_argument(
        "--range", nargs=2, type=float, required=True, metavar=("A", "B"), help="the branch's range"
    )
    p.add_argument("--param2", metavar="NAME", help="the second parameter")
    p.add_argument("--range2", nargs=2, type=float, metavar=("C", "D"), help="its range")
    p.add_argument(
        "--point", type=int, action="append", metavar="N", help="special point N of the branch (repeatable)"
    )
    p.add_argument("--kind", action="append", metavar="K", help="every special point of kind K (repeatable)")
    p.add_argument("--list", action="store_true", help="print the branch's special points and stop")
    p.add_argument(
        "--step",
        type=positive_float,
        default=0.02,
        help="first step along a locus, in the plane scaled by the ranges (default 0.02)",
    )
    p.add_argument(
        "--max-points", type=positive_int, default=200, help="points per half of a locus (default 200)"
    )
    p.add_argument(
        "--locate-tol",
        type=positive_float,
        default=LOCATE_TOL,
        metavar="TOL",
        help="a special point is `located` when its interval's half-width is at most TOL times the "
        f"range of its parameter (--range, or --range2 for a point located in the second; default {LOCATE_TOL:g}); "
        "else `bracketed`, with its interval",
    )
    add_guess_args(p)
    add_tolerances(p)
    p.add_argument(
        "--coordinate", default=None, metavar="NAME", help="variable whose amplitude the branch shows"
    )
    p.add_argument("--out", default=None, help=OUT_HELP)
    p.add_argument("--json", action="store_true", help="print the summary as JSON on stdout")
    p.add_argument("--no-plot", action="store_true", help="do not write the figure")
    p.add_argument(
        "--progress", action=argparse.BooleanOptionalAction, default=None, help="progress bar on stderr"
    )
    add_budget(p)
    p.set_defaults(handler=run)


def _branches(system, params, args, options, x0, mode0, out: list) -> None:
    """The one-parameter branches whose special points are offered (see the module docstring),
    appended to ``out`` as each is computed (a deadline that passes keeps those done)."""
    lo, hi = args.range
    if system.period is not None:
        out.append(
            continue_orbits(
                system,
                params,
                args.param,
                (lo, hi),
                x0=x0,
                mode0=mode0,
                options=options,
                settings=ContinuationOptions(locate_tol=_search_tol(args)),
            )
        )
        return
    for mode in (m.name for m in system.modes):
        try:
            eb = equilibrium_branch(
                system, params, mode, args.param, np.linspace(min(lo, hi), max(lo, hi), EQUILIBRIUM_POINTS)
            )
        except (ValueError, RuntimeError):
            continue
        if any(e.converged and e.admissible for e in eb.points):
            out.append(eb)
    orbit = autonomous_orbit(system, params, x0, mode0, options=options)
    if orbit.converged and min(lo, hi) <= params[args.param] <= max(lo, hi):
        span = abs(hi - lo)
        st = replace(
            AUTONOMOUS_CONTINUATION,
            ds=0.02 * max(span, 1.0),
            ds_max=0.05 * max(span, 1.0),
            locate_tol=_search_tol(args),
        )
        for direction in (1, -1):
            out.append(
                orbit_branch(
                    orbit,
                    args.param,
                    (min(lo, hi), max(lo, hi)),
                    direction=direction,
                    options=options,
                    settings=st,
                )
            )


def _search_tol(args) -> float:
    """The tolerance the locators work to (relative to a range): the library's default, or the
    one asked for where it is finer. How a point is reported follows ``--locate-tol``
    (:func:`_to_tolerance`)."""
    return min(ContinuationOptions().locate_tol, args.locate_tol)


def _to_tolerance(point, tol: float):
    """``point`` (a special point or a locus point) ``located`` if its interval's half-width is at
    most ``tol`` [the parameter's unit], else ``bracketed`` (one known on a side only stays so)."""
    if not (is_dataclass(point) and hasattr(point, "accuracy") and hasattr(point, "description")):
        return point
    if not math.isfinite(point.accuracy) or point.status == LocateStatus.UNLOCATED:
        return point
    if point.accuracy <= tol:
        note = "; not located to the tolerance"
        desc = point.description.replace(note, "").replace("not located to the tolerance", "").rstrip("; ")
        return replace(point, status=LocateStatus.LOCATED, description=desc)
    return replace(point, status=LocateStatus.BRACKETED)


def _report_to_tolerance(branches: list, tol: float) -> None:
    """Every branch's special points through :func:`_to_tolerance` (``tol``: in ``--param``)."""
    for b in branches:
        b.special[:] = [_to_tolerance(sp, tol) for sp in b.special]


def _settings(branch, locate_tol: float) -> ContinuationOptions | None:
    """The settings of a locus's one-parameter branches: ``--locate-tol`` in those of its kind
    (None: an equilibrium branch's, which continue_locus takes)."""
    if branch.kind == "forced-orbits":
        return ContinuationOptions(locate_tol=locate_tol)
    if branch.kind == "equilibria":
        return None
    return replace(AUTONOMOUS_CONTINUATION, locate_tol=locate_tol)


def _stopped(branches: list, exc: BudgetExceeded | None) -> str | None:
    """Why the branches do not cover the range (a budget ran out, or the deadline passed), or None;
    called inside the command's :func:`hybrid.time_limit`."""
    if exc is not None:
        return str(exc)
    late = [
        b
        for b in branches
        if getattr(b, "reason", "") == "budget" or (deadline_passed() and b.status != "completed")
    ]
    if late:
        return late[0].message
    return "time limit reached (--max-time) before every branch was computed" if deadline_passed() else None


def _compute_branches(system, params, args, options, x0, mode0, branches: list) -> str | None:
    """:func:`_branches` into ``branches``; why they stopped short of the range (None if they did not)."""
    try:
        _branches(system, params, args, options, x0, mode0, branches)
    except BudgetExceeded as exc:
        return _stopped(branches, exc)
    return _stopped(branches, None)


def _listing(branches: list) -> list[str]:
    """The special points of ``branches``, one line each, numbered as ``--point`` takes them."""
    points = [(b, j) for b in branches for j in range(len(b.special))]
    return [
        f"  [{n}] {b.special[j].kind} at {b.parameter} = {b.special[j].parameter:.10g} ({b.special[j].status}) "
        f"on a branch of {b.kind}"
        for n, (b, j) in enumerate(points)
    ]


def _chosen(args, points: list, listing: list[str], stopped: str | None) -> list[int]:
    """The special points to follow (``--point``, ``--kind``), checked.

    Raises
    ------
    UsageError
        A point that is not on the branch, or not of a kind followed, or none of the kinds asked for.
    BudgetExceeded
        As the first case or the last, but the branch stopped short of its range (a budget): the
        point may lie beyond where it stopped.
    """
    late = f"the branch stopped before the end of its range ({stopped}); " if stopped is not None else ""
    chosen = list(args.point or [])
    for n in chosen:
        if not 0 <= n < len(points):
            text = f"--point {n}: the branch has {len(points)} special points" + (
                f" (0 to {len(points) - 1})" if points else ""
            )
            if late:
                raise BudgetExceeded("time", f"{late}{text} found before it")
            raise UsageError(text)
    chosen += [
        n
        for n, (b, j) in enumerate(points)
        if args.kind and b.special[j].kind in args.kind and n not in chosen
    ]
    bad = [
        n
        for n in chosen
        if points[n][0].special[points[n][1]].kind not in LOCUS_KINDS.get(points[n][0].kind, ())
    ]
    if bad:
        raise UsageError(
            f"special point(s) {', '.join(map(str, bad))} are not of a kind followed: "
            + "; ".join(f"{k}: {', '.join(v)}" for k, v in LOCUS_KINDS.items())
            + "\n"
            + "\n".join(listing)
        )
    if not chosen:
        if late:
            raise BudgetExceeded(
                "time", f"{late}no special point of the kinds asked for among those found before it"
            )
        raise UsageError(
            "no special point of the kinds asked for on the branch:\n" + "\n".join(listing or ["  (none)"])
        )
    return chosen


def coordinates(system) -> list[str]:
    """The names ``--coordinate`` may take: the variables that are not quadratures, and the outputs."""
    return [v for v in system.variable_names if v not in system.quadratures] + list(system.outputs)


def run(args) -> int:
    """Handler of ``hybrid locus``."""
    system = model(args.model)
    for name in (args.param, args.param2):
        if name is not None and name not in system.parameter_names:
            raise UsageError(
                f"model `{system.name}` has no parameter `{name}`; parameters: {', '.join(system.parameter_names)}"
            )
    lo, hi = args.range
    if not (math.isfinite(lo) and math.isfinite(hi) and lo != hi):
        raise UsageError(f"--range must be two different finite numbers, got {args.range}")
    if not args.list:
        if args.param2 is None or args.range2 is None:
            raise UsageError(
                "give the second parameter and its range (--param2 NAME --range2 C D), or --list"
            )
        if args.param2 == args.param:
            raise UsageError("--param2 must differ from --param")
        if not (args.point or args.kind):
            raise UsageError("give the special points to follow (--point N or --kind K; --list shows them)")
    if args.coordinate is not None and args.coordinate not in coordinates(system):
        raise UsageError(
            f"--coordinate `{args.coordinate}` is not a variable (other than a quadrature) nor an output of "
            f"`{system.name}`; coordinates: {', '.join(coordinates(system))}"
        )
    preset, params = parameters(system, args)
    x0, mode0 = guess(system, args)
    options = solver_options(args)
    check_integrator(system, params, options)
    if args.list:  # writes nothing: no folder to lock
        announce(system, preset, params)
        branches: list = []
        with time_limit(args.max_time):
            stopped = _compute_branches(system, params, args, options, x0, mode0, branches)
        _report_to_tolerance(branches, args.locate_tol * abs(hi - lo))
        print(
            "\n".join(
                [f"{system.name}: special points of the branch in {args.param}"]
                + (_listing(branches) or ["  (none)"])
            )
        )
        if stopped is not None:
            info(
                f"hybrid: the branch stopped before the end of its range, so the list may miss points: {stopped}"
            )
            return 1
        return 0
    out = output_dir(system, args)
    bar = ProgressBar(f"locus {system.name}", enabled=args.progress)
    with results(out, FILES) as fs:  # the folder locked for the whole run, the files renamed into place
        announce(system, preset, params)  # (after the folder is locked and checked)
        t0 = time.perf_counter()
        with time_limit(args.max_time):
            branches = []
            stopped = _compute_branches(system, params, args, options, x0, mode0, branches)
            _report_to_tolerance(branches, args.locate_tol * abs(hi - lo))
            points = [(b, j) for b in branches for j in range(len(b.special))]
            listing = _listing(branches)
            chosen = _chosen(args, points, listing, stopped)
            loci = []
            for m, n in enumerate(chosen):
                b, j = points[n]
                done = m / len(chosen)
                lc = continue_locus(
                    b,
                    j,
                    args.param2,
                    tuple(args.range2),
                    step=args.step,
                    max_points=args.max_points,
                    options=options,
                    settings=_settings(b, _search_tol(args)),
                    progress=lambda f, done=done: bar(min(1.0, done + f / len(chosen))),
                )
                tols = {args.param: args.locate_tol * abs(hi - lo)}
                tols[args.param2] = args.locate_tol * abs(args.range2[1] - args.range2[0])
                lc.points[:] = [_to_tolerance(q, tols[q.located]) for q in lc.points]
                loci.append(lc)
                info(
                    f"locus of point {n} ({lc.kind}): {len(lc.points)} points in {lc.wall_time:.1f} s; {lc.message}"
                )
        bar(1.0)
        wall = time.perf_counter() - t0
        rows = [
            {"locus": k, "point": n, **r}
            for k, (n, lc) in enumerate(zip(chosen, loci, strict=True))
            for r in lc.to_rows()
        ]
        write_rows_csv(rows, fs.path("locus.csv"))
        written = ["locus.csv"]
        brows = [{"branch": k, **r} for k, b in enumerate(branches) for r in b.to_rows()]
        write_rows_csv(brows, fs.path("locus_branch.csv"))
        written.append("locus_branch.csv")
        if not args.no_plot:
            from ..plot.locus import plot_locus

            plot_locus(loci, [b for b in branches if b.points], fs.path("locus.png"), args.coordinate)
            written.append("locus.png")
        summary = {
            "model": system.name,
            "preset": preset,
            "parameters": params,
            "parameter": args.param,
            "range": [lo, hi],
            "parameter2": args.param2,
            "range2": list(args.range2),
            "locate_tol": args.locate_tol,
            "special": [
                {
                    "point": n,
                    "kind": b.special[j].kind,
                    "value": b.special[j].parameter,
                    "status": b.special[j].status,
                    "interval": list(b.special[j].interval),
                    "branch_kind": b.kind,
                }
                for n, (b, j) in enumerate(points)
            ],
            "loci": [
                {
                    "point": n,
                    "kind": lc.kind,
                    "points": len(lc.points),
                    "status": lc.status,
                    "message": lc.message,
                    "wall_time_s": lc.wall_time,
                    "located": sum(1 for q in lc.points if q.status == "located"),
                }
                for n, lc in zip(chosen, loci, strict=True)
            ],
            "wall_time_s": wall,
            "files": [str(fs.final(n)) for n in [*written, "locus.json"]],
        }
        fs.path("locus.json").write_text(to_json(summary) + "\n")
    if args.json:
        print(to_json(summary))
    else:
        lines = [f"{system.name}: loci in ({args.param}, {args.param2})"] + listing
        for lc in summary["loci"]:
            lines.append(
                f"  locus of point {lc['point']} ({lc['kind']}): {lc['points']} points ({lc['located']} located), "
                f"{lc['wall_time_s']:.1f} s; {lc['message']}"
            )
        print("\n".join(lines))
    for n in [*written, "locus.json"]:
        info(f"wrote {out / n}")
    info(f"loci in {wall:.1f} s")
    return 0 if all(lc.status == "completed" for lc in loci) else 1
