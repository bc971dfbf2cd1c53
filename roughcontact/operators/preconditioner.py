"""A Fourier preconditioner for H_SS, the flexibility matrix on a contact set.

The symbol of the Eq. 10 operator decays like 1/|q| (the half-space's
A/|q| times the punch's sin(|q|a)/(|q|a)), so H is ill-conditioned in
proportion to the grid size and unpreconditioned Krylov iterations grow
with it. The preconditioner applies the inverse of a circulant C that
approximates H, restricted to the contact set S:

    z = R_S C⁻¹ R_Sᵀ g,

i.e. the residual g on S, zero elsewhere, multiplied by 1/symbol in Fourier
space (a |q| filter) and read back on S. C is the circulant of the Eq. 10
kernel wrapped onto one period of the grid (nearest image): positive
definite (its symbol is positive, checked at set up), and an n × n transform
instead of the padded 2n × 2n one of the product. The periodic operator uses
the same C: its own kernel has a zero mean mode (the gauge), which C⁻¹
cannot invert, and differs from C only in the far field. R_S C⁻¹ R_Sᵀ is symmetric positive definite, so it can precondition
CG. On a filled contact set it is the inverse of H up to boundary terms; on
isolated nodes it is a constant multiple of the inverse of the diagonal.

References: E.A.H. Vollebregt, J. Comput. Phys. 257 (2014) 333–351 (an FFT
preconditioner for the contact set in CG); for the 1/|q| symbol, K.L.
Johnson, Contact Mechanics (1985) §3.
"""
from __future__ import annotations

import numpy as np

from ..errors import ConvergenceError
from .convolution import SlabConvolution
from .kernel import punch_kernel


def wrapped_kernel(shape: tuple[int, int], spacing: float, compliance: float,
                   rows: tuple[int, int] | None = None) -> np.ndarray:
    """The Eq. 10 table folded onto one period, k[min(i, n − i), min(j, n − j)], on the grid rows
    ``rows`` = (start, stop) (default all): the rows one rank transforms."""
    nx, ny = shape
    start, stop = (0, nx) if rows is None else rows
    i = np.arange(start, stop)
    j = np.arange(ny)
    table = punch_kernel(shape, spacing, compliance, rows=np.minimum(i, nx - i))
    return table[:, np.minimum(j, ny - j)]


class FourierPreconditioner:
    """z = R_S C⁻¹ R_Sᵀ g on the layout of a :class:`~.flexibility.Flexibility`."""

    def __init__(self, flexibility):
        self.layout = flexibility.layout
        shape = flexibility.shape
        self.convolution = SlabConvolution(shape, flexibility.comm, periodic=True,
                                           workers=flexibility.convolution.workers)
        # the half-space kernel for the periodic operator too (its own has a zero mean mode)
        self.convolution.set_kernel(wrapped_kernel(shape, flexibility.spacing, flexibility.compliance,
                                                   rows=self.convolution.rows))
        smallest = flexibility.comm.allreduce(float(self.convolution.symbol.min()), op=_min())
        if not smallest > 0.0:
            raise ConvergenceError("PC_SYMBOL_NOT_POSITIVE",
                                   f"the wrapped kernel's symbol reaches {smallest:.3e} <= 0; the Fourier "
                                   "preconditioner is not positive definite on this grid: use -normal_pc_type none")
        self.convolution.set_symbol(1.0 / self.convolution.symbol)     # C⁻¹: a product applies it
        self._slab = np.zeros((self.layout.rows[1] - self.layout.rows[0], shape[1]))

    def apply_nodes(self, values: np.ndarray, nodes: np.ndarray, single: bool = False) -> np.ndarray:
        """R_S C⁻¹ R_Sᵀ on S given by this rank's node indices; ``values`` and the result on S;
        ``single``: in single precision (:mod:`.convolution`), the result still float64."""
        self._slab.fill(0.0)
        positions = self.layout.positions[nodes]
        self._slab.reshape(-1)[positions] = values
        smoothed = self.convolution.apply(self._slab, single)
        return smoothed.reshape(-1)[positions].astype(float, copy=False)


def _min():
    from mpi4py import MPI

    return MPI.MIN
