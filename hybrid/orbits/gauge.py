"""The gauges that pick one member of a family of periodic orbits: :class:`Gauge`.

A family of periodic orbits (a neutral multiplier 1 of the stroboscopic map, e.g. the free offset
of an element that stays fixed all period) leaves ``I - M`` singular, with one null direction per
free coordinate. The model's ``[orbit] gauge`` lists expressions of the state that are 0 on the
member wanted; Newton's method adds the rows ``gauge = 0`` for as many of them as the family has
null directions, those whose gradients fix the directions best (a pivoted QR factorisation of
their projections on the null directions, each gradient normalised: a gauge of an element that
does not move along the family is never picked).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
import scipy.linalg as sla

from ..model.codegen import compile_scalar
from ..model.expr import diff, free_symbols
from ..model.system import HybridSystem

__all__ = ["Gauge", "gauge_functions", "GAUGE_PICK_TOL"]

#: A gauge whose normalised gradient's projection on the family's null directions not fixed by the
#: gauges picked before it is below this fixes none of them: it is not picked.
GAUGE_PICK_TOL = 1e-6


@dataclass(frozen=True)
class Gauge:
    """The model's gauges at one state.

    Attributes
    ----------
    values : ndarray, shape (k,)
        Each gauge's value (0 on the member it picks).
    grad : ndarray, shape (k, n)
        Their gradients in the state.
    texts : tuple of str
        The expressions as the model writes them.
    """

    values: np.ndarray
    grad: np.ndarray
    texts: tuple

    @property
    def size(self) -> int:
        return int(self.values.size)

    def pick(self, vt: np.ndarray, q: int, d: np.ndarray, bs: np.ndarray | None = None) -> np.ndarray:
        """Indices of the gauges that hold a family with ``q`` null directions (at most ``q``).

        Each gauge's gradient over ``d`` is normalised and projected on the null directions; a
        pivoted QR factorisation of the projections orders the gauges by how much of the
        directions not yet fixed each one fixes, and those above :data:`GAUGE_PICK_TOL` are
        picked (a gauge of a coordinate that does not move along the family fixes nothing).

        Parameters
        ----------
        vt : ndarray
            Right singular vectors (rows, by decreasing singular value) of ``I - M`` over the
            differential coordinates ``d``, in the coordinates scaled by ``bs``; the last ``q``
            rows span its null space.
        q : int
            Dimension of the family (null directions of ``I - M``).
        d : ndarray of int
            The state coordinates of ``I - M``.
        bs : ndarray, optional
            The coordinates' scales (``y_d = bs * y_scaled``); default ones.
        """
        k = self.size
        if q <= 0 or k == 0:
            return np.zeros(0, dtype=int)
        G = self.grad[:, d] * (1.0 if bs is None else bs)[None, :]
        norms = np.linalg.norm(G, axis=1)
        P = np.zeros((k, q))
        live = norms > 0.0
        P[live] = (G[live] / norms[live, None]) @ vt[-q:].T
        _, R, piv = sla.qr(P.T, mode="economic", pivoting=True)
        diag = np.abs(np.diag(R))
        keep = [int(piv[i]) for i in range(diag.size) if diag[i] > GAUGE_PICK_TOL]
        return np.array(sorted(keep), dtype=int)

    def describe(self, picked: np.ndarray) -> str:
        """The picked gauges as the model writes them: `` `x3`, `x7` ``."""
        return ", ".join(f"`{self.texts[i]}`" for i in picked)


def gauge_functions(system: HybridSystem) -> tuple[list, list] | None:
    """The model's ``[orbit] gauge`` expressions and their gradients, compiled once per system with
    the parameters read at call time (``v = [t, state..., parameters...]``); None without a gauge.

    Returns ``(functions, gradients)``: one function per gauge, and per gauge the ``(index,
    function)`` pairs of its nonzero gradient entries."""
    gauges = system.parsed.gauge
    if gauges is None:
        return None

    def make() -> tuple[list[Callable], list[list]]:
        names = system.variable_names
        slots = {"t": 0, **{nm: i + 1 for i, nm in enumerate(names)}}
        slots.update({p.name: len(names) + 1 + j for j, p in enumerate(system.parameters)})
        fns, grads = [], []
        for g in gauges:
            fns.append(compile_scalar(g, slots, {}))
            used = free_symbols(g)
            grads.append(
                [(i, compile_scalar(diff(g, nm), slots, {})) for i, nm in enumerate(names) if nm in used]
            )
        return fns, grads

    return system.cache.get("gauge_functions", make)
