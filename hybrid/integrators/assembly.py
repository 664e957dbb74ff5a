"""Exact flows of a system with components, assembled per mode from its parts by linear algebra.

The affine analysis (:mod:`hybrid.integrators.affine`) is made once per system on its *parts*:
each own mode (the rows of the variables no component owns, its transitions) and each local mode
of each component (the rows of the variables it owns, its transitions), with the parameters kept
as symbols. A mode of the system is a choice of one local mode per part: its generator is
assembled from the parts' coefficient rows (:func:`hybrid.integrators.affine.assemble_form`: the slave
variables eliminated by a linear solve) when the mode is first entered, with no code generated,
and kept in a bounded cache.
"""

from __future__ import annotations

import numpy as np

from ..core.cache import LRUCache
from ..core.errors import NotAffineError
from ..model.expr import free_symbols, num
from .affine import AffineAnalysis, AffineMode, ModeForm, assemble_form

__all__ = ["ComposedAnalysis", "ComposedFlows", "composed_analysis"]

#: Assembled flows of a system with components kept per parameter set (the most recent).
FLOW_CACHE = 2048


class ComposedAnalysis:
    """The parametric affine analysis of the parts of a system with components.

    Parameters
    ----------
    system : HybridSystem
        A system with components.

    Raises
    ------
    NotAffineError
        Naming the part, the equation and the first non-affine term.
    """

    def __init__(self, system):
        self.system = system
        names = tuple(system.variable_names)
        index = {nm: i for i, nm in enumerate(names)}
        parsed = system.parsed
        parts = []  # (part, local, label, diff_idx, alg_idx, f_expr, g_expr, guards)
        forced = False
        own_out = [[] for _ in system.modes]
        for tr, td in zip(system.transitions, parsed.transitions, strict=True):
            own_out[system.mode_names.index(tr.source)].append((tr.name, td["guard"]))
        for k, m in enumerate(system.modes):
            md = parsed.modes[m.name]
            parts.append((0, k, f"mode `{m.name}`", md, own_out[k]))
        for c, (comp, cd) in enumerate(zip(system.components, parsed.components, strict=True)):
            out = [[] for _ in comp.modes]
            for tr, td in zip(comp.transitions, cd["transitions"], strict=True):
                out[comp.mode_names.index(tr.source)].append((tr.name, td["guard"]))
            for k, m in enumerate(comp.modes):
                parts.append(
                    (1 + c, k, f"component `{comp.name}`, mode `{m.name}`", cd["modes"][m.name], out[k])
                )
        tuples = []
        for _, _, label, md, guards in parts:
            derivs, alg = md["derivatives"], md["algebraic"]
            exprs = [*derivs.values(), *alg.values(), *(g for _, g in guards)]
            forced = forced or any("t" in free_symbols(e) for e in exprs)
            tuples.append(
                (
                    label,
                    names,
                    sorted(index[n] for n in derivs),
                    sorted(index[n] for n in alg),
                    {index[n]: e for n, e in derivs.items()},
                    {index[n]: e for n, e in alg.items()},
                    guards,
                )
            )
        self.analysis = AffineAnalysis(
            tuples, tuple(system.quadratures), tuple(system.parameter_names), forcing=forced
        )
        self.one = self.analysis._pos(num(1.0))  # a guard slot that never fires: the constant 1
        self.form_of: dict[tuple[int, int], int] = {(p, k): j for j, (p, k, *_rest) in enumerate(parts)}
        self.names = names

    def assemble(self, key: tuple[int, ...], vals: np.ndarray, omegas: list, slots) -> tuple:
        """``(omega, d, a, q, M, P, Q, W)`` of the mode ``key`` from the coefficient values.

        ``slots`` is the compiled form's guard layout (``part_slots``, ``slot_of``), so that the
        rows of ``W`` are the mode's guard slots in order (a slot its parts' modes leave unused is
        the constant 1, which never crosses zero).
        """
        forms = [self.analysis.forms[self.form_of[(p, k)]] for p, k in enumerate(key)]
        omega = None
        for f, w in zip(forms, (omegas[self.form_of[(p, k)]] for p, k in enumerate(key)), strict=True):
            if w is None:
                continue
            if omega is None:
                omega = w
            elif not np.isclose(w, omega, rtol=1e-15, atol=0.0):
                raise NotAffineError(f"{f.name} is forced at {w!r} rad/s, another part at {omega!r}")
        d = np.concatenate([f.d for f in forms]).astype(int)
        a = np.concatenate([f.a for f in forms]).astype(int)
        q = np.concatenate([f.q for f in forms]).astype(int)
        od, oa, oq = np.argsort(d), np.argsort(a), np.argsort(q)
        F = np.concatenate([f.F for f in forms])[od]
        G = np.concatenate([f.G for f in forms])[oa]
        Qu = np.concatenate([f.Qu for f in forms])[oq]
        width = forms[0].F.shape[1]
        rows = []
        part_slots, slot_of = slots
        for p, k in enumerate(key):
            form = forms[p]
            for j in range(len(part_slots[p])):
                if j < len(slot_of[p][k]):
                    rows.append(form.Wu[j])
                else:
                    row = np.zeros(width, dtype=int)
                    row[-1] = self.one
                    rows.append(row)
        W = np.array(rows, dtype=int).reshape(len(rows), width)
        merged = ModeForm(self.system.mode_label(key), self.names, d[od], a[oa], q[oq], [], F, G, W, Qu)
        return assemble_form(merged, vals, omega)


def composed_analysis(system) -> ComposedAnalysis:
    """The :class:`ComposedAnalysis` of ``system``, made once and kept with it (NotAffineError,
    also on later calls, where a part is not affine)."""

    def make():
        try:
            return ComposedAnalysis(system)
        except NotAffineError as exc:
            return exc

    hit = system.cache.get("composed_affine_analysis", make)
    if isinstance(hit, NotAffineError):
        raise NotAffineError(str(hit))
    return hit


class ComposedFlows:
    """``exact_flows(cs)`` of a system with components: each mode's :class:`AffineMode` by index,
    assembled when first asked for (at most :data:`FLOW_CACHE` kept)."""

    def __init__(self, cs):
        self.cs = cs
        self.analysis = composed_analysis(cs.system)
        an = self.analysis.analysis
        self.vals, self.omegas = an.coefficients([cs.params[p] for p in an.params])
        self._built = LRUCache(FLOW_CACHE)

    def __getitem__(self, index: int) -> AffineMode:
        am = self._built.get(index)
        if am is None:
            cs = self.cs
            key = cs.key(index)
            flat = self.analysis.assemble(key, self.vals, self.omegas, (cs.form.part_slots, cs.form.slot_of))
            am = AffineMode(cs.modes[index], *flat)
            self._built.put(index, am)
        return am

    def __len__(self) -> int:
        return len(self.cs.modes)

    def __iter__(self):
        return (self[k] for k in range(len(self)))
