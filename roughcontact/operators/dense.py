"""The flexibility operator H of Eq. 9–11 as a distributed PETSc matrix.

The operator is an explicit dense matrix (MATDENSE) whose rows are split over
the ranks of the communicator it is given; each rank tabulates the Eq. 10
kernel once and gathers its own rows from it, vectorised. The normal solvers
use nothing but the PETSc ``Mat`` interface (``mult``, ``createSubMatrix``),
so a matrix-free operator can replace this one untouched.
"""
from __future__ import annotations

import numpy as np
from petsc4py import PETSc

from ..materials import Interface
from ..surfaces.topography import Topography
from .kernel import influence_rows, punch_kernel


def ownership(n: int, comm) -> tuple[int, int]:
    """PETSc's default split of ``n`` rows over ``comm``: (start, stop) of this rank."""
    size, rank = comm.Get_size(), comm.Get_rank()
    counts = [n // size + (1 if r < n % size else 0) for r in range(size)]
    start = sum(counts[:rank])
    return start, start + counts[rank]


def assemble_flexibility(topography: Topography, interface: Interface, comm) -> PETSc.Mat:
    """Dense flexibility matrix H (Eq. 10) over the footprint nodes, row-distributed.

    Unknowns are the footprint nodes in C order of the mask
    (``numpy.argwhere(topography.footprint)``). Entries are in m/N.
    """
    n = int(topography.footprint.sum())
    start, stop = ownership(n, comm)
    kernel = punch_kernel(topography.shape, topography.spacing, interface.compliance)
    local = np.empty((stop - start, n), order="F")
    influence_rows(kernel, topography.footprint, slice(start, stop), out=local)
    mat = PETSc.Mat().createDense(((stop - start, n), (stop - start, n)), array=local, comm=comm)
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


def apply_on_columns(mat: PETSc.Mat, values: np.ndarray, columns: np.ndarray, start: int) -> np.ndarray:
    """Local rows of H x for a distributed x that is zero outside ``columns``.

    ``values`` and ``columns`` (a boolean mask) are over this rank's rows.
    For a dense operator only the selected columns of the local block are
    read (gathered column indices and values, one matrix-vector product of
    the local rows by |S| columns): when the contact set is a few per cent
    of the footprint this is that many times cheaper than the full product,
    which PETSc's ``createSubMatrix`` on MATDENSE does not achieve. Any other
    operator gets the plain ``mult``.
    """
    if mat.getType() in (PETSc.Mat.Type.MPIDENSE, PETSc.Mat.Type.SEQDENSE):
        comm = mat.getComm().tompi4py()
        index = np.concatenate(comm.allgather(np.flatnonzero(columns) + start))
        selected = np.concatenate(comm.allgather(np.asarray(values)[columns]))
        if 2 * index.size < mat.getSize()[1]:
            block = mat.getDenseArray(readonly=True)
            return block[:, index] @ selected
    x, y = mat.createVecs()
    x.getArray()[:] = np.where(columns, values, 0.0)
    mat.mult(x, y)
    out = y.getArray().copy()
    x.destroy()
    y.destroy()
    return out
