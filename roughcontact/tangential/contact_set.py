"""Corrective solves on the actual contact set, by its explicit matrix (Eq. 23, receding).

As Q grows at constant P the corrective load P* = P − Q/f falls and the stick
set, the contact set of p*, recedes inside the actual contact set C (Eq. 23;
:mod:`.cattaneo`). A corrective solve therefore needs H only between the
nodes of C. Where C is a small part of the grid (a light load: 3 731 of the
263 169 nodes of the 513² sweep scene) the explicit H_CC is cheaper than the
FFT over the whole grid, and the CG on it needs no Fourier preconditioner:

- the part problem: a :class:`~roughcontact.normal.NormalProblem` whose
  footprint is C, with the ``"dense"`` operator, whose products then go
  through its matrix (:attr:`~roughcontact.operators.flexibility.Flexibility.explicit_products`);
- the CG there without preconditioner: at 513² the nine corrective solves took
  0.82 s (28–42 iterations each) against 2.2 s with the Fourier one (20–25
  iterations; its transforms over the grid cost 3.6 ms an iteration, an
  explicit product 1.5 ms in single precision, 4.3 ms in double);
- each part solution then starts the whole problem's corrective solver,
  which confirms it (one iteration, 28 ms at 513²) or, if a node off C had
  to stick, goes on from it until the whole footprint's conditions hold. The
  answer is the whole problem's in every case.

The rigid motions of the two problems differ by a constant: rotations are
taken about each footprint's centroid and the initial gap from each
footprint's highest node (Eq. 7), so with the rotation θ fixed
δz_part = δz + θx (y_c − y_c') + θy (x_c − x_c') + max_C Δh − max Δh.
"""
from __future__ import annotations

import time
from dataclasses import replace

import numpy as np

from ..collective import Collective
from ..errors import ConvergenceError, InputError
from ..normal.factory import make_solver
from ..normal.problem import NormalProblem
from ..normal.result import NormalResult
from ..operators.layout import NodeLayout

#: iterations a part solve may take before the whole solver goes on from its own start (the 513²
#: sweep's took 26–42; the default limit of the CG, 5 000 unpreconditioned products, would cost
#: 7–20 s before the whole solver took over)
PART_ITERATIONS = 500


def contact_set_pays(problem: NormalProblem, contact: np.ndarray) -> bool:
    """Whether the corrective solves of ``problem`` go to the contact set ``contact`` (a whole-grid
    mask): the problem holds its topography whole and has an FFT operator on a bounded grid, and
    the contact set, at most an eighth of the grid, has explicit products that pay
    (:func:`~roughcontact.operators.flexibility.explicit_products_pay`)."""
    from ..operators.flexibility import explicit_products_pay, sparse_footprint  # PETSc: when the CLI says

    flexibility = problem.flexibility
    if flexibility.convolution is None or flexibility.periodic or problem.topography.by_rows:
        return False
    if not contact.any():
        return False
    layout = NodeLayout.build(problem.topography.with_footprint(contact), problem.comm)
    return sparse_footprint(layout) and explicit_products_pay(layout, problem.comm)


class ContactSetSolver(Collective):
    """The corrective CG of :class:`~.cattaneo.CattaneoSolver` run on the actual contact set and
    confirmed on the whole footprint; it answers as the whole problem's solver does
    (:meth:`warm_start`, :meth:`start_from`, :meth:`solve_load`, :attr:`forces`, :attr:`rigid`).

    Parameters
    ----------
    problem
        The whole normal problem.
    normal
        Its actual solution: C is its contact set.
    whole
        The whole problem's corrective solver (a CG), which confirms each solution.
    """

    def __init__(self, problem: NormalProblem, normal: NormalResult, whole):
        from ..normal.constrained_cg import ConstrainedCGSolver

        if not isinstance(whole, ConstrainedCGSolver):
            raise InputError("method", "the corrective solves on the contact set confirm by the CG; "
                                       f"got a {type(whole).__name__}")
        if not contact_set_pays(problem, normal.contact):
            raise InputError("normal", f"its contact set ({int(normal.contact.sum())} nodes) is not one whose "
                                       "explicit products pay (contact_set_pays)")
        self.problem = problem
        self.whole = whole
        self.part = NormalProblem(problem.topography.with_footprint(normal.contact), problem.interface,
                                  problem.comm, operator="dense", workers=problem.flexibility.workers)
        assert self.part.flexibility.explicit_products     # what contact_set_pays promised
        settings = whole.settings
        try:
            self.solver = make_solver(self.part, "cg", nested=False, settings=replace(
                settings, preconditioner="none", max_iterations=min(settings.max_iterations, PART_ITERATIONS)))
        except BaseException:
            self.part.destroy()
            raise

    def _shift(self, rotation) -> float:
        """δz_part − δz under the rotation (θx, θy): the same interpenetration on C (Eq. 7)."""
        theta_x, theta_y = rotation
        (xc, yc), (xp, yp) = self.problem.centroid, self.part.centroid
        return theta_x * (yc - yp) + theta_y * (xc - xp) + self.part.top_height - self.problem.top_height

    @property
    def settings(self):
        return self.whole.settings

    @property
    def forces(self) -> np.ndarray:
        """p* on this rank's nodes of the whole footprint."""
        return self.whole.forces

    @property
    def rigid(self) -> np.ndarray:
        """(δz*, θx, θy) of the whole problem."""
        return self.whole.rigid

    def warm_start(self, result: NormalResult) -> None:
        """Start both solvers from a solution of the whole problem (:meth:`.NormalSolver.warm_start`)."""
        self.whole.warm_start(result)
        self._start_part()

    def start_from(self, forces: np.ndarray, rigid: np.ndarray, active: np.ndarray | None = None) -> None:
        """Start both solvers from forces on this rank's nodes of the whole footprint and the whole
        problem's rigid motion (:meth:`.NormalSolver.start_from`)."""
        self.whole.start_from(forces, rigid, active)
        self._start_part()

    def solve_load(self, load: float, rotation: tuple[float, float]) -> NormalResult:
        """The corrective solution at P* with the rotation fixed, of the whole problem: solved on C,
        confirmed (or completed) on the whole footprint from there. Its ``linear_iterations``
        count both solves' iterations and its ``elapsed`` both solves' time; its ``choice`` says how
        many iterations each took."""
        self._check_alive()
        t0 = time.perf_counter()
        try:
            part = self.solver.solve_load(load, rotation=rotation, gather=False)
        except ConvergenceError:
            part = None                                 # the whole solver goes on from its own start
        if part is not None:
            self.whole.start_from(self._to_whole(self.solver.forces),
                                  self.solver.rigid - np.array([self._shift(rotation), 0.0, 0.0]))
        result = self.whole.solve_load(load, rotation=rotation)
        iterations = part.linear_iterations if part is not None else 0
        nodes = self.part.size
        how = (f"{iterations} iterations on the contact set's {nodes} nodes (explicit products)"
               if part is not None else f"no solution within {PART_ITERATIONS} iterations on the contact "
                                        f"set's {nodes} nodes")
        choice = f"{result.choice}; corrective: {how}, then {result.linear_iterations} on the whole footprint"
        return replace(result, linear_iterations=result.linear_iterations + iterations,
                       elapsed=time.perf_counter() - t0, choice=choice)

    def _start_part(self) -> None:
        # with the rotation fixed, as in every corrective solve, the CG finds δz from the load and
        # the start's is not read; the shift keeps the start a state of the part problem all the same
        rigid = self.whole.rigid
        shift = np.array([self._shift(rigid[1:]), 0.0, 0.0])
        self.solver.start_from(self._to_part(self.whole.forces), rigid + shift)

    def _to_part(self, values: np.ndarray) -> np.ndarray:
        """This rank's values on C from its values on the whole footprint (the same grid rows)."""
        slab = self.problem.flexibility.layout.to_slab(values)
        return slab[self.part.flexibility.layout.local_mask]

    def _to_whole(self, values: np.ndarray) -> np.ndarray:
        """This rank's values on the whole footprint (0 off C) from its values on C."""
        slab = self.part.flexibility.layout.to_slab(values)
        return self.problem.flexibility.layout.from_slab(slab).copy()

    def _release(self) -> None:
        self.solver.destroy()
        self.part.destroy()
        self.whole.destroy()
