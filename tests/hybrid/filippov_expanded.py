"""The reference of tests/hybrid/test_filippov_components.py: the builder of ``hybrid.model.filippov``
as it was before issue 22 (commit 0247ea9), which expanded every combination of a mode's surfaces
into region, sliding and halt modes (at most 4 surfaces). Kept unchanged (imports made absolute)
so that the component form is checked against it; not part of the library.

Its docstring as it was:

Filippov systems: modes whose right-hand sides contain ``sign(h)``, expanded into a hybrid automaton.

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

:func:`filippov_system` turns such a model into ordinary modes and transitions of the engine
(an event-driven method in the spirit of Piiroinen & Kuznetsov, ACM TOMS 34(3), 2008). For a
mode ``M`` with surfaces ``h_1 ... h_s``:

* one *region* mode per sign pattern, ``M_+-...``, with ``sign(h_i)`` replaced by the pattern's
  +1 or -1; it lives where ``p_i h_i > 0`` and reaches surface ``i`` when ``h_i`` crosses 0
  (projecting the state onto it where ``h_i`` is affine in a differential variable);
* one *sliding* mode per surface and pattern of the others, ``M_0+...`` (a ``0`` at place
  ``i``), with ``sign(h_i)`` replaced by a new slave variable ``sign_i`` solved (by IDA, or
  exactly by the affine integrator) from ``0 = dh_i/dt``, index 1 where ``a+ != a-``. For a right-hand
  side affine in ``sign(h_i)`` (required) this is Filippov's convex combination. It leaves for
  the region of ``+`` when ``a+`` rises through 0 and for the region of ``-`` when ``a-``
  falls through 0: at an exit (tangency), or at once at entry where the flow crosses. A crossing
  is therefore a *chained* switch region -> sliding -> region at one instant (docs/engine.md),
  whose saltation matrix is the classical ``I + (f+ - f-) h_y / (h_t + h_y f-)``; entering a
  sliding mode gives ``h_y Xi = 0`` (a zero Floquet multiplier); leaving it at a tangency,
  ``Xi = I``;
* *halt* modes (:attr:`hybrid.Mode.halt`) that end the run with a message: repulsive sliding
  (where the orientation ``d(dh_i/dt)/d sign_i = (a+ - a-)/2`` is positive on the surface; a
  crossing with that orientation passes through) and the meeting of two surfaces while sliding
  on one (passed at once where the sliding field crosses the second surface; where it would slide
  on both, the mode ``M_00`` sliding on both if the mode has exactly two surfaces, else a halt);
* the *entry* ``M`` itself (initial mode, target of transitions into ``M``): with the flow frozen,
  it sends the state to the region it lies in, or, on a surface, to the sliding mode, whose
  guards classify it (sliding, exit, crossing or repulsion).

A surface whose ``dh/dt`` does not depend on ``sign(h)`` cannot slide: it gets direct crossing
transitions between its regions. docs/filippov.md has the whole picture and the limits.

Every ``sign_i`` is a slave variable in every mode (``sign_i = +-1`` in the regions), so it is
recorded along trajectories (it is the set-valued ``sign(h_i)``, e.g. the friction force over its
limit) and adds a structural zero to the multipliers of a periodic orbit.
"""

from __future__ import annotations

import itertools
from collections.abc import Mapping
from dataclasses import dataclass

from hybrid.core.errors import ModelError
from hybrid.model.elements import Mode, Transition, Variable
from hybrid.model.expr import (
    ONE,
    ZERO,
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
from hybrid.model.system import HybridSystem

__all__ = ["filippov_system", "Surface", "surfaces"]

#: Most surfaces in one mode (3^s - 1 derived modes grow fast; the engine's limit is 1000 modes).
MAX_SURFACES = 4
#: Key of the surfaces a Filippov system was derived from, in its :attr:`HybridSystem.cache`.
SURFACES_KEY = "filippov_surfaces"

_SIDE = {1: "+", -1: "-", 0: "0"}


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
        The derived modes: regions, sliding and halt modes.
    """

    mode: str
    h: str
    coefficient: str
    slides: bool
    modes: tuple[str, ...]


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
            elif h.op == "sub" and Expr("sub", (h.args[1], h.args[0])) in keys:
                g, factor = Expr("sub", (h.args[1], h.args[0])), -1.0
            if g not in keys:
                keys.append(g)
            nodes[node] = (keys.index(g), factor)
    return keys, nodes


def filippov_system(**kwargs) -> HybridSystem:
    """A hybrid system whose modes may contain ``sign(h)``: surfaces handled by Filippov's convention.

    Parameters
    ----------
    **kwargs
        As for :class:`hybrid.HybridSystem`. A mode whose derivatives contain ``sign(h)`` of the
        state or of ``t`` (definitions expanded) is replaced by its regions, sliding modes and
        halt modes (module docstring); transitions from it are copied to each, with
        ``sign(h)`` replaced likewise; transitions into it, and the initial mode, go to its
        region where every ``sign`` is +1 (a state on the other side passes on at once).

    Returns
    -------
    HybridSystem
        The system itself if no mode contains such a ``sign()``.

    Raises
    ------
    ModelError
        As :class:`hybrid.HybridSystem`; or a ``sign(h)`` that cannot be expanded: ``h``
        containing ``sign()`` itself or depending on a slave variable or a quadrature, a
        derivative not affine in ``sign(h)``, ``sign(h)`` in an algebraic equation, more than
        :data:`MAX_SURFACES` surfaces in a mode, or a derived mode name already taken.

    Examples
    --------
    >>> from hybrid import Mode
    >>> sys_ = filippov_system(
    ...     name="relay", variables=["x", "v"], parameters=["k", "R"],
    ...     modes=[Mode("m", derivatives={"x": "v", "v": "-k*x - R*sign(v)"})], transitions=[])
    >>> sys_.mode_names
    ('m_+', 'm_-', 'm_0', 'm_0r', 'm')
    >>> [s.h for s in surfaces(sys_)]
    ['v']
    """
    if not _mentions_sign(kwargs):
        return HybridSystem(**kwargs)  # no sign() anywhere: parsed once
    raw = _Parsed(**kwargs)
    pre = f"model `{raw.name}`"
    params = set(raw.parameter_names)
    mode_data = raw.parsed.modes
    found = {}
    for m in raw.modes:
        md = mode_data[m.name]
        keys, nodes = _surface_nodes(md["derivatives"].values(), params)
        if keys:
            found[m.name] = (keys, nodes)
    if not found:
        return HybridSystem(**kwargs)
    taken = set(raw.variable_names) | params | set(raw.definitions)
    for m in raw.modes:
        taken |= set(m.definitions)
    n_lam = max(len(k) for k, _ in found.values())
    lams = []
    for i in range(n_lam):
        lams.append(_free_name(f"sign_{i + 1}", taken))
        taken.add(lams[-1])
    trans_data = raw.parsed.transitions
    builder = _Builder(raw, pre, lams, mode_data, trans_data)
    for m in raw.modes:
        if m.name in found:
            builder.expand(m, *found[m.name])
        else:
            builder.keep(m)
    builder.transitions_of_user()
    variables = list(raw.variables) + [
        Variable(lam, "", "Filippov coefficient: sign() of a discontinuity surface, in [-1, 1] while sliding")
        for lam in lams
    ]
    out = dict(kwargs)
    out.update(
        variables=variables,
        modes=builder.modes,
        transitions=builder.transitions,
        initial_mode=builder.entry.get(raw.initial_mode, raw.initial_mode),
    )
    system = HybridSystem(**out)
    found_surfaces = tuple(builder.surfaces)
    system.cache.get(SURFACES_KEY, lambda: found_surfaces)
    return system


def surfaces(system: HybridSystem) -> tuple[Surface, ...]:
    """The discontinuity surfaces :func:`filippov_system` derived for ``system`` (empty for others)."""
    return system.cache.get(SURFACES_KEY, tuple)


class _Builder:
    """Derived modes and transitions of one system (see :func:`filippov_system`)."""

    def __init__(self, raw, pre, lams, mode_data, trans_data):
        self.raw, self.pre, self.lams = raw, pre, lams
        self.mode_data, self.trans_data = mode_data, trans_data
        self.modes: list[Mode] = []
        self.transitions: list[Transition] = []
        self.surfaces: list[Surface] = []
        self.entry: dict[str, str] = {}  # user mode -> derived mode that stands for it
        self.copies: dict[str, list[tuple[str, dict]]] = {}  # user mode -> (derived mode, node map)
        self.user_modes = set(raw.mode_names)

    def _mode_name(self, base: str, pattern) -> str:
        name = f"{base}_" + "".join(_SIDE[p] for p in pattern)
        if name in self.user_modes - {base}:
            raise ModelError(
                f"{self.pre}: the mode `{name}` derived from `{base}` is already a mode of the model"
            )
        return name

    def keep(self, m: Mode) -> None:
        md = self.mode_data[m.name]
        alg = dict(md["algebraic"])
        for lam in self.lams:
            alg[lam] = sym(lam)
        defs = {n: md["defs"][n] for n in m.definitions}
        self.modes.append(Mode(m.name, dict(md["derivatives"]), alg, defs))
        self.copies[m.name] = [(m.name, {})]

    def expand(self, m: Mode, keys: list[Expr], nodes: dict[Expr, tuple[int, float]]) -> None:
        pre = f"{self.pre}: mode `{m.name}`"
        md = self.mode_data[m.name]
        s = len(keys)
        if s > MAX_SURFACES:
            raise ModelError(f"{pre} has {s} surfaces sign(h); at most {MAX_SURFACES} are allowed")
        lams = self.lams[:s]
        quads = set(self.raw.quadratures)
        diffvars = set(md["derivatives"])
        for h in keys:
            shown = to_string(h, 80)
            if sign_arguments(h):
                raise ModelError(
                    f"{pre}: the surface of sign({shown}) contains sign() itself; h must be smooth"
                )
            bad = (h.free & set(md["algebraic"])) | (h.free & quads)
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
        # Affine in each sign(h_i): d f / d sign_i must not contain sign_i.
        symbolic = {node: mul(num(f), sym(lams[i])) for node, (i, f) in nodes.items()}
        deriv_sym = {n: replace_nodes(e, symbolic) for n, e in md["derivatives"].items()}
        for n, e in deriv_sym.items():
            for i, lam in enumerate(lams):
                if lam in diff(e, lam).free:
                    raise ModelError(
                        f"{pre}: the derivative of `{n}` is not affine in sign({to_string(keys[i], 80)}); "
                        "Filippov's convex combination is derived for right-hand sides f0 + sign(h) f1"
                    )
        # Rate of each surface along the field with sign_i symbolic: a_i(sign) = h_t + h_y f.
        rates = []
        for h in keys:
            a = diff(h, "t")
            for v in sorted(h.free & diffvars):
                a = add(a, mul(diff(h, v), deriv_sym[v]))
            rates.append(a)
        slides = [lams[i] in rates[i].free for i in range(s)]

        def nodemap(pattern) -> dict[Expr, Expr]:
            return {
                node: (num(f * pattern[i]) if pattern[i] else mul(num(f), sym(lams[i])))
                for node, (i, f) in nodes.items()
            }

        def values(pattern) -> dict[str, Expr]:
            return {lam: num(p) for lam, p in zip(lams, pattern, strict=True) if p}

        def rate(i: int, pattern) -> Expr:
            """dh_i/dt with the signs of ``pattern`` (0 at place i: sign_i symbolic)."""
            return _subst(rates[i], values(pattern))

        def make(name, pattern, halt="", frozen=False):
            mp = nodemap(pattern)
            derivs = {n: (ZERO if frozen else replace_nodes(e, mp)) for n, e in md["derivatives"].items()}
            alg = dict(md["algebraic"])
            for i, lam in enumerate(self.lams):
                if i >= s:
                    alg[lam] = sym(lam)
                elif pattern[i]:
                    alg[lam] = sub(sym(lam), num(pattern[i]))
                else:
                    alg[lam] = rate(i, pattern)
            defs = {
                n: replace_nodes(e, mp)
                for n, e in md["defs"].items()
                if n in m.definitions or any(node in mp for node in _sign_nodes(e))
            }
            self.modes.append(Mode(name, derivs, alg, defs, halt))
            return mp

        patterns = list(itertools.product((1, -1), repeat=s))
        names = {p: self._mode_name(m.name, p) for p in patterns}
        derived: dict[int, list[str]] = {i: [] for i in range(s)}
        copies = []
        for p in patterns:
            copies.append((names[p], make(names[p], p)))
            for i in range(s):
                derived[i].append(names[p])
        for p in patterns:
            for i in range(s):
                h, lam = keys[i], lams[i]
                flip = tuple(-q if j == i else q for j, q in enumerate(p))
                if not slides[i]:
                    self._add(names[p], names[flip], h, -p[i], f"{lam}:cross")
                    continue
                if p[i] == -1:
                    continue  # the sliding mode is made once, from the + side
                sp = tuple(0 if j == i else q for j, q in enumerate(p))
                sname = self._mode_name(m.name, sp)
                copies.append((sname, make(sname, sp)))
                derived[i].append(sname)
                plus, minus = names[p], names[flip]
                project = _projection(h, diffvars, set(self.raw.parameter_names))
                self._add(plus, sname, h, -1, f"{lam}:reach", project)
                self._add(minus, sname, h, 1, f"{lam}:reach", project)
                # Sliding: repulsion -> halt; exits at tangency (at once where the flow crosses).
                a_plus, a_minus = rate(i, p), rate(i, flip)
                orientation = diff(rate(i, sp), lam)
                shown = to_string(h, 80)
                xname = self._mode_name(m.name, sp) + "r"
                make(
                    xname,
                    sp,
                    halt=f"repulsive sliding on the surface {shown} = 0 of mode `{m.name}`: both vector fields "
                    "point away from it, Filippov's solution is not unique here",
                )
                derived[i].append(xname)
                self._add(sname, xname, orientation, 1, f"{lam}:repel")
                self._add(xname, minus, a_plus, -1, f"{lam}:cross-")
                self._add(xname, plus, a_minus, 1, f"{lam}:cross+")
                self._add(sname, plus, a_plus, 1, f"{lam}:exit+")
                self._add(sname, minus, a_minus, -1, f"{lam}:exit-")
                # Sliding on surface i, the state reaches surface j: it crosses it (to the sliding
                # mode with sign_j flipped) if the sliding field there leaves surface j on the other
                # side; otherwise it would slide on both (the intersection): a halt.
                for j in range(s):
                    if j != i:
                        yname = f"{sname}_meet{j + 1}"
                        if yname in self.user_modes:
                            raise ModelError(
                                f"{pre}: the derived mode `{yname}` is already a mode of the model"
                            )
                        q = -p[j]
                        spf = tuple(q if n == j else v for n, v in enumerate(sp))
                        make(
                            yname,
                            spf,
                            halt=f"the surfaces {shown} = 0 and {to_string(keys[j], 80)} = 0 of mode "
                            f"`{m.name}` intersect here: sliding on the first, the state reached the second, "
                            "and the vector fields do not carry it across (sliding on both is not derived)",
                        )
                        derived[i].append(yname)
                        self._add(sname, yname, keys[j], q, f"{lams[j]}:meet")
                        self._add(yname, self._mode_name(m.name, spf), rate(j, spf), q, f"{lams[j]}:cross")
                        if s == 2 and all(slides):  # sliding on both surfaces
                            self._add(yname, self._mode_name(m.name, (0, 0)), ONE, 1, f"{lams[j]}:slide")
        if s == 2 and all(slides):
            # Sliding on both surfaces (codimension 2): sign_1 and sign_2 are the slaves of
            # dh_1/dt = dh_2/dt = 0; it leaves surface i where sign_i reaches +-1 (the exit of
            # an attractive surface, e.g. a friction contact breaking away).
            both = self._mode_name(m.name, (0, 0))
            copies.append((both, make(both, (0, 0))))
            derived[0].append(both)
            derived[1].append(both)
            for i, lam in enumerate(lams):
                for q in (1, -1):
                    one = tuple(q if n == i else 0 for n in range(2))
                    self._add(
                        both, self._mode_name(m.name, one), sub(sym(lam), num(q)), q, f"{lam}:exit{_SIDE[q]}"
                    )
        # Entry: the mode's own name decides the side of each surface in turn from the state, with
        # the flow frozen (so a state on a surface has no side: it goes to the sliding mode, whose
        # guards classify it by Filippov's rules: sliding, exit, crossing or repulsion).
        for k in range(s - 1, -1, -1):
            for prefix in itertools.product((1, -1), repeat=k):
                dname = m.name if k == 0 else self._mode_name(m.name, prefix) + "x" * (s - k)
                rest = (1,) * (s - k)
                make(
                    dname,
                    prefix + rest,
                    halt=f"entry of mode `{m.name}`: the side of each surface is decided from the state",
                    frozen=True,
                )
                derived[k].append(dname)

                def after(q, k=k, prefix=prefix):
                    # On a surface (q = 0): its sliding mode if it is the last to decide and can
                    # slide; otherwise the + side, whose guards decide from its flow's series.
                    if q == 0 and (k < s - 1 or not slides[k]):
                        q = 1
                    full = prefix + (q,)
                    if len(full) == s:
                        return names[full] if q else self._mode_name(m.name, full)
                    return self._mode_name(m.name, full) + "x" * (s - k - 1)

                self._add(dname, after(1), keys[k], 1, f"{lams[k]}:side+")
                self._add(dname, after(-1), keys[k], -1, f"{lams[k]}:side-")
                self._add(dname, after(0), ONE, 1, f"{lams[k]}:on")
        self.copies[m.name] = copies
        self.entry[m.name] = m.name
        for i in range(s):
            self.surfaces.append(Surface(m.name, to_string(keys[i]), lams[i], slides[i], tuple(derived[i])))

    def _add(self, source, target, guard: Expr, direction: int, name: str, reset=None) -> None:
        self.transitions.append(Transition(source, target, guard, direction, name, reset or {}))

    def transitions_of_user(self) -> None:
        """The model's own transitions, copied to every derived mode of their source."""
        taken = {(t.source, t.name) for t in self.transitions}
        for tr, td in zip(self.raw.transitions, self.trans_data, strict=True):
            for src, mp in self.copies[tr.source]:
                if (src, tr.name) in taken:
                    raise ModelError(
                        f"{self.pre}: transition name `{tr.name}` is also the name of a derived transition of `{src}`"
                    )
                guard = replace_nodes(td["guard"], mp) if mp else td["guard"]
                reset = {n: replace_nodes(e, mp) if mp else e for n, e in td["reset"].items()}
                target = self.entry.get(tr.target, tr.target)
                self.transitions.append(Transition(src, target, guard, tr.direction, tr.name, reset))


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


def _subst(e: Expr, values: Mapping[str, Expr]) -> Expr:
    return substitute(e, values) if values else e
