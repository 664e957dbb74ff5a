"""The exact flow ``z(h) = expm(M h) z`` of an affine mode, with its quadratures and derivatives.

* ``expm(M h) = V exp(L h) V^-1`` where ``M`` (balanced) has a well-conditioned eigenvector
  basis, for any ``h`` at the cost of a few matrix-vector products; otherwise scaling and
  squaring with the [13/13] Pade approximant (:func:`matrix_exp`);
* a quadrature whose rate is a quadratic form ``z^T Q z`` (work, dissipated power) integrates
  exactly: ``q(t + h) - q(t) = z^T K(h) z`` with ``K(h) = int_0^h expm(M^T s) Q expm(M s) ds``
  (Van Loan's block exponential, or the eigenbasis);
* the Frechet derivative of ``expm(M h)`` in a direction (for a parameter's sensitivity).
"""

from __future__ import annotations

import math

import numpy as np

from ..core.balance import balance
from ..core.cache import LRUCache

__all__ = ["Flow", "balanced_exp", "matrix_exp", "shared_flow"]


def _cond1(A: np.ndarray, Ainv: np.ndarray | None = None) -> float:
    """Condition number of ``A`` in the 1-norm (``Ainv``: its inverse, if known); inf if singular."""
    try:
        Ainv = np.linalg.inv(A) if Ainv is None else Ainv
    except np.linalg.LinAlgError:
        return math.inf
    c = float(np.abs(A).sum(axis=0).max() * np.abs(Ainv).sum(axis=0).max())
    return c if math.isfinite(c) else math.inf


#: Largest condition number (1-norm) of the eigenvector matrix for the eigen-decomposition path of a flow.
EIGEN_COND = 1e4


#: Largest error of ``V exp(L h) V^-1`` against :func:`matrix_exp` for the eigen path of a flow,
#: relative to each row's ``sum |expm(M h)_ij|`` (componentwise: each state variable to its own
#: scale, which the balanced condition number does not bound). The absorber in engineering units
#: (tests/hybrid/test_units.py) differs from the Pade path by 1.0e-12 to 1.3e-12 (either may hold
#: that error); the tutorial's stuck mode, which this test is for, by 5.5e-10 to 1.1e-9.
EIGEN_ACCURACY = 1e-11


def balanced_exp(A: np.ndarray, s: np.ndarray) -> np.ndarray:
    """``expm(A)`` as ``diag(s) expm(diag(s)^-1 A diag(s)) diag(s)^-1`` (:func:`matrix_exp` of the
    balanced matrix; ``s`` powers of 2, :func:`hybrid.core.balance.balance`, so the similarity is
    exact in floating point).

    Scaling and squaring loses about ``eps ||A||`` (relative, per row) where ``A`` is badly scaled:
    the generator of a cantilever beam of 10 finite elements with a stuck tip contact (issue 32),
    whose rows mix displacements [m] and rotations [rad] through ``M^-1 K``, has ``||M||_1 = 2.2e11``
    against a spectral radius of 8.9e4, and its unbalanced Pade exponential over 1.8e-5 s was wrong
    by 5.4e-5 of a row (3.3e-3 for 20 elements): the period map was noisy there and Newton's method
    on the beam's orbit stalled at a residual of 2.7e-6. Balanced, it equals the eigen-decomposition
    to 3e-12 (1.3e-11 for 20 elements)."""
    return matrix_exp(A * s[None, :] / s[:, None]) * (s[:, None] / s[None, :])


def _eigen_accurate(
    M: np.ndarray, V: np.ndarray, lam: np.ndarray, Vinv: np.ndarray, s: np.ndarray | None = None
) -> bool:
    """Whether ``V exp(L h) V^-1`` equals ``expm(M h)`` row by row to :data:`EIGEN_ACCURACY` at the
    time scales of ``M`` (``1 / ||M||`` and a quarter of the fastest oscillation).

    A generator with a nearly defective eigenvalue passes the balanced condition test yet loses
    accuracy in one variable: the stuck mode of the tutorial's damper (issue 30), whose generator
    carries a rounding residue of 2e-14 where the relative displacement's coefficient is zero,
    has eigenvalues +-1.4e-7 beside the constant's 0; balancing (by 4e9 in that displacement)
    brings its eigenvector basis to a condition number of 1.4e3, and the flow was wrong by 1e-9
    of the contact force, so the period map was noisy at 1e-10 and the continuation's corrector
    stalled entering the stick-slip band."""
    n = M.shape[0]
    norm = float(np.max(np.abs(M).sum(axis=0))) if n else 0.0
    if norm == 0.0 or not math.isfinite(norm):
        return math.isfinite(norm)
    hs = [1.0 / norm]
    fast = float(np.max(np.abs(lam.imag)))
    if fast > 0.0:
        hs.append(0.5 * math.pi / fast)
    s = np.ones(n) if s is None else s
    for h in hs:
        E = balanced_exp(M * h, s)
        err = np.abs(((V * np.exp(lam * h)) @ Vinv).real - E).sum(axis=1)
        if np.any(err > EIGEN_ACCURACY * np.maximum(np.abs(E).sum(axis=1), 1e-300)):
            return False
    return True


# Pade [13/13] coefficients (Higham 2005) and the norm bound of the scaled matrix.
_PADE13 = (
    64764752532480000.0, 32382376266240000.0, 7771770303897600.0, 1187353796428800.0,
    129060195264000.0, 10559470521600.0, 670442572800.0, 33522128640.0, 1323241920.0,
    40840800.0, 960960.0, 16380.0, 182.0, 1.0,
)  # fmt: skip


_THETA13 = 5.371920351148152


def matrix_exp(A: np.ndarray) -> np.ndarray:
    """``expm(A)`` by scaling and squaring with the [13/13] Pade approximant (Higham 2005), in numpy.

    (scipy's ``expm`` runs through its own threaded BLAS, which on small
    matrices costs milliseconds a call on a loaded machine; this costs tens
    of microseconds.)
    """
    n = A.shape[0]
    norm = float(np.max(np.sum(np.abs(A), axis=0))) if n else 0.0
    s = max(0, int(math.ceil(math.log2(norm / _THETA13)))) if norm > _THETA13 else 0
    A = A / 2.0**s
    b = _PADE13
    eye = np.eye(n)
    A2 = A @ A
    A4 = A2 @ A2
    A6 = A4 @ A2
    U = A @ (A6 @ (b[13] * A6 + b[11] * A4 + b[9] * A2) + b[7] * A6 + b[5] * A4 + b[3] * A2 + b[1] * eye)
    V = A6 @ (b[12] * A6 + b[10] * A4 + b[8] * A2) + b[6] * A6 + b[4] * A4 + b[2] * A2 + b[0] * eye
    E = np.linalg.solve(V - U, V + U)
    for _ in range(s):
        E = E @ E
    return E


#: Flows kept by :func:`shared_flow` (the most recent ones).
MAX_SHARED_FLOWS = 64


#: Step lengths whose kernels a :class:`Flow` keeps (:meth:`Flow.kernel`).
KERNELS_KEPT = 16

_FLOWS = LRUCache(MAX_SHARED_FLOWS)


def shared_flow(M: np.ndarray, Q: np.ndarray) -> Flow:
    """The :class:`Flow` of ``(M, Q)``, built once for equal matrices (its eigen-decomposition, guard
    series and step kernels are then computed once for a parameter value, not once per run)."""
    key = M.tobytes() + b"|" + Q.tobytes() + repr((M.shape, Q.shape)).encode()
    return _FLOWS.get_or_make(key, lambda: Flow(M, Q))


class Flow:
    """The exact flow ``z(h) = expm(M h) z`` of one affine mode, and its quadratures.

    Where ``M`` has a well-conditioned eigenvector basis (condition number at
    most :data:`EIGEN_COND` after balancing, :func:`hybrid.core.balance.balance`),
    ``expm(M h) = V exp(L h) V^-1`` costs a few matrix-vector products for any ``h``; otherwise (a defective ``M``, e.g.
    forcing exactly at a natural frequency) :func:`matrix_exp` is used, with
    the quadratures by Van Loan's block exponential.

    Parameters
    ----------
    M : ndarray, shape (nz, nz)
    Q : ndarray, shape (nq, nz, nz)
        Quadrature rates as quadratic forms.
    """

    def __init__(self, M: np.ndarray, Q: np.ndarray):
        self.M, self.Q = M, Q
        self.nz = M.shape[0]
        self._kernels = LRUCache(KERNELS_KEPT)  # kernel(h) at the most recent steps h
        self.eigen = False
        self._scale = np.ones(self.nz)
        try:
            # eigenvectors of the balanced generator (a diagonal similarity by powers of 2): in
            # engineering units (velocities 1e3 times the displacements) those of M itself had a
            # condition number over EIGEN_COND, and every flow fell back on the Pade path
            b = self._scale = balance(M)
            lam, Vb = np.linalg.eig(M * b[None, :] / b[:, None])
            Vbinv = np.linalg.inv(Vb)
            V, Vinv = Vb * b[:, None], Vbinv / b[None, :]
            if _cond1(Vb, Vbinv) <= EIGEN_COND and _eigen_accurate(M, V, lam, Vinv, b):
                self.lam, self.V, self.Vinv = lam, V, Vinv
                # quadratures in the eigenbasis: int z^T Q z = c^T (V^T Q V o Phi(h)) c, c = V^-1 z
                self.QV = np.array([V.T @ Qj @ V for Qj in Q]).reshape(len(Q), self.nz, self.nz)
                self.mu = lam[:, None] + lam[None, :]
                self._mu_safe = np.where(self.mu == 0.0, 1.0, self.mu)
                self.eigen = True
        except np.linalg.LinAlgError:  # pragma: no cover - eig of a finite matrix
            pass

    def kernel(self, h: float) -> tuple[np.ndarray, np.ndarray | None]:
        """``(expm(M h), K)`` with ``q(h) - q(0) = z^T K_j z`` (None without quadratures), kept for reuse."""
        return self._kernels.get_or_make(h, lambda: self._kernel(h))

    def _kernel(self, h: float) -> tuple[np.ndarray, np.ndarray | None]:
        nq, nz = self.Q.shape[0], self.nz
        E = self.matrix(h)
        K = None
        if nq and self.eigen:
            mh = self.mu * h
            small = np.abs(mh) < 1e-3
            phi = np.where(small, h * (1 + mh / 2 + mh * mh / 6 + mh**3 / 24), 0j)
            phi[~small] = (np.exp(mh[~small]) - 1.0) / self.mu[~small]
            K = np.real(np.einsum("ji,qjk,kl->qil", self.Vinv, self.QV * phi, self.Vinv))
        elif nq:
            K = np.zeros((nq, nz, nz))
            for j, Qj in enumerate(self.Q):
                B = np.zeros((2 * nz, 2 * nz))
                B[:nz, :nz] = -self.M.T
                B[:nz, nz:] = Qj
                B[nz:, nz:] = self.M
                K[j] = E.T @ self._exp_quadrature(B * h)[:nz, nz:]
        return E, K

    def matrix(self, h: float) -> np.ndarray:
        """``expm(M h)``."""
        if self.eigen:
            return ((self.V * np.exp(self.lam * h)) @ self.Vinv).real
        return balanced_exp(self.M * h, self._scale)

    def _exp_quadrature(self, B: np.ndarray) -> np.ndarray:
        """``expm(B)`` of a Van Loan block ``[[-M^T h, Q h], [0, M h]]``, balanced as ``M`` is
        (``diag(1/s, s)``)."""
        return balanced_exp(B, np.concatenate([1.0 / self._scale, self._scale]))

    def frechet(self, h: float, D: np.ndarray) -> np.ndarray:
        """``d/de expm((M + e D) h)`` at ``e = 0``: ``V (G o V^-1 D V) V^-1`` with the divided differences
        ``G_jk = (exp(l_j h) - exp(l_k h)) / (l_j - l_k)`` of the eigenvalues (``h exp(l h)`` where
        they meet); on the defective path the corner block of Van Loan's ``expm([[M, D], [0, M]] h)``."""
        if not self.eigen:
            nz = self.nz
            B = np.zeros((2 * nz, 2 * nz))
            B[:nz, :nz] = self.M
            B[:nz, nz:] = D
            B[nz:, nz:] = self.M
            return balanced_exp(B * h, np.concatenate([self._scale, self._scale]))[:nz, nz:]
        lam = self.lam
        e = np.exp(lam * h)
        x = (lam[:, None] - lam[None, :]) * h
        small = np.abs(x) < 1e-3
        x_safe = np.where(small, 1.0, x)
        # (e_j - e_k) / (l_j - l_k) = h e_k (exp(x) - 1) / x, x = (l_j - l_k) h: a series where x is small
        phi = np.where(small, 1.0 + x * (0.5 + x * (1.0 / 6.0 + x / 24.0)), np.expm1(x) / x_safe)
        G = h * e[None, :] * phi
        return (self.V @ ((self.Vinv @ D @ self.V) * G) @ self.Vinv).real

    def prepare(self, z: np.ndarray):
        """What :meth:`advance` from ``z`` reuses for any ``h`` (eigen path; None otherwise)."""
        if not self.eigen:
            return None
        c = self.Vinv @ z
        return c, (self.QV * np.outer(c, c) if self.Q.shape[0] else None)

    def advance(self, z: np.ndarray, h: float, prep=None) -> tuple[np.ndarray, np.ndarray]:
        """``(z(h), q(h) - q(0))`` from ``z`` (``prep``: :meth:`prepare` of ``z``, if kept)."""
        nq = self.Q.shape[0]
        if self.eigen:
            c, cc = prep if prep is not None else self.prepare(z)
            e = np.exp(self.lam * h)
            z1 = (self.V @ (e * c)).real
            if cc is None:
                return z1, np.zeros(0)
            # int_0^h exp(mu s) ds with mu_jk = lam_j + lam_k (exp(mu h) = e_j e_k); a series where mu h is small
            mh = self.mu * h
            phi = np.where(
                np.abs(mh) < 1e-3,
                h * (1.0 + mh * (0.5 + mh * (1.0 / 6.0 + mh / 24.0))),
                (np.outer(e, e) - 1.0) / self._mu_safe,
            )
            return z1, np.einsum("qjk,jk->q", cc, phi).real
        if not nq:
            return self.matrix(h) @ z, np.zeros(0)
        nz = self.nz
        E = self.matrix(h)
        out = np.zeros(nq)
        for j, Qj in enumerate(self.Q):
            B = np.zeros((2 * nz, 2 * nz))
            B[:nz, :nz] = -self.M.T
            B[:nz, nz:] = Qj
            B[nz:, nz:] = self.M
            X = self._exp_quadrature(B * h)
            out[j] = z @ (E.T @ X[:nz, nz:]) @ z
        return E @ z, out
