"""Coarse-to-fine starts: solve on the grid of spacing 2s, prolong the contact state to s.

A cold solve on a fine grid spends most of its iterations finding the
contact set at the scales the coarse grids already resolve. A nested start
solves the same control on the topography decimated by 2 (every other node,
:func:`~roughcontact.surfaces.coarsen`), recursively down to a grid of at
most :data:`COARSEST` footprint nodes, and starts the fine solve from the
coarse pressure interpolated bilinearly to the fine nodes (force = pressure
× s²), with the coarse rigid motion. The coarse solves are loose (their
error is dominated by the discretisation anyway): ``tol`` = :data:`COARSE_TOL`.

The controls are carried over in absolute terms: the coarse grid has its own
highest node and footprint centroid, so an imposed approach δz and imposed
moments are translated to give the same rigid-body position and the same
load point, and the coarse approach is translated back.
"""
from __future__ import annotations

import warnings

import numpy as np

from ..errors import ConvergenceError, InputError
from ..surfaces.rows import TopographyRows, rows_window, split
from .problem import NormalProblem
from .result import NormalResult

#: footprint nodes of the coarsest grid
COARSEST = 64 * 64
#: tolerance of the coarse solves
COARSE_TOL = 1e-4


class NestedStart:
    """The coarse levels of one fine problem, built on first use and kept for later cold starts.

    Parameters
    ----------
    problem
        The fine :class:`NormalProblem`.
    make
        ``make(coarse_problem) -> solver``: a solver of the same method for a
        coarse level (it gets its own nested start, so the recursion ends at
        :data:`COARSEST`).
    """

    def __init__(self, problem: NormalProblem, make):
        self.problem = problem
        self.make = make
        self.solver = None
        self.coarse_problem = None
        self.iterations = 0           # linear iterations spent on the coarse levels, last start

    @staticmethod
    def applies(problem: NormalProblem) -> bool:
        """Whether the grid is fine enough for a coarse level to pay off, and its operator one that
        can be rebuilt on a coarser grid (not a user's Mat)."""
        return problem.size > 4 * COARSEST and problem.flexibility.convolution is not None

    def start(self, rigid: np.ndarray, free: list[int], loads: np.ndarray):
        """(forces, rigid motion) on this rank's fine nodes, or None when the coarse level cannot
        give a start (a load point outside its footprint, a failed solve: warned about)."""
        fine = self.problem
        if self.solver is None:
            # every other node, by rows: no rank holds a whole coarse grid (N/4 + N/16 + … heights
            # and masks, 3 B per fine node, were on every rank where the fine surface was whole)
            coarse_topography = fine.topography.decimated(fine.comm) if fine.topography.by_rows \
                else decimated_rows(fine.topography, fine.comm)
            self.coarse_problem = NormalProblem(coarse_topography, fine.interface, fine.comm,
                                                operator=fine.operator_kind)
            self.solver = self.make(self.coarse_problem)
        coarse = self.coarse_problem
        offset = _height_offset(fine, coarse)
        shift = fine.centroid - coarse.centroid                 # (x, y) of the fine centroid, coarse frame
        try:
            if not free:
                closure = rigid[0] + rigid[1] * shift[1] + rigid[2] * shift[0] + offset
                result = self.solver.solve_closure(closure, (rigid[1], rigid[2]), gather=False)
            elif len(free) == 1:
                result = self.solver.solve_load(loads[0], rotation=(rigid[1], rigid[2]), gather=False)
            else:
                load = loads[0]
                moments = (-loads[1] + load * shift[1], -loads[2] + load * shift[0])
                result = self.solver.solve_load(load, moments=moments, gather=False)
        except (ConvergenceError, InputError) as exc:
            warnings.warn(f"the coarse-grid start failed ({exc}); the solve starts from independent "
                          "punches instead", RuntimeWarning, stacklevel=3)
            return None
        self.iterations = result.linear_iterations
        # the coarse level waits idle while the fine grid solves: its padded buffers (~70 B per
        # coarse node) are made again if a later cold start needs them
        coarse.flexibility.release_buffers()
        motion = np.array([result.closure - result.rotation[0] * shift[1] - result.rotation[1] * shift[0]
                           - offset, *result.rotation])
        forces = prolong(result, coarse, fine)
        return forces, motion

    def destroy(self) -> None:
        if self.solver is not None:
            self.solver.destroy()
            self.coarse_problem.destroy()
        self.solver = self.coarse_problem = None


def decimated_rows(topography, comm) -> TopographyRows:
    """This rank's rows of :func:`~roughcontact.surfaces.coarsen` (``topography``, 2,
    ``"decimate"``) for a whole topography (every rank holds it): its own rows taken as a
    :class:`~roughcontact.surfaces.TopographyRows` (a copy of N/ranks values, let go at once) and
    decimated by rows (:meth:`~roughcontact.surfaces.TopographyRows.decimated`)."""
    start, stop = split(topography.shape[0], comm.Get_size())[comm.Get_rank()]
    return TopographyRows.from_rows(topography.heights[start:stop], topography.spacing, topography.shape, comm,
                                    topography.footprint[start:stop], topography.metadata).decimated(comm)


def _height_offset(fine: NormalProblem, coarse: NormalProblem) -> float:
    """max Δh on the coarse footprint minus max Δh on the fine one (≤ 0: decimation drops nodes)."""
    return coarse.top_height - fine.top_height


def prolong(coarse_result: NormalResult, coarse: NormalProblem, fine: NormalProblem) -> np.ndarray:
    """Fine nodal forces (this rank's nodes) from a solution on the grid decimated by 2.

    The coarse pressure (zero off its contact set and footprint) is
    interpolated bilinearly at the fine nodes, which sit on coarse nodes or
    halfway between them, and multiplied by the fine cell area s². The
    coarse result holds each rank's own coarse rows (a ``gather=False``
    solve); a rank receives the coarse rows its fine rows fall between
    (:func:`~roughcontact.surfaces.rows.rows_window`), not the whole coarse grid.
    """
    layout = fine.flexibility.layout
    (r0, r1), mask = layout.rows, layout.local_mask
    cx = coarse.topography.shape[0]
    # the coarse rows each fine row lies between (the same twice on a coarse one)
    rows = np.arange(r0, r1)
    i0 = np.minimum(rows // 2, cx - 1)
    i1 = np.minimum(i0 + rows % 2, cx - 1)
    needed = (int(i0[0]), int(i1[-1]) + 1) if rows.size else (0, 0)
    mine = np.where(coarse_result.contact, coarse_result.pressure, 0.0)
    if coarse_result.distributed:
        pressure = rows_window(mine, coarse_result.rows, needed, coarse.comm)
    else:
        pressure = mine[needed[0]:needed[1]]
    # bilinear, one direction at a time: whole rows of the grid, not one gather per node and corner
    along_x = pressure[i0 - needed[0]] + pressure[i1 - needed[0]]
    both = _neighbour_sums(along_x, fine.topography.shape[1])
    both *= 0.25
    value = both.reshape(-1) if layout.whole_rows else both[mask]
    return value * fine.topography.spacing**2


def _neighbour_sums(values: np.ndarray, count: int) -> np.ndarray:
    """values[:, j0] + values[:, j1] for the ``count`` fine columns j, j0 = min(j // 2, c − 1) and
    j1 = min(j0 + j % 2, c − 1) (c coarse columns), by strided slices: the gathers by index arrays
    took 0.3 s of a 2048² solve"""
    coarse = values.shape[1]
    out = np.empty((values.shape[0], count))
    even, odd = out[:, 0::2], out[:, 1::2]
    inner = min(even.shape[1], coarse)                 # fine 2k on coarse k
    np.multiply(values[:, :inner], 2.0, out=even[:, :inner])
    even[:, inner:] = 2.0 * values[:, coarse - 1:coarse]
    inner = min(odd.shape[1], coarse - 1)              # fine 2k + 1 between coarse k and k + 1
    np.add(values[:, :inner], values[:, 1:inner + 1], out=odd[:, :inner])
    odd[:, inner:] = 2.0 * values[:, coarse - 1:coarse]
    return out
