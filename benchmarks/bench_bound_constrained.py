#!/usr/bin/env python3
"""PETSc TAO's bound-constrained solvers against the package's constrained CG, on the FFT operator.

The normal problem in displacement control is the QP min ½ pᵀHp − wᵀp over
p ≥ 0 (its gradient Hp − w is the deformed gap). Each TAO method gets the
objective and gradient (one FFT product per evaluation), the matrix-free H
as Hessian, p ≥ 0 as bounds, and a convergence test that stops it as soon as
the contact conditions hold to the same measure and tolerance as the CG
(max(|g| on p > 0, max(−g) on p = 0) ≤ 1e-8 of the scale of w). Counted per
run: wall time, iterations and FFT products, and the error of the contact
area against the CG's answer.

    python -m benchmarks.bench_bound_constrained [--sizes 128 256 512] [--output results/bench_bound_constrained.json]

A surface of the large-grid benchmark (Fourier-filtered, H = 0.8, unit rms
slope, roll-off at the box, cut-off at 8 s, non-periodic), E* = 1, the
approach at which the CG carries 0.01 E* of mean pressure.
"""
from __future__ import annotations

import argparse
import json
import time

import numpy as np

from benchmarks.common import save_json, scene_surface

TAO_TYPES = ("bncg", "blmvm", "bqnls", "gpcg", "tron", "bqnkls")


class Counter:
    """Counts the FFT products of one Flexibility."""

    def __init__(self, flexibility):
        self.flexibility = flexibility
        self.original = flexibility.product
        self.count = 0
        flexibility.product = self

    def __call__(self, values):
        self.count += 1
        return self.original(values)

    def reset(self):
        self.count = 0


def run_tao(problem, kind: str, closure: float, tol: float, max_it: int) -> dict:
    from petsc4py import PETSc

    w = problem.interpenetration(np.array([closure, 0.0, 0.0]))
    w_scale = max(float(problem.allmax(np.abs(w).max())), problem.height_range)
    op = problem.operator
    x, g = op.createVecs()
    lower, upper = x.duplicate(), x.duplicate()
    lower.set(0.0)
    upper.set(PETSc.INFINITY)
    x.set(0.0)

    def objective_gradient(tao, xv, gv):
        p = xv.getArray(readonly=True)
        u = problem.displacement(p)
        gv.getArray()[:] = u - w
        return float(problem.allsum(0.5 * p @ u - w @ p))

    def hessian(tao, xv, h, pmat):
        pass

    state = {"residual": np.inf}

    def converged(tao):
        p = tao.getSolution().getArray(readonly=True)
        gap = tao.getGradient()[0].getArray(readonly=True)
        contact = p > 0.0
        residual = float(problem.allmax(max(np.abs(gap[contact]).max(initial=0.0),
                                            -gap[~contact].min(initial=0.0)))) / w_scale
        state["residual"] = residual
        if residual <= tol:
            tao.setConvergedReason(PETSc.TAO.ConvergedReason.CONVERGED_USER)
        elif tao.getIterationNumber() >= max_it:
            tao.setConvergedReason(PETSc.TAO.ConvergedReason.DIVERGED_MAXITS)
        else:
            tao.setConvergedReason(PETSc.TAO.ConvergedReason.ITERATING)

    tao = PETSc.TAO().create(problem.comm)
    tao.setType(kind)
    tao.setObjectiveGradient(objective_gradient, g)
    tao.setHessian(hessian, op)
    tao.setVariableBounds(lower, upper)
    tao.setSolution(x)
    tao.setConvergenceTest(converged)
    tao.setMaximumIterations(max_it)
    if kind in ("gpcg", "tron", "bqnkls"):
        tao.getKSP().getPC().setType("none")
    tao.setFromOptions()
    t0 = time.perf_counter()
    tao.solve()
    elapsed = time.perf_counter() - t0
    reason = tao.getConvergedReason()
    p = x.getArray(readonly=True)
    out = {"iterations": tao.getIterationNumber(), "seconds": elapsed, "residual": state["residual"],
           "converged": reason > 0, "reason": int(reason), "contact": int(problem.allsum((p > 0).sum()))}
    for obj in (tao, x, g, lower, upper):
        obj.destroy()
    return out


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--sizes", type=int, nargs="+", default=[128, 256, 512])
    parser.add_argument("--types", nargs="+", default=list(TAO_TYPES))
    parser.add_argument("--tol", type=float, default=1e-8)
    parser.add_argument("--max-it", type=int, default=3000)
    parser.add_argument("--output", default="results/bench_bound_constrained.json")
    args = parser.parse_args()

    import petsc4py

    petsc4py.init([])
    from mpi4py import MPI

    from roughcontact.materials import Interface, Material
    from roughcontact.normal import CGSettings, NormalProblem, make_solver

    comm = MPI.COMM_WORLD
    rows = []
    for n in args.sizes:
        problem = NormalProblem(scene_surface(n), Interface(Material(1.0, 0.0)), comm, operator="fft")
        counter = Counter(problem.flexibility)
        with make_solver(problem, "cg") as solver:
            reference = solver.solve_load(0.01, rotation=(0.0, 0.0))
        closure = reference.closure
        for name, settings, nested in (("cg (fourier, nested)", CGSettings(), True),
                                       ("cg (fourier)", CGSettings(), False),
                                       ("cg (no preconditioner)", CGSettings(preconditioner="none"), False)):
            with make_solver(problem, "cg", settings=settings, nested=nested) as solver:
                counter.reset()
                t0 = time.perf_counter()
                result = solver.solve_closure(closure)
                row = {"n": n, "method": name, "seconds": time.perf_counter() - t0,
                       "iterations": result.linear_iterations, "coarse_iterations": result.coarse_iterations,
                       "products": counter.count, "residual": result.residual, "converged": True,
                       "contact": int(result.contact.sum())}
            rows.append(row)
            print(json.dumps(row), flush=True)
        for kind in args.types:
            counter.reset()
            row = {"n": n, "method": f"tao {kind}", **run_tao(problem, kind, closure, args.tol, args.max_it)}
            row["products"] = counter.count
            rows.append(row)
            print(json.dumps(row), flush=True)
        for row in rows:
            if row["n"] == n:
                row["contact_error"] = abs(row["contact"] / reference.contact.sum() - 1.0)
        problem.destroy()
    if comm.Get_rank() == 0:
        save_json(rows, args.output)


if __name__ == "__main__":
    main()
