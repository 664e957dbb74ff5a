"""Model files: a :class:`HybridSystem` written as TOML (data only, never executed).

Layout of a model file::

    [model]
    name = "coulomb"
    title = "..."                # optional
    reference = "..."            # optional
    period = "2*pi/Omega"        # optional forcing period
    initial_mode = "stick"       # optional
    format = "modes"             # optional: another format is built by the entry point of
                                 # that name in group `hybrid.model_formats` (e.g. "network")
    quadratures = ["W", "D"]     # optional
    outputs = ["H"]              # optional, names of definitions

    [variables.x]                # one table per variable, in state order
    unit = "m"
    description = "..."

    [parameters.m]               # domain: "real" | "positive" | "nonnegative"
    unit = "kg"
    domain = "positive"

    [presets.standard]           # named parameter sets
    m = 1.0

    [definitions]                # named expressions shared by all modes
    H = "k*x - F*sin(Omega*t)"

    [equations]                  # derivatives shared by all modes
    x = "v"

    [modes.stick]                # per mode: derivatives, algebraic, definitions
    derivatives = { x = "0", v = "0" }

    [[transitions]]
    source = "stick"
    target = "slip+"
    guard = "H + R"
    direction = -1
    reset = { v = "0" }          # optional

    [plot]                       # optional hints for the CLI figure
    force = "H"
    linear_references = { "linear: stuck" = "stick" }   # modes linearised over `hybrid frc`

    [energy]                     # optional: names for energy balances
    input = "W"
    dissipated = "D"
    mechanical = "E"

    [orbit]                      # optional: periodic-orbit hints
    gauge = "x2 - u"             # picks the member of a neutral family (gauge = 0)
"""

from __future__ import annotations

import stat
import tomllib
from collections.abc import Iterator, Mapping
from contextlib import contextmanager
from contextvars import ContextVar
from importlib.metadata import entry_points
from pathlib import Path

from ..core.errors import ModelError
from .elements import Mode, Parameter, Transition, Variable
from .filippov import filippov_system
from .system import HybridSystem

__all__ = [
    "load_system",
    "system_from_dict",
    "read_model_file",
    "describe_model_file",
    "draw_model_file",
    "MAX_FILE_BYTES",
    "model_file",
    "reading_model_file",
    "shown_key",
    "shown_value",
]

#: Entry-point group of the model-file formats other than "modes": each entry loads an object
#: (e.g. a module) with ``build(data)``, turning the parsed file into the content of a mode-level
#: file (a mapping) or into a :class:`HybridSystem` (e.g. one composed of components, which a
#: mode-level file does not write), and optionally ``describe(data) -> str`` and
#: ``draw(data, png_path)``.
FORMAT_GROUP = "hybrid.model_formats"

#: Largest model file read [bytes] (checked before it is read; the shipped models are about 5 KB).
MAX_FILE_BYTES = 1 << 20

_TOP = {
    "model",
    "variables",
    "parameters",
    "presets",
    "definitions",
    "equations",
    "modes",
    "transitions",
    "plot",
    "energy",
    "orbit",
}
_MODEL = {"name", "title", "reference", "period", "initial_mode", "quadratures", "outputs", "format"}
_VAR = {"unit", "description"}
_PAR = {"unit", "description", "domain"}
_MODE = {"derivatives", "algebraic", "definitions"}
_TRANS = {"source", "target", "guard", "direction", "name", "reset"}


#: The model file being built (set while its format's methods run), for formats whose files name
#: other files beside them (e.g. the matrices of a structure, relative to the model file).
_MODEL_FILE: ContextVar[Path | None] = ContextVar("model_file", default=None)


def model_file() -> Path | None:
    """The model file whose content is being built or described, or None (content from a dict).

    A model format whose files name other files (relative to the model file) resolves them
    against ``model_file().parent``.
    """
    return _MODEL_FILE.get()


@contextmanager
def reading_model_file(path: str | Path) -> Iterator[None]:
    """While in this context, :func:`model_file` is ``path`` (resolved): the files a model file
    names beside it (e.g. a structure's matrices) resolve against its folder."""
    path = Path(path)
    token = _MODEL_FILE.set(path.resolve())
    try:
        yield
    finally:
        _MODEL_FILE.reset(token)


def load_system(path: str | Path) -> HybridSystem:
    """Read a model file (TOML).

    Parameters
    ----------
    path : str or Path
        The file: a mode-level model, or another format named by ``[model] format``.

    Returns
    -------
    HybridSystem

    Raises
    ------
    ModelError
        The file is not valid TOML or the model is inconsistent; the message
        names the file and the item.
    """
    path = Path(path)
    data = read_model_file(path)
    try:
        with reading_model_file(path):
            return system_from_dict(data)
    except ModelError as exc:
        raise ModelError(f"{path.name}: {exc}") from None


def _with_format(path: str | Path, method: str, *args):
    """``(True, result)`` of the file's format's ``method(data, *args)``; ``(False, None)`` if its
    format (the mode-level one, or one without that method) has none. Errors name the file."""
    path = Path(path)
    data = read_model_file(path)
    try:
        fmt = _format(data)
        if fmt is None or not hasattr(fmt, method):
            return False, None
        with reading_model_file(path):
            return True, getattr(fmt, method)(data, *args)
    except ModelError as exc:
        raise ModelError(f"{path.name}: {exc}") from None


def describe_model_file(path: str | Path) -> str | None:
    """The description its format gives of a model file (None for mode-level files).

    Raises
    ------
    ModelError
        As :func:`load_system`.
    """
    found, text = _with_format(path, "describe")
    return str(text) if found else None


def draw_model_file(path: str | Path, out: str | Path) -> bool:
    """Write the figure its format draws of a model file to ``out``; False if the format draws none.

    Raises
    ------
    ModelError
        As :func:`load_system`.
    """
    found, _ = _with_format(path, "draw", out)
    return found


def epmc_model_file(path: str | Path) -> HybridSystem | None:
    """The free system with the EPMC term (``+ xi M v``, no forcing) that its format derives from a
    model file (the format's ``epmc``, e.g. a network's); None if its format derives none.

    Raises
    ------
    ModelError
        As :func:`load_system`.
    """
    found, system = _with_format(path, "epmc")
    return system if found else None


def read_model_file(path: str | Path) -> dict:
    """The parsed content of a model file, read within the size limits.

    Raises
    ------
    ModelError
        Missing, unreadable, too large, not UTF-8 or not valid TOML; the
        message names the file.
    """
    path = Path(path)
    name = str(path)
    try:
        st = path.stat()
    except FileNotFoundError:
        raise ModelError(f"model file {name!r} does not exist") from None
    except OSError as exc:
        raise ModelError(f"model file {name!r} cannot be read: {exc.strerror or exc}") from None
    if stat.S_ISDIR(st.st_mode):
        raise ModelError(f"model file {name!r} is a directory")
    if not stat.S_ISREG(st.st_mode):
        raise ModelError(f"model file {name!r} is not a regular file (a device, pipe or socket)")
    if st.st_size > MAX_FILE_BYTES:
        raise ModelError(f"model file {name!r} has {st.st_size} bytes; at most {MAX_FILE_BYTES} are allowed")
    try:
        with path.open("rb") as fh:
            raw = fh.read(MAX_FILE_BYTES + 1)  # the file may grow after the stat
    except OSError as exc:
        raise ModelError(f"model file {name!r} cannot be read: {exc.strerror or exc}") from None
    if len(raw) > MAX_FILE_BYTES:
        raise ModelError(f"model file {name!r} has more than {MAX_FILE_BYTES} bytes")
    try:
        text = raw.decode("utf-8-sig")  # a byte-order mark is allowed
    except UnicodeDecodeError:
        raise ModelError(f"model file {name!r} is not UTF-8 text") from None
    try:
        return tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        raise ModelError(f"model file {name!r} is not valid TOML: {exc}") from None
    except RecursionError:
        raise ModelError(f"model file {name!r}: tables or arrays nested too deeply") from None


def _format(data: Mapping) -> object | None:
    """The format object named by ``[model] format`` (None for the mode-level format)."""
    model = data.get("model") if isinstance(data, Mapping) else None
    fmt = model.get("format", "modes") if isinstance(model, Mapping) else "modes"
    if fmt == "modes":
        return None
    formats = {ep.name: ep for ep in entry_points(group=FORMAT_GROUP)}
    if not isinstance(fmt, str) or fmt not in formats:
        have = ", ".join(["modes", *sorted(formats)])
        raise ModelError(
            f"[model] `format` = {shown_value(fmt)} is not a known model format; formats: {have}"
        )
    return formats[fmt].load()


def shown_value(value: object, width: int = 60) -> str:
    """A value read from a model file as an error message shows it: its ``repr``, cut to ``width``
    characters.

    For the readers of other model formats (the ``build`` of :data:`FORMAT_GROUP`), so that every
    message about a file quotes its values alike.

    Parameters
    ----------
    value : object
        The value as parsed (a string, a number, a table, ...).
    width : int
        Largest length of the text [characters] (at least 4); a longer ``repr`` ends in ``...``.

    Returns
    -------
    str

    Examples
    --------
    >>> shown_value("stick")
    "'stick'"
    >>> shown_value(list(range(30)), 20)
    '[0, 1, 2, 3, 4, 5...'
    """
    text = repr(value)
    return text if len(text) <= width else text[: width - 3] + "..."


def shown_key(name: object) -> str:
    """A key (a table's name) read from a model file as an error message shows it: as it is if it
    is printable text of at most 64 characters, else its ``repr`` cut to 40 (:func:`shown_value`).

    Parameters
    ----------
    name : object
        The key as parsed (TOML keys are strings; a mapping built in code may hold anything).

    Returns
    -------
    str

    Examples
    --------
    >>> shown_key("slip+")
    'slip+'
    >>> shown_key("x" * 70)
    "'xxxxxxxxxxxxxxxxxxxxxxxxxxxxxxxxxxxx..."
    """
    if isinstance(name, str) and name.isprintable() and len(name) <= 64:
        return name
    return shown_value(name, 40)


def _check_keys(table: Mapping, allowed: set[str], where: str) -> None:
    if not isinstance(table, Mapping):
        raise ModelError(f"{where} must be a table, got {shown_value(table)}")
    extra = set(table) - allowed
    if extra:
        shown = ", ".join(shown_key(k) for k in sorted(extra)[:5]) + (" ..." if len(extra) > 5 else "")
        raise ModelError(f"{where}: unknown key(s) {shown}; allowed: {', '.join(sorted(allowed))}")


def system_from_dict(data: Mapping) -> HybridSystem:
    """Build a :class:`HybridSystem` from the parsed content of a model file.

    A file whose ``[model] format`` names another format is first turned into
    mode-level content, or into the system itself, by that format's ``build`` (see
    :data:`FORMAT_GROUP`).
    """
    fmt = _format(data)
    if fmt is not None:
        built = fmt.build(data)
        if isinstance(built, HybridSystem):
            return built
        if _format(built) is not None:
            raise ModelError("a model format must build mode-level content")
        return system_from_dict(built)
    _check_keys(data, _TOP, "model file")
    for key in _TOP - {"transitions"}:
        if key in data and not isinstance(data[key], Mapping):
            raise ModelError(
                f"[{key}] must be a table, got {type(data[key]).__name__} {shown_value(data[key])}"
            )
    if "transitions" in data and not (
        isinstance(data["transitions"], list) and all(isinstance(t, Mapping) for t in data["transitions"])
    ):
        raise ModelError("`transitions` must be an array of tables ([[transitions]])")
    model = data.get("model", {})
    _check_keys(model, _MODEL, "[model]")
    if "name" not in model:
        raise ModelError("[model] needs a `name`")
    for key in ("name", "title", "reference", "period", "initial_mode"):
        if key in model and not isinstance(model[key], str):
            raise ModelError(f"[model] `{key}` must be a string, got {shown_value(model[key])}")
    plot = data.get("plot", {})
    for key in ("displacements", "shade_modes"):
        value = plot.get(key, [])
        if not isinstance(value, list) or not all(isinstance(v, str) for v in value):
            raise ModelError(f"[plot] `{key}` must be a list of names, got {shown_value(value)}")
    for key in ("units",):
        if key in plot and not isinstance(plot[key], Mapping):
            raise ModelError(f"[plot] `{key}` must be a table of names to units")
    variables = []
    for name, spec in data.get("variables", {}).items():
        _check_keys(spec, _VAR, f"[variables.{shown_key(name)}]")
        variables.append(Variable(name, str(spec.get("unit", "")), str(spec.get("description", ""))))
    parameters = []
    for name, spec in data.get("parameters", {}).items():
        _check_keys(spec, _PAR, f"[parameters.{shown_key(name)}]")
        parameters.append(
            Parameter(
                name,
                str(spec.get("unit", "")),
                str(spec.get("description", "")),
                str(spec.get("domain", "real")),
            )
        )
    modes = []
    for name, spec in data.get("modes", {}).items():
        _check_keys(spec, _MODE, f"[modes.{shown_key(name)}]")
        modes.append(
            Mode(name, spec.get("derivatives", {}), spec.get("algebraic", {}), spec.get("definitions", {}))
        )
    transitions = []
    for k, spec in enumerate(data.get("transitions", [])):
        _check_keys(spec, _TRANS, f"transition #{k + 1}")
        missing = {"source", "target", "guard"} - set(spec)
        if missing:
            raise ModelError(f"transition #{k + 1} lacks {', '.join(sorted(missing))}")
        transitions.append(
            Transition(
                source=spec["source"],
                target=spec["target"],
                guard=spec["guard"],
                direction=spec.get("direction", 0),
                name=spec.get("name", ""),
                reset=spec.get("reset", {}),
            )
        )
    for key in ("quadratures", "outputs"):
        value = model.get(key, [])
        if not isinstance(value, list) or not all(isinstance(v, str) for v in value):
            raise ModelError(f"[model] `{key}` must be a list of names, got {shown_value(value)}")
    presets = {}
    for pname, values in data.get("presets", {}).items():
        if not isinstance(values, Mapping):
            raise ModelError(f"[presets.{shown_key(pname)}] must be a table of parameter values")
        presets[pname] = dict(values)
    return filippov_system(
        name=str(model["name"]),
        title=str(model.get("title", "")),
        reference=str(model.get("reference", "")),
        variables=variables,
        parameters=parameters,
        modes=modes,
        transitions=transitions,
        equations=data.get("equations", {}),
        definitions=data.get("definitions", {}),
        quadratures=tuple(model.get("quadratures", ())),
        outputs=tuple(model.get("outputs", ())),
        period=model.get("period"),
        initial_mode=model.get("initial_mode"),
        presets=presets,
        plot=data.get("plot", {}),
        energy=data.get("energy", {}),
        orbit=data.get("orbit", {}),
    )
