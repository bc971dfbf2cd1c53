"""The package's one warm-started Krylov solve (roughcontact/petsc.py, ``solve_checked``): the
answer against a dense solve, and the products each kind of guess takes, on any rank count.

The operator is a 1-D Laplacian plus 2 I (SPD, κ ≈ 3), wrapped in a Python Mat that counts its
products. PETSc's CG takes one product per iteration; a guess that is not zero takes one more
for its first residual, and ``solve_checked`` one more to check it against a zero start.
"""
from __future__ import annotations

import numpy as np
import pytest
from petsc4py import PETSc

from roughcontact.errors import ConvergenceError
from roughcontact.petsc import solve_checked

SIZE = 40


class Counted:
    """Python Mat context: y = A x (A = tridiag(−1, 4, −1)), counting the calls."""

    def __init__(self, comm):
        self.mat = PETSc.Mat().createAIJ([SIZE, SIZE], nnz=3, comm=comm)
        start, stop = self.mat.getOwnershipRange()
        for i in range(start, stop):
            self.mat.setValue(i, i, 4.0)
            if i > 0:
                self.mat.setValue(i, i - 1, -1.0)
            if i < SIZE - 1:
                self.mat.setValue(i, i + 1, -1.0)
        self.mat.assemble()
        self.calls = 0

    def mult(self, mat, x, y):
        self.calls += 1
        self.mat.mult(x, y)


def dense_matrix() -> np.ndarray:
    return 4.0 * np.eye(SIZE) - np.eye(SIZE, k=1) - np.eye(SIZE, k=-1)


@pytest.fixture
def system(comm):
    counted = Counted(comm)
    local = counted.mat.getLocalSize()[0]
    mat = PETSc.Mat().createPython(((local, SIZE), (local, SIZE)), counted, comm=comm)
    mat.setUp()
    ksp = PETSc.KSP().create(comm)
    ksp.setType(PETSc.KSP.Type.CG)
    ksp.getPC().setType(PETSc.PC.Type.NONE)
    ksp.setTolerances(rtol=1e-12, atol=0.0, max_it=200)
    ksp.setInitialGuessNonzero(True)
    ksp.setOperators(mat)
    b, x = mat.createVecs()
    r = b.duplicate()
    start, stop = b.getOwnershipRange()
    rhs = np.sin(np.arange(SIZE) + 1.0)
    b.getArray()[:] = rhs[start:stop]
    yield counted, mat, ksp, b, x, r, rhs, (start, stop)
    for obj in (ksp, mat, b, x, r, counted.mat):
        obj.destroy()


@pytest.mark.parametrize("guess, extra", [("zero", 0), ("near", 2), ("far", 1)])
def test_a_guess_takes_the_products_it_needs(system, guess, extra):
    """Zero: no product beyond the iterations' (the KSP is told its guess is zero, and is told
    back after). Near the answer: the check and the KSP's first residual, and fewer iterations.
    Far (worse than zero, dropped): the check only. The answer agrees with numpy's dense solve to
    1e-10 (rtol 1e-12 on a system of condition about 3)."""
    counted, mat, ksp, b, x, r, rhs, rows = system
    exact = np.linalg.solve(dense_matrix(), rhs)
    if guess == "near":
        x.getArray()[:] = exact[slice(*rows)] * (1.0 + 1e-3)
    elif guess == "far":
        x.getArray()[:] = -100.0 * exact[slice(*rows)]
    else:
        x.set(0.0)
    counted.calls = 0
    its = solve_checked(ksp, mat, b, x, r, "test solve")
    assert counted.calls == its + extra
    assert ksp.getInitialGuessNonzero()
    np.testing.assert_allclose(x.getArray(readonly=True), exact[slice(*rows)], rtol=0.0, atol=1e-10)


def test_a_zero_guess_gives_the_solve_from_b_minus_a_zero(system):
    """The zero-guess path changes only the products taken: the same iterations and the same
    answer, bit for bit, as the KSP's own start from a nonzero-flagged zero guess (b − A 0 = b)."""
    counted, mat, ksp, b, x, r, rhs, rows = system
    x.set(0.0)
    its = solve_checked(ksp, mat, b, x, r, "test solve")
    ours = x.getArray(readonly=True).copy()
    x.set(0.0)
    ksp.solve(b, x)                              # flagged nonzero: its first residual by a product
    assert ksp.getIterationNumber() == its
    assert np.array_equal(x.getArray(readonly=True), ours)


def test_a_diverged_solve_is_named(system):
    """Too few iterations allowed: ConvergenceError KSP_DIVERGED_MAX_IT, from the zero-guess path too,
    and the KSP's flag is still restored."""
    counted, mat, ksp, b, x, r, rhs, rows = system
    ksp.setTolerances(max_it=2)
    x.set(0.0)
    with pytest.raises(ConvergenceError, match="KSP_DIVERGED_MAX_IT: test solve stopped after 2 iterations"):
        solve_checked(ksp, mat, b, x, r, "test solve")
    assert ksp.getInitialGuessNonzero()
