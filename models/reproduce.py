"""``hybrid reproduce``: regenerate the figures of [1] as PNG + CSV + JSON, and a Markdown report.

Registered as the ``reproduce`` entry point of the group ``hybrid.commands``; :func:`register`
adds the subcommand to ``hybrid``'s parser. The jobs of every figure asked for
(:data:`hybrid_models.figures.FIGURES`) are run once each, in parallel over processes, with a
progress bar on stderr; then the IDA cross-checks of the figures computed with the exact
integrator; then each figure is built and written. Only results go to stdout.

Results go to ``out/reproduction/`` and the report to ``out/reproduction.md`` unless told
otherwise (``--out``, ``--report``). ``--docs`` regenerates the committed report instead
(``docs/reproduction/`` and ``docs/reproduction.md``, run from the checkout's root), with the
notes written by hand in ``docs/reproduction_notes.md`` merged in; no run writes that file. The
report lists every figure whose JSON is in the folder, so regenerating one figure keeps the others.

The output folder is locked for the run and the files are renamed into place at its end
(:func:`hybrid.cli.common.results`); the worker processes die with this one. Ctrl-C, ``SIGTERM``
or ``--max-time`` stop the computation at once: the figures whose jobs had all finished are
written, with the report (which names the others), and the command exits with 130 (143) or 1.

References
----------
.. [1] Aramendiz et al., "Sequential friction-spring dampers" (``shared/seed``).
"""

from __future__ import annotations

import argparse
import os
import platform
import sys
import time
from concurrent.futures import FIRST_COMPLETED, wait
from contextlib import nullcontext
from pathlib import Path

from hybrid import ProgressBar
from hybrid.core.budget import deadline_passed, time_limit
from hybrid.core.commands import info, positive_float, results, writable_folder
from hybrid.core.files import check_target, os_error_text
from hybrid.core.workers import ProcessPool, Terminated, cap_workers
from hybrid.engine.io import to_json  # one JSON convention (non-finite floats as null) for every output

__all__ = ["register", "run", "parse_figures", "parse_workers", "output_folder", "write_csv", "targets"]

#: Where a run writes unless told otherwise (relative to the working directory; `out/` is git-ignored).
DEFAULT_OUT = Path("out/reproduction")
#: The committed report's folder (``--docs``), relative to a checkout's root.
DOCS_OUT = Path("docs/reproduction")
#: The notes written by hand for the committed report.
NOTES = Path("docs/reproduction_notes.md")


def register(subparsers) -> None:
    """Add ``reproduce`` to the subparsers of ``hybrid`` (entry point group ``hybrid.commands``).

    Parameters
    ----------
    subparsers : argparse._SubParsersAction
    """
    p = subparsers.add_parser(
        "reproduce", help="regenerate the paper's figures (PNG, CSV, JSON) and a report"
    )
    p.add_argument("--out", default=None, help=f"output folder (default {DEFAULT_OUT})")
    p.add_argument(
        "--figure",
        nargs="+",
        action="extend",
        metavar="ID",
        help="figures to make (default all): 3a 3b 4a 4b 5 6 7 8 9 10 11 12 13 B1 B2 B3 B4",
    )
    p.add_argument("--workers", default=None, help="worker processes (default os.cpu_count())")
    p.add_argument(
        "--integrator",
        choices=("exact", "ida"),
        default="exact",
        help="exact (default: matrix exponentials, both dampers are affine; peaks cross-checked with IDA) or ida",
    )
    p.add_argument("--report", default=None, help="Markdown report (default: OUT.md beside the folder)")
    p.add_argument(
        "--docs",
        action="store_true",
        help=f"regenerate the committed report: {DOCS_OUT}/ and {DOCS_OUT}.md, with the notes written by "
        f"hand in {NOTES} (run from the checkout's root; not with --out or --report)",
    )
    p.add_argument(
        "--notes",
        default=None,
        metavar="MD",
        help=f"notes written by hand to merge into the report (default with --docs: {NOTES}; read, never written)",
    )
    p.add_argument(
        "--max-time",
        type=positive_float,
        default=None,
        metavar="SECONDS",
        help="wall-clock limit of the computation (default none): the figures finished by then are written",
    )
    p.add_argument(
        "--progress", action=argparse.BooleanOptionalAction, default=None, help="progress bar on stderr"
    )
    p.set_defaults(handler=run)


def parse_figures(ids: list[str] | None) -> list[str]:
    """The figure ids asked for, in the paper's order (all if ``ids`` is None).

    Raises
    ------
    ValueError
        An unknown id.
    """
    from .figures import FIGURES

    if not ids:
        return list(FIGURES)
    norm = {k.lower(): k for k in FIGURES}
    bad = [i for i in ids if i.lower().removeprefix("fig") not in norm]
    if bad:
        raise ValueError(f"unknown figure {bad[0]!r}; figures: {' '.join(FIGURES)}")
    want = {norm[i.lower().removeprefix("fig")] for i in ids}
    return [k for k in FIGURES if k in want]


def parse_workers(text: str | None) -> int:
    """``--workers``: an integer >= 1 (default ``os.cpu_count()``).

    Raises
    ------
    ValueError
    """
    if text is None:
        return os.cpu_count() or 1
    try:
        n = int(text)
    except ValueError:
        raise ValueError(f"`--workers` must be an integer >= 1, got {text!r}") from None
    if n < 1:
        raise ValueError(f"`--workers` must be an integer >= 1, got {text!r}")
    return n


def output_folder(text: str) -> Path:
    """``--out``, created and checked writable.

    Raises
    ------
    ValueError
    """
    if not text.strip():
        raise ValueError("`--out` needs a folder path, got an empty string")
    return writable_folder(Path(text))


def targets(args) -> tuple[Path, Path, Path | None]:
    """The output folder, the report and the notes file of a run (see :func:`register`).

    Raises
    ------
    ValueError
        ``--docs`` with ``--out`` or ``--report``, or away from a checkout's root; a notes file
        that does not exist; a report path that is a folder.
    """
    if args.docs:
        if args.out is not None or args.report is not None:
            raise ValueError(
                "`--docs` writes docs/reproduction/ and docs/reproduction.md: give no `--out` or `--report` with it"
            )
        if not NOTES.is_file():
            raise ValueError(
                f"`--docs` regenerates the committed report and is run from the checkout's root, where {NOTES} "
                f"is; not found under {Path.cwd()}"
            )
        out = output_folder(str(DOCS_OUT))
        report = _report_path(str(DOCS_OUT.with_suffix(".md")), out)
        notes = Path(args.notes) if args.notes else NOTES
    else:
        out = output_folder(args.out if args.out is not None else str(DEFAULT_OUT))
        report = _report_path(args.report, out)
        notes = Path(args.notes) if args.notes else None
    if notes is not None and not notes.is_file():
        raise ValueError(f"`--notes {notes}`: no such file")
    return out, report, notes


def _earlier_figures(out: Path, made: list[str]) -> list[dict]:
    """The JSON of every figure in ``out`` not made by this run (the report lists them too)."""
    import json

    from .figures import FIGURES

    found = []
    for k in FIGURES:
        f = out / f"fig{k}.json"
        if k not in made and f.is_file():
            try:
                found.append(json.loads(f.read_text()))
            except ValueError:
                continue  # not ours, or half written: left out of the report
    return found


def _timed(job):
    from .jobs import run_job

    t0 = time.perf_counter()
    res = run_job(job)
    return res, time.perf_counter() - t0


class _Stopped(Exception):
    """The computation stopped before its last job (the deadline passed, or a job failed)."""


def _run_all(jobs: list, pool: ProcessPool, bar, done_weight: list, total_weight: float, timed: dict) -> None:
    """Run ``jobs`` on ``pool``; each result and its wall seconds put in ``timed`` as it comes.

    Raises
    ------
    _Stopped
        The deadline of :func:`hybrid.time_limit` passed, or a job failed (the jobs in progress are
        the caller's to stop: it kills the pool).
    """
    order = sorted(jobs, key=lambda j: -j.weight)  # long jobs first: a shorter tail
    pending = {pool.submit(_timed, j): j for j in order}
    while pending:
        done, _ = wait(pending, timeout=0.25, return_when=FIRST_COMPLETED)
        for f in done:
            j = pending.pop(f)
            try:
                timed[j] = f.result()
            except Exception as exc:  # a job that raised, or a worker that died
                raise _Stopped(
                    f"the {j.kind} job of `{j.model}` failed ({type(exc).__name__}: {exc})"
                ) from None
            done_weight[0] += j.weight
            bar(done_weight[0] / total_weight)
        if pending and deadline_passed():
            raise _Stopped(f"time limit of --max-time reached with {len(pending)} jobs not finished")


def write_csv(rows: list[dict], path: Path) -> Path:
    """Rows (dicts, the union of their keys as columns, in first-seen order) as CSV.

    Parameters
    ----------
    rows : list of dict
    path : Path

    Returns
    -------
    Path
    """
    import csv

    cols: list[str] = []
    for r in rows:
        cols += [k for k in r if k not in cols]
    with path.open("w", newline="") as fh:
        w = csv.writer(fh)
        w.writerow(cols)
        for r in rows:
            w.writerow([repr(v) if isinstance(v, float) else v for v in (r.get(c, "") for c in cols)])
    return path


def _report_path(text: str | None, out: Path) -> Path:
    """``--report`` (default OUT.md beside the folder), checked writable before any computation.

    Raises
    ------
    ValueError
    """
    report = Path(text) if text else out.with_suffix(".md")
    if report.exists() and report.is_dir():
        raise ValueError(f"`--report {report}` is a folder")
    check_target(report)
    parent = report.parent if str(report.parent) else Path(".")
    if not parent.is_dir():
        raise ValueError(
            f"`--report {report}`: its folder {str(parent)!r} does not exist; create it or choose another"
        )
    probe = parent / f".{report.name}.{os.getpid()}.probe"
    try:
        fd = os.open(probe, os.O_WRONLY | os.O_CREAT | os.O_EXCL, 0o644)
        os.close(fd)
        os.unlink(probe)
    except OSError as exc:
        raise ValueError(os_error_text(exc, report, "choose another --report")) from None
    return report


def _files(ids: list[str]) -> list[str]:
    return [f"fig{i}.{ext}" for i in ids for ext in ("png", "csv", "json")] + ["reproduce.json"]


def run(args) -> int:
    """The ``reproduce`` subcommand (see :func:`register`)."""
    ids = parse_figures(args.figure)
    asked = None if args.workers is None else parse_workers(args.workers)
    out, report, notes_path = targets(args)

    from .figures import FIGURES

    specs = [FIGURES[i] for i in ids]
    stage1 = list(dict.fromkeys(j for s in specs for j in s.jobs(args.integrator)))
    workers, note = cap_workers(asked, len(stage1), "jobs")
    if note:
        info(note)
    with results(out, _files(ids)) as staged:
        return _reproduce(args, ids, specs, stage1, workers, out, report, staged, notes_path)


def _reproduce(
    args, ids, specs, stage1, workers: int, out: Path, report: Path, staged, notes_path: Path | None = None
) -> int:
    load0 = os.getloadavg()
    t0 = time.perf_counter()
    bar = ProgressBar("reproduce", enabled=args.progress)
    total = sum(j.weight for j in stage1) * 1.15 + 1e-9  # + the cross-checks, roughly
    done = [0.0]
    timed: dict = {}
    stopped: BaseException | None = None
    with ProcessPool(workers) as pool:
        try:
            with time_limit(args.max_time) if args.max_time else nullcontext():
                _run_all(stage1, pool, bar, done, total, timed)
                results = {j: r for j, (r, _) in timed.items()}
                stage2 = list(dict.fromkeys(j for s in specs for j in s.checks(results, args.integrator)))
                stage2 = [j for j in stage2 if j not in results]
                total = max(total, done[0] + sum(j.weight for j in stage2))
                _run_all(stage2, pool, bar, done, total, timed)
        except (_Stopped, KeyboardInterrupt) as exc:
            pool.kill()  # the jobs in progress are dropped at once
            stopped = exc
    results = {j: r for j, (r, _) in timed.items()}
    if stopped is None:
        bar(1.0)
    compute_wall = time.perf_counter() - t0
    load1 = os.getloadavg()

    summary = []
    not_made = []
    for s in specs:
        own = list(s.jobs(args.integrator))
        if not all(j in results for j in own) or not all(
            j in results for j in s.checks(results, args.integrator)
        ):
            not_made.append(s.id)
            continue
        own = list(dict.fromkeys(own + s.checks(results, args.integrator)))
        tb = time.perf_counter()
        fig = s.build(results, args.integrator)
        cpu = sum(timed[j][1] for j in own if j in timed)
        stem = staged.path(f"fig{fig.id}.png").with_suffix("")
        shown = out / f"fig{fig.id}"
        fig.figure.savefig(stem.with_suffix(".png"), dpi=100)
        import matplotlib.pyplot as plt

        plt.close(fig.figure)
        write_csv(fig.rows, stem.with_suffix(".csv"))
        info_ = {
            "figure": fig.id,
            "title": fig.title,
            "integrator": fig.integrator,
            "claim": fig.claim,
            "verdict": fig.verdict,
            "numbers": fig.numbers,
            "ida_check": fig.ida_check,
            "compute_seconds": cpu,
            "build_seconds": time.perf_counter() - tb,
            "jobs": len(own),
            "load_average": list(load1),
        }
        stem.with_suffix(".json").write_text(to_json(info_) + "\n")
        summary.append(info_)
        print(f"Fig. {fig.id}: {fig.verdict} [{shown.with_suffix('.png')}]")
    total_wall = time.perf_counter() - t0
    meta = {
        "command": "hybrid " + " ".join(sys.argv[1:])
        if sys.argv and "reproduce" in sys.argv
        else "hybrid reproduce",
        "figures": ids,
        "workers": workers,
        "integrator": args.integrator,
        "cpu_count": os.cpu_count(),
        "machine": platform.machine(),
        "python": platform.python_version(),
        "load_average_start": list(load0),
        "load_average_end": list(load1),
        "compute_wall_seconds": compute_wall,
        "total_wall_seconds": total_wall,
        "jobs": len(timed),
        "date_utc": time.strftime("%Y-%m-%d %H:%M UTC", time.gmtime()),
    }
    if stopped is not None:
        why = str(stopped) if isinstance(stopped, _Stopped) else f"interrupted ({_what(stopped)})"
        meta.update(stopped=why, not_made=[f"Fig. {i}" for i in not_made])
    staged.path("reproduce.json").write_text(to_json(meta) + "\n")
    from .figures import FIGURES
    from .report import read_notes, write_report

    notes = read_notes(notes_path) if notes_path is not None else None
    if notes_path is not None:
        meta = {**meta, "notes": str(notes_path)}
    every = {f["figure"]: f for f in _earlier_figures(out, ids) + summary}
    write_report(report, out, meta, [every[k] for k in FIGURES if k in every], notes)
    if isinstance(stopped, KeyboardInterrupt):
        info(
            f"hybrid: interrupted ({_what(stopped)}) after {total_wall:.1f} s: {len(summary)} of {len(ids)} figures "
            f"written to {out}; report {report}"
        )
        return stopped.exit_code if isinstance(stopped, Terminated) else 130
    if stopped is not None:
        info(f"hybrid: {stopped}: {len(summary)} of {len(ids)} figures written to {out}; report {report}")
        return 1
    print(f"{len(ids)} figures in {total_wall:.1f} s ({workers} workers); report {report}")
    return 0


def _what(exc: KeyboardInterrupt) -> str:
    return exc.name if isinstance(exc, Terminated) else "Ctrl-C"
