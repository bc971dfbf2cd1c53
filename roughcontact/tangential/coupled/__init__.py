"""The coupled tangential problem (β = 0, γ ≠ 0): the reference for the uncoupled Cattaneo model.

- :mod:`.operator`: T of Eqs. 15–16 as PETSc Mats (matrix-free, FFT) and the
  Newton system of an increment;
- :mod:`.increment`: one load increment, Newton on the stick and slip sets
  with Krylov inner solves;
- :mod:`.solver`: :class:`CoupledTangentialSolver`, the state along a load path;
- :mod:`.sweep`: monotonic sweeps of Q; :mod:`.result`: the states.
"""
from .increment import CoupledSettings
from .result import CoupledState, CoupledSweep
from .solver import CoupledTangentialSolver, check_coupled_interface
from .sweep import coupled_sweep

__all__ = ["CoupledSettings", "CoupledState", "CoupledSweep", "CoupledTangentialSolver",
           "check_coupled_interface", "coupled_sweep"]
