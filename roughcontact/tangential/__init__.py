"""Tangential loading of a rough contact: the discrete Cattaneo theorem (§4–§5).

A partial-slip state at shear load Q is the difference of two normal
solutions (Eqs. 21–24): :class:`CattaneoSolver` builds it at one Q,
:func:`tangential_sweep` over Q from 0 to fP, :func:`fretting_cycle` the
cyclic (Mindlin–Deresiewicz) loop between ±Q*, :func:`tangential_history`
any Q(t) with reversals and :func:`fretting_map` the energy per cycle against
the amplitude. Results are exact for β = γ
= 0 and labelled the uncoupled approximation otherwise (:mod:`.model`), with
the measured error of that approximation (:mod:`.uncoupled_error`).
"""
from .cattaneo import CattaneoSolver, first_touch_gap, incipient_sliding_energy
from .dataset import fretting_dataset, fretting_map_dataset, tangential_dataset
from .energy import frictional_energy, loop_area, stored_energy, work
from .fretting import FrettingCycle, fretting_cycle, reversal_traction
from .fretting_map import FrettingMap, fretting_map
from .history import TangentialHistory, tangential_history
from .model import CattaneoConsistencyWarning, UncoupledApproximationWarning, cattaneo_model
from .result import TangentialState
from .sweep import TangentialSweep, tangential_loads, tangential_sweep

__all__ = ["CattaneoConsistencyWarning", "CattaneoSolver", "FrettingCycle", "FrettingMap", "TangentialHistory",
           "TangentialState", "TangentialSweep", "UncoupledApproximationWarning", "cattaneo_model",
           "first_touch_gap", "fretting_cycle", "fretting_dataset", "fretting_map", "fretting_map_dataset",
           "frictional_energy", "incipient_sliding_energy", "loop_area",
           "reversal_traction", "stored_energy", "tangential_dataset", "tangential_history",
           "tangential_loads", "tangential_sweep", "work"]
