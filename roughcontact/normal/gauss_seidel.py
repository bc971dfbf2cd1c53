"""The paper's reference inner solver: Gauss–Seidel on H_SS p_S = b (§3.1).

Borri-Brunetto et al. solve the system of each active set with an iterative
Gauss–Seidel method, "taking into account the symmetry of matrix H". Here
each sweep x ← (D + L)⁻¹ (b − U x) is one triangular solve and one product
with the strict upper triangle, done by LAPACK/BLAS on the dense H_SS,
which is gathered from the PETSc Mat and replicated on every rank (a
reference method: serial by nature, correct on any rank count).
Gauss–Seidel converges for any symmetric positive definite matrix, but
slowly: its sweep count grows with the size of the contact set, which is
what the benchmark charts against the Krylov solver.
"""
from __future__ import annotations

import numpy as np
from scipy.linalg import solve_triangular

from ..errors import ConvergenceError
from ..operators.dense import gather_dense
from .subsolver import ContactSetSubsolver


class GaussSeidelSubsolver(ContactSetSubsolver):
    """Gauss–Seidel sweeps on the gathered dense H_SS."""

    name = "gauss-seidel"

    def __init__(self, flexibility, rtol: float = 1e-11, max_sweeps: int = 20000):
        super().__init__(flexibility)
        self.comm = flexibility.comm
        self.rtol = rtol
        self.max_sweeps = max_sweeps
        self.description = f"gauss-seidel (rtol={rtol:g}, max_sweeps={max_sweeps})"

    def _build(self, active: np.ndarray) -> None:
        sub = self.flexibility.block(active, explicit=True)
        matrix = gather_dense(sub, self.comm)
        sub.destroy()
        self.lower = np.tril(matrix)
        self.upper = np.triu(matrix, 1)
        self.counts = self.comm.allgather(int(active.sum()))
        self.offset = sum(self.counts[: self.comm.Get_rank()])

    def solve(self, rhs: np.ndarray, guess: np.ndarray) -> tuple[np.ndarray, int]:
        b = np.concatenate(self.comm.allgather(np.asarray(rhs, dtype=float)))
        x = np.concatenate(self.comm.allgather(np.asarray(guess, dtype=float)))
        norm_b = np.linalg.norm(b)
        if norm_b == 0.0:
            return np.zeros_like(rhs), 0
        residual = np.inf
        upper_x = self.upper @ x
        for sweep in range(1, self.max_sweeps + 1):
            x_new = solve_triangular(self.lower, b - upper_x, lower=True, check_finite=False)
            # after the sweep L x_new = b − U x, so b − (L + U) x_new = U (x − x_new)
            change = self.upper @ (x - x_new)
            upper_x = upper_x - change
            x = x_new
            residual = np.linalg.norm(change) / norm_b
            if residual <= self.rtol:
                local = slice(self.offset, self.offset + len(rhs))
                return x[local].copy(), sweep
        raise ConvergenceError(
            "GAUSS_SEIDEL_MAX_SWEEPS",
            f"Gauss–Seidel on {b.size} contact nodes reached {self.max_sweeps} sweeps "
            f"with relative residual {residual:.3e} > rtol {self.rtol:g}")

    def destroy(self) -> None:
        self.lower = self.upper = None
