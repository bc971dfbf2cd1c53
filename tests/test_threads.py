"""Each solve runs its BLAS calls on one thread and gives the process its own setting back
(roughcontact/threads.py: OpenBLAS's spinning threads cost 1.4× on one rank and 4.3× on two at
1024², benchmarks/bench_threads.py)."""
from __future__ import annotations

import numpy as np
from threadpoolctl import threadpool_info, threadpool_limits

from roughcontact.materials import Interface, Material
from roughcontact.normal import NormalProblem, make_solver
from roughcontact.surfaces import Topography


def blas_threads() -> list[int]:
    return [pool["num_threads"] for pool in threadpool_info() if pool["user_api"] == "blas"]


def test_a_solve_uses_one_blas_thread_and_restores_the_setting(comm):
    heights = np.random.default_rng(2).standard_normal((48, 48)) * 1e-6
    problem = NormalProblem(Topography(heights, 1e-4), Interface(Material(30e9, 0.25)), comm, operator="fft")
    seen = []
    product = problem.displacement

    def spy(*args, **kwargs):
        seen.append(max(blas_threads()))
        return product(*args, **kwargs)

    problem.displacement = spy
    with threadpool_limits(2, user_api="blas"):
        before = blas_threads()
        with make_solver(problem, "cg") as solver:
            result = solver.solve_load(0.05, rotation=(0.0, 0.0))
        after = blas_threads()
    assert result.residual <= 1e-8
    assert seen and set(seen) == {1}
    assert after == before
    problem.destroy()
