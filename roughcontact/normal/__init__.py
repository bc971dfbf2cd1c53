"""Normal contact of a composite topography against an elastic half-space (§2–§3.1)."""
from .active_set import ActiveSetSettings, ActiveSetSolver, solve_closures, solve_loads
from .problem import NormalProblem
from .result import NormalResult
from .solver import METHODS, NormalSolver, make_solver

__all__ = ["ActiveSetSettings", "ActiveSetSolver", "METHODS", "NormalProblem", "NormalResult",
           "NormalSolver", "make_solver", "solve_closures", "solve_loads"]
