"""Memory a normal solve needs on each rank, estimated before anything is built.

A study checks these figures against the machine before its first solve, so
a grid too large for an operator is refused with the alternatives instead of
ending in a numpy ``MemoryError`` or an out-of-memory kill.

The estimate is the high-water resident set of a whole normal solve on the
busiest rank (problem, operator, solver, result), above what the process
held once the topography was made, as measured by
``benchmarks/bench_memory.py`` (each size and rank count in processes of its
own, the high-water mark reset after the surface), and of a study task's
sweep of warm-started loads, which climbs above one solve's (``--sweep``;
:data:`REPLICATED`):

- what every rank holds whatever the number of ranks — the result's fields
  in the default, gathered form (a :class:`~roughcontact.normal.result.NormalResult`
  whole on every rank: force, pressure, contact and gap, 25 B/node, made
  after the solver's vectors are freed) and the C allocator's retention of
  freed mid-sized arrays — at most
  :data:`REPLICATED` bytes per node; the operator itself keeps only its
  rank's rows of the Eq. 10 table and its nodes' coordinates, and a solve with
  ``gather=False`` only its rank's rows of the fields
  (:mod:`roughcontact.normal.fields`);
- the rest is split over the ranks: the FFT symbols of the operator and its
  preconditioner, the padded transform buffers in double and single
  precision, the solver's vectors and the coarse levels (whose transform
  buffers are freed once they have given the fine grid its start) — at most
  :data:`DISTRIBUTED` bytes per node in all, the most near full contact,
  where the CG's vectors on the free set are nearly N long;
- ``"dense"`` adds the explicit N × N matrix, 8 N²/ranks bytes, and the
  C-ordered rows its assembly fills (the same memory, handed to PETSc), and
  as much again for a contact-set block (PETSc's sub-matrix of its rows);
  where its products go through the matrix (a footprint that is a small part
  of its grid, :func:`~.flexibility.explicit_products_pay`) its rows in
  float32 as well, 4 N²/ranks, the two within EXPLICIT_BYTES on the busiest
  rank. A tangential sweep's corrective solves on the actual contact set
  (:mod:`roughcontact.tangential.contact_set`) hold such an operator beside
  the whole problem's: at most EXPLICIT_BYTES, as an explicit block would;
- explicit contact-set blocks H_SS (:func:`explicit_block_memory`), which
  the active set's Krylov solves and the free rotation's Hessian (a study's
  default) build where the contact set is small, and keep through the next
  solves: the block, at most 8 · EXPLICIT_RATIO · N bytes and
  EXPLICIT_BYTES on the rank holding most of S, the Eq. 10 table it reads
  (at most TABLE_BYTES; the periodic operator's whole period) and a chunk's
  temporaries — at most 304 MiB per rank (49 MiB at 257², 147 MiB at 513²).
  With the rotation free, a solve of the large-grid scene took 377 / 286 /
  269 B/node on one rank at 512² / 1024² / 2048² (``bench_memory
  --free-rotation``), where the estimate without the blocks gave 315.

Measured with the constrained CG (mixed precision, nested start, fields by rows), peak bytes
per node per rank on 1, 2, 4 ranks: 1024² 309, 168, 91; 2048² 298, 161, 85; 4096² 286, 150,
78 — a fit N (R + D/ranks) gives R = 10–21, D = 276–289 (docs/solvers.md); 8192² on 4 ranks
with the surface by rows, 74. With the transforms' blocks above 32 MiB kept on the heap
(:mod:`.heap`, from 2048² nodes per rank): 2048² 307, 152, 78; 4096² on one rank 298; and
the single-precision transform buffers inside the double ones: 2048² 283, 142, 74; 4096² 274;
and the CG's tracked edge weights (A 1_S in float32): 2048² 283, 148, 78; 4096² 282. Near full
contact (fractal dimension 2.5 at 1 E*, 86 % of the nodes in the free set; ``bench_memory
--scenes full``) the same solve took more: 1024² 382, 195, 114; 2048² 369, 201, 115; 4096² on
one rank 375; gathered, on 4 ranks, 123 and 112 — a fit gives R = 20–31, D = 338–360
(DISTRIBUTED was 285, fitted on the large-grid scene alone, which near full contact exceeded by
10–14 % on one rank). Since the CG lets each vector of the free set's size go once it has served
and the problem makes its nodes' indices when asked (docs/solvers.md, "Vectors let go once they
have served"): near full contact 1024² 280, 147, 84; 2048² 280, 144, 77; 4096² on one rank 282;
gathered, on 4 ranks, 97 and 94 (R = 9–18, D = 262–271); the large-grid scene 1024² 237, 132,
77; 2048² 238, 130, 68; 4096² 240; gathered, on 4 ranks, 90 and 84. Since the FFT symbols keep
half their rows, w is not held beside gap0, the coarse grids are held by rows and the coordinates
by rows and columns (docs/solvers.md, "The symbol by half its rows"): near full contact 1024²
246, 127, 73; 2048² 252, 123, 64; 4096² on one rank 236; the scene 1024² 201, 112, 66; 2048²
200, 108, 56; 4096² 200 (R = −0.5 to 22.1, D = 179–252); 8192² on 4 ranks with the surface by
rows (without the coordinates by rows and columns), 60. The constants
bound every one of
these from above. ``"fft-periodic"`` makes its whole
Ewald-summed table once at set-up (8 B/node, transient). Explicit blocks of
H_SS (small contact sets) read the whole Eq. 10 table only up to TABLE_BYTES and count in
:func:`explicit_block_memory`.
"""
from __future__ import annotations

import math

from ..errors import InputError
from .kernel import BLOCK_CHUNK

#: the operators built from a topography (one list for the package; numpy only, so it can be
#: read before PETSc starts)
KINDS = ("dense", "fft", "fft-periodic")
#: bytes per node held on every rank. A study's task is a sweep of warm-started loads, whose
#: resident peak climbs from load to load (the allocator keeps what the earlier solves freed) above
#: a single solve's: the ensemble task's 12 loads with the rotation free, to 94 % in contact, took
#: 340.0 / 216.0 / 142.1 B/node at 1025² on 1 / 2 / 4 ranks, gathered (``bench_memory --sweep``:
#: a fit R = 80, D = 262; 338.3 / 216.5 / 132.8 at 2049² in a scratch run; docs/solvers.md, "Load
#: sweeps"), where the constants were 50 and 265, fitted on single solves
REPLICATED = 85
#: bytes per node split over the ranks (above; a single solve near full contact took at most 252
#: B/node on one rank at 2048²); on one rank also the bound of a solve's own allocations with its
#: fields by rows (tests/test_normal_distributed.py)
DISTRIBUTED = 290

# Explicit blocks H_SS of small contact sets (the active set's Krylov solves, the free rotation's
# Hessian; operators/flexibility.py), which a solve may hold beside its vectors:
#: an explicit H_SS is used while |S|² ≤ EXPLICIT_RATIO · N (N the footprint's nodes): its product
#: then costs about what an FFT product and the preconditioner save in iterations (the active set's
#: load sweeps at 65² and 129² were fastest at |S|² ≤ 16 Lx Ly, the padded grid's points, about
#: 64 N on a whole grid, against 4 and 64 Lx Ly; an explicit block at every size took 2.5 times
#: longer at 129²) ...
EXPLICIT_RATIO = 64
#: ... and while the rank with the most of S holds at most EXPLICIT_BYTES of it. A free-rotation
#: solve at 1024² on a light load (3 810 contact nodes: 116 MB) took 13.4 s with the block explicit
#: and 17.8 s matrix-free, with 32 MiB
EXPLICIT_BYTES = 256 * 2**20
#: the blocks read Eq. 10 from its whole table (8 B per node of the grid, kept on every rank) while
#: the table takes at most this (grids up to 2048²), and evaluate it entry by entry on larger grids
#: (the same bits, four times the time), so that no rank holds an array of the grid's size for them
TABLE_BYTES = 32 * 2**20
#: the temporaries of a block's chunk of entries (kernel.BLOCK_CHUNK): offsets, distances, ratios
BLOCK_TEMPORARIES = 8


def explicit_block_memory(kind: str, nodes: int, ranks: int = 1) -> int:
    """Bytes a rank may hold for explicit contact-set blocks, besides the solve's vectors: the block
    (all of S may lie in one rank's rows), the table it reads and a chunk's temporaries; the
    dense operator's block is PETSc's sub-matrix of the rank's rows of H."""
    if kind == "dense":
        return 8 * nodes * math.ceil(nodes / ranks)
    block = min(EXPLICIT_BYTES, 8 * EXPLICIT_RATIO * nodes)
    table = 8 * nodes if kind == "fft-periodic" else min(8 * nodes, TABLE_BYTES)
    return block + table + BLOCK_TEMPORARIES * 8 * min(BLOCK_CHUNK, EXPLICIT_RATIO * nodes)


def operator_memory(kind: str, nodes: int, ranks: int = 1) -> int:
    """Peak bytes of a normal solve with operator ``kind`` on the busiest rank.

    Parameters
    ----------
    kind
        ``"dense"``, ``"fft"`` or ``"fft-periodic"``.
    nodes
        N, the number of footprint nodes (unknowns).
    ranks
        Ranks the operator is distributed over.
    """
    if kind not in KINDS:
        raise InputError("operator", f"must be one of {', '.join(KINDS)}, got {kind!r}")
    if isinstance(nodes, bool) or int(nodes) != nodes or nodes < 1:
        raise InputError("nodes", f"must be a positive integer, got {nodes!r}")
    if isinstance(ranks, bool) or int(ranks) != ranks or ranks < 1:
        raise InputError("ranks", f"must be a positive integer, got {ranks!r}")
    nodes, ranks = int(nodes), int(ranks)
    solve = nodes * (REPLICATED + DISTRIBUTED / ranks)
    if kind == "dense":
        solve += 8 * nodes * math.ceil(nodes / ranks)
    return int(solve) + explicit_block_memory(kind, nodes, ranks)
