"""One BLAS thread during a solve: numpy's and PETSc's OpenBLAS pools, limited with threadpoolctl.

The solvers' BLAS calls are dot products and small dense blocks, between FFTs
that already use the rank's cores (``workers`` threads,
:mod:`~roughcontact.operators.convolution`). OpenBLAS's own threads, one per
core by default, spin after each call and take those cores from the FFT and
from the other ranks of the node: the large-grid scene at 1024² (one CG
solve, medians of 3, two rounds) took 1.82–2.00 s with them and 1.29–1.45 s
with one BLAS thread on one rank, and 5.3 s against 0.97 s on two ranks,
where every rank's spinning threads wait at each transpose for the other's.
``scripts/`` and the command line set ``OPENBLAS_NUM_THREADS=1`` before
numpy loads; a program that imports the package as a library gets the same
limit for the duration of each solve, and its own setting back afterwards.

threadpoolctl (the thread-pool control joblib and scikit-learn use) finds
every BLAS library loaded in the process — numpy's bundled OpenBLAS and the
system one PETSc links — which a variable read at load time cannot reach once
numpy is imported. The controller is made once (0.01 ms a limit against
0.3 ms for a fresh search of the loaded libraries, which a farm of small
solves would notice).
"""
from __future__ import annotations

from contextlib import contextmanager

_controller = None


@contextmanager
def blas_threads(count: int):
    """Within the block, every loaded BLAS library uses ``count`` threads; the previous limits
    after it."""
    global _controller
    if _controller is None:
        from threadpoolctl import ThreadpoolController

        _controller = ThreadpoolController()
    with _controller.limit(limits=count, user_api="blas"):
        yield


def single_blas_thread():
    """Within the block, every loaded BLAS library uses one thread; the previous limits after it."""
    return blas_threads(1)
