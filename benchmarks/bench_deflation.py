#!/usr/bin/env python3
"""What deflation could save the CG: preconditioned CG on a fixed contact set, with and without an
exact coarse space.

The constrained CG's iterations grow with n (16, 19, 22, 37 from 256² to
2048² on the large-grid scene, benchmarks/bench_products.py). This measures
the linear part of that growth and what deflation (Vollebregt 2014) would
take off it, before building one: the large-grid scene (0.01 E*) is solved,
its contact set S fixed, and H_SS x = b solved (b = H_SS of a random
positive vector) by the Fourier-preconditioned CG of the solver to a relative
residual of 1e-8 (2-norm), plainly and deflated (DPCG: P = I − A Z E⁻¹ Zᵀ,
E = Zᵀ A Z exact) with coarse spaces Z restricted to S:

- ``poly1``: 1, x, y; ``poly2``: 1, x, y, x², xy, y²;
- ``block<b>``: the indicators of the b × b blocks of the grid that hold
  contact nodes.

Each row gives the iterations and the coarse vectors: A Z costs one FFT
product per vector, every time S changes — the price a deflated constrained
CG would pay. One rank.

    python -m benchmarks.bench_deflation [--sizes 256 512 1024 2048] [--output results/bench_deflation.json]
"""
from __future__ import annotations

import argparse

import numpy as np

from benchmarks.common import (
    add_launch_arguments,
    emit,
    run_on_ranks,
    save_json,
    scene_problem,
    scene_topography,
    solve_scene,
    worker_mpi,
    write_rows,
)

TOL = 1e-8


def pcg(apply, precondition, rhs, deflation=None, limit: int = 1000) -> int:
    """Iterations of (deflated) PCG on apply(x) = rhs to a relative residual TOL."""
    norm = np.linalg.norm(rhs)
    if deflation is None:
        project = lambda v: v                                  # noqa: E731
        residual = rhs.copy()
    else:
        z_basis, az, inverse = deflation
        project = lambda v: v - az @ (inverse @ (z_basis.T @ v))   # noqa: E731
        residual = project(rhs)
    z = precondition(residual)
    direction, rz = z.copy(), residual @ z
    for iteration in range(1, limit + 1):
        product = project(apply(direction))
        step = rz / (direction @ product)
        residual -= step * product
        if np.linalg.norm(residual) <= TOL * norm:
            return iteration
        z = precondition(residual)
        rz, previous = residual @ z, rz
        direction = z + (rz / previous) * direction
    return limit


def coarse_spaces(nodes: np.ndarray, n: int, blocks: list[int]) -> dict[str, np.ndarray]:
    x, y = (nodes[:, 0] - n / 2) / n, (nodes[:, 1] - n / 2) / n
    one = np.ones_like(x)
    spaces = {"poly1": np.stack([one, x, y], axis=1),
              "poly2": np.stack([one, x, y, x * x, x * y, y * y], axis=1)}
    for b in blocks:
        count = -(-n // b)
        block = (nodes[:, 0] // b) * count + nodes[:, 1] // b
        used, column = np.unique(block, return_inverse=True)
        z = np.zeros((nodes.shape[0], used.size))
        z[np.arange(nodes.shape[0]), column] = 1.0
        spaces[f"block{b}"] = z
    return spaces


def worker(args) -> None:
    MPI = worker_mpi()

    comm = MPI.COMM_WORLD
    rows: list[dict] = []
    for n in args.sizes:
        topography = scene_topography(n)
        problem = scene_problem(topography, comm)
        result = solve_scene(problem)
        flexibility = problem.flexibility
        contact = np.flatnonzero(result.contact[topography.footprint])

        def apply(values):
            full = np.zeros(problem.size)
            full[contact] = values
            return flexibility.product(full)[contact]

        def precondition(values):
            return flexibility.precondition_nodes(values, contact)

        rhs = apply(np.abs(np.random.default_rng(0).standard_normal(contact.size)))
        base = {"n": n, "contact_nodes": int(contact.size), "cg_fine_iterations": result.linear_iterations}
        emit(comm, rows, {**base, "space": "none", "vectors": 0, "iterations": pcg(apply, precondition, rhs)})
        blocks = [b for b in (n // 4, n // 8, n // 16, n // 32) if b >= 8]
        for name, basis in coarse_spaces(problem.nodes[contact], n, blocks).items():
            if basis.shape[1] > args.max_vectors:
                continue
            az = np.stack([apply(basis[:, k]) for k in range(basis.shape[1])], axis=1)
            inverse = np.linalg.inv(basis.T @ az)
            emit(comm, rows, {**base, "space": name, "vectors": int(basis.shape[1]),
                              "iterations": pcg(apply, precondition, rhs, (basis, az, inverse))})
        problem.destroy()
    write_rows(comm, rows, args.json)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    add_launch_arguments(parser, repeats=1, output="results/bench_deflation.json")
    parser.set_defaults(ranks=[1])
    parser.add_argument("--sizes", type=int, nargs="+", default=[256, 512, 1024, 2048])
    parser.add_argument("--max-vectors", type=int, default=120, help="skip coarse spaces larger than this")
    args = parser.parse_args()
    if args.worker:
        return worker(args)
    rows = run_on_ranks(__spec__.name, args.ranks, ["--sizes", *map(str, args.sizes),
                                                     "--max-vectors", str(args.max_vectors)])
    save_json(rows, args.output)


if __name__ == "__main__":
    main()
