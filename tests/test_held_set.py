"""The held-set bound of benchmarks/bench_held_set.py: the solution's own contact set, held.

The contact problem's solution is unique (H is positive definite on any set),
so a solve that holds the solution's own set S* from the fine level's start
must end on the same forces, and since the set is right it must not move.
Near full contact at 512² (Δ 2.5, 1 E*; the primal–dual steps run there),
on this rank alone (under mpiexec each rank runs it).
"""
import pytest


@pytest.fixture(scope="module")
def rows():
    from mpi4py import MPI

    from benchmarks.bench_held_set import measure

    kept, held = measure("full", 512, 1, MPI.COMM_SELF)
    return kept, held


def test_the_held_set_ends_on_the_same_solution(rows):
    """The forces agree to 1e-7 of the largest. Both solves meet the gap's tolerance (1e-8 of
    w's scale), and their forces differ by what H_SS⁻¹ makes of the two residuals: 7e-9 of the
    largest here, measured, so 1e-7 is a margin of 14 over it. A hold that left out any node of
    S* whose force is above 1e-7 of the largest would fail it: its force there would be zero.
    At most 10 of the 262 144 nodes may differ in contact: nodes whose force and gap are both
    within the tolerance of zero fall either way."""
    kept, held = rows
    assert held["force_difference"] <= 1e-7
    assert held["nodes_differing"] <= 10


def test_the_held_set_does_not_move(rows):
    """The held solve takes at most three passes on the fine level (its one set, a confirmation
    that may find the single-precision steps' gap off by more than the tolerance, and the last
    confirmation); the kept one starts from the coarse level's set, which is not S*, so it moves
    at least once. The held solve therefore takes fewer fine products: each move costs an exact
    H p and a restart of the directions."""
    kept, held = rows
    assert held["fine_passes"] <= 3
    assert kept["fine_passes"] >= 4
    assert held["fine_iterations"] < kept["fine_iterations"]
    assert held["coarse_iterations"] == kept["coarse_iterations"]   # the same nested start
