"""Memory a normal solve needs on each rank, estimated before anything is built.

A study checks these figures against the machine before its first solve, so
a grid too large for an operator is refused with the alternatives instead of
ending in a numpy ``MemoryError`` or an out-of-memory kill.

The estimate is the high-water resident set of a whole normal solve on the
busiest rank (problem, operator, solver, result), above what the process
held before, as measured by ``benchmarks/bench_normal_large.py``:

- every kind holds some arrays of all N nodes on every rank: the Eq. 10
  table, node coordinates, the gathered result fields — about
  :data:`REPLICATED` bytes per node;
- the rest is split over the ranks: the FFT symbols of the operator and its
  preconditioner, the padded transform buffers, the solver's vectors and the
  coarse levels of a nested start — about :data:`DISTRIBUTED` bytes per node
  in all;
- ``"dense"`` adds the explicit N × N matrix, 8 N²/ranks bytes, and the
  C-ordered rows its assembly fills (the same memory, handed to PETSc).

Measured (1024², the constrained CG with its nested start): 370 B/node on
one rank, 240 B/node/rank on two; at 2048² on one rank, 304 B/node. The
mixed-precision CG (the default) adds the float32 and complex64 twins of the
padded buffers of the operator and its preconditioner: at 2048² on one rank
396 against 362 B/node in double, at 1024² 402 against 390 (peak above the
process after the surface was made).
"""
from __future__ import annotations

import math

from ..errors import InputError

#: the operators built from a topography (one list for the package; numpy only, so it can be
#: read before PETSc starts)
KINDS = ("dense", "fft", "fft-periodic")
#: bytes per node held on every rank
REPLICATED = 110
#: bytes per node split over the ranks
DISTRIBUTED = 310


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
    return int(solve)
