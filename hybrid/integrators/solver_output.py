"""What a solver prints while a thread runs it, kept off the program's stdout (issue 29).

scikit-sundae reports SUNDIALS' errors (``"[IDASolve, Error: -1] At t = 7.05, mxstep steps taken
before reaching tout."``) with Python's ``print`` from its Cython error handler: the built-in
``print`` is bound when its module is imported and SUNDIALS' own handler (C ``stderr``) is replaced,
so the words reach ``sys.stdout`` and nothing else; there is no option to route or silence them.
They can be caught only there.

:func:`kept_prints` does that without taking the stream from anyone. While at least one thread is
inside it, ``sys.stdout`` is :data:`ROUTER` (put there by the first thread to enter, and the stream it
replaced put back by the last to leave, under one process-wide lock): a write from a thread inside
:func:`kept_prints` is kept for that thread; a write from any other thread goes on to the replaced
stream at once. A program's own output is therefore never held back or lost, whatever its threads
do, and a thread reads only what its own calls printed. A reference to the router kept by the
program (``old = sys.stdout`` while it was in place) keeps passing writes on to the replaced stream;
a stream the program puts in ``sys.stdout`` meanwhile is left in place.
"""

from __future__ import annotations

import os
import re
import sys
import threading
from collections.abc import Iterator
from contextlib import contextmanager
from typing import Any, TextIO

__all__ = ["ROUTER", "Kept", "StdoutRouter", "kept_prints"]


class Kept:
    """What one thread printed inside :func:`kept_prints`.

    Attributes
    ----------
    text : str
        The last non-blank write, stripped, with a leading ``[where, Error: flag]`` tag removed
        (SUNDIALS' message as scikit-sundae prints it); ``""`` if nothing was printed.
    """

    __slots__ = ("text",)

    def __init__(self) -> None:
        self.text = ""

    def write(self, s: str) -> None:
        s = s.strip()
        if s:
            self.text = re.sub(r"^\[[^\]]*\]\s*", "", s)


#: Per thread: ``kept``, the :class:`Kept` of its innermost :func:`kept_prints` (None outside), and
#: ``inside``, how many of them it is in.
_LOCAL = threading.local()
#: Guards the installation of the router and the number of threads inside.
_LOCK = threading.Lock()
_depth = 0


class StdoutRouter:
    """Stands for ``sys.stdout`` while threads run a solver inside :func:`kept_prints`.

    Parameters
    ----------
    target : text stream or None
        The stream it replaced: every write of a thread outside :func:`kept_prints` goes there at
        once (None: dropped, as ``print`` does when ``sys.stdout`` is None). Every other attribute
        (``encoding``, ``fileno``, ``buffer``, ...) is the target's.
    """

    def __init__(self, target: TextIO | None):
        self.target = target

    def write(self, s: str) -> int:
        kept = getattr(_LOCAL, "kept", None)
        if kept is not None:
            kept.write(s)
            return len(s)
        if self.target is None:
            return len(s)
        return self.target.write(s)

    def writelines(self, lines) -> None:
        for line in lines:
            self.write(line)

    def flush(self) -> None:
        if self.target is not None and getattr(_LOCAL, "kept", None) is None:
            self.target.flush()

    def __getattr__(self, name: str) -> Any:
        return getattr(self.target, name)  # (None: an AttributeError naming None)

    def __repr__(self) -> str:
        return f"StdoutRouter({self.target!r})"


#: The one router, made once and never freed: the built-in ``print`` holds ``sys.stdout`` without a
#: reference of its own (CPython 3.11) while it calls ``write``, so a router dropped by another thread
#: leaving meanwhile would be freed under it (measured: a segmentation fault within seconds).
ROUTER = StdoutRouter(None)


def _enter() -> None:
    global _depth
    with _LOCK:
        if _depth == 0 and sys.stdout is not ROUTER:  # (already in place: put back by the program)
            ROUTER.target = sys.stdout
            sys.stdout = ROUTER
        _depth += 1


def _leave() -> None:
    global _depth
    with _LOCK:
        _depth -= 1
        if _depth == 0 and sys.stdout is ROUTER:  # rebound by the program meanwhile: its stream stays
            sys.stdout = ROUTER.target


def _after_fork_in_child() -> None:
    """A forked process has only the thread that forked: the others are not inside any more, and
    the lock may have been held by one of them."""
    global _LOCK, _depth
    _LOCK = threading.Lock()
    _depth = getattr(_LOCAL, "inside", 0)
    if _depth == 0 and sys.stdout is ROUTER:
        sys.stdout = ROUTER.target


if hasattr(os, "register_at_fork"):  # (not on Windows, which does not fork)
    os.register_at_fork(after_in_child=_after_fork_in_child)


@contextmanager
def kept_prints() -> Iterator[Kept]:
    """Keep what this thread prints inside the block (see the module's description).

    Yields
    ------
    Kept
        Filled while the block runs; read it after the block (or inside, after the call).
    """
    kept = Kept()
    outer = getattr(_LOCAL, "kept", None)
    _enter()
    try:
        _LOCAL.inside = getattr(_LOCAL, "inside", 0) + 1
        _LOCAL.kept = kept
        yield kept
    finally:
        _LOCAL.kept = outer
        _LOCAL.inside -= 1
        _leave()
