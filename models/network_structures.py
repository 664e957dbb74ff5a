"""Linear structures in network files: the ``[structures.NAME]`` tables and their equations.

A network file may hold structures given by matrices (:mod:`hybrid_models.structures`)::

    [structures.beam]
    matrices = "beam20.npz"      # relative to the model file (.npz, .mat, or a directory of .mtx)
    rayleigh = [0.0, 1e-5]       # or modal_damping = [0.01], or a C in the file (one at most)
    reduce = { modes = 6 }       # optional: Craig-Bampton, the attached DOFs as boundary DOFs

Its DOF ``w20`` is addressed ``beam.w20`` wherever a mass can be named (``between`` of springs,
dampers and friction elements, ``on`` of forces). In the system it is the variable ``beam_w20``
[m] with the velocity ``v_beam_w20`` [m/s] (a variable name is an identifier, so the dot becomes
an underscore); a reduced structure's modal coordinates are ``beam_eta1 ...``.

Equations: ``q' = v``, ``v' = M^-1 (N - K q - C v)`` with ``N`` the network's forces on the
attached DOFs (definitions ``net_beam_w20``), written with the numbers of ``-M^-1 K``,
``-M^-1 C`` and ``M^-1`` (``repr``: 17 significant digits), so every mode stays affine and the
exact integrator applies. A full model of ``n`` DOFs writes about ``2 n^2`` coefficients; above
:data:`MAX_INLINE_DOFS` DOFs it is refused with the advice to reduce it.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from hybrid import ModelError
from hybrid.model.loader import model_file, shown_key, shown_value

from .craig_bampton import Reduction, craig_bampton
from .structures import Structure, read_matrices

__all__ = ["MAX_INLINE_DOFS", "NetStructure", "finish_structures", "read_structures"]

#: Most coordinates of a structure in the equations (full, or after reduction).
MAX_INLINE_DOFS = 200
_KEYS = {"matrices", "dofs", "rayleigh", "modal_damping", "reduce", "description"}


@dataclass(frozen=True, eq=False)
class NetStructure:
    """A structure of a network, as it enters the equations.

    Attributes
    ----------
    name : str
    model : Structure
        What enters the equations: the full structure, or its Craig-Bampton reduction.
    full : Structure
        As read.
    reduction : Reduction or None
    coords : tuple of str
        The variable of each coordinate of ``model`` (``NAME_DOF``) [m].
    velocities : tuple of str
        Their velocities (``v_NAME_DOF``) [m/s].
    description : str
    """

    name: str
    model: Structure
    full: Structure
    reduction: Reduction | None
    coords: tuple
    velocities: tuple
    description: str = ""
    #: Name of a parameter ``xi`` [1/s] of an added damping ``- xi M v`` (EPMC,
    #: :mod:`hybrid_models.epmc`): ``M^-1 (xi M v) = xi v`` adds ``+ xi*v_X`` to each acceleration.
    epmc: str | None = None

    def equations(self, net_force: Mapping[str, str], total: Callable[[list[str]], str]) -> dict[str, str]:
        """``{coordinate: velocity, velocity: acceleration}``; ``net_force`` maps the attached
        coordinates to the name of their network force [N]; ``total`` sums signed terms."""
        Minv = np.linalg.inv(self.model.M)
        A, B = -Minv @ self.model.K, -Minv @ self.model.C
        attached = [(k, net_force[c]) for k, c in enumerate(self.coords) if c in net_force]
        out: dict[str, str] = {}
        for i, (q, v) in enumerate(zip(self.coords, self.velocities, strict=True)):
            terms = _terms(A[i], self.coords) + _terms(B[i], self.velocities)
            terms += _terms(np.array([Minv[i, k] for k, _ in attached]), [n for _, n in attached])
            if self.epmc is not None:
                terms.append(f"+{self.epmc}*{v}")
            out[q] = v
            out[v] = total(terms)
        return out

    def energy_terms(self) -> list[str]:
        """Signed terms of ``v'Mv/2 + q'Kq/2`` [J]."""
        return _quadratic(0.5 * self.model.M, self.velocities) + _quadratic(0.5 * self.model.K, self.coords)

    def mass_terms(self) -> list[str]:
        """Signed terms of ``v'Mv`` [J] (twice the kinetic energy)."""
        return _quadratic(self.model.M, self.velocities)

    def dissipation_terms(self) -> list[str]:
        """Signed terms of ``v'Cv`` [W]."""
        return _quadratic(self.model.C, self.velocities)


def _number(c: float, name: str) -> str:
    return f"{'-' if c < 0 else '+'}{abs(float(c))!r}*{name}"


def _terms(row: np.ndarray, names) -> list[str]:
    return [_number(c, n) for c, n in zip(row, names, strict=True) if c != 0.0]


def _quadratic(Q: np.ndarray, names) -> list[str]:
    """Signed terms of ``x' Q x`` (``Q`` symmetric)."""
    out = []
    n = len(names)
    for i in range(n):
        if Q[i, i] != 0.0:
            out.append(_number(Q[i, i], f"{names[i]}**2"))
        for j in range(i + 1, n):
            if Q[i, j] != 0.0:
                out.append(_number(2.0 * Q[i, j], f"{names[i]}*{names[j]}"))
    return out


@dataclass(frozen=True, eq=False)
class _Spec:
    name: str
    structure: Structure
    modes: int | None
    description: str
    where: str


def read_structures(
    table: object, claim: Callable[[str, str], str]
) -> tuple[dict[str, _Spec], dict[str, str]]:
    """Read ``[structures]``: each structure's matrices, checked, and the address of its DOFs.

    Parameters
    ----------
    table : mapping
        The file's ``[structures]`` table.
    claim : callable
        ``claim(name, what)`` reserves a variable name of the model (refusing a name taken).

    Returns
    -------
    specs : dict
        Structure name -> what :func:`finish_structures` needs.
    aliases : dict of str to str
        ``"NAME.DOF"`` -> the variable ``NAME_DOF``.
    """
    if not isinstance(table, Mapping):
        raise ModelError(f"[structures] must be a table, got {shown_value(table)}")
    specs: dict[str, _Spec] = {}
    aliases: dict[str, str] = {}
    home = model_file()
    for name, spec in table.items():
        where = f"[structures.{shown_key(name)}]"
        if not isinstance(spec, Mapping):
            raise ModelError(f"{where} must be a table, got {shown_value(spec)}")
        extra = set(spec) - _KEYS
        if extra:
            raise ModelError(
                f"{where}: unknown key(s) {', '.join(sorted(map(str, extra))[:5])}; allowed: {', '.join(sorted(_KEYS))}"
            )
        if "matrices" not in spec:
            raise ModelError(f'{where} lacks `matrices` (a file: matrices = "beam.npz")')
        claim(name, where)
        damping = {k: spec[k] for k in ("rayleigh", "modal_damping") if k in spec}
        dofs = spec.get("dofs")
        if dofs is not None and not (isinstance(dofs, list) and all(isinstance(d, str) for d in dofs)):
            raise ModelError(f"{where} `dofs` must be a list of names, got {shown_value(dofs)}")
        src = spec["matrices"]
        if isinstance(src, Structure):  # from Python
            s = src
            if dofs is not None or damping:
                s = Structure.from_arrays(
                    s.M, s.K, dofs or s.dofs, None if damping else s.C, source=where, **damping
                )
        elif isinstance(src, str) and src.strip():
            path = Path(src)
            if not path.is_absolute() and home is not None:
                path = home.parent / path
            s = read_matrices(path, dofs=dofs, where=where, **damping)
        else:
            raise ModelError(
                f"{where} `matrices` must be a file name (.npz, .mat, or a directory of .mtx files; relative "
                f"to the model file) or, from Python, a Structure; got {shown_value(src)}"
            )
        modes = None
        if "reduce" in spec:
            red = spec["reduce"]
            if not isinstance(red, Mapping) or set(red) != {"modes"}:
                raise ModelError(
                    f"{where} `reduce` must be {{ modes = N }} (Craig-Bampton), got {shown_value(red)}"
                )
            modes = red["modes"]
            if isinstance(modes, bool) or not isinstance(modes, int) or modes < 0:
                raise ModelError(
                    f"{where} `reduce` `modes` must be an integer >= 0, got {shown_value(modes)}"
                )
        desc = spec.get("description", "")
        if not isinstance(desc, str):
            raise ModelError(f"{where} `description` must be a string")
        for d in s.dofs:
            var = claim(f"{name}_{d}", f"{where} DOF `{d}` (variable {name}_{d})")
            claim(f"v_{var}", f"{where} DOF `{d}` (velocity v_{var})")
            aliases[f"{name}.{d}"] = var
        specs[name] = _Spec(name, s, modes, desc, where)
    return specs, aliases


def finish_structures(
    specs: Mapping[str, _Spec], attached: set[str], claim: Callable[[str, str], str]
) -> dict[str, NetStructure]:
    """The structures as they enter the equations: reduced (``reduce``) to the attached DOFs.

    Parameters
    ----------
    specs : mapping
        From :func:`read_structures`.
    attached : set of str
        The variables (``NAME_DOF``) that elements or forces attach to.
    claim : callable
        As for :func:`read_structures` (the modal coordinates' names are reserved here).
    """
    out: dict[str, NetStructure] = {}
    for name, sp in specs.items():
        reduction = None
        model = sp.structure
        if sp.modes is not None:
            boundary = [d for d in sp.structure.dofs if f"{name}_{d}" in attached]
            reduction = craig_bampton(sp.structure, boundary, sp.modes, where=sp.where)
            model = reduction.structure
            for d in model.dofs[len(boundary) :]:
                claim(f"{name}_{d}", f"{sp.where} modal coordinate `{d}`")
                claim(f"v_{name}_{d}", f"{sp.where} modal coordinate `{d}` (velocity)")
        if model.n > MAX_INLINE_DOFS:
            raise ModelError(
                f"{sp.where}: {model.n} coordinates; at most {MAX_INLINE_DOFS} enter the equations (each "
                "acceleration is written with its coefficients); reduce it: reduce = { modes = 6 }"
            )
        coords = tuple(f"{name}_{d}" for d in model.dofs)
        out[name] = NetStructure(
            name, model, sp.structure, reduction, coords, tuple(f"v_{c}" for c in coords), sp.description
        )
    return out


def describe_structures(structures: Mapping[str, NetStructure], count: int = 6) -> list[str]:
    """Lines describing each structure (and its reduction's frequencies against the full model's)."""
    lines = []
    for s in structures.values():
        head = f"  structure {s.name}: {s.full.n} DOFs from {s.full.source}"
        if s.description:
            head += f"  ({s.description})"
        lines.append(head)
        if s.reduction is not None:
            r = s.reduction
            lines.append(
                f"    Craig-Bampton: {len(r.boundary)} boundary DOFs ({', '.join(r.boundary[:8])}) + "
                f"{r.modes} fixed-interface modes"
            )
            lines.append(
                "    natural frequencies of the free structure [rad/s]: full, reduced, relative error"
            )
            for k, (wf, wr, e) in enumerate(r.frequencies(count), start=1):
                lines.append(f"      {k:>2}  {wf:14.6g}  {wr:14.6g}  {e:10.2e}")
        else:
            w = s.full.frequencies(count)
            lines.append(
                "    natural frequencies of the free structure [rad/s]: " + ", ".join(f"{x:.6g}" for x in w)
            )
    return lines
