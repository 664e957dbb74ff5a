"""Repeated structures in network files: a cell declared once and repeated as a chain or a ring.

A ``[cells.NAME]`` table of a network file declares a *cell*: masses, nodes, springs, dampers,
friction elements, 2-D contacts, forces and structures (``[cells.NAME.structures.S]``, matrices as
at the top level) with names local to the cell, repeated ``count`` times. Copy ``i`` (1 to
``count``) of a local item ``X`` is the network item ``X_i``; its ends may name the cell's own
points, its neighbours' (``next.X``, ``prev.X``), a copy of any cell (``CELL[k].X``), the top-level
masses and nodes, and ``ground``; a point may be a DOF of a local structure (``S.D``, ``next.S.D``,
``CELL[k].S.D``: the DOF ``D`` of copy ``S_i``). Parameters declared in the cell
(``[cells.NAME.parameters.P]``) take one value per copy (the network parameters ``P_1`` ...
``P_count``), given in a preset's sub-table ``[presets.S.NAME]`` as one number for all copies, a
list of ``count`` numbers, or a named distribution (``{ linear = [a, b] }``,
``{ alternating = [a, b, ...] }``). In the cell's expressions ``i`` is the copy's index and ``N``
the count. Nothing in a file is executed; :func:`expand_cells` turns the cells into the ordinary
tables that :func:`hybrid_models.network.read_network` reads, and says where each generated item
comes from, for messages. The syntax is documented in ``docs/models.md``.
"""

from __future__ import annotations

import math
import re
from collections.abc import Mapping

from hybrid import ModelError
from hybrid.model.loader import shown_key, shown_value  # a file's values shown alike in messages

__all__ = ["MAX_COPIES", "expand_cells"]

#: Copies of one cell (each with a clear error beyond; the network's own limits apply after expansion).
MAX_COPIES = 5000

_CELL_KEYS = {"count", "layout", "ends", "description"}
_PART_TABLES = ("masses", "nodes", "springs", "dampers", "friction", "forces", "contacts", "structures")
_ELEMENT_TABLES = ("springs", "dampers", "friction", "contacts")
_LAYOUTS = ("chain", "ring")
_ENDS = ("free", "fixed")
#: Keys of a cell's items that hold expressions (the cell's index ``i``, count ``N`` and per-copy
#: parameters are substituted in them).
_EXPR_KEYS = {
    "mass",
    "stiffness",
    "coefficient",
    "sliding",
    "static",
    "offset",
    "amplitude",
    "frequency",
    "phase",
    "preload",  # a 2-D contact's (hybrid_models.network_contacts)
    "normal_stiffness",
    "tangential_stiffness",
    "mu",
}
_NAME_TOKEN = re.compile(r"(?<![A-Za-z0-9_.])[A-Za-z_][A-Za-z0-9_]*")
_CELL_REF = re.compile(
    r"([A-Za-z_][A-Za-z0-9_]*)\[(-?[0-9]+)\]\.([A-Za-z_][A-Za-z0-9_]*(?:\.[A-Za-z_][A-Za-z0-9_]*)?)"
)
_DISTRIBUTIONS = ("linear", "alternating")


def _is_name(name: object) -> bool:
    return (
        isinstance(name, str)
        and 0 < len(name) <= 64
        and name.isascii()
        and (name[0].isalpha() or name[0] == "_")
        and name.replace("_", "a").isalnum()
    )


def _number(value: object) -> bool:
    return isinstance(value, int | float) and not isinstance(value, bool) and math.isfinite(value)


class _Cell:
    """One ``[cells.NAME]`` table, validated: its count, layout, local items and parameters."""

    def __init__(self, name: str, spec: object, top_names: set[str], top_params: set[str]):
        where = f"[cells.{shown_key(name)}]"
        if not _is_name(name):
            raise ModelError(
                f"{where}: {shown_value(name)} is not a valid cell name (1 to 64 letters, digits, _)"
            )
        if not isinstance(spec, Mapping):
            raise ModelError(f"{where} must be a table, got {shown_value(spec)}")
        allowed = _CELL_KEYS | set(_PART_TABLES) | {"parameters"}
        extra = set(spec) - allowed
        if extra:
            shown = ", ".join(shown_key(k) for k in sorted(map(str, extra))[:5])
            raise ModelError(f"{where}: unknown key(s) {shown}; allowed: {', '.join(sorted(allowed))}")
        if "count" not in spec:
            raise ModelError(f"{where} lacks `count` (the number of copies of the cell)")
        count = spec["count"]
        if isinstance(count, bool) or not isinstance(count, int) or not 1 <= count <= MAX_COPIES:
            raise ModelError(
                f"{where} `count` = {shown_value(count)}: the number of copies must be an integer from 1 to {MAX_COPIES}"
            )
        layout = spec.get("layout", "chain")
        if layout not in _LAYOUTS:
            raise ModelError(
                f'{where} `layout` = {shown_value(layout)}: a cell repeats as a "chain" or a "ring"'
            )
        ends = spec.get("ends", "free")
        if ends not in _ENDS:
            raise ModelError(
                f'{where} `ends` = {shown_value(ends)}: the ends of a chain are "free" (elements reaching past them '
                'are left out) or "fixed" (they attach to the ground)'
            )
        if "ends" in spec and layout == "ring":
            raise ModelError(f"{where}: a ring has no ends; `ends` is for a chain")
        desc = spec.get("description", "")
        if not isinstance(desc, str):
            raise ModelError(f"{where} `description` must be a string")
        self.name, self.where, self.count, self.layout, self.ends = name, where, count, layout, ends
        self.parts: dict[str, Mapping] = {}
        self.points: set[str] = set()  # local masses and nodes
        local: dict[str, str] = {}
        local_table: dict[str, str] = {}
        for table in (*_PART_TABLES, "parameters"):
            content = spec.get(table, {})
            if not isinstance(content, Mapping):
                raise ModelError(f"{where}: [{table}] must be a table, got {shown_value(content)}")
            for item in content:
                here = f"[cells.{name}.{table}.{shown_key(item)}]"
                if not _is_name(item):
                    raise ModelError(
                        f"{here}: {shown_value(item)} is not a valid name (1 to 64 letters, digits, _)"
                    )
                # element names have a namespace of their own: `[springs.k] stiffness = "k"`
                shared = {table, local_table.get(item)} <= {*_ELEMENT_TABLES, "parameters"} and (
                    "parameters" in {table, local_table.get(item)}
                )
                if item in local and not shared:
                    raise ModelError(f"{here}: the name `{item}` is already {local[item]} of the cell")
                if item in ("ground", "next", "prev", "i", "N", "t", "pi"):
                    raise ModelError(f"{here}: the name `{item}` is reserved in a cell")
                if item in top_names or (item in top_params and table not in _ELEMENT_TABLES):
                    raise ModelError(
                        f"{here}: `{item}` is also the name of a top-level item or parameter; inside the cell "
                        "it would hide it: rename one"
                    )
                local[item] = f"[{table}.{item}]"
                local_table[item] = table
            self.parts[table] = content
        self.points = set(self.parts["masses"]) | set(self.parts["nodes"])
        self.structures = set(self.parts["structures"])  # their DOFs: STRUCTURE.DOF
        for m, mspec in self.parts["masses"].items():
            v = mspec.get("velocity") if isinstance(mspec, Mapping) else None
            if v is not None:
                if not _is_name(v):
                    raise ModelError(
                        f"[cells.{name}.masses.{shown_key(m)}] `velocity`: {shown_value(v)} is not a valid name"
                    )
                if v in local:
                    raise ModelError(
                        f"[cells.{name}.masses.{shown_key(m)}] `velocity`: the name `{v}` is already {local[v]} of the cell"
                    )
                local[v] = "a velocity"
        self.params = dict(self.parts["parameters"])
        if not any(self.parts[t] for t in _PART_TABLES):
            raise ModelError(f"{where} has no masses, nodes, elements or forces")

    def copy_name(self, local: str, i: int) -> str:
        return f"{local}_{i}"

    def local_point(self, text: str, i: int) -> str | None:
        """Copy ``i`` of a local point: a mass or node ``X`` (``X_i``), or a DOF ``S.D`` of a local
        structure ``S`` (``S_i.D``; the DOF is checked when the structure's matrices are read).
        None if ``text`` is neither."""
        if text in self.points:
            return self.copy_name(text, i)
        head, dot, tail = text.partition(".")
        if dot and head in self.structures and tail:
            return f"{self.copy_name(head, i)}.{tail}"
        return None

    def kinds(self) -> str:
        """What a point of the cell may be, for a message."""
        return "mass, node or structure's DOF" if self.structures else "mass or node"

    def shown_points(self) -> str:
        """The cell's points for a message."""
        have = sorted(self.points) + [f"{s}.DOF" for s in sorted(self.structures)]
        return ", ".join(have) or "none"

    def neighbour(self, i: int, step: int) -> int | None:
        """Index of the copy ``step`` away from copy ``i`` (None past a chain's end)."""
        j = i + step
        if self.layout == "ring":
            return (j - 1) % self.count + 1
        return j if 1 <= j <= self.count else None


class _Expander:
    def __init__(self, data: Mapping):
        cells = data["cells"]
        if not isinstance(cells, Mapping):
            raise ModelError(f"[cells] must be a table of cells, got {shown_value(cells)}")
        if not cells:
            raise ModelError("[cells] declares no cell")
        top_params = data.get("parameters", {})
        top_params = set(top_params) if isinstance(top_params, Mapping) else set()
        for reserved in ("i", "N"):
            if reserved in top_params:
                raise ModelError(
                    f"[parameters.{reserved}]: in the expressions of a cell `i` is the copy's index and `N` the "
                    "number of copies; rename the parameter"
                )
        top_names = {"ground"}
        for table in _PART_TABLES:
            content = data.get(table, {})
            if isinstance(content, Mapping):
                top_names |= {k for k in content if isinstance(k, str)}
        self.cells = {name: _Cell(name, spec, top_names, top_params) for name, spec in cells.items()}
        self.origins: dict[str, str] = {}

    # references ----------------------------------------------------------------
    def cell_ref(self, text: str, where: str) -> str:
        """``CELL[k].X`` as the generated name of item ``X`` of copy ``k`` of cell ``CELL``."""
        m = _CELL_REF.fullmatch(text)
        if m is None:
            raise ModelError(
                f"{where}: {shown_value(text)} is not a reference to a cell's item; write CELL[k].NAME, e.g. block[1].x"
            )
        cname, k, item = m.group(1), int(m.group(2)), m.group(3)
        cell = self.cells.get(cname)
        if cell is None:
            raise ModelError(
                f"{where}: {text!r} names cell `{cname}`, which does not exist; cells: {', '.join(self.cells)}"
            )
        if not 1 <= k <= cell.count:
            raise ModelError(f"{where}: {text!r}: cell `{cname}` has copies 1 to {cell.count}")
        point = cell.local_point(item, k)
        if point is None:
            raise ModelError(
                f"{where}: {text!r}: cell `{cname}` has no {cell.kinds()} `{item}`; its points: "
                f"{cell.shown_points()}"
            )
        return point

    def point(self, text: object, cell: _Cell | None, i: int, where: str) -> str | None:
        """An end or ``on`` as a network point name (None: past the free end of a chain)."""
        if not isinstance(text, str):
            return text  # the network reader names the bad value
        if "[" in text:
            return self.cell_ref(text, where)
        if cell is None:
            return text
        if text.startswith(("next.", "prev.")):
            local = text[5:]
            if cell.local_point(local, i) is None:
                raise ModelError(
                    f"{where}: {text!r}: the cell has no {cell.kinds()} `{local}` (its points: "
                    f"{cell.shown_points()})"
                )
            j = cell.neighbour(i, 1 if text.startswith("next.") else -1)
            if j is None:
                return "ground" if cell.ends == "fixed" else None
            return cell.local_point(local, j)
        return cell.local_point(text, i) or text

    def expression(self, value: object, cell: _Cell, i: int) -> object:
        """A cell's coefficient for copy ``i``: ``i``, ``N`` and per-copy parameters substituted."""
        if not isinstance(value, str):
            return value

        def sub(m: re.Match) -> str:
            word = m.group(0)
            if word == "i":
                return f"({i})"
            if word == "N":
                return f"({cell.count})"
            if word in cell.params:
                return cell.copy_name(word, i)
            return word

        return _NAME_TOKEN.sub(sub, value)

    # expansion -------------------------------------------------------------------
    def expand(self, data: Mapping) -> dict:
        out = {k: v for k, v in data.items() if k != "cells"}
        for table in (*_PART_TABLES, "parameters"):
            content = data.get(table, {})
            out[table] = dict(content) if isinstance(content, Mapping) else content
        # top-level items may refer to copies as CELL[k].X
        for table in _PART_TABLES:
            if not isinstance(out[table], dict):
                continue
            for name, spec in list(out[table].items()):
                if isinstance(spec, Mapping):
                    out[table][name] = self.resolve(spec, None, 0, f"[{table}.{shown_key(name)}]")
        for cell in self.cells.values():
            for table in _PART_TABLES:
                if not isinstance(out[table], dict):
                    raise ModelError(f"[{table}] must be a table, got {shown_value(out[table])}")
            for i in range(1, cell.count + 1):
                for table in _PART_TABLES:
                    for local, spec in cell.parts[table].items():
                        here = f"[cells.{cell.name}.{table}.{local}]"
                        if not isinstance(spec, Mapping):
                            raise ModelError(f"{here} must be a table, got {shown_value(spec)}")
                        new = self.resolve(spec, cell, i, here)
                        if new is None:  # reaches past the free end of a chain
                            continue
                        gen = cell.copy_name(local, i)
                        if gen in out[table]:
                            raise ModelError(
                                f"{here}: copy {i} is named `{gen}`, which the file already uses in [{table}]"
                            )
                        if table == "masses" and "velocity" in new:
                            new["velocity"] = cell.copy_name(new["velocity"], i)
                        out[table][gen] = new
                        self.origins[gen] = f"{here} (copy {i} of {cell.count}, `{gen}`)"
            if not isinstance(out["parameters"], dict):
                raise ModelError(f"[parameters] must be a table, got {shown_value(out['parameters'])}")
            for local, spec in cell.params.items():
                here = f"[cells.{cell.name}.parameters.{local}]"
                if not isinstance(spec, Mapping):
                    raise ModelError(f"{here} must be a table, got {shown_value(spec)}")
                for i in range(1, cell.count + 1):
                    gen = cell.copy_name(local, i)
                    if gen in out["parameters"]:
                        raise ModelError(f"{here}: copy {i} is named `{gen}`, which is already a parameter")
                    new = dict(spec)
                    desc = new.get("description", "")
                    if isinstance(desc, str):
                        new["description"] = (desc + " " if desc else "") + f"(cell {cell.name}, copy {i})"
                    out["parameters"][gen] = new
                    self.origins[gen] = f"{here} (copy {i} of {cell.count}, `{gen}`)"
        out["presets"] = self.presets(data.get("presets", {}))
        return out

    def resolve(self, spec: Mapping, cell: _Cell | None, i: int, where: str) -> dict | None:
        new = dict(spec)
        for key in ("between", "tangential", "normal"):  # (the last two: a contact's pairs of ends)
            if key in new and isinstance(new[key], list):
                ends = [self.point(e, cell, i, f"{where} `{key}`") for e in new[key]]
                if any(e is None for e in ends):
                    return None
                new[key] = ends
        if "on" in new:
            on = new["on"]
            if isinstance(on, str) and cell is not None and on.startswith(("next.", "prev.")):
                raise ModelError(f"{where} `on` = {on!r}: a cell's force acts on a mass of its own copy")
            new["on"] = self.point(on, cell, i, f"{where} `on`")
        if cell is not None:
            for k in _EXPR_KEYS & new.keys():
                new[k] = self.expression(new[k], cell, i)
            if isinstance(new.get("harmonics"), list):  # a force's harmonics: each amplitude and phase
                new["harmonics"] = [
                    {k: self.expression(v, cell, i) if k in _EXPR_KEYS else v for k, v in h.items()}
                    if isinstance(h, Mapping)
                    else h
                    for h in new["harmonics"]
                ]
        return new

    def presets(self, presets: object) -> object:
        if not isinstance(presets, Mapping):
            return presets  # the network reader names the problem
        out = {}
        for pname, values in presets.items():
            if not isinstance(values, Mapping):
                out[pname] = values
                continue
            flat = {}
            for key, value in values.items():
                if not isinstance(value, Mapping):
                    flat[key] = value
                    continue
                where = f"[presets.{shown_key(pname)}.{shown_key(key)}]"
                cell = self.cells.get(key)
                if cell is None:
                    raise ModelError(
                        f"{where}: a table in a preset gives the per-copy parameters of a cell, and there is no "
                        f"cell `{shown_key(key)}`; cells: {', '.join(self.cells)}"
                    )
                for local, spec in value.items():
                    if local not in cell.params:
                        have = ", ".join(cell.params) or "none"
                        raise ModelError(
                            f"{where}: `{shown_key(local)}` is not a parameter of cell `{cell.name}`; its parameters: {have}"
                        )
                    for k, v in enumerate(_per_copy(spec, cell.count, f"{where} `{local}`"), start=1):
                        gen = cell.copy_name(local, k)
                        if gen in values:
                            raise ModelError(
                                f"[presets.{shown_key(pname)}]: `{gen}` is given twice ({where} sets it too)"
                            )
                        flat[gen] = v
            out[pname] = flat
        return out


def _per_copy(spec: object, n: int, where: str) -> list[float]:
    """The values of a per-copy parameter for ``n`` copies."""
    if _number(spec):
        return [float(spec)] * n
    if isinstance(spec, list):
        if len(spec) != n:
            raise ModelError(
                f"{where}: {len(spec)} values for the {n} copies of the cell; give {n} (or one number)"
            )
        for k, v in enumerate(spec, start=1):
            if not _number(v):
                raise ModelError(f"{where}: value {k} is {shown_value(v)}, not a finite number")
        return [float(v) for v in spec]
    if isinstance(spec, Mapping):
        if len(spec) != 1 or next(iter(spec)) not in _DISTRIBUTIONS:
            raise ModelError(
                f"{where}: a distribution is one of {{ linear = [a, b] }} (from a in copy 1 to b in copy N) or "
                f"{{ alternating = [a, b, ...] }} (repeated in turn), got {shown_value(dict(spec))}"
            )
        kind, args = next(iter(spec.items()))
        if not isinstance(args, list) or not args or not all(_number(a) for a in args):
            raise ModelError(f"{where}: `{kind}` takes a list of finite numbers, got {shown_value(args)}")
        if kind == "linear":
            if len(args) != 2:
                raise ModelError(f"{where}: `linear` takes two numbers [a, b], got {len(args)}")
            a, b = float(args[0]), float(args[1])
            return [a] if n == 1 else [a + (b - a) * k / (n - 1) for k in range(n)]
        return [float(args[k % len(args)]) for k in range(n)]
    raise ModelError(
        f"{where}: give one number, a list of {n} numbers, or a distribution ({{ linear = [a, b] }}, "
        f"{{ alternating = [a, b] }}), got {shown_value(spec)}"
    )


def expand_cells(data: Mapping) -> tuple[Mapping, dict[str, str]]:
    """The network file with its cells written out as ordinary items.

    Parameters
    ----------
    data : mapping
        The file as :func:`tomllib.loads` returns it.

    Returns
    -------
    data : mapping
        ``data`` itself if it has no ``[cells]``; otherwise a copy whose ``masses``, ``nodes``,
        ``springs``, ``dampers``, ``friction``, ``forces`` and ``parameters`` hold every copy of
        every cell (top-level items first, then each cell's copies in order, copy by copy), whose
        presets give each per-copy parameter by its generated name, and whose references
        ``CELL[k].X`` are resolved.
    origins : dict of str to str
        Generated name -> where it comes from (``[cells.block.friction.contact] (copy 3 of 20,
        `contact_3`)``), for messages.

    Raises
    ------
    ModelError
        Naming the cell and the problem: a bad count or layout, a name used twice, a reference to a
        cell, a copy or an item that does not exist, per-copy values of the wrong number or form.
    """
    if not isinstance(data, Mapping) or "cells" not in data:
        return data, {}
    expander = _Expander(data)
    return expander.expand(data), expander.origins
