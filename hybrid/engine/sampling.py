"""The sample times of a run (an array, a grid made on demand, or every internal step) and the caps
on how many a run may record."""

from __future__ import annotations

import math

import numpy as np

from ..core.errors import InputError
from .record import MAX_SAMPLES, MAX_STREAMED_SAMPLES

__all__ = []


def check_sample_count(samples, span: float, max_step: float, streamed: bool) -> None:
    """Refuse, before the run, more samples than a run may record (in memory, or handed to a sink)."""
    cap = MAX_STREAMED_SAMPLES if streamed else MAX_SAMPLES
    advice = (
        "sample less or shorten the run"
        if streamed
        else "stream them to a sink, sample less or shorten the run"
    )
    where = "handed to a sink" if streamed else "kept in memory"
    if samples is None:
        n = math.ceil(min(span / max_step, 1e18))
        if n > cap:
            raise InputError(
                f"sampling every internal step of at most {max_step:.6g} s over {span:.6g} s makes at least {n} "
                f"samples; at most {cap} may be {where}: give `samples_per_period` or `t_eval`, or {advice}"
            )
        return
    n = samples.size
    if n > cap:
        what = getattr(samples, "description", f"{n} sample times")
        raise InputError(f"{what} make {n} samples; at most {cap} may be {where}: {advice}")


class SampleGrid:
    """The sample times ``t0 + i*h <= t1`` (``i = 0, 1, ...``), then ``t1`` if the last falls short of it.

    Computed on demand (constant memory); indexable like the array it stands for.
    """

    def __init__(self, t0: float, h: float, n: int, t1: float, description: str):
        while n > 0 and t0 + n * h > t1:
            n -= 1
        self.t0, self.h, self.n, self.t1 = t0, h, n, t1
        self.size = n + 1 + int(t0 + n * h < t1)
        self.description = description

    def __getitem__(self, i: int) -> float:
        if not 0 <= i < self.size:
            raise IndexError(i)
        return self.t0 + i * self.h if i <= self.n else self.t1

    def searchsorted(self, t: float, side: str) -> int:
        """As ``np.searchsorted(times, t, side)`` on the array of the grid's times."""
        k = min(max(int(math.floor((t - self.t0) / self.h)) - 1, 0), self.size)
        while k < self.size and (self[k] < t or (side == "right" and self[k] == t)):
            k += 1
        while k > 0 and (self[k - 1] > t or (side == "left" and self[k - 1] == t)):
            k -= 1
        return k

    def times(self, a: int, b: int) -> np.ndarray:
        """The times ``a`` to ``b - 1`` as an array."""
        return np.array([self[i] for i in range(a, b)])


def sample_times(t_eval, spp, period, t0, t1) -> np.ndarray | SampleGrid | None:
    if t_eval is not None and spp is not None:
        raise InputError("give `t_eval` or `samples_per_period`, not both")
    if spp is not None:
        if isinstance(spp, bool) or not isinstance(spp, int) or spp < 1:
            raise InputError(f"`samples_per_period` must be an integer >= 1, got {spp!r}")
        if period is None:
            raise InputError("`samples_per_period` needs a model with a forcing period")
        n = int(math.floor(min((t1 - t0) / period * spp, 1e12) + 1e-9))
        what = f"{(t1 - t0) / period:.6g} periods at `samples_per_period` = {spp}"
        return SampleGrid(t0, period / spp, n, t1, what)
    if t_eval is None:
        return None
    ts = np.asarray(t_eval, dtype=float).ravel()
    if ts.size > MAX_STREAMED_SAMPLES:
        raise InputError(f"`t_eval` has {ts.size} times; at most {MAX_STREAMED_SAMPLES} are allowed")
    if ts.size == 0 or not np.all(np.isfinite(ts)):
        raise InputError("`t_eval` must be a non-empty array of finite times")
    if np.any(np.diff(ts) < 0) or ts[0] < t0 or ts[-1] > t1:
        raise InputError(f"`t_eval` must be increasing and lie within t_span [{t0}, {t1}]")
    return ts
