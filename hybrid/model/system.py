"""Declarative hybrid systems: variables, parameters, modes, guards, transitions.

A :class:`HybridSystem` is pure data. Every equation, guard, reset and
definition is an expression string over the system's named variables,
parameters, definitions and the time ``t``; all of them are parsed and checked
once, when the system is constructed, so that a malformed model fails before
any integration starts with a message naming the item at fault.

Semantics
---------
* Each mode gives, for every variable, either a time derivative
  (``derivatives``: the variable is differential in that mode) or an algebraic
  residual (``algebraic``: the variable is a slave variable fixed by
  ``0 = residual``). A variable may be differential in one mode and algebraic
  in another. ``HybridSystem.equations`` holds derivatives shared by all modes.
* A transition leaves ``source`` for ``target`` when its guard crosses zero in
  its ``direction``: +1 rising, -1 falling, 0 either way. A guard with
  direction +1 (-1) also bounds its source mode: the mode lives where the guard
  is negative (positive), and entering the mode where the guard already lies
  beyond zero on its firing side takes that transition at once.
* ``reset`` maps variables to expressions evaluated with the values just before
  the switch; variables not named are continuous.
* ``quadratures`` are differential variables that only accumulate integrals
  (work, dissipated energy); no equation or guard may depend on them.
"""

from __future__ import annotations

import itertools
import math
import threading
from collections.abc import Mapping
from dataclasses import dataclass, field
from types import MappingProxyType

from ..core.budget import check_deadline
from ..core.cache import DerivedCache, LRUCache
from ..core.errors import ExpressionError, InputError, InputTypeError, ModelError
from .codegen import compile_scalar
from .elements import (
    _MODE_NAME,
    _MODEL_NAME,
    _NAME,
    MAX_TEXT,
    Component,
    Mode,
    Transition,
    _as_parameters,
    _as_variables,
    _frozen_map,
    _shown,
)
from .expr import (
    Expr,
    count_nodes,
    free_symbols,
    parse,
    sign_arguments,
    substitute,
    to_string,
)
from .orbit_hints import validate_hints

__all__ = ["HybridSystem"]


#: Size limits of a model (a model file is untrusted input: every limit has a clear error).
MAX_VARIABLES = 20_000
MAX_PARAMETERS = 20_000
MAX_MODES = 1000
MAX_TRANSITIONS = 10_000
#: Components (e.g. contacts) of a system, and local modes and transitions of all of them together.
MAX_COMPONENTS = 10_000
MAX_LOCAL_MODES = 100_000
MAX_LOCAL_TRANSITIONS = 200_000
MAX_DEFINITIONS = 10_000
MAX_NODES = 2_000_000  # distinct operation nodes of all expressions of the model, definitions expanded
_RESERVED = {"t", "pi"}
#: Joins the parts of a mode's name: its own mode, then each component's local mode.
MODE_SEPARATOR = "|"
_PLOT_KEYS = {"force", "velocity", "displacements", "shade_modes", "units", "linear_references"}
_DOMAINS = ("real", "positive", "nonnegative")


#: Systems :func:`shared` keeps at once (the most recently shared; an older one is dropped).
MAX_SHARED_SYSTEMS = 32

#: The systems that pickle by reference (see :func:`shared`): ``id(system) -> (serial, system)``,
#: bounded. The serial tells a system from a later one at the same address after the first was
#: dropped and freed: a reference to the first then fails instead of naming the second.
_SHARED = LRUCache(MAX_SHARED_SYSTEMS)
_SERIALS = itertools.count(1)
_SHARING = threading.Lock()  # a system shared by two threads at once gets one serial


def shared(system: HybridSystem) -> None:
    """Let ``system`` be pickled by reference: a process forked after this call (e.g. a worker of
    :func:`hybrid.frequency_response`) sends results that refer to it, and they unpickle here as
    the same object. (A system holds compiled code and is not pickled by value.)

    The :data:`MAX_SHARED_SYSTEMS` most recently shared systems are kept (sharing one again makes
    it the most recent); a reference to a system dropped since fails to unpickle, naming the limit.
    """
    with _SHARING:
        hit = _SHARED.get(id(system))  # (a system kept is alive: no other object has its id)
        if hit is None:
            _SHARED.put(id(system), (next(_SERIALS), system))


def _shared_system(key: int, serial: int) -> HybridSystem:
    hit = _SHARED.get(key)
    if hit is None or hit[0] != serial:
        raise InputTypeError(
            "a HybridSystem is unpickled only in the process it was shared from, while it is among the "
            f"{MAX_SHARED_SYSTEMS} systems shared last there (hybrid.model.system.shared)"
        )
    return hit[1]


@dataclass(frozen=True)
class ParsedSystem:
    """A :class:`HybridSystem`'s expressions, parsed, checked and expanded once at construction.

    Attributes
    ----------
    defs : mapping of str to Expr
        The system's definitions, expanded over each other.
    modes : mapping of str to dict
        Per mode name: ``derivatives`` and ``algebraic`` (variable -> Expr, definitions
        expanded), ``defs`` (the mode's definitions merged over the system's), ``expand`` (a
        callable substituting them into an expression).
    transitions : list of dict
        Per transition, in ``HybridSystem.transitions`` order: ``guard`` (Expr) and ``reset``
        (variable -> Expr).
    period : Expr or None
        The forcing period's expression in the parameters.
    gauge : tuple of Expr or None
        The ``[orbit] gauge`` expressions of a family of orbits (one for a string).
    autonomous : dict
        The ``[orbit]`` hints of autonomous orbits (:mod:`hybrid.model.orbit_hints`).
    components : tuple of dict
        Per component, in ``HybridSystem.components`` order: ``modes`` (per local mode name, as
        ``modes`` above, with its ``halt`` text), ``transitions`` (as ``transitions`` above, in the
        component's order) and ``owned`` (the variables it owns, in state order).
    """

    defs: Mapping
    modes: Mapping
    transitions: list
    period: object
    gauge: object
    autonomous: Mapping
    components: tuple = ()


@dataclass(frozen=True)
class HybridSystem:
    """A hybrid automaton given as data.

    Attributes
    ----------
    name : str
        Model name.
    variables : tuple of Variable
        State variables, in the order of state vectors ``y``.
    parameters : tuple of Parameter
        Parameters (their values are passed to :func:`hybrid.simulate`).
    modes : tuple of Mode
        Discrete states.
    transitions : tuple of Transition
        Guarded switches.
    equations : mapping of str to str
        Derivatives shared by every mode (a mode's own entries take precedence).
    definitions : mapping of str to str
        Named expressions usable everywhere (e.g. a friction force ``H``).
    quadratures : tuple of str
        Variables that only integrate outputs (e.g. work, dissipated energy).
    outputs : tuple of str
        Definitions recorded along trajectories.
    period : str or None
        Expression of the forcing period, if the system is periodically forced
        (bounds the step size; sets samples per period).
    initial_mode : str or None
        Default initial mode.
    presets : mapping of str to mapping of str to float
        Named parameter sets.
    title, reference : str
        Documentation.
    plot : mapping
        Hints for the CLI's figure (e.g. ``force``, ``velocity``,
        ``displacements``, ``shade_modes``).
    energy : mapping of str to str
        Names (variables or definitions) of the ``input`` work, the
        ``dissipated`` energy and the ``mechanical`` energy, for energy
        balances (``input = dissipated + change of mechanical``).
    orbit : mapping
        Hints for periodic orbits: ``gauge``, an expression of the state
        (no ``t``) that selects one member of a family of periodic orbits
        (a neutral multiplier 1, e.g. the free offset of a stuck friction
        element): the member with ``gauge = 0`` at the section is returned. A list of
        expressions serves families of several dimensions (e.g. one offset per element that may
        stay stuck): for a family of ``q`` neutral directions, the ``q`` of them that fix those
        directions best are set to 0 (chosen by a pivoted QR factorisation of their gradients
        projected on the directions).
    components : tuple of Component
        Parts with local modes of their own (e.g. one per friction contact), composed with the
        system's own ``modes`` on demand: the system's mode is the tuple of its own mode and one
        local mode per component (named ``own|local1|local2|...``; with no component, the own
        mode's name). See :class:`hybrid.Component`.

    Notes
    -----
    Frozen: no field changes after construction, and what the engine derives from the system is
    kept in its explicit :attr:`cache`. Two systems are equal when their fields are (two loads of
    one file are equal); a system is hashable (its hash is that of its name and the names of its
    variables, parameters and modes, so equal systems hash alike), so it can key a dict.

    Examples
    --------
    >>> from hybrid import HybridSystem, Mode
    >>> osc = HybridSystem(
    ...     name="oscillator", variables=["x", "v"], parameters=["k"],
    ...     modes=[Mode("free", derivatives={"x": "v", "v": "-k*x"})], transitions=[],
    ... )
    >>> osc.variable_names, osc.mode_names
    (('x', 'v'), ('free',))
    >>> HybridSystem(name="bad", variables=["x"], parameters=[],
    ...              modes=[Mode("a", derivatives={"x": "y"})], transitions=[])
    Traceback (most recent call last):
    ...
    hybrid.core.errors.ModelError: model `bad`: mode `a`: derivative of `x`: unknown name `y` in 'y'; known names: t, x, pi
    """

    name: str
    variables: tuple
    parameters: tuple
    modes: tuple
    transitions: tuple
    equations: Mapping[str, str] = field(default_factory=dict)
    definitions: Mapping[str, str] = field(default_factory=dict)
    quadratures: tuple = ()
    outputs: tuple = ()
    period: str | None = None
    initial_mode: str | None = None
    presets: Mapping[str, Mapping[str, float]] = field(default_factory=dict)
    title: str = ""
    reference: str = ""
    plot: Mapping[str, object] = field(default_factory=dict)
    energy: Mapping[str, str] = field(default_factory=dict)
    orbit: Mapping[str, object] = field(default_factory=dict)
    components: tuple = ()

    # ------------------------------------------------------------------
    def __post_init__(self):
        set_ = object.__setattr__
        set_(self, "variables", _as_variables(self.variables))
        set_(self, "parameters", _as_parameters(self.parameters))
        set_(self, "modes", tuple(self.modes))
        set_(self, "transitions", tuple(self.transitions))
        set_(self, "quadratures", tuple(self.quadratures))
        set_(self, "outputs", tuple(self.outputs))
        set_(self, "equations", _frozen_map(self.equations, "equations"))
        set_(self, "definitions", _frozen_map(self.definitions, "definitions"))
        set_(self, "plot", MappingProxyType(dict(self.plot)))
        set_(self, "energy", _frozen_map(self.energy, "energy"))
        set_(self, "orbit", MappingProxyType(dict(self.orbit)))
        set_(self, "components", tuple(self.components))
        set_(
            self,
            "presets",
            MappingProxyType({k: MappingProxyType(dict(v)) for k, v in dict(self.presets).items()}),
        )
        set_(self, "_building", {})
        try:
            self._validate()
        except ExpressionError as exc:
            msg = str(exc)
            prefix = f"model `{self.name}`: "
            raise ModelError(msg if msg.startswith(prefix) else prefix + msg) from None
        set_(self, "_parsed", ParsedSystem(**self._building))
        set_(self, "_building", None)
        set_(self, "_derived", DerivedCache())

    def _validate_sizes_and_texts(self) -> None:
        """Names that reach files, counts, and texts: checked before any expression is parsed."""
        if not isinstance(self.name, str) or not _MODEL_NAME.fullmatch(self.name):
            raise ModelError(
                f"model name {self.name!r} is not allowed: 1 to 64 letters, digits, _ or -, starting "
                "with a letter or _ (it names the output folder)"
            )
        pre = f"model `{self.name}`"
        for what, items, limit in (
            ("variables", self.variables, MAX_VARIABLES),
            ("parameters", self.parameters, MAX_PARAMETERS),
            ("modes", self.modes, MAX_MODES),
            ("transitions", self.transitions, MAX_TRANSITIONS),
        ):
            if len(items) > limit:
                raise ModelError(f"{pre}: {len(items)} {what}; at most {limit} are allowed")
        if len(self.components) > MAX_COMPONENTS:
            raise ModelError(
                f"{pre}: {len(self.components)} components; at most {MAX_COMPONENTS} are allowed"
            )
        for c in self.components:
            if not isinstance(c, Component):
                raise ModelError(f"{pre}: components must be Component objects, got {type(c).__name__}")
        n_local = sum(len(c.modes) for c in self.components)
        if n_local > MAX_LOCAL_MODES:
            raise ModelError(
                f"{pre}: {n_local} local modes in its components; at most {MAX_LOCAL_MODES} are allowed"
            )
        n_local = sum(len(c.transitions) for c in self.components)
        if n_local > MAX_LOCAL_TRANSITIONS:
            raise ModelError(
                f"{pre}: {n_local} transitions in its components; at most {MAX_LOCAL_TRANSITIONS} are allowed"
            )
        local_modes = [m for c in self.components for m in c.modes if isinstance(m, Mode)]
        n_defs = len(self.definitions) + sum(
            len(m.definitions) for m in [*self.modes, *local_modes] if isinstance(m, Mode)
        )
        if n_defs > MAX_DEFINITIONS:
            raise ModelError(f"{pre}: {n_defs} definitions; at most {MAX_DEFINITIONS} are allowed")
        texts = [("title", self.title), ("reference", self.reference)]
        for v in self.variables:
            texts += [(f"unit of variable `{v.name}`", v.unit), (f"description of `{v.name}`", v.description)]
        for p in self.parameters:
            texts += [
                (f"unit of parameter `{p.name}`", p.unit),
                (f"description of `{p.name}`", p.description),
            ]
        for tr in [*self.transitions, *(tr for c in self.components for tr in c.transitions)]:
            if isinstance(tr, Transition):
                texts.append((f"name of transition {tr.source}->{tr.target}", tr.name))
        for c in self.components:
            texts.append((f"description of component `{c.name}`", c.description))
        for what, text in texts:
            if not isinstance(text, str):
                raise ModelError(f"{pre}: {what} must be a string, got {text!r}")
            if len(text) > MAX_TEXT or not text.isprintable():
                raise ModelError(
                    f"{pre}: {what} {text[:40]!r} must be printable text (no newlines or control "
                    f"characters) of at most {MAX_TEXT} characters"
                )
        for pname in self.presets:
            if not isinstance(pname, str) or not _MODEL_NAME.fullmatch(pname):
                raise ModelError(
                    f"{pre}: preset name {pname!r} is not allowed: 1 to 64 letters, digits, _ or -"
                )

    def _validate(self) -> None:
        self._validate_sizes_and_texts()
        pre = f"model `{self.name}`"
        vnames = [v.name for v in self.variables]
        pnames = [p.name for p in self.parameters]
        if not vnames:
            raise ModelError(f"{pre}: no variables")
        if not self.modes:
            raise ModelError(f"{pre}: no modes")
        for kind, items in (("variable", self.variables), ("parameter", self.parameters)):
            for it in items:
                if not isinstance(it.name, str):
                    raise ModelError(f"{pre}: {kind} name {it.name!r} is not a string")
        for kind, names in (("variable", vnames), ("parameter", pnames)):
            for n in names:
                if not _NAME.fullmatch(n) or n in _RESERVED:
                    raise ModelError(
                        f"{pre}: invalid {kind} name {_shown(n)} (1 to 64 letters, digits, _; not t or pi)"
                    )
        for p in self.parameters:
            if p.domain not in _DOMAINS:
                raise ModelError(f"{pre}: parameter `{p.name}` has domain {p.domain!r}; allowed: {_DOMAINS}")
        seen: dict[str, str] = {}
        for kind, names in (
            ("variable", vnames),
            ("parameter", pnames),
            ("definition", list(self.definitions)),
        ):
            for n in names:
                if n in seen:
                    raise ModelError(f"{pre}: name `{n}` is both a {seen[n]} and a {kind}")
                seen[n] = kind
        for n in self.definitions:
            if not _NAME.fullmatch(n) or n in _RESERVED:
                raise ModelError(f"{pre}: invalid definition name {_shown(n)} (1 to 64 letters, digits, _)")
        for m in self.modes:
            if not isinstance(m, Mode):
                raise ModelError(f"{pre}: modes must be Mode objects, got {m!r}")
        mnames = [m.name for m in self.modes]
        for m in self.modes:
            if not isinstance(m.name, str) or not _MODE_NAME.fullmatch(m.name):
                raise ModelError(f"{pre}: invalid mode name {m.name!r}")
        if len(set(mnames)) != len(mnames):
            raise ModelError(f"{pre}: duplicate mode names in {mnames}")
        for n in self.equations:
            if n not in vnames:
                raise ModelError(
                    f"{pre}: shared equation given for unknown variable `{n}`; variables: {', '.join(vnames)}"
                )
        for q in self.quadratures:
            if q not in vnames:
                raise ModelError(f"{pre}: quadrature `{q}` is not a variable")
        if self.initial_mode is not None and self.initial_mode not in mnames:
            raise ModelError(
                f"{pre}: initial mode `{self.initial_mode}` does not exist; modes: {', '.join(mnames)}"
            )

        base_known = set(vnames) | set(pnames) | {"t"}
        parsed_defs = self._parse_definitions(self.definitions, base_known, {}, "definition")
        self._set_cache("defs", parsed_defs)

        owned = self._validate_components(pre, vnames)

        mode_data: dict[str, dict] = {}
        for m in self.modes:
            where = f"mode `{m.name}`"
            for n in list(m.derivatives) + list(m.algebraic):
                if n not in vnames:
                    raise ModelError(
                        f"{pre}: {where} gives an equation for unknown variable `{n}`; variables: {', '.join(vnames)}"
                    )
            for n in m.definitions:
                if n in vnames or n in pnames or not _NAME.fullmatch(n) or n in _RESERVED:
                    raise ModelError(f"{pre}: {where}: invalid definition name {_shown(n)}")
            derivs = {**self.equations, **m.derivatives}
            for n in m.algebraic:  # a slave variable of this mode drops its shared derivative
                derivs.pop(n, None)
            both = set(m.derivatives) & set(m.algebraic)
            if both:
                raise ModelError(
                    f"{pre}: {where}: `{sorted(both)[0]}` has both a derivative and an algebraic equation"
                )
            taken = (set(m.derivatives) | set(m.algebraic)) & owned.keys()
            if taken:
                n = sorted(taken)[0]
                raise ModelError(
                    f"{pre}: {where} gives an equation for `{n}`, which component `{owned[n]}` owns "
                    "(its local modes give its equations)"
                )
            missing = [n for n in vnames if n not in derivs and n not in m.algebraic and n not in owned]
            if missing:
                raise ModelError(f"{pre}: {where} has no equation for variable(s) {', '.join(missing)}")
            for q in self.quadratures:
                if q in m.algebraic:
                    raise ModelError(f"{pre}: {where}: quadrature `{q}` cannot be algebraic")
            known = base_known | set(self.definitions) | set(m.definitions)
            mdefs = dict(parsed_defs)
            mdefs.update(self._parse_definitions(m.definitions, known, parsed_defs, f"{where} definition"))
            expand = _Expander(mdefs)
            deriv_e = {
                n: expand(parse(derivs[n], known, f"{pre}: {where}: derivative of `{n}`"))
                for n in vnames
                if n in derivs
            }
            alg_e = {
                n: expand(parse(r, known, f"{pre}: {where}: algebraic equation of `{n}`"))
                for n, r in m.algebraic.items()
            }
            for n, e in alg_e.items():
                if not (free_symbols(e) & (set(m.algebraic) | owned.keys())):
                    raise ModelError(
                        f"{pre}: {where}: algebraic equation of `{n}` does not involve any slave variable of the mode"
                    )
            mode_data[m.name] = {"derivatives": deriv_e, "algebraic": alg_e, "defs": mdefs, "expand": expand}

        trans = []
        names_by_source: dict[str, set[str]] = {}
        for tr in self.transitions:
            if not isinstance(tr, Transition):
                raise ModelError(f"{pre}: transitions must be Transition objects, got {tr!r}")
            for end in ("source", "target"):
                if getattr(tr, end) not in mnames:
                    raise ModelError(
                        f"{pre}: transition `{tr.name}` has {end} mode `{getattr(tr, end)}` that does not exist; modes: {', '.join(mnames)}"
                    )
            used = names_by_source.setdefault(tr.source, set())
            if tr.name in used:
                raise ModelError(f"{pre}: duplicate transition name `{tr.name}` from mode `{tr.source}`")
            used.add(tr.name)
            md = mode_data[tr.source]
            known = base_known | set(md["defs"])
            g = md["expand"](parse(tr.guard, known, f"{pre}: guard of transition `{tr.name}`"))
            # A guard built by a front end (an Expr, not text) may be constant: it is then a test
            # at entry to its mode (e.g. a Filippov sliding mode's orientation), never a crossing.
            if isinstance(tr.guard, str) and not (free_symbols(g) - set(pnames)):
                raise ModelError(
                    f"{pre}: guard of transition `{tr.name}` ({tr.guard!r}) depends on no variable and not on t: "
                    "it can never cross zero"
                )
            resets = {}
            for n, r in tr.reset.items():
                if n not in vnames:
                    raise ModelError(f"{pre}: transition `{tr.name}` resets unknown variable `{n}`")
                resets[n] = md["expand"](parse(r, known, f"{pre}: reset of `{n}` in transition `{tr.name}`"))
            trans.append({"guard": g, "reset": resets})
        comp_data = self._parse_components(pre, base_known, parsed_defs, vnames, pnames)
        roots = [td["guard"] for td in trans] + [e for td in trans for e in td["reset"].values()]
        for cd in comp_data:
            for td in cd["transitions"]:
                roots += [td["guard"], *td["reset"].values()]
            for md in cd["modes"].values():
                roots += list(md["derivatives"].values()) + list(md["algebraic"].values())
        for md in mode_data.values():
            roots += list(md["derivatives"].values()) + list(md["algebraic"].values())
            roots += [md["defs"][o] for o in self.outputs if o in md["defs"]]
        n_nodes = count_nodes(roots)
        if n_nodes > MAX_NODES:
            raise ModelError(
                f"{pre}: its expressions, definitions expanded, have {n_nodes} distinct operations; "
                f"at most {MAX_NODES} are allowed"
            )
        # Quadratures must not feed back into the dynamics or the guards.
        qs = set(self.quadratures)
        if qs:
            for mname, md in mode_data.items():
                for n, e in list(md["derivatives"].items()) + list(md["algebraic"].items()):
                    if n not in qs and free_symbols(e) & qs:
                        raise ModelError(
                            f"{pre}: mode `{mname}`: equation of `{n}` depends on a quadrature ({', '.join(sorted(free_symbols(e) & qs))})"
                        )
            for tr, td in zip(self.transitions, trans, strict=True):
                if free_symbols(td["guard"]) & qs:
                    raise ModelError(f"{pre}: guard of transition `{tr.name}` depends on a quadrature")
            for c, cd in zip(self.components, comp_data, strict=True):
                for lname, md in cd["modes"].items():
                    for n, e in list(md["derivatives"].items()) + list(md["algebraic"].items()):
                        if free_symbols(e) & qs:
                            raise ModelError(
                                f"{pre}: component `{c.name}`, mode `{lname}`: equation of `{n}` depends on a quadrature"
                            )
                for tr, td in zip(c.transitions, cd["transitions"], strict=True):
                    if free_symbols(td["guard"]) & qs:
                        raise ModelError(
                            f"{pre}: component `{c.name}`: guard of transition `{tr.name}` depends on a quadrature"
                        )
        for role, n in self.energy.items():
            if not isinstance(n, str):
                raise ModelError(f"{pre}: energy `{role}` must be a name, got {n!r}")
            if role not in ("input", "dissipated", "mechanical"):
                raise ModelError(
                    f"{pre}: energy role `{role}` unknown; allowed: input, dissipated, mechanical"
                )
            if n not in vnames and n not in self.outputs:
                raise ModelError(f"{pre}: energy `{role}` = `{n}` is neither a variable nor an output")
        unknown = set(self.plot) - _PLOT_KEYS
        if unknown:
            raise ModelError(
                f"{pre}: [plot] has unknown key(s) {', '.join(sorted(map(str, unknown)))}; "
                f"allowed: {', '.join(sorted(_PLOT_KEYS))}"
            )
        units = self.plot.get("units", {})
        if not isinstance(units, Mapping) or not all(
            isinstance(k, str) and isinstance(u, str) and len(u) <= MAX_TEXT and u.isprintable()
            for k, u in units.items()
        ):
            raise ModelError(f"{pre}: [plot] `units` must map names to printable unit strings")
        for key in ("force", "velocity"):
            n = self.plot.get(key)
            if n is not None and not isinstance(n, str):
                raise ModelError(f"{pre}: plot `{key}` must be a name, got {n!r}")
            if n is not None and n not in vnames and n not in self.outputs:
                raise ModelError(f"{pre}: plot `{key}` = `{n}` is neither a variable nor an output")
        refs = self.plot.get("linear_references", {})

        def is_mode(r: object) -> bool:
            if not self.components:
                return r in self.mode_names
            try:
                self.mode_key(r)
            except InputError:
                return False
            return True

        if not isinstance(refs, Mapping) or not all(
            isinstance(k, str) and k.isprintable() and len(k) <= MAX_TEXT and is_mode(r)
            for k, r in refs.items()
        ):
            known = ", ".join(self.mode_names) if not self.components else f"e.g. `{self.default_mode}`"
            raise ModelError(
                f"{pre}: [plot] `linear_references` must map labels to modes of the model "
                f"({known}), got {dict(refs) if isinstance(refs, Mapping) else refs!r}"
            )
        for n in self.plot.get("displacements", ()):
            if n not in vnames and n not in self.outputs:
                raise ModelError(f"{pre}: plot displacement `{n}` is neither a variable nor an output")
        for o in self.outputs:
            for m in self.modes:
                if o not in mode_data[m.name]["defs"]:
                    raise ModelError(f"{pre}: output `{o}` is not a definition in mode `{m.name}`")
        self._validate_orbit(pre, base_known, parsed_defs, mode_data)
        self._check_continuous(pre, mode_data)
        if self.period is not None:
            pe = parse(self.period, set(pnames), f"{pre}: period")
            self._set_cache("period", pe)
        else:
            self._set_cache("period", None)
        pmap = {p.name: p for p in self.parameters}
        for pname, values in self.presets.items():
            for k, val in values.items():
                if k in pmap:
                    try:
                        pmap[k].check(val)
                    except ValueError as exc:
                        raise ModelError(f"{pre}: preset `{pname}`: {exc}") from None
            for k in values:
                if k not in pmap:
                    raise ModelError(
                        f"{pre}: preset `{pname}` sets unknown parameter `{k}`; parameters: {', '.join(pnames)}"
                    )
        self._set_cache("modes", mode_data)
        self._set_cache("transitions", trans)
        self._set_cache("components", tuple(comp_data))

    def _validate_components(self, pre: str, vnames: list[str]) -> dict[str, str]:
        """Names, local modes and owned variables of the components; ``{variable: component}``."""
        owned: dict[str, str] = {}
        seen: set[str] = set()
        vset = set(vnames)
        for c in self.components:
            if not isinstance(c.name, str) or not _NAME.fullmatch(c.name):
                raise ModelError(
                    f"{pre}: invalid component name {_shown(c.name)} (1 to 64 letters, digits, _)"
                )
            if c.name in seen:
                raise ModelError(f"{pre}: duplicate component name `{c.name}`")
            seen.add(c.name)
            where = f"{pre}: component `{c.name}`"
            if not c.modes:
                raise ModelError(f"{where} has no modes")
            for m in c.modes:
                if not isinstance(m, Mode):
                    raise ModelError(f"{where}: modes must be Mode objects, got {m!r}")
                if not isinstance(m.name, str) or not _MODE_NAME.fullmatch(m.name):
                    raise ModelError(f"{where}: invalid mode name {m.name!r}")
            names = [m.name for m in c.modes]
            if len(set(names)) != len(names):
                raise ModelError(f"{where}: duplicate mode names in {names}")
            if c.initial_mode is not None and c.initial_mode not in names:
                raise ModelError(
                    f"{where}: initial mode `{c.initial_mode}` does not exist; modes: {', '.join(names)}"
                )
            first = c.modes[0]
            ours = set(first.derivatives) | set(first.algebraic)
            if not ours:
                raise ModelError(
                    f"{where}: mode `{first.name}` gives no equation (a component owns at least one variable)"
                )
            for m in c.modes[1:]:
                theirs = set(m.derivatives) | set(m.algebraic)
                if theirs != ours:
                    diff = sorted(ours ^ theirs)
                    raise ModelError(
                        f"{where}: modes `{first.name}` and `{m.name}` give equations for different variables "
                        f"({', '.join(diff)}): every mode of a component gives one for each variable it owns"
                    )
            for m in c.modes:
                both = set(m.derivatives) & set(m.algebraic)
                if both:
                    raise ModelError(
                        f"{where}: mode `{m.name}`: `{sorted(both)[0]}` has both a derivative and an algebraic equation"
                    )
            for n in sorted(ours):
                if n not in vset:
                    raise ModelError(f"{where} gives an equation for unknown variable `{n}`")
                if n in owned:
                    raise ModelError(f"{where}: variable `{n}` is already owned by component `{owned[n]}`")
                if n in self.equations:
                    raise ModelError(
                        f"{where}: variable `{n}` has a shared equation; the component's modes give its own"
                    )
                if n in self.quadratures and any(n in m.algebraic for m in c.modes):
                    raise ModelError(f"{where}: quadrature `{n}` cannot be algebraic")
                owned[n] = c.name
            for tr in c.transitions:
                if not isinstance(tr, Transition):
                    raise ModelError(f"{where}: transitions must be Transition objects, got {tr!r}")
                for end in ("source", "target"):
                    if getattr(tr, end) not in names:
                        raise ModelError(
                            f"{where}: transition `{tr.name}` has {end} mode `{getattr(tr, end)}` that does "
                            f"not exist; modes: {', '.join(names)}"
                        )
        return owned

    def _parse_components(self, pre, base_known, parsed_defs, vnames, pnames) -> list[dict]:
        """Each component's local modes and transitions, parsed and expanded (as the own modes')."""
        out = []
        # Linear in the number of components: what every local mode without definitions of its own
        # shares (the names it may use, the definitions it expands) is made once, not copied.
        shared_known = base_known | set(self.definitions)
        shared_expand = _Expander(parsed_defs)
        vset, pset = set(vnames), set(pnames)
        vindex = {n: i for i, n in enumerate(vnames)}
        for k, c in enumerate(self.components):
            if k and not k & 255:  # a large model's set-up honours the deadline in force (--max-time)
                check_deadline(f"reading the model's components ({k} of {len(self.components)} read)")
            where = f"{pre}: component `{c.name}`"
            modes: dict[str, dict] = {}
            for m in c.modes:
                for n in m.definitions:
                    if n in vset or n in pset or not _NAME.fullmatch(n) or n in _RESERVED:
                        raise ModelError(f"{where}: mode `{m.name}`: invalid definition name {_shown(n)}")
                if m.definitions:
                    known = shared_known | set(m.definitions)
                    mdefs = dict(parsed_defs)
                    mdefs.update(
                        self._parse_definitions(
                            m.definitions, known, parsed_defs, f"{where}: mode `{m.name}` definition"
                        )
                    )
                    expand = _Expander(mdefs)
                else:
                    known, mdefs, expand = shared_known, parsed_defs, shared_expand
                modes[m.name] = {
                    "derivatives": {
                        n: expand(parse(e, known, f"{where}: mode `{m.name}`: derivative of `{n}`"))
                        for n, e in m.derivatives.items()
                    },
                    "algebraic": {
                        n: expand(parse(e, known, f"{where}: mode `{m.name}`: algebraic equation of `{n}`"))
                        for n, e in m.algebraic.items()
                    },
                    "defs": mdefs,
                    "known": known,
                    "expand": expand,
                    "halt": m.halt,
                }
            trans = []
            used: dict[str, set[str]] = {}
            for tr in c.transitions:
                if tr.name in used.setdefault(tr.source, set()):
                    raise ModelError(
                        f"{where}: duplicate transition name `{tr.name}` from mode `{tr.source}`"
                    )
                used[tr.source].add(tr.name)
                md = modes[tr.source]
                known = md["known"]
                g = md["expand"](parse(tr.guard, known, f"{where}: guard of transition `{tr.name}`"))
                if isinstance(tr.guard, str) and not (free_symbols(g) - pset):
                    raise ModelError(
                        f"{where}: guard of transition `{tr.name}` ({tr.guard!r}) depends on no variable and "
                        "not on t: it can never cross zero"
                    )
                resets = {}
                for n, r in tr.reset.items():
                    if n not in vset:
                        raise ModelError(f"{where}: transition `{tr.name}` resets unknown variable `{n}`")
                    resets[n] = md["expand"](
                        parse(r, known, f"{where}: reset of `{n}` in transition `{tr.name}`")
                    )
                trans.append({"guard": g, "reset": resets})
            owned = sorted(set(c.modes[0].derivatives) | set(c.modes[0].algebraic), key=vindex.__getitem__)
            out.append({"modes": modes, "transitions": trans, "owned": tuple(owned)})
        return out

    def _check_continuous(self, pre: str, mode_data: Mapping[str, dict]) -> None:
        """Refuse ``sign()`` of the state or of ``t`` in a mode's equations (a discontinuous
        right-hand side, which IDA would step across silently): such a system is built by
        :func:`hybrid.filippov_system`, which derives its regions and sliding modes."""
        for mname, md in mode_data.items():
            for kind, eqs in (("derivative", md["derivatives"]), ("algebraic equation", md["algebraic"])):
                for n, e in eqs.items():
                    for h in sign_arguments(e):
                        if h.free - {p.name for p in self.parameters}:
                            raise ModelError(
                                f"{pre}: mode `{mname}`: {kind} of `{n}` contains sign({to_string(h, 80)}), "
                                "a discontinuous right-hand side that an integrator would step across; "
                                "build the system with hybrid.filippov_system(...) (load_system does so for "
                                "model files) to have its surfaces handled by Filippov's convention"
                            )

    def _validate_orbit(self, pre: str, base_known: set[str], defs: Mapping[str, Expr], mode_data) -> None:
        if "stick_modes" in self.orbit:
            raise ModelError(
                f"{pre}: [orbit] `stick_modes` is no longer read: every orbit reports the fraction of the "
                "period in each mode (`mode_fractions`; columns `fraction_<mode>` of frc.csv); remove the key"
            )
        unknown = set(self.orbit) - {"gauge", *_AUTONOMOUS_ORBIT_KEYS}
        if unknown:
            raise ModelError(
                f"{pre}: [orbit] has unknown key(s) {', '.join(sorted(unknown))}; "
                f"allowed: gauge, {', '.join(_AUTONOMOUS_ORBIT_KEYS)}"
            )
        self._set_cache("autonomous", validate_hints(self, pre))
        gauge = self.orbit.get("gauge")
        if gauge is None:
            self._set_cache("gauge", None)
            return
        texts = [gauge] if isinstance(gauge, str) else gauge
        if not isinstance(texts, (list, tuple)) or not texts or not all(isinstance(g, str) for g in texts):
            raise ModelError(
                f"{pre}: [orbit] `gauge` must be an expression string or a non-empty list of them, got {gauge!r}"
            )
        if len(texts) > len(self.variables):
            raise ModelError(
                f"{pre}: [orbit] `gauge` lists {len(texts)} expressions, more than the {len(self.variables)} "
                "variables a family could leave free; list one per element that may stay fixed"
            )
        gauges = []
        state = {v.name for v in self.variables}
        known, expand = base_known | set(defs), _Expander(defs)  # once, not per gauge (issue 32)
        for text in texts:
            g = expand(parse(text, known, f"{pre}: orbit gauge"))
            if "t" in free_symbols(g) or not (free_symbols(g) & state):
                raise ModelError(f"{pre}: orbit gauge {text!r} must depend on the state and not on t")
            if free_symbols(g) & set(self.quadratures):
                raise ModelError(f"{pre}: orbit gauge {text!r} depends on a quadrature")
            gauges.append(g)
        self._set_cache("gauge", tuple(gauges))

    def _set_cache(self, key: str, value) -> None:
        """Keep a part of :attr:`parsed` while the system is validated (construction only)."""
        self._building[key] = value

    def __hash__(self) -> int:
        return hash((self.name, self.variable_names, self.parameter_names, self.mode_names))

    def __repr__(self) -> str:
        """One line: the name and the counts (the whole model is in its fields, and `hybrid show`)."""
        n_v, n_p, n_m, n_t = len(self.variables), len(self.parameters), len(self.modes), len(self.transitions)
        return (
            f"HybridSystem({self.name!r}: {n_v} variable{'s' * (n_v != 1)}, {n_p} parameter{'s' * (n_p != 1)}, "
            f"{n_m} mode{'s' * (n_m != 1)}, {n_t} transition{'s' * (n_t != 1)}"
            + (f", period {self.period}" if self.period else ", autonomous")
            + ")"
        )

    @property
    def parsed(self) -> ParsedSystem:
        """The model's expressions as parsed and expanded at construction (read-only)."""
        return self._parsed

    @property
    def cache(self) -> DerivedCache:
        """What the engine derives from this system and keeps with it (compiled forms, the exact
        integrator's analysis, ...), each entry made once on first use by the module that owns its key."""
        return self._derived

    @staticmethod
    def _parse_definitions(
        defs: Mapping[str, str], known: set[str], outer: Mapping[str, Expr], what: str
    ) -> dict[str, Expr]:
        """Parse ``defs`` and expand them over each other and ``outer`` (already expanded).

        Each definition is expanded once, in dependency order, by one
        substitution of the already expanded ones: linear in the size of the
        definitions (shared sub-expressions stay shared, see :class:`Expr`).
        Returns ``outer`` updated with the expanded ``defs``.
        """
        known = known | set(defs) | set(outer)
        raw = {n: parse(text, known, f"{what} `{n}`") for n, text in defs.items()}
        env = dict(outer)
        for n in _dependency_order(raw, what):
            env[n] = substitute(raw[n], env)
        return env

    # ------------------------------------------------------------------
    @property
    def variable_names(self) -> tuple[str, ...]:
        """Names of the state variables, in state-vector order."""
        return tuple(v.name for v in self.variables)

    @property
    def parameter_names(self) -> tuple[str, ...]:
        """Names of the parameters."""
        return tuple(p.name for p in self.parameters)

    @property
    def mode_names(self) -> tuple[str, ...]:
        """Names of the modes."""
        return tuple(m.name for m in self.modes)

    @property
    def composed(self) -> bool:
        """True if the system has components (its modes are composed on demand)."""
        return bool(self.components)

    @property
    def default_mode(self) -> str | None:
        """Name of the system's initial mode: its own ``initial_mode`` and, for each component, its
        ``initial_mode`` (its first mode where it names none); None where the system names none."""
        if self.initial_mode is None:
            return None
        if not self.components:
            return self.initial_mode
        return MODE_SEPARATOR.join(
            [self.initial_mode, *(c.initial_mode or c.modes[0].name for c in self.components)]
        )

    @property
    def local_mode_names(self) -> tuple[str, ...]:
        """The modes of the system's parts: its own modes, then each component's local modes named
        ``component.mode``; without components, :attr:`mode_names`. A few per component, never
        their product: what a branch's table has a time-fraction column for."""
        return (*self.mode_names, *(f"{c.name}.{m}" for c in self.components for m in c.mode_names))

    def local_modes_of(self, name: str) -> tuple[str, ...]:
        """The parts' modes (see :attr:`local_mode_names`) that mode ``name`` is made of: its own
        mode, then one local mode per component; without components, ``(name,)``."""
        if not self.components:
            return (name,)
        parts = name.split(MODE_SEPARATOR)
        return (parts[0], *(f"{c.name}.{p}" for c, p in zip(self.components, parts[1:], strict=True)))

    def mode_key(self, name: str) -> tuple[int, ...]:
        """The indices of a mode's parts: its own mode, then the local mode of each component.

        A mode of a system with components is named ``own|local1|local2|...`` (one local mode
        name per component, in order); without components, by its own name.

        Raises
        ------
        InputError
            The name has the wrong number of parts or names a mode that does not exist (the
            message names the part).
        """
        if not isinstance(name, str):
            raise InputError(f"model `{self.name}`: a mode name must be a string, got {name!r}")
        parts = name.split(MODE_SEPARATOR) if self.components else [name]
        if len(parts) != 1 + len(self.components):
            raise InputError(
                f"model `{self.name}`: mode `{name[:80]}` has {len(parts)} parts; a mode of this model names its "
                f"own mode and the mode of each of its {len(self.components)} components, joined by "
                f"`{MODE_SEPARATOR}` (e.g. `{self.default_mode or ''}`)"
            )
        own = {m.name: k for k, m in enumerate(self.modes)}
        if parts[0] not in own:
            raise InputError(
                f"model `{self.name}` has no mode `{parts[0]}`; modes: {', '.join(self.mode_names)}"
            )
        key = [own[parts[0]]]
        for c, part in zip(self.components, parts[1:], strict=True):
            names = c.mode_names
            if part not in names:
                raise InputError(
                    f"model `{self.name}`: component `{c.name}` has no mode `{part}`; its modes: {', '.join(names)}"
                )
            key.append(names.index(part))
        return tuple(key)

    def mode_label(self, key: tuple[int, ...]) -> str:
        """The name of the mode whose parts have the indices ``key`` (see :meth:`mode_key`)."""
        if not self.components:
            return self.modes[key[0]].name
        return MODE_SEPARATOR.join(
            [
                self.modes[key[0]].name,
                *(c.modes[k].name for c, k in zip(self.components, key[1:], strict=True)),
            ]
        )

    def mode(self, name: str) -> Mode:
        """The mode called ``name``: one of :attr:`modes`, or a mode of a system with components,
        composed from its parts (their equations merged; ``halt`` if a part halts).

        Raises
        ------
        InputError
            No such mode (the message lists the modes, or names the part that does not exist).
        """
        if not self.components:
            for m in self.modes:
                if m.name == name:
                    return m
            raise InputError(f"model `{self.name}` has no mode `{name}`; modes: {', '.join(self.mode_names)}")
        key = self.mode_key(name)
        parts = [self.modes[key[0]], *(c.modes[k] for c, k in zip(self.components, key[1:], strict=True))]
        halts = [m.halt for m in parts if m.halt]
        halt = "; ".join(halts)
        if len(halt) > 4 * MAX_TEXT:  # many parts halt: the first messages, and how many
            tail = f" ... ({len(halts)} parts halt)"
            halt = halt[: 4 * MAX_TEXT - len(tail)] + tail
        return Mode(
            name,
            derivatives={n: e for m in parts for n, e in m.derivatives.items()},
            algebraic={n: e for m in parts for n, e in m.algebraic.items()},
            halt=halt,
        )

    def algebraic_variables(self, mode: str) -> tuple[str, ...]:
        """Names of the slave (algebraic) variables of ``mode``."""
        return tuple(self.mode(mode).algebraic)

    def parameter_values(
        self,
        values: Mapping[str, object] | None = None,
        *,
        preset: str | None = None,
    ) -> dict[str, float]:
        """Complete, checked parameter values.

        Parameters
        ----------
        values : mapping, optional
            Values given explicitly; they override the preset's.
        preset : str, optional
            Name of a preset of the model to start from.

        Returns
        -------
        dict of str to float

        Raises
        ------
        ValueError
            Unknown preset or parameter name, a missing parameter, or a value
            that is not finite or outside the parameter's domain.
        """
        out: dict[str, object] = {}
        if preset is not None:
            if preset not in self.presets:
                have = ", ".join(self.presets) or "none"
                raise InputError(f"model `{self.name}` has no preset `{preset}`; presets: {have}")
            out.update(self.presets[preset])
        if values:
            for k in values:
                if k not in self.parameter_names:
                    raise InputError(
                        f"model `{self.name}` has no parameter `{k}`; parameters: {', '.join(self.parameter_names)}"
                    )
            out.update(values)
        missing = [p for p in self.parameter_names if p not in out]
        if missing:
            raise InputError(f"model `{self.name}`: missing value for parameter(s) {', '.join(missing)}")
        return {p.name: p.check(out[p.name]) for p in self.parameters}

    def __reduce__(self):
        hit = _SHARED.get(id(self))
        if hit is None or hit[1] is not self:
            raise InputTypeError(
                f"model `{self.name}`: a HybridSystem is not pickled by value (it holds compiled code); "
                "it is pickled by reference only between processes forked after hybrid.model.system.shared(system)"
            )
        return (_shared_system, (id(self), hit[0]))

    def preset(self, name: str, **overrides: float) -> dict[str, float]:
        """Parameter values of preset ``name`` with ``overrides`` applied (checked)."""
        return self.parameter_values(overrides, preset=name)

    def period_value(self, params: Mapping[str, float]) -> float | None:
        """Forcing period for ``params`` (None if the model declares none)."""
        pe = self._parsed.period
        if pe is None:
            return None
        try:
            value = float(compile_scalar(pe, {}, params)(()))
        except (ArithmeticError, ValueError) as exc:
            raise ModelError(
                f"model `{self.name}`: forcing period {self.period!r} cannot be evaluated: {exc}"
            ) from None
        if not (math.isfinite(value) and value > 0):
            raise ModelError(
                f"model `{self.name}`: forcing period {self.period!r} evaluates to {value!r}; it must be finite and > 0"
            )
        return value


#: ``[orbit]`` keys read by autonomous periodic orbits (:mod:`hybrid.model.orbit_hints`).
_AUTONOMOUS_ORBIT_KEYS = ("section", "period_guess")


class _Expander:
    """Substitute definitions (already fully expanded) into an expression: one pass."""

    def __init__(self, defs: Mapping[str, Expr]):
        self.defs = defs

    def __call__(self, e: Expr) -> Expr:
        return substitute(e, self.defs)


def _dependency_order(raw: Mapping[str, Expr], what: str) -> list[str]:
    """Definition names, each after the definitions it uses (iterative depth-first search).

    Raises
    ------
    ExpressionError
        If the definitions form a cycle (named in the message).
    """
    state: dict[str, int] = {}  # 1: on the current path, 2: done
    order: list[str] = []
    for root in raw:
        if root in state:
            continue
        state[root] = 1
        path = [root]
        stack = [iter(sorted(raw[root].free & raw.keys()))]
        while stack:
            nxt = next(stack[-1], None)
            if nxt is None:
                stack.pop()
                done = path.pop()
                state[done] = 2
                order.append(done)
                continue
            s = state.get(nxt)
            if s == 1:
                cycle = path[path.index(nxt) :] + [nxt]
                raise ExpressionError(f"{what}s form a cycle: {' -> '.join(cycle)}")
            if s == 2:
                continue
            state[nxt] = 1
            path.append(nxt)
            stack.append(iter(sorted(raw[nxt].free & raw.keys())))
    return order
