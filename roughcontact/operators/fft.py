"""Matrix-free PETSc Mats of the FFT flexibility operator (``Mat.createPython``).

:func:`full_operator` is H over the whole footprint; its ``createSubMatrix``
on a contact set S (the same index set for rows and columns: H_SS) returns
:meth:`~.flexibility.Flexibility.block`, explicit or matrix-free. The
matrix-free H_SS (:func:`restricted_operator`) applies the full convolution
to a vector that is zero outside S and reads the result on S. Both are
symmetric positive definite; their diagonal is the punch self term A/(4a)
(Eq. 10 at r = 0).
"""
from __future__ import annotations

import numpy as np
from petsc4py import PETSc

from ..errors import InputError


class _Full:
    """Python context of H (all footprint nodes)."""

    def __init__(self, flexibility):
        self.flexibility = flexibility

    def mult(self, mat, x, y):
        y.getArray()[:] = self.flexibility.product(x.getArray(readonly=True))

    multTranspose = mult

    def getDiagonal(self, mat, diagonal):
        diagonal.set(self.flexibility.diagonal)

    def createSubMatrix(self, mat, rows, columns, reuse):
        if columns is not None and not rows.equal(columns):
            raise InputError("operator", "only the symmetric restriction H_SS (same rows and columns) "
                                         "of the flexibility operator is available")
        layout = self.flexibility.layout
        active = np.zeros(layout.local_size, dtype=bool)
        active[rows.getIndices() - layout.start] = True
        return self.flexibility.block(active)


class _Restricted:
    """Python context of H_SS: x on S, zero elsewhere, full convolution (``single``: in single
    precision), read on S; it holds S's slab positions, not a vector of the rank's nodes."""

    def __init__(self, flexibility, active: np.ndarray, single: bool = False):
        self.convolution = flexibility.convolution
        self.positions = flexibility.layout.slab_positions(np.flatnonzero(active))
        self.single = single
        self.diagonal = flexibility.diagonal

    def mult(self, mat, x, y):
        # x goes into the transform at S's positions (only S's rows transformed where S is sparse),
        # and the product is read at them before it is cropped: no field of the rank's nodes
        y.getArray()[:] = self.convolution.restricted(x.getArray(readonly=True), self.positions, self.single)

    multTranspose = mult

    def getDiagonal(self, mat, diagonal):
        diagonal.set(self.diagonal)


def _python_mat(context, local: int, comm) -> PETSc.Mat:
    mat = PETSc.Mat().createPython(((local, None), (local, None)), context, comm=comm)
    mat.setOption(PETSc.Mat.Option.SYMMETRIC, True)
    mat.setOption(PETSc.Mat.Option.SPD, True)
    mat.setUp()
    return mat


def full_operator(flexibility) -> PETSc.Mat:
    """H as a matrix-free Mat over the footprint nodes (rows of ``flexibility.layout``)."""
    return _python_mat(_Full(flexibility), flexibility.layout.local_size, flexibility.comm)


def restricted_operator(flexibility, active: np.ndarray, single: bool = False) -> PETSc.Mat:
    """H_SS as a matrix-free Mat over the contact set (``active``: mask of this rank's nodes);
    ``single``: its products in single precision."""
    return _python_mat(_Restricted(flexibility, active, single), int(active.sum()), flexibility.comm)
