"""Threads of the BLAS library while the engine computes.

The engine's linear algebra is on small and medium matrices (a mode's slave block, an exact flow's
generator, a monodromy matrix: tens to a few hundred rows), solved many thousand times. A
multi-threaded BLAS (OpenBLAS, as numpy's wheels ship it) splits each of them over every core and
spins waiting for its threads; where the cores are busy (a loaded machine, a process pool, a cluster
node shared by several workers) that costs far more than it gains. Measured on a 2-core machine at
load 4 (OpenBLAS 0.3.31): ``numpy.linalg.solve`` of a 128 x 128 system 18.5 ms with its default
threads against 0.33 ms with one; IDA on a chain of 128 contacts spent 80 of 113 s in such solves;
a 20-block chain's periodic orbit took 7.3 s of CPU against 3.1 s.

:func:`blas_threads` limits BLAS to ``HYBRID_BLAS_THREADS`` threads (default 1; ``0`` leaves the
library as it is) for the duration of a computation, through `threadpoolctl
<https://github.com/joblib/threadpoolctl>`_ (the library scikit-learn and joblib use for this).
It is re-entrant and cheap when nested; the previous limits are restored on exit.
"""

from __future__ import annotations

import contextlib
import functools
import os
import sys
import threading
from collections.abc import Callable, Iterator
from typing import TypeVar

from .errors import InputError

__all__ = ["blas_threads", "with_blas_threads", "new_process", "BLAS_THREADS_ENV"]

#: Environment variable: BLAS threads while the engine computes (default 1; 0: not limited).
BLAS_THREADS_ENV = "HYBRID_BLAS_THREADS"

#: Most BLAS threads ``HYBRID_BLAS_THREADS`` may ask for (the libraries take a C ``int``; no machine
#: has more cores).
MAX_BLAS_THREADS = 4096

_state = threading.local()
_controller = None
_modules = -1  # len(sys.modules) when the controller was made
_lock = threading.Lock()

F = TypeVar("F", bound=Callable)


def _limit() -> int:
    text = os.environ.get(BLAS_THREADS_ENV, "1").strip()
    try:
        value = int(text)
    except ValueError:
        value = -1
    if not 0 <= value <= MAX_BLAS_THREADS:
        raise InputError(
            f"{BLAS_THREADS_ENV}={text[:40]!r}: give a number of threads from 1 to {MAX_BLAS_THREADS}, "
            "or 0 to leave BLAS as it is"
        )
    return value


def _get_controller():
    """The threadpoolctl controller of the BLAS libraries loaded now: made again when modules were
    imported since (an import may load another BLAS: scikit-sundae brings its own OpenBLAS, loaded
    with the first IDA run, which a controller made before it would leave unlimited)."""
    global _controller, _modules
    if _controller is None or len(sys.modules) != _modules:
        with _lock:
            if _controller is None or len(sys.modules) != _modules:
                from threadpoolctl import ThreadpoolController

                _controller = ThreadpoolController()
                _modules = len(sys.modules)
    return _controller


@contextlib.contextmanager
def blas_threads() -> Iterator[None]:
    """Limit the BLAS library's threads while the block runs (see the module's docstring)."""
    if getattr(_state, "depth", 0) > 0:
        _state.depth += 1
        try:
            yield
        finally:
            _state.depth -= 1
        return
    n = _limit()
    if n == 0:
        yield
        return
    with _get_controller().limit(limits=n, user_api="blas"):
        _state.depth = 1
        try:
            yield
        finally:
            _state.depth = 0


def with_blas_threads(fn: F) -> F:
    """Decorator: ``fn`` runs under :func:`blas_threads`."""

    @functools.wraps(fn)
    def wrapper(*args, **kwargs):
        with blas_threads():
            return fn(*args, **kwargs)

    return wrapper  # type: ignore[return-value]


def new_process() -> None:
    """In a process just forked (a pool's worker): forget the limits this thread was inside in the
    parent, so that the next :func:`blas_threads` limits every BLAS library loaded here (one
    loaded after the fork included) rather than nest in the parent's block."""
    _state.depth = 0
