"""Options of one integration: :class:`SolverOptions`, holding the integration method.

The method (:class:`hybrid.integrators.ida.IDA`, :class:`hybrid.integrators.exact.Exact`) owns
what belongs to it (IDA's tolerances, each method's noise model); :class:`SolverOptions` holds
what every run has whatever its method (budgets, the step bound, switch handling). The spelling of
earlier versions (``SolverOptions(rtol=..., atol=..., integrator="exact")``) is refused with a
message that gives the new one.

>>> from hybrid import IDA, Exact, SolverOptions
>>> SolverOptions(method=IDA(rtol=1e-9)).method.rtol
1e-09
>>> SolverOptions(rtol=1e-9)  # doctest: +ELLIPSIS
Traceback (most recent call last):
...
hybrid.core.errors.InputTypeError: SolverOptions: `rtol` belongs to the integration method now: ...
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field, fields, replace

from ..core.errors import InputError, InputTypeError
from ..core.options import check_positive, plain_number
from .base import Method
from .ida import IDA
from .registry import METHODS

__all__ = ["SolverOptions", "LEGACY_FIELDS"]

#: Fields of ``SolverOptions`` of earlier versions that belong to the method now.
LEGACY_FIELDS = ("rtol", "atol", "atol_default", "max_num_steps", "guard_noise", "integrator")


def legacy_spelling(old: dict) -> str:
    """The method that ``SolverOptions(**old)`` of earlier versions meant, as code
    (``method=IDA(rtol=1e-09)``, ``method=Exact()``)."""
    cls = METHODS.get(old.get("integrator"), IDA)
    takes = {f.name for f in fields(cls) if f.init}
    keep = {k: v for k, v in old.items() if k in takes}
    return f"method={cls.__name__}({', '.join(f'{k}={v!r}' for k, v in keep.items())})"


@dataclass(frozen=True, init=False)
class SolverOptions:
    """Options of one integration (:func:`hybrid.simulate`, a period map, a branch's runs).

    Attributes
    ----------
    method : Method
        The integration method and its own settings: :class:`hybrid.IDA` (default ``IDA()``:
        SUNDIALS IDA, any model, ``rtol`` 1e-8, ``atol`` 1e-10) or :class:`hybrid.Exact`
        (matrix exponentials and exact guard roots, for models whose modes and guards are affine
        in the state with time only in sin/cos of one forcing frequency; no tolerances).
    max_step : float or None
        Largest step [s]. ``None``: a sixteenth of the forcing period, or a fiftieth of the time
        span if the system declares no period.
    max_steps : int
        Budget of one integration (a simulation, or the variational run of one period), all modes
        and calls together, counted in IDA residual evaluations (every internal step takes at
        least one; with the exact Jacobian usually one or two). A run that exhausts it stops with
        ``Status.STEP_LIMIT``; so does a run that, after 2 % of it (and at least 20 000), needs
        more than four times it at its rate so far (e.g. dynamics far faster than the forcing).
        The default allows about ten thousand forcing periods of the shipped models.
    max_wall_time : float
        Wall-clock budget of one integration [s] (``Status.TIME_LIMIT``). A whole computation is
        limited by :func:`hybrid.time_limit`.
    zeno_count : int
        A burst of this many transitions ...
    zeno_window : float or None
        ... within this time [s] stops the run as a Zeno burst. ``None``: 1e-6 times the forcing
        period, or 1e-6 s for a model without one (independent of the time span).
    max_chain : int
        Transitions allowed at one instant (chained switches) before the run stops with "no
        admissible mode"; for a system with components, this many per component and as many again.
    taylor_order : int
        Order of the Taylor series used to decide the successor mode at a switch where a guard of
        the new mode starts at zero.

    Notes
    -----
    Changed in this version: ``rtol``, ``atol``, ``atol_default``, ``max_num_steps`` and
    ``guard_noise`` belong to the method (``SolverOptions(method=IDA(rtol=1e-9))``), and
    ``integrator="exact"`` is ``method=Exact()``; the old spelling raises
    :class:`hybrid.core.errors.InputTypeError` naming the new one.
    """

    method: Method = field(default_factory=IDA)
    max_step: float | None = None
    max_steps: int = 10_000_000
    max_wall_time: float = 900.0
    zeno_count: int = 20
    zeno_window: float | None = None
    max_chain: int = 8
    taylor_order: int = 4

    def __init__(
        self,
        *,
        method: Method | None = None,
        max_step: float | None = None,
        max_steps: int = 10_000_000,
        max_wall_time: float = 900.0,
        zeno_count: int = 20,
        zeno_window: float | None = None,
        max_chain: int = 8,
        taylor_order: int = 4,
        **unexpected,
    ):
        old = {k: unexpected.pop(k) for k in LEGACY_FIELDS if k in unexpected}
        if unexpected:
            raise InputTypeError(
                f"SolverOptions: no option {', '.join(map(repr, unexpected))}; options: method, max_step, "
                "max_steps, max_wall_time, zeno_count, zeno_window, max_chain, taylor_order"
            )
        if old:
            raise InputTypeError(
                f"SolverOptions: {', '.join(f'`{k}`' for k in old)} "
                f"{'belongs' if len(old) == 1 else 'belong'} to the integration method now: write "
                f"SolverOptions({legacy_spelling(old)}) (IDA's tolerances are IDA(rtol=..., atol=...); "
                "the exact method has none)"
            )
        method = IDA() if method is None else method
        if not isinstance(method, Method):
            raise InputTypeError(
                "SolverOptions: `method` must be an integration method such as hybrid.IDA(rtol=1e-8) or "
                f"hybrid.Exact(), got {method!r}"
            )
        max_step, max_steps, max_wall_time, zeno_count, zeno_window, max_chain, taylor_order = (
            plain_number(v)
            for v in (max_step, max_steps, max_wall_time, zeno_count, zeno_window, max_chain, taylor_order)
        )
        values = dict(
            method=method,
            max_step=max_step,
            max_steps=max_steps,
            max_wall_time=max_wall_time,
            zeno_count=zeno_count,
            zeno_window=zeno_window,
            max_chain=max_chain,
            taylor_order=taylor_order,
        )
        for k, v in values.items():
            object.__setattr__(self, k, v)
        check_positive("SolverOptions", "max_step", max_step, allow_none=True)
        check_positive("SolverOptions", "zeno_window", zeno_window, allow_none=True)
        check_positive("SolverOptions", "max_wall_time", max_wall_time)
        for name in ("max_steps", "zeno_count", "max_chain", "taylor_order"):
            v = values[name]
            if isinstance(v, bool) or not isinstance(v, int) or v < 1:
                raise InputError(f"SolverOptions: `{name}` must be an integer >= 1, got {v!r}")
        if taylor_order < 2:
            raise InputError(
                "SolverOptions: `taylor_order` must be >= 2 (a switch into stick needs the second order)"
            )

    #: Keywords of earlier versions that :func:`hybrid.core.options.reject_keywords` turns into the
    #: new spelling (:meth:`spelled_with`).
    LOOSE_KEYWORDS = LEGACY_FIELDS

    def spelled_with(self, old: Mapping) -> str:
        """The call that builds these options with the settings ``old`` of the earlier spelling
        (``rtol``, ``integrator``, ...) applied, as code: ``SolverOptions(method=IDA(rtol=1e-09))``.
        A method named by ``integrator`` replaces this one (its settings, where they apply, kept)."""
        cls = METHODS.get(old.get("integrator"), type(self.method))
        takes = [f.name for f in fields(cls) if f.init]
        mine = self.method.settings() if type(self.method) is cls else {}
        settings = {**mine, **{k: v for k, v in old.items() if k != "integrator"}}
        default = cls().settings()
        args = [f"{k}={settings[k]!r}" for k in takes if k in settings and settings[k] != default.get(k)]
        rest = [
            f"{f.name}={getattr(self, f.name)!r}"
            for f in fields(self)
            if f.name != "method" and getattr(self, f.name) != f.default
        ]
        method = f"method={cls.__name__}({', '.join(args)})"
        return f"SolverOptions({', '.join([method, *rest])})"

    def with_method(self, method: Method) -> SolverOptions:
        """These options with another method."""
        return replace(self, method=method)
