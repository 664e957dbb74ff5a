"""Where the section of a periodic orbit is put: in the middle of the longest mode interval of a
run's last period, so that the map is smooth near the orbit and the mode at ``t0 + T`` equals the
mode at ``t0``."""

from __future__ import annotations

import math

import numpy as np

from ..engine.trajectory import Trajectory, sampled_trajectory

__all__ = ["choose_section_period"]


def _choose_section(tr: Trajectory, T: float) -> tuple[float, np.ndarray, str]:
    """Section time/state/mode in the middle of the longest mode interval of the run's last period.

    The interval across the period boundary counts as one (its first and last pieces joined).
    """
    t_end = tr.t_final
    t_start = t_end - T
    ivs = [(max(a, t_start), b, m) for a, b, m in tr.mode_intervals() if b > t_start]
    if len(ivs) <= 1:
        return t_end, tr.y_final, tr.mode_final
    first, last = ivs[0], ivs[-1]
    cands = list(ivs[1:-1])
    if first[2] == last[2]:
        cands.append((last[0], first[1] + T, last[2]))  # wrapped interval
    else:
        cands += [first, last]
    a, b, m = max(cands, key=lambda iv: iv[1] - iv[0])
    tm = 0.5 * (a + b)
    if tm > t_end:
        tm -= T
    k = int(np.argmin(np.abs(tr.t - tm)))
    return float(tr.t[k]), tr.y[k].copy(), str(tr.mode[k])


def choose_section_period(tr: Trajectory, T: float) -> tuple[float, np.ndarray, str]:
    t, y, m = _choose_section(sampled_trajectory(tr), T)
    return t - math.floor(t / T) * T, y, m
