"""Craig-Bampton reduction of a :class:`~hybrid_models.structures.Structure`.

The DOFs split into boundary DOFs ``b`` (those that carry contacts, springs, dampers and forces)
and interior DOFs ``i``. The interior follows the boundary statically (constraint modes
``Psi = -K_ii^-1 K_ib``) plus the lowest ``m`` fixed-interface modes ``Phi`` (``K_ii Phi = M_ii Phi
Lambda``, mass-normalised, :func:`scipy.linalg.eigh`): ``q = T [q_b; eta]`` with
``T = [[I, 0], [Psi, Phi]]`` (rows in the structure's DOF order), and ``M_r = T' M T``,
``K_r = T' K T``, ``C_r = T' C T``. The boundary DOFs keep their names; the modal coordinates are
named ``eta1 ... etam`` (dimension: [m] times sqrt of [kg], the modes being mass-normalised).

Craig & Bampton, AIAA J. 6 (1968) 1313; Krack & Gross, *Harmonic Balance for Nonlinear
Vibration Problems* (2019), ch. 3.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
import scipy.linalg

from hybrid import ModelError

from .structures import Structure, natural_frequencies

__all__ = ["Reduction", "craig_bampton", "frequency_table"]


@dataclass(frozen=True, eq=False)
class Reduction:
    """A Craig-Bampton reduced structure and how it was made.

    Attributes
    ----------
    structure : Structure
        The reduced model: DOFs ``boundary + (eta1, ..., etam)``.
    full : Structure
        The model it reduces.
    boundary : tuple of str
        The kept physical DOFs, in the order given.
    T : ndarray, shape (n_full, n_reduced)
        ``q_full = T q_reduced``.
    """

    structure: Structure
    full: Structure
    boundary: tuple
    T: np.ndarray

    @property
    def modes(self) -> int:
        """Number of fixed-interface modes kept."""
        return self.structure.n - len(self.boundary)

    def frequencies(self, count: int | None = None) -> np.ndarray:
        """``(count, 3)`` rows ``(full, reduced, relative error)`` of the lowest natural frequencies
        [rad/s] of the free structure (:func:`frequency_table`)."""
        return frequency_table(self.full, self.structure, count)


def frequency_table(full: Structure, reduced: Structure, count: int | None = None) -> np.ndarray:
    """The lowest natural frequencies of a full and a reduced model side by side.

    Parameters
    ----------
    full, reduced : Structure
    count : int, optional
        How many (default: all of the reduced model's).

    Returns
    -------
    ndarray, shape (count, 3)
        Columns: full [rad/s], reduced [rad/s], ``(reduced - full)/full`` (0 where both are 0).
        The reduced ones are never below the full ones (Rayleigh-Ritz).
    """
    count = reduced.n if count is None else min(count, reduced.n)
    wf = natural_frequencies(full.M, full.K, count)
    wr = natural_frequencies(reduced.M, reduced.K, count)
    err = np.where(wf > 0, (wr - wf) / np.where(wf > 0, wf, 1.0), 0.0)
    return np.column_stack([wf, wr, err])


def craig_bampton(structure: Structure, boundary: Sequence[str], modes: int, *, where: str = "") -> Reduction:
    """Reduce ``structure`` to its ``boundary`` DOFs and ``modes`` fixed-interface modes.

    Parameters
    ----------
    structure : Structure
    boundary : sequence of str
        Names of the DOFs kept (those that carry contacts, springs, dampers and forces).
    modes : int
        Fixed-interface modes kept (0 to the number of interior DOFs).
    where : str
        Prefix of error messages.

    Returns
    -------
    Reduction

    Raises
    ------
    ModelError
        Unknown or repeated boundary DOF, ``modes`` out of range, or ``K_ii`` singular (the
        structure can move with its boundary held: keep a DOF of each free part as boundary).
    """
    at = where or structure.source
    index = {d: k for k, d in enumerate(structure.dofs)}
    b = []
    for d in boundary:
        if d not in index:
            raise ModelError(f"{at}: boundary DOF `{d}` is not a DOF of the structure")
        if index[d] in b:
            raise ModelError(f"{at}: boundary DOF `{d}` is given twice")
        b.append(index[d])
    interior = [k for k in range(structure.n) if k not in set(b)]
    if isinstance(modes, bool) or not isinstance(modes, int | np.integer) or not 0 <= modes <= len(interior):
        raise ModelError(
            f"{at}: `modes` = {modes!r} must be an integer from 0 to {len(interior)} (the interior DOFs)"
        )
    M, K, C = structure.M, structure.K, structure.C
    n, nb = structure.n, len(b)
    T = np.zeros((n, nb + modes))
    T[b, np.arange(nb)] = 1.0
    if interior:
        Kii = K[np.ix_(interior, interior)]
        try:
            factor = scipy.linalg.cho_factor(Kii)
        except np.linalg.LinAlgError:
            raise ModelError(
                f"{at}: with the boundary DOFs {', '.join(boundary) or '(none)'} held, the interior can "
                "still move (K_ii is singular): keep a DOF of each free part as a boundary DOF"
            ) from None
        if nb:
            T[np.ix_(interior, range(nb))] = -scipy.linalg.cho_solve(factor, K[np.ix_(interior, b)])
        if modes:
            _, phi = scipy.linalg.eigh(Kii, M[np.ix_(interior, interior)], subset_by_index=[0, modes - 1])
            T[np.ix_(interior, range(nb, nb + modes))] = phi
    names = tuple(structure.dofs[k] for k in b) + tuple(f"eta{j + 1}" for j in range(modes))
    taken = set(structure.dofs[k] for k in b)
    if taken & set(names[nb:]):
        raise ModelError(
            f"{at}: a boundary DOF is named like a modal coordinate (eta1, eta2, ...); rename it"
        )

    def project(A: np.ndarray) -> np.ndarray:
        R = T.T @ A @ T
        return 0.5 * (R + R.T)

    reduced = Structure(project(M), project(K), project(C), names, f"{structure.source} (Craig-Bampton)")
    return Reduction(reduced, structure, tuple(boundary), T)
