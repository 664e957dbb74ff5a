"""Mechanical networks with Coulomb friction: a file describes the mechanism, the automaton is derived.

A *network file* is a model file (TOML) with ``format = "network"`` in its
``[model]`` table. Instead of modes, slave equations and guards it lists the
parts of a one-dimensional mechanism:

* ``[masses.X]``: a point mass whose displacement variable is ``X`` [m];
  ``mass`` (a number > 0 or a parameter of domain positive) [kg], ``velocity`` (name of its
  velocity variable, default ``v_X``) [m/s], ``description``;
* ``[nodes.U]``: a massless node (connecting point) of displacement ``U`` [m];
* ``ground``: the fixed point (or the moving base, with ``[base]``);
* ``[springs.NAME]``: ``between = [A, B]``, ``stiffness`` [N/m];
* ``[dampers.NAME]``: ``between = [A, B]``, ``coefficient`` [N s/m] (not
  between two massless nodes);
* ``[friction.NAME]``: a Coulomb friction element, ``between = [A, B]``,
  ``sliding`` level R [N] (> 0), optional ``static`` level R_s >= R [N]:
  the element sticks while the force it must carry stays inside
  ``(-R_s, R_s)`` and slides with the force ``+-R``;
* ``[forces.NAME]``: ``on = X`` (a mass), ``offset`` F0 [N], ``amplitude``
  F [N], ``frequency`` Omega [rad/s]: the force ``F0 + F sin(Omega t)``,
  named ``NAME`` among the model's definitions;
* ``[base]``: ``amplitude`` Y [m], ``frequency`` Omega [rad/s]: the ground
  moves as ``y(t) = Y sin(Omega t)``.

``[parameters]``, ``[presets]``, and optionally ``[plot]`` and ``[orbit]``, are
those of a mode-level file (:mod:`hybrid.model.loader`).

Derivation (see ``docs/models.md``): each friction element ``e`` between
``A`` and ``B`` is in one of the states ``stick``, ``slip+`` (``v_B > v_A``),
``slip-``; a mode is one state per element (all combinations are reachable
from the all-stick mode by single switches). In a mode, the sticking
elements glue their ends into *clusters* that move rigidly:

* a cluster holding the ground moves with the ground;
* a cluster holding masses moves with the acceleration (sum of the forces
  of the springs, dampers, slipping elements and excitations on its members) /
  (sum of its masses); its massless nodes are differential variables with the
  cluster's velocity;
* a massless node in no cluster is a slave (algebraic) variable fixed by its
  force balance, as the hand-written absorber's ``u``; in a cluster of massless
  nodes only, the first node is the slave of the cluster's balance and the
  others move with the cluster's velocity; nodes joined to each other by
  springs have coupled balances and their velocities are slave variables
  ``vel_U`` (the time derivative of the balances); a node with a damper is
  differential, ``U' = vel_U``, with ``vel_U`` fixed by its balance.

The force a sticking element carries follows from cutting the cluster at the
element (the cluster is a tree: loops of friction elements are refused). The
element breaks away when that force crosses ``+-R_s`` and a sliding element
sticks when its relative velocity crosses zero; a stop that joins masses (or
a mass and the ground) resets their velocities to the cluster's common one
(momentum-conserving), as the hand-written Coulomb oscillator does.

Outputs: for each element ``f_NAME`` (the force it exerts on its first end,
``A``) [N] and ``w_NAME = v_B - v_A`` [m/s]; ``E`` (kinetic + spring energy)
[J]; the excitation forces. Quadratures: ``W`` (work of the excitations, base
motion included) [J] and ``D`` (energy dissipated by friction and dampers) [J].
"""

from __future__ import annotations

import itertools
import math
import textwrap
from collections.abc import Mapping
from dataclasses import dataclass, field

from hybrid import ExpressionError, ModelError
from hybrid.model.expr import parse
from hybrid.model.loader import _key, _short  # how a file's values are quoted in messages: one place

__all__ = [
    "GROUND",
    "Network",
    "build",
    "describe",
    "describe_network",
    "draw",
    "draw_network",
    "network_model",
    "read_network",
]

#: Name of the fixed point (the base when ``[base]`` is given).
GROUND = "ground"
#: Limits of a network (each with a clear error): 3**MAX_FRICTION modes.
MAX_FRICTION = 6
MAX_POINTS = 100
MAX_ELEMENTS = 500

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
}
_MODEL = {"name", "title", "reference", "format"}
_KEYS = {
    "masses": ({"mass"}, {"velocity", "description"}),
    "nodes": (set(), {"description"}),
    "springs": ({"between", "stiffness"}, {"description"}),
    "dampers": ({"between", "coefficient"}, {"description"}),
    "friction": ({"between", "sliding"}, {"static", "description"}),
    "forces": ({"on"}, {"offset", "amplitude", "frequency", "harmonics", "description"}),
}
_STATES = ("stick", "slip+", "slip-")
_SIGN = {"slip+": 1, "slip-": -1}


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
    """An excitation ``offset + amplitude*sin(frequency*t)`` [N] on a mass, or with ``harmonics``
    ``offset + sum of amplitude_k*sin(multiple_k*frequency*t + phase_k)``."""

    name: str
    on: str
    offset: str | None
    amplitude: str | None
    frequency: str | None
    harmonics: tuple = ()  # (amplitude, multiple, phase or None) each

    def terms(self) -> list[tuple[str, int, str | None]]:
        """``(amplitude, multiple, phase)`` of each harmonic (one for ``amplitude``)."""
        if self.harmonics:
            return list(self.harmonics)
        return [(self.amplitude, 1, None)] if self.amplitude is not None else []

    def text(self, space: str = "*") -> str:
        """The force as an expression (``space=" "``: for reading, ``F sin(Omega t)``)."""
        parts = [self.offset] if self.offset is not None else []
        for amp, n, phase in self.terms():
            arg = (f"{n}*" if n != 1 else "") + f"{_paren(self.frequency)}*t"
            if phase is not None:
                arg += f" + {_paren(phase)}"
            part = f"{_paren(amp)}*sin({arg})"
            parts.append(part.replace("*", " ") if space == " " else part)
        return " + ".join(parts)


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
        Passed to the mode-level model as they are.
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

    @property
    def friction(self) -> tuple[Element, ...]:
        """The friction elements, in file order."""
        return tuple(e for e in self.elements if e.kind == "friction")

    @property
    def node_velocities(self) -> dict[str, str]:
        """Node -> name of its velocity variable, for the nodes joined to another node by a spring and
        the nodes with a damper.

        The balances of nodes joined by springs are coupled, so their velocities (needed for the
        relative velocities of sliding elements) are slave variables fixed by the time derivative of
        those balances; a damper puts the velocity into the balance itself, which then fixes it (the
        node's position is then differential).
        """
        coupled = {
            p
            for e in self.elements
            if (e.kind == "spring" and e.a in self.nodes and e.b in self.nodes) or e.kind == "damper"
            for p in (e.a, e.b)
        }
        return {u: f"vel_{u}" for u in self.nodes if u in coupled}


def _table(data: Mapping, key: str) -> Mapping:
    value = data.get(key, {})
    if not isinstance(value, Mapping):
        raise ModelError(f"[{key}] must be a table, got {type(value).__name__} {_short(value)}")
    return value


def _check_keys(spec: object, required: set[str], optional: set[str], where: str) -> Mapping:
    if not isinstance(spec, Mapping):
        raise ModelError(f"{where} must be a table, got {_short(spec)}")
    extra = set(spec) - required - optional
    if extra:
        shown = ", ".join(_key(k) for k in sorted(map(str, extra))[:5])
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
        raise ModelError(f"{where} must be a number or an expression of parameters, got {_short(value)}")
    if not isinstance(value, str):
        if not math.isfinite(value):
            raise ModelError(f"{where} must be finite, got {value!r}")
        return repr(float(value))
    try:
        parse(value, set(params), where)
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

    Raises
    ------
    ModelError
        Naming the table, the element and the problem: unknown keys or ends,
        a mass with no connection, a node whose position is undetermined, a
        non-positive friction level, a loop of friction elements, ...
    """
    if not isinstance(data, Mapping):
        raise ModelError(f"a network file must be a table, got {_short(data)}")
    extra = set(data) - _TOP
    if extra:
        shown = ", ".join(_key(k) for k in sorted(map(str, extra))[:5])
        raise ModelError(f"network file: unknown table(s) {shown}; allowed: {', '.join(sorted(_TOP))}")
    model = _check_keys(_table(data, "model"), {"name", "format"}, _MODEL - {"name", "format"}, "[model]")
    for k, v in model.items():
        if not isinstance(v, str):
            raise ModelError(f"[model] `{k}` must be a string, got {_short(v)}")
    if model["format"] != "network":
        raise ModelError(f'[model] `format` is {model["format"]!r}; this reader takes "network"')

    params: dict[str, str] = {}
    for pname, spec in _table(data, "parameters").items():
        spec = _check_keys(spec, set(), {"unit", "description", "domain"}, f"[parameters.{_key(pname)}]")
        if not _is_name(pname):
            raise ModelError(f"[parameters.{_key(pname)}]: invalid parameter name")
        dom = spec.get("domain", "real")
        params[pname] = dom if isinstance(dom, str) else ""
    presets = _table(data, "presets")
    for pset, values in presets.items():
        if not isinstance(values, Mapping):
            raise ModelError(f"[presets.{_key(pset)}] must be a table of parameter values")

    names: dict[str, str] = {GROUND: "the ground"}

    def claim(name: object, what: str, element: bool = False) -> str:
        # springs, dampers and friction elements (`element`) may share a name with a parameter
        # (`[springs.k1] stiffness = "k1"`): their names name no variable, parameter or definition
        # of the model (a friction element's outputs f_NAME, w_NAME are checked when it is built)
        if not _is_name(name):
            raise ModelError(f"{what}: {_short(name)} is not a valid name (1 to 64 letters, digits, _)")
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

    masses: dict[str, tuple[str, str, str]] = {}
    for x, spec in _table(data, "masses").items():
        where = f"[masses.{_key(x)}]"
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
    for u, spec in _table(data, "nodes").items():
        where = f"[nodes.{_key(u)}]"
        spec = _check_keys(spec, *_KEYS["nodes"], where)
        claim(u, where)
        desc = spec.get("description", "")
        if not isinstance(desc, str):
            raise ModelError(f"{where} `description` must be a string")
        nodes[u] = desc
    if not masses:
        raise ModelError("[masses]: a network needs at least one mass")
    if len(masses) + len(nodes) > MAX_POINTS:
        raise ModelError(f"{len(masses) + len(nodes)} masses and nodes; at most {MAX_POINTS} are allowed")
    points = set(masses) | set(nodes) | {GROUND}

    elements: list[Element] = []
    coef_key = {"springs": "stiffness", "dampers": "coefficient", "friction": "sliding"}
    kinds = {"springs": "spring", "dampers": "damper", "friction": "friction"}
    for table in ("springs", "dampers", "friction"):
        for name, spec in _table(data, table).items():
            where = f"[{table}.{_key(name)}]"
            spec = _check_keys(spec, *_KEYS[table], where)
            claim(name, where, element=True)
            ends = spec["between"]
            if not (isinstance(ends, list) and len(ends) == 2 and all(isinstance(e, str) for e in ends)):
                raise ModelError(f"{where} `between` must be a list of two names, got {_short(ends)}")
            for end in ends:
                if end not in points:
                    raise ModelError(
                        f"{where} `between`: unknown end `{_key(end)}`; masses: {', '.join(masses)}; "
                        f"nodes: {', '.join(nodes) or 'none'}; or {GROUND}"
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
    if len(elements) > MAX_ELEMENTS:
        raise ModelError(f"{len(elements)} elements; at most {MAX_ELEMENTS} are allowed")

    forces: list[Force] = []
    for name, spec in _table(data, "forces").items():
        where = f"[forces.{_key(name)}]"
        spec = _check_keys(spec, *_KEYS["forces"], where)
        claim(name, where)
        if not isinstance(spec["on"], str) or spec["on"] not in masses:
            raise ModelError(
                f"{where} `on` = {_short(spec['on'])}: a force acts on a mass; masses: {', '.join(masses)}"
            )
        if "amplitude" in spec and "harmonics" in spec:
            raise ModelError(f"{where}: give `amplitude` (one harmonic) or `harmonics` (several), not both")
        periodic = "amplitude" in spec or "harmonics" in spec
        if periodic != ("frequency" in spec):
            raise ModelError(f"{where}: `amplitude` (or `harmonics`) and `frequency` go together")
        if not periodic and "offset" not in spec:
            raise ModelError(f"{where} has neither an `offset` nor an `amplitude`")
        got = {
            k: _coef(spec[k], params, f"{where} `{k}`")
            for k in ("offset", "amplitude", "frequency")
            if k in spec
        }
        harmonics = _harmonics(spec.get("harmonics"), params, where) if "harmonics" in spec else ()
        forces.append(
            Force(name, spec["on"], got.get("offset"), got.get("amplitude"), got.get("frequency"), harmonics)
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
            f"{{ amplitude = ..., multiple = N, phase = ... }}, got {_short(value)}"
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
                f"{at} `multiple` must be an integer from 1 to 1000 (of `frequency`), got {_short(n)}"
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
    touching: dict[str, list[Element]] = {p: [] for p in (*net.masses, *net.nodes, GROUND)}
    for e in net.elements:
        touching[e.a].append(e)
        touching[e.b].append(e)
    for x in net.masses:
        if not touching[x]:
            raise ModelError(
                f"[masses.{x}] has no connection: no spring, damper or friction element touches it"
            )
    friction = net.friction
    if len(friction) > MAX_FRICTION:
        raise ModelError(
            f"[friction]: {len(friction)} friction elements give 3**{len(friction)} modes; at most {MAX_FRICTION} elements are allowed"
        )
    _check_friction_loops(net)
    for u in net.nodes:
        springs = [e for e in touching[u] if e.kind in ("spring", "damper")]
        for e in touching[u]:
            if e.kind == "damper" and e.a in net.nodes and e.b in net.nodes:
                raise ModelError(
                    f"[dampers.{e.name}] joins two massless nodes (`{e.a}`, `{e.b}`): not supported (their "
                    "velocities would be undetermined); attach dampers to a mass or the ground"
                )
        if not touching[u]:
            raise ModelError(f"[nodes.{u}] has no connection: its position is undetermined")
        if not springs:
            fr = ", ".join(e.name for e in touching[u])
            raise ModelError(
                f"[nodes.{u}]: no spring or damper is attached, so its position is undetermined while its "
                f"friction element(s) {fr} slip"
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
                f"[nodes.{u}]: the massless nodes {names} are joined by springs only to each other, so their "
                "positions are undetermined while their friction elements slip; attach one to a mass or the ground"
            )


def _check_friction_loops(net: Network) -> None:
    """Friction elements must not form a loop (their forces would be undetermined while all stick)."""
    parent: dict[str, str] = {}

    def find(p: str) -> str:
        while parent.get(p, p) != p:
            p = parent[p]
        return p

    adjacency: dict[str, list[tuple[str, Element]]] = {}
    for e in net.friction:
        ra, rb = find(e.a), find(e.b)
        if ra == rb:
            path = _tree_path(adjacency, e.a, e.b)
            loop = [e.name] + [el.name for el in path]
            massless = all(p in net.nodes for el in [e, *path] for p in (el.a, el.b))
            what = "a loop of massless nodes joined only by friction" if massless else "a loop"
            raise ModelError(
                f"[friction.{e.name}]: friction elements {', '.join(loop)} form {what}: while they all stick "
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


# ----------------------------------------------------------------------------
# Derivation of the automaton
# ----------------------------------------------------------------------------
def _paren(text: str) -> str:
    """``text`` ready to be a factor: bare names and numbers as they are, else in parentheses."""
    if _is_name(text):
        return text
    try:
        float(text)
        return text if not text.startswith("-") else f"({text})"
    except ValueError:
        return f"({text})"


def _join(terms: list[str]) -> str:
    """A sum of signed terms ``["+a", "-b"]`` as text, ``"0"`` if empty."""
    if not terms:
        return "0"
    out = terms[0][1:] if terms[0].startswith("+") else terms[0]
    for t in terms[1:]:
        out += f" {t[0]} {t[1:]}"
    return out


def _times(coef: str, diff: str) -> str:
    """``coef*(diff)``, with the parentheses needed."""
    return f"{_paren(coef)}*{_paren(diff)}"


class _Mode:
    """The derivation for one combination of friction states."""

    def __init__(self, net: Network, states: tuple[str, ...]):
        self.net = net
        self.states = dict(zip((e.name for e in net.friction), states, strict=True))
        self.stuck = [e for e in net.friction if self.states[e.name] == "stick"]
        # clusters: union of the ends of the sticking elements
        self.cluster: dict[str, frozenset[str]] = {}
        points = [*net.masses, *net.nodes, GROUND]
        groups = {p: {p} for p in points}
        for e in self.stuck:
            ga, gb = groups[e.a], groups[e.b]
            if ga is not gb:
                ga |= gb
                for p in gb:
                    groups[p] = ga
        for p in points:
            self.cluster[p] = frozenset(groups[p])
        self._acc: dict[frozenset[str], str] = {}
        self.order = {p: k for k, p in enumerate(points)}
        self.touching: dict[str, list[Element]] = {p: [] for p in points}
        for e in net.elements:
            self.touching[e.a].append(e)
            self.touching[e.b].append(e)

    # positions, velocities, accelerations of points -------------------------
    def pos(self, p: str) -> str:
        if p == GROUND:
            return "y_base" if self.net.base else "0"
        return p

    def ground_vel(self) -> str:
        return "dy_base" if self.net.base else "0"

    def ground_acc(self) -> str:
        return "ddy_base" if self.net.base else "0"

    def rep(self, p: str) -> str | None:
        """The point whose velocity a cluster moves with: the ground, its first mass, or None (a free node)."""
        c = self.cluster[p]
        if GROUND in c:
            return GROUND
        for x in self.net.masses:
            if x in c:
                return x
        return None

    def vel(self, p: str) -> str:
        r = self.rep(p)
        if r == GROUND:
            return self.ground_vel()
        if r is not None:
            return self.net.masses[r][1]
        # a massless cluster (a free node, or nodes glued by sticking elements): the time derivative
        # of its force balance (a cluster with a node joined by a spring to another node has a velocity
        # variable instead, above)
        c = self.cluster[p]
        named = self.velocity_variable(c)
        if named is not None:
            return named
        springs = self.leaving_springs(c)
        others = [e.b if e.a in c else e.a for e in springs]
        if len(springs) == 1:
            return self.vel(others[0])
        num = _join([f"+{_times(e.coef, self.vel(q))}" for e, q in zip(springs, others, strict=True)])
        den = _join([f"+{e.coef}" for e in springs])
        return f"({num})/({den})"

    def velocity_variable(self, c: frozenset[str]) -> str | None:
        """The velocity variable of a cluster's first node that has one (None if none has)."""
        named = self.net.node_velocities
        for q in sorted(c, key=self.order.__getitem__):
            if q in named:
                return named[q]
        return None

    def damped(self, c: frozenset[str]) -> bool:
        """Does a damper join a member of the massless cluster ``c`` to a point outside it?"""
        return any(e.kind == "damper" and not (e.a in c and e.b in c) for q in c for e in self.touching[q])

    def leaving_springs(self, c: frozenset[str]) -> list[Element]:
        """The springs from a cluster's members to points outside it, in file order of the points."""
        return [
            e
            for q in sorted(c, key=self.order.__getitem__)
            for e in self.touching[q]
            if e.kind == "spring" and not (e.a in c and e.b in c)
        ]

    def diff(self, q: str, p: str, what: str) -> str:
        """``what(q) - what(p)`` as text (positions or velocities)."""
        if what == "vel_of":  # q is already a velocity (a variable's name)
            fq, fp = q, self.vel(p)
        else:
            f = self.pos if what == "pos" else self.vel
            fq, fp = f(q), f(p)
        if fp == "0":
            return fq
        if fq == "0":
            return f"-{_paren(fp)}"
        return f"{fq} - {_paren(fp)}"

    # forces ------------------------------------------------------------------
    def external(self, group: frozenset[str], skip: Element | None = None) -> list[str]:
        """Signed terms of the force on ``group`` from everything outside it (never the ground's)."""
        terms: list[str] = []
        for p in sorted(group - {GROUND}, key=self.order.__getitem__):
            for e in self.touching[p]:
                if e is skip:
                    continue
                q = e.b if e.a == p else e.a
                if q in group:
                    continue
                if e.kind == "spring":
                    terms.append(f"+{_times(e.coef, self.diff(q, p, 'pos'))}")
                elif e.kind == "damper":
                    terms.append(f"+{_times(e.coef, self.diff(q, p, 'vel'))}")
                else:
                    s = self.states[e.name]
                    if s == "stick":  # pragma: no cover - a sticking element joins one cluster
                        raise AssertionError(e)
                    sign = _SIGN[s] * (1 if p == e.a else -1)
                    terms.append(f"{'+' if sign > 0 else '-'}{_paren(e.coef)}")
            for f in self.net.forces:
                if f.on == p:
                    terms.append(f"+{f.name}")
        return terms

    def mass_of(self, group: frozenset[str]) -> list[str]:
        return [self.net.masses[x][0] for x in self.net.masses if x in group]

    def acceleration(self, p: str) -> str:
        """Acceleration of the cluster of ``p`` (which holds a mass or the ground)."""
        c = self.cluster[p]
        if GROUND in c:
            return self.ground_acc()
        if c not in self._acc:  # once per cluster: all its masses share it
            m = self.mass_of(c)
            num = _join(self.external(c))
            den = _paren(m[0]) if len(m) == 1 else "(" + " + ".join(m) + ")"
            self._acc[c] = f"({num})/{den}"
        return self._acc[c]

    def side(self, e: Element) -> frozenset[str]:
        """The part of ``e``'s cluster on the side of ``e.a`` when ``e`` is cut."""
        adj: dict[str, list[str]] = {}
        for s in self.stuck:
            if s is not e:
                adj.setdefault(s.a, []).append(s.b)
                adj.setdefault(s.b, []).append(s.a)
        seen = {e.a}
        stack = [e.a]
        while stack:
            p = stack.pop()
            for q in adj.get(p, []):
                if q not in seen:
                    seen.add(q)
                    stack.append(q)
        return frozenset(seen)

    def friction_force(self, e: Element) -> str:
        """The force ``e`` exerts on its end ``a`` [N]."""
        s = self.states[e.name]
        if s != "stick":
            return e.coef if s == "slip+" else f"-{_paren(e.coef)}"
        side_a = self.side(e)
        side_b = self.cluster[e.a] - side_a
        # the force on a is m_A*acc - ext(A), or, from the other side, ext(B) - m_B*acc; the
        # ground's forces are unknown, so never sum over the side that holds it
        if GROUND in side_a:
            use_a = False
        elif GROUND in side_b:
            use_a = True
        else:
            use_a = not self.mass_of(side_a) or bool(self.mass_of(side_b))
        group = side_a if use_a else side_b
        ext = _join(self.external(group, skip=e))
        m = self.mass_of(group)
        acc = self.acceleration(e.a) if m else "0"
        inertia = _times(" + ".join(m), acc) if acc != "0" else None
        if use_a:
            return f"{inertia} - ({ext})" if inertia else f"-({ext})"
        return f"{ext} - {inertia}" if inertia else ext

    def relative_velocity(self, e: Element) -> str:
        if self.states[e.name] == "stick":
            return "0"
        return self.diff(e.b, e.a, "vel")

    # the mode ----------------------------------------------------------------
    def derivatives(self) -> tuple[dict[str, str], dict[str, str]]:
        der: dict[str, str] = {}
        alg: dict[str, str] = {}
        for x, (_, v, _) in self.net.masses.items():
            r = self.rep(x)
            if r == GROUND:
                der[x] = self.ground_vel()
            der[v] = self.acceleration(x)
        for u in self.net.nodes:
            c = self.cluster[u]
            if self.rep(u) is not None or self.damped(c):
                der[u] = self.vel(u)
            elif u == min(c, key=self.order.__getitem__):
                # the first node of a massless cluster: a slave variable fixed by the cluster's balance
                alg[u] = f"-({_join(self.external(c))})"
            else:  # the others keep their offsets to it: they move with the cluster's velocity
                der[u] = self.vel(u)
        for u, vu in self.net.node_velocities.items():
            c = self.cluster[u]
            first = self.velocity_variable(c)
            if self.rep(u) is not None:
                alg[vu] = f"{vu} - {_paren(self.vel(u))}"
            elif vu != first:
                alg[vu] = f"{vu} - {first}"
            elif self.damped(c):  # the cluster's balance, which its dampers make depend on its velocity
                alg[vu] = f"-({_join(self.external(c))})"
            else:  # the time derivative of the cluster's balance
                terms = [
                    f"+{_times(e.coef, self.diff(vu, e.b if e.a in c else e.a, 'vel_of'))}"
                    for e in self.leaving_springs(c)
                ]
                alg[vu] = _join(terms)
        return der, alg


def _velocity_difference(net: Network, q: str, p: str) -> str:
    """``v_q - v_p`` in every mode alike (a damper's ends: masses, the ground, nodes with a velocity variable)."""

    def vel(r: str) -> str:
        if r == GROUND:
            return "dy_base" if net.base else "0"
        return net.masses[r][1] if r in net.masses else net.node_velocities[r]

    vq, vp = vel(q), vel(p)
    return vq if vp == "0" else (f"-{vp}" if vq == "0" else f"{vq} - {vp}")


def _mode_name(states: tuple[str, ...]) -> str:
    """``stick`` etc. for one element, states joined by ``_`` for several, ``free`` for none."""
    if not states:
        return "free"
    return states[0] if len(states) == 1 else "_".join(states)


def network_model(net: Network) -> dict:
    """The mode-level model data (as a mode-level TOML file would give it) of a network.

    Parameters
    ----------
    net : Network

    Returns
    -------
    dict
        Tables ``model``, ``variables``, ``parameters``, ``presets``,
        ``definitions``, ``equations``, ``modes``, ``transitions``, ``plot``,
        ``energy``, ``orbit``, ready for :func:`hybrid.system_from_dict`.
    """
    friction = net.friction
    if not friction:
        combos = [()]
    else:
        combos = list(itertools.product(_STATES, repeat=len(friction)))
    variables: dict[str, dict] = {}
    for x, (_, v, desc) in net.masses.items():
        variables[x] = {"unit": "m", "description": f"displacement of {desc or 'mass ' + x}"}
        variables[v] = {"unit": "m/s", "description": f"velocity of {desc or 'mass ' + x}"}
    for u, desc in net.nodes.items():
        variables[u] = {
            "unit": "m",
            "description": f"displacement of the massless node {u}" + (f" ({desc})" if desc else ""),
        }
    for u, vu in net.node_velocities.items():
        variables[vu] = {
            "unit": "m/s",
            "description": f"velocity of the massless node {u} (a slave variable)",
        }
    variables["W"] = {"unit": "J", "description": "work done by the excitations"}
    variables["D"] = {"unit": "J", "description": "energy dissipated by friction and dampers"}
    generated = {"W", "D", "E"} | {f"f_{e.name}" for e in friction} | {f"w_{e.name}" for e in friction}
    generated |= set(net.node_velocities.values())
    if net.base:
        generated |= {"y_base", "dy_base", "ddy_base"}
    taken = set(net.masses) | {v for _, v, _ in net.masses.values()} | set(net.nodes) | set(net.parameters)
    taken |= {e.name for e in net.elements} | {f.name for f in net.forces}
    clash = generated & taken
    if clash:
        raise ModelError(
            f"the name(s) {', '.join(sorted(clash))} are generated by the builder (W, D, E, f_NAME, w_NAME of "
            "friction elements, y_base, dy_base, ddy_base); rename the item(s) in the file"
        )

    definitions: dict[str, str] = {}
    for f in net.forces:
        terms = []
        if f.offset is not None:
            terms.append(f"+{f.offset}")
        for amp, n, phase in f.terms():
            arg = (
                (f"{n}*" if n != 1 else "")
                + f"{_paren(f.frequency)}*t"
                + (f" + {_paren(phase)}" if phase else "")
            )
            terms.append(f"+{_paren(amp)}*sin({arg})")
        definitions[f.name] = _join(terms)
    if net.base:
        y, om = (_paren(s) for s in net.base)
        definitions["y_base"] = f"{y}*sin({om}*t)"
        definitions["dy_base"] = f"{y}*{om}*cos({om}*t)"
        definitions["ddy_base"] = f"-{y}*{om}**2*sin({om}*t)"
    probe = _Mode(net, combos[0])
    energy_terms = [f"+0.5*{_paren(m)}*{v}**2" for m, v, _ in net.masses.values()]
    for e in net.elements:
        if e.kind == "spring":
            energy_terms.append(f"+0.5*{_paren(e.coef)}*({probe.diff(e.b, e.a, 'pos')})**2")
    definitions["E"] = _join(energy_terms)

    equations = {x: v for x, (_, v, _) in net.masses.items()}
    power = [f"+{f.name}*{net.masses[f.on][1]}" for f in net.forces]
    if net.base:
        # power the moving ground puts in: minus (force of the elements on the ground) x ground velocity
        for e in net.elements:
            if GROUND not in (e.a, e.b):
                continue
            q = e.b if e.a == GROUND else e.a
            if e.kind == "spring":
                power.append(f"-{_times(e.coef, probe.diff(q, GROUND, 'pos'))}*dy_base")
            elif e.kind == "damper":
                power.append(f"-{_times(e.coef, _velocity_difference(net, q, GROUND))}*dy_base")
            else:
                sign = "-" if e.a == GROUND else "+"
                power.append(f"{sign}f_{e.name}*dy_base")
    equations["W"] = _join(power)
    dissipation = [f"+f_{e.name}*w_{e.name}" for e in friction]
    for e in net.elements:
        if e.kind == "damper":
            dissipation.append(f"+{_paren(e.coef)}*({_velocity_difference(net, e.b, e.a)})**2")
    equations["D"] = _join(dissipation)

    modes: dict[str, dict] = {}
    transitions: list[dict] = []
    prefix = len(friction) > 1
    for states in combos:
        md = _Mode(net, states)
        der, alg = md.derivatives()
        defs = {}
        for e in friction:
            defs[f"f_{e.name}"] = md.friction_force(e)
            defs[f"w_{e.name}"] = md.relative_velocity(e)
        spec: dict[str, dict] = {}
        if der:
            spec["derivatives"] = der
        if alg:
            spec["algebraic"] = alg
        if defs:
            spec["definitions"] = defs
        modes[_mode_name(states)] = spec
        for k, e in enumerate(friction):
            s = states[k]
            tag = f"{e.name}:" if prefix else ""
            if s == "stick":
                level = _paren(e.static or e.coef)
                for new, sign, direction in (("slip+", "-", 1), ("slip-", "+", -1)):
                    target = states[:k] + (new,) + states[k + 1 :]
                    transitions.append(
                        {
                            "name": f"{tag}breakaway{new[-1]}",
                            "source": _mode_name(states),
                            "target": _mode_name(target),
                            "guard": f"f_{e.name} {sign} {level}",
                            "direction": direction,
                        }
                    )
            else:
                target = states[:k] + ("stick",) + states[k + 1 :]
                tr = {
                    "name": f"{tag}stop{s[-1]}",
                    "source": _mode_name(states),
                    "target": _mode_name(target),
                    "guard": f"w_{e.name}",
                    "direction": -_SIGN[s],
                }
                reset = _stop_reset(net, _Mode(net, target), e)
                if reset:
                    tr["reset"] = reset
                transitions.append(tr)

    all_stick = _mode_name(combos[0])
    outputs = [f"f_{e.name}" for e in friction] + [f"w_{e.name}" for e in friction] + ["E"]
    outputs += [f.name for f in net.forces] + (["y_base"] if net.base else [])
    units = {o: "N" for o in outputs if o.startswith("f_")} | {
        o: "m/s" for o in outputs if o.startswith("w_")
    }
    units |= {"E": "J"} | {f.name: "N" for f in net.forces}
    if net.base:
        units["y_base"] = "m"
    plot: dict = {"displacements": list(net.masses), "units": units}
    if friction:
        # the figure draws the first element: shade where it sticks
        first_sticks = [_mode_name(c) for c in combos if c[0] == "stick"]
        plot |= {
            "force": f"f_{friction[0].name}",
            "velocity": f"w_{friction[0].name}",
            "shade_modes": first_sticks,
        }
    if friction:
        # the linear references drawn over a frequency response: every contact stuck, every one sliding
        plot["linear_references"] = {
            "linear: all contacts stuck": all_stick,
            "linear: all contacts sliding": _mode_name(("slip+",) * len(friction)),
        }
    if net.plot is not None:
        plot = {**({"linear_references": plot["linear_references"]} if friction else {}), **net.plot}
    orbit: dict = {}
    if friction:
        e = friction[0]
        # the stuck offset of the first element (the ground counted at 0) selects a member of a
        # neutral family of periodic orbits (as the hand-written files' gauges do)
        a_pos, b_pos = (p if p != GROUND else "0" for p in (e.a, e.b))
        orbit = {"gauge": b_pos if a_pos == "0" else (f"-{a_pos}" if b_pos == "0" else f"{b_pos} - {a_pos}")}
    if net.orbit is not None:
        orbit = dict(net.orbit)
    freqs = {f.frequency for f in net.forces if f.frequency is not None} | (
        {net.base[1]} if net.base else set()
    )
    model = {
        "name": net.name,
        "title": net.title,
        "reference": net.reference,
        "initial_mode": all_stick,
        "quadratures": ["W", "D"],
        "outputs": outputs,
    }
    if len(freqs) == 1:
        model["period"] = f"2*pi/{_paren(next(iter(freqs)))}"
    return {
        "model": model,
        "variables": variables,
        "parameters": net.parameters,
        "presets": net.presets,
        "definitions": definitions,
        "equations": equations,
        "modes": modes,
        "transitions": transitions,
        "plot": plot,
        "energy": {"input": "W", "dissipated": "D", "mechanical": "E"},
        "orbit": orbit,
    }


def _stop_reset(net: Network, target: _Mode, e: Element) -> dict[str, str]:
    """Velocities of the masses glued by a stop: the ground's, or the momentum-weighted mean."""
    c = target.cluster[e.a]
    ms = [x for x in net.masses if x in c]
    if GROUND in c:
        return {net.masses[x][1]: target.ground_vel() for x in ms}
    if len(ms) < 2:
        return {}
    num = " + ".join(f"{_paren(net.masses[x][0])}*{net.masses[x][1]}" for x in ms)
    den = " + ".join(net.masses[x][0] for x in ms)
    return {net.masses[x][1]: f"({num})/({den})" for x in ms}


def describe_network(net: Network) -> str:
    """The network as text: its points, then one line per element and excitation."""
    lines = [f"network `{net.name}`" + (f": {net.title}" if net.title else "")]
    for x, (m, v, desc) in net.masses.items():
        lines.append(f"  mass   {x:<10} m = {m}, velocity {v}" + (f"  ({desc})" if desc else ""))
    for u, desc in net.nodes.items():
        lines.append(f"  node   {u:<10} massless" + (f"  ({desc})" if desc else ""))
    ground = "ground (moving: y = " + f"{net.base[0]}*sin({net.base[1]}*t))" if net.base else "ground"
    lines.append(f"  {ground}")
    symbols = {"spring": "/\\/\\", "damper": "[==]", "friction": "]||["}
    for e in net.elements:
        what = {"spring": f"k = {e.coef}", "damper": f"c = {e.coef}", "friction": f"R = {e.coef}"}[e.kind]
        if e.static:
            what += f", R_s = {e.static}"
        lines.append(f"  {e.a:>10} --{symbols[e.kind]}-- {e.b:<10} {e.kind} {e.name}: {what}")
    for f in net.forces:
        lines.append(f"  force  {f.name} = {f.text()} on {f.on}")
    return "\n".join(lines)


def build(data: Mapping) -> dict:
    """The mode-level model data of a parsed network file (the ``network`` model format).

    Parameters
    ----------
    data : mapping
        The file as :func:`tomllib.loads` returns it.

    Returns
    -------
    dict
        What a mode-level file of the same model would hold; see :func:`network_model`.

    Raises
    ------
    ModelError
        See :func:`read_network`.
    """
    return network_model(read_network(data))


def describe(data: Mapping) -> str:
    """The network of a parsed network file as text (the ``network`` model format's description)."""
    return describe_network(read_network(data))


def _layout(net: Network) -> dict[str, int]:
    """Columns of the points: the ground first, the masses in breadth-first order along the elements,
    each massless node between the points it joins (at the mean of their columns), so that a node
    hanging between two masses is drawn between them."""
    adj: dict[str, list[str]] = {}
    for e in net.elements:
        adj.setdefault(e.a, []).append(e.b)
        adj.setdefault(e.b, []).append(e.a)
    order = [GROUND]
    queue = [GROUND]
    while queue:
        p = queue.pop(0)
        for q in adj.get(p, []):
            if q not in order:
                order.append(q)
                queue.append(q)
    order += [p for p in (*net.masses, *net.nodes) if p not in order]
    masses = [p for p in order if p not in net.nodes]
    pos = {p: float(k) for k, p in enumerate(masses)}
    nodes = [p for p in order if p in net.nodes]
    for u in nodes:
        pos[u] = float(len(masses))
    for _ in range(50):  # each node at the mean of its neighbours (the masses stay)
        for u in nodes:
            nb = [pos[q] for q in adj.get(u, []) if q in pos]
            if nb:
                pos[u] = sum(nb) / len(nb)
    ranked = sorted(order, key=lambda p: (pos[p], p in net.nodes, order.index(p)))
    return {p: k for k, p in enumerate(ranked)}


def draw_network(net: Network, path) -> None:
    """Draw the network as a PNG: points as columns (ground hatched, masses as boxes, nodes as dots),
    one row per element (springs as zigzags, dampers as pistons, friction as blocks), forces as arrows.

    Parameters
    ----------
    net : Network
    path : str or Path
        The PNG to write.
    """
    import numpy as np
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure
    from matplotlib.patches import Rectangle

    col = _layout(net)
    rows = len(net.elements) + len(net.forces)
    width = max(6.5, 2.0 + 1.8 * len(col))
    fig = Figure(figsize=(width, 1.4 + 0.55 * rows))
    FigureCanvasAgg(fig)
    ax = fig.add_subplot()
    top = rows + 0.5
    for p, x in col.items():
        if p == GROUND:
            ax.add_patch(Rectangle((x - 0.08, -0.5), 0.08, top + 0.5, hatch="///", fill=False, lw=1))
            label = "base y(t)" if net.base else "ground"
        elif p in net.masses:
            ax.add_patch(Rectangle((x - 0.15, -0.5), 0.3, top + 0.5, color="0.85", ec="k", lw=1, zorder=2))
            label = f"{p}\n({net.masses[p][0]})"
        else:
            ax.plot([x, x], [-0.5, top], color="k", lw=1, ls=":")
            label = p
        ax.text(x, top + 0.25, label, ha="center", va="bottom", fontsize=9)

    def edge(p: str) -> float:
        return 0.15 if p in net.masses else 0.0

    for row, e in enumerate(net.elements):
        (xa, pa), (xb, pb) = sorted(((col[e.a], e.a), (col[e.b], e.b)))
        y = row
        if pa == GROUND and xb - xa > 1:
            # to the ground across other points: a ground of its own beside the point, not a line
            # drawn through the masses in between
            xa = xb - 1
            ax.add_patch(Rectangle((xa - 0.08, y - 0.3), 0.08, 0.6, hatch="///", fill=False, lw=1, zorder=3))
        lo, hi = xa + edge(pa), xb - edge(pb)
        if any(xa < col[q] < xb for q in net.masses):
            # across a mass (between two other points): the symbol in the first gap, the line
            # passing behind the masses (their boxes are drawn over it)
            hi_sym = min(col[q] for q in col if xa < col[q] < xb) - edge(pb)
            ax.plot([hi_sym, hi], [y, y], color="0.5", lw=1, ls="--", zorder=1)
            hi = hi_sym
        mid = 0.5 * (lo + hi)
        w = min(0.5, 0.4 * (hi - lo))
        if e.kind == "spring":
            zx = np.linspace(mid - w / 2, mid + w / 2, 9)
            zy = y + 0.15 * np.array([0, 1, -1, 1, -1, 1, -1, 1, 0])
            ax.plot([lo, mid - w / 2], [y, y], "k", lw=1)
            ax.plot(zx, zy, "k", lw=1)
            ax.plot([mid + w / 2, hi], [y, y], "k", lw=1)
        elif e.kind == "damper":
            ax.plot([lo, mid], [y, y], "k", lw=1)
            ax.plot(
                [mid - w / 3, mid + w / 3, mid + w / 3, mid - w / 3],
                [y - 0.15, y - 0.15, y + 0.15, y + 0.15],
                "k",
                lw=1,
            )
            ax.plot([mid, mid], [y - 0.12, y + 0.12], "k", lw=2)
            ax.plot([mid, hi], [y, y], "k", lw=1)
        else:
            ax.plot([lo, mid], [y, y], "k", lw=1)
            ax.add_patch(Rectangle((mid - w / 4, y - 0.18), w / 2, 0.36, color="tab:red", alpha=0.6))
            ax.plot([mid + w / 4, hi], [y, y], "k", lw=1)
        level = e.coef + (f", {e.static}" if e.static else "")
        ax.text(mid, y + 0.22, f"{e.name}: {level}", ha="center", va="bottom", fontsize=8)
    for k, f in enumerate(net.forces):
        y = len(net.elements) + k
        x = col[f.on]
        arrow = {"arrowstyle": "->", "color": "tab:blue"}
        ax.annotate("", xy=(x + 0.6, y), xytext=(x + edge(f.on), y), arrowprops=arrow)
        parts = [f.text(" ")]
        ax.text(
            x + 0.2, y + 0.15, f"{f.name} = {' + '.join(parts)}", va="bottom", fontsize=8, color="tab:blue"
        )
    ax.set_xlim(-0.6, len(col) - 0.2)
    ax.set_ylim(-0.8, top + 0.9)
    ax.set_axis_off()
    title = f"network `{net.name}`" + (f": {net.title}" if net.title else "")
    ax.set_title(textwrap.fill(title, int(11 * width)), fontsize=10)
    fig.tight_layout()
    fig.savefig(path, dpi=110)


def draw(data: Mapping, path) -> None:
    """Draw the network of a parsed network file as a PNG (the ``network`` format's figure)."""
    draw_network(read_network(data), path)
