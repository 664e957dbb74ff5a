"""A sweep's folder: its manifest and point files, written by :func:`hybrid.sweep` and read back
(:class:`SweepResult`, :func:`load_sweep`); a folder is resumed only if its manifest matches."""

from __future__ import annotations

import json
import math
import os
import re
import stat
from collections.abc import Mapping
from dataclasses import dataclass, field, fields
from pathlib import Path

from ..core.errors import InputError
from ..core.options import ContinuationOptions
from ..core.plain import options_text
from ..core.status import PointStatus
from ..core.tables import Tabular, table_columns
from ..integrators.base import Method
from ..integrators.options import SolverOptions
from .axes import MAX_POINTS, Axis
from .modeldata import _plain

__all__ = ["SweepResult", "load_sweep", "MANIFEST", "LAYOUT", "READABLE_LAYOUTS", "STATUSES"]

#: Name of the manifest in a sweep's folder.
MANIFEST = "manifest.json"


#: Version of the folder's layout (manifest and point files). 2: a point's ``reason`` is a code and
#: its ``message`` the text; the settings' Newton options nested (``settings.newton``). A folder
#: of layout 1 is still read (:func:`load_sweep`), not resumed.
LAYOUT = 2


#: Layouts :func:`load_sweep` reads.
READABLE_LAYOUTS = (1, 2)


#: A point's status (:class:`PointStatus`): its curve covers the range (``bounded``), a branch grew
#: without bound (``unbounded``), parts of the range were not computed (``incomplete``: the peak
#: is a lower bound), the computation raised (``failed``) or ran out of the per-point limit
#: (``time limit``).
STATUSES = tuple(s.value for s in PointStatus)


def _point_name(index: tuple[int, ...]) -> str:
    return "point-" + "-".join(f"{i:04d}" for i in index) + ".json"


#: A point file's name (its indices along the axes).
_POINT_NAME = re.compile(r"point-(\d{4,6}(?:-\d{4,6})*)\.json")


# ----------------------------------------------------------------------------------------------
# The folder: manifest and point files
def _identity(manifest: Mapping) -> dict:
    """The entries of a manifest that fix the results (a resumed sweep must match them all)."""
    keys = ("layout", "model", "model_hash", "version", "parameter", "coordinate", "p_range")
    keys += ("axes", "params", "options", "settings", "point_time_limit")
    return {k: manifest[k] for k in keys}


def _options_dict(o) -> dict:
    """Options as plain data; a method as its settings (``{"name": "ida", "rtol": ...}``)."""
    out = {}
    for f in fields(o):
        v = getattr(o, f.name)
        out[f.name] = v.settings() if isinstance(v, Method) else _plain(v)
    return out


@dataclass
class SweepResult(Tabular):
    """A sweep's folder as read back: its manifest and the result of every finished point.

    Attributes
    ----------
    folder : Path
    manifest : dict
        Model, hash, version, axes (``name``, ``values``, ``spacing``, ``spec``), other
        parameter values, frequency range, coordinate, options.
    points : dict
        ``{index tuple: result dict}`` (:func:`run_point` plus ``index`` and ``values``).
    computed, reused : list of tuple
        Indices computed by this call of :func:`sweep`, and those found finished in the folder.
    lost : list of (tuple, str)
        Points the executor did not return (a worker died, the cluster went away) and why; they
        have no file and are computed by a resumed sweep.
    stopped : str
        Why the sweep stopped before its last point (its deadline passed), ``""`` if it did not.
    options : SolverOptions or None
        The solver options of every point, as :func:`sweep` was given them (or its default); None
        for a sweep read back by :func:`load_sweep`, whose manifest holds them as data
        (``manifest["options"]``).
    settings : ContinuationOptions or None
        The continuation options of every point (likewise; ``manifest["settings"]``).
    """

    folder: Path
    manifest: dict
    points: dict = field(default_factory=dict)
    computed: list = field(default_factory=list)
    reused: list = field(default_factory=list)
    lost: list = field(default_factory=list)
    stopped: str = ""
    options: SolverOptions | None = None
    settings: ContinuationOptions | None = None

    @property
    def axes(self) -> list[Axis]:
        return [Axis(a["name"], a["values"], a["spacing"], a["spec"]) for a in self.manifest["axes"]]

    @property
    def shape(self) -> tuple[int, ...]:
        return tuple(len(a["values"]) for a in self.manifest["axes"])

    @property
    def complete(self) -> bool:
        """Every point of the grid has a result."""
        return len(self.points) == math.prod(self.shape)

    def table(self) -> dict[str, list]:
        """One row per finished point, in grid order: ``index`` (one column per axis, e.g.
        ``index.R``), the axes' ``values`` (``values.R``) and the rest of its file (for
        :meth:`to_numpy`, :meth:`to_pandas`)."""
        names = [a["name"] for a in self.manifest["axes"]]
        rows = []
        for index in sorted(self.points):
            r = dict(self.points[index])
            r["index"] = dict(zip(names, (int(i) for i in index), strict=True))
            rows.append(r)
        return table_columns(rows)

    def counts(self) -> dict[str, int]:
        """Points per status (:data:`STATUSES`), and ``missing``."""
        out = {s: 0 for s in STATUSES}
        for r in self.points.values():
            out[r["status"]] = out.get(r["status"], 0) + 1
        out["missing"] = math.prod(self.shape) - len(self.points)
        return out

    def __repr__(self) -> str:
        m = self.manifest
        grid = " x ".join(f"{a['name']} ({len(a['values'])})" for a in m["axes"])
        counts = ", ".join(f"{v} {k}" for k, v in self.counts().items() if v)
        given = [(n, getattr(self, n)) for n in ("options", "settings") if getattr(self, n) is not None]
        opts = "; " + ", ".join(f"{n}={options_text(v)}" for n, v in given) if given else ""
        return f"SweepResult({m['model']} over {grid} in {str(self.folder)!r}: {counts}{opts})"


#: Largest manifest read [bytes] (a grid of MAX_POINTS values takes about 3 MB).
MAX_MANIFEST_BYTES = 32 * 1024 * 1024


#: Largest point file read [bytes].
MAX_POINT_BYTES = 64 * 1024 * 1024


#: The entries of a manifest every reader needs, and their types.
_MANIFEST_KEYS = {
    "layout": int,
    "model": str,
    "parameter": str,
    "coordinate": str,
    "p_range": list,
    "axes": list,
    "params": dict,
    "options": dict,
    "settings": dict,
}


class _Bad(InputError):
    """A sweep file that is not what the sweep wrote."""


def _read_json(path: Path, limit: int, what: str):
    """The JSON of a regular file of at most ``limit`` bytes (NaN and infinities refused)."""
    try:
        st = os.stat(path)
    except OSError as exc:
        raise _Bad(f"{str(path)!r} cannot be read: {exc.strerror or exc}") from None
    if not stat.S_ISREG(st.st_mode):
        kind = "a folder" if stat.S_ISDIR(st.st_mode) else "not a regular file"
        raise _Bad(f"{str(path)!r} is {kind}, not a {what}")
    if st.st_size > limit:
        raise _Bad(f"{str(path)!r} has {st.st_size} bytes, more than a {what} may ({limit})")

    def refuse(name):
        raise InputError(f"{name} is not a number JSON allows")

    try:
        with open(path, "rb") as fh:
            return json.loads(fh.read(limit + 1), parse_constant=refuse)
    except (OSError, ValueError, RecursionError) as exc:  # (JSONDecodeError is a ValueError)
        raise _Bad(f"{str(path)!r} cannot be read as a {what}: {exc}") from None


def _number(v, finite: bool = True) -> bool:
    return isinstance(v, int | float) and not isinstance(v, bool) and (not finite or math.isfinite(v))


def _check_manifest(path: Path, m) -> None:
    """Raise :class:`_Bad` naming the key if ``m`` is not a manifest a sweep wrote; the grid's size
    is checked before anything is made of it."""

    def bad(key: str, what: str):
        return _Bad(
            f"{str(path)!r}: `{key}` {what}: this is not the manifest a sweep wrote; restore it, or start "
            "the sweep again in another folder"
        )

    if not isinstance(m, dict):
        raise bad("(the whole file)", f"is a JSON {type(m).__name__}, not an object")
    if m.get("layout") not in READABLE_LAYOUTS:
        raise InputError(
            f"{str(path)!r}: sweep layout {m.get('layout')!r}, this version reads "
            + ", ".join(str(v) for v in READABLE_LAYOUTS)
        )
    for key, kind in _MANIFEST_KEYS.items():
        if key not in m:
            raise bad(key, "is missing")
        if not isinstance(m[key], kind) or (kind is int and isinstance(m[key], bool)):
            raise bad(key, f"must be a JSON {'number' if kind is int else kind.__name__}, got {m[key]!r:.60}")
    lo_hi = m["p_range"]
    if not (len(lo_hi) == 2 and all(_number(v) for v in lo_hi) and 0 < lo_hi[0] < lo_hi[1]):
        raise bad("p_range", f"must be two numbers 0 < A < B, got {lo_hi!r:.60}")
    axes = m["axes"]
    if not axes:
        raise bad("axes", "is empty")
    sizes = []
    for k, a in enumerate(axes):
        key = f"axes[{k}]"
        if not isinstance(a, dict):
            raise bad(key, f"must be an object, got {a!r:.60}")
        for sub in ("name", "values", "spacing", "spec"):
            if sub not in a:
                raise bad(f"{key}.{sub}", "is missing")
        if not isinstance(a["name"], str) or not a["name"]:
            raise bad(f"{key}.name", f"must be a parameter name, got {a['name']!r:.60}")
        vals = a["values"]
        if not isinstance(vals, list) or not vals:
            raise bad(f"{key}.values", "must be a non-empty list")
        if len(vals) > MAX_POINTS:
            raise bad(f"{key}.values", f"has {len(vals)} values, more than a sweep has ({MAX_POINTS})")
        sizes.append(len(vals))
        if math.prod(sizes) > MAX_POINTS:
            raise bad("axes", f"make a grid of more than {MAX_POINTS} points")
        if not all(_number(v) for v in vals) or any(b <= a_ for a_, b in zip(vals, vals[1:], strict=False)):
            raise bad(f"{key}.values", "must be finite numbers, increasing")
        if a["spacing"] not in ("linear", "log"):
            raise bad(f"{key}.spacing", f"must be 'linear' or 'log', got {a['spacing']!r:.60}")
        if not isinstance(a["spec"], list) or not all(_number(v) for v in a["spec"]):
            raise bad(f"{key}.spec", "must be a list of numbers")
    names = [a["name"] for a in axes]
    if len(set(names)) != len(names):
        raise bad("axes", f"name a parameter twice: {names}")


def _check_point(path: Path, r, index: tuple, axes: list) -> None:
    """Raise :class:`_Bad` naming the key if ``r`` is not the point file a sweep wrote at ``index``."""

    def bad(key: str, what: str):
        return _Bad(
            f"{str(path)!r}: `{key}` {what}: this is not a point file the sweep wrote; remove it and run "
            "the sweep again with --resume to compute the point again"
        )

    if not isinstance(r, dict):
        raise bad("(the whole file)", f"is a JSON {type(r).__name__}, not an object")
    for key in ("index", "values", "status"):
        if key not in r:
            raise bad(key, "is missing")
    if r["index"] != list(index):
        raise bad("index", f"is {r['index']!r:.60}, not {list(index)} as its name says")
    want = {a["name"]: a["values"][i] for a, i in zip(axes, index, strict=True)}
    if r["values"] != want:
        raise bad("values", f"are {r['values']!r:.80}, not the grid's {want}")
    if r["status"] not in STATUSES:
        raise bad("status", f"is {r['status']!r:.60}, not one of {', '.join(STATUSES)}")
    for key in ("peak", "peak_at"):
        v = r.get(key)
        if v is not None and not _number(v):
            raise bad(key, f"must be a finite number or null, got {v!r:.60}")
    if (
        r["status"] in (PointStatus.BOUNDED, PointStatus.INCOMPLETE)
        and r.get("peak") is None
        and r.get("curve")
    ):
        raise bad("peak", "is missing where the curve has orbits")
    for key in ("reason", "message"):
        if key in r and not isinstance(r[key], str):
            raise bad(key, f"must be text, got {r[key]!r:.60}")
    if "curve" in r and not isinstance(r["curve"], dict):
        raise bad("curve", f"must be an object, got {r['curve']!r:.60}")


def load_sweep(folder: str | Path) -> SweepResult:
    """Read a sweep's folder (the manifest and every point file), each file checked.

    Raises
    ------
    InputError
        No manifest, a manifest of another layout, or a manifest or point file that is not what a
        sweep wrote (not JSON, a value that is not a number, NaN, a key missing or of the wrong
        type, a grid larger than :data:`MAX_POINTS`, a point file whose index or values are not its
        grid point's, a folder or FIFO in place of a file, a file in the folder named like a point
        of no grid point): the message names the file and the key. Checked before any work.
    """
    folder = Path(folder)
    path = folder / MANIFEST
    if not os.path.lexists(path):
        raise InputError(
            f"{str(folder)!r} holds no sweep: no {MANIFEST} (run `hybrid sweep ... --out` first)"
        )
    manifest = _read_json(path, MAX_MANIFEST_BYTES, "sweep manifest")
    _check_manifest(path, manifest)
    res = SweepResult(folder, manifest)
    shape = res.shape
    axes = manifest["axes"]
    try:
        entries = sorted(os.scandir(folder), key=lambda e: e.name)
    except OSError as exc:
        raise InputError(f"{str(folder)!r} cannot be read: {exc.strerror or exc}") from None
    for e in entries:
        m = _POINT_NAME.fullmatch(e.name)
        if m is None:
            continue
        index = tuple(int(i) for i in m.group(1).split("-"))
        p = folder / e.name
        if len(index) != len(shape) or any(i >= n for i, n in zip(index, shape, strict=False)):
            raise _Bad(
                f"{str(p)!r} is named like a point of no grid point of this sweep ({' x '.join(map(str, shape))}): "
                "remove it"
            )
        r = _read_json(p, MAX_POINT_BYTES, "point file")
        _check_point(p, r, index, axes)
        res.points[index] = r
    return res
