"""Krylov solves on the current contact set: H_SS p_S = b with a PETSc KSP (§3.1).

The sub-operator H_SS is ``H.createSubMatrix(S, S)``, so any PETSc Mat that
supports ``createSubMatrix`` (dense, or a matrix-free Python context) works.
Defaults (CG, no preconditioner: the Eq. 10 matrix is symmetric positive
definite with a constant diagonal) are set in code, then ``setFromOptions``
reads the options database under the prefix (default ``normal_``), so
``-normal_ksp_type gmres -normal_ksp_monitor`` work from the command line.
Every solve checks the converged reason; a negative reason raises
:class:`~roughcontact.errors.ConvergenceError` naming it.
"""
from __future__ import annotations

import numpy as np
from petsc4py import PETSc

from ..errors import ConvergenceError

_REASONS = {getattr(PETSc.KSP.ConvergedReason, k): k
            for k in dir(PETSc.KSP.ConvergedReason) if k.isupper()}


def ksp_reason_name(reason: int) -> str:
    """The name of a KSPConvergedReason value, e.g. ``DIVERGED_ITS``."""
    return _REASONS.get(int(reason), str(int(reason)))


class OptionsScope:
    """Insert options under a prefix for the life of an object, then remove them."""

    def __init__(self, prefix: str, options: dict | None):
        self.prefix = prefix
        self.keys = []
        db = PETSc.Options()
        for key, value in (options or {}).items():
            name = prefix + key.lstrip("-")
            db.setValue(name, "" if value is None else str(value))
            self.keys.append(name)

    def close(self) -> None:
        db = PETSc.Options()
        for name in self.keys:
            db.delValue(name)
        self.keys = []


class KSPSubsolver:
    """Solve H_SS x = b on the active set with a PETSc KSP.

    Parameters
    ----------
    operator
        The full flexibility Mat H.
    start
        First global row owned by this rank.
    prefix
        Options prefix (``normal_``).
    rtol, max_it
        Defaults written before ``setFromOptions``.
    options
        Extra options (``{"ksp_type": "gmres"}``) set under the prefix for the
        life of this object.
    """

    name = "ksp"

    def __init__(self, operator: PETSc.Mat, start: int, prefix: str = "normal_",
                 rtol: float = 1e-11, max_it: int = 10000, options: dict | None = None):
        self.operator = operator
        self.start = start
        self.scope = OptionsScope(prefix, options)
        self.ksp = PETSc.KSP().create(operator.getComm())
        self.ksp.setOptionsPrefix(prefix)
        self.ksp.setType(PETSc.KSP.Type.CG)
        self.ksp.getPC().setType(PETSc.PC.Type.NONE)
        self.ksp.setTolerances(rtol=rtol, atol=0.0, max_it=max_it)
        self.ksp.setInitialGuessNonzero(True)
        self.ksp.setFromOptions()
        self.sub = None
        self.index_set = None
        self.x = self.b = self.r = None

    @property
    def description(self) -> str:
        rtol, atol, _, max_it = self.ksp.getTolerances()
        return (f"{self.ksp.getType()}+{self.ksp.getPC().getType()} "
                f"(rtol={rtol:g}, max_it={max_it})")

    def set_active(self, active: np.ndarray) -> None:
        """Restrict to the active local nodes (boolean mask over owned rows)."""
        self._free_sub()
        rows = (np.flatnonzero(active) + self.start).astype(PETSc.IntType)
        self.index_set = PETSc.IS().createGeneral(rows, comm=self.operator.getComm())
        self.sub = self.operator.createSubMatrix(self.index_set, self.index_set)
        self.ksp.setOperators(self.sub)
        self.x, self.b = self.sub.createVecs()
        self.r = self.b.duplicate()

    def solve(self, rhs: np.ndarray, guess: np.ndarray) -> tuple[np.ndarray, int]:
        self.b.getArray()[:] = rhs
        self.x.getArray()[:] = guess
        # a warm start worse than zero (a much smaller load, a receding set) is dropped: CG
        # would otherwise start from a residual far above |b| and may stop on PETSc's
        # divergence test before its first iteration
        self.sub.mult(self.x, self.r)
        self.r.aypx(-1.0, self.b)
        if self.r.norm() > self.b.norm():
            self.x.set(0.0)
        self.ksp.solve(self.b, self.x)
        reason = self.ksp.getConvergedReason()
        its = self.ksp.getIterationNumber()
        if reason < 0:
            raise ConvergenceError(
                "KSP_" + ksp_reason_name(reason),
                f"the Krylov solve on the contact set ({self.sub.getSize()[0]} nodes, "
                f"{self.description}) stopped after {its} iterations with residual norm "
                f"{self.ksp.getResidualNorm():.3e}; raise -{self.ksp.getOptionsPrefix()}ksp_max_it "
                "or loosen -ksp_rtol")
        return self.x.getArray().copy(), its

    def _free_sub(self) -> None:
        # the contact set changes size: the KSP must drop its old work vectors
        self.ksp.reset()
        for obj in (self.sub, self.index_set, self.x, self.b, self.r):
            if obj is not None:
                obj.destroy()
        self.sub = self.index_set = self.x = self.b = self.r = None

    def destroy(self) -> None:
        self._free_sub()
        self.ksp.destroy()
        self.scope.close()
