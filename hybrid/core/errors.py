"""The exceptions of :mod:`hybrid`: one base, :class:`HybridError`, and a typed subclass per cause.

Every error that :mod:`hybrid` raises on purpose derives from :class:`HybridError`, so that a
caller may catch all of them at once. Each subclass also derives from the built-in exception
a caller would expect for its cause (bad input: ``ValueError``; a failed computation:
``RuntimeError``), so ``except ValueError`` keeps working; its docstring names that built-in.
Import them from here (or from :mod:`hybrid`), not from the modules that raise them.

A failure of the model's own arithmetic (a division by zero, the logarithm of a negative number
in an equation) stays the built-in Python raises (``ZeroDivisionError``, ``ValueError``, ...):
it is reported as an evaluation failure, never taken for one of these.

Bad input raises at construction or before any integration; a computation that fails is
returned as data where a result type exists (``status``, ``reason``, ``message``) and raised
only where there is none, or where the caller asked for it (``simulate(..., throw=True)``).
"""

from __future__ import annotations

__all__ = [
    "HybridError",
    "InputError",
    "InputTypeError",
    "ModelError",
    "ExpressionError",
    "NotAffineError",
    "SimulationError",
    "AlgebraicSolveError",
    "IntegratorError",
    "BudgetExceeded",
    "ConvergenceError",
    "GrazingSwitchError",
    "ParameterOutOfDomain",
    "SampleCapReached",
    "WorkerError",
    "OutputError",
    "FolderInUse",
]


class HybridError(Exception):
    """Base of every exception raised by :mod:`hybrid` on purpose."""


class InputError(HybridError, ValueError):
    """An argument or option is invalid (a :class:`ValueError`): out of its domain, or inconsistent
    with the model or with another argument (bad input other than the model's definition, which is
    a :class:`ModelError`)."""


class InputTypeError(HybridError, TypeError):
    """An argument has the wrong type (a :class:`TypeError`), e.g. ``options`` that is not a
    :class:`hybrid.SolverOptions`."""


class ModelError(HybridError, ValueError):
    """A hybrid-system definition is inconsistent (unknown name, missing equation, ...), or the model
    lacks what a computation needs (e.g. a forcing period for forced periodic orbits); a
    :class:`ValueError`."""


class ExpressionError(ModelError):
    """An expression of a model is malformed, uses a forbidden construct or an unknown name (a
    :class:`ValueError`, as every :class:`ModelError`)."""


class NotAffineError(ExpressionError):
    """A mode is not affine in its state (or time enters otherwise than through one forcing
    frequency): the exact integrator cannot take it (a :class:`ValueError`, as every
    :class:`ModelError`)."""


class SimulationError(HybridError, RuntimeError):
    """A simulation stopped before the end of its time span (raised when ``throw=True``), or a run
    of a map did not give what the map needs (it failed, or never returned to its section); a
    :class:`RuntimeError`."""


class AlgebraicSolveError(HybridError, RuntimeError):
    """The slave variables of a mode could not be solved from their algebraic equations (a
    :class:`RuntimeError`)."""


class IntegratorError(HybridError, RuntimeError):
    """An integrator failed outside a simulation's event loop (e.g. in the variational
    equations of a monodromy, or interpolating a step); a :class:`RuntimeError`."""


class BudgetExceeded(HybridError):
    """A budget of an integration was exhausted.

    Derives from no built-in exception beyond ``Exception``: a recovery from a failed run
    (``except RuntimeError``) does not swallow it.

    Attributes
    ----------
    kind : {"steps", "projected", "time"}
        ``"steps"``: ``SolverOptions.max_steps`` residual evaluations were used;
        ``"projected"``: at its rate so far the run would need several times that;
        ``"time"``: the wall-clock budget or the computation's deadline ran out.
    message : str
    """

    def __init__(self, kind: str, message: str):
        super().__init__(message)
        self.kind = kind
        self.message = message


class ConvergenceError(HybridError, RuntimeError):
    """An iteration did not converge where no result type can report it (e.g. an equilibrium
    along the bracket of :func:`hybrid.locate_hopf`); a :class:`RuntimeError`."""


class GrazingSwitchError(HybridError, ZeroDivisionError):
    """A guard crosses zero at a vanishing rate (a grazing switch): no saltation matrix exists
    there, so no monodromy matrix either. (A :class:`ZeroDivisionError`: the saltation matrix
    divides by that rate.)"""


class ParameterOutOfDomain(HybridError, ValueError, RuntimeError):
    """An iteration (e.g. a continuation's corrector) reached a parameter value, or an unknown such
    as an autonomous orbit's period, outside its domain: a failed iteration (a
    :class:`RuntimeError` to the caller's recovery), not bad input, though a
    :class:`ValueError` too, as the domain check of the parameter it comes from."""


class SampleCapReached(HybridError):
    """A run would record more samples than it may keep (derives from no built-in exception beyond
    ``Exception``; a simulation reports it as ``Status.MAX_SAMPLES``)."""


class WorkerError(HybridError, RuntimeError):
    """A worker process of a parallel computation failed (its exception's type and message are in
    this one's) or ended without a result; a :class:`RuntimeError`."""


class OutputError(HybridError, OSError):
    """Writing a result failed (a full disk, no permission, a read-only file system, a folder where
    a file goes, ...): an :class:`OSError` whose message is one line naming the path, the cause and
    what to do (:func:`hybrid.core.files.os_error_text`); ``errno`` is the cause's."""

    def __init__(self, message: str, code: int | None = None):
        super().__init__(message)
        self.errno = code


class FolderInUse(InputError):
    """Another run holds the lock of the output folder (:class:`hybrid.core.files.FolderLock`):
    refused before any computation, as bad input is (a :class:`ValueError`)."""
