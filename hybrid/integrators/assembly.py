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
import scipy.sparse as sp
import scipy.sparse.linalg as spla

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
        self._sparse_parts: dict[int, _SparsePart] = {}
        self.names = names

    def _omega(self, key, omegas, forms) -> float | None:
        """The forcing frequency of the mode ``key`` (NotAffineError if its parts differ)."""
        omega = None
        for f, w in zip(forms, (omegas[self.form_of[(p, k)]] for p, k in enumerate(key)), strict=True):
            if w is None:
                continue
            if omega is None:
                omega = w
            elif not np.isclose(w, omega, rtol=1e-15, atol=0.0):
                raise NotAffineError(f"{f.name} is forced at {w!r} rad/s, another part at {omega!r}")
        return omega

    def assemble_sparse(self, key: tuple[int, ...], vals: np.ndarray, omegas: list, slots) -> tuple:
        """As :meth:`assemble`, with sparse matrices (:func:`assemble_sparse`)."""
        idx = [self.form_of[(p, k)] for p, k in enumerate(key)]
        forms = [self.analysis.forms[i] for i in idx]
        omega = self._omega(key, omegas, forms)
        parts = []
        for i in idx:
            sp_part = self._sparse_parts.get(i)
            if sp_part is None:
                sp_part = self._sparse_parts[i] = _SparsePart(self.analysis.forms[i])
            parts.append(sp_part)
        return assemble_sparse(
            parts, key, self.system.mode_label(key), self.names, vals, omega, slots, self.one
        )

    def assemble(self, key: tuple[int, ...], vals: np.ndarray, omegas: list, slots) -> tuple:
        """``(omega, d, a, q, M, P, Q, W)`` of the mode ``key`` from the coefficient values.

        ``slots`` is the compiled form's guard layout (``part_slots``, ``slot_of``), so that the
        rows of ``W`` are the mode's guard slots in order (a slot its parts' modes leave unused is
        the constant 1, which never crosses zero).
        """
        forms = [self.analysis.forms[self.form_of[(p, k)]] for p, k in enumerate(key)]
        omega = self._omega(key, omegas, forms)
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
    """``exact_flows(cs)`` of a system with components: each mode's :class:`AffineMode` by index (the
    indices ``cs`` gives its modes), assembled when first asked for (at most :data:`FLOW_CACHE`
    kept), at ``cs``'s parameters or at ``params``."""

    def __init__(self, cs, params=None):
        self.cs = cs
        self.analysis = composed_analysis(cs.system)
        an = self.analysis.analysis
        params = cs.params if params is None else params
        self.vals, self.omegas = an.coefficients([params[p] for p in an.params])
        self._built = LRUCache(FLOW_CACHE)
        # the size of the state decides the path (dense with eigen-decompositions, or sparse)
        self.sparse = len(cs.names) + 3 > DENSE_LIMIT

    def __getitem__(self, index: int) -> AffineMode:
        am = self._built.get(index)
        if am is None:
            cs = self.cs
            key = cs.key(index)
            slots = (cs.form.part_slots, cs.form.slot_of)
            if self.sparse:
                flat = self.analysis.assemble_sparse(key, self.vals, self.omegas, slots)
                am = SparseAffineMode(cs.modes[index], *flat)
            else:
                flat = self.analysis.assemble(key, self.vals, self.omegas, slots)
                am = AffineMode(cs.modes[index], *flat)
            self._built.put(index, am)
        return am

    def __len__(self) -> int:
        return len(self.cs.modes)

    def __iter__(self):
        return (self[k] for k in range(len(self)))


# ----------------------------------------------------------------------------------------------
# Large systems: sparse assembly
# ----------------------------------------------------------------------------------------------
#: Augmented states larger than this are assembled as sparse matrices and integrated by the Taylor
#: series of the flow (:class:`hybrid.integrators.exact.TaylorModeSolver`); smaller ones densely,
#: with the eigen-decomposition of :class:`hybrid.integrators.flow.Flow`.
DENSE_LIMIT = 64


def _triplets(idx: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The positions ``(row, col)`` of the coefficients of an index array that are not the constant
    zero (index 0 of the analysis' values), and their indices."""
    r, c = np.nonzero(idx)
    return r, c, idx[r, c]


class _SparsePart:
    """One part's coefficient rows as triplets (made once per part)."""

    def __init__(self, form: ModeForm):
        self.form = form
        self.F = _triplets(form.F)
        self.G = _triplets(form.G)
        self.W = _triplets(form.Wu)
        self.Q = [_triplets(Qj) for Qj in form.Qu]


class SparseAffineMode(AffineMode):
    """An :class:`AffineMode` whose matrices are sparse (``scipy.sparse.csr_array``; ``Q`` a list
    of them): the mode of a large system with components. ``flow()`` and :meth:`dense` give the
    dense form where an eigen-decomposition is wanted (a monodromy matrix)."""

    def dense(self) -> AffineMode:
        """The same mode with dense matrices (made once)."""
        hit = self.__dict__.get("_dense")
        if hit is None:
            Q = np.array([Qj.toarray() for Qj in self.Q]).reshape(len(self.Q), self.nz, self.nz)
            hit = self.__dict__["_dense"] = AffineMode(
                self.cm,
                self.omega,
                self.d,
                self.a,
                self.q,
                self.M.toarray(),
                self.P.toarray(),
                Q,
                self.W.toarray(),
            )
        return hit

    def flow(self):
        return self.dense().flow()

    def guard_series(self, k: int, t: float, y: np.ndarray, order: int) -> np.ndarray:
        z = self.augment(t, y)
        row = self.W[[k]]
        out = np.empty(order + 1)
        for j in range(order + 1):
            out[j] = float((row @ z)[0])
            z = (self.M @ z) / (j + 1)
        return out

    def quadratic(self, z: np.ndarray, w: np.ndarray) -> np.ndarray:
        """``z^T Q_j w`` for every quadrature ``j``."""
        return np.array([z @ (Qj @ w) for Qj in self.Q])

    def derivatives(self, z: np.ndarray) -> np.ndarray:
        yp = self.P @ (self.M @ z)
        if self.q.size:
            yp[self.q] = self.quadratic(z, z)
        return yp

    def second_derivatives(self, z: np.ndarray) -> np.ndarray:
        mz = self.M @ z
        ypp = self.P @ (self.M @ mz)
        if self.q.size:
            ypp[self.q] = self.quadratic(z, mz) + self.quadratic(mz, z)
        return ypp


def assemble_sparse(
    parts: list[_SparsePart], key, label: str, names, vals: np.ndarray, omega, slots, one: int
):
    """``(omega, d, a, q, M, P, Q, W)`` of a mode, sparse: the parts' rows stacked, the slave
    variables eliminated by a sparse LU factorisation (``M`` keeps the sparsity of the couplings)."""
    n = len(names)
    forms = [p.form for p in parts]
    nf = 2 if omega is not None else 0
    d = np.concatenate([f.d for f in forms]).astype(int)
    a = np.concatenate([f.a for f in forms]).astype(int)
    q = np.concatenate([f.q for f in forms]).astype(int)
    width = forms[0].F.shape[1]  # nu + 1 (u = [y, S, C, 1], S and C where some part is forced)
    pos_d = np.empty(n, dtype=int)
    pos_d[np.sort(d)] = np.arange(d.size)
    pos_a = np.empty(n, dtype=int)
    pos_a[np.sort(a)] = np.arange(a.size)

    def stack(which: str, pos: np.ndarray, rows_of) -> sp.csr_array:
        r, c, v = [], [], []
        for p in parts:
            rr, cc, ii = getattr(p, which)
            local = rows_of(p.form)
            r.append(pos[local[rr]])
            c.append(cc)
            v.append(vals[ii])
        size = sum(len(rows_of(f)) for f in forms)
        return sp.csr_array((np.concatenate(v), (np.concatenate(r), np.concatenate(c))), shape=(size, width))

    F = stack("F", pos_d, lambda f: f.d)
    G = stack("G", pos_a, lambda f: f.a)
    ds = np.sort(d)
    nz = ds.size + nf + 1
    # u from z: differential variables are z's first entries, S and C (if any) next, then 1.
    ident_r = np.concatenate([ds, n + np.arange(nf), [width - 1]])
    ident_c = np.concatenate([np.arange(ds.size), ds.size + np.arange(nf), [nz - 1]])
    rest = sp.csr_array((np.ones(ident_r.size), (ident_r, ident_c)), shape=(width, nz))
    Pu = rest
    if a.size:
        as_ = np.sort(a)
        Ga = G[:, as_].tocsc()
        try:
            lu = spla.splu(Ga)
        except RuntimeError:
            raise NotAffineError(
                f"{label}: the algebraic equations are singular in the slave variables"
            ) from None
        X = -lu.solve((G @ rest).toarray())
        if not np.all(np.isfinite(X)):
            raise NotAffineError(f"{label}: the algebraic equations are singular in the slave variables")
        X[np.abs(X) < 1e-300] = 0.0
        Xs = sp.csr_array(X)
        slave = sp.csr_array((np.ones(as_.size), (as_, np.arange(as_.size))), shape=(width, as_.size))
        Pu = rest + slave @ Xs
    Md = sp.coo_array(F @ Pu)
    rows, cols, data = [Md.row], [Md.col], [Md.data]
    if omega is not None:
        k = ds.size
        rows.append(np.array([k, k + 1]))  # S' = w C, C' = -w S
        cols.append(np.array([k + 1, k]))
        data.append(np.array([omega, -omega]))
    M = sp.csr_array((np.concatenate(data), (np.concatenate(rows), np.concatenate(cols))), shape=(nz, nz))
    # guard slots in order: the parts' transitions, the constant 1 where a part leaves a slot unused
    part_slots, slot_of = slots
    wr, wc, wv = [], [], []
    row = 0
    for p_index, (p, k) in enumerate(zip(parts, key, strict=True)):
        rr, cc, ii = p.W
        used = len(slot_of[p_index][k])
        for j in range(len(part_slots[p_index])):
            if j < used:
                sel = rr == j
                wr.append(np.full(int(sel.sum()), row))
                wc.append(cc[sel])
                wv.append(vals[ii[sel]])
            else:
                wr.append(np.array([row]))
                wc.append(np.array([width - 1]))
                wv.append(np.array([vals[one]]))
            row += 1
    Wu = sp.csr_array(
        (
            np.concatenate(wv) if wv else np.zeros(0),
            (np.concatenate(wr) if wr else np.zeros(0, int), np.concatenate(wc) if wc else np.zeros(0, int)),
        ),
        shape=(row, width),
    )
    W = sp.csr_array(Wu @ Pu)
    Q = []
    for p in parts:
        for rr, cc, ii in p.Q:
            Qu = sp.csr_array((vals[ii], (rr, cc)), shape=(width, width))
            Q.append(sp.csr_array(Pu.T @ Qu @ Pu))
    order = np.argsort(q)
    Q = [Q[i] for i in order]
    P = sp.csr_array(Pu[:n])
    return omega, ds, np.sort(a), np.sort(q), M, P, Q, W
