"""Filippov systems: modes whose right-hand sides contain ``sign(h)``, one component per surface.

A mode whose derivatives contain ``sign(h)`` of a smooth expression ``h(t, y)`` has a
discontinuous vector field across the *surface* ``h = 0``. Filippov's convention (Filippov 1988;
di Bernardo et al. 2008) reads it as follows, with ``f+`` (``f-``) the field with ``sign(h)``
replaced by +1 (-1) and ``a+-`` = ``dh/dt`` along ``f+-`` (``h_t + h_y f+-``):

* *crossing* where ``a+`` and ``a-`` have the same sign: the state passes to the other side;
* *sliding* where both point towards the surface (``a+ < 0 < a-``): the state moves on it
  with the convex combination ``f = (1 + lam)/2 f+ + (1 - lam)/2 f-``, ``lam`` in ``[-1, 1]``
  fixed by ``dh/dt = 0``;
* *exit* where the sliding coefficient reaches +1 or -1 (``a+`` or ``a-`` reaches 0: one
  field becomes tangent to the surface): the state leaves on that field's side;
* *repulsive sliding* where both point away (``a+ > 0 > a-``): the solution is not unique.

:func:`filippov_system` turns such a model into a system of *components*
(:class:`hybrid.Component`; an event-driven method in the spirit of Piiroinen & Kuznetsov, ACM
TOMS 34(3), 2008). Every ``sign(h_i)`` of a mode ``M`` becomes a slave variable ``sign_i``, and
the mode ``M`` keeps its derivatives with ``sign(h_i)`` replaced by ``sign_i`` (one own mode of
the system, the same in every region). Surface ``i`` is the component named ``sign_i``, which
owns ``sign_i`` and decides it by its local modes:

* ``plus`` and ``minus``, the *regions*: ``sign_i = +1`` / ``-1``. They reach the surface when
  ``h_i`` crosses 0 (transition ``reach``, to ``slide``; projecting the state onto the surface
  where ``h_i`` is affine in a differential variable);
* ``slide``: ``sign_i`` is the slave of ``0 = dh_i/dt`` (index 1 where ``a+ != a-``; solved by
  IDA, or exactly by the affine integrator, together with the other surfaces' sliding
  coefficients). For a right-hand side affine in ``sign(h_i)`` (required) this is Filippov's
  convex combination. It leaves for ``plus`` when ``a+`` rises through 0 (``exit+``) and for
  ``minus`` when ``a-`` falls through 0 (``exit-``): at an exit (tangency), or at once at entry
  where the flow crosses. A crossing is therefore a *chained* switch region -> slide -> region
  at one instant (docs/engine.md), whose saltation matrix is the classical
  ``I + (f+ - f-) h_y / (h_t + h_y f-)``; entering ``slide`` gives ``h_y Xi = 0`` (a zero
  Floquet multiplier); leaving it at a tangency, ``Xi = I``;
* ``repel``, a *halt* (:attr:`hybrid.Mode.halt`) that ends the run with a message: repulsive
  sliding (where the orientation ``d(dh_i/dt)/d sign_i = (a+ - a-)/2`` turns positive on the
  surface; a crossing with that orientation passes through, ``cross+-``);
* ``entry+`` and ``entry-``, the *entry* (the initial local mode): they send the state at once
  to the region it lies in, or, on the surface, classify it by the fields (``entry+`` follows
  ``f+``, ``entry-`` follows ``f-``): where ``f+`` leaves the surface downwards, to ``minus``
  (whose ``reach`` then decides sliding or crossing by ``f-``); where it leaves upwards, to
  ``entry-``, which sends the state to ``plus`` where ``f-`` leaves upwards too (crossing) and
  otherwise to ``slide``, whose guards report repulsion; where neither decides, to ``slide``.

Several surfaces are several components: the event loop decides their simultaneous switches
(:mod:`hybrid.engine.eventloop`: at a switch every guard of the new mode is checked, component by
component, until none asks to switch). Sliding on two surfaces at once is two components in
``slide``: both ``sign_i`` are solved together from ``dh_1/dt = dh_2/dt = 0`` (Filippov's
multi-affine convex combination of the equations as written), and a surface reached while
sliding on another is crossed or joined by its own guards. Nothing enumerates the combinations:
building costs time linear in the number of surfaces.

A surface whose ``dh/dt`` does not depend on ``sign(h)`` cannot slide: its regions are joined by
direct ``cross`` transitions. A system with several modes of its own (``[modes.*]`` of a file)
gets, for each mode ``M`` with surfaces, a slave variable ``in_M`` (1 in ``M``, 0 in the other
modes) that the components read: outside ``M`` a component is ``off`` (``sign_i = 0``), and
re-enters ``M`` through its entry. A transition from ``M`` to itself (an impact's reset, say) goes
to a twin ``M_`` of ``M`` and back, so that the components re-enter too. docs/filippov.md has the
whole picture and the limits.

Every ``sign_i`` is a slave variable in every mode (``sign_i = +-1`` in the regions), so it is
recorded along trajectories (it is the set-valued ``sign(h_i)``, e.g. the friction force over its
limit) and adds a structural zero to the multipliers of a periodic orbit.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, replace

from ..core.errors import ModelError
from .elements import _NAME, Component, Mode, Transition, Variable
from .expr import (
    ONE,
    Expr,
    add,
    diff,
    div,
    mul,
    num,
    replace_nodes,
    sign_arguments,
    sub,
    substitute,
    sym,
    to_string,
)
from .system import MAX_COMPONENTS, MAX_VARIABLES, HybridSystem

__all__ = ["filippov_system", "Surface", "surfaces"]

#: Most surfaces ``sign(h)`` of a model, all its modes together (each is a component of the system).
MAX_SURFACES = MAX_COMPONENTS
#: Most terms of the surfaces' rates ``dh/dt = h_t + sum_y h_y y'``: the differential variables
#: each surface depends on, summed over the surfaces (a bound on the work of deriving them).
MAX_SURFACE_TERMS = 200_000
#: Key of the surfaces a Filippov system was derived from, in its :attr:`HybridSystem.cache`.
SURFACES_KEY = "filippov_surfaces"

#: The local modes of a surface's component (for one mode of the system), in order.
LOCAL_MODES = ("entry+", "entry-", "plus", "minus", "slide", "repel")
#: The local mode of a component while the system is in a mode without its surface.
OFF = "off"


@dataclass(frozen=True)
class Surface:
    """One discontinuity surface ``h = 0`` of a Filippov mode.

    Attributes
    ----------
    mode : str
        The mode of the model file whose equations contain ``sign(h)``.
    h : str
        The surface function, definitions expanded.
    coefficient : str
        The slave variable that stands for ``sign(h)`` (in ``[-1, 1]`` while sliding).
    slides : bool
        False if ``dh/dt`` does not depend on ``sign(h)``: the flow can only cross.
    modes : tuple of str
        The local modes of its component for this mode: entry, regions, sliding and halt modes.
    component : str
        The component that decides ``coefficient`` (named as it).
    """

    mode: str
    h: str
    coefficient: str
    slides: bool
    modes: tuple[str, ...]
    component: str = ""


class _Parsed(HybridSystem):
    """A system parsed and checked as usual, with ``sign()`` of the state admitted."""

    def _check_continuous(self, pre, mode_data) -> None:
        return None


def _free_name(base: str, taken: set[str]) -> str:
    name = base
    while name in taken:
        name += "_"
    return name


def _surface_nodes(equations, params: set[str]) -> tuple[list[Expr], dict[Expr, tuple[int, float]]]:
    """Surfaces of a mode and, for each ``sign(.)`` node of its equations, ``(surface, factor)``.

    ``sign(-g)`` and ``sign(b - a)`` are the surface of ``sign(g)`` / ``sign(a - b)`` with factor -1.
    """
    keys: list[Expr] = []
    position: dict[Expr, int] = {}
    nodes: dict[Expr, tuple[int, float]] = {}
    for e in equations:
        for h in sign_arguments(e):
            if not (h.free - params):
                continue  # sign of parameters: a constant
            node = Expr("call", ("sign", h))
            if node in nodes:
                continue
            g, factor = h, 1.0
            if h.op == "neg":
                g, factor = h.args[0], -1.0
            elif h.op == "sub" and Expr("sub", (h.args[1], h.args[0])) in position:
                g, factor = Expr("sub", (h.args[1], h.args[0])), -1.0
            if g not in position:
                position[g] = len(keys)
                keys.append(g)
            nodes[node] = (position[g], factor)
    return keys, nodes


def filippov_system(**kwargs) -> HybridSystem:
    """A hybrid system whose modes may contain ``sign(h)``: surfaces handled by Filippov's convention.

    Parameters
    ----------
    **kwargs
        As for :class:`hybrid.HybridSystem` (without ``components``). In a mode whose derivatives
        contain ``sign(h)`` of the state or of ``t`` (definitions expanded), every such
        ``sign(h_i)`` is replaced by a slave variable ``sign_i`` decided by a component of its own
        (module docstring); the model's transitions keep their modes, with ``sign(h)`` in their
        guards and resets replaced likewise.

    Returns
    -------
    HybridSystem
        The system itself if no mode contains such a ``sign()``; otherwise a system with one
        component per surface index, named ``sign_i`` as its variable, whose modes are named
        ``M|l_1|...|l_s`` (:meth:`hybrid.HybridSystem.mode_key`). Its default initial mode (if
        the model names one) has every component in its entry.

    Raises
    ------
    ModelError
        As :class:`hybrid.HybridSystem`; or a ``sign(h)`` that cannot be handled: ``h``
        containing ``sign()`` itself or depending on a slave variable or a quadrature, a
        derivative not affine in ``sign(h)``, ``sign(h)`` in an algebraic equation; or a model
        too large: more than :data:`MAX_SURFACES` surfaces, more than
        :data:`hybrid.model.system.MAX_VARIABLES` variables with the ``sign_i``, or surfaces whose
        rates have more than :data:`MAX_SURFACE_TERMS` terms.

    Examples
    --------
    >>> from hybrid import Mode
    >>> sys_ = filippov_system(
    ...     name="relay", variables=["x", "v"], parameters=["k", "R"],
    ...     modes=[Mode("m", derivatives={"x": "v", "v": "-k*x - R*sign(v)"})], transitions=[])
    >>> sys_.mode_names, [c.name for c in sys_.components]
    (('m',), ['sign_1'])
    >>> sys_.components[0].mode_names
    ('entry+', 'entry-', 'plus', 'minus', 'slide', 'repel')
    >>> [(s.h, s.coefficient) for s in surfaces(sys_)]
    [('v', 'sign_1')]
    """
    if not _mentions_sign(kwargs):
        return HybridSystem(**kwargs)  # no sign() anywhere: parsed once
    if kwargs.get("components"):
        raise ModelError(
            f"model `{kwargs.get('name')}`: a system written with sign() gets its components from its "
            "surfaces; give components to HybridSystem, without sign() of the state in its equations"
        )
    raw = _Parsed(**kwargs)
    pre = f"model `{raw.name}`"
    params = set(raw.parameter_names)
    mode_data = raw.parsed.modes
    found: dict[str, tuple[list[Expr], dict]] = {}
    for m in raw.modes:
        keys, nodes = _surface_nodes(mode_data[m.name]["derivatives"].values(), params)
        if keys:
            found[m.name] = (keys, nodes)
    if not found:
        return HybridSystem(**kwargs)
    _check_size(raw, pre, found)
    own, mode_data, pairs = _twins(raw, found)
    taken = set(raw.variable_names) | params | set(raw.definitions)
    for m in raw.modes:
        taken |= set(m.definitions)
    n_lam = max(len(k) for k, _ in found.values())
    lams = []
    for i in range(n_lam):
        lams.append(_free_name(f"sign_{i + 1}", taken))
        taken.add(lams[-1])
    # Several modes of its own: each Filippov mode M gets a slave in_M (1 in M, 0 elsewhere),
    # which tells the components whether their surface is in the current mode.
    indicators: dict[str, str] = {}
    if len(own) > 1:
        for k, m in enumerate(own):
            if m.name in found:
                base = f"in_{m.name}" if _NAME.fullmatch(f"in_{m.name}") else f"in_mode_{k + 1}"
                indicators[m.name] = _free_name(base, taken)
                taken.add(indicators[m.name])
    analyses = {
        m.name: _analyse(raw, pre, m, mode_data[m.name], *found[m.name], lams) for m in own if m.name in found
    }
    modes = [_own_mode(m, mode_data[m.name], analyses.get(m.name), indicators) for m in own]
    transitions = _own_transitions(pairs, analyses)
    components, found_surfaces = _components(raw, own, analyses, lams, indicators)
    variables = list(raw.variables)
    variables += [
        Variable(lam, "", "Filippov coefficient: sign() of a discontinuity surface, in [-1, 1] while sliding")
        for lam in lams
    ]
    variables += [
        Variable(name, "", f"1 in mode `{mname}` (whose surfaces sign() decides), 0 in the others")
        for mname, name in indicators.items()
    ]
    out = dict(kwargs)
    out.update(variables=variables, modes=modes, transitions=transitions, components=components)
    system = HybridSystem(**out)
    surfaces_ = tuple(found_surfaces)
    system.cache.get(SURFACES_KEY, lambda: surfaces_)
    return system


def surfaces(system: HybridSystem) -> tuple[Surface, ...]:
    """The discontinuity surfaces :func:`filippov_system` derived for ``system`` (empty for others)."""
    return system.cache.get(SURFACES_KEY, tuple)


def _twins(raw: HybridSystem, found: dict) -> tuple[list[Mode], dict, list]:
    """The system's own modes, their parsed data, and the model's transitions with their parsed
    data, where a Filippov mode ``M`` with a transition to itself gets a twin ``M_`` (the same
    equations and transitions): that transition goes from one to the other, so that the
    components see the system leave the mode and re-enter it through their entry (after its
    reset, e.g. an impact, the state may lie on another side of a surface). ``found`` gets the
    twins' surfaces."""
    pairs = list(zip(raw.transitions, raw.parsed.transitions, strict=True))
    data = dict(raw.parsed.modes)
    loops = [
        m for m in raw.modes if m.name in found and any(t.source == t.target == m.name for t, _ in pairs)
    ]
    if not loops:
        return list(raw.modes), data, pairs
    names = set(raw.mode_names)
    twin: dict[str, str] = {}
    for m in loops:
        name = _free_name(f"{m.name}_" if len(m.name) < 60 else "twin", names)
        names.add(name)
        twin[m.name] = name
        data[name] = data[m.name]
        found[name] = found[m.name]
    own = []
    for m in raw.modes:
        own.append(m)
        if m.name in twin:
            own.append(Mode(twin[m.name], m.derivatives, m.algebraic, m.definitions))
    out = []
    for tr, td in pairs:
        loop = tr.source in twin and tr.target == tr.source
        out.append((replace(tr, target=twin[tr.source]) if loop else tr, td))
        if tr.source in twin:
            out.append((replace(tr, source=twin[tr.source], target=tr.source if loop else tr.target), td))
    return own, data, out


def _check_size(raw: HybridSystem, pre: str, found: Mapping[str, tuple[list[Expr], dict]]) -> None:
    """The limits by size, each with its own message, before anything is derived."""
    counts = {name: len(keys) for name, (keys, _) in found.items()}
    # a mode with a transition to itself counts twice (it gets a twin, see _twins)
    loops = {name for name in found if any(t.source == t.target == name for t in raw.transitions)}
    total = sum(counts.values()) + sum(counts[name] for name in loops)
    if total > MAX_SURFACES:
        per_mode = ", ".join(
            f"`{name}`: {n}" + (" (twice)" if name in loops else "") for name, n in counts.items()
        )
        raise ModelError(
            f"{pre} has {total} discontinuity surfaces sign(h) ({per_mode}); at most {MAX_SURFACES} are "
            "allowed (each is a component of the system)"
        )
    n_lam = max(counts.values())
    n_ind = len(found) + len(loops) if len(raw.modes) + len(loops) > 1 else 0
    n_vars = len(raw.variables) + n_lam + n_ind
    if n_vars > MAX_VARIABLES:
        raise ModelError(
            f"{pre}: {len(raw.variables)} variables and {n_lam} surfaces sign(h) in one mode make "
            f"{n_vars} variables (each surface adds its coefficient sign_i"
            + (f", each of the {n_ind} modes with surfaces its indicator" if n_ind else "")
            + f"); at most {MAX_VARIABLES} are allowed"
        )
    for name, (keys, _) in found.items():
        diffvars = set(raw.parsed.modes[name]["derivatives"])
        terms = sum(len(h.free & diffvars) for h in keys)
        if terms > MAX_SURFACE_TERMS:
            raise ModelError(
                f"{pre}: mode `{name}`: the rates dh/dt of its {len(keys)} surfaces sign(h) have {terms} "
                f"terms (one per differential variable a surface depends on); at most {MAX_SURFACE_TERMS} "
                "are allowed: write the surfaces in fewer variables each"
            )


@dataclass
class _Analysis:
    """The surfaces of one mode: their nodes, rates and the expressions of their components."""

    mode: Mode
    keys: list  # h_i
    nodes: dict  # sign(.) node -> (i, factor)
    symbolic: dict  # sign(.) node -> factor * sign_i
    derivatives: dict  # variable -> derivative with sign(h_i) replaced by sign_i
    rates: list  # dh_i/dt with every sign symbolic
    slides: list  # whether dh_i/dt depends on sign_i
    projections: list  # reset putting the state on h_i = 0 (may be empty)


def _analyse(
    raw: HybridSystem, pre: str, m: Mode, md: dict, keys: list, nodes: dict, lams: list
) -> _Analysis:
    """Check the surfaces of mode ``m`` (parsed as ``md``) and derive their rates (linear in their
    number)."""
    pre = f"{pre}: mode `{m.name}`"
    quads = set(raw.quadratures)
    slaves = set(md["algebraic"])
    diffvars = set(md["derivatives"])
    for h in keys:
        shown = to_string(h, 80)
        if sign_arguments(h):
            raise ModelError(f"{pre}: the surface of sign({shown}) contains sign() itself; h must be smooth")
        bad = (h.free & slaves) | (h.free & quads)
        if bad:
            raise ModelError(
                f"{pre}: the surface of sign({shown}) depends on `{sorted(bad)[0]}`, a slave variable or "
                "quadrature of the mode; a surface may depend only on differential variables, parameters and t"
            )
    for n, e in md["algebraic"].items():
        if any(node in nodes for node in _sign_nodes(e)):
            raise ModelError(
                f"{pre}: algebraic equation of `{n}` contains sign() of a surface; Filippov's convention "
                "is derived for derivatives only"
            )
    symbolic = {node: mul(num(f), sym(lams[i])) for node, (i, f) in nodes.items()}
    lamset = {lams[i]: i for i in range(len(keys))}
    derivs = {n: replace_nodes(e, symbolic) for n, e in md["derivatives"].items()}
    # Affine in each sign(h_i): d f / d sign_i must not contain sign_i.
    for n, e in derivs.items():
        for lam in sorted(e.free & lamset.keys(), key=lamset.__getitem__):
            if lam in diff(e, lam).free:
                raise ModelError(
                    f"{pre}: the derivative of `{n}` is not affine in sign({to_string(keys[lamset[lam]], 80)}); "
                    "Filippov's convex combination is derived for right-hand sides f0 + sign(h) f1"
                )
    # Rate of each surface along the field with every sign symbolic: h_t + h_y f.
    rates = []
    for h in keys:
        a = diff(h, "t")
        for v in sorted(h.free & diffvars):
            a = add(a, mul(diff(h, v), derivs[v]))
        rates.append(a)
    slides = [lams[i] in rates[i].free for i in range(len(keys))]
    projections = [_projection(h, diffvars, set(raw.parameter_names)) for h in keys]
    return _Analysis(m, keys, nodes, symbolic, derivs, rates, slides, projections)


def _own_mode(m: Mode, md: dict, an: _Analysis | None, indicators: Mapping[str, str]) -> Mode:
    """The system's own mode for the model's mode ``m``: its equations with ``sign(h_i)`` replaced
    by ``sign_i`` (a Filippov mode), and the indicators' equations."""
    alg = dict(md["algebraic"])
    for mname, ind in indicators.items():
        alg[ind] = sub(sym(ind), ONE) if mname == m.name else sym(ind)
    if an is None:
        defs = {n: md["defs"][n] for n in m.definitions}
        return Mode(m.name, dict(md["derivatives"]), alg, defs)
    defs = {
        n: replace_nodes(e, an.symbolic)
        for n, e in md["defs"].items()
        if n in m.definitions or any(node in an.symbolic for node in _sign_nodes(e))
    }
    return Mode(m.name, an.derivatives, alg, defs)


def _own_transitions(pairs: list, analyses: Mapping[str, _Analysis]) -> list[Transition]:
    """The model's transitions (each with its parsed data), with ``sign(h)`` of their source's
    surfaces replaced by ``sign_i``."""
    out = []
    for tr, td in pairs:
        an = analyses.get(tr.source)
        if an is None:
            out.append(tr)
            continue
        guard = replace_nodes(td["guard"], an.symbolic)
        reset = {n: replace_nodes(e, an.symbolic) for n, e in td["reset"].items()}
        if guard is td["guard"] and all(reset[n] is e for n, e in td["reset"].items()):
            out.append(tr)  # no sign() of a surface in it: as written
        else:
            out.append(Transition(tr.source, tr.target, guard, tr.direction, tr.name, reset))
    return out


def _components(
    raw: HybridSystem, own: list, analyses: Mapping[str, _Analysis], lams: list, indicators: Mapping[str, str]
):
    """One component per surface index ``i`` (its variable ``sign_i``), over every mode with an
    ``i``-th surface; and the :class:`Surface` list."""
    components, found = [], []
    n_own = len(own)
    for i, lam in enumerate(lams):
        with_i = [(k, an) for k, an in enumerate(analyses.values()) if len(an.keys) > i]
        modes: list[Mode] = []
        transitions: list[Transition] = []
        initial = None
        prefixes = {}
        for k, an in with_i:
            mname = an.mode.name
            prefix = "" if len(with_i) == 1 else (f"{mname}_" if len(mname) <= 56 else f"mode{k + 1}_")
            prefixes[mname] = prefix
            names = _local_modes(an, i, lam, prefix, indicators.get(mname), modes, transitions)
            if raw.initial_mode == mname:
                initial = prefix + "entry+"
            found.append(Surface(mname, to_string(an.keys[i]), lam, an.slides[i], names, lam))
        if n_own > 1:  # in a mode without surface i the component is off (and passes off between modes)
            modes.append(Mode(OFF, algebraic={lam: sym(lam)}))
            for mname, prefix in prefixes.items():
                transitions.append(
                    Transition(
                        OFF, prefix + "entry+", sub(sym(indicators[mname]), num(0.5)), 1, f"enter {mname}"
                    )
                )
            if raw.initial_mode is not None and initial is None:
                initial = OFF
        if len(with_i) == 1:
            what = f"the surface {to_string(with_i[0][1].keys[i], 80)} = 0 of mode `{with_i[0][1].mode.name}`"
        else:
            what = f"surface number {i + 1} of modes " + ", ".join(f"`{an.mode.name}`" for _, an in with_i)
        description = f"{what}: decides {lam} (Filippov's convention)"
        if len(description) > 500:
            description = f"surface number {i + 1}: decides {lam} (Filippov's convention)"
        components.append(Component(lam, tuple(modes), tuple(transitions), initial, description))
    return components, found


def _local_modes(
    an: _Analysis, i: int, lam: str, prefix: str, indicator: str | None, modes: list, transitions: list
) -> tuple[str, ...]:
    """Append the local modes and transitions of surface ``i`` of ``an``'s mode to ``modes`` and
    ``transitions``; return the local modes' names."""
    h, rate, shown, mname = an.keys[i], an.rates[i], to_string(an.keys[i], 80), an.mode.name
    slides = an.slides[i]
    kinds = [k for k in LOCAL_MODES if slides or k not in ("entry-", "slide", "repel")]
    name = {k: prefix + k for k in kinds}
    equations = {
        "entry+": sub(sym(lam), ONE),
        "entry-": sub(sym(lam), num(-1.0)),
        "plus": sub(sym(lam), ONE),
        "minus": sub(sym(lam), num(-1.0)),
        "slide": rate,
        "repel": rate,
    }
    halts = {  # (the entry is never stayed in: its guard `on` is always beyond its level)
        "repel": f"repulsive sliding on the surface {shown} = 0 of mode `{mname}`: both vector fields point "
        "away from it, Filippov's solution is not unique here",
    }
    for k in kinds:
        modes.append(Mode(name[k], algebraic={lam: equations[k]}, halt=halts.get(k, "")))

    def add_(source: str, target: str, guard: Expr, direction: int, tname: str, reset=None) -> None:
        transitions.append(Transition(name[source], name[target], guard, direction, tname, reset or {}))

    if indicator is not None:  # the system leaves this mode: the surface is off
        for k in kinds:
            transitions.append(Transition(name[k], OFF, sub(sym(indicator), num(0.5)), -1, "leave"))
    if slides:
        a_plus, a_minus = substitute(rate, {lam: ONE}), substitute(rate, {lam: num(-1.0)})
        orientation = diff(rate, lam)
        add_("entry+", "minus", h, -1, "side-")
        add_("entry+", "entry-", h, 1, "side+")
        add_("entry+", "slide", ONE, 1, "on")
        add_("entry-", "plus", h, 1, "side+")
        add_("entry-", "slide", ONE, 1, "on")
        add_("plus", "slide", h, -1, "reach", an.projections[i])
        add_("minus", "slide", h, 1, "reach", an.projections[i])
        add_("slide", "repel", orientation, 1, "repel")
        add_("slide", "plus", a_plus, 1, "exit+")
        add_("slide", "minus", a_minus, -1, "exit-")
        add_("repel", "minus", a_plus, -1, "cross-")
        add_("repel", "plus", a_minus, 1, "cross+")
    else:
        add_("entry+", "minus", h, -1, "side-")
        add_("entry+", "plus", h, 1, "side+")
        add_("entry+", "plus", ONE, 1, "on")
        add_("plus", "minus", h, -1, "cross")
        add_("minus", "plus", h, 1, "cross")
    return tuple(name[k] for k in kinds)


def _projection(h: Expr, diffvars: set[str], params: set[str]) -> dict[str, Expr]:
    """Reset that puts the state exactly on ``h = 0`` when it reaches the surface: ``y := y - h/h_y``
    for the first differential variable ``y`` in which ``h`` is affine with a coefficient of
    parameters only (the automaton's ``v = 0`` at a stop); none for a surface not of that form.
    A located event lies within rounding of the surface, but a grazing one may not, and the
    sliding mode keeps ``h`` where it starts."""
    for y in sorted(h.free & diffvars):
        d = diff(h, y)
        if not (d.free - params) and not (d.op == "num" and d.args[0] == 0.0):
            return {y: sub(sym(y), div(h, d))}
    return {}


def _mentions_sign(kwargs: Mapping) -> bool:
    """Whether any equation or definition could call ``sign`` (a text containing it, or a tree)."""
    texts = [kwargs.get("equations") or {}, kwargs.get("definitions") or {}]
    for m in kwargs.get("modes") or ():
        texts += [getattr(m, "derivatives", {}), getattr(m, "algebraic", {}), getattr(m, "definitions", {})]
    for table in texts:
        values = table.values() if isinstance(table, Mapping) else ()
        if any(not isinstance(v, str) or "sign" in v for v in values):
            return True
    return False


def _sign_nodes(e: Expr) -> list[Expr]:
    return [Expr("call", ("sign", h)) for h in sign_arguments(e)]
