"""A dependency-free text progress bar for long runs (written to stderr)."""

from __future__ import annotations

import sys
import time
from typing import TextIO

__all__ = ["ProgressBar"]


class ProgressBar:
    """Callable ``bar(fraction, detail="")`` drawing ``label [#####.....]  42%  3.1 s  detail`` on one line.

    Parameters
    ----------
    label : str
        Text before the bar.
    stream : file, optional
        Where to draw (default ``sys.stderr``).
    enabled : bool, optional
        Draw at all (default: only if the stream is a terminal).
    """

    def __init__(
        self, label: str, stream: TextIO | None = None, enabled: bool | None = None, width: int = 30
    ):
        self.label = label
        self.stream = stream if stream is not None else sys.stderr
        self.enabled = self.stream.isatty() if enabled is None else enabled
        self.width = width
        self.t0 = time.perf_counter()
        self._last = (-1, "")

    def __call__(self, fraction: float, detail: str = "") -> None:
        if not self.enabled:
            return
        fraction = min(max(float(fraction), 0.0), 1.0)
        pct = int(100 * fraction)
        if (pct, detail) == self._last:
            return
        self._last = (pct, detail)
        filled = int(self.width * fraction)
        bar = "#" * filled + "." * (self.width - filled)
        elapsed = time.perf_counter() - self.t0
        self.stream.write(
            f"\r{self.label} [{bar}] {pct:3d}%  {elapsed:5.1f} s" + (f"  {detail}\x1b[K" if detail else "")
        )
        if fraction >= 1.0:
            self.stream.write("\n")
        self.stream.flush()
