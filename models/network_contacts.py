"""Two-dimensional contacts of network files: normal load, lift-off and an elastic Coulomb slider.

A ``[contacts.NAME]`` table of a network file (``docs/models.md``, "Contacts with normal load and
lift-off") joins two pairs of points: the *tangential* pair ``[A, B]`` (relative tangential
displacement ``x = B - A`` [m]) and the *normal* pair ``[C, D]`` (gap ``g = D - C`` [m], ``g > 0``
separates). Its forces are

* the normal force ``N = N0 - kn g`` while closed (``g < N0/kn``), ``0`` while open, pushing the two
  normal ends apart (``+N`` on ``D``, ``-N`` on ``C``);
* the tangential force of a Jenkins element (a spring ``kt`` in series with a massless Coulomb slider
  at ``w``): ``T = kt (x - w)`` with ``|T| <= mu N`` (``-T`` on ``B``, ``+T`` on ``A``), zero while open.

It is one component of the system with the local modes ``open``, ``stick``, ``slip+``, ``slip-``;
each is affine in the state (``mu N = mu N0 - mu kn g``), so the exact integrator applies. It owns
four variables: the slider position ``s_NAME`` (= ``w`` [m], differential while it sticks, a slave
variable otherwise), its velocity ``vs_NAME`` [m/s], and the forces ``T_NAME``, ``N_NAME`` [N]
(slave variables). Per mode::

    open    N = 0,  T = 0,  w = x,  w' = x'
    stick   N = N0 - kn g,  T = kt (x - w),  w' = 0
    slip+   N = N0 - kn g,  T = +mu N,  w = x - mu N/kt,  w' = x' + mu kn g'/kt
    slip-   N = N0 - kn g,  T = -mu N,  w = x + mu N/kt,  w' = x' - mu kn g'/kt

and the guards: ``close`` (open -> stick, ``N0 - kn g`` rising through 0; the slider starts at the
closing position, ``T = 0``; if ``kt |x'| > mu kn (-g')`` the tangential force leaves the growing cone at
once and the event loop passes on to slip in the same instant, decided by the vector field),
``open`` (closed -> open, ``N0 - kn g`` falling through 0), ``slip+``/``slip-`` (stick -> slip,
``T -+ mu N`` crossing 0 outwards), ``stop+``/``stop-`` (slip -> stick, ``w'`` crossing 0). The
derivation is in ``docs/theory.md``. The energy stored in the contact, ``T^2/(2 kt) + N^2/(2 kn)``,
is part of the mechanical energy ``E``; the power ``T w'`` is dissipated (``D``).
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from dataclasses import dataclass

from hybrid import Mode, ModelError, Transition, Variable
from hybrid.model.elements import Component
from hybrid.model.loader import shown_key, shown_value

__all__ = ["CONTACT_STATES", "MAX_CONTACTS", "Contact", "contact_component", "read_contacts"]

#: Local modes of a contact.
CONTACT_STATES = ("stick", "slip+", "slip-", "open")
#: Most contacts in one network (each a component with four variables).
MAX_CONTACTS = 3000
#: Keys of a contact table: required, optional.
CONTACT_KEYS = (
    {"tangential", "normal", "preload", "normal_stiffness", "tangential_stiffness", "mu"},
    {"description"},
)


@dataclass(frozen=True)
class Contact:
    """A 2-D contact of a network (see the module docstring).

    Attributes
    ----------
    name : str
        Key of the contact in ``[contacts]``.
    tangential, normal : tuple of (str, str)
        The ends ``(A, B)`` of the tangential displacement ``x = B - A`` and ``(C, D)`` of the gap
        ``g = D - C`` [m]: masses, structures' DOFs (their variables ``NAME_DOF``) or ``"ground"``.
    preload : str
        ``N0`` [N], the normal force at ``g = 0`` (the contact opens at ``g = N0/kn``).
    kn, kt : str
        Normal and tangential stiffness [N/m] (> 0).
    mu : str
        Friction coefficient [-] (> 0).
    """

    name: str
    tangential: tuple
    normal: tuple
    preload: str
    kn: str
    kt: str
    mu: str

    def names(self) -> dict[str, str]:
        """The variables the contact owns: role -> name."""
        return {
            "slider": f"s_{self.name}",
            "velocity": f"vs_{self.name}",
            "T": f"T_{self.name}",
            "N": f"N_{self.name}",
        }


def read_contacts(
    table: Mapping,
    *,
    masses: Mapping,
    nodes: Mapping,
    params: Mapping[str, str],
    loc: Callable[[str, object], str],
    claim: Callable[..., str],
    coef: Callable[[object, Mapping, str], str],
    positive: Callable[..., None],
    check_keys: Callable[..., Mapping],
    dofs: Mapping[str, str] | None = None,
) -> tuple[Contact, ...]:
    """Validate the ``[contacts]`` table of a network file (the reader's helpers passed in).

    ``dofs`` maps the address of each structure's DOF (``"blade.x5"``) to its variable
    (``"blade_x5"``): a contact's end may be such a DOF (its forces then enter the structure's
    accelerations through the columns of ``M^-1``, :mod:`hybrid_models.network_structures`).

    Raises
    ------
    ModelError
        Naming the contact and the key: a missing or unknown key, an end that is not a mass, a
        structure's DOF or the ground (a structure's DOF that does not exist: the message lists that
        structure's DOFs), the same pair twice, a stiffness or friction coefficient that is not > 0.
    """
    dofs = dofs or {}
    variables = set(dofs.values())
    if len(table) > MAX_CONTACTS:
        raise ModelError(
            f"[contacts]: {len(table)} contacts; at most {MAX_CONTACTS} are allowed (each is a component of "
            "the system with four variables)"
        )
    out = []
    for name, spec in table.items():
        where = loc("contacts", name)
        spec = check_keys(spec, *CONTACT_KEYS, where)
        claim(name, where, element=True)
        pairs = {}
        for key in ("tangential", "normal"):
            ends = spec[key]
            if not (isinstance(ends, list) and len(ends) == 2 and all(isinstance(e, str) for e in ends)):
                raise ModelError(
                    f"{where} `{key}` must be a list of two names [A, B] (the displacement B - A), got "
                    f"{shown_value(ends)}"
                )
            ends = [dofs.get(e, e) for e in ends]  # a structure's DOF: NAME.DOF -> NAME_DOF
            for end in ends:
                if end in nodes:
                    raise ModelError(
                        f"{where} `{key}`: `{end}` is a massless node; a contact's ends are masses or ground "
                        "(its forces enter their momentum balances): put a mass there"
                    )
                if end != "ground" and end not in masses and end not in variables:
                    raise ModelError(f"{where} `{key}`: {unknown_end(end, masses, dofs)}")
            if ends[0] == ends[1]:
                raise ModelError(f"{where} `{key}`: both ends are `{ends[0]}`")
            pairs[key] = (ends[0], ends[1])
        if set(pairs["tangential"]) == set(pairs["normal"]):
            raise ModelError(
                f"{where}: `tangential` and `normal` join the same two points; they are two different "
                'displacements (e.g. tangential = ["ground", "x"], normal = ["ground", "y"])'
            )
        got = {
            k: coef(spec[k], params, f"{where} `{k}`")
            for k in ("preload", "normal_stiffness", "tangential_stiffness", "mu")
        }
        positive(got["normal_stiffness"], params, f"{where} `normal_stiffness`", "a normal stiffness")
        positive(
            got["tangential_stiffness"], params, f"{where} `tangential_stiffness`", "a tangential stiffness"
        )
        positive(got["mu"], params, f"{where} `mu`", "a friction coefficient")
        desc = spec.get("description", "")
        if not isinstance(desc, str):
            raise ModelError(f"{where} `description` must be a string")
        out.append(
            Contact(
                name,
                pairs["tangential"],
                pairs["normal"],
                got["preload"],
                got["normal_stiffness"],
                got["tangential_stiffness"],
                got["mu"],
            )
        )
    return tuple(out)


def unknown_end(end: str, masses: Mapping, dofs: Mapping[str, str]) -> str:
    """What is wrong with an end that is neither a mass, a structure's DOF nor the ground: for
    ``S.X`` with ``S`` a structure, the DOFs ``S`` has; else the masses and structures there are."""
    structures: dict[str, list[str]] = {}
    for address in dofs:
        s, _, d = address.partition(".")
        structures.setdefault(s, []).append(d)
    head, dot, tail = end.partition(".")
    if dot and head in structures:
        have = structures[head]
        shown = ", ".join(have[:24]) + (f", ... ({len(have) - 24} more)" if len(have) > 24 else "")
        return (
            f"structure `{head}` has no DOF `{shown_key(tail)}`; its DOFs: {shown} "
            f"(address one as {head}.{have[0]})"
        )
    msg = f"unknown end `{shown_key(end)}`; a contact's ends are masses ({', '.join(list(masses)[:12]) or 'none'})"
    if structures:
        msg += f", structures' DOFs (NAME.DOF; structures: {', '.join(list(structures)[:12])})"
    return msg + " or ground"


def _p(text: str) -> str:
    """``text`` as a factor: a bare name or number as it is, else in parentheses."""
    return text if text.replace("_", "a").replace(".", "0").isalnum() else f"({text})"


def _rel(b: str, a: str) -> str:
    """``b - a`` as a factor (``"0"``, the fixed ground, dropped)."""
    if a == "0":
        return _p(b)
    return _p(f"-{_p(a)}" if b == "0" else f"{b} - {_p(a)}")


def force_terms(contacts: tuple[Contact, ...]) -> dict[str, list[str]]:
    """Signed force terms of the contacts on each mass they touch (``T`` on the tangential ends,
    ``N`` on the normal ends)."""
    out: dict[str, list[str]] = {}
    for c in contacts:
        n = c.names()
        (ta, tb), (na, nb) = c.tangential, c.normal
        out.setdefault(ta, []).append(f"+{n['T']}")
        out.setdefault(tb, []).append(f"-{n['T']}")
        out.setdefault(na, []).append(f"-{n['N']}")
        out.setdefault(nb, []).append(f"+{n['N']}")
    out.pop("ground", None)
    return out


def contact_component(c: Contact, pos: Callable[[str], str], vel: Callable[[str], str]) -> Component:
    """The component of contact ``c`` (``pos``, ``vel``: text of a point's position and velocity)."""
    n = c.names()
    s, vs, T, N = n["slider"], n["velocity"], n["T"], n["N"]
    x = _rel(pos(c.tangential[1]), pos(c.tangential[0]))
    vx = _rel(vel(c.tangential[1]), vel(c.tangential[0]))
    g = _rel(pos(c.normal[1]), pos(c.normal[0]))
    vg = _rel(vel(c.normal[1]), vel(c.normal[0]))
    N0, kn, kt, mu = (_p(v) for v in (c.preload, c.kn, c.kt, c.mu))
    closed_N = f"{N} - ({N0} - {kn}*{g})"
    rate = f"{mu}*{kn}*{vg}/{kt}"  # the slider's velocity relative to x' while it slips
    modes = [
        Mode("stick", derivatives={s: "0"}, algebraic={vs: vs, N: closed_N, T: f"{T} - {kt}*({x} - {s})"}),
        Mode(
            "slip+",
            algebraic={
                N: closed_N,
                T: f"{T} - {mu}*{N}",
                s: f"{s} - {x} + {T}/{kt}",
                vs: f"{vs} - {vx} - {rate}",
            },
        ),
        Mode(
            "slip-",
            algebraic={
                N: closed_N,
                T: f"{T} + {mu}*{N}",
                s: f"{s} - {x} + {T}/{kt}",
                vs: f"{vs} - {vx} + {rate}",
            },
        ),
        Mode("open", algebraic={N: N, T: T, s: f"{s} - {x}", vs: f"{vs} - {vx}"}),
    ]
    load = f"{N0} - {kn}*{g}"  # the normal force the closed contact would carry
    transitions = [
        Transition("open", "stick", load, 1, name="close"),
        Transition("stick", "slip+", f"{T} - {mu}*{N}", 1, name="slip+"),
        Transition("stick", "slip-", f"{T} + {mu}*{N}", -1, name="slip-"),
        Transition("slip+", "stick", vs, -1, name="stop+"),
        Transition("slip-", "stick", vs, 1, name="stop-"),
    ]
    transitions += [
        Transition(m, "open", load, -1, name=f"open_from_{m}") for m in ("stick", "slip+", "slip-")
    ]
    return Component(
        c.name,
        modes=modes,
        transitions=transitions,
        initial_mode="stick",
        description=(
            f"2-D contact {c.name}: tangential {c.tangential[1]} - {c.tangential[0]}, "
            f"normal {c.normal[1]} - {c.normal[0]}"
        ),
    )


def energy_terms(contacts: tuple[Contact, ...]) -> list[str]:
    """Energy stored in the contacts [J]: ``T^2/(2 kt) + N^2/(2 kn)`` each."""
    out = []
    for c in contacts:
        n = c.names()
        out.append(f"+0.5*{n['T']}**2/{_p(c.kt)}")
        out.append(f"+0.5*{n['N']}**2/{_p(c.kn)}")
    return out


def dissipation_terms(contacts: tuple[Contact, ...]) -> list[str]:
    """Power dissipated by the sliders [W]: ``T w'`` each."""
    return [f"+{c.names()['T']}*{c.names()['velocity']}" for c in contacts]


def work_on_base(contacts: tuple[Contact, ...]) -> list[str]:
    """Power a moving ground puts into the contacts [W] (terms over ``dy_base``)."""
    out = []
    for c in contacts:
        n = c.names()
        if c.tangential[0] == "ground":
            out.append(f"-{n['T']}*dy_base")
        if c.tangential[1] == "ground":
            out.append(f"+{n['T']}*dy_base")
        if c.normal[0] == "ground":
            out.append(f"+{n['N']}*dy_base")
        if c.normal[1] == "ground":
            out.append(f"-{n['N']}*dy_base")
    return out


def generated_names(contacts: tuple[Contact, ...]) -> set[str]:
    """Names the contacts add to the model."""
    return {v for c in contacts for v in c.names().values()}


def variables(contacts: tuple[Contact, ...]) -> list:
    """The contacts' variables (slider, its velocity, the forces)."""
    out = []
    for c in contacts:
        n = c.names()
        out += [
            Variable(n["slider"], "m", f"slider of contact {c.name} (w; equal to x while open)"),
            Variable(n["velocity"], "m/s", f"velocity of the slider of contact {c.name} (a slave variable)"),
            Variable(
                n["T"], "N", f"tangential force of contact {c.name} (kt (x - w); on the first tangential end)"
            ),
            Variable(n["N"], "N", f"normal force of contact {c.name} (N0 - kn g while closed, 0 open)"),
        ]
    return out


def plot_hints(contacts: tuple[Contact, ...], own: str, sep: str) -> dict:
    """Plot hints of a network whose only components are contacts: the first contact's tangential
    force against its slider velocity, stick shaded, and the linear references stuck and open."""
    first = contacts[0].names()
    rest = "|*" if len(contacts) > 1 else ""
    return {
        "force": first["T"],
        "velocity": first["velocity"],
        "shade_modes": [f"{own}{sep}stick{rest}"],
        "linear_references": {
            "linear: all contacts stuck": sep.join([own] + ["stick"] * len(contacts)),
            "linear: all contacts open": sep.join([own] + ["open"] * len(contacts)),
        },
    }
