"""The two-level candidate of benchmarks/two_level.py: its cheap products and its balancing form.

The cheap product is P H_c Pᵀ z plus the near-field stencils N = H − P H_c Pᵀ
made from the kernel tables of Eq. 10; near a source it must therefore give
H exactly, which holds only if the tables agree with the fine and coarse
FFT operators the package builds. The balancing form must stay symmetric
positive definite for an approximate W, which is what lets the benchmark
feed it one.
"""
import numpy as np
import pytest


@pytest.fixture(scope="module")
def scene():
    """A 64² scene on this rank alone (the candidate is one rank's; under mpiexec each rank runs it)."""
    from mpi4py import MPI

    from benchmarks.common import scene_problem, scene_topography

    topography = scene_topography(64)
    problem = scene_problem(topography, MPI.COMM_SELF)
    yield topography, problem
    problem.destroy()


def test_cheap_product_is_exact_within_the_near_field(scene):
    """Every position of a source inside its coarse cell (8 × 8): within 4 nodes of the source
    the cheap product equals H e to round-off (1e-12 of the punch's own settlement: both sides
    are double-precision FFT products of the same kernels); further out it is an approximation."""
    from benchmarks.two_level import CheapProducts

    topography, problem = scene
    nx, ny = topography.shape
    cheap = CheapProducts(problem, topography, np.arange(problem.size), factor=8, radius=4)
    try:
        scale = problem.flexibility.diagonal
        for p in range(8):
            for q in range(8):
                i, j = 24 + p, 24 + q
                unit = np.zeros(problem.size)
                unit[i * ny + j] = 1.0
                exact = problem.flexibility.product(unit).reshape(nx, ny)
                approximate = cheap.product(unit).reshape(nx, ny)
                window = (slice(i - 4, i + 5), slice(j - 4, j + 5))
                assert np.abs(approximate[window] - exact[window]).max() <= 1e-12 * scale
                outside = np.ones((nx, ny), dtype=bool)
                outside[window] = False
                assert np.abs(approximate[outside] - exact[outside]).max() > 1e-9 * scale
    finally:
        cheap.destroy()


def test_balancing_form_is_symmetric_positive_definite_for_an_approximate_w():
    """P = Q + (I − Z E⁻¹ Wᵀ) M (I − W E⁻¹ Zᵀ) with W = H Z perturbed by 10 %: symmetric to
    round-off and its smallest eigenvalue positive; with the exact W, P H has the eigenvalue 1
    on the coarse space (P H Z = Z), the balancing form's defining property."""
    from benchmarks.two_level import balancing

    rng = np.random.default_rng(4)
    size, vectors = 40, 4
    root = rng.standard_normal((size, size))
    operator = root @ root.T + size * np.eye(size)
    precondition_matrix = np.diag(1.0 / np.diag(operator))
    basis = np.zeros((size, vectors))
    basis[np.arange(size), np.arange(size) % vectors] = 1.0
    exact = operator @ basis
    perturbed = exact * (1.0 + 0.1 * rng.standard_normal(exact.shape))
    for products in (exact, perturbed):
        apply = balancing(lambda v: precondition_matrix @ v, basis, products)
        matrix = np.stack([apply(column) for column in np.eye(size)], axis=1)
        assert np.abs(matrix - matrix.T).max() <= 1e-12 * np.abs(matrix).max()
        assert np.linalg.eigvalsh(0.5 * (matrix + matrix.T)).min() > 0.0
    apply = balancing(lambda v: precondition_matrix @ v, basis, exact)
    for k in range(vectors):
        np.testing.assert_allclose(apply(operator @ basis[:, k]), basis[:, k], atol=1e-12)
