"""A Fourier preconditioner for H_SS, the flexibility matrix on a contact set.

The symbol of the Eq. 10 operator decays like 1/|q| (the half-space's
A/|q| times the punch's sin(|q|a)/(|q|a)), so H is ill-conditioned in
proportion to the grid size and unpreconditioned Krylov iterations grow
with it. The preconditioner applies the inverse of a circulant C that
approximates H, restricted to the contact set S:

    z = R_S C⁻¹ R_Sᵀ g,

i.e. the residual g on S, zero elsewhere, multiplied by 1/symbol in Fourier
space (a |q| filter) and read back on S. C is the circulant of the Eq. 10
kernel folded onto a period (nearest image) PERIOD_MARGIN nodes or more
longer than the grid, which sits in one corner of it
(:func:`embedding_period`): positive definite (its symbol is positive,
checked at set up), and a transform of about n × n instead of the padded
2n × 2n one of the product. On the grid's own period C joined the grid's
opposite edges, where a contact set that reaches them has a punch's edge:
a flat punch over the whole grid was preconditioned to a condition of 8.5 /
13.8 at 24² / 48² (1.7 / 1.9 now), and near full contact the largest mode
lay on the grid's outer nodes. The periodic operator keeps the grid as the
period (its images are physical) and the half-space kernel wrapped on it:
its own kernel has a zero mean mode (the gauge), which C⁻¹ cannot invert,
and differs from C only in the far field. R_S C⁻¹ R_Sᵀ is symmetric positive definite, so it can precondition
CG. On a filled contact set it is the inverse of H up to boundary terms; on
isolated nodes it is a constant multiple of the inverse of the diagonal.

The edge correction. With A = C⁻¹ (off-diagonal entries ≤ 0 but for some
far ones, each below 0.5 % of the diagonal) the preconditioner's quadratic
form on a set S splits into a part that sees only differences inside S and
a diagonal that sees the rest of the grid,

    gᵀ R_S A R_Sᵀ g = ½ Σ_{i,j∈S} (−A_ij)(g_i − g_j)² + Σ_{i∈S} (a₀ + κ_i) g_i²,
    κ_i = Σ_{j∉S} (−A_ij) = (A 1_S)_i − a₀,      a₀ = Σ_j A_ij (the row sum),

and κ_i grows like 1/d near an island's edge (d the distance to it), where
H_SS⁻¹ has only the 1/√d of the punch pressure: the preconditioned operator's
largest eigenvalues live on the islands' boundary nodes and grow with the
resolution (Ritz values of M H_SS on the solved set of the large-grid scene,
benchmarks/bench_deflation.py: largest 6.5 / 14.3 / 18.7 at 512² / 1024² /
2048², smallest 1.0 / 1.0 / 0.64). :meth:`FourierPreconditioner.edge_weights`
gives e_i = EDGE_SHARE · min(max(κ_i, 0), EDGE_CAP · A_ii) (κ_i can fall
slightly below 0 through those positive entries), and the corrected
preconditioner R_S A R_Sᵀ − diag(e) keeps a diagonal of at least
a₀ + min(κ_i, (1 − EDGE_SHARE) κ_i): positive definite wherever the
difference part is, and isolated nodes (κ ≈ A_ii) keep most of their
scaling (tests/test_preconditioner_edge.py checks it on sets from sparse to
nearly full). One periodic
product of the set's indicator makes κ for every node. On the same sets the
largest Ritz values fall to 1.5 / 3.2 / 4.5 and the smallest to 0.40 / 0.43
/ 0.41; fixed-set PCG iterations to 1e-8: 16 → 12, 21 → 15, 29 → 20.

References: E.A.H. Vollebregt, J. Comput. Phys. 257 (2014) 333–351 (an FFT
preconditioner for the contact set in CG); for the 1/|q| symbol, K.L.
Johnson, Contact Mechanics (1985) §3; for the split of a fractional
operator's form on a domain into a regional part and a killing term, Q.-Y.
Guan, Z.-M. Ma, Probab. Theory Relat. Fields 134 (2006) 649–694; for
operator preconditioning on screens, where the restricted inverse of an
operator of order ±1 needs modifying at the edge, R. Hiptmair, C.
Jerez-Hanckes, C. Urzúa-Torres, "Optimal operator preconditioning for
hypersingular operator over 3D screens", SAM report 2016-09, ETH Zürich.
"""
from __future__ import annotations

from contextlib import contextmanager

import numpy as np
import scipy.fft as sfft

from ..errors import ConvergenceError
from . import passes
from .convolution import SlabConvolution, dense
from .kernel import mirrored_kernel, punch_kernel
from .near_field import gathered_centres
from .set_blocks import held_for_set

#: the share of κ the edge correction removes, and its cap in units of C⁻¹'s diagonal. On the fixed
#: solved set of the large-grid scene at 512² / 1024² / 2048² (benchmarks/bench_deflation.py, PCG
#: iterations to 1e-8, cap 0.5): none 16 / 21 / 29; share 0.5 14 / 17 / 24; 0.7 13 / 15 / 21;
#: 0.8 12 / 15 / 20; 0.9 15 / 16 / 24 (the smallest Ritz value falls to 0.26). Without the cap
#: isolated nodes lose the share of their scaling (0.7: 17 / 23 at 1024² / 2048²); a share of 1
#: leaves them none (32 at 512²)
EDGE_SHARE = 0.8
EDGE_CAP = 0.5
#: the half-width (nodes) of the window of A = C⁻¹ through which tracked edge weights follow small
#: changes of the set (:class:`EdgeWeights`): beyond it |A_ij| is at most 1.2e-5 of A_ii (512² and
#: 2048²). At 4096² a radius of 8 (|A_ij| up to 8e-5 beyond) took 43 fine iterations, 16 took 42,
#: a product at every change 41; the 28 updates of 33 × 33 windows took 0.81 s, 36 products 3.5 s
EDGE_RADIUS = 16
#: the zeros between a bounded grid and its periodic images in C (nodes each way, rounded up to fast
#: FFT lengths). On the grid's own period C joined its opposite edges: near full contact (Δ = 2.5,
#: 1 E*) fixed-set PCG at 512² / 1024² took 26 / 30 iterations, 18 / 23 with 16 (8 to 512 gave 18-19
#: at 512²). Whole solves took the same fine iterations with 4, 16 or 48. EDGE_RADIUS: the tracked
#: windows never wrap onto the grid
PERIOD_MARGIN = EDGE_RADIUS
#: tracked weights are made again by a product when more than one node in this many changed at once
EDGE_UPDATES = 1000
#: ... or after this many updates through windows, so that what the windows leave out cannot pile up
EDGE_REFRESH = 8
#: changed nodes whose windows are added at once (bounds the index arrays of one update)
WINDOW_CHUNK = 1024


def embedding_period(shape: tuple[int, int]) -> tuple[int, int]:
    """C's period for a bounded grid of ``shape``: fast FFT lengths at least PERIOD_MARGIN longer
    than the grid (at most 2n − 1), so that C does not join the grid's opposite edges."""
    nx, ny = shape
    return (min(sfft.next_fast_len(nx + PERIOD_MARGIN), max(2 * nx - 1, 1)),
            min(sfft.next_fast_len(ny + PERIOD_MARGIN, real=True), max(2 * ny - 1, 1)))


class FourierPreconditioner:
    """z = R_S C⁻¹ R_Sᵀ g on the layout of a :class:`~.flexibility.Flexibility`."""

    def __init__(self, flexibility, period: tuple[int, int] | None = None):
        self.layout = flexibility.layout
        self.comm = flexibility.comm
        shape = flexibility.shape
        # C's period (given: a benchmark's comparison); by default the grid's own for the periodic
        # operator, whose images are physical, and a longer one for a bounded grid
        if period is None:
            period = shape if flexibility.periodic else embedding_period(shape)
        self.convolution = SlabConvolution(shape, flexibility.comm, period=period,
                                           workers=flexibility.convolution.workers)
        # the half-space kernel for the periodic operator too (its own has a zero mean mode), by
        # |offset|, folded onto the period (nearest image)
        r0, r1 = self.convolution.rows
        self.convolution.set_folded_kernel(punch_kernel(shape, flexibility.spacing, flexibility.compliance,
                                                        rows=np.arange(r0, r1), workers=self.convolution.workers))
        smallest = flexibility.comm.allreduce(float(self.convolution.symbol.min()), op=_min())
        if not smallest > 0.0:
            raise ConvergenceError("PC_SYMBOL_NOT_POSITIVE",
                                   f"the wrapped kernel's symbol reaches {smallest:.3e} <= 0; the Fourier "
                                   "preconditioner is not positive definite on this grid: use -normal_pc_type none")
        self.convolution.set_symbol(1.0 / self.convolution.symbol)     # C⁻¹: a product applies it
        # C⁻¹'s diagonal A_ii, read off its column at node (0, 0), which the first rank's rows
        # hold, and its row sum a₀ over the whole period, the symbol at frequency (0, 0) (the
        # column comes back on the grid only, without the margin and the negative offsets); the
        # double buffers of this one product are not kept (mixed-precision solves never use them)
        first = self.convolution.rows[0] == 0
        column = self.convolution.apply_at(1.0, np.zeros(1 if first else 0, dtype=np.intp))
        self.convolution.release_buffers()
        c0, c1 = self.convolution.my_columns
        zero = c0 == 0 < c1
        self.inverse_diagonal, self.inverse_row_sum = (float(v) for v in flexibility.comm.allreduce(
            np.array([column[0, 0] if first else 0.0, self.convolution.symbol[0, 0] if zero else 0.0])))
        # A's window for tracked edge weights, and the most it leaves out per changed node
        self.window, self.tail = self._edge_window(column)

    def apply_nodes(self, values: np.ndarray, nodes: np.ndarray, single: bool = False,
                    edge: np.ndarray | None = None) -> np.ndarray:
        """R_S C⁻¹ R_Sᵀ on S given by this rank's node indices, less ``edge`` ∘ values when the
        edge correction's weights on S are given (:meth:`edge_weights`); ``values`` and the
        result on S; ``single``: in single precision (:mod:`.convolution`), the result still
        float64."""
        smoothed = self._restricted(values, nodes, single)
        if edge is not None:
            # on the transforms' threads: 3.2 against 4.7 ms for 3.6 M nodes
            workers = self.convolution.workers
            taken = passes.combine(np.multiply, edge, values, np.empty_like(smoothed), workers)
            passes.combine(np.subtract, smoothed, taken, smoothed, workers)
        return smoothed

    def edge_weights(self, nodes: np.ndarray, single: bool = False, share: float = EDGE_SHARE) -> np.ndarray:
        """The edge correction's weights on S, given by this rank's node indices (float64):
        e_i = share · min(max(κ_i, 0), EDGE_CAP · A_ii), κ_i = Σ_{j∉S} (−A_ij) = (A 1_S)_i − a₀,
        so that R_S C⁻¹ R_Sᵀ g − e ∘ g is the corrected preconditioner on S. One periodic product
        (in single precision with ``single``); collective."""
        return self.weights_from_sums(self._restricted(1.0, nodes, single), share)    # (A 1_S)_i on S

    def _edge_window(self, column: np.ndarray) -> tuple[np.ndarray | None, float]:
        """A's window over the signed offsets within EDGE_RADIUS, (2R + 1)², from this rank's rows
        of its column at node (0, 0) (every rank gets all of it), and the largest |A_ij| outside
        it; (None, inf) on a grid whose period the window would reach round."""
        reach = EDGE_RADIUS
        nx, ny = self.layout.shape
        lx, ly = self.convolution.lengths
        if min(nx, ny) < 2 * reach + 2:
            return None, np.inf
        r0, r1 = self.convolution.rows
        i = np.arange(r0, r1)
        near_i = np.minimum(i, lx - i) <= reach
        j = np.arange(ny)
        near_j = np.minimum(j, ly - j) <= reach
        outside = np.abs(column[~near_i]).max(initial=0.0)
        outside = max(outside, np.abs(column[near_i][:, ~near_j]).max(initial=0.0))
        mine = [(int(row), column[row - r0, :reach + 1]) for row in range(r0, min(r1, reach + 1))]
        quadrant = np.empty((reach + 1, reach + 1))
        for part in self.comm.allgather(mine):
            for row, values in part:
                quadrant[row] = values
        tail = float(self.comm.allreduce(outside, op=_max()))
        return mirrored_kernel(quadrant).astype(np.float32), tail

    def add_windows(self, field: np.ndarray, nodes: np.ndarray, signs: np.ndarray) -> None:
        """field += Σ sign · A's window around each of this rank's ``nodes`` (local indices), on
        this rank's slab rows, wrapped like C (on its period: what falls outside the grid is
        dropped); collective: every rank adds the windows of every rank's nodes that reach its
        rows."""
        nx, ny = self.layout.shape
        lx, ly = self.convolution.lengths
        r0, r1 = self.layout.rows
        every = np.concatenate(gathered_centres(self.comm, self.layout.rows, ny, self.layout.slab_positions(nodes),
                                                signs))
        reach = self.window.shape[0] // 2
        offsets = np.arange(-reach, reach + 1)
        # in chunks of nodes: the index arrays of one chunk are (chunk × (2R + 1)²) values, 9 MB
        # for 1024 nodes, where all of 16 k changed nodes at once would take 146 MB
        for start in range(0, every.shape[0], WINDOW_CHUNK):
            part = every[start:start + WINDOW_CHUNK]
            rows = (part[:, 0:1].astype(np.intp) + offsets) % lx               # (K, 2R + 1)
            columns = (part[:, 1:2].astype(np.intp) + offsets) % ly
            k, a = np.nonzero((rows >= r0) & (rows < r1))                       # window rows on this rank
            flat = ((rows[k, a] - r0) * ny)[:, None] + columns[k]
            values = part[k, 2:3].astype(np.float32) * self.window[a]
            if ly > ny:                                                         # columns past the grid
                inside = columns[k] < ny
                flat, values = flat[inside], values[inside]
            np.add.at(field.reshape(-1), flat.reshape(-1), values.reshape(-1))

    def weights_from_sums(self, sums: np.ndarray, share: float) -> np.ndarray:
        """e_i = share · min(max(κ_i, 0), EDGE_CAP · A_ii) from (A 1_S)_i on S, float64."""
        weights = np.subtract(sums, self.inverse_row_sum, out=held_for_set(np.size(sums)), dtype=float)
        np.clip(weights, 0.0, EDGE_CAP * self.inverse_diagonal, out=weights)
        weights *= share
        return weights

    @contextmanager
    def circulant(self):
        """Inside the block :meth:`apply_nodes` applies C itself, not its inverse: the periodic
        products the balancing coarse space takes in place of H Z (:mod:`.balancing`); the
        symbol is inverted once for all the products of the block."""
        with self.convolution.inverted():
            yield self

    def _restricted(self, values, nodes: np.ndarray, single: bool) -> np.ndarray:
        """[C⁻¹ (values on S, 0 elsewhere)]_S as float64, a new array (collective); the values are
        written at S's slab positions only (:meth:`~.convolution.SlabConvolution.restricted`)."""
        smoothed = self.convolution.restricted(values, self.layout.slab_positions(nodes), single)   # a copy
        return smoothed.astype(float, copy=False)


def _min():
    from mpi4py import MPI

    return MPI.MIN


def _max():
    from mpi4py import MPI

    return MPI.MAX


class EdgeWeights:
    """The edge correction's weights on a free set that changes from one call to the next.

    κ needs (A 1_S) at every node of S, one periodic product of the set's
    indicator (:meth:`FourierPreconditioner.edge_weights`). Late in a solve S
    changes by a few nodes per iteration, and A = C⁻¹ decays like 1/r³: the
    field A 1_S is kept for the whole grid and follows a change through the
    (2 EDGE_RADIUS + 1)² window of A around each node that entered (+) or left
    (−) the set, wrapped like C. What the windows leave out, A beyond
    EDGE_RADIUS nodes, is at most ``tail`` (the largest |A_ij| there) per
    changed node; the field is made again by the product when more than one
    node in EDGE_UPDATES changed at once or after EDGE_REFRESH updates.
    """

    def __init__(self, preconditioner: FourierPreconditioner, share: float = EDGE_SHARE):
        self.pc = preconditioner
        self.share = share
        self.sums: np.ndarray | None = None      # A 1_S on this rank's slab rows, float32
        self.members: np.ndarray | None = None   # S of those sums, a mask over this rank's nodes
        self.updates = 0                         # window updates since the last product
        self.products = 0                        # periodic products taken

    def weights(self, nodes: np.ndarray, members: np.ndarray, single: bool = False) -> np.ndarray:
        """The weights on S, given by this rank's node indices ``nodes`` and as a mask ``members``
        over this rank's nodes (the same set); collective."""
        pc = self.pc
        if pc.window is None:                    # a grid the window would wrap round: the product
            self.products += 1
            return pc.edge_weights(nodes, single, self.share)
        trackable = self.sums is not None and self.updates < EDGE_REFRESH
        if trackable:
            changed = np.flatnonzero(np.not_equal(members, self.members))
            total = int(pc.comm.allreduce(changed.size))
            trackable = total <= pc.layout.size // EDGE_UPDATES
        if trackable:
            if total:
                signs = np.where(members[changed], 1.0, -1.0)
                pc.add_windows(self.sums, changed, signs)
                self.members[changed] = members[changed]
                self.updates += 1
        else:
            # the product's own result (a fresh array, contiguous on the periodic grid) is kept
            if dense(nodes.size, members.size):
                # a dense set: its mask goes into the transform whole, where writing 1 at its
                # positions cost three passes over the slab (the product 0.53-0.71 of the time
                # near full contact at 1024² and 2048², 86 % of the nodes in the set)
                indicator = pc.convolution.apply(pc.layout.to_slab(members), single)
            else:
                indicator = pc.convolution.apply_at(1.0, pc.layout.slab_positions(nodes), single)
            self.sums = np.ascontiguousarray(indicator, dtype=np.float32)
            self.members = members.copy()
            self.updates = 0
            self.products += 1
        return pc.weights_from_sums(self.sums.reshape(-1)[pc.layout.slab_positions(nodes)], self.share)
