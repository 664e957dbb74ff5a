"""Write ``blade.npz``: a small 2-D finite-element model of a turbine blade with a platform.

Used by ``blade_damper.toml`` (one blade with an underplatform damper) and ``blade_ring.toml`` (a
ring of such sectors), both reducing it by Craig-Bampton to the platform's DOFs and the tip's
tangential DOF.

Run ``python models/data/make_blade.py`` (it writes beside itself; deterministic, so the file in
the repository is what it writes).

The blade: a straight steel beam along the radial direction ``y``, clamped at the disk (``y = 0``),
length L = 0.1 m, rectangular section 30 mm (chord) x 5 mm (thickness, in the tangential direction
``x``); E = 210 GPa, rho = 7850 kg/m^3, so EI = 65.625 N m^2 (bending in x), EA = 31.5 MN and
rho A = 1.1775 kg/m. Ten 2-D frame elements (each a bar in ``y`` and an Euler-Bernoulli beam in
``x``), nodes 1 ... 10 at ``y = k L/10``, each with the DOFs ``xk`` (tangential) [m], ``yk``
(radial) [m], ``thk`` [rad] (counter-clockwise). The platform is a steel plate 30 mm (along the
chord) x 3 mm, two frame elements from node 3 (y = 30 mm) to its edges at x = -15 mm (DOFs
``xpl, ypl, thpl``) and x = +15 mm (``xpr, ypr, thpr``): as the blade bends the platform rotates,
so its edges move radially (the normal direction of an underplatform damper's contacts).
Consistent element mass matrices (bar: rho A le/6 [[2, 1], [1, 2]]; beam: the cubic Hermite one)
and stiffness matrices (Przemieniecki, *Theory of Matrix Structural Analysis*, 1968, ch. 5
and 11). SI units: M [kg] (x, y rows), [kg m^2] (theta rows); K [N/m], [N/rad], [N m/rad]. No
damping in the file (the model files give it). Centrifugal stiffening is not modelled.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import scipy.linalg

LENGTH = 0.1  # [m] the blade's length
ELEMENTS = 10  # along the blade
E = 210e9  # [Pa]
RHO = 7850.0  # [kg/m^3]
CHORD, THICKNESS = 0.03, 0.005  # [m] the blade's section
PLATFORM_NODE = 3  # the platform joins the blade at node 3 (y = 30 mm)
PLATFORM_HALF = 0.015  # [m] each half of the platform (x from -15 mm to +15 mm)
PLATFORM_THICKNESS = 0.003  # [m] (its width along the chord is CHORD)


def frame_element(
    EA: float, EI: float, rhoA: float, le: float, angle: float
) -> tuple[np.ndarray, np.ndarray]:
    """Global ``(m, k)`` (6 x 6, DOFs x1, y1, th1, x2, y2, th2; th counter-clockwise) of a 2-D frame
    element of length ``le`` [m] whose axis makes ``angle`` [rad] with the x axis."""
    a, b = EA / le, EI / le**3
    k = np.array(
        [
            [a, 0, 0, -a, 0, 0],
            [0, 12 * b, 6 * b * le, 0, -12 * b, 6 * b * le],
            [0, 6 * b * le, 4 * b * le**2, 0, -6 * b * le, 2 * b * le**2],
            [-a, 0, 0, a, 0, 0],
            [0, -12 * b, -6 * b * le, 0, 12 * b, -6 * b * le],
            [0, 6 * b * le, 2 * b * le**2, 0, -6 * b * le, 4 * b * le**2],
        ]
    )
    c = rhoA * le / 420.0
    m = c * np.array(
        [
            [140, 0, 0, 70, 0, 0],
            [0, 156, 22 * le, 0, 54, -13 * le],
            [0, 22 * le, 4 * le**2, 0, 13 * le, -3 * le**2],
            [70, 0, 0, 140, 0, 0],
            [0, 54, 13 * le, 0, 156, -22 * le],
            [0, -13 * le, -3 * le**2, 0, -22 * le, 4 * le**2],
        ]
    )
    cs, sn = np.cos(angle), np.sin(angle)
    r = np.array([[cs, sn, 0.0], [-sn, cs, 0.0], [0.0, 0.0, 1.0]])  # global -> local
    R = np.zeros((6, 6))
    R[:3, :3] = R[3:, 3:] = r
    return R.T @ m @ R, R.T @ k @ R


def blade_matrices(n: int = ELEMENTS, platform: bool = True) -> tuple[np.ndarray, np.ndarray, list[str]]:
    """``(M, K, dofs)`` of the clamped blade of ``n`` frame elements and its two-element platform
    (DOFs x1, y1, th1, ..., xn, yn, thn, then xpl, ypl, thpl and xpr, ypr, thpr: the platform's
    left and right edges; without them if not ``platform``: the bare cantilever)."""
    blade = (E * CHORD * THICKNESS, E * CHORD * THICKNESS**3 / 12.0, RHO * CHORD * THICKNESS)
    plate = (
        E * CHORD * PLATFORM_THICKNESS,
        E * CHORD * PLATFORM_THICKNESS**3 / 12.0,
        RHO * CHORD * PLATFORM_THICKNESS,
    )
    nodes = n + 3  # node 0 (the clamp), 1 ... n, the platform's left and right edges
    M = np.zeros((3 * nodes, 3 * nodes))
    K = np.zeros((3 * nodes, 3 * nodes))

    def add(i: int, j: int, props: tuple, le: float, angle: float) -> None:
        m, k = frame_element(*props, le, angle)
        idx = [3 * i, 3 * i + 1, 3 * i + 2, 3 * j, 3 * j + 1, 3 * j + 2]
        M[np.ix_(idx, idx)] += m
        K[np.ix_(idx, idx)] += k

    for e in range(n):
        add(e, e + 1, blade, LENGTH / n, np.pi / 2)  # along +y
    dofs = [name for j in range(1, n + 1) for name in (f"x{j}", f"y{j}", f"th{j}")]
    if not platform:
        return M[3:-6, 3:-6], K[3:-6, 3:-6], dofs
    add(PLATFORM_NODE, n + 1, plate, PLATFORM_HALF, np.pi)  # to the left edge, along -x
    add(PLATFORM_NODE, n + 2, plate, PLATFORM_HALF, 0.0)  # to the right edge, along +x
    dofs += ["xpl", "ypl", "thpl", "xpr", "ypr", "thpr"]
    return M[3:, 3:], K[3:, 3:], dofs


if __name__ == "__main__":
    M, K, dofs = blade_matrices()
    out = Path(__file__).with_name("blade.npz")
    np.savez(out, M=M, K=K, dofs=np.array(dofs))
    w = np.sqrt(scipy.linalg.eigh(K, M, eigvals_only=True))
    print(f"wrote {out} ({len(dofs)} DOFs); first natural frequencies [rad/s]: {w[:4]}")
