"""hybrid: event-driven simulation of hybrid (Filippov / stick-slip) systems on SUNDIALS IDA.

A model is data: a :class:`HybridSystem` of named variables, parameters,
modes (derivatives and algebraic equations as expression strings), guarded
transitions and resets. :func:`simulate` integrates it event-driven, with the
slave (algebraic) variables of each mode solved as a DAE by IDA.
"""

from ._autobranch import EquilibriumBranch as EquilibriumBranch
from ._autobranch import OrbitBranch as OrbitBranch
from ._autobranch import equilibrium_branch as equilibrium_branch
from ._autobranch import hopf_branch as hopf_branch
from ._autobranch import orbit_branch as orbit_branch
from ._autonomous import autonomous_orbit as autonomous_orbit
from ._budget import time_limit as time_limit
from ._continuation import Branch as Branch
from ._continuation import SpecialPoint as SpecialPoint
from ._continuation import continuation as continuation
from ._continuation import forcing_parameter as forcing_parameter
from ._equilibria import Equilibrium as Equilibrium
from ._equilibria import equilibrium as equilibrium
from ._equilibria import locate_hopf as locate_hopf
from ._expr import FUNCTIONS as FUNCTIONS
from ._expr import ExpressionError as ExpressionError
from ._filippov import filippov_system as filippov_system
from ._frc import FrequencyResponse as FrequencyResponse
from ._frc import frequency_response as frequency_response
from ._io import EventsCSVWriter as EventsCSVWriter
from ._io import TrajectoryCSVWriter as TrajectoryCSVWriter
from ._loader import load_system as load_system
from ._loader import system_from_dict as system_from_dict
from ._options import ContinuationOptions as ContinuationOptions
from ._options import SolverOptions as SolverOptions
from ._orbit import ORBIT_OPTIONS as ORBIT_OPTIONS
from ._orbit import PeriodicOrbit as PeriodicOrbit
from ._palc import PalcSettings as PalcSettings
from ._plothints import plot_hints as plot_hints
from ._progress import ProgressBar as ProgressBar
from ._record import Envelope as Envelope
from ._record import Sink as Sink
from ._record import Tee as Tee
from ._shooting import periodic_orbit as periodic_orbit
from ._simulate import SimulationError as SimulationError
from ._simulate import initial_state as initial_state
from ._simulate import simulate as simulate
from ._sweep import Axis as Axis
from ._sweep import SweepResult as SweepResult
from ._sweep import linear_axis as linear_axis
from ._sweep import load_sweep as load_sweep
from ._sweep import log_axis as log_axis
from ._sweep import model_hash as model_hash
from ._sweep import sweep as sweep
from ._system import HybridSystem as HybridSystem
from ._system import Mode as Mode
from ._system import ModelError as ModelError
from ._system import Parameter as Parameter
from ._system import Transition as Transition
from ._system import Variable as Variable
from ._trajectory import Status as Status
from ._trajectory import Trajectory as Trajectory
from ._trajectory import TransitionRecord as TransitionRecord

__version__ = "0.1.0"
