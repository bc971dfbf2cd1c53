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

Why the iterations grow (rows with ``space`` = ``spectrum``): the extreme
Ritz values of M H_SS (M the Fourier preconditioner R_S C⁻¹ R_Sᵀ) after 40
Lanczos steps of the same PCG, and where the top eigenvector lives (60
power iterations): the share of its energy on the boundary nodes of S (a
4-neighbour outside S). M H_SS ≥ 1 when C = H (the Schur complement bound),
so κ is the largest eigenvalue. Rows ``schur<k>`` precondition with a
better approximation of H_SS⁻¹ = B_SS − B_SO B_OO⁻¹ B_OS (B = C⁻¹, O the
nodes outside S): B_OO⁻¹ by k terms of its Neumann series at step
1.5/max(B) — k + 1 periodic FFT pairs per application instead of one.
Rows ``period+<margin>`` (``--parts period``): the package's preconditioner
with C on the grid's own period (margin 0) and on a period PERIOD_MARGIN
nodes longer (the package's, :func:`~roughcontact.operators.preconditioner.embedding_period`),
plain and corrected, with the top mode's energy on the grid's outer FRAME
nodes; ``--scenes full`` takes the near-full-contact scene of
benchmarks/bench_products.py (Δ = 2.5 at 1 E*). Rows ``edge<share>``
precondition with M less the edge correction of the
package (:mod:`roughcontact.operators.preconditioner`, e = share · min(max(κ, 0),
EDGE_CAP · C⁻¹_ii)) at several shares; its weights cost one periodic
product per set. Rows ``modes-<name>`` (``--parts modes``): the solver's
whole preconditioner (edge correction and hole charge) and variants of its
diagonal, and where the solver's top and bottom modes live (:func:`mode_rows`).
Rows ``solver`` and ``solver-block<b>`` (``--parts solver``): that whole
preconditioner, plainly and deflated by the blocks (:func:`solver_rows`):
what deflation would take off the solver's settled rate. Rows ``twolevel-block<b>``
(``--parts twolevel``): the same blocks in the balancing form around that
preconditioner, with W = H Z exact and from the cheap products of
:mod:`benchmarks.two_level` (:func:`solver_rows` too: both take each space's
exact A Z from one set of products). Rows ``exact-inner<tol>`` (``--parts exact``): the
ceiling of every preconditioner of this family, C_SS⁻¹ itself (the inverse of C on the set,
where the package's M is R_S C⁻¹ R_Sᵀ less its corrections), as C_SS⁻¹ = B_SS − B_SO B_OO⁻¹ B_OS
with O the whole period outside S (the grid's outside and C's margin) and B_OO⁻¹ by an inner
Jacobi CG to EXACT_TOLS, beside the solver's own on the same set (:func:`exact_rows`).

    python -m benchmarks.bench_deflation [--sizes 256 512 1024 2048] [--max-vectors 120]
        [--scenes scene full] [--parts deflation spectrum edge schur period modes solver twolevel exact]
        [--output results/bench_deflation.json]
"""
from __future__ import annotations

import argparse
import time

import numpy as np

from benchmarks.bench_products import PRESSURES, SHAPES
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
#: the row groups: deflated PCG (``none``, ``poly``, ``block``), ``spectrum``, ``edge``, ``schur``, ``period``,
#: ``modes``, ``solver``, ``twolevel``, ``exact``
PARTS = ("deflation", "spectrum", "edge", "schur", "period", "modes", "solver", "twolevel", "exact")
#: the ``period`` rows' frame: nodes within this many of the grid's edges
FRAME = 8
#: the ``modes`` rows' classes of islands by their nodes: (label, more than, at most)
ISLAND_SIZES = (("<=16", 0, 16), ("17-256", 16, 256), (">256", 256, np.inf))
#: the shares of the edge term the ``edge<share>`` rows remove (at the package's cap)
EDGE_SHARES = (0.5, 0.7, 0.8, 0.9)
#: the ``exact`` rows' inner tolerances for B_OO⁻¹ (relative, 2-norm): the first is the exact C_SS⁻¹
EXACT_TOLS = (1e-10, 1e-3, 1e-2)
#: the ``twolevel`` rows' cheap H Z: the coarse grid's factor and the near field's radius (nodes)
CHEAP_FACTOR, CHEAP_RADIUS = 8, 4


def pcg(apply, precondition, rhs, deflation=None, limit: int = 1000, tol: float = TOL,
        solution: np.ndarray | None = None) -> int:
    """Iterations of (deflated) PCG on apply(x) = rhs to a relative residual ``tol``, x from 0 and
    added into ``solution`` where one is given (without deflation); raises where the
    preconditioned operator shows a non-positive curvature or ``tol`` is not met in ``limit``
    iterations, so that no row reports a count that did not converge."""
    if deflation is not None and solution is not None:
        raise ValueError("pcg keeps no solution with deflation (its x needs the coarse part)")
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
        curvature = direction @ product
        if not (curvature > 0.0 and rz > 0.0):
            raise RuntimeError(f"PCG iteration {iteration}: dᵀAd = {curvature:.3e}, rᵀz = {rz:.3e}: "
                               "the operator or the preconditioner is not positive definite here")
        step = rz / curvature
        if solution is not None:
            solution += step * direction
        residual -= step * product
        if np.linalg.norm(residual) <= tol * norm:
            return iteration
        z = precondition(residual)
        rz, previous = residual @ z, rz
        direction = z + (rz / previous) * direction
    raise RuntimeError(f"PCG did not reach a relative residual {tol:g} in {limit} iterations "
                       f"(last {np.linalg.norm(residual) / norm:.3e})")


def coarse_spaces(nodes: np.ndarray, n: int, limit: int) -> dict[str, np.ndarray]:
    """The polynomial spaces and the spaces of the blocks of n/4, n/8, n/16 and n/32 (at least 8) that
    hold at most ``limit`` vectors (larger ones are not made: near full contact at 1024² the blocks of
    16 would take 28 GiB)."""
    blocks = [b for b in (n // 4, n // 8, n // 16, n // 32) if b >= 8]
    x, y = (nodes[:, 0] - n / 2) / n, (nodes[:, 1] - n / 2) / n
    one = np.ones_like(x)
    spaces = {"poly1": np.stack([one, x, y], axis=1),
              "poly2": np.stack([one, x, y, x * x, x * y, y * y], axis=1)}
    for b in blocks:
        count = -(-n // b)
        block = (nodes[:, 0] // b) * count + nodes[:, 1] // b
        used, column = np.unique(block, return_inverse=True)
        if used.size > limit:
            continue
        z = np.zeros((nodes.shape[0], used.size))
        z[np.arange(nodes.shape[0]), column] = 1.0
        spaces[f"block{b}"] = z
    return spaces


def worker(args) -> None:
    MPI = worker_mpi()

    comm = MPI.COMM_WORLD
    rows: list[dict] = []
    for scene, n in ((scene, n) for scene in args.scenes for n in args.sizes):
        rows += scene_rows(comm, scene, n, args)
    write_rows(comm, rows, args.json)


def scene_rows(comm, scene: str, n: int, args) -> list[dict]:
    rows: list[dict] = []
    topography = scene_topography(n, **SHAPES[scene])
    problem = scene_problem(topography, comm)
    result = solve_scene(problem, PRESSURES[scene])
    flexibility = problem.flexibility
    contact = np.flatnonzero(result.contact[topography.footprint])

    def apply(values):
        full = np.zeros(problem.size)
        full[contact] = values
        return flexibility.product(full)[contact]

    def precondition(values):
        return flexibility.precondition_nodes(values, contact)

    rhs = apply(np.abs(np.random.default_rng(0).standard_normal(contact.size)))
    base = {"scene": scene, "n": n, "contact_nodes": int(contact.size),
            "cg_fine_iterations": result.linear_iterations}
    parts = set(args.parts)
    if "deflation" in parts:
        emit(comm, rows, {**base, "space": "none", "vectors": 0, "iterations": pcg(apply, precondition, rhs)})
        for name, basis in coarse_spaces(problem.nodes[contact], n, args.max_vectors).items():
            az, _ = column_products(apply, basis)
            inverse = np.linalg.inv(basis.T @ az)
            emit(comm, rows, {**base, "space": name, "vectors": int(basis.shape[1]),
                              "iterations": pcg(apply, precondition, rhs, (basis, az, inverse))})
    if "spectrum" in parts:
        emit(comm, rows, {**base, "space": "spectrum", **spectrum(apply, precondition, contact, result.contact)})
    if "edge" in parts:
        for share in EDGE_SHARES:
            edge = flexibility.preconditioner.edge_weights(contact, share=share)

            def corrected(values, edge=edge):
                return flexibility.precondition_nodes(values, contact, edge=edge)

            ritz = lanczos_ritz(apply, corrected, np.random.default_rng(1).standard_normal(contact.size), 40)
            emit(comm, rows, {**base, "space": f"edge{share:g}", "vectors": 0,
                              "iterations": pcg(apply, corrected, rhs),
                              "ritz_min": float(ritz[0]), "ritz_max": float(ritz[-1]), "periodic_pairs": 1})
    if "schur" in parts:
        for terms in (1, 4):
            schur = schur_preconditioner(flexibility, contact, result.contact, terms)
            ritz = lanczos_ritz(apply, schur, np.random.default_rng(1).standard_normal(contact.size), 40)
            emit(comm, rows, {**base, "space": f"schur{terms}", "vectors": 0,
                              "iterations": pcg(apply, schur, rhs),
                              "ritz_max": float(ritz[-1]), "periodic_pairs": terms + 1})
    if "period" in parts:
        for row in period_rows(flexibility, apply, contact, problem.nodes[contact], n, rhs):
            emit(comm, rows, {**base, **row})
    if "modes" in parts:
        for row in mode_rows(problem, apply, contact, result.contact, rhs):
            emit(comm, rows, {**base, **row})
    if "exact" in parts:
        for row in exact_rows(problem, apply, contact, result.contact, rhs):
            emit(comm, rows, {**base, **row})
    if parts & {"solver", "twolevel"}:
        for row in solver_rows(problem, topography, apply, contact, result.contact, rhs, n, args.max_vectors,
                               parts):
            emit(comm, rows, {**base, **row})
    problem.destroy()
    return rows


def period_rows(flexibility, apply, contact: np.ndarray, positions: np.ndarray, n: int, rhs: np.ndarray):
    """Rows ``period+<margin>``: the package's preconditioner with C on the grid's own period
    (margin 0) and on its embedding period (PERIOD_MARGIN), plain and corrected: fixed-set PCG
    iterations, extreme Ritz values, and the top mode's energy on the nodes within FRAME of the
    grid's edges (one rank)."""
    from roughcontact.operators.preconditioner import EDGE_SHARE, PERIOD_MARGIN, FourierPreconditioner

    frame = np.minimum(positions, n - 1 - positions).min(axis=1) < FRAME
    for margin, period in ((0, flexibility.shape), (PERIOD_MARGIN, None)):
        pc = FourierPreconditioner(flexibility, period=period)
        for share in (0.0, EDGE_SHARE):
            edge = pc.edge_weights(contact, share=share) if share else None

            def preconditioned(values, pc=pc, edge=edge):
                return pc.apply_nodes(values, contact, edge=edge)

            ritz, x = extremes(apply, preconditioned, contact.size)
            yield {"space": f"period+{margin}", "period": list(pc.convolution.lengths), "share": share,
                   "vectors": 0, "iterations": pcg(apply, preconditioned, rhs), "ritz_min": float(ritz[0]),
                   "ritz_max": float(ritz[-1]), "frame_share_of_nodes": float(frame.mean()),
                   "top_mode_frame_energy": float(np.sum(x[frame] ** 2))}
        pc.convolution.release_buffers()


def mode_rows(problem, apply, contact: np.ndarray, in_contact: np.ndarray, rhs: np.ndarray):
    """Rows ``modes``: the solver's whole preconditioner on the solved set (the edge correction and
    the hole charge, as the constrained CG takes it once the set has settled) and variants of its
    diagonal, each with fixed-set PCG iterations and Ritz values after 60 Lanczos steps; for the
    solver's own, where its top and bottom modes live (one rank). The variants give each node i
    of S its own share s_i of κ_i (capped at EDGE_CAP · C⁻¹_ii as the solver's) and leave
    (1 − s_i) κ_i to the hole charge:

    - ``neighbours``: 0.85 on nodes with at least 6 nodes of S in their 3 × 3 square, else 0.8;
    - ``islands``: 0.9 on such nodes of islands of more than 256 nodes, else 0.8;
    - ``small-islands``: 0.85 on islands of more than 64 nodes, 0.75 on the others;
    - ``cap0.7``: 0.8 with the cap at 0.7 C⁻¹_ii;
    - ``boundary-laplacian``: 0.9, plus 0.1 L, L the graph Laplacian of the 8-neighbour pairs
      of S weighted by √(κ_i κ_j) (it takes nothing back from a field constant along the
      boundary and adds to one that alternates along it).
    """
    from scipy import ndimage

    from roughcontact.operators.preconditioner import EDGE_SHARE

    flexibility = problem.flexibility
    pc = flexibility.preconditioner
    shape = in_contact.shape
    grid = in_contact.astype(float)
    members = in_contact.reshape(-1)
    sums, capped = edge_terms(pc, contact)
    kappa = np.maximum(sums - pc.inverse_row_sum, 0.0)
    square = np.rint(ndimage.uniform_filter(grid, size=3, mode="constant") * 9).reshape(-1)[contact]
    labels, _ = ndimage.label(in_contact)
    island = np.bincount(labels.ravel())[labels.reshape(-1)[contact]]
    distance = ndimage.distance_transform_cdt(np.pad(in_contact, 1), metric="taxicab")[1:-1, 1:-1].reshape(-1)[contact]

    def box(values):                                   # Σ over the 8 neighbours, on S
        field = np.zeros(in_contact.size)
        field[contact] = values
        return (ndimage.uniform_filter(field.reshape(shape), size=3, mode="constant") * 9).reshape(-1)[contact] - values

    root = np.sqrt(capped)
    weight = box(root)

    def laplacian(values):
        return root * (values * weight - box(root * values))

    wider = np.minimum(kappa, 0.7 * pc.inverse_diagonal)
    # name: (the edge weights e, the capped κ whose rest, κ − e, the hole charge takes, the Laplacian's share)
    variants = {
        "package": (EDGE_SHARE * capped, capped, 0.0),
        "neighbours": (np.where(square >= 6, 0.85, 0.8) * capped, capped, 0.0),
        "islands": (np.where((square >= 6) & (island > 256), 0.9, 0.8) * capped, capped, 0.0),
        "small-islands": (np.where(island > 64, 0.85, 0.75) * capped, capped, 0.0),
        "cap0.7": (EDGE_SHARE * wider, wider, 0.0),
        "boundary-laplacian": (0.9 * capped, capped, 0.1),
    }
    for name, (edge, whole, laplace) in variants.items():
        charged = charged_preconditioner(problem, contact, members, edge, whole)

        def preconditioned(values, charged=charged, laplace=laplace):
            z = charged(values)
            if laplace:
                z += laplace * laplacian(values)
            return z

        ritz = lanczos_ritz(apply, preconditioned, np.random.default_rng(1).standard_normal(contact.size), 60)
        row = {"space": f"modes-{name}", "vectors": 0, "iterations": pcg(apply, preconditioned, rhs),
               "ritz_min": float(ritz[0]), "ritz_max": float(ritz[-1])}
        if name == "package":
            # 100 power iterations for the top, 200 on 1.05 · top − M H_SS for the bottom
            ends = (("top", power_mode(apply, preconditioned, contact.size, 100)),
                    ("bottom", power_mode(apply, preconditioned, contact.size, 200, 1.05 * ritz[-1], seed=4)))
            for end, mode in ends:
                energy = mode * mode
                row[f"{end}_sign"] = float(abs(mode.sum()) / np.abs(mode).sum())
                row[f"{end}_energy_by_distance"] = {str(d): float(energy[np.minimum(distance, 3) == d].sum())
                                                    for d in (1, 2, 3)}
                row[f"{end}_energy_by_island"] = {label: float(energy[(island > lo) & (island <= hi)].sum())
                                                  for label, lo, hi in ISLAND_SIZES}
            row["nodes_by_distance"] = {str(d): float(np.mean(np.minimum(distance, 3) == d)) for d in (1, 2, 3)}
            row["nodes_by_island"] = {label: float(np.mean((island > lo) & (island <= hi)))
                                      for label, lo, hi in ISLAND_SIZES}
        yield row


def edge_terms(pc, contact: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """((C⁻¹ 1_S) on S, the capped κ = min(max(κ, 0), EDGE_CAP · C⁻¹_ii) the solver's edge weights take
    their share of) for the fixed set ``contact``."""
    sums = pc.convolution.restricted(1.0, pc.layout.positions[contact]).astype(float)
    return sums, pc.weights_from_sums(sums, share=1.0)


def charged_preconditioner(problem, contact: np.ndarray, members: np.ndarray, edge: np.ndarray, whole: np.ndarray):
    """The Fourier preconditioner on the fixed set ``contact`` (``members`` its mask) less the edge
    weights ``edge``, with the hole charge of the rest of the capped κ, ``whole`` − ``edge`` (the
    solver's on a settled set where ``edge`` is EDGE_SHARE · ``whole``)."""
    from roughcontact.operators.holes import HoleCharge
    from roughcontact.operators.preconditioner import EDGE_SHARE

    flexibility = problem.flexibility
    holes = HoleCharge(flexibility.layout, problem.comm, EDGE_SHARE)
    holes.relabel(members)
    holes.update(contact, (whole - edge) * EDGE_SHARE / (1.0 - EDGE_SHARE))    # r = whole − e

    def preconditioned(values):
        z = flexibility.precondition_nodes(values, contact, edge=edge)
        holes.subtract(values, z)
        return z

    return preconditioned


def solver_preconditioner(problem, contact: np.ndarray, in_contact: np.ndarray):
    """The solver's whole preconditioner on the settled set ``contact`` (edge correction at
    EDGE_SHARE and the hole charge of the rest)."""
    from roughcontact.operators.preconditioner import EDGE_SHARE

    _, capped = edge_terms(problem.flexibility.preconditioner, contact)
    return charged_preconditioner(problem, contact, in_contact.reshape(-1), EDGE_SHARE * capped, capped)


def block_spaces(nodes: np.ndarray, n: int, limit: int) -> dict[str, np.ndarray]:
    """The ``block<b>`` spaces of :func:`coarse_spaces`."""
    return {name: basis for name, basis in coarse_spaces(nodes, n, limit).items() if name.startswith("block")}


def column_products(apply, basis: np.ndarray) -> tuple[np.ndarray, float]:
    """(``apply`` of each column of Z = ``basis``, side by side; its seconds)."""
    start = time.perf_counter()
    az = np.stack([apply(basis[:, k]) for k in range(basis.shape[1])], axis=1)
    return az, time.perf_counter() - start


def solver_rows(problem, topography, apply, contact: np.ndarray, in_contact: np.ndarray, rhs: np.ndarray,
                n: int, limit: int, parts: set[str]):
    """Fixed-set PCG with the solver's whole preconditioner (edge correction and hole charge) and
    the block spaces of at most ``limit`` vectors, whose exact A Z (its seconds in double,
    ``az_seconds``) both row groups share, made once per space.

    ``solver`` in ``parts``: rows ``solver`` (plainly) and ``solver-block<b>`` (deflated by the
    blocks, and the same spaces added to the preconditioner instead, M + Z E⁻¹ Zᵀ,
    ``additive_iterations``). ``twolevel`` in ``parts``: rows ``twolevel-block<b>``
    (:mod:`benchmarks.two_level`), the balancing preconditioner around the solver's with
    W = H Z exact (``iterations``) and from :class:`~benchmarks.two_level.CheapProducts` at
    CHEAP_FACTOR and CHEAP_RADIUS (``cheap_iterations``, ``cheap_seconds``; ``cheap_error`` =
    ‖W̃ − W‖ / ‖W‖, Frobenius; ``cheap_setup_seconds``: its coarse operator, stencils and lookup,
    once per set). One rank."""
    from benchmarks.two_level import CheapProducts, balancing

    solver = solver_preconditioner(problem, contact, in_contact)
    if "solver" in parts:
        yield {"space": "solver", "vectors": 0, "iterations": pcg(apply, solver, rhs)}
    cheap = None
    if "twolevel" in parts:
        start = time.perf_counter()
        cheap = CheapProducts(problem, topography, contact, CHEAP_FACTOR, CHEAP_RADIUS)
        setup = time.perf_counter() - start
    for name, basis in block_spaces(problem.nodes[contact], n, limit).items():
        az, seconds = column_products(apply, basis)
        if "solver" in parts:
            inverse = np.linalg.inv(basis.T @ az)

            def additive(values, basis=basis, inverse=inverse):
                return solver(values) + basis @ (inverse @ (basis.T @ values))

            yield {"space": f"solver-{name}", "vectors": int(basis.shape[1]), "az_seconds": seconds,
                   "iterations": pcg(apply, solver, rhs, (basis, az, inverse)),
                   "additive_iterations": pcg(apply, additive, rhs)}
        if cheap is not None:
            approximate, cheap_seconds = column_products(cheap.product, basis)
            yield {"space": f"twolevel-{name}", "vectors": int(basis.shape[1]), "az_seconds": seconds,
                   "iterations": pcg(apply, balancing(solver, basis, az), rhs),
                   "cheap_factor": CHEAP_FACTOR, "cheap_radius": CHEAP_RADIUS, "cheap_setup_seconds": setup,
                   "cheap_seconds": cheap_seconds,
                   "cheap_error": float(np.linalg.norm(approximate - az) / np.linalg.norm(az)),
                   "cheap_iterations": pcg(apply, balancing(solver, basis, approximate), rhs)}
            del approximate
        del az
    if cheap is not None:
        cheap.destroy()


def exact_rows(problem, apply, contact: np.ndarray, in_contact: np.ndarray, rhs: np.ndarray):
    """Rows ``solver`` and ``exact-inner<tol>``: fixed-set PCG iterations and Ritz values (40
    Lanczos steps) with the solver's whole preconditioner and with C_SS⁻¹, B_OO⁻¹ to each of
    EXACT_TOLS (``inner_median`` / ``inner_max``: the inner iterations of one application, each a
    periodic product; ``periodic_pairs`` per application, their median plus two). One rank."""
    solver = solver_preconditioner(problem, contact, in_contact)
    ritz = lanczos_ritz(apply, solver, np.random.default_rng(1).standard_normal(contact.size), 40)
    yield {"space": "solver", "vectors": 0, "iterations": pcg(apply, solver, rhs),
           "ritz_min": float(ritz[0]), "ritz_max": float(ritz[-1]), "periodic_pairs": 1}
    for tol in EXACT_TOLS:
        inverse, inner = exact_inverse(problem.flexibility, contact, tol)
        iterations = pcg(apply, inverse, rhs)
        counts = list(inner)
        ritz = lanczos_ritz(apply, inverse, np.random.default_rng(1).standard_normal(contact.size), 40)
        yield {"space": f"exact-inner{tol:g}", "vectors": 0, "iterations": iterations,
               "ritz_min": float(ritz[0]), "ritz_max": float(ritz[-1]),
               "inner_median": float(np.median(counts)), "inner_max": int(max(counts)),
               "periodic_pairs": float(np.median(counts)) + 2}


def exact_inverse(flexibility, contact: np.ndarray, tol: float):
    """(v ↦ [B ṽ − B R_Oᵀ B_OO⁻¹ R_O B ṽ]_S, the inner iteration counts of its applications so far):
    C_SS⁻¹ (B = C⁻¹, the preconditioner's periodic symbol on its whole period; ṽ: v on S, zero
    elsewhere on the period; O the period's nodes outside S) with B_OO⁻¹ by CG with Jacobi to a
    relative residual ``tol``. Checked first against the package's plain M = R_S C⁻¹ R_Sᵀ, which
    it must equal without the Schur term. One rank, a footprint that fills the grid (``contact``:
    grid nodes)."""
    import scipy.fft as sfft

    if not flexibility.layout.whole_grid:
        raise RuntimeError("the exact rows take the contact set's nodes as grid nodes: they need a "
                           "footprint that fills the grid")

    convolution = flexibility.preconditioner.convolution
    lengths = tuple(convolution.lengths)
    symbol = convolution.symbol                        # C⁻¹'s, (Lx, Ly // 2 + 1)
    workers = convolution.workers

    def spread(field):
        return sfft.irfft2(sfft.rfft2(field, workers=workers) * symbol, s=lengths, workers=workers)

    rows, columns = np.divmod(contact, flexibility.shape[1])
    outside = np.ones(lengths, dtype=bool)
    outside[rows, columns] = False
    delta = np.zeros(lengths)
    delta[0, 0] = 1.0
    diagonal = float(spread(delta)[0, 0])

    def embedded(values):
        field = np.zeros(lengths)
        field[rows, columns] = values
        return field

    probe = np.random.default_rng(5).standard_normal(contact.size)
    plain = spread(embedded(probe))[rows, columns]
    package = flexibility.precondition_nodes(probe, contact)
    mismatch = np.linalg.norm(plain - package) / np.linalg.norm(package)
    if not mismatch < 1e-10:
        raise RuntimeError(f"B on the period differs from the package's R_S C⁻¹ R_Sᵀ by {mismatch:.2e}")
    inner: list[int] = []

    def outside_product(values):                       # B_OO on the period's values (zero off O)
        product = spread(values.reshape(lengths))
        product[~outside] = 0.0
        return product.reshape(-1)

    def solve_outside(right):                          # B_OO y = right (zero off O), Jacobi PCG
        y = np.zeros(right.size)
        inner.append(pcg(outside_product, lambda r: r / diagonal, right.reshape(-1), limit=10000,
                         tol=tol, solution=y))
        return y.reshape(lengths)

    def inverse(values):
        smoothed = spread(embedded(values))
        right = np.where(outside, smoothed, 0.0)
        return (smoothed - spread(solve_outside(right)))[rows, columns]

    return inverse, inner


def lanczos_ritz(apply, precondition, rhs, steps: int) -> np.ndarray:
    """Ritz values of the preconditioned operator from ``steps`` PCG steps (the Lanczos
    tridiagonal of the CG coefficients: diagonal 1/α_k + β_(k−1)/α_(k−1), off-diagonal √β_k/α_k)."""
    from scipy.linalg import eigh_tridiagonal

    residual = rhs.copy()
    z = precondition(residual)
    direction, rz = z.copy(), residual @ z
    alphas, betas = [], []
    for _ in range(steps):
        product = apply(direction)
        alpha = rz / (direction @ product)
        residual -= alpha * product
        z = precondition(residual)
        rz, previous = residual @ z, rz
        alphas.append(alpha)
        betas.append(rz / previous)
        direction = z + betas[-1] * direction
    a, b = np.array(alphas), np.array(betas)
    diagonal = 1.0 / a
    diagonal[1:] += b[:-1] / a[:-1]
    return eigh_tridiagonal(diagonal, np.sqrt(b[:-1]) / a[:-1], eigvals_only=True)


def extremes(apply, precondition, size: int) -> tuple[np.ndarray, np.ndarray]:
    """(Ritz values of M H_SS after 40 Lanczos steps, its top eigenvector by 60 power iterations)."""
    ritz = lanczos_ritz(apply, precondition, np.random.default_rng(1).standard_normal(size), 40)
    return ritz, power_mode(apply, precondition, size, 60)


def power_mode(apply, precondition, size: int, steps: int, shift: float = 0.0, seed: int = 3) -> np.ndarray:
    """The eigenvector of M H_SS at the top of its spectrum (``shift`` 0) or at the bottom (``shift``
    above the top: power iterations on shift − M H_SS), unit 2-norm, after ``steps`` iterations."""
    x = np.random.default_rng(seed).standard_normal(size)
    for _ in range(steps):
        x = shift * x - precondition(apply(x)) if shift else precondition(apply(x))
        x /= np.linalg.norm(x)
    return x


def spectrum(apply, precondition, contact: np.ndarray, in_contact: np.ndarray) -> dict:
    """Extreme Ritz values of M H_SS, and the top eigenvector's energy share on the boundary of S."""
    from scipy import ndimage

    ritz, x = extremes(apply, precondition, contact.size)
    neighbours = ndimage.convolve(in_contact.astype(np.int8), np.array([[0, 1, 0], [1, 0, 1], [0, 1, 0]], np.int8),
                                  mode="constant")
    boundary = (neighbours < 4)[in_contact]
    return {"vectors": 0, "ritz_min": float(ritz[0]), "ritz_max": float(ritz[-1]),
            "boundary_share_of_nodes": float(boundary.mean()), "top_mode_boundary_energy": float(np.sum(x[boundary] ** 2))}


def schur_preconditioner(flexibility, contact: np.ndarray, in_contact: np.ndarray, terms: int):
    """v ↦ [B v − B (θ Σ_(k<terms) (I − θ B_OO)^k) (B v)_O]_S, B = C⁻¹ (the Fourier preconditioner's
    periodic convolution), θ = 1.5 / max(B): H_SS⁻¹ with B_OO⁻¹ by a Neumann series (one rank)."""
    convolution = flexibility.preconditioner.convolution
    shape = in_contact.shape
    outside = ~in_contact.reshape(-1)
    theta = 1.5 / float(convolution.symbol.max())

    def inverse(v):
        field = np.zeros(in_contact.size)
        field[contact] = v
        spread = convolution.apply(field.reshape(shape)).reshape(-1)
        rest = np.where(outside, spread, 0.0)
        total = term = theta * rest
        for _ in range(1, terms):
            term = term - theta * np.where(outside, convolution.apply(term.reshape(shape)).reshape(-1), 0.0)
            total = total + term
        return (spread - convolution.apply(total.reshape(shape)).reshape(-1))[contact]

    return inverse


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    add_launch_arguments(parser, repeats=1, output="results/bench_deflation.json")
    parser.set_defaults(ranks=[1])
    parser.add_argument("--sizes", type=int, nargs="+", default=[256, 512, 1024, 2048])
    parser.add_argument("--max-vectors", type=int, default=120, help="skip coarse spaces larger than this")
    parser.add_argument("--scenes", nargs="+", choices=sorted(PRESSURES), default=["scene"])
    parser.add_argument("--parts", nargs="+", choices=PARTS, default=list(PARTS))
    args = parser.parse_args()
    if args.worker:
        return worker(args)
    rows = run_on_ranks(__spec__.name, args.ranks, ["--sizes", *map(str, args.sizes),
                                                     "--max-vectors", str(args.max_vectors),
                                                     "--scenes", *args.scenes, "--parts", *args.parts])
    save_json(rows, args.output)


if __name__ == "__main__":
    main()
