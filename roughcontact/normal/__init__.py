"""Normal contact of a composite topography against an elastic half-space (§2–§3.1)."""
from .active_set import ActiveSetSettings, ActiveSetSolver
from .cg_settings import CGSettings
from .choice import METHODS
from .constrained_cg import ConstrainedCGSolver
from .factory import make_solver, solve_closures, solve_loads
from .fields import gather_result, write_result
from .problem import NormalProblem
from .result import NormalResult
from .solver import NormalSolver

__all__ = ["ActiveSetSettings", "ActiveSetSolver", "CGSettings", "ConstrainedCGSolver", "METHODS",
           "NormalProblem", "NormalResult", "NormalSolver", "gather_result", "make_solver", "solve_closures",
           "solve_loads", "write_result"]
