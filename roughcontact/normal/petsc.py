"""Krylov solves on the current contact set: H_SS p_S = b with a PETSc KSP (§3.1).

The sub-operator H_SS is the operator's block on S
(:meth:`~roughcontact.operators.flexibility.Flexibility.block`): an explicit
matrix when S is small, the matrix-free restriction otherwise. Defaults are
set in code: CG (the Eq. 10 matrix is symmetric positive definite), without
preconditioner on an explicit block (its diagonal is constant) and with the
Fourier preconditioner of the contact set (:class:`FourierPC`, a Python PC)
on a matrix-free one; then ``setFromOptions`` reads the options database
under the prefix (default ``normal_``), so ``-normal_ksp_type gmres
-normal_pc_type none -normal_ksp_monitor`` work from the command line and a
``pc_type`` given there is kept for every block. Every solve checks the
converged reason; a negative reason raises
:class:`~roughcontact.errors.ConvergenceError` naming it. With ``keep_load``
the solves are on the forces of S that sum to zero (:class:`LoadKept`): the
free rotation's Hessian at a constant load.
"""
from __future__ import annotations

import numpy as np
from petsc4py import PETSc

from ..errors import InputError
from ..operators.preconditioner import EDGE_SHARE
from ..petsc import OptionsScope, solve_checked
from .subsolver import ContactSetSubsolver


class FourierPC:
    """Python PC context: z = R_S C⁻¹ R_Sᵀ r − e ∘ r, the Fourier preconditioner of H_SS with its
    edge correction (:mod:`roughcontact.operators.preconditioner`) on the current contact set;
    ``single``: its products in single precision."""

    def __init__(self, flexibility, edge_share: float = EDGE_SHARE, single: bool = False):
        self.flexibility = flexibility
        self.edge_share = edge_share
        self.single = single
        self.nodes: np.ndarray | None = None        # this rank's indices of S
        self.edge: np.ndarray | None = None         # the edge weights on S (None: share 0)

    def set_nodes(self, nodes: np.ndarray) -> None:
        """S by this rank's node indices (collective); its edge weights cost one periodic
        product. On the active set's fixed sets and the free rotation's Hessian solves they took
        a 12-load sweep at 129² (active set) from 4081 to 3842 Krylov iterations and at 257² (CG,
        rotation free) from 1674 to 1614 linear iterations. No fallback as in the constrained
        CG: the corrected block's smallest eigenvalue stayed at 0.19 C⁻¹_ii or above on
        checkerboard, striped, sparse and holed sets (an indefinite one would end the KSP with
        a named ConvergenceError, not a wrong answer)."""
        self.nodes = nodes
        self.edge = self.flexibility.preconditioner.edge_weights(nodes, self.single, self.edge_share) \
            if self.edge_share > 0.0 else None

    def apply(self, pc, x, y):
        y.getArray()[:] = self.flexibility.precondition_nodes(x.getArray(readonly=True), self.nodes,
                                                              self.single, self.edge)


class LoadKept:
    """Python Mat context of P H_SS P, P = I − 1 1ᵀ/|S|: H_SS on the forces of S that sum to zero.

    The Mat carries the constant null space, which PETSc's KSP removes from the preconditioned
    residual (``KSP_PCApply``), so CG on it with any preconditioner of H_SS stays on Σx = 0 and
    solves the saddle point H_SS x + μ 1 = b, 1ᵀx = 0 (μ the approach that keeps the load)."""

    def __init__(self, sub: PETSc.Mat):
        self.sub = sub
        self.nullspace = PETSc.NullSpace().create(constant=True, comm=sub.getComm())
        self.work = sub.createVecLeft()

    def mult(self, mat, x, y):
        x.copy(self.work)
        self.nullspace.remove(self.work)
        self.sub.mult(self.work, y)
        self.nullspace.remove(y)

    multTranspose = mult

    def mat(self) -> PETSc.Mat:
        """The PETSc Mat of this context, with its null space."""
        (local, _), _ = self.sub.getSizes()
        mat = PETSc.Mat().createPython(((local, None), (local, None)), self, comm=self.sub.getComm())
        mat.setOption(PETSc.Mat.Option.SYMMETRIC, True)
        mat.setUp()
        mat.setNullSpace(self.nullspace)
        mat.setTransposeNullSpace(self.nullspace)
        return mat

    def release(self) -> None:
        """Free the work vector and the null space (after the Mat; not ``destroy``, which
        petsc4py calls on a Python Mat's context as the Mat goes)."""
        self.work.destroy()
        self.nullspace.destroy()


class KSPSubsolver(ContactSetSubsolver):
    """Solve H_SS x = b on the active set with a PETSc KSP.

    Parameters
    ----------
    flexibility
        The operator H (:class:`~roughcontact.operators.flexibility.Flexibility`).
    prefix
        Options prefix (``normal_``).
    rtol, max_it
        Defaults written before ``setFromOptions``.
    options
        Extra options (``{"ksp_type": "gmres"}``) set under the prefix for the
        life of this object. ``fourier_edge_share`` (default ``edge_share``)
        sets the share of the Fourier preconditioner's edge correction (0: the
        plain R_S C⁻¹ R_Sᵀ), e.g. ``-normal_fourier_edge_share 0``.
    edge_share
        The default of that option (the constrained CG passes its own setting).
    single
        The products of a matrix-free block and of its preconditioner in single precision (their
        relative error about 1e-7): for solves far looser than that, as the free rotation's
        Hessian (rtol 1e-3).
    keep_load
        Solve on the forces of S that sum to zero (:class:`LoadKept`): x = H_SS⁻¹ (b − μ 1) with
        Σx = 0 over all ranks, the response of the forces to a rigid motion b at a constant load.
    """

    name = "ksp"

    def __init__(self, flexibility, prefix: str = "normal_",
                 rtol: float = 1e-11, max_it: int = 10000, options: dict | None = None,
                 edge_share: float = EDGE_SHARE, single: bool = False, keep_load: bool = False):
        super().__init__(flexibility)
        self.single = single
        self.keep_load = keep_load
        self.scope = OptionsScope(prefix, options)
        self.ksp = PETSc.KSP().create(flexibility.comm)
        self.ksp.setOptionsPrefix(prefix)
        self.ksp.setType(PETSc.KSP.Type.CG)
        self.ksp.getPC().setType(PETSc.PC.Type.NONE)
        self.ksp.setTolerances(rtol=rtol, atol=0.0, max_it=max_it)
        self.ksp.setInitialGuessNonzero(True)
        self.ksp.setFromOptions()
        # a pc_type from the options database wins over the per-block default
        self.user_pc = PETSc.Options().hasName(prefix + "pc_type")
        share = PETSc.Options().getReal(prefix + "fourier_edge_share", edge_share)
        if not 0.0 <= share < 1.0:
            self.ksp.destroy()
            self.scope.close()
            raise InputError(prefix + "fourier_edge_share", f"must be in [0, 1), got {share!r}")
        self.fourier = FourierPC(flexibility, share, single)
        self.sub = self.operator = self.kept = None
        self.x = self.b = self.r = None

    @property
    def description(self) -> str:
        rtol, atol, _, max_it = self.ksp.getTolerances()
        return (f"{self.ksp.getType()}+{self.ksp.getPC().getType()} "
                f"(rtol={rtol:g}, max_it={max_it})")

    def _build(self, active: np.ndarray) -> None:
        self._free_sub()
        self.sub = self.operator = self.flexibility.block(active, single=self.single)
        if self.keep_load:
            self.kept = LoadKept(self.sub)
            self.operator = self.kept.mat()
        # the projection's Mat solves, the block preconditions: a pc_type of the options database
        # (jacobi, cholesky …) reads the block's entries or diagonal, which the projection has not
        self.ksp.setOperators(self.operator, self.sub)
        if not self.user_pc:
            pc = self.ksp.getPC()
            if self.sub.getType() == PETSc.Mat.Type.PYTHON:
                self.fourier.set_nodes(np.flatnonzero(active))
                pc.setType(PETSc.PC.Type.PYTHON)
                pc.setPythonContext(self.fourier)
            else:
                pc.setType(PETSc.PC.Type.NONE)
        self.x, self.b = self.sub.createVecs()
        self.r = self.b.duplicate()

    def solve(self, rhs: np.ndarray, guess: np.ndarray) -> tuple[np.ndarray, int]:
        self.b.getArray()[:] = rhs
        self.x.getArray()[:] = guess
        if self.kept is not None:                     # both on Σ = 0: the KSP's iterates stay there
            self.kept.nullspace.remove(self.b)
            self.kept.nullspace.remove(self.x)
        its = solve_checked(self.ksp, self.operator, self.b, self.x, self.r,
                            f"the Krylov solve on the contact set ({self.sub.getSize()[0]} nodes, "
                            f"{self.description})")
        if self.kept is not None:
            # the KSP removes the null space after a left preconditioner only: a right-preconditioned
            # or flexible ksp_type of the options database may leave a constant in x
            self.kept.nullspace.remove(self.x)
        return self.x.getArray().copy(), its

    def _free_sub(self) -> None:
        # the contact set changes size: the KSP must drop its old work vectors
        self.ksp.reset()
        if self.kept is not None:
            self.operator.destroy()
            self.kept.release()
        for obj in (self.sub, self.x, self.b, self.r):
            if obj is not None:
                obj.destroy()
        self.sub = self.operator = self.kept = self.x = self.b = self.r = None

    def destroy(self) -> None:
        self._free_sub()
        self.ksp.destroy()
        self.scope.close()
