"""The flexibility operator H of Eqs. 9–11 as an explicit distributed PETSc matrix (MATDENSE).

Rows are split over the ranks by blocks of grid rows (:mod:`.layout`). H is
symmetric, so the local block of rows, which PETSc stores column-major, is
the C-ordered array whose row j holds H[j, owned nodes]: each rank fills
that array once, row by row, as strided windows of the Eq. 10 table
(:func:`~.kernel.influence_rows`), and hands it to PETSc without a copy.
"""
from __future__ import annotations

import numpy as np
from petsc4py import PETSc

from .kernel import influence_rows
from .layout import NodeLayout


def assemble_flexibility(kernel: np.ndarray, layout: NodeLayout, comm) -> PETSc.Mat:
    """Dense flexibility matrix H (Eq. 10) over the footprint nodes, rows of ``layout``.

    Parameters
    ----------
    kernel
        The Eq. 10 table of :func:`~.kernel.punch_kernel` (entries in m/N).
    layout
        Which nodes (rows) this rank owns.
    comm
        mpi4py communicator of the matrix.
    """
    n, local = layout.size, layout.local_size
    # row j of this C-ordered array is column j of the local rows (H is symmetric)
    columns = np.empty((n, local))
    influence_rows(kernel, layout.footprint, slice(0, n), columns=layout.rows, out=columns)
    mat = PETSc.Mat().createDense(((local, n), (local, n)), array=columns.T, comm=comm)
    mat.setOption(PETSc.Mat.Option.SYMMETRIC, True)
    mat.setOption(PETSc.Mat.Option.SPD, True)
    mat.assemble()
    return mat


def gather_dense(mat: PETSc.Mat, comm) -> np.ndarray:
    """The whole of a row-distributed dense ``mat`` as a numpy array on every rank."""
    if mat.getType() in (PETSc.Mat.Type.MPIDENSE, PETSc.Mat.Type.SEQDENSE):
        local = np.array(mat.getDenseArray(readonly=True))
    else:
        start, stop = mat.getOwnershipRange()
        ncols = mat.getSize()[1]
        local = np.array(mat.getValues(range(start, stop), range(ncols))).reshape(stop - start, ncols)
    return np.concatenate(comm.allgather(local), axis=0)
