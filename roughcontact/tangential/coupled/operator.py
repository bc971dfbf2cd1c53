"""The coupled shear operator T of Eqs. 15–16, and the Newton system of a step as a PETSc Mat.

:class:`ShearOperator` holds T over the footprint of a normal problem
(:class:`~roughcontact.operators.shear.ShearConvolution`, matrix-free: two
FFT transforms each way per product) on that problem's communicator and row
layout: :meth:`ShearOperator.product` applies it to this rank's (q_x, q_y).

A step of the incremental stick/slip problem (:mod:`.increment`) solves, on
the contact nodes, the Newton system K y = b of the stick set and the slip
set: y holds both components of the traction change at a stick node and one
component, along the tangent t_i ⊥ q_i of the Coulomb circle |q_i| = f p_i,
at a slip node, so that with Z the map from y to the two traction fields

    K = Zᵀ T Z + diag(0 on stick, η_i on slip),   η_i = (s_i · d_i) / (f p_i),

with d_i = q_i / |q_i| and s_i the slip increment: η_i is the multiplier of
the circle constraint times its curvature (the Hessian of the Lagrangian on
the circle). K is symmetric positive definite: :class:`TangentMat`
is its Python context, :class:`TangentPC` the Fourier preconditioner of the
Eq. 10 kernel on the contact set, applied to each component (Zᵀ blockdiag(M,
M) Z; T ≈ (1 + O(γ)) K·I, so the bound of the normal problem carries over).
"""
from __future__ import annotations

import numpy as np
from petsc4py import PETSc

from ...collective import Collective
from ...errors import InputError
from ...operators.shear import ShearConvolution


class ShearOperator(Collective):
    """T (Eqs. 15–16) over the footprint nodes of ``problem``, for composite Poisson ratio ``gamma``.

    Parameters
    ----------
    problem
        A :class:`~roughcontact.normal.NormalProblem` built from a topography
        (operator ``"dense"`` or ``"fft"``: its layout, spacing and compliance A).
    gamma
        Composite Poisson ratio γ (Eq. 4b).
    """

    def __init__(self, problem, gamma: float):
        flexibility = problem.flexibility
        if flexibility.convolution is None or flexibility.periodic:
            raise InputError("operator", f"the coupled shear operator needs a half-space operator built from "
                                         f"the topography ('dense' or 'fft'), not {flexibility.kind!r}")
        self.flexibility = flexibility
        self.layout = flexibility.layout
        self.comm = problem.comm
        self.gamma = float(gamma)
        self.convolution = ShearConvolution(flexibility.shape, flexibility.spacing, flexibility.compliance,
                                            self.gamma, self.comm, workers=flexibility.convolution.workers)
        rows = (self.layout.rows[1] - self.layout.rows[0], flexibility.shape[1])
        self._slabs = (np.zeros(rows), np.zeros(rows))

    def product(self, qx: np.ndarray, qy: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(u_x, u_y) = T (q_x, q_y) on this rank's footprint nodes (Eqs. 15–16); collective."""
        self._check_alive()
        layout = self.layout
        sx = layout.to_slab(qx, out=self._slabs[0])
        sy = layout.to_slab(qy, out=self._slabs[1])
        ux, uy = self.convolution.apply(sx, sy)
        return layout.from_slab(ux).copy(), layout.from_slab(uy).copy()

    def _release(self) -> None:
        """Nothing to free (no PETSc objects of its own); later products raise DestroyedError."""


class Basis:
    """Z: the Newton unknowns y of a step → the two traction fields on this rank's nodes.

    y = [Δq_x on stick, Δq_y on stick, Δq·t on slip]; ``nodes`` are the local
    indices of the contact nodes, ``stick`` a mask over them, ``tangent`` the
    unit vectors t_i (2, slip count) of the slip nodes.
    """

    def __init__(self, nodes: np.ndarray, stick: np.ndarray, tangent: np.ndarray, local_size: int):
        self.stick_nodes = nodes[stick]
        self.slip_nodes = nodes[~stick]
        self.tangent = tangent
        self.local_size = local_size
        self.n_stick = self.stick_nodes.size
        self.size = 2 * self.n_stick + self.slip_nodes.size

    def fields(self, y: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Z y as (g_x, g_y) over this rank's footprint nodes (0 off the contact set)."""
        k = self.n_stick
        gx, gy = np.zeros(self.local_size), np.zeros(self.local_size)
        gx[self.stick_nodes], gy[self.stick_nodes] = y[:k], y[k:2 * k]
        gx[self.slip_nodes], gy[self.slip_nodes] = y[2 * k:] * self.tangent[0], y[2 * k:] * self.tangent[1]
        return gx, gy

    def reduce(self, ux: np.ndarray, uy: np.ndarray) -> np.ndarray:
        """Zᵀ (u_x, u_y): both components on stick nodes, the tangential one on slip nodes."""
        slip = self.slip_nodes
        return np.concatenate([ux[self.stick_nodes], uy[self.stick_nodes],
                               self.tangent[0] * ux[slip] + self.tangent[1] * uy[slip]])


class TangentMat:
    """Python context of K = Zᵀ T Z + diag(0, η) (symmetric positive definite)."""

    def __init__(self, operator: ShearOperator, basis: Basis, curvature: np.ndarray):
        self.operator = operator
        self.basis = basis
        self.curvature = curvature           # η on the slip nodes

    def mult(self, mat, x, y):
        values = x.getArray(readonly=True)
        out = self.basis.reduce(*self.operator.product(*self.basis.fields(values)))
        out[2 * self.basis.n_stick:] += self.curvature * values[2 * self.basis.n_stick:]
        y.getArray()[:] = out

    multTranspose = mult


class TangentPC:
    """Python PC context: z = Zᵀ blockdiag(M, M) Z r, M = R_S C⁻¹ R_Sᵀ the Fourier preconditioner
    of the Eq. 10 kernel on the contact set S (:mod:`roughcontact.operators.preconditioner`)."""

    def __init__(self, flexibility, nodes: np.ndarray, basis: Basis):
        self.flexibility = flexibility
        self.nodes = nodes
        self.basis = basis

    def apply(self, pc, x, y):
        gx, gy = self.basis.fields(x.getArray(readonly=True))
        zx, zy = np.zeros_like(gx), np.zeros_like(gy)
        zx[self.nodes] = self.flexibility.precondition_nodes(gx[self.nodes], self.nodes)
        zy[self.nodes] = self.flexibility.precondition_nodes(gy[self.nodes], self.nodes)
        y.getArray()[:] = self.basis.reduce(zx, zy)


def tangent_mat(operator: ShearOperator, basis: Basis, curvature: np.ndarray) -> PETSc.Mat:
    """K of one Newton iteration as a Python Mat on ``operator``'s communicator."""
    mat = PETSc.Mat().createPython(((basis.size, None), (basis.size, None)),
                                   TangentMat(operator, basis, curvature), comm=operator.comm)
    mat.setOption(PETSc.Mat.Option.SYMMETRIC, True)
    mat.setOption(PETSc.Mat.Option.SPD, True)
    mat.setUp()
    return mat
