"""``hybrid models`` (the built-in models) and ``hybrid show`` (a model's modes, guards and
transitions, and its network if it is a network file)."""

from __future__ import annotations

import os
from collections.abc import Sequence
from pathlib import Path

from ..core.errors import InputError, OutputError
from ..core.files import check_target, os_error_text
from ..model.filippov import surfaces
from ..model.loader import describe_model_file, draw_model_file
from ..model.registry import builtin_models, is_model_file
from ..model.system import HybridSystem
from .common import UsageError, info, model


def register(sub) -> None:
    """Add ``models`` and ``show`` to the subparsers of ``hybrid``."""
    sub.add_parser("models", help="list the built-in models").set_defaults(handler=cmd_models)
    p = sub.add_parser("show", help="print a model's modes, guards and transitions (and its network, if any)")
    p.add_argument("model", help="built-in model name (see `hybrid models`) or path of a model file (.toml)")
    p.add_argument(
        "--out", default=None, metavar="PNG", help="also draw the network of a network file to PNG"
    )
    p.set_defaults(handler=cmd_show)


def cmd_models(args) -> int:
    models = sorted(builtin_models().items())
    width = max((len(name) for name, _ in models), default=0)
    for name, ep in models:
        system = ep.load()()
        presets = ", ".join(system.presets) or "-"
        print(f"{name:{width}s}  {system.title}  [presets: {presets}]")
    return 0


def table(header: Sequence[str], rows: list[Sequence[str]]) -> list[str]:
    """Rows as text columns, each as wide as its widest cell (the last one left ragged)."""
    widths = [max(len(str(r[k])) for r in [header, *rows]) for k in range(len(header) - 1)]
    lines = []
    for r in [header, *rows]:
        cells = [str(c).ljust(w) for c, w in zip(r[:-1], widths, strict=True)] + [str(r[-1])]
        lines.append("  " + "  ".join(cells).rstrip())
    return lines


def _short(name: str, width: int = 200) -> str:
    """A mode name cut to ``width`` characters (a system of many components has long ones)."""
    return name if len(name) <= width else name[: width - 3] + "..."


def show_text(system: HybridSystem, description: str | None = None) -> str:
    """A model as text: its network (if given), then its modes and its transitions as tables; a
    system with components, its own modes and then each component's local modes and transitions."""
    lines = [description, ""] if description else []
    lines.append(f"model `{system.name}`" + (f": {system.title}" if system.title else ""))
    if system.components:
        n_local = sum(len(c.modes) for c in system.components)
        n_trans = len(system.transitions) + sum(len(c.transitions) for c in system.components)
        lines.append(
            f"  {len(system.variables)} variables, {len(system.modes)} own mode(s), {len(system.components)} "
            f"components ({n_local} local modes, composed on demand), {n_trans} transitions, initial mode "
            f"{_short(system.default_mode or system.mode_names[0])}"
        )
    else:
        lines.append(
            f"  {len(system.variables)} variables, {len(system.modes)} modes, {len(system.transitions)} "
            f"transitions, initial mode {system.initial_mode or system.mode_names[0]}"
        )
    owned = {n for c in system.components for m in c.modes[:1] for n in (*m.derivatives, *m.algebraic)}
    lines.append("")
    lines.append("modes:" if not system.components else "own modes (the variables no component owns):")
    rows = []
    for m in system.modes:
        differential = [v for v in system.variable_names if v not in m.algebraic and v not in owned]
        rows.append((m.name, ", ".join(differential), ", ".join(m.algebraic) or "-"))
    lines += table(("mode", "differential", "slave (algebraic)"), rows)
    if system.components:
        lines.append("")
        lines.append(
            "components (a mode of the system is its own mode and one local mode per component, joined by |):"
        )
        rows = [
            (c.name, m.name, ", ".join(m.derivatives) or "-", ", ".join(m.algebraic) or "-")
            for c in system.components
            for m in c.modes
        ]
        lines += table(("component", "local mode", "differential", "slave (algebraic)"), rows)
    found = surfaces(system)
    if found:
        lines.append("")
        lines.append("discontinuity surfaces h = 0 of sign(h) (Filippov's convention, docs/filippov.md):")
        rows = [
            (s.h, s.mode, s.coefficient, "sliding" if s.slides else "crossing only", ", ".join(s.modes))
            for s in found
        ]
        lines += table(("h", "in mode", "sign(h) is", "on h = 0", "derived modes"), rows)
    lines.append("")
    lines.append("transitions:")
    arrow = {1: "rising", -1: "falling", 0: "either"}
    named = [("", t) for t in system.transitions] + [
        (f"{c.name}.", t) for c in system.components for t in c.transitions
    ]
    rows = [
        (
            prefix + t.name,
            t.source,
            t.target,
            arrow[t.direction],
            t.guard,
            ", ".join(f"{k} = {v}" for k, v in t.reset.items()) or "-",
        )
        for prefix, t in named
    ]
    lines += table(("name", "from", "to", "crossing", "guard", "reset"), rows)
    return "\n".join(lines)


def cmd_show(args) -> int:
    system = model(args.model)
    description = describe_model_file(Path(args.model)) if is_model_file(args.model) else None
    if args.out is not None:
        out = png_target(args.out)
        if description is None:
            raise UsageError(f"model `{system.name}` is not a network file: there is no network to draw")
        tmp = out.with_name(f".{out.stem}.{os.getpid()}.tmp{out.suffix}")
        try:
            draw_model_file(Path(args.model), tmp)
            os.replace(tmp, out)
        except OSError as exc:
            tmp.unlink(missing_ok=True)
            raise OutputError(os_error_text(exc, out), exc.errno) from None
    print(show_text(system, description))
    if args.out is not None:
        info(f"wrote {args.out}")
    return 0


def png_target(text: str) -> Path:
    """``--out PNG`` of ``show``, checked before anything is drawn: a file (not a folder, a link, a
    FIFO) in an existing folder that can be written.

    Raises
    ------
    UsageError
    """
    out = Path(text)
    if not text.strip() or out.is_dir() or not out.parent.is_dir():
        raise UsageError(f"`--out {text}` must name a PNG file in an existing folder")
    try:
        check_target(out)
    except InputError as exc:
        raise UsageError(str(exc)) from None
    probe = out.with_name(f".{out.name}.{os.getpid()}.probe")
    try:
        os.close(os.open(probe, os.O_WRONLY | os.O_CREAT | os.O_EXCL, 0o644))
        os.unlink(probe)
    except OSError as exc:
        raise UsageError(os_error_text(exc, out)) from None
    return out
