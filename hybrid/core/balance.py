"""Balancing of a small matrix by a diagonal similarity (Parlett & Reinsch 1969).

``diag(s)^-1 A diag(s)`` with ``s`` powers of 2 (exact in floating point) so that each row and
column off the diagonal have comparable norms. It removes what the units of a state put into a
matrix of its derivatives (a velocity hundreds of times a displacement, in a model in engineering
units): used for the rank tests of ``I - M`` (:func:`hybrid.orbits.orbit.balance_scales`) and for the
eigen-decomposition of an affine mode's generator (:class:`hybrid.integrators.exact.Flow`).
"""

from __future__ import annotations

import math

import numpy as np

__all__ = ["balance"]


def balance(A: np.ndarray, sweeps: int = 100) -> np.ndarray:
    """Scales ``s`` (powers of 2) with ``diag(s)^-1 A diag(s)`` balanced (the 1-norms of each row
    and column off the diagonal within a factor of about 2 of each other; a row or column that is
    zero off the diagonal is left as it is)."""
    n = A.shape[0]
    B = np.abs(np.asarray(A, dtype=float))
    np.fill_diagonal(B, 0.0)
    # Entries at the rounding of the matrix's largest carry no coupling: a column that holds only
    # such residues is zero (issue 30: I - M of a stuck contact has a column of 1e-15 in the
    # offset it does not depend on, and balancing it scaled that coordinate by 8.6e9, which made
    # the truncated pseudo-inverse of Newton's method drop the whole correction)
    top = float(B.max()) if B.size else 0.0
    if math.isfinite(top):
        B[B <= 1e-14 * top] = 0.0
    s = np.ones(n)
    for _ in range(sweeps):
        changed = False
        for i in range(n):
            c, r = float(B[:, i].sum()), float(B[i, :].sum())
            if c == 0.0 or r == 0.0 or not (math.isfinite(c) and math.isfinite(r)):
                continue
            f = 2.0 ** round(0.5 * math.log2(r / c))
            if f != 1.0 and c * f + r / f < 0.95 * (c + r):
                B[:, i] *= f
                B[i, :] /= f
                s[i] *= f
                changed = True
        if not changed:
            break
    return s
