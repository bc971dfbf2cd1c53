"""The transforms' large temporaries reused from the C heap instead of mapped afresh at every product.

glibc serves a block above 32 MiB (its largest dynamic mmap threshold) with a mapping of its
own, whose pages the kernel zeroes on first touch, and unmaps it when it is freed. A product
on 2048² nodes of one rank or more makes three such blocks every time it is taken — scipy's
transform of the rows, its inverse, and the float64 product on the nodes (128 MiB each at
4096²) — and each is zeroed again: about 9 ms per 128 MiB on this project's machines, 5.7 s of
a 55 s 4096² solve in the nodal copy alone (docs/solver-cost.md, "Large temporaries").

:func:`retain_large_blocks` raises glibc's mmap and trim thresholds to :data:`LARGEST`, so
such blocks come from the heap and their pages stay with the process for the next product.
:class:`~.convolution.SlabConvolution` calls it when a rank's transform makes blocks of that
size. The cost: memory freed by the process stays resident until it exits or
:func:`release_free_blocks` is called (the peak itself is not raised: the same blocks are
reused). Set ``ROUGHCONTACT_HEAP=system`` in the environment to leave the allocator as it
is. Elsewhere than glibc these functions do nothing.

:func:`hold_touched_pages` is for measurements: it keeps every freed page in the process and
can touch a given amount beforehand, so that a timed solve does not pay the first touch of its
memory, which on a virtual machine that reports freed pages to its host costs about 20 times
what it costs on pages the host still backs.
"""
from __future__ import annotations

import ctypes
import ctypes.util
import os
import platform

import numpy as np

#: mallopt's parameters (malloc.h)
M_TRIM_THRESHOLD, M_MMAP_THRESHOLD = -1, -3
#: glibc's largest dynamic mmap threshold on 64-bit systems: blocks above it are always mapped
MAPPED_FROM = 32 * 1024 * 1024
#: blocks up to this size come from the heap once retained (the largest a rank's transforms of a
#: 8192² grid make on one rank is 0.5 GiB), and free memory at the heap's top up to this size stays
LARGEST = 1 << 30
#: the environment variable that, set to "system", leaves the allocator's thresholds as they are
VARIABLE = "ROUGHCONTACT_HEAP"

_retained = False


def _libc():
    """The C library, where it is glibc; None elsewhere."""
    if platform.system() != "Linux" or platform.libc_ver()[0] != "glibc":
        return None
    try:
        return ctypes.CDLL(ctypes.util.find_library("c") or "libc.so.6")
    except OSError:
        return None


def retain_large_blocks() -> bool:
    """Serve blocks up to :data:`LARGEST` from the heap and keep freed ones for reuse (process-wide,
    once); True where the thresholds are set, False where glibc is absent or ``ROUGHCONTACT_HEAP``
    is ``system``."""
    global _retained
    if _retained:
        return True
    if os.environ.get(VARIABLE, "").strip().lower() == "system":
        return False
    libc = _libc()
    if libc is None:
        return False
    _retained = bool(libc.mallopt(M_MMAP_THRESHOLD, LARGEST) == 1 and libc.mallopt(M_TRIM_THRESHOLD, LARGEST) == 1)
    return _retained


def hold_touched_pages(nbytes: int = 0) -> bool:
    """Keep every freed page in the process (glibc's trim threshold set to never, process-wide),
    after touching and freeing ``nbytes`` of heap, so that the blocks made afterwards reuse pages
    the system has already backed; True where that was done (glibc, ``ROUGHCONTACT_HEAP`` not
    ``system``).

    For measurements on virtual machines whose balloon device reports freed guest pages to the
    host (virtio-balloon free page reporting): there the first touch of memory the guest freed
    more than a few seconds before is a fault on the host, about 2 s per GiB on this project's
    machines against 0.1 s per GiB for pages the host still backs, so a one-solve process pays
    it for its whole peak, and a transform whose freed blocks go back to the system pays it at
    every call (docs/solver-cost.md, "First touches on a virtual machine").
    """
    if not retain_large_blocks():
        return False
    _libc().mallopt(M_TRIM_THRESHOLD, -1)
    if nbytes > 0:
        block = LARGEST // 2
        blocks = [np.ones(min(block, nbytes - start) // 8) for start in range(0, nbytes, block)]
        del blocks
    return True


def release_free_blocks() -> None:
    """Give the heap's free pages back to the system (glibc's malloc_trim): what a retained heap
    holds beyond the blocks in use, e.g. before measuring a resident set."""
    libc = _libc()
    if libc is not None:
        libc.malloc_trim(ctypes.c_size_t(0))
