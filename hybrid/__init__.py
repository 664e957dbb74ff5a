"""hybrid: event-driven simulation of hybrid (Filippov / stick-slip) systems on SUNDIALS IDA.

A model is data: a :class:`HybridSystem` of named variables, parameters,
modes (derivatives and algebraic equations as expression strings), guarded
transitions and resets. :func:`simulate` integrates it event-driven, with the
slave (algebraic) variables of each mode solved as a DAE by IDA.
"""

from .continuation.autonomous import equilibrium_branch as equilibrium_branch
from .continuation.autonomous import hopf_branch as hopf_branch
from .continuation.autonomous import orbit_branch as orbit_branch
from .continuation.backbone import backbone as backbone
from .continuation.backbone_result import Backbone as Backbone
from .continuation.branch import Branch as Branch
from .continuation.branch import forcing_parameter as forcing_parameter
from .continuation.forced import SpecialPoint as SpecialPoint
from .continuation.forced import continue_orbits as continue_orbits
from .continuation.frc import FrequencyResponse as FrequencyResponse
from .continuation.frc import frequency_response as frequency_response
from .continuation.locus import Locus as Locus
from .continuation.locus import LocusPoint as LocusPoint
from .continuation.locus import continue_locus as continue_locus
from .continuation.periodic import periodic_orbit as periodic_orbit
from .continuation.switching import switch_branch as switch_branch
from .core.budget import time_limit as time_limit
from .core.errors import AlgebraicSolveError as AlgebraicSolveError
from .core.errors import BudgetExceeded as BudgetExceeded
from .core.errors import ConvergenceError as ConvergenceError
from .core.errors import ExpressionError as ExpressionError
from .core.errors import FolderInUse as FolderInUse
from .core.errors import GrazingSwitchError as GrazingSwitchError
from .core.errors import HybridError as HybridError
from .core.errors import InputError as InputError
from .core.errors import InputTypeError as InputTypeError
from .core.errors import IntegratorError as IntegratorError
from .core.errors import ModelError as ModelError
from .core.errors import NotAffineError as NotAffineError
from .core.errors import OutputError as OutputError
from .core.errors import ParameterOutOfDomain as ParameterOutOfDomain
from .core.errors import SampleCapReached as SampleCapReached
from .core.errors import SimulationError as SimulationError
from .core.errors import WorkerError as WorkerError
from .core.options import ContinuationOptions as ContinuationOptions
from .core.options import NewtonOptions as NewtonOptions
from .core.options import ShootingOptions as ShootingOptions
from .core.progress import ProgressBar as ProgressBar
from .core.status import SPECIAL_KINDS as SPECIAL_KINDS
from .core.status import BranchStatus as BranchStatus
from .core.status import LocateStatus as LocateStatus
from .core.status import PointStatus as PointStatus
from .core.status import ResponseStatus as ResponseStatus
from .core.status import SolveStatus as SolveStatus
from .core.version import __version__ as __version__
from .engine.io import EventsCSVWriter as EventsCSVWriter
from .engine.io import TrajectoryCSVWriter as TrajectoryCSVWriter
from .engine.record import Envelope as Envelope
from .engine.record import Sink as Sink
from .engine.record import Tee as Tee
from .engine.simulate import initial_state as initial_state
from .engine.simulate import simulate as simulate
from .engine.trajectory import Status as Status
from .engine.trajectory import Trajectory as Trajectory
from .engine.trajectory import TransitionRecord as TransitionRecord
from .integrators.base import Method as Method
from .integrators.exact import Exact as Exact
from .integrators.ida import IDA as IDA
from .integrators.options import SolverOptions as SolverOptions
from .integrators.registry import method_named as method_named
from .model.elements import Component as Component
from .model.elements import Mode as Mode
from .model.elements import Parameter as Parameter
from .model.elements import Transition as Transition
from .model.elements import Variable as Variable
from .model.expr import FUNCTIONS as FUNCTIONS
from .model.filippov import filippov_system as filippov_system
from .model.loader import load_system as load_system
from .model.loader import system_from_dict as system_from_dict
from .model.plot_hints import plot_hints as plot_hints
from .model.registry import resolve_model as resolve_model
from .model.system import HybridSystem as HybridSystem
from .orbits.autonomous import autonomous_orbit as autonomous_orbit
from .orbits.equilibria import Equilibrium as Equilibrium
from .orbits.equilibria import HopfPoint as HopfPoint
from .orbits.equilibria import equilibrium as equilibrium
from .orbits.equilibria import locate_hopf as locate_hopf
from .orbits.orbit import ORBIT_OPTIONS as ORBIT_OPTIONS
from .orbits.orbit import PeriodicOrbit as PeriodicOrbit
from .studies.sweep import Axis as Axis
from .studies.sweep import SweepResult as SweepResult
from .studies.sweep import linear_axis as linear_axis
from .studies.sweep import load_sweep as load_sweep
from .studies.sweep import log_axis as log_axis
from .studies.sweep import model_hash as model_hash
from .studies.sweep import sweep as sweep

__all__ = [
    "Component",
    "AlgebraicSolveError",
    "autonomous_orbit",
    "Axis",
    "Branch",
    "BranchStatus",
    "BudgetExceeded",
    "ContinuationOptions",
    "continue_locus",
    "continue_orbits",
    "ConvergenceError",
    "Envelope",
    "Equilibrium",
    "equilibrium",
    "equilibrium_branch",
    "EventsCSVWriter",
    "ExpressionError",
    "filippov_system",
    "forcing_parameter",
    "frequency_response",
    "FolderInUse",
    "FrequencyResponse",
    "FUNCTIONS",
    "GrazingSwitchError",
    "hopf_branch",
    "HopfPoint",
    "HybridError",
    "HybridSystem",
    "initial_state",
    "InputError",
    "InputTypeError",
    "IntegratorError",
    "linear_axis",
    "load_sweep",
    "load_system",
    "locate_hopf",
    "LocateStatus",
    "Locus",
    "LocusPoint",
    "log_axis",
    "Mode",
    "model_hash",
    "ModelError",
    "NewtonOptions",
    "NotAffineError",
    "orbit_branch",
    "backbone",
    "Backbone",
    "ORBIT_OPTIONS",
    "OutputError",
    "Parameter",
    "ParameterOutOfDomain",
    "periodic_orbit",
    "PeriodicOrbit",
    "plot_hints",
    "PointStatus",
    "ProgressBar",
    "resolve_model",
    "ResponseStatus",
    "SampleCapReached",
    "ShootingOptions",
    "simulate",
    "SimulationError",
    "Sink",
    "SolverOptions",
    "IDA",
    "Exact",
    "Method",
    "method_named",
    "SolveStatus",
    "SPECIAL_KINDS",
    "SpecialPoint",
    "Status",
    "sweep",
    "SweepResult",
    "switch_branch",
    "system_from_dict",
    "Tee",
    "time_limit",
    "Trajectory",
    "TrajectoryCSVWriter",
    "Transition",
    "TransitionRecord",
    "Variable",
    "WorkerError",
]
