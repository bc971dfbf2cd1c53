"""Shared fixtures. The same files run serially and under ``mpiexec -n 2``:
every assertion must hold on every rank (results are replicated on all ranks)."""
from __future__ import annotations

import gc
from pathlib import Path

import numpy as np
import pytest
from mpi4py import MPI


def pytest_configure(config):
    """Under MPI each rank gets its own temporary base directory, so ranks do not
    race to clean up one shared directory."""
    if MPI.COMM_WORLD.Get_size() > 1 and not config.option.basetemp:
        import tempfile

        config.option.basetemp = tempfile.mkdtemp(prefix=f"pytest-rank{MPI.COMM_WORLD.Get_rank()}-")


@pytest.fixture
def comm():
    return MPI.COMM_WORLD


@pytest.fixture
def shared_dir(tmp_path, comm):
    """Rank 0's temporary directory on every rank: rank 0 writes the files, every rank reads them."""
    return Path(comm.bcast(str(tmp_path), root=0))


@pytest.fixture
def settle_calls(monkeypatch):
    """Every call of the primal–dual steps a constrained-CG solve makes, in order, as (the moments
    imposed, what :func:`~roughcontact.normal.primal_dual.settle` returned): which way a solve
    went, read where the steps return (the calls themselves unchanged)."""
    import roughcontact.normal.constrained_cg as constrained_cg

    settle, calls = constrained_cg.settle, []

    def recorded(*args, **kwargs):
        settled = settle(*args, **kwargs)
        calls.append((kwargs.get("loads") is not None, settled))
        return settled

    monkeypatch.setattr(constrained_cg, "settle", recorded)
    return calls


@pytest.fixture(autouse=True)
def _collective_cleanup():
    """Free PETSc objects deterministically and keep ranks in step between tests."""
    yield
    gc.collect()
    MPI.COMM_WORLD.Barrier()


def sphere_heights(n: int, spacing: float, radius: float, centre=None) -> np.ndarray:
    """Paraboloid Δh = −r²/(2R) on an n×n grid, centred on the middle node by default."""
    c = (n - 1) * spacing / 2.0 if centre is None else centre
    x = np.arange(n) * spacing - (c if np.isscalar(c) else c[0])
    y = np.arange(n) * spacing - (c if np.isscalar(c) else c[1])
    return -(x[:, None] ** 2 + y[None, :] ** 2) / (2.0 * radius)


def table_block(table: np.ndarray, rows: np.ndarray, columns: np.ndarray) -> np.ndarray:
    """H between two sets of (i, j) nodes read from an Eq. 10 table K[|Δi|, |Δj|] by numpy's
    indexing: the reference the operators' blocks and solves are checked against."""
    return table[np.abs(rows[:, None, 0] - columns[None, :, 0]), np.abs(rows[:, None, 1] - columns[None, :, 1])]


def traced_peak(work, *args) -> int:
    """Peak bytes of the allocations traced while ``work(*args)`` runs (tracemalloc: deterministic,
    unlike the resident set)."""
    import tracemalloc

    tracemalloc.start()
    try:
        work(*args)
        return tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()


def traced_share(comm, work) -> float:
    """Peak traced allocations (:func:`traced_peak`) of ``work(on)`` on the busiest rank of ``comm``,
    over the same on one rank alone. Each side runs once first, so FFT plan caches and first-use
    buffers are not counted."""
    traced_peak(work, MPI.COMM_SELF)
    traced_peak(work, comm)
    alone = traced_peak(work, MPI.COMM_SELF)
    return comm.allreduce(traced_peak(work, comm), op=MPI.MAX) / alone
