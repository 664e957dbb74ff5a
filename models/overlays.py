"""Curves drawn over a computed frequency-response curve (``hybrid frc``), from Appendix A of [1]_.

Each function has the signature of the ``hybrid.frc_overlays`` entry points
(registered in ``pyproject.toml`` under the model's name)::

    overlay(params: dict, omega: ndarray) -> {curve label: {coordinate: amplitudes}}

with ``params`` the model's parameter values (``Omega`` is replaced by the
grid ``omega`` [rad/s]) and amplitudes ``max |x|`` [m] with the shape of ``omega``.
Two curves per damper:

* the linear stick system, ``|A1|`` and ``|A2|`` of Eqs. (A.1)-(A.2), with
  zero friction offset (the member of the family of stuck orbits that
  ``hybrid`` returns, see the models' ``[orbit] gauge``);
* the structural-change limit ``A_L``: the stick response with ``|H| = R``,
  the largest amplitude of ``x1`` for which the stuck element holds, Eq. (5)
  (absorber) or Eq. (9) (isolator), for offset 0; for ``x2`` the same limit
  mapped through the stick relation ``x2 = c2 x1 / (c2 - m2 Omega^2)`` of Eq. (4),
  i.e. ``A_L c2 / |c2 - m2 Omega^2|`` (for the absorber ``R / (m2 Omega^2)``: while
  stuck ``H = c2 (x2 - x1)``, which reaches ``R`` there).

References
----------
.. [1] Aramendiz et al., "Sequential friction-spring dampers" (``shared/seed``).
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike, NDArray

from .linear import limit_amplitude, stick_amplitudes

__all__ = ["absorber", "isolator"]

STICK = "linear stick system (Eqs. A.1-A.2)"


def _curves(model: str, eq: str, params: dict, omega: ArrayLike) -> dict[str, dict[str, NDArray]]:
    p = {k: float(v) for k, v in params.items()}
    w = np.asarray(omega, dtype=float)
    a1, a2 = stick_amplitudes(p, w)
    limit = limit_amplitude(model, {**p, "Omega": 1.0}, w)  # Omega is replaced by the grid
    with np.errstate(divide="ignore", invalid="ignore"):
        if model == "absorber":  # A_L c2 / |c2 - m2 W^2| simplified: finite at the antiresonance
            limit_x2 = p["R"] / (p["m2"] * w**2)
        else:
            limit_x2 = limit * p["c2"] / np.abs(p["c2"] - p["m2"] * w**2)
    return {
        STICK: {"x1": np.abs(a1), "x2": np.abs(a2)},
        f"structural-change limit A_L ({eq})": {"x1": limit, "x2": limit_x2},
    }


def absorber(params: dict, omega: ArrayLike) -> dict[str, dict[str, NDArray]]:
    """Overlays of the absorber: stick response and the limit ``A_L(Omega)`` of Eq. (5).

    Parameters
    ----------
    params : dict
        ``m1, m2`` [kg], ``c1, c2, c3`` [N/m], ``R, F`` [N] (``Omega`` ignored).
    omega : array_like
        Excitation frequencies [rad/s].

    Returns
    -------
    dict
        ``{curve label: {"x1": ndarray, "x2": ndarray}}``, amplitudes [m].

    Examples
    --------
    >>> import numpy as np, hybrid_models
    >>> from hybrid_models.overlays import absorber
    >>> c = absorber(hybrid_models.absorber().preset("standard"), np.array([0.5]))
    >>> round(float(c["linear stick system (Eqs. A.1-A.2)"]["x1"][0]), 6)
    0.013953
    """
    return _curves("absorber", "Eq. 5", params, omega)


def isolator(params: dict, omega: ArrayLike) -> dict[str, dict[str, NDArray]]:
    """Overlays of the isolator: stick response and the constant limit ``A_L`` of Eq. (9).

    Parameters and returns as for :func:`absorber`.
    """
    return _curves("isolator", "Eq. 9", params, omega)
