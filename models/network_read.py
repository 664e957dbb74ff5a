"""Network files read and validated: :func:`read_network` turns the parsed file into a :class:`Network`.

The layout of a network file is documented in :mod:`hybrid_models.network` and ``docs/models.md``;
:mod:`hybrid_models.network_cells` writes out its repeated cells first. Every refusal names the
table and the item (for a copy of a cell: the cell's table and the copy) and says what is wrong.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass, field

from hybrid import ExpressionError, ModelError
from hybrid.model.expr import parse
from hybrid.model.loader import shown_key, shown_value  # a file's values shown alike in messages

from .network_cells import expand_cells
from .network_contacts import read_contacts
from .network_structures import finish_structures, read_structures

__all__ = [
    "GROUND",
    "MAX_ELEMENTS",
    "MAX_FORCES",
    "MAX_FRICTION",
    "MAX_HARMONICS",
    "MAX_POINTS",
    "Element",
    "Force",
    "Network",
    "read_network",
]

#: Name of the fixed point (the base when ``[base]`` is given).
GROUND = "ground"
#: Limits of a network by size (each with a clear error). A friction element is one component of the
#: system (its modes are composed on demand, never enumerated) and one to three state variables; a
#: mass two; a node one or two. The engine's own limits (20000 variables, 10000 definitions: one
#: ``w_NAME`` per friction element, one per force) apply beyond.
MAX_FRICTION = 3000
MAX_POINTS = 6000
MAX_ELEMENTS = 20000
MAX_FORCES = 3000

_TOP = {
    "model",
    "parameters",
    "presets",
    "masses",
    "nodes",
    "springs",
    "dampers",
    "friction",
    "forces",
    "base",
    "plot",
    "orbit",
    "cells",
    "contacts",
    "structures",
}
_MODEL = {"name", "title", "reference", "format"}
_KEYS = {
    "masses": ({"mass"}, {"velocity", "description"}),
    "nodes": (set(), {"description"}),
    "springs": ({"between", "stiffness"}, {"description"}),
    "dampers": ({"between", "coefficient"}, {"description"}),
    "friction": ({"between", "sliding"}, {"static", "description"}),
    "forces": ({"on"}, {"offset", "amplitude", "frequency", "phase", "harmonics", "description"}),
}


# ----------------------------------------------------------------------------
# The network as data
# ----------------------------------------------------------------------------
@dataclass(frozen=True)
class Element:
    """A two-ended element of a network.

    Attributes
    ----------
    kind : {"spring", "damper", "friction"}
    name : str
        Key of the element in its table.
    a, b : str
        Its ends: a mass, a node or ``"ground"``; relative quantities are ``b - a``.
    coef : str
        Stiffness [N/m], damping coefficient [N s/m] or sliding level R [N].
    static : str or None
        Static level R_s [N] of a friction element (None: equal to R).
    """

    kind: str
    name: str
    a: str
    b: str
    coef: str
    static: str | None = None


@dataclass(frozen=True)
class Force:
    """An excitation ``offset + amplitude*sin(frequency*t + phase)`` [N] on a mass (phase [rad]), or
    with ``harmonics`` ``offset + sum of amplitude_k*sin(multiple_k*frequency*t + phase_k)``."""

    name: str
    on: str
    offset: str | None
    amplitude: str | None
    frequency: str | None
    phase: str | None = None
    harmonics: tuple = ()  # (amplitude, multiple, phase or None) each

    def terms(self) -> list[tuple[str, int, str | None]]:
        """``(amplitude, multiple, phase)`` of each harmonic (one for ``amplitude``)."""
        if self.harmonics:
            return list(self.harmonics)
        return [(self.amplitude, 1, self.phase)] if self.amplitude is not None else []


@dataclass(frozen=True)
class Network:
    """A validated mechanical network (see the module docstring for the file layout).

    Attributes
    ----------
    name, title, reference : str
        From ``[model]``.
    masses : dict of str to (str, str, str)
        Displacement name -> (mass expression [kg], velocity name, description).
    nodes : dict of str to str
        Massless node name -> description.
    elements : tuple of Element
        Springs, dampers and friction elements, in file order.
    forces : tuple of Force
    base : tuple of (str, str) or None
        (amplitude [m], frequency [rad/s]) of the base motion.
    parameters, presets, plot, orbit : dict
        Passed to the system as they are (cells written out).
    origins : dict of str to str
        Generated name -> the cell and copy it comes from (empty without ``[cells]``).
    cells : tuple of (str, int, str)
        Each cell's name, number of copies and layout (``chain``, ``chain, fixed ends``, ``ring``).
    structures : dict of str to NetStructure
        The linear structures given by matrices (:mod:`hybrid_models.network_structures`); their
        coordinates ``NAME_DOF`` are points of the network as masses are.
    """

    name: str
    title: str
    reference: str
    masses: dict
    nodes: dict
    elements: tuple
    forces: tuple
    base: tuple | None
    parameters: dict = field(default_factory=dict)
    presets: dict = field(default_factory=dict)
    plot: dict | None = None
    orbit: dict | None = None
    origins: dict = field(default_factory=dict)
    cells: tuple = ()
    contacts: tuple = ()  # the 2-D contacts (hybrid_models.network_contacts.Contact)
    structures: dict = field(default_factory=dict)

    @property
    def coords(self) -> dict[str, str]:
        """Coordinate of a structure (``NAME_DOF``) -> its velocity variable."""
        return {q: v for s in self.structures.values() for q, v in zip(s.coords, s.velocities, strict=True)}

    def where(self, table: str, name: str) -> str:
        """Where an item is written, for messages: ``[table.name]``, or the cell and copy it comes from."""
        return self.origins.get(name) or f"[{table}.{name}]"

    @property
    def friction(self) -> tuple[Element, ...]:
        """The friction elements, in file order."""
        return tuple(e for e in self.elements if e.kind == "friction")

    @property
    def node_velocities(self) -> dict[str, str]:
        """Node -> name of its velocity variable (a slave variable), for the nodes whose velocity the
        equations need: the ends of friction elements (their relative velocity), the nodes with a
        damper, and the nodes joined to another node by a spring.

        A node's velocity is fixed by the time derivative of its force balance (while its friction
        element slides, or always if it has none), by the velocity of the point its friction element
        holds it to (while it sticks), or, with a damper, by the balance itself (the damper's force
        holds the velocity; the node's position is then differential).
        """
        needed = {
            p
            for e in self.elements
            if (e.kind == "spring" and e.a in self.nodes and e.b in self.nodes) or e.kind != "spring"
            for p in (e.a, e.b)
        }
        return {u: f"vel_{u}" for u in self.nodes if u in needed}


def _table(data: Mapping, key: str) -> Mapping:
    value = data.get(key, {})
    if not isinstance(value, Mapping):
        raise ModelError(f"[{key}] must be a table, got {type(value).__name__} {shown_value(value)}")
    return value


def _check_keys(spec: object, required: set[str], optional: set[str], where: str) -> Mapping:
    if not isinstance(spec, Mapping):
        raise ModelError(f"{where} must be a table, got {shown_value(spec)}")
    extra = set(spec) - required - optional
    if extra:
        shown = ", ".join(shown_key(k) for k in sorted(map(str, extra))[:5])
        raise ModelError(
            f"{where}: unknown key(s) {shown}; allowed: {', '.join(sorted(required | optional))}"
        )
    missing = required - set(spec)
    if missing:
        raise ModelError(f"{where} lacks {', '.join(sorted(missing))}")
    return spec


def _is_name(name: object) -> bool:
    return (
        isinstance(name, str)
        and 0 < len(name) <= 64
        and name.isascii()
        and (name[0].isalpha() or name[0] == "_")
        and name.replace("_", "a").isalnum()
    )


def _coef(value: object, params: Mapping[str, str], where: str) -> str:
    """An element's coefficient as expression text: a number or an expression of parameters."""
    if isinstance(value, bool) or not isinstance(value, int | float | str):
        raise ModelError(f"{where} must be a number or an expression of parameters, got {shown_value(value)}")
    if not isinstance(value, str):
        if not math.isfinite(value):
            raise ModelError(f"{where} must be finite, got {value!r}")
        return repr(float(value))
    try:
        parse(value, params, where)
    except ExpressionError as exc:
        raise ModelError(str(exc)) from None
    return value.strip()


def _positive(value: str, params: Mapping[str, str], where: str, what: str = "a friction level") -> None:
    """``value`` must be a number > 0 or a parameter whose domain is positive (so no run can break it)."""
    try:
        number = float(value)
    except ValueError:
        number = None
    if number is not None:
        if not number > 0:
            raise ModelError(f"{where} is {number!r}: {what} must be > 0")
        return
    if value not in params:
        raise ModelError(
            f"{where} = {value!r}: {what} must be a number > 0 or a parameter whose domain is "
            "positive (it cannot be checked at run time otherwise)"
        )
    if params[value] != "positive":
        raise ModelError(
            f'{where}: parameter `{value}` has domain {params[value]!r}; {what} must have domain = "positive"'
        )


def _level_value(expr: str, values: Mapping) -> float | None:
    try:
        return float(expr)
    except ValueError:
        v = values.get(expr)
        return float(v) if isinstance(v, int | float) and not isinstance(v, bool) else None


def read_network(data: Mapping) -> Network:
    """Validate the parsed content of a network file.

    Parameters
    ----------
    data : mapping
        The file as :func:`tomllib.loads` returns it.

    Returns
    -------
    Network
        With the file's cells written out (:func:`hybrid_models.network_cells.expand_cells`).

    Raises
    ------
    ModelError
        Naming the table, the element and the problem: unknown keys or ends,
        a mass with no connection, a node whose position is undetermined, a
        non-positive friction level, a loop of friction elements, a network
        beyond the limits of size, ...
    """
    if not isinstance(data, Mapping):
        raise ModelError(f"a network file must be a table, got {shown_value(data)}")
    extra = set(data) - _TOP
    if extra:
        shown = ", ".join(shown_key(k) for k in sorted(map(str, extra))[:5])
        raise ModelError(f"network file: unknown table(s) {shown}; allowed: {', '.join(sorted(_TOP))}")
    model = _check_keys(_table(data, "model"), {"name", "format"}, _MODEL - {"name", "format"}, "[model]")
    for k, v in model.items():
        if not isinstance(v, str):
            raise ModelError(f"[model] `{k}` must be a string, got {shown_value(v)}")
    if model["format"] != "network":
        raise ModelError(f'[model] `format` is {model["format"]!r}; this reader takes "network"')
    original = data
    data, origins = expand_cells(data)

    def loc(table: str, name: object) -> str:
        return (
            origins.get(name) or f"[{table}.{shown_key(name)}]"
            if isinstance(name, str)
            else f"[{table}.{shown_key(name)}]"
        )

    params: dict[str, str] = {}
    for pname, spec in _table(data, "parameters").items():
        spec = _check_keys(spec, set(), {"unit", "description", "domain"}, loc("parameters", pname))
        if not _is_name(pname):
            raise ModelError(f"{loc('parameters', pname)}: invalid parameter name")
        dom = spec.get("domain", "real")
        params[pname] = dom if isinstance(dom, str) else ""
    presets = _table(data, "presets")
    for pset, values in presets.items():
        if not isinstance(values, Mapping):
            raise ModelError(f"[presets.{shown_key(pset)}] must be a table of parameter values")

    names: dict[str, str] = {GROUND: "the ground"}

    def claim(name: object, what: str, element: bool = False) -> str:
        # springs, dampers and friction elements (`element`) may share a name with a parameter
        # (`[springs.k1] stiffness = "k1"`): their names name no variable, parameter or definition
        # of the model (a friction element's f_NAME, w_NAME are checked when the system is built)
        if not _is_name(name):
            raise ModelError(f"{what}: {shown_value(name)} is not a valid name (1 to 64 letters, digits, _)")
        if name in ("t", "pi"):
            raise ModelError(f"{what}: the name `{name}` is reserved")
        if name in names:
            raise ModelError(f"{what}: the name `{name}` is already {names[name]}")
        if name in params and not element:
            raise ModelError(
                f"{what}: the name `{name}` is already a parameter (masses, nodes and forces name variables "
                "and definitions of the model, which a parameter may not share; springs, dampers and "
                "friction elements may)"
            )
        names[name] = what
        return name

    tables = {t: _table(data, t) for t in ("masses", "nodes", "springs", "dampers", "friction", "forces")}
    n_points = len(tables["masses"]) + len(tables["nodes"])
    if n_points > MAX_POINTS:
        raise ModelError(
            f"{n_points} masses and nodes; at most {MAX_POINTS} are allowed (the engine's limit of state "
            "variables is 20000)"
        )
    if len(tables["friction"]) > MAX_FRICTION:
        raise ModelError(
            f"[friction]: {len(tables['friction'])} friction elements; at most {MAX_FRICTION} are allowed "
            "(each is a component of the system with one to three state variables)"
        )
    n_elements = sum(len(tables[t]) for t in ("springs", "dampers", "friction"))
    if n_elements > MAX_ELEMENTS:
        raise ModelError(
            f"{n_elements} springs, dampers and friction elements; at most {MAX_ELEMENTS} are allowed"
        )
    if len(tables["forces"]) > MAX_FORCES:
        raise ModelError(
            f"[forces]: {len(tables['forces'])} forces; at most {MAX_FORCES} are allowed (each is an output of "
            "the model, recorded at every sample)"
        )

    masses: dict[str, tuple[str, str, str]] = {}
    for x, spec in tables["masses"].items():
        where = loc("masses", x)
        spec = _check_keys(spec, *_KEYS["masses"], where)
        claim(x, where)
        v = spec.get("velocity", f"v_{x}")
        claim(v, f"{where} `velocity`")
        desc = spec.get("description", "")
        if not isinstance(desc, str):
            raise ModelError(f"{where} `description` must be a string")
        mass = _coef(spec["mass"], params, f"{where} `mass`")
        _positive(mass, params, f"{where} `mass`", "a mass")
        masses[x] = (mass, v, desc)
    nodes: dict[str, str] = {}
    for u, spec in tables["nodes"].items():
        where = loc("nodes", u)
        spec = _check_keys(spec, *_KEYS["nodes"], where)
        claim(u, where)
        desc = spec.get("description", "")
        if not isinstance(desc, str):
            raise ModelError(f"{where} `description` must be a string")
        nodes[u] = desc
    specs, aliases = read_structures(data["structures"], claim) if "structures" in data else ({}, {})
    if not masses and not specs:
        raise ModelError("[masses]: a network needs at least one mass (or a structure)")
    points = set(masses) | set(nodes) | {GROUND} | set(aliases.values())

    elements: list[Element] = []
    coef_key = {"springs": "stiffness", "dampers": "coefficient", "friction": "sliding"}
    kinds = {"springs": "spring", "dampers": "damper", "friction": "friction"}
    for table in ("springs", "dampers", "friction"):
        for name, spec in tables[table].items():
            where = loc(table, name)
            spec = _check_keys(spec, *_KEYS[table], where)
            claim(name, where, element=True)
            ends = spec["between"]
            if not (isinstance(ends, list) and len(ends) == 2 and all(isinstance(e, str) for e in ends)):
                raise ModelError(f"{where} `between` must be a list of two names, got {shown_value(ends)}")
            ends = [aliases.get(end, end) for end in ends]  # a structure's DOF: NAME.DOF
            for end in ends:
                if end not in points:
                    raise ModelError(
                        f"{where} `between`: unknown end `{shown_key(end)}`; masses: {_listed(masses)}; "
                        f"nodes: {_listed(nodes) or 'none'}; "
                        + (f"DOFs of structures: {_listed(aliases)}; " if aliases else "")
                        + f"or {GROUND}"
                    )
            if ends[0] == ends[1]:
                raise ModelError(f"{where} `between`: both ends are `{ends[0]}`")
            coef = _coef(spec[coef_key[table]], params, f"{where} `{coef_key[table]}`")
            static = None
            if table == "friction":
                _positive(coef, params, f"{where} `sliding`")
                if "static" in spec:
                    static = _coef(spec["static"], params, f"{where} `static`")
                    _positive(static, params, f"{where} `static`")
                    _check_static(coef, static, presets, where)
            elements.append(Element(kinds[table], name, ends[0], ends[1], coef, static))

    contacts = read_contacts(
        _table(data, "contacts"),
        masses=masses,
        nodes=nodes,
        params=params,
        loc=loc,
        claim=claim,
        coef=_coef,
        positive=_positive,
        check_keys=_check_keys,
        dofs=aliases,
    )

    forces: list[Force] = []
    for name, spec in tables["forces"].items():
        where = loc("forces", name)
        spec = _check_keys(spec, *_KEYS["forces"], where)
        claim(name, where)
        on = aliases.get(spec["on"], spec["on"]) if isinstance(spec["on"], str) else spec["on"]
        if not isinstance(on, str) or (on not in masses and on not in aliases.values()):
            raise ModelError(
                f"{where} `on` = {shown_value(spec['on'])}: a force acts on a mass or a structure's DOF; "
                f"masses: {_listed(masses) or 'none'}" + (f"; DOFs: {_listed(aliases)}" if aliases else "")
            )
        if "amplitude" in spec and "harmonics" in spec:
            raise ModelError(f"{where}: give `amplitude` (one harmonic) or `harmonics` (several), not both")
        periodic = "amplitude" in spec or "harmonics" in spec
        if periodic != ("frequency" in spec):
            raise ModelError(f"{where}: `amplitude` (or `harmonics`) and `frequency` go together")
        if "phase" in spec and "harmonics" in spec:
            raise ModelError(f"{where}: with `harmonics`, each harmonic has its own `phase`")
        if "phase" in spec and "amplitude" not in spec:
            raise ModelError(f"{where}: a `phase` needs an `amplitude` and a `frequency`")
        if not periodic and "offset" not in spec:
            raise ModelError(f"{where} has neither an `offset` nor an `amplitude`")
        got = {
            k: _coef(spec[k], params, f"{where} `{k}`")
            for k in ("offset", "amplitude", "frequency", "phase")
            if k in spec
        }
        forces.append(
            Force(
                name,
                on,
                got.get("offset"),
                got.get("amplitude"),
                got.get("frequency"),
                got.get("phase"),
                _harmonics(spec["harmonics"], params, where) if "harmonics" in spec else (),
            )
        )
    base = None
    if "base" in data:
        spec = _check_keys(_table(data, "base"), {"amplitude", "frequency"}, set(), "[base]")
        base = (
            _coef(spec["amplitude"], params, "[base] `amplitude`"),
            _coef(spec["frequency"], params, "[base] `frequency`"),
        )
    for extra_table in ("plot", "orbit"):
        if extra_table in data and not isinstance(data[extra_table], Mapping):
            raise ModelError(f"[{extra_table}] must be a table")

    attached = {p for e in elements for p in (e.a, e.b)} | {f.on for f in forces}
    attached |= {p for c in contacts for p in (*c.tangential, *c.normal)}  # kept as boundary DOFs
    structures = finish_structures(specs, attached, claim)
    cells = tuple(
        (
            c,
            spec["count"],
            spec.get("layout", "chain") + (", fixed ends" if spec.get("ends") == "fixed" else ""),
        )
        for c, spec in original.get("cells", {}).items()
    )
    net = Network(
        name=model["name"],
        title=model.get("title", ""),
        reference=model.get("reference", ""),
        masses=masses,
        nodes=nodes,
        elements=tuple(elements),
        forces=tuple(forces),
        base=base,
        parameters={k: dict(v) for k, v in _table(data, "parameters").items()},
        presets={k: dict(v) for k, v in presets.items()},
        plot=dict(data["plot"]) if "plot" in data else None,
        orbit=dict(data["orbit"]) if "orbit" in data else None,
        origins=origins,
        cells=cells,
        contacts=contacts,
        structures=structures,
    )
    _check_topology(net)
    return net


#: Most harmonics of one force.
MAX_HARMONICS = 64


def _harmonics(value: object, params: Mapping[str, str], where: str) -> tuple:
    """A force's ``harmonics``: a list of tables ``{amplitude, multiple = 1, phase = 0}``, the
    ``multiple`` an integer >= 1 of the force's ``frequency``, the ``phase`` [rad]."""
    if not isinstance(value, list) or not value or len(value) > MAX_HARMONICS:
        raise ModelError(
            f"{where} `harmonics` must be a list of 1 to {MAX_HARMONICS} tables "
            f"{{ amplitude = ..., multiple = N, phase = ... }}, got {shown_value(value)}"
        )
    out = []
    seen = set()
    for k, h in enumerate(value):
        at = f"{where} `harmonics[{k}]`"
        if not isinstance(h, Mapping):
            raise ModelError(f"{at} must be a table {{ amplitude = ..., multiple = N, phase = ... }}")
        h = _check_keys(h, {"amplitude"}, {"multiple", "phase"}, at)
        n = h.get("multiple", 1)
        if isinstance(n, bool) or not isinstance(n, int) or not 1 <= n <= 1000:
            raise ModelError(
                f"{at} `multiple` must be an integer from 1 to 1000 (of `frequency`), got {shown_value(n)}"
            )
        if n in seen:
            raise ModelError(
                f"{at}: the multiple {n} is given twice; add the amplitudes, or give phases in one"
            )
        seen.add(n)
        amp = _coef(h["amplitude"], params, f"{at} `amplitude`")
        phase = _coef(h["phase"], params, f"{at} `phase`") if "phase" in h else None
        out.append((amp, n, phase))
    return tuple(out)


def _listed(names: Mapping, limit: int = 12) -> str:
    """Names for a message, the first ``limit`` of them (a network may have thousands)."""
    shown = list(names)[:limit]
    more = len(names) - len(shown)
    return ", ".join(shown) + (f", ... ({more} more)" if more > 0 else "")


def _check_static(sliding: str, static: str, presets: Mapping, where: str) -> None:
    """The static level must not lie below the sliding level (numbers, and every preset)."""
    for pname, values in [("", {})] + list(presets.items()):
        r, rs = _level_value(sliding, values), _level_value(static, values)
        if r is not None and rs is not None and rs < r:
            at = f" in preset `{pname}`" if pname else ""
            raise ModelError(
                f"{where}: static level {static} = {rs!r} lies below the sliding level {sliding} = {r!r}{at}"
            )


def _check_topology(net: Network) -> None:
    """Refuse the networks the derivation cannot handle, naming the element."""
    touching: dict[str, list[Element]] = {p: [] for p in (*net.masses, *net.nodes, *net.coords, GROUND)}
    for e in net.elements:
        touching[e.a].append(e)
        touching[e.b].append(e)
    in_contact = {p for c in net.contacts for p in (*c.tangential, *c.normal)}
    for x in net.masses:
        if not touching[x] and x not in in_contact:
            raise ModelError(
                f"{net.where('masses', x)} has no connection: no spring, damper, friction element or contact touches it"
            )
    _check_friction_loops(net)
    for u in net.nodes:
        springs = [e for e in touching[u] if e.kind in ("spring", "damper")]
        for e in touching[u]:
            if e.kind == "damper" and e.a in net.nodes and e.b in net.nodes:
                raise ModelError(
                    f"{net.where('dampers', e.name)} joins two massless nodes (`{e.a}`, `{e.b}`): not supported "
                    "(their velocities would be undetermined); attach dampers to a mass or the ground"
                )
        if not touching[u]:
            raise ModelError(f"{net.where('nodes', u)} has no connection: its position is undetermined")
        if not springs:
            fr = ", ".join(e.name for e in touching[u])
            raise ModelError(
                f"{net.where('nodes', u)}: no spring or damper is attached, so its position is undetermined "
                f"while its friction element(s) {fr} slip"
            )
        held = [e.name for e in touching[u] if e.kind == "friction"]
        if len(held) > 1:
            raise ModelError(
                f"{net.where('nodes', u)} is held by {len(held)} friction elements ({', '.join(held[:6])}): not "
                "supported. Each friction element is a component of the system that owns its massless ends, so "
                "that a node's equations depend on the state of one element only; a node between two elements "
                "would make them depend on both. Put a mass between the elements, or join them by a spring "
                "through two nodes"
            )
    # nodes joined by springs form groups whose balances are coupled: each needs a spring to a mass or
    # the ground, else the group floats while its friction elements slip
    seen: set[str] = set()
    for u in net.nodes:
        if u in seen:
            continue
        group, stack, anchored = {u}, [u], False
        while stack:
            p = stack.pop()
            for e in touching[p]:
                if e.kind == "friction":
                    continue
                q = e.b if e.a == p else e.a
                if q not in net.nodes:  # a spring or damper to a mass or the ground
                    anchored = True
                elif q not in group:
                    group.add(q)
                    stack.append(q)
        seen |= group
        if not anchored:
            names = ", ".join(q for q in net.nodes if q in group)
            raise ModelError(
                f"{net.where('nodes', u)}: the massless nodes {names} are joined by springs only to each other, "
                "so their positions are undetermined while their friction elements slip; attach one to a mass "
                "or the ground"
            )


def _check_friction_loops(net: Network) -> None:
    """Friction elements must not form a loop (their forces would be undetermined while all stick)."""
    parent: dict[str, str] = {}

    def find(p: str) -> str:
        root = p
        while parent.get(root, root) != root:
            root = parent[root]
        while p != root:  # path compression: a chain of n elements costs O(n), not O(n**2)
            parent[p], p = root, parent[p]
        return root

    adjacency: dict[str, list[tuple[str, Element]]] = {}
    for e in net.friction:
        ra, rb = find(e.a), find(e.b)
        if ra == rb:
            path = _tree_path(adjacency, e.a, e.b)
            loop = [e.name] + [el.name for el in path]
            massless = all(p in net.nodes for el in [e, *path] for p in (el.a, el.b))
            what = "a loop of massless nodes joined only by friction" if massless else "a loop"
            shown = ", ".join(loop[:8]) + (f", ... ({len(loop) - 8} more)" if len(loop) > 8 else "")
            raise ModelError(
                f"{net.where('friction', e.name)}: friction elements {shown} form {what}: while they all stick "
                "the forces they carry are undetermined"
            )
        parent[ra] = rb
        adjacency.setdefault(e.a, []).append((e.b, e))
        adjacency.setdefault(e.b, []).append((e.a, e))


def _tree_path(adjacency: Mapping[str, list[tuple[str, Element]]], start: str, goal: str) -> list[Element]:
    """The elements on the path from ``start`` to ``goal`` in a forest (breadth-first)."""
    prev: dict[str, tuple[str, Element] | None] = {start: None}
    queue = [start]
    while queue:
        p = queue.pop(0)
        if p == goal:
            break
        for q, e in adjacency.get(p, []):
            if q not in prev:
                prev[q] = (p, e)
                queue.append(q)
    path = []
    p = goal
    while prev.get(p) is not None:
        p, e = prev[p]
        path.append(e)
    return path
