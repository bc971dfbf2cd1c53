"""Normal contact of a composite topography against an elastic half-space (§2–§3.1)."""
from .active_set import ActiveSetSettings, ActiveSetSolver, solve_closures, solve_loads
from .problem import NormalProblem
from .result import NormalResult

__all__ = ["ActiveSetSettings", "ActiveSetSolver", "NormalProblem", "NormalResult",
           "solve_closures", "solve_loads"]
