"""A normal contact problem: composite topography + materials + flexibility operator.

Rigid-body motion and loads (Eqs. 7–8)
--------------------------------------
The initial gap of a footprint node is ``gap0 = max(Δh) − Δh`` (zero at the
highest node). Rotations are taken about the centroid (x_c, y_c) of the
footprint, and with x, y measured from it the imposed interpenetration is

    w_i = δz − θx y_i − θy x_i − gap0_i                           (Eq. 7)

so that contact (Eq. 7a) means u_i = w_i and separation (Eq. 7b) u_i > w_i,
with u = H p the elastic displacement. The resultants (Eq. 8) are
P = Σ p, Mx = Σ p y, My = Σ p x about the same centroid; written with the
columns C = [1, −y, −x] they are the loads conjugate to r = (δz, θx, θy):
Cᵀ p = (P, −Mx, −My).
"""
from __future__ import annotations

import numpy as np

from ..collective import Collective
from ..errors import ConvergenceError, InputError
from ..materials import Interface
from ..operators.set_blocks import held_for_set, indices_of
from ..surfaces.rows import gather_into
from ..surfaces.topography import Topography

#: the nodes whose coordinates C's columns are made from at a time (:meth:`NormalProblem.columns_at`)
ARMS_CHUNK = 1 << 16


def node_indices(nodes: np.ndarray) -> np.ndarray:
    """Local node indices from indices, or from a mask over a rank's nodes (then a set-sized block,
    :func:`~roughcontact.operators.set_blocks.indices_of`)."""
    nodes = np.asarray(nodes)
    return indices_of(nodes.reshape(-1)) if nodes.dtype == bool else nodes


class NormalProblem(Collective):
    """Layout of one normal contact problem on a communicator.

    Parameters
    ----------
    topography
        Composite topography Δh on a square grid with its footprint: a
        :class:`~roughcontact.surfaces.Topography` (whole on every rank) or a
        :class:`~roughcontact.surfaces.TopographyRows` (each rank its own rows; solves with
        ``gather=False`` then hold nothing of size N on any rank).
    interface
        The two materials.
    comm
        mpi4py communicator the operator is distributed on.
    operator
        The flexibility operator H over the footprint nodes: ``"auto"``
        (:func:`~.choice.choose_operator`), ``"dense"`` (the explicit Eq. 10
        matrix), ``"fft"`` (matrix-free, zero-padded FFT convolution),
        ``"fft-periodic"`` (the grid is one period) or a user's PETSc Mat
        (rows owned as :class:`~roughcontact.operators.layout.NodeLayout`).
        See :class:`~roughcontact.operators.flexibility.Flexibility`.
    workers
        FFT threads per rank (default: the node's cores shared by its ranks).
    """

    def __init__(self, topography: Topography, interface: Interface, comm, operator="auto",
                 workers: int | None = None):
        from ..operators.flexibility import Flexibility
        from .choice import choose_operator

        self.topography = topography
        self.interface = interface
        self.comm = comm
        if isinstance(operator, str):
            kind, self.operator_reason = choose_operator(topography, operator)
            self.flexibility = Flexibility(topography, interface, comm, kind=kind, workers=workers)
            self._owns_operator = True
        else:
            self.flexibility = Flexibility.from_mat(operator, topography, comm)
            self.operator_reason = "given"
            self._owns_operator = False
        layout = self.flexibility.layout
        self.size = layout.size
        self.start, self.stop = layout.start, layout.stop
        self.counts = np.array(comm.allgather(layout.local_size))     # nodes of each rank
        s = topography.spacing
        # the centroid from integer sums: exact, so the same bits on any number of ranks
        index_sums = np.array(comm.allreduce(layout.index_sums()), dtype=float)
        self.centroid = index_sums * s / self.size
        # the coordinates by grid row (x) and by grid column (y): a node's are its row's and its
        # column's (Eq. 8), so no array of the nodes' size is held for them
        self._x_rows = np.arange(*layout.rows) * s - self.centroid[0]
        self._y_columns = np.arange(layout.shape[1]) * s - self.centroid[1]
        heights = topography.local_rows(layout.rows)[0][layout.local_mask]
        top, negative_bottom = self.allmax(np.array([heights.max(initial=-np.inf),
                                                     -heights.min(initial=np.inf)]))
        self.gap0 = top - heights
        self.top_height = float(top)                                  # max Δh on the footprint
        # the scale of heights, used to make gap tolerances relative
        self.height_range = float(top + negative_bottom) if self.size > 1 else 0.0
        # the farthest row and column that hold a node of this rank
        mask = layout.local_mask
        self._extent = float(self.allmax(max(np.abs(self._x_rows[mask.any(axis=1)]).max(initial=0.0),
                                             np.abs(self._y_columns[mask.any(axis=0)]).max(initial=0.0))))
        self._hull = None

    @property
    def nodes(self) -> np.ndarray:
        """(i, j) grid indices of this rank's nodes, in the order of the unknowns (int32), made
        when asked: 8 B per node that every rank held for the few reads of a solver's set-up."""
        return self.flexibility.layout.local_nodes()

    @property
    def x(self) -> np.ndarray:
        """x (m, from the footprint's centroid) of this rank's nodes, made when asked (8 B per
        node). What every solve needs of the coordinates, the interpenetration w (Eq. 7) and the
        load's moments, is taken from the rows' and columns' coordinates instead
        (:meth:`interpenetration`, :meth:`moments`): made in every solve, node arrays of them took
        fresh pages each time (about 6 000 more page faults in a repeated 1024² solve)."""
        return self._by_node(self._x_rows[:, None])

    @property
    def y(self) -> np.ndarray:
        """y (m, from the footprint's centroid) of this rank's nodes, made when asked (as :attr:`x`)."""
        return self._by_node(self._y_columns[None, :])

    def _by_node(self, rows_by_columns: np.ndarray) -> np.ndarray:
        """This rank's nodes' values of a field given by rows and columns (broadcast to the slab)."""
        layout = self.flexibility.layout
        field = np.broadcast_to(rows_by_columns, layout.local_mask.shape)     # a read-only view
        return field.copy().reshape(-1) if layout.whole_rows else field[layout.local_mask]

    def moments(self, values: np.ndarray) -> np.ndarray:
        """(Σ v, Σ v y, Σ v x) over this rank's nodes of nodal ``values`` (partial sums: allsum them),
        by grid rows and columns: Σ v x = Σ_rows x_row Σ_row v, without the nodes' coordinates."""
        slab = self.flexibility.slab(values)
        return np.array([values.sum(), slab.sum(axis=0) @ self._y_columns, slab.sum(axis=1) @ self._x_rows])

    @property
    def operator(self):
        """The PETSc Mat of H (MATDENSE or matrix-free)."""
        return self.flexibility.mat

    @property
    def operator_kind(self) -> str:
        """Which operator: ``"dense"``, ``"fft"``, ``"fft-periodic"`` or ``"user (<Mat type>)"``."""
        return self.flexibility.kind

    def displacement(self, forces: np.ndarray, single: bool = False) -> np.ndarray:
        """u = H p on this rank's nodes for nodal forces p on this rank's nodes (Eq. 9);
        ``single``: the FFT product in single precision (:meth:`.Flexibility.product`)."""
        self._check_alive()
        return self.flexibility.product(forces, single)

    def displacement_at(self, forces: np.ndarray, nodes: np.ndarray, single: bool = False) -> np.ndarray:
        """u = H p on this rank's nodes for forces ``forces`` on this rank's ``nodes`` (local
        indices) and none elsewhere (:meth:`.Flexibility.product_at`)."""
        self._check_alive()
        return self.flexibility.product_at(forces, nodes, single)

    def held_displacement(self, forces: np.ndarray, single: bool = False):
        """:meth:`displacement` held before its inverse transforms, with pᵀHp known
        (:meth:`.Flexibility.held_product`)."""
        self._check_alive()
        return self.flexibility.held_product(forces, single)

    def held_displacement_at(self, forces: np.ndarray, nodes: np.ndarray, single: bool = False):
        """:meth:`displacement_at` held before its inverse transforms
        (:meth:`.Flexibility.held_product_at`)."""
        self._check_alive()
        return self.flexibility.held_product_at(forces, nodes, single)

    @property
    def extent(self) -> float:
        """Largest |x| or |y| of a footprint node from the centroid (m); s for a single node."""
        return self._extent or self.topography.spacing

    def columns_at(self, nodes: np.ndarray) -> np.ndarray:
        """C = [1, −y, −x] (Eq. 8) at this rank's ``nodes`` (local indices, or a mask over this
        rank's nodes), from the rows' and columns' coordinates: |nodes| × 3 values, and no array
        of every node's coordinates (a Hessian of the free rotation on a light load's few contact
        nodes had made C on all nodes, with x and y, 56 B per node)."""
        nodes = node_indices(nodes)
        columns = np.empty((nodes.size, 3))
        columns[:, 0] = 1.0
        self._arms_into(nodes, columns[:, 1], columns[:, 2])
        return columns

    def arms_at(self, nodes: np.ndarray) -> np.ndarray:
        """C's columns −y and −x (Eq. 8) at this rank's ``nodes`` as two contiguous rows, 2 × |nodes|
        values, for the moments Σ p·(−y), Σ p·(−x) by BLAS."""
        nodes = node_indices(nodes)
        arms = held_for_set(nodes.size, float, rows=2)
        self._arms_into(nodes, arms[0], arms[1])
        return arms

    def _arms_into(self, nodes: np.ndarray, minus_y: np.ndarray, minus_x: np.ndarray) -> None:
        """−y and −x of the nodes ``nodes`` (local indices) into ``minus_y`` and ``minus_x``, in
        chunks of ARMS_CHUNK nodes: the positions, rows and columns of a whole set near full contact
        (8 B per node each, beside the three columns stacked and then copied) had been the peak of
        a study's load sweep, about 72 B per node of the set."""
        positions_of = self.flexibility.layout.slab_positions
        width = self.flexibility.layout.shape[1]
        for start in range(0, nodes.size, ARMS_CHUNK):
            row, column = np.divmod(positions_of(nodes[start:start + ARMS_CHUNK]), width)
            np.negative(self._y_columns[column], out=minus_y[start:start + ARMS_CHUNK])
            np.negative(self._x_rows[row], out=minus_x[start:start + ARMS_CHUNK])

    @property
    def local_size(self) -> int:
        return self.stop - self.start

    def interpenetration(self, rigid: np.ndarray) -> np.ndarray:
        """w = C r − gap0 on the local nodes, for r = (δz, θx, θy) (Eq. 7)."""
        approach, theta_x, theta_y = np.asarray(rigid, dtype=float)
        if theta_x == 0.0 and theta_y == 0.0:
            return approach - self.gap0
        displaced = self.rigid_displacement(rigid)
        displaced -= self.gap0
        return displaced

    def rigid_displacement(self, rigid: np.ndarray) -> np.ndarray:
        """C r = δz − θx y − θy x on the local nodes (Eq. 7), a new array."""
        approach, theta_x, theta_y = np.asarray(rigid, dtype=float)
        # the same operations per node as on the nodes' coordinates, on the rows' and columns'
        tilted = (approach - theta_x * self._y_columns)[None, :] - theta_y * self._x_rows[:, None]
        return self.flexibility.layout.from_slab(tilted)

    def allsum(self, local) -> np.ndarray:
        """Sum over ranks of a local partial sum (same bits on every rank)."""
        return self._allreduce(local, "SUM")

    def allmax(self, local) -> np.ndarray:
        """Maximum over ranks."""
        return self._allreduce(local, "MAX")

    def allmean(self, values: np.ndarray) -> float:
        """Mean over all ranks of a distributed set of values (0 for an empty set)."""
        total, count = self.allsum(np.array([values.sum(), values.size]))
        return float(total / count) if count else 0.0

    def load_scale(self, forces: np.ndarray, load: float) -> float:
        """P / Σ p over all ranks: the rescaling that restores the load P exactly (Polonsky &
        Keer); raises where every force has vanished."""
        total = float(self.allsum(forces.sum()))
        if not total > 0.0:
            raise ConvergenceError("CG_NO_CONTACT", "every force vanished during the iteration; "
                                                    "the load cannot be restored")
        return load / total

    def interpenetration_scale(self, w: np.ndarray) -> float:
        """The scale the gap residual is measured against: the largest |w| over all ranks, at
        least the height range of the footprint (1 for a flat, untouched one)."""
        return max(float(self.allmax(np.abs(w).max(initial=0.0))), self.height_range) or 1.0

    def _allreduce(self, local, op: str) -> np.ndarray:
        from mpi4py import MPI

        send = np.array(local, dtype=float, ndmin=1)
        recv = np.empty_like(send)
        self.comm.Allreduce(send, recv, op=getattr(MPI, op))
        return recv.reshape(np.shape(local))

    def gather(self, local: np.ndarray) -> np.ndarray:
        """All footprint values of a distributed vector (this rank's nodes), on every rank: received
        in place into one array (no pickled copies)."""
        if np.shape(local) != (self.local_size,):
            raise ValueError(f"gather takes this rank's {self.local_size} values, got shape {np.shape(local)}")
        return gather_into(self.comm, local, self.counts, (self.size,))

    def nearest_node(self, point) -> int:
        """Global index of the footprint node nearest to ``point`` (centroid-relative x, y; the
        lowest index among equally near ones)."""
        distance = (self.x - point[0]) ** 2 + (self.y - point[1]) ** 2
        local = int(np.argmin(distance)) if distance.size else -1
        best = (float(distance[local]), self.start + local) if local >= 0 else (np.inf, self.size)
        return int(min(self.comm.allgather(best))[1])

    def to_rows(self, values: np.ndarray, fill=0.0) -> np.ndarray:
        """This rank's grid rows of a field, (row_stop − row_start, ny), from this rank's node values,
        ``fill`` off the footprint (always a new array)."""
        mask = self.flexibility.layout.local_mask
        field = np.full(mask.shape, fill, dtype=np.asarray(values).dtype)
        field[mask] = values
        return field

    def to_field(self, values: np.ndarray, fill: float = 0.0) -> np.ndarray:
        """A (nx, ny) field from footprint values (global vector), ``fill`` elsewhere."""
        self.require_whole_topography("a whole field")
        field = np.full(self.topography.shape, fill, dtype=np.asarray(values).dtype)
        field[self.topography.footprint] = values
        return field

    def require_whole_topography(self, what: str) -> None:
        """Raise a one-line InputError when the topography is held by rows and ``what`` needs all of it."""
        if self.topography.by_rows:
            raise InputError("topography", f"is held by rows (TopographyRows); {what} needs the whole "
                                           "Topography on every rank")

    def load_point_inside(self, point: np.ndarray) -> bool:
        """Whether ``point`` (centroid-relative x, y) lies in the footprint's convex hull."""
        from scipy.spatial import ConvexHull, QhullError

        if self._hull is None:
            # the hull of the footprint is the hull of each grid row's first and last node (the
            # nodes are in row order)
            rows = self.nodes[:, 0]
            first = np.flatnonzero(np.diff(rows, prepend=-1) != 0)
            last = np.append(first[1:], rows.size) - 1 if rows.size else first
            ends = np.union1d(first, last)
            self._hull = np.concatenate(self.comm.allgather(np.stack([self.x[ends], self.y[ends]], axis=1)))
        try:
            hull = ConvexHull(self._hull)
        except (QhullError, ValueError):
            # fewer than 3 nodes or collinear nodes: allow the exact centroid only
            return bool(np.allclose(point, 0.0, atol=1e-12 * self.topography.spacing))
        tol = 1e-9 * self.topography.spacing
        return bool(np.all(hull.equations[:, :2] @ point + hull.equations[:, 2] <= tol))

    def _release(self) -> None:
        """Free the operator if this problem built it (collective)."""
        if self._owns_operator:
            self.flexibility.destroy()

