"""Write ``beam10.npz`` and ``beam20.npz``: Euler-Bernoulli cantilevers of 10 and 20 elements.

``beam_tip.toml`` uses the 10 elements in full (20 DOFs: its 48 states stay on the exact
integrator's dense path); ``beam_tip_cb.toml`` reduces the 20 elements by Craig-Bampton.

Run ``python models/data/make_beam.py`` (it writes beside itself; deterministic, so the file in the
repository is what it writes).

The beam: steel, length L = 1 m, rectangular section b x h = 40 mm x 10 mm, bending about the
weak axis; E = 210 GPa, rho = 7850 kg/m^3, so EI = 700 N m^2 and rho A = 3.14 kg/m. Clamped at
x = 0 (that node's DOFs removed); nodes 1 ... n at x = k L / n, each with the transverse
displacement ``wk`` [m] and the rotation ``thk`` [rad]. Consistent (non-diagonal) element mass
matrix and the cubic Hermite stiffness matrix (e.g. Przemieniecki, *Theory of Matrix Structural
Analysis*, 1968, ch. 5 and 11). SI units: M in [kg] (w rows) and [kg m^2] (theta rows), K in
[N/m], [N/rad], [N m/rad]. No damping in the file (the model file gives it).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

LENGTH = 1.0  # [m]
ELEMENTS = 20
E = 210e9  # [Pa]
RHO = 7850.0  # [kg/m^3]
WIDTH, HEIGHT = 0.04, 0.01  # [m]


def beam_matrices(n: int = ELEMENTS, length: float = LENGTH) -> tuple[np.ndarray, np.ndarray, list[str]]:
    """``(M, K, dofs)`` of the clamped-free beam of ``n`` elements (DOFs w1, th1, ..., wn, thn; M [kg, kg m^2], K [N/m, N m/rad])."""
    EI = E * WIDTH * HEIGHT**3 / 12.0
    rhoA = RHO * WIDTH * HEIGHT
    le = length / n
    k = (
        EI
        / le**3
        * np.array(
            [
                [12, 6 * le, -12, 6 * le],
                [6 * le, 4 * le**2, -6 * le, 2 * le**2],
                [-12, -6 * le, 12, -6 * le],
                [6 * le, 2 * le**2, -6 * le, 4 * le**2],
            ]
        )
    )
    m = (
        rhoA
        * le
        / 420.0
        * np.array(
            [
                [156, 22 * le, 54, -13 * le],
                [22 * le, 4 * le**2, 13 * le, -3 * le**2],
                [54, 13 * le, 156, -22 * le],
                [-13 * le, -3 * le**2, -22 * le, 4 * le**2],
            ]
        )
    )
    size = 2 * (n + 1)
    M = np.zeros((size, size))
    K = np.zeros((size, size))
    for e in range(n):
        idx = slice(2 * e, 2 * e + 4)
        M[idx, idx] += m
        K[idx, idx] += k
    dofs = [name for j in range(1, n + 1) for name in (f"w{j}", f"th{j}")]
    return M[2:, 2:], K[2:, 2:], dofs


if __name__ == "__main__":
    for n in (10, 20):
        M, K, dofs = beam_matrices(n)
        out = Path(__file__).with_name(f"beam{n}.npz")
        np.savez(out, M=M, K=K, dofs=np.array(dofs))
        print(f"wrote {out} ({len(dofs)} DOFs)")
