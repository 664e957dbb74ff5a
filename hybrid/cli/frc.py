"""``hybrid frc``: the frequency-response curve (periodic orbits continued in the forcing
frequency), written row by row as it is computed, with its special points, overlays and figure."""

from __future__ import annotations

import argparse
import csv
import importlib
import os
import threading
import time
from collections.abc import Callable
from importlib.metadata import entry_points

import numpy as np

from ..continuation.branch import forcing_parameter, orbit_row
from ..continuation.frc import Piece, default_range, frequency_response
from ..continuation.switching import SWITCHABLE, switch_branch
from ..core.budget import deadline_passed, no_deadline, time_limit
from ..core.errors import HybridError
from ..core.plain import options_text, plain_data
from ..core.progress import ProgressBar
from ..core.status import BranchStatus, ResponseStatus
from ..core.workers import Terminated, cap_workers
from ..engine.io import csv_cell, to_json, write_rows_csv
from ..integrators.options import SolverOptions
from ..model.linear import linear_response, natural_frequencies
from ..model.plot_hints import plot_hints, unit_of
from ..model.system import HybridSystem
from .common import (
    OUT_HELP,
    UsageError,
    add_budget,
    add_locate_tol,
    add_model_args,
    add_tolerances,
    announce,
    check_integrator,
    info,
    model,
    output_dir,
    parameters,
    positive_float,
    positive_int,
    results,
    solver_options,
    with_locate_tol,
)

FRC_OVERLAY_GROUP = "hybrid.frc_overlays"

#: The files `frc` writes in its output folder.
FILES = ("frc.csv", "frc_special.csv", "frc_overlays.csv", "frc.png", "frc.json")


def register(sub) -> None:
    """Add this subcommand to the subparsers of ``hybrid``."""
    p = sub.add_parser(
        "frc", help="frequency-response curve: periodic orbits continued in the forcing frequency"
    )
    add_model_args(p, omega=False)
    p.add_argument(
        "--parameter",
        default=None,
        metavar="NAME",
        help="parameter to continue in (default: the forcing frequency, the parameter the period depends on)",
    )
    p.add_argument(
        "--omega-range",
        nargs=2,
        type=positive_float,
        metavar=("A", "B"),
        help="range of the continued parameter (default, for the forcing frequency: 0.8 x lowest to "
        "1.2 x highest natural frequency of the initial mode linearised at rest)",
    )
    add_tolerances(p)
    add_locate_tol(p)
    p.add_argument(
        "--switch",
        type=int,
        action="append",
        default=None,
        metavar="N",
        help="switch branches at special point N (its row in frc_special.csv, from 0, as printed): at a "
        "branch-point follow the crossing branch both ways, at a period-doubling the branch of twice the "
        "period (hybrid.switch_branch); the new branches are added to the curve (repeatable)",
    )
    p.add_argument("--out", default=None, help=OUT_HELP)
    p.add_argument("--json", action="store_true", help="print a JSON summary on stdout")
    p.add_argument("--no-plot", action="store_true", help="do not write the figure")
    p.add_argument(
        "--workers",
        type=positive_int,
        default=None,
        metavar="N",
        help="pieces of the range (one per resonance) computed at once, in forked processes (default: "
        "the number of CPUs; 1: one after the other; the result is the same)",
    )
    p.add_argument(
        "--progress", action=argparse.BooleanOptionalAction, default=None, help="progress bar on stderr"
    )
    add_budget(p)
    p.set_defaults(handler=cmd_frc)


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
        info(f"hybrid: warning: overlays of `{system.name}` failed ({type(exc).__name__}: {exc}); none drawn")
        return {}


def linear_references(
    system: HybridSystem, params: dict[str, float], parameter: str, grid: np.ndarray
) -> dict:
    """The linear references of a model over ``grid``: ``{label: {coordinate: max |x|}}``.

    Each is a mode named in the model's ``linear_references`` plot hint (a network file: every
    contact stuck, every contact sliding; by default the initial mode), linearised at rest by
    :func:`hybrid.model.linear.linear_response`. One that cannot be computed is reported on
    stderr and left out.
    """
    coords = list(plot_hints(system)["displacements"])
    out = {}
    for label, mode in plot_hints(system)["linear_references"].items():
        try:
            amps = linear_response(system, params, mode, parameter, grid)
        except (HybridError, np.linalg.LinAlgError) as exc:
            info(f"hybrid: warning: the linear reference `{label}` (mode `{mode}`) was not computed: {exc}")
            continue
        out[str(label)] = {c: amps[c] for c in coords if c in amps}
    return out


def frc_text(fr, preset: str | None) -> str:
    """A readable summary of a frequency response (stdout of ``hybrid frc`` without ``--json``)."""
    system = fr.system
    par = fr.parameter
    lo, hi = fr.p_range
    unit = unit_of(system, par)
    initial = natural_frequencies(system, fr.params) if len(fr.resonances) else fr.resonances
    whose = "the linearised initial mode"
    if len(fr.resonances) and not len(initial):
        mode = next(
            m
            for m in plot_hints(system)["linear_references"].values()
            if len(natural_frequencies(system, fr.params, m))
        )
        whose = f"mode `{mode}` linearised (the initial mode has none)"
    lines = [
        f"{system.name}"
        + (f", preset `{preset}`" if preset else "")
        + f": {par} from {lo:.6g} to {hi:.6g} {unit}".rstrip(),
        f"  natural frequencies of {whose}: "
        + (", ".join(f"{w:.6g}" for w in fr.resonances) or "none")
        + " rad/s",
        f"  computed with options={options_text(fr.options)}, settings={options_text(fr.settings)}",
    ]
    coords = list(plot_hints(system)["displacements"])
    for k, b in enumerate(fr.branches):
        if not b.points:
            lines.append(f"  branch {k}: no point ({b.message})")
            continue
        p = b.values
        stab = {s: b.stability.count(s) for s in dict.fromkeys(b.stability)}
        lines.append(
            f"  branch {k}: {len(p)} orbits, {par} {p[0]:.6g} -> {p[-1]:.6g}, "
            + ", ".join(f"{n} {s}" for s, n in stab.items())
            + (f"; {b.status}: {b.message}" if b.status != BranchStatus.COMPLETED else "")
        )
        for name in coords:
            a = b.amplitude(name)
            i = int(np.argmax(a))
            lines.append(f"    max |{name}| = {a[i]:.6g} at {par} = {p[i]:.6g}")
    for row in fr.special_rows:
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


def _switch(fr, rows: list[int], p_range, options: SolverOptions, on_point) -> list[dict]:
    """Switch branches at the special points of rows ``rows`` (of :meth:`FrequencyResponse.special_rows`):
    the new branches are added to ``fr`` as one more piece over the range (their orbits passed to
    ``on_point`` with their branch indices); returns what was done, per row."""
    index = [(k, j) for k, b in enumerate(fr.branches) for j in range(len(b.special))]
    for n in rows:
        if not 0 <= n < len(index):
            raise UsageError(
                f"--switch {n}: the curve has {len(index)} special points (rows 0 to {len(index) - 1})"
            )
        k, j = index[n]
        kind = fr.branches[k].special[j].kind
        if kind not in SWITCHABLE["forced-orbits"]:
            ok = [
                str(m)
                for m, (a, b) in enumerate(index)
                if fr.branches[a].special[b].kind in SWITCHABLE["forced-orbits"]
            ]
            raise UsageError(
                f"--switch {n}: special point {n} is a {kind}; branches are switched at a branch-point or a "
                f"period-doubling (rows: {', '.join(ok) or 'none'})"
            )
    out = []
    piece = Piece(p_range[0], p_range[1], None)
    for n in rows:
        k, j = index[n]
        first = len(fr.branches)
        new = switch_branch(fr.branches[k], j, p_range, options=options)
        piece.branches.extend(new)
        if piece not in fr.pieces:
            fr.pieces.append(piece)
        for m, b in enumerate(new):
            for o in b.points:
                on_point(first + m, o)
        info(
            f"switched at special point {n} ({fr.branches[k].special[j].kind}): branches {first} to {first + len(new) - 1}"
        )
        out.append(
            {
                "row": n,
                "kind": fr.branches[k].special[j].kind,
                "branches": list(range(first, first + len(new))),
            }
        )
    return out


def import_in_background(module: str) -> Callable[[], None]:
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
    system = model(args.model)
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
    preset, params = parameters(system, args)
    if args.omega_range is not None:
        lo, hi = args.omega_range
        if not lo < hi:
            raise UsageError(f"`--omega-range A B` needs A < B, got {lo:g} {hi:g}")
    elif par == forcing:
        lo, hi = default_range(system, params)
    else:
        raise UsageError(f"give the range of `{par}` (--omega-range A B)")
    options = solver_options(args)
    check_integrator(system, params, options)
    out = output_dir(system, args)
    with results(out, FILES) as staged:
        announce(system, preset, params)  # (after the folder is locked and checked)
        info(f"continuation in {par} from {lo:.6g} to {hi:.6g}")
        fr, files, summary, wall = _run_frc(
            args, system, params, preset, par, forcing, lo, hi, options, out, staged
        )
    if fr is None:  # interrupted: the rows written are in place (`wall` is the exit code)
        return wall
    with no_deadline():  # (the summary's natural frequencies, after a time limit too)
        print(to_json(summary) if args.json else frc_text(fr, preset))
    for f in files:
        info(f"wrote {f}")
    n = sum(len(b.points) for b in fr.branches)
    info(f"{n} periodic orbits in {wall:.1f} s")
    family = sum(1 for b in fr.branches for o in b.points if o.family)
    if family and system.parsed.gauge is None:
        info(
            f"hybrid: {family} orbits belong to families of periodic orbits (a neutral multiplier 1) and the "
            "model declares no `[orbit] gauge`: the branch keeps the member nearest its first orbit (found "
            "from a transient), which may be off-centre, e.g. touching a guard on one side only (slip setting "
            "in early); a gauge (an expression of the state that is 0 on the member wanted, e.g. a stuck "
            "element's offset) picks the member (README, docs/models.md)"
        )
    if fr.status != ResponseStatus.COMPLETE:
        for m in fr.messages():
            info(f"hybrid: {m}")
        return 1
    return 0


def _run_frc(args, system, params, preset, par, forcing, lo, hi, options, out, staged):
    """The curve computed and its files written in ``staged`` (:func:`hybrid.cli.common.results`);
    ``(fr, files, summary, wall)``, or Nones after an interrupt (the orbits done are kept)."""
    # Every orbit is written to frc.csv as it is accepted: an interrupt keeps what was done.
    csv_path = out / "frc.csv"  # (where it will be once the run ends)
    written = {"rows": 0}
    fh = staged.path("frc.csv").open("w", newline="")
    writer = csv.writer(fh)
    columns: list[str] = []

    def on_point(k: int, orbit) -> None:
        row = {"branch": k, **orbit_row(par, orbit)}
        try:
            if not columns:
                columns.extend(row)
                writer.writerow(columns)
            writer.writerow([csv_cell(row.get(c)) for c in columns])
            fh.flush()
        except OSError as exc:  # (a full disk: the error names the file)
            exc.filename = exc.filename or str(csv_path)
            raise
        written["rows"] += 1

    bar = ProgressBar(f"frc {system.name}", enabled=args.progress)
    workers, note = cap_workers(args.workers, None)
    if note:  # (the pieces of the range cap them too, silently: one per resonance)
        info(note)
    t0 = time.perf_counter()
    try:
        with time_limit(args.max_time):
            fr = frequency_response(
                system,
                params,
                (lo, hi),
                parameter=par,
                options=options,
                settings=with_locate_tol(None, args),
                progress=bar,
                on_point=on_point,
                workers=workers,
                # matplotlib is imported (0.4 s) while the workers compute
                while_computing=None if args.no_plot else import_in_background("hybrid.plot.frc"),
            )
            switched = _switch(fr, args.switch, (lo, hi), options, on_point) if args.switch else []
    except KeyboardInterrupt as exc:
        info(
            f"hybrid: interrupted{_signal_name(exc)} after {time.perf_counter() - t0:.1f} s: "
            f"{written['rows']} periodic orbits kept in {csv_path}"
        )
        return None, None, None, exc.exit_code if isinstance(exc, Terminated) else 130
    finally:
        try:
            fh.close()
        except OSError:  # its rows were flushed one by one: the error, if any, was raised there
            pass
    bar(1.0)
    wall = time.perf_counter() - t0
    late = deadline_passed()  # (the whole command's --max-time, hybrid.cli.main)
    with no_deadline():  # what was computed is written, the limit passed or not
        return _write_frc(
            args, system, params, preset, par, forcing, lo, hi, out, staged, fr, switched, wall, late
        )


def _write_frc(args, system, params, preset, par, forcing, lo, hi, out, staged, fr, switched, wall, late):
    """The files of :func:`_run_frc` once the curve is computed: ``(fr, files, summary, wall)``.
    After the time limit (``late``) the linear references, whose set-up grows with the model, are
    not computed (issue 33: a ring of 24 blades spent minutes in them past --max-time)."""
    from ..plot.frc import zoom_windows

    csv_path = out / "frc.csv"
    files = [csv_path]
    special = fr.special_rows
    write_rows_csv(
        special,
        staged.path("frc_special.csv"),
        None if special else ["branch", "row", "kind", par, "status", "accuracy", "stability", "description"],
    )
    files.append(out / "frc_special.csv")
    overlays, references, grid = {}, {}, None
    if par == forcing:  # the models' overlays are curves over the forcing frequency
        zooms = zoom_windows(fr)
        grid = np.unique(
            np.concatenate([np.linspace(lo, hi, 2001)] + [np.linspace(a, b, 801) for a, b, _ in zooms])
        )
        overlays = frc_overlays(system, params, grid)
        if late and plot_hints(system)["linear_references"]:
            info("hybrid: the linear references were not computed: the time limit (--max-time) had passed")
        else:
            references = linear_references(system, params, par, grid)
        ov_rows = [{par: float(w)} for w in grid]
        for curve, coords in {**overlays, **references}.items():
            for name, values in coords.items():
                for row, v in zip(ov_rows, values, strict=True):
                    row[f"{curve}: {name}"] = float(v)
        write_rows_csv(ov_rows, staged.path("frc_overlays.csv"))
        files.append(out / "frc_overlays.csv")
    if not args.no_plot:
        from ..plot.frc import plot_frc

        plot_frc(fr, staged.path("frc.png"), overlays=overlays, grid=grid, references=references)
        files.append(out / "frc.png")
    summary = _summary(fr, preset, params, (lo, hi), special, switched, overlays, references)
    summary.update(wall_time_s=wall, files=[str(f) for f in files] + [str(out / "frc.json")])
    staged.path("frc.json").write_text(to_json(summary) + "\n")
    files.append(out / "frc.json")
    return fr, files, summary, wall


def _summary(fr, preset, params: dict, p_range, special: list, switched: list, overlays, references) -> dict:
    """frc.json (without its wall time and files): the input, the options that repeat the
    computation, the branches, special points, gaps and the overlays drawn."""
    system, par = fr.system, fr.parameter
    lo, hi = p_range
    return {
        "model": system.name,
        "preset": preset,
        "parameter": par,
        "parameters": {k: v for k, v in params.items() if k != par},
        "omega_range": [lo, hi],
        # what repeats the computation (issue 29 item 6): hybrid.frequency_response(..., options=, settings=)
        "options": plain_data(fr.options),
        "settings": plain_data(fr.settings),
        "natural_frequencies": [float(w) for w in fr.resonances],
        "branches": [
            {
                "points": len(b.points),
                "omega_start": float(b.values[0]) if b.points else None,
                "omega_end": float(b.values[-1]) if b.points else None,
                "status": b.status,
                "reason": b.reason,
                "message": b.message,
            }
            for b in fr.branches
        ],
        "special": special,
        "gaps": [list(g) for g in fr.gaps],
        "switched": switched,
        "complete": fr.status == ResponseStatus.COMPLETE,
        "overlays": list(overlays),
        "linear_references": {c: plot_hints(system)["linear_references"][c] for c in references},
    }


def _signal_name(exc: KeyboardInterrupt) -> str:
    """`` (SIGTERM)`` for a terminating signal, nothing for Ctrl-C."""
    return f" ({exc.name})" if isinstance(exc, Terminated) else ""
