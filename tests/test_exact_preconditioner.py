"""The ceiling of the set's Fourier preconditioner in benchmarks/bench_deflation.py: C_SS⁻¹.

``exact_inverse`` applies B_SS − B_SO B_OO⁻¹ B_OS (B = C⁻¹ on C's whole
period, O the period outside S), which by the block inverse of C on the
period is the inverse of C restricted to S. The test builds C_SS as a dense
matrix from the column of C's circulant on the period (the inverse of the
package's C⁻¹ symbol), and checks that the benchmark's operator inverts it.
"""
import numpy as np
import pytest


@pytest.fixture(scope="module")
def scene():
    """A 32² scene on this rank alone (the benchmark's rows are one rank's; under mpiexec each
    rank runs it), solved, with its contact set."""
    from mpi4py import MPI

    from benchmarks.common import scene_problem, scene_topography, solve_scene

    topography = scene_topography(32)
    problem = scene_problem(topography, MPI.COMM_SELF)
    result = solve_scene(problem, 0.05)
    contact = np.flatnonzero(result.contact[topography.footprint])
    yield problem, contact
    problem.destroy()


def _c_on_set(problem, contact):
    """C_SS, dense: C on the preconditioner's period, from C's symbol (the reciprocal of the
    package's C⁻¹ symbol) by an inverse FFT, its circulant's rows and columns at the set's grid
    nodes ``contact``."""
    import scipy.fft as sfft

    convolution = problem.flexibility.preconditioner.convolution
    lx, ly = convolution.lengths
    column = sfft.irfft2(1.0 / convolution.symbol, s=(lx, ly))      # C's column at node (0, 0)
    i, j = np.divmod(contact, problem.topography.shape[1])         # the set's places on the period
    return column[(i[:, None] - i[None, :]) % lx, (j[:, None] - j[None, :]) % ly]


def test_exact_inverse_inverts_c_on_the_set(scene):
    """‖C_SS⁻¹ (C_SS v) − v‖ ≤ 1e-7 ‖v‖ for the inner tolerance 1e-10: the inner CG's residual,
    amplified by B_OO's condition number, bounds the error. A Schur term with O taken on the
    grid alone (C's margin left out of O) fails it."""
    from benchmarks.bench_deflation import exact_inverse

    problem, contact = scene
    assert 0 < contact.size < problem.size
    c_ss = _c_on_set(problem, contact)
    inverse, inner = exact_inverse(problem.flexibility, contact, 1e-10)
    v = np.random.default_rng(2).standard_normal(contact.size)
    assert np.linalg.norm(inverse(c_ss @ v) - v) <= 1e-7 * np.linalg.norm(v)
    assert len(inner) == 1 and inner[0] > 1           # the Schur term's inner CG ran


def test_exact_inverse_differs_from_the_plain_preconditioner(scene):
    """The Schur term is not zero: R_S C⁻¹ R_Sᵀ alone is C_SS⁻¹ only where S fills the period,
    and on this set it misses C_SS⁻¹ (C_SS v) = v by more than 10 %."""
    problem, contact = scene
    c_ss = _c_on_set(problem, contact)
    v = np.random.default_rng(2).standard_normal(contact.size)
    plain = problem.flexibility.precondition_nodes(c_ss @ v, contact)
    assert np.linalg.norm(plain - v) > 0.1 * np.linalg.norm(v)
