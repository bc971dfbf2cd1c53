"""Memory an operator needs on each rank, estimated before it is built.

A study checks these figures against the machine before its first solve, so
a grid too large for an operator is refused with the alternatives instead of
ending in a numpy ``MemoryError`` or an out-of-memory kill.
"""
from __future__ import annotations

import math

from ..errors import InputError

#: operators whose memory is estimated here
KINDS = ("dense",)


def operator_memory(kind: str, nodes: int, ranks: int = 1) -> int:
    """Bytes of the operator on the busiest rank.

    Parameters
    ----------
    kind
        ``"dense"``: the explicit matrix H (Eq. 10), N² float64 entries with
        its rows split over the ranks, plus the C-ordered block of rows the
        assembly fills before handing it to PETSc (at most 256 rows).
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
    rows = math.ceil(nodes / ranks)
    return 8 * nodes * (rows + min(rows, 256))
