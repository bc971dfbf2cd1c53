"""Blocks sized by a contact or free set, made in sizes that repeat from one set to the next.

A solve makes, at every move of its set, arrays as long as the set: the gathers onto it
(:func:`.passes.gather`: the gap g, the directions), the primal–dual steps' node indices and
C_S's coordinates (Eq. 8; :func:`roughcontact.normal.problem.node_indices`,
``NormalProblem.arms_at``), the extension's copy of the set and the edge weights. Made at the
set's exact size, each is often a little longer than the block its predecessor freed, so the heap
cannot place it there: the freed blocks stay resident beside the new ones. On two ranks that free
memory was a quarter of a study's load-sweep peak (46 of 186 B/node at 1025², against 30 of 301
on one rank; docs/solvers.md, "Load sweeps"). :func:`set_sized` makes such a block in the next
size of a geometric ladder (steps of 2^(1/4)), so that sets of nearby sizes take blocks of one
size and each reuses the last one's place; only the set's share of the block is written, and the
rest costs address space, not memory, where the block is new. The blocks kept while their set is
(:func:`held_for_set`: the set's indices and C_S's coordinates, the extension's copy and offsets,
the edge weights, the hole charge) take, from :data:`MAPPED_FROM` bytes, a mapping of their own.
"""
from __future__ import annotations

import mmap

import numpy as np

#: the ladder's steps per doubling of a block's size
STEPS = 4
#: the mask's nodes searched at a time by :func:`indices_of` (its temporaries' length)
CHUNK = 1 << 16
#: :func:`held_for_set` blocks of at least this many bytes have a mapping of their own
MAPPED_FROM = 1 << 20


def capacity(count: int) -> int:
    """The ladder's size for ``count`` values: the least 2^(k / STEPS) ≥ count, rounded up (never
    below ``count``, whatever the rounding of the logarithm); 1 for none."""
    if count <= 1:
        return 1
    return max(count, int(np.ceil(2.0 ** (np.ceil(np.log2(count) * STEPS) / STEPS))))


def set_sized(count: int, dtype=float, rows: int = 1) -> np.ndarray:
    """An uninitialised contiguous (``count``,) block, or (``rows``, ``count``), in a storage of
    ``rows`` × :func:`capacity` values (module docstring)."""
    storage = np.empty(rows * capacity(count), dtype=dtype)[:rows * count]
    return storage if rows == 1 else storage.reshape(rows, count)


def indices_of(mask: np.ndarray) -> np.ndarray:
    """numpy.flatnonzero(mask) of a 1-D ``mask`` into a :func:`held_for_set` block, searched in
    chunks of CHUNK nodes."""
    out = held_for_set(int(np.count_nonzero(mask)), np.intp)
    done = 0
    for start in range(0, mask.size, CHUNK):
        part = np.flatnonzero(mask[start:start + CHUNK])
        np.add(part, start, out=out[done:done + part.size])
        done += part.size
    return out


def held_for_set(count: int, dtype=float, rows: int = 1) -> np.ndarray:
    """A :func:`set_sized` block that is kept while its set is (the set's indices, C_S's arms, the
    extension's copy and offsets, the edge weights, the hole charge), on a mapping of its own where
    it takes at least :data:`MAPPED_FROM` bytes.

    Such a block outlives the iterations' temporaries, which the heap places around it; at the
    set's move it is freed among them, and its successor, of another size, may not fit there. On
    four ranks a study's load sweep had about 20 B/node of the grid free in the heap at the end of
    each load, in blocks of about a rank's rows (glibc's ``malloc_info``). A mapping of its own is
    given back to the system when the block goes (munmap) and leaves no hole in the heap; its
    pages are touched anew, once per set, as transparent huge pages where the system offers them:
    along the ensemble task's 1025² sweep on one rank, 314 of 535 held blocks were mapped, 1.6 GB
    in all, and the sweep's time did not change (docs/solvers.md, "Load sweeps"). Where the mmap
    module has no private mappings (Windows) the block is a :func:`set_sized` one."""
    dtype = np.dtype(dtype)
    nbytes = rows * count * dtype.itemsize
    if nbytes < MAPPED_FROM or not hasattr(mmap, "MAP_PRIVATE"):
        return set_sized(count, dtype, rows)
    mapping = mmap.mmap(-1, nbytes, flags=mmap.MAP_PRIVATE)
    if hasattr(mmap, "MADV_HUGEPAGE"):
        # a fault per 2 MiB, not per 4 KiB: 30 MB touched anew took 3.4–3.8 ms against 20.5–21.5
        # (2.1 for a block the heap reused); a kernel without huge pages refuses (EINVAL), and
        # the block is then on 4 KiB pages
        try:
            mapping.madvise(mmap.MADV_HUGEPAGE)
        except OSError:
            pass
    storage = np.frombuffer(mapping, dtype=dtype, count=rows * count)
    return storage if rows == 1 else storage.reshape(rows, count)
