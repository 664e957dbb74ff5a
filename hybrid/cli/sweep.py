"""Subcommands ``hybrid sweep MODEL ...`` and ``hybrid chart DIR`` (added to the parser by :mod:`hybrid.cli`).

``sweep`` runs :func:`hybrid.sweep` over worker processes (``--workers``) or a Dask cluster
(``--scheduler``), with a progress bar of the points done, failed and the time left; ``chart``
writes the design charts of a finished (or partial) sweep (:mod:`hybrid.plot.chart`).
"""

from __future__ import annotations

import argparse
import asyncio
import logging
import math
import sys
import time
from contextlib import contextmanager
from pathlib import Path

from ..core.budget import time_limit
from ..core.errors import WorkerError
from ..core.files import FolderLock
from ..core.progress import ProgressBar
from ..core.workers import ProcessPool, Terminated, cap_workers, die_with_parent
from ..studies.sweep import FAILED, MANIFEST, linear_axis, load_sweep, log_axis, sweep
from .common import (
    UsageError,
    add_model_args,
    add_tolerances,
    add_work_limits,
    check_integrator,
    command_line,
    default_output_dir,
    folder_note,
    info,
    model,
    parameters,
    positive_float,
    positive_int,
    results,
    solver_options,
    writable_folder,
)

__all__ = ["register", "cmd_sweep", "cmd_chart", "dask_client", "die_with_parent"]

#: Seconds to connect to a Dask scheduler and hear it answer as one (`--scheduler`).
HANDSHAKE_TIMEOUT = 10.0
#: The files `chart` writes in its output folder.
CHART_FILES = ("chart.csv", "chart.json", "chart_lines.png", "chart_plane.png")


class _AxisAction(argparse.Action):
    """``--param`` / ``--param-log``: kept in one list, in command-line order (the grid's axis order)."""

    def __call__(self, parser, namespace, values, option_string=None):
        axes = list(getattr(namespace, self.dest) or [])
        axes.append((option_string, list(values)))
        setattr(namespace, self.dest, axes)


def parse_axes(items: list | None) -> list:
    """The grid's axes from ``--param NAME START STOP STEP`` / ``--param-log NAME START STOP NUM``.

    Raises
    ------
    UsageError
        No axis, a number that does not parse, or an axis :func:`hybrid.linear_axis` /
        :func:`hybrid.log_axis` refuses.
    """
    if not items:
        raise UsageError(
            "give at least one axis: --param NAME START STOP STEP or --param-log NAME START STOP NUM"
        )
    axes = []
    for option, (name, *nums) in items:
        words = ("START", "STOP", "NUM" if option == "--param-log" else "STEP")
        vals = []
        for w, text in zip(words, nums, strict=True):
            try:
                vals.append(int(text) if w == "NUM" else float(text))
            except ValueError:
                kind = "an integer" if w == "NUM" else "a number"
                raise UsageError(f"`{option} {name} {' '.join(nums)}`: {w} {text!r} is not {kind}") from None
        try:
            axes.append((log_axis if option == "--param-log" else linear_axis)(name, *vals))
        except ValueError as exc:
            raise UsageError(f"`{option} {name} {' '.join(nums)}`: {exc}") from None
    return axes


def register(sub) -> None:
    """Add ``sweep`` and ``chart`` to the subparsers of ``hybrid``."""
    p = sub.add_parser(
        "sweep",
        help="frequency responses over a grid of parameters, in parallel (processes or Dask), resumable",
        description="Each grid point is a frequency-response curve; its figure of merit is the largest "
        "amplitude (half peak-to-peak) of one coordinate. Every finished point is written at once to "
        "OUT/point-*.json beside OUT/manifest.json; --resume computes only the missing points.",
    )
    add_model_args(p, omega=False)
    p.add_argument(
        "--param",
        dest="axes",
        nargs=4,
        action=_AxisAction,
        metavar=("NAME", "START", "STOP", "STEP"),
        help="an axis of the grid: START, START+STEP, ... up to STOP (repeatable; first axis slowest)",
    )
    p.add_argument(
        "--param-log",
        dest="axes",
        nargs=4,
        action=_AxisAction,
        metavar=("NAME", "START", "STOP", "NUM"),
        help="an axis of NUM values from START to STOP equally spaced in log (0 < START < STOP)",
    )
    p.add_argument(
        "--omega-range",
        nargs=2,
        type=positive_float,
        metavar=("A", "B"),
        help="range of the forcing frequency [rad/s] (default: 0.8 x lowest to 1.2 x highest natural "
        "frequency of the initial mode linearised at rest, over all grid points)",
    )
    p.add_argument(
        "--coordinate",
        default=None,
        metavar="NAME",
        help="variable whose peak amplitude is the figure of merit (default: the model's first coordinate)",
    )
    par = p.add_mutually_exclusive_group()
    par.add_argument(
        "--workers", type=positive_int, default=None, help="worker processes (default os.cpu_count())"
    )
    par.add_argument(
        "--scheduler",
        default=None,
        metavar="ADDRESS",
        help="run on a Dask distributed cluster (e.g. tcp://127.0.0.1:8786; needs the `dask` extra)",
    )
    p.add_argument("--out", default=None, help="output folder (default out/NAME/sweep)")
    p.add_argument(
        "--resume", action="store_true", help="go on with the sweep in --out: compute only the missing points"
    )
    p.add_argument(
        "--point-time-limit",
        type=positive_float,
        default=None,
        metavar="SECONDS",
        help="wall-clock limit of one point: it is recorded as `time limit` and the sweep goes on",
    )
    p.add_argument(
        "--max-time",
        type=positive_float,
        default=None,
        metavar="SECONDS",
        help="wall-clock limit of the whole sweep (default none): the points finished are kept, those in "
        "progress dropped; --resume goes on",
    )
    p.add_argument(
        "--worker-wait",
        type=positive_float,
        default=60.0,
        metavar="SECONDS",
        help="with --scheduler: stop when the cluster has had no worker for this long (default 60 s)",
    )
    add_tolerances(p)
    add_work_limits(p)
    p.add_argument(
        "--progress", action=argparse.BooleanOptionalAction, default=None, help="progress bar on stderr"
    )
    p.set_defaults(handler=cmd_sweep)

    p = sub.add_parser(
        "chart", help="design charts of a sweep: peak amplitude over the parameter plane and as lines"
    )
    p.add_argument("folder", metavar="DIR", help="folder of a sweep (`hybrid sweep --out DIR`)")
    p.add_argument(
        "--x", default=None, metavar="NAME", help="parameter on the horizontal axis (default the first)"
    )
    p.add_argument("--out", default=None, help="output folder (default DIR)")
    p.set_defaults(handler=cmd_chart)


def dask_client(address: str, timeout: float | None = None):
    """A ``distributed.Client`` connected to the Dask scheduler at ``address``.

    The scheduler is asked who it is first, within ``timeout`` seconds (default
    :data:`HANDSHAKE_TIMEOUT`): a listener that is not a Dask scheduler, or that never answers, is
    refused in that time, whatever it sends.

    Raises
    ------
    UsageError
        Dask is not installed, nothing listens at ``address``, or what listens there is not a
        Dask scheduler or does not answer within ``timeout`` [s].
    """
    try:
        from distributed import Client
        from distributed.comm import connect
    except ImportError:
        raise UsageError(
            "`--scheduler` needs Dask's distributed scheduler, which is not installed here: "
            "pip install 'dask[distributed]>=2024.1' (from a checkout of hybrid: pip install '.[dask]')"
        ) from None
    timeout = HANDSHAKE_TIMEOUT if timeout is None else timeout

    async def identity():
        comm = await asyncio.wait_for(connect(address, timeout=timeout), timeout)
        try:
            await asyncio.wait_for(comm.write({"op": "identity"}), timeout)
            return await asyncio.wait_for(comm.read(), timeout)
        finally:
            comm.abort()

    with _quiet_dask():
        try:
            who = asyncio.run(identity())
        except TimeoutError:
            raise UsageError(
                f"`--scheduler {address}`: no Dask scheduler answered within {timeout:g} s (what listens "
                "there is silent, or not a Dask scheduler); give the address `dask scheduler` prints"
            ) from None
        except OSError as exc:
            raise UsageError(f"`--scheduler {address}`: cannot connect: {exc}") from None
        except Exception as exc:  # anything else a stranger at that address makes the client raise
            raise UsageError(
                f"`--scheduler {address}`: not a Dask scheduler ({type(exc).__name__}: {str(exc)[:120]}); "
                "give the address `dask scheduler` prints"
            ) from None
        if not (isinstance(who, dict) and who.get("type") == "Scheduler"):
            raise UsageError(
                f"`--scheduler {address}`: not a Dask scheduler (it answered {str(who)[:80]!r}); give the "
                "address `dask scheduler` prints"
            )
        try:
            return Client(address, timeout=timeout)
        except Exception as exc:
            raise UsageError(
                f"`--scheduler {address}`: cannot connect: {type(exc).__name__}: {exc}"
            ) from None


@contextmanager
def _quiet_dask():
    """Dask's own log (its warnings and tracebacks on a lost connection) silenced: hybrid reports
    what happened in one line."""
    log = logging.getLogger("distributed")
    level = log.level
    log.setLevel(logging.CRITICAL)
    try:
        yield
    finally:
        log.setLevel(level)


class _Workers:
    """The heartbeat of a sweep on a Dask cluster: stops it (:class:`WorkerError`) when the cluster
    has had no worker for ``patience`` seconds (none started, or all died)."""

    def __init__(self, client, address: str, patience: float):
        self.client, self.address, self.patience = client, address, patience
        self.seen = time.monotonic()

    def count(self) -> int:
        try:
            return len(self.client.scheduler_info(n_workers=-1).get("workers", {}))
        except (OSError, RuntimeError):  # the scheduler gone (closed comm, timeout, closed loop)
            return 0

    def __call__(self) -> None:
        now = time.monotonic()
        if self.count():
            self.seen = now
        elif now - self.seen > self.patience:
            raise WorkerError(
                f"the Dask cluster at {self.address} has had no worker for {self.patience:g} s (--worker-wait): "
                f"start workers (dask worker {self.address}) and run again with --resume; the points "
                "finished are kept"
            )


class _SweepBar:
    """A sweep's progress drawn as a bar with the points done, failed and the time left: called as
    ``progress(fraction)`` (the points done), its :meth:`point` as ``on_point(index, result)``
    (counts the failed ones; ``failed``: those found failed in a resumed folder)."""

    def __init__(self, label: str, enabled: bool | None, total: int, failed: int = 0):
        self.bar = ProgressBar(label, enabled=enabled)
        self.t0 = time.perf_counter()
        self.first = None  # points already done when the run started
        self.total = total
        self.failed = failed

    def point(self, index: int | tuple, result: dict) -> None:
        self.failed += result["status"] in FAILED

    def __call__(self, fraction: float) -> None:
        total, failed = self.total, self.failed
        done = round(fraction * total)
        if self.first is None:
            self.first = done
        new = done - self.first
        elapsed = time.perf_counter() - self.t0
        left = (total - done) * elapsed / new if new else math.nan
        eta = f"{left / 60:.1f} min left" if math.isfinite(left) else "time left: after the first point"
        self.bar(done / total if total else 1.0, f"{done}/{total} done, {failed} failed, {eta}")


def cmd_sweep(args) -> int:
    system = model(args.model)
    if system.period is None:
        raise UsageError(
            f"model `{system.name}` declares no forcing `period`: a sweep of frequency responses needs one "
            f"(an autonomous model is continued with `hybrid cont`)"
        )
    axes = parse_axes(args.axes)
    preset, params = parameters(system, args)
    p_range = None
    if args.omega_range is not None:
        p_range = tuple(args.omega_range)
        if not p_range[0] < p_range[1]:
            raise UsageError(f"`--omega-range A B` needs A < B, got {p_range[0]:g} {p_range[1]:g}")
    options = solver_options(args, wall_time=False)
    check_integrator(system, params, options)
    if args.out is not None and not args.out.strip():
        raise UsageError("`--out` needs a folder path, got an empty string")
    out = writable_folder(
        Path(args.out) if args.out is not None else default_output_dir(system, args.model) / "sweep"
    )
    with FolderLock(out, command_line()) as lock:  # one run in the folder: another is refused at once
        folder_note(lock)
        return _sweep_in(args, system, preset, params, axes, p_range, options, out)


def _sweep_in(args, system, preset, params, axes, p_range, options, out: Path) -> int:
    """The sweep in ``out``, whose lock is held."""
    if (out / MANIFEST).exists() and not args.resume:
        raise UsageError(
            f"{str(out)!r} already holds a sweep: add --resume to go on with it, or give another --out"
        )
    resumed = load_sweep(out) if args.resume and (out / MANIFEST).exists() else None  # checked first
    n = math.prod(len(a.values) for a in axes)
    grid = " x ".join(f"{a.name} ({len(a.values)} {a.spacing})" for a in axes)
    info(f"sweep of `{system.name}`" + (f" (preset `{preset}`)" if preset else "") + f": {grid} = {n} points")
    failed = sum(r["status"] in FAILED for r in resumed.points.values()) if resumed is not None else 0
    bar = _SweepBar(f"sweep {system.name}", args.progress, n, failed)
    heartbeat = None
    if args.scheduler is not None:
        executor = dask_client(args.scheduler)
        heartbeat = _Workers(executor, args.scheduler, args.worker_wait)
        where = f"Dask scheduler {args.scheduler}"
    else:
        todo = n - (len(resumed.points) if resumed is not None else 0)
        workers, note = cap_workers(args.workers, todo, "points to compute")
        if note:
            info(note)
        executor = ProcessPool(workers)
        where = f"{workers} worker processes"
    info(f"running on {where}; each point written to {out} as it finishes")
    t0 = time.perf_counter()
    try:
        with _quiet_dask(), time_limit(args.max_time) if args.max_time else _nothing():
            res = sweep(
                system,
                params,
                axes,
                out,
                p_range=p_range,
                coordinate=args.coordinate,
                options=options,
                point_time_limit=args.point_time_limit,
                executor=executor,
                resume=args.resume,
                progress=bar,
                on_point=bar.point,
                heartbeat=heartbeat,
            )
    except KeyboardInterrupt as exc:
        _stop(executor)
        what = f" ({exc.name})" if isinstance(exc, Terminated) else ""
        info(
            f"hybrid: interrupted{what} after {time.perf_counter() - t0:.1f} s: finished points kept in {out}; "
            "run again with --resume to compute the rest"
        )
        return exc.exit_code if isinstance(exc, Terminated) else 130
    except BaseException:
        _stop(executor)
        raise
    _stop(executor)
    wall = time.perf_counter() - t0
    print(_sweep_text(res, wall))
    if res.stopped:
        info(f"hybrid: {res.stopped}")
        return 1
    if res.lost:
        info(
            f"hybrid: {len(res.lost)} points lost by the executor (first: {res.lost[0][1]}); --resume computes them"
        )
    bad = [r for r in res.points.values() if r["status"] in FAILED]
    if bad or not res.complete:
        info(
            f"hybrid: {len(bad)} points failed or ran out of time; their reasons are in their files in {out}"
        )
        return 1
    return 0


@contextmanager
def _nothing():
    yield


def _stop(executor) -> None:
    """End the executor's work now: a process pool's workers killed (the points in progress are
    dropped: they have no file), a Dask client closed."""
    if isinstance(executor, ProcessPool):
        executor.kill()
        return
    with _quiet_dask():  # (hybrid.sweep has cancelled its futures)
        try:
            executor.close(timeout=5)
        except Exception:
            pass


def _sweep_text(res, wall: float) -> str:
    from ..plot.chart import optimum

    m = res.manifest
    counts = ", ".join(f"{v} {k}" for k, v in res.counts().items() if v)
    lines = [
        f"{m['model']}: {len(res.points)} of {len(res.points) + res.counts()['missing']} points ({counts}); "
        f"{len(res.computed)} computed in {wall:.1f} s, {len(res.reused)} found finished",
        f"  figure of merit: peak of {m['coordinate']} (half peak-to-peak) for {m['parameter']} in "
        f"[{m['p_range'][0]:.6g}, {m['p_range'][1]:.6g}]",
    ]
    best = optimum(res)
    if best is not None:
        at = ", ".join(f"{k} = {v:.6g}" for k, v in best["values"].items())
        lines.append(
            f"  lowest bounded peak: {best['peak']:.6g} at {at} ({m['parameter']} = {best['peak_at']:.6g})"
        )
    lines.append(f"  results in {res.folder} (charts: hybrid chart {res.folder})")
    return "\n".join(lines)


def cmd_chart(args) -> int:
    from ..plot.chart import write_charts

    res = load_sweep(args.folder)  # every file checked first
    out = writable_folder(Path(args.out) if args.out is not None else Path(args.folder))
    with results(out, CHART_FILES) as staged:
        files, lines = write_charts(res, staged.staging, x=args.x)
    print("\n".join(lines))
    for f in files:
        print(f"wrote {out / f.name}", file=sys.stderr)
    return 0
