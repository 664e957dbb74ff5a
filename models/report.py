"""The Markdown report of ``hybrid reproduce``: figures, key numbers, verdicts, and the notes written by hand.

The report is generated; what people write about the figures lives apart, in a notes file
(``docs/reproduction_notes.md`` for the committed report ``docs/reproduction.md``), which
:func:`read_notes` reads and :func:`write_report` merges in. No run writes the notes file.
"""

from __future__ import annotations

import math
import os
from pathlib import Path

from hybrid.core.files import write_atomic

__all__ = ["write_report", "number_table", "read_notes", "regenerate", "NOTES"]

#: The notes written by hand for the committed report, relative to a checkout's root.
NOTES = Path("docs/reproduction_notes.md")

#: Lists longer than this are summarised (first, smallest, largest, last) in the tables.
LIST_LIMIT = 6


def _fmt(v) -> str:
    if isinstance(v, bool) or v is None:
        return str(v)
    if isinstance(v, float):
        return "inf" if math.isinf(v) else f"{v:.6g}"
    if isinstance(v, list | tuple):
        if len(v) > LIST_LIMIT and all(isinstance(x, int | float) and x is not None for x in v):
            return f"{len(v)} values: first {_fmt(v[0])}, min {_fmt(min(v))}, max {_fmt(max(v))}, last {_fmt(v[-1])}"
        return "[" + ", ".join(_fmt(x) for x in v) + "]"
    return str(v).replace("|", "/")


def _heading(f: dict) -> str:
    """A figure's section heading."""
    return f"Fig. {f['figure']}: {f['title'].split(': ', 1)[-1]}"


def _anchor(heading: str) -> str:
    """The anchor GitHub (and MyST, ``github`` slugs) gives a heading: lower case, spaces to ``-``,
    other punctuation dropped."""
    import re

    return re.sub(r"[^\w\- ]", "", heading.strip().lower()).replace(" ", "-")


def _flat(d: dict, prefix: str = "") -> list[tuple[str, object]]:
    out = []
    for k, v in d.items():
        key = f"{prefix}{k}"
        if isinstance(v, dict) and k != "parameters":
            out += _flat(v, key + ".")
        elif isinstance(v, dict):
            out.append((key, ", ".join(f"{a}={b:g}" for a, b in v.items())))
        else:
            out.append((key, v))
    return out


def number_table(numbers: dict) -> list[str]:
    """The key numbers of a figure as a two-column Markdown table (nested keys joined by dots).

    Parameters
    ----------
    numbers : dict

    Returns
    -------
    list of str
        Lines.
    """
    lines = ["| quantity | value |", "|---|---|"]
    lines += [f"| {k} | {_fmt(v)} |" for k, v in _flat(numbers)]
    return lines


def _design_lines(by_id: dict) -> list[str]:
    lines = []
    rows = []
    if "12" in by_id:
        for m, r in by_id["12"]["numbers"]["resonances"].items():
            rows.append(
                (
                    "absorber",
                    m,
                    r["R_opt_numerical_N"],
                    r["R_opt_averaging_N"],
                    r["R_opt_relative_difference"],
                    r["R_min_numerical_bracket_N"],
                    r["R_min_averaging_N"],
                )
            )
    if "9" in by_id:
        n = by_id["9"]["numbers"]
        for m, o in n["optimum"].items():
            rm = n.get("R_min", {}).get(m, {})
            rows.append(
                (
                    "isolator",
                    m,
                    o["R_numerical_N"],
                    o["R_averaging_N"],
                    o["relative_difference"],
                    rm.get("numerical_bracket_N"),
                    rm.get("averaging_N"),
                )
            )
    if rows:
        lines += [
            "## Design values",
            "",
            "R minimising the peak of x1 near each resonance: numerical (bounded Brent on the refined peak of the "
            "continued branch, xatol 1e-5 N) against the averaging model (Eqs. 37, 44; Eq. 51 for the isolator); "
            "smallest R with a bounded response: numerical bracket (bisection on whether the continuation meets "
            "a band of unbounded growth) against `R_min` of the averaging model (Eqs. 35, 43, D.14, D.20).",
            "",
            "| damper | resonance | R_opt numerical [N] | R_opt averaging [N] | difference | R_min numerical [N] | R_min averaging [N] |",
            "|---|---|---|---|---|---|---|",
        ]
        for d, m, a, b, rel, br, rm in rows:
            brs = f"({br[0]:.4g}, {br[1]:.4g}]" if br else "-"
            lines.append(f"| {d} | {m} | {a:.5f} | {b:.5f} | {100 * rel:+.3f} % | {brs} | {_fmt(rm)} |")
        lines.append("")
    errs = [(i, by_id[i]["numbers"]["resonances"]) for i in ("11", "13") if i in by_id]
    if errs:
        lines += [
            "## Averaging model against the event-driven model (peak of x1)",
            "",
            "| figure | resonance | numerical [m] | averaging [m] | relative error |",
            "|---|---|---|---|---|",
        ]
        for i, res in errs:
            for m, r in res.items():
                lines.append(
                    f"| {i} | {m} | {r['peak_x1_numerical_m']:.6g} | {r['peak_x1_averaging_m']:.6g} | "
                    f"{100 * r['relative_error_averaging']:+.3f} % |"
                )
        lines.append("")
    return lines


def read_notes(path: Path) -> dict[str, str]:
    """The sections of a notes file: ``{key: text}`` for each ``## key`` heading.

    Keys are ``intro`` (after the report's first paragraph), ``design-values`` (after the table of
    design values) and ``fig ID`` (e.g. ``fig 3a``: under that figure, as "Seen on the PNG"). Text
    before the first heading and HTML comments are left out.

    Parameters
    ----------
    path : Path

    Returns
    -------
    dict of str to str
    """
    import re

    text = re.sub(r"<!--.*?-->", "", Path(path).read_text(), flags=re.S)
    notes: dict[str, str] = {}
    key = None
    for line in text.splitlines():
        if line.startswith("## "):
            key = line[3:].strip().lower()
            notes[key] = ""
        elif key is not None:
            notes[key] += line + "\n"
    return {k: v.strip() for k, v in notes.items() if v.strip()}


def write_report(
    path: Path, out: Path, meta: dict, figures: list[dict], notes: dict[str, str] | None = None
) -> Path:
    """Write the report.

    Parameters
    ----------
    path : Path
        The Markdown file.
    out : Path
        The folder of the PNGs (linked relative to ``path``).
    meta : dict
        Run data (times, load, workers, integrator).
    figures : list of dict
        The JSON of each figure.
    notes : dict of str to str, optional
        The notes written by hand (:func:`read_notes`).

    Returns
    -------
    Path
    """
    notes = notes or {}
    rel = Path(os.path.relpath(out, path.parent))
    notes_rel = Path(os.path.relpath(meta.get("notes", NOTES), path.parent))
    by_id = {f["figure"]: f for f in figures}
    la0 = ", ".join(f"{x:.2f}" for x in meta["load_average_start"])
    la1 = ", ".join(f"{x:.2f}" for x in meta["load_average_end"])
    lines = [
        "# Reproduction of the paper's figures",
        "",
        "Generated by `hybrid reproduce` (`models/reproduce.py`, figures in `models/figures.py`, studies and design "
        "values in `models/studies.py`). Each figure: PNG, CSV of the plotted data and JSON of its key numbers in "
        f"`{rel}/`. Verdicts are computed from the numbers"
        + (
            "; the **Seen on the PNG** notes were written by hand after looking at the PNGs "
            f"([`{notes_rel.name}`]({notes_rel}), which no run writes)."
            if notes
            else "; no notes written by hand are merged in (the committed report's are in "
            f"`{NOTES}`: `hybrid reproduce --docs`)."
        ),
        "",
        *([notes["intro"], ""] if "intro" in notes else []),
        f"- run: {meta['date_utc']}"
        + (
            f" (figures {', '.join(meta['figures'])}; the others are from earlier runs)"
            if set(by_id) - set(meta.get("figures", by_id))
            else ""
        )
        + f", {meta['workers']} worker processes on {meta['cpu_count']} CPUs "
        f"({meta['machine']}, Python {meta['python']}), integrator `{meta['integrator']}`",
        f"- wall time: **{meta['total_wall_seconds']:.1f} s** in total ({meta['compute_wall_seconds']:.1f} s of "
        f"computation, {meta['jobs']} jobs)",
        f"- load average (1, 5, 15 min, `os.getloadavg()`): {la0} at the start, {la1} at the end",
        *(
            [f"- **not made**: {', '.join(meta['not_made'])} ({meta['stopped']})"]
            if meta.get("not_made")
            else []
        ),
        "",
        "| figure | integrator | jobs | compute [s] (sum over its jobs) | largest exact-vs-IDA peak difference | verdict |",
        "|---|---|---|---|---|---|",
    ]
    for f in figures:
        ida = f["ida_check"]
        d = (
            "-"
            if not ida or ida.get("max_relative_difference") is None
            else f"{ida['max_relative_difference']:.2e}"
        )
        lines.append(
            f"| [{f['figure']}](#{_anchor(_heading(f))}) | {f['integrator']} | {f['jobs']} | "
            f"{f['compute_seconds']:.1f} | {d} | {f['verdict'].split(':')[0]} |"
        )
    lines += [
        "",
        "Compute seconds are the wall times of a figure's jobs added up (jobs shared between figures, e.g. the "
        "absorber's curve at R = 0.5 N in Figs. 7, 11, 12 and B1, count in each).",
        "",
    ]
    design = _design_lines(by_id)
    lines += design
    if design and "design-values" in notes:
        lines += [notes["design-values"], ""]
    for f in figures:
        lines += [
            f"## {_heading(f)}",
            "",
            f"![Fig. {f['figure']}]({rel}/fig{f['figure']}.png)",
            "",
            f"**Paper:** {f['claim']}. **Here:** {f['verdict']}",
            "",
        ]
        seen = notes.get(f"fig {f['figure'].lower()}")
        if seen:
            lines += [f"**Seen on the PNG:** {seen}", ""]
        lines += number_table(f["numbers"])
        ida = f["ida_check"]
        if ida and ida.get("curves"):
            lines += [
                "",
                "Exact integrator against IDA (rtol 1e-10):",
                "",
                "| curve | exact | IDA | relative difference |",
                "|---|---|---|---|",
            ]
            for c in ida["curves"]:
                if "R" in c:
                    name = f"{c['model']} R={c['R']:g} N c3={c['c3']:g} N/m window {c['window']}"
                    lines.append(
                        f"| {name} | {c['exact_peak_x1']:.10g} | {c['ida_peak_x1']:.10g} | {c['relative_difference']:.2e} |"
                    )
                else:
                    lines.append(
                        f"| {c['what']} | {c['exact']:.10g} | {c['ida']:.10g} | {ida['max_relative_difference']:.2e} |"
                    )
        lines += ["", f"Compute time {f['compute_seconds']:.1f} s over {f['jobs']} jobs.", ""]
    return write_atomic(path, "\n".join(lines) + "\n")


def regenerate(out: Path, report: Path, notes: Path | None = None) -> Path:
    """Write the report again from the JSON files in ``out`` (no computation), with ``notes`` merged in.

    Parameters
    ----------
    out : Path
        A folder written by ``hybrid reproduce`` (``reproduce.json`` and ``fig*.json``).
    report : Path
    notes : Path, optional
        A notes file (:func:`read_notes`).

    Returns
    -------
    Path
    """
    import json

    from .figures import FIGURES

    meta = json.loads((out / "reproduce.json").read_text())
    if notes is not None:
        meta["notes"] = str(notes)
    figs = [
        json.loads((out / f"fig{k}.json").read_text()) for k in FIGURES if (out / f"fig{k}.json").is_file()
    ]
    return write_report(report, out, meta, figs, read_notes(notes) if notes is not None else None)
