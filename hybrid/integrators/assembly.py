"""Exact flows of a system with components, assembled per mode from its parts by linear algebra.

The affine analysis (:mod:`hybrid.integrators.affine`) is made once per system on its *parts*:
each own mode (the rows of the variables no component owns, its transitions) and each local mode
of each component (the rows of the variables it owns, its transitions), with the parameters kept
as symbols. A mode of the system is a choice of one local mode per part: its generator is
assembled from the parts' coefficient rows (:func:`hybrid.integrators.affine.assemble_form`: the slave
variables eliminated by a linear solve) when the mode is first entered, with no code generated,
and kept in a bounded cache.

A forcing that is a sum of harmonics (:mod:`hybrid.integrators.affine`) gives every part the same
``u``: the ``S, C`` pairs of every group of forcing rates that occurs in any part (the analysis is
made with ``forcing=True``); a mode's ``z`` holds one pair ``S_n, C_n`` per multiple ``n`` of the
base frequency, as :meth:`AffineAnalysis.coefficients` gives them for its forced parts.
"""

from __future__ import annotations

from dataclasses import dataclass, field

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

    def _omega(self, key, coeffs, forms) -> tuple:
        """The forcing of the mode ``key``: its base frequency (NotAffineError if its parts differ),
        harmonics and pairs (:func:`hybrid.integrators.affine.assemble_form`; every part has the
        same ``u``, so every forced part the same harmonics and pairs)."""
        _vals, omegas, harmonics, pairs = coeffs
        omega, harm, pair = None, (1,), [0] * len(forms[0].groups)
        for f, i in zip(forms, (self.form_of[(p, k)] for p, k in enumerate(key)), strict=True):
            w = omegas[i]
            if w is None:
                continue
            if omega is None:
                omega, harm, pair = w, harmonics[i], pairs[i]
            elif not np.isclose(w, omega, rtol=1e-15, atol=0.0):
                raise NotAffineError(f"{f.name} is forced at {w!r} rad/s, another part at {omega!r}")
        return omega, harm, pair

    def assemble_sparse(self, key: tuple[int, ...], coeffs: tuple, slots) -> tuple:
        """As :meth:`assemble`, with sparse matrices (:func:`assemble_sparse`)."""
        idx = [self.form_of[(p, k)] for p, k in enumerate(key)]
        forms = [self.analysis.forms[i] for i in idx]
        omega, harmonics, pairs = self._omega(key, coeffs, forms)
        parts = []
        part_slots, slot_of = slots
        for p, (i, k) in enumerate(zip(idx, key, strict=True)):
            sp_part = self._sparse_parts.get(i)
            if sp_part is None:
                sp_part = self._sparse_parts[i] = _SparsePart(
                    self.analysis.forms[i], part_slots[p], len(slot_of[p][k]), self.one
                )
            parts.append(sp_part)
        return assemble_sparse(
            parts, self.system.mode_label(key), self.names, coeffs[0], omega, part_slots, harmonics, pairs
        )

    def assemble(self, key: tuple[int, ...], coeffs: tuple, slots) -> tuple:
        """``(omega, d, a, q, M, P, Q, W, harmonics)`` of the mode ``key`` from the coefficient
        values ``coeffs`` (:meth:`hybrid.integrators.affine.AffineAnalysis.coefficients`).

        ``slots`` is the compiled form's guard layout (``part_slots``, ``slot_of``), so that the
        rows of ``W`` are the mode's guard slots in order (a slot its parts' modes leave unused is
        the constant 1, which never crosses zero).
        """
        forms = [self.analysis.forms[self.form_of[(p, k)]] for p, k in enumerate(key)]
        omega, harmonics, pairs = self._omega(key, coeffs, forms)
        vals = coeffs[0]
        d = np.concatenate([f.d for f in forms]).astype(int)
        a = np.concatenate([f.a for f in forms]).astype(int)
        q = np.concatenate([f.q for f in forms]).astype(int)
        od, oa, oq = np.argsort(d), np.argsort(a), np.argsort(q)
        F = sp.vstack([f.F for f in forms], format="csr")[od]
        G = sp.vstack([f.G for f in forms], format="csr")[oa]
        Qu = [Qj for f in forms for Qj in f.Qu]
        Qu = [Qu[j] for j in oq]
        width = forms[0].F.shape[1]
        rows = []
        part_slots, slot_of = slots
        for p, k in enumerate(key):
            form = forms[p]
            for j in range(len(part_slots[p])):
                if j < len(slot_of[p][k]):
                    rows.append(form.Wu[[j]])
                else:
                    rows.append(
                        sp.csr_array(([self.one], ([0], [width - 1])), shape=(1, width), dtype=np.int64)
                    )
        W = sp.vstack(rows, format="csr") if rows else sp.csr_array((0, width), dtype=np.int64)
        merged = ModeForm(
            self.system.mode_label(key), self.names, d[od], a[oa], q[oq], [], forms[0].groups, F, G, W, Qu
        )
        return assemble_form(merged, vals, omega, harmonics, pairs)


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
        self.coeffs = an.coefficients([params[p] for p in an.params])
        self._built = LRUCache(FLOW_CACHE)
        # small states take the dense path (eigen-decompositions); larger ones are assembled sparse,
        # and each mode then takes the cheaper path by :func:`dense_is_cheaper`
        self.sparse = len(cs.names) + 3 > DENSE_LIMIT

    def __getitem__(self, index: int) -> AffineMode:
        am = self._built.get(index)
        if am is None:
            cs = self.cs
            key = cs.key(index)
            slots = (cs.form.part_slots, cs.form.slot_of)
            am = None
            if self.sparse:
                flat = self.analysis.assemble_sparse(key, self.coeffs, slots)
                am = SparseAffineMode(cs.modes[index], *flat)
                if dense_is_cheaper(am):
                    am = None
            if am is None:
                flat = self.analysis.assemble(key, self.coeffs, slots)
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

#: Floating-point operations per second and the fixed cost of one Taylor step (in operations) of
#: the cost model of :func:`dense_is_cheaper` (a rough machine: only their ratio to the counts matters).
FLOP_RATE = 1e9
TAYLOR_STEP_OVERHEAD = 3e4


def dense_is_cheaper(am: SparseAffineMode) -> bool:
    """Whether the dense path (:class:`hybrid.integrators.flow.Flow`: eigen-decomposition or
    exponential of ``M``, the guards' Taylor rows) costs less than the sparse Taylor path over one
    forcing period of a forced mode.

    The Taylor path steps ``h = TAYLOR_THETA / ||M||_inf``, each step ``TAYLOR_DEGREE`` sparse
    products (``2 nnz(M)`` operations) and a fixed overhead; the dense path decomposes once
    (about ``60 nz^3`` operations, with the guards' Taylor rows ``33 ng nz^2``) and steps at the
    spectral radius, which does not exceed ``||M||``. Measured (issue 32): a cantilever of 20 finite
    elements (84 states, ``||M||_inf = 6.9e12``, stiff) needs 3e11 Taylor steps per period at
    60 rad/s and never finished, where the dense path runs 0.2 s of it in 5 s; a forced chain of 256
    friction blocks (515 states, ``||M||_inf`` about 4, a new mode at every switch) runs 5 s in 18 s
    on the Taylor path and did not finish 5 s within 300 s on the dense one (an eigen-decomposition
    of 515 states at each of 768 switches). An unforced mode has no time scale to compare with: it
    stays on the Taylor path."""
    if am.omega is None or am.omega == 0.0:
        return False
    nz, ng = am.nz, am.W.shape[0]
    norm = float(np.max(np.abs(am.M).sum(axis=1))) if nz else 0.0
    period = 2.0 * np.pi / abs(am.omega)
    steps = period * norm / 1.5  # (exact.TAYLOR_THETA; a later layer's constant is not imported here)
    sparse_cost = steps * (2.0 * 24 * am.M.nnz + TAYLOR_STEP_OVERHEAD)
    dense_cost = 60.0 * nz**3 + 33.0 * ng * nz**2
    return bool(dense_cost < sparse_cost)


def _triplets(idx: sp.csr_array) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The positions ``(row, col)`` of the coefficients of a sparse index matrix that are not the
    constant zero (index 0 of the analysis' values), and their indices, row by row."""
    coo = idx.tocoo()
    keep = coo.data != 0
    r, c, i = coo.row[keep], coo.col[keep], coo.data[keep]
    order = np.lexsort((c, r))
    return r[order].astype(int), c[order].astype(int), i[order].astype(int)


class _SparsePart:
    """One part's coefficient rows as triplets over the whole system's numbering (made once per
    part and local mode): rows of ``F`` and ``G`` by variable, rows of ``W`` by guard slot (the
    constant 1 in a slot the local mode leaves unused)."""

    def __init__(self, form: ModeForm, slots: range, used: int, one: int):
        self.form = form
        r, c, i = _triplets(form.F)
        self.F = (np.asarray(form.d, dtype=int)[r], c, i)
        r, c, i = _triplets(form.G)
        self.G = (np.asarray(form.a, dtype=int)[r], c, i)
        width = form.F.shape[1]
        r, c, i = _triplets(form.Wu)
        keep = r < used
        unused = np.arange(used, len(slots))
        self.W = (
            np.concatenate([slots.start + r[keep], slots.start + unused]),
            np.concatenate([c[keep], np.full(unused.size, width - 1)]),
            np.concatenate([i[keep], np.full(unused.size, one)]),
        )
        self.Q = [_triplets(Qj) for Qj in form.Qu]


@dataclass
class SparseAffineMode(AffineMode):
    """An :class:`AffineMode` whose matrices are sparse (``scipy.sparse.csr_array``; ``Q`` a list
    of them): the mode of a large system with components. ``flow()`` and :meth:`dense` give the
    dense form where an eigen-decomposition is wanted (a monodromy matrix; kept in ``_dense``)."""

    _dense: AffineMode | None = field(default=None, init=False, repr=False, compare=False)

    def dense(self) -> AffineMode:
        """The same mode with dense matrices (made once)."""
        if self._dense is None:
            Q = np.array([Qj.toarray() for Qj in self.Q]).reshape(len(self.Q), self.nz, self.nz)
            self._dense = AffineMode(
                self.cm,
                self.omega,
                self.d,
                self.a,
                self.q,
                self.M.toarray(),
                self.P.toarray(),
                Q,
                self.W.toarray(),
                self.harmonics,
            )
        return self._dense

    def flow(self):
        return self.dense().flow()

    def propagate_d(self, h: float, Yd: np.ndarray) -> np.ndarray:
        """``expm(M h)[:nd, :nd] @ Yd`` without the dense flow: the action of the exponential of
        the sparse generator on the columns (Al-Mohy and Higham's truncated Taylor series with
        scaling, ``scipy.sparse.linalg.expm_multiply``, to double precision). A fundamental matrix
        over a mode of a large system costs sparse products, not the eigen-decomposition of a new
        dense generator at every mode change (issue 32: 0.3 s against 65 s at 256 blades)."""
        nd = self.d.size
        Z = np.zeros((self.nz, Yd.shape[1]))
        Z[:nd] = Yd
        return spla.expm_multiply(self.M * float(h), Z)[:nd]

    def guard_row(self, k: int) -> tuple[np.ndarray, np.ndarray]:
        """Row ``k`` of ``W`` as ``(columns, values)`` (no sparse matrix made)."""
        W = self.W
        lo, hi = W.indptr[k], W.indptr[k + 1]
        return W.indices[lo:hi], W.data[lo:hi]

    def guard_series(self, k: int, t: float, y: np.ndarray, order: int) -> np.ndarray:
        z = self.augment(t, y)
        cols, w = self.guard_row(k)
        out = np.empty(order + 1)
        for j in range(order + 1):
            out[j] = float(w @ z[cols])
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
    parts: list[_SparsePart],
    label: str,
    names,
    vals: np.ndarray,
    omega,
    part_slots,
    harmonics=(1,),
    pairs=(0,),
):
    """``(omega, d, a, q, M, P, Q, W, harmonics)`` of a mode, sparse: the parts' rows stacked, the slave
    variables eliminated by a sparse LU factorisation (``M`` keeps the sparsity of the couplings);
    ``harmonics`` and ``pairs`` as for :func:`hybrid.integrators.affine.assemble_form`."""
    n = len(names)
    forms = [p.form for p in parts]
    nf = 2 * len(harmonics) if omega is not None else 0
    d = np.sort(np.concatenate([f.d for f in forms]).astype(int))
    a = np.sort(np.concatenate([f.a for f in forms]).astype(int))
    q = np.concatenate([f.q for f in forms]).astype(int)
    width = forms[0].F.shape[1]  # nu + 1 (u = [y, S_1, C_1, ..., 1], S and C where some part is forced)
    pos = np.empty(n, dtype=int)  # a variable's row among the differential, or the slave, ones
    pos[d] = np.arange(d.size)
    pos[a] = np.arange(a.size)

    def stack(which: str, size: int) -> sp.csr_array:
        trip = [getattr(p, which) for p in parts]
        r = np.concatenate([t[0] for t in trip])
        c = np.concatenate([t[1] for t in trip])
        i = np.concatenate([t[2] for t in trip])
        return sp.csr_array((vals[i], (pos[r], c)), shape=(size, width))

    F = stack("F", d.size)
    nz = d.size + nf + 1
    # u from z: differential variables are z's first entries, the S, C pairs (if any) next, then 1;
    # the i-th pair of u (a group of rates) is the pairs[i]-th of z (its multiple's).
    if omega is not None:
        fu = np.array([n + 2 * i + j for i in range(len(pairs)) for j in (0, 1)], dtype=int)
        fz = np.array([d.size + 2 * p + j for p in pairs for j in (0, 1)], dtype=int)
    else:
        fu = fz = np.zeros(0, dtype=int)
    ident_r = np.concatenate([d, fu, [width - 1]])
    ident_c = np.concatenate([np.arange(d.size), fz, [nz - 1]])
    rest = sp.csr_array((np.ones(ident_r.size), (ident_r, ident_c)), shape=(width, nz))
    Pu = rest
    if a.size:
        G = stack("G", a.size)
        try:
            lu = spla.splu(G[:, a].tocsc())
        except RuntimeError:
            raise NotAffineError(
                f"{label}: the algebraic equations are singular in the slave variables"
            ) from None
        X = -lu.solve((G @ rest).toarray())
        if not np.all(np.isfinite(X)):
            raise NotAffineError(f"{label}: the algebraic equations are singular in the slave variables")
        X[np.abs(X) < 1e-300] = 0.0
        slave = sp.csr_array((np.ones(a.size), (a, np.arange(a.size))), shape=(width, a.size))
        Pu = rest + slave @ sp.csr_array(X)
    Md = sp.coo_array(F @ Pu)
    rows, cols, data = [Md.row], [Md.col], [Md.data]
    if omega is not None:
        for j, m in enumerate(harmonics):
            k = d.size + 2 * j
            rows.append(np.array([k, k + 1]))  # S_m' = m w C_m, C_m' = -m w S_m (m = 1: exactly w)
            cols.append(np.array([k + 1, k]))
            data.append(np.array([m * omega, -m * omega]))
    M = sp.csr_array((np.concatenate(data), (np.concatenate(rows), np.concatenate(cols))), shape=(nz, nz))
    # guard slots in order: the parts' transitions, the constant 1 where a part leaves a slot unused
    n_slots = part_slots[-1].stop if part_slots else 0
    trip = [p.W for p in parts]
    Wu = sp.csr_array(
        (
            vals[np.concatenate([t[2] for t in trip])],
            (np.concatenate([t[0] for t in trip]), np.concatenate([t[1] for t in trip])),
        ),
        shape=(n_slots, width),
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
    return omega, d, a, np.sort(q), M, P, Q, W, tuple(harmonics)
