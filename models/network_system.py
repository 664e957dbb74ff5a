"""A network as a composed hybrid system: one own mode for the mechanism, one component per friction element.

:func:`network_system` derives from a validated :class:`~hybrid_models.network_read.Network` a
:class:`hybrid.HybridSystem` whose modes are never enumerated (``docs/models.md``, "How the system
is derived"):

* the own mode ``motion`` holds the masses' kinematics and momentum balances (``x' = v``,
  ``v' = (sum of the forces)/m``, the friction forces among them), the massless nodes that no
  friction element holds, and the energy quadratures ``W`` and ``D``;
* each friction element ``e`` between ``A`` and ``B`` is a component with the local modes ``stick``,
  ``slip+`` (``w_e = v_B - v_A > 0``) and ``slip-``. It owns the slave variable ``f_e``, the force it
  exerts on ``A``: ``f_e = +-R`` while it slides, and while it sticks the force that keeps the
  relative acceleration of its ends at zero (``0 = a_B - a_A``, the accelerations from the momentum
  balances). It also owns its massless ends (the node ``u`` and its velocity ``vel_u``): while it
  sticks the node moves with the other end and its force balance gives ``f_e``; while it slides the
  balance gives the node's position (or, with a damper, its velocity), as the hand-written absorber's
  ``u``. Its transitions are the break-away when ``f_e`` crosses ``+-R_s`` and the stop when ``w_e``
  crosses zero, which resets the velocities of the masses it joins (to the ground's, or to their
  momentum-weighted mean).

Every equation is written once, in the size of the element's neighbourhood, so a network of ``N``
contacts is derived in time linear in ``N``.
"""

from __future__ import annotations

import re

import numpy as np

from hybrid import HybridSystem, Mode, ModelError, Transition, Variable
from hybrid.model.elements import Component, Parameter
from hybrid.model.system import MODE_SEPARATOR

from . import network_contacts as contacts2d
from .network_read import GROUND, Element, Network, _is_name

__all__ = ["OWN_MODE", "STATES", "network_system"]

#: The name of the system's own mode (the mechanism without its friction states).
OWN_MODE = "motion"
#: Local modes of a friction element.
STATES = ("stick", "slip+", "slip-")
#: A mass with more force terms than this gets its net force as a definition ``net_X`` (the stick
#: equations of its friction elements then name it instead of repeating it: linear size for hubs).
HUB_TERMS = 8
#: Longest sum written as one expression [characters] (the engine parses at most 10000): a longer
#: one (the energy of a thousand springs, the dissipation of a thousand contacts) is summed in parts,
#: each a definition ``__sumK``.
SUM_BUDGET = 4000
#: Most operators (signs of the sum, and the operators, parentheses and commas inside its terms)
#: in one part of a long sum: the engine parses at most 1000 per expression (a mass on 3000
#: springs wrote parts of 4000 characters with 1333 operators: issue 32).
SUM_OPERATORS = 800
_OPERATOR = re.compile(r"[-+*/^,(]")


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
    return out + "".join(f" {t[0]} {t[1:]}" for t in terms[1:])


def _times(coef: str, diff: str) -> str:
    """``coef*(diff)``, with the parentheses needed."""
    return f"{_paren(coef)}*{_paren(diff)}"


class _Derivation:
    """The expressions of one network: positions, velocities, forces and balances of its points."""

    def __init__(self, net: Network):
        self.net = net
        self.coords = net.coords  # coordinates of structures -> velocities
        self.touching: dict[str, list[Element]] = {
            p: [] for p in (*net.masses, *net.nodes, *self.coords, GROUND)
        }
        for e in net.elements:
            self.touching[e.a].append(e)
            self.touching[e.b].append(e)
        self.vel_var = net.node_velocities
        self.held: dict[str, Element] = {}  # node -> the friction element that holds it
        for e in net.friction:
            for p in (e.a, e.b):
                if p in net.nodes:
                    self.held[p] = e
        self.damped = {u for u in net.nodes if any(e.kind == "damper" for e in self.touching[u])}
        self.hubs: dict[str, str] = {}  # mass -> name of its net-force definition
        self.parts: dict[str, str] = {}  # definitions of the parts of long sums
        self.contact_terms = contacts2d.force_terms(net.contacts)  # mass -> forces of its 2-D contacts

    def total(self, terms: list[str]) -> str:
        """A sum of signed terms as text, in parts (definitions ``__sumK``) where it is long."""
        text = _join(terms)
        if len(text) <= SUM_BUDGET and len(_OPERATOR.findall(text)) <= SUM_OPERATORS:
            return text
        chunks: list[list[str]] = [[]]
        size = ops = 0
        for t in terms:
            n_ops = len(_OPERATOR.findall(t)) + 1
            if (size + len(t) + 3 > SUM_BUDGET or ops + n_ops > SUM_OPERATORS) and chunks[-1]:
                chunks.append([])
                size = ops = 0
            chunks[-1].append(t)
            size += len(t) + 3
            ops += n_ops
        names = []
        for chunk in chunks:
            name = f"__sum{len(self.parts) + 1}"
            self.parts[name] = _join(chunk)
            names.append(f"+{name}")
        return self.total(names)

    # kinematics of points ------------------------------------------------------
    def pos(self, p: str) -> str:
        if p == GROUND:
            return "y_base" if self.net.base else "0"
        return p

    def vel(self, p: str) -> str:
        if p == GROUND:
            return "dy_base" if self.net.base else "0"
        if p in self.net.masses:
            return self.net.masses[p][1]
        if p in self.coords:
            return self.coords[p]
        if p in self.vel_var:
            return self.vel_var[p]
        # a free node joined by springs to masses and the ground only: the time derivative of its balance
        springs = [e for e in self.touching[p] if e.kind == "spring"]
        num = self.total([f"+{_times(e.coef, self.vel(e.b if e.a == p else e.a))}" for e in springs])
        den = self.total([f"+{e.coef}" for e in springs])
        return f"({num})/({den})"

    def acc_ground(self) -> str:
        return "ddy_base" if self.net.base else "0"

    @staticmethod
    def diff(q: str, p: str) -> str:
        """``q - p`` as text (``q``, ``p`` positions or velocities; ``"0"`` dropped)."""
        if p == "0":
            return q
        if q == "0":
            return f"-{_paren(p)}"
        return f"{q} - {_paren(p)}"

    # forces --------------------------------------------------------------------
    def force_terms(self, p: str, *, springs=True, dampers=True, friction=True) -> list[str]:
        """Signed terms of the force on point ``p`` from its elements (friction: ``+-f_e``)."""
        terms: list[str] = []
        for e in self.touching[p]:
            q = e.b if e.a == p else e.a
            if e.kind == "spring" and springs:
                terms.append(f"+{_times(e.coef, self.diff(self.pos(q), self.pos(p)))}")
            elif e.kind == "damper" and dampers:
                terms.append(f"+{_times(e.coef, self.diff(self.vel(q), self.vel(p)))}")
            elif e.kind == "friction" and friction:
                terms.append(f"{'+' if p == e.a else '-'}f_{e.name}")
        return terms

    def net_force(self, x: str) -> str:
        """The net force on mass ``x`` [N] (a name ``net_x`` for a hub, see :data:`HUB_TERMS`)."""
        if x in self.hubs:
            return self.hubs[x]
        return self._net_force_text(x)

    def _net_force_text(self, x: str) -> str:
        terms = self.force_terms(x) + [f"+{f.name}" for f in self.forces_on.get(x, [])]
        terms += self.contact_terms.get(x, [])
        return self.total(terms)

    def acceleration(self, x: str) -> str:
        """``x'' `` of a mass (its momentum balance) or of a structure's coordinate (its definition
        ``acc_X``) [m/s^2]."""
        if x in self.coords:
            return f"acc_{x}"
        return f"({self.net_force(x)})/{_paren(self.net.masses[x][0])}"

    def balance(self, u: str) -> str:
        """Force balance of a massless node: the sum of the forces on it (its friction force included)."""
        return self.total(self.force_terms(u))

    def balance_rate(self, u: str) -> str:
        """Time derivative of the balance of an undamped node whose friction force is constant (or absent)."""
        terms = [
            f"+{_times(e.coef, self.diff(self.vel(e.b if e.a == u else e.a), self.vel(u)))}"
            for e in self.touching[u]
            if e.kind == "spring"
        ]
        return self.total(terms)

    def prepare(self) -> None:
        self.forces_on: dict[str, list] = {}
        for f in self.net.forces:
            self.forces_on.setdefault(f.on, []).append(f)
        for x in self.net.masses:
            if (
                len(self.touching[x]) + len(self.forces_on.get(x, [])) + len(self.contact_terms.get(x, []))
                > HUB_TERMS
            ):
                self.hubs[x] = f"net_{x}"
        for x in self.coords:  # a structure's accelerations name the forces on its attached DOFs
            if self.touching[x] or x in self.forces_on or x in self.contact_terms:
                self.hubs[x] = f"net_{x}"

    # a friction element as a component -----------------------------------------
    def component(self, e: Element) -> Component:
        f = f"f_{e.name}"
        R = _paren(e.coef)
        level = _paren(e.static or e.coef)
        nodes = [p for p in (e.a, e.b) if p in self.net.nodes]
        slip = {"slip+": f"{f} - {R}", "slip-": f"{f} + {R}"}
        modes: dict[str, tuple[dict, dict]] = {s: ({}, {}) for s in STATES}  # (derivatives, algebraic)
        if not nodes:  # between masses, or a mass and the ground: 0 = a_B - a_A
            if GROUND in (e.a, e.b):
                x = e.b if e.a == GROUND else e.a
                if x in self.coords:  # a structure's DOF: its acceleration is the ground's
                    stick = self.diff(self.acceleration(x), self.acc_ground())
                else:
                    stick = self.net_force(x)
                    if self.net.base:
                        stick = f"{stick} - {_times(self.net.masses[x][0], 'ddy_base')}"
            else:
                stick = f"{self.acceleration(e.b)} - {self.acceleration(e.a)}"
            modes["stick"][1][f] = stick
            for s in ("slip+", "slip-"):
                modes[s][1][f] = slip[s]
        elif len(nodes) == 1:  # a node u held to a mass or the ground P
            u = nodes[0]
            P = e.b if e.a == u else e.a
            vu = self.vel_var[u]
            modes["stick"][0][u] = vu
            modes["stick"][1][vu] = self.diff(vu, self.vel(P))
            modes["stick"][1][f] = self.balance(u)
            for s in ("slip+", "slip-"):
                modes[s][1][f] = slip[s]
                self._free_node(u, modes[s])
        else:  # a massless pair: two nodes joined by the element
            ua, ub = e.a, e.b
            va, vb = self.vel_var[ua], self.vel_var[ub]
            rest = self.total(self.force_terms(ua, friction=False) + self.force_terms(ub, friction=False))
            der, alg = modes["stick"]
            alg[f] = self.balance(ua)
            alg[va] = self.diff(va, vb)
            if ua in self.damped or ub in self.damped:
                der[ua], der[ub] = va, vb
                alg[vb] = rest  # the pair's balance holds its velocity through the dampers
            else:
                # the pair's balance fixes one node (one with a spring leaving the pair), the other keeps
                # its offset to it; the balance's time derivative gives their common velocity
                outside = [
                    p
                    for p in (ua, ub)
                    if any(el.kind == "spring" and {el.a, el.b} != {ua, ub} for el in self.touching[p])
                ]
                slave = outside[0]
                other = ub if slave == ua else ua
                alg[slave] = rest
                der[other] = self.vel_var[other]
                rate = [self.balance_rate(ua), self.balance_rate(ub)]
                alg[vb] = _join([f"+({r})" for r in rate if r != "0"])
            for s in ("slip+", "slip-"):
                modes[s][1][f] = slip[s]
                self._free_node(ua, modes[s])
                self._free_node(ub, modes[s])
        transitions = [
            Transition("stick", "slip+", f"{f} - {level}", 1, name="breakaway+"),
            Transition("stick", "slip-", f"{f} + {level}", -1, name="breakaway-"),
        ]
        reset = self.stop_reset(e)
        for s, direction in (("slip+", -1), ("slip-", 1)):
            transitions.append(
                Transition(s, "stick", f"w_{e.name}", direction, name=f"stop{s[-1]}", reset=reset)
            )
        return Component(
            e.name,
            modes=[Mode(s, derivatives=der, algebraic=alg) for s, (der, alg) in modes.items()],
            transitions=transitions,
            initial_mode="stick",
            description=f"friction element {e.name} between {e.a} and {e.b}",
        )

    def _free_node(self, u: str, mode: tuple[dict, dict]) -> None:
        """The equations of a node that no sticking element holds: its balance and its velocity."""
        der, alg = mode
        vu = self.vel_var.get(u)
        if u in self.damped:  # the damper's force holds the velocity: the balance fixes it
            der[u] = vu
            alg[vu] = self.balance(u)
        else:
            alg[u] = self.balance(u)
            if vu is not None:
                alg[vu] = self.balance_rate(u)

    def stop_reset(self, e: Element) -> dict[str, str]:
        """Velocities of the masses a stop joins: the ground's, or their momentum-weighted mean."""
        ends = [p for p in (e.a, e.b) if p in self.net.masses]
        if any(p in self.coords for p in (e.a, e.b)):  # a structure's DOF: the impulse through M^-1
            return _impulse_reset(self, e)
        if GROUND in (e.a, e.b):
            return {self.vel(x): self.vel(GROUND) for x in (e.a, e.b) if x in self.net.masses}
        if len(ends) < 2:
            return {}
        num = " + ".join(f"{_paren(self.net.masses[x][0])}*{self.net.masses[x][1]}" for x in ends)
        den = " + ".join(self.net.masses[x][0] for x in ends)
        return {self.net.masses[x][1]: f"({num})/({den})" for x in ends}


def _impulse_reset(d: _Derivation, e: Element) -> dict[str, str]:
    """The stop of a friction element with a structure's DOF at an end (the other a mass, a DOF or
    the ground, which takes no velocity change):
    the impulse ``J`` (``+J`` on ``a``, ``-J`` on ``b``) that makes the ends' velocities equal,
    ``J = w / g`` with ``w = v_b - v_a`` and ``g = u_a - u_b`` (``u = M^-1 (e_a - e_b)``, the
    velocity change per unit impulse), each velocity ``v <- v + u_v J`` (for two masses: their
    momentum-weighted mean). None if an end is a massless node (its element holds no momentum)."""
    if any(p in d.net.nodes for p in (e.a, e.b)):
        return {}
    change: dict[str, list[str]] = {}  # velocity -> signed terms of u
    for p, sign in ((e.a, "+"), (e.b, "-")):
        if p == GROUND:
            continue
        if p in d.net.masses:
            m, v, _ = d.net.masses[p]
            change.setdefault(v, []).append(f"{sign}1/{_paren(m)}")
            continue
        for s in d.net.structures.values():
            if p in s.coords:
                k = s.coords.index(p)
                column = np.linalg.inv(s.model.M)[:, k]
                for v, c in zip(s.velocities, column, strict=True):
                    if c != 0.0:
                        neg = (c < 0) != (sign == "-")
                        change.setdefault(v, []).append(f"{'-' if neg else '+'}{abs(float(c))!r}")
    u = {v: _join(terms) for v, terms in change.items()}
    g = _join([f"+({u.get(d.vel(e.a), '0')})", f"-({u.get(d.vel(e.b), '0')})"])
    J = f"({d.diff(d.vel(e.b), d.vel(e.a))})/({g})"
    return {v: f"{v} + ({text})*{J}" for v, text in u.items()}


def _offset(e: Element) -> str:
    """The relative displacement across element ``e`` (its b end minus its a end; the ground at 0)."""
    a_pos, b_pos = (p if p != GROUND else "0" for p in (e.a, e.b))
    return b_pos if a_pos == "0" else (f"-{a_pos}" if b_pos == "0" else f"{b_pos} - {a_pos}")


def network_system(net: Network) -> HybridSystem:
    """The hybrid system of a network: one own mode and one component per friction element.

    Parameters
    ----------
    net : Network

    Returns
    -------
    HybridSystem
        Variables: each mass's displacement [m] and velocity [m/s], each node [m], the node
        velocities ``vel_U`` [m/s] (slave variables), each friction element's force ``f_NAME`` [N]
        (a slave variable), ``W`` and ``D`` [J] (quadratures). Outputs: ``w_NAME`` [m/s], ``E`` [J],
        the forces [N], ``y_base`` [m]. Mode names ``motion|s1|s2|...`` (one state per friction
        element, in file order); initial mode all stuck.

    Raises
    ------
    ModelError
        A name the builder generates is taken in the file.
    """
    d = _Derivation(net)
    d.prepare()
    friction = net.friction
    vel_var = d.vel_var
    variables: list[Variable] = []
    for x, (_, v, desc) in net.masses.items():
        variables.append(Variable(x, "m", f"displacement of {desc or 'mass ' + x}"))
        variables.append(Variable(v, "m/s", f"velocity of {desc or 'mass ' + x}"))
    for u, desc in net.nodes.items():
        variables.append(
            Variable(u, "m", f"displacement of the massless node {u}" + (f" ({desc})" if desc else ""))
        )
    for s in net.structures.values():
        for q, v, dof in zip(s.coords, s.velocities, s.model.dofs, strict=True):
            what = f"DOF {dof} of structure {s.name}" + (f" ({s.description})" if s.description else "")
            unit = "m"
            if s.reduction is not None and dof not in s.reduction.boundary:
                what = f"modal coordinate {dof} of structure {s.name} (Craig-Bampton, mass-normalised)"
                unit = "m kg^(1/2)"
            variables.append(Variable(q, unit, what))
            variables.append(Variable(v, f"{unit}/s", f"velocity of {what}"))
    for u, vu in vel_var.items():
        variables.append(Variable(vu, "m/s", f"velocity of the massless node {u} (a slave variable)"))
    for e in friction:
        variables.append(
            Variable(f"f_{e.name}", "N", f"force of friction element {e.name} on {e.a} (a slave variable)")
        )
    variables += contacts2d.variables(net.contacts)
    variables.append(Variable("W", "J", "work done by the excitations"))
    variables.append(Variable("D", "J", "energy dissipated by friction and dampers"))

    generated = {"W", "D", "E"} | {f"f_{e.name}" for e in friction} | {f"w_{e.name}" for e in friction}
    generated |= (
        set(vel_var.values())
        | set(d.hubs.values())
        | contacts2d.generated_names(net.contacts)
        | {f"acc_{q}" for q in d.coords}
    )
    if net.base:
        generated |= {"y_base", "dy_base", "ddy_base"}
    taken = set(net.masses) | {v for _, v, _ in net.masses.values()} | set(net.nodes) | set(net.parameters)
    taken |= set(d.coords) | set(d.coords.values()) | set(net.structures)
    taken |= {e.name for e in net.elements} | {f.name for f in net.forces}
    clash = generated & taken
    if clash:
        shown = ", ".join(sorted(clash)[:8])
        raise ModelError(
            f"the name(s) {shown} are generated by the builder (W, D, E, f_NAME, w_NAME of friction elements, "
            "vel_U of nodes, net_X of masses with many elements and of structures' DOFs, acc_X of structures' DOFs, "
            "s_C, vs_C, T_C, N_C of contacts, y_base, dy_base, ddy_base); rename the item(s) "
            "in the file"
        )

    definitions: dict[str, str] = {}
    for f in net.forces:
        terms = []
        if f.offset is not None:
            terms.append(f"+{f.offset}")
        for amp, n, phase in f.terms():
            arg = (f"{n}*" if n != 1 else "") + f"{_paren(f.frequency)}*t"
            arg += f" + {_paren(phase)}" if phase is not None else ""
            terms.append(f"+{_paren(amp)}*sin({arg})")
        definitions[f.name] = _join(terms)
    if net.base:
        y, om = (_paren(s) for s in net.base)
        definitions["y_base"] = f"{y}*sin({om}*t)"
        definitions["dy_base"] = f"{y}*{om}*cos({om}*t)"
        definitions["ddy_base"] = f"-{y}*{om}**2*sin({om}*t)"
    for x, name in d.hubs.items():
        definitions[name] = d._net_force_text(x)
    energy_terms = [f"+0.5*{_paren(m)}*{v}**2" for m, v, _ in net.masses.values()]
    for s in net.structures.values():
        energy_terms += s.energy_terms()
    for e in net.elements:
        if e.kind == "spring":
            energy_terms.append(f"+0.5*{_paren(e.coef)}*({d.diff(d.pos(e.b), d.pos(e.a))})**2")
    energy_terms += contacts2d.energy_terms(net.contacts)
    definitions["E"] = d.total(energy_terms)
    for e in friction:
        definitions[f"w_{e.name}"] = d.diff(d.vel(e.b), d.vel(e.a))

    # the own mode: masses, the nodes no friction element holds, the quadratures
    equations: dict[str, str] = {}
    own_alg: dict[str, str] = {}
    for x, (_, v, _) in net.masses.items():
        equations[x] = v
        equations[v] = d.acceleration(x)
    for s in net.structures.values():
        own = s.equations({q: d.net_force(q) for q in s.coords if q in d.hubs}, d.total)
        for q, v in zip(s.coords, s.velocities, strict=True):
            equations[q] = own[q]
            definitions[f"acc_{q}"] = own[v]
            equations[v] = f"acc_{q}"
    for u in net.nodes:
        if u not in d.held:
            d._free_node(u, (equations, own_alg))
    power = [f"+{f.name}*{d.vel(f.on)}" for f in net.forces]
    if net.base:
        # power the moving ground puts in: minus (force of the elements on the ground) x ground velocity
        for e in d.touching[GROUND]:
            q = e.b if e.a == GROUND else e.a
            if e.kind == "spring":
                power.append(f"-{_times(e.coef, d.diff(d.pos(q), 'y_base'))}*dy_base")
            elif e.kind == "damper":
                power.append(f"-{_times(e.coef, d.diff(d.vel(q), 'dy_base'))}*dy_base")
            else:
                power.append(f"{'-' if e.a == GROUND else '+'}f_{e.name}*dy_base")
        power += contacts2d.work_on_base(net.contacts)
    equations["W"] = d.total(power)
    dissipation = [f"+f_{e.name}*w_{e.name}" for e in friction] + contacts2d.dissipation_terms(net.contacts)
    for e in net.elements:
        if e.kind == "damper":
            dissipation.append(f"+{_paren(e.coef)}*({d.diff(d.vel(e.b), d.vel(e.a))})**2")
    for s in net.structures.values():
        dissipation += s.dissipation_terms()
    equations["D"] = d.total(dissipation)

    components = [d.component(e) for e in friction]
    components += [contacts2d.contact_component(c, d.pos, d.vel) for c in net.contacts]
    clash = set(d.parts) & taken
    if clash:
        raise ModelError(
            f"the name(s) {', '.join(sorted(clash)[:8])} are generated by the builder (the parts __sumK of long "
            "sums); rename the item(s) in the file"
        )
    definitions.update(d.parts)

    outputs = [f"w_{e.name}" for e in friction] + ["E"] + [f.name for f in net.forces]
    outputs += ["y_base"] if net.base else []
    units = {f"f_{e.name}": "N" for e in friction} | {f"w_{e.name}": "m/s" for e in friction}
    units |= {"E": "J"} | {f.name: "N" for f in net.forces}
    if net.base:
        units["y_base"] = "m"
    shown = list(net.masses) + [q for q in d.coords if q in d.hubs]
    plot: dict = {"displacements": shown[:6], "units": units}
    orbit: dict = {}
    if friction:
        # the figure draws the first element: shade where it sticks (a pattern: every mode of the others)
        first = friction[0]
        shade = f"{OWN_MODE}|stick" + ("|*" if len(friction) > 1 else "")
        plot |= {"force": f"f_{first.name}", "velocity": f"w_{first.name}", "shade_modes": [shade]}
        # the stuck offsets of the elements (the ground counted at 0) select a member of a neutral
        # family of periodic orbits (as the hand-written files' gauges do); where several elements
        # stick at once the family has several dimensions and the orbit solver holds the offsets
        # that fix it best (hybrid.orbits.gauge)
        offsets = list(dict.fromkeys(_offset(e) for e in friction))
        orbit = {"gauge": offsets[0] if len(offsets) == 1 else offsets}
        # the linear references drawn over a frequency response: every contact stuck, every one sliding
        closed = ["stick"] * len(net.contacts)  # the 2-D contacts stuck in both references
        plot["linear_references"] = {
            "linear: all contacts stuck": MODE_SEPARATOR.join(
                [OWN_MODE] + ["stick"] * len(friction) + closed
            ),
            "linear: all contacts sliding": MODE_SEPARATOR.join(
                [OWN_MODE] + ["slip+"] * len(friction) + closed
            ),
        }
    elif net.contacts:
        plot |= contacts2d.plot_hints(net.contacts, OWN_MODE, MODE_SEPARATOR)
    if net.plot is not None:
        # the file's [plot] replaces the derived hints; the linear references are kept unless given
        kept = {"linear_references": plot["linear_references"]} if "linear_references" in plot else {}
        plot = {**kept, **net.plot}
    if net.orbit is not None:
        orbit = dict(net.orbit)
    freqs = {f.frequency for f in net.forces if f.frequency is not None} | (
        {net.base[1]} if net.base else set()
    )
    parameters = []
    for pname, spec in net.parameters.items():
        parameters.append(
            Parameter(
                pname,
                str(spec.get("unit", "")),
                str(spec.get("description", "")),
                str(spec.get("domain", "real")),
            )
        )
    return HybridSystem(
        name=net.name,
        title=net.title,
        reference=net.reference,
        variables=variables,
        parameters=parameters,
        modes=[Mode(OWN_MODE, algebraic=own_alg)],
        transitions=[],
        equations=equations,
        definitions=definitions,
        quadratures=("W", "D"),
        outputs=tuple(outputs),
        period=f"2*pi/{_paren(next(iter(freqs)))}" if len(freqs) == 1 else None,
        initial_mode=OWN_MODE,
        presets=net.presets,
        plot=plot,
        energy={"input": "W", "dissipated": "D", "mechanical": "E"},
        orbit=orbit,
        components=components,
    )
