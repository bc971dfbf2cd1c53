"""What every inner solver of H_SS x = b on the contact set S shares (§3.1).

Newton's evaluations and Hessians, and the CG's free-rotation steps, often
return to the set of the previous solve; building H_SS is collective and
costs an allgather and, for an explicit block, |S|² kernel entries. So
:meth:`ContactSetSubsolver.set_active` rebuilds only when S changed on some
rank (decided on all ranks together).
"""
from __future__ import annotations

import numpy as np


class ContactSetSubsolver:
    """Base of the inner solvers: :meth:`_build` is called when the contact set changes."""

    def __init__(self, flexibility):
        self.flexibility = flexibility
        self._active: np.ndarray | None = None

    def set_active(self, active: np.ndarray) -> None:
        """Restrict to the active local nodes (boolean mask over owned rows)."""
        from mpi4py import MPI

        same = self._active is not None and np.array_equal(self._active, active)
        if self.flexibility.comm.allreduce(0 if same else 1, op=MPI.MAX):
            self._build(active)
            self._active = active.copy()

    def _build(self, active: np.ndarray) -> None:
        raise NotImplementedError
