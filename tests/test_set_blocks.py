"""Set-sized blocks (roughcontact/operators/set_blocks.py): sizes on a geometric ladder, so that the
blocks of sets of nearby sizes repeat their size, and the set's node indices exactly numpy's.

The ladder is arithmetic on integers and powers of two, so its checks are exact: every capacity
holds its count, exceeds it by less than one step (2^(1/4)), and counts between two rungs share
one capacity. The indices must equal numpy.flatnonzero bit for bit, at chunk boundaries too. The
blocks held while their set is take a mapping of their own from MAPPED_FROM bytes, whose pages
must leave the process when the block goes (the kernel's resident set, in whole MiB).
"""
from __future__ import annotations

import json
import mmap
import os
import platform
import subprocess
import sys

import numpy as np
import pytest

from roughcontact.operators import set_blocks
from roughcontact.operators.set_blocks import capacity, held_for_set, indices_of, set_sized

STEP = 2.0 ** (1.0 / set_blocks.STEPS)


@pytest.mark.parametrize("count", [0, 1, 2, 3, 7, 100, 1000, 65_537, 1_048_576, 3_000_001])
def test_a_capacity_holds_its_count_within_one_step(count):
    held = capacity(count)
    assert held >= max(count, 1)
    # one step of the ladder at most, and one more value for the rounding up of 2^(k/4)
    assert held <= max(STEP * count + 1, 1)


def test_no_capacity_falls_below_its_count():
    """Every count up to 2 M in steps of 7 (and each power of two's neighbours): the logarithm's
    rounding must never give a storage shorter than the block."""
    counts = list(range(1, 2_000_000, 7)) + [2 ** k + d for k in range(1, 31) for d in (-1, 0, 1)]
    assert all(capacity(c) >= c for c in counts)


def test_the_capacities_are_few_and_shared_by_nearby_counts():
    """Over 1 … 2^20 the capacities are the ladder's rungs: 4 per doubling, 81 in all; a set
    that grows by 1 % keeps its block's size for about 17 moves between rungs."""
    counts = np.arange(1, (1 << 20) + 1, 97)
    held = np.array([capacity(int(c)) for c in counts])
    assert np.all(np.diff(held) >= 0)
    assert len(np.unique(held)) <= set_blocks.STEPS * 20 + 1
    sizes, count = [], 10_000
    for _ in range(200):
        sizes.append(capacity(count))
        count = int(count * 1.01)
    assert len(set(sizes)) <= int(np.ceil(np.log(1.01 ** 200) / np.log(STEP))) + 1


@pytest.mark.parametrize("rows", [1, 2])
def test_a_set_sized_block_is_contiguous_of_its_count_on_the_ladders_storage(rows):
    block = set_sized(1000, np.float32, rows=rows)
    assert block.shape == ((1000,) if rows == 1 else (rows, 1000))
    assert block.dtype == np.float32 and block.flags.c_contiguous
    assert block.base.size == rows * capacity(1000)
    assert set_sized(0).shape == (0,)


@pytest.mark.parametrize("share", [0.0, 0.02, 0.5, 0.93, 1.0])
def test_the_indices_are_numpys_across_chunks(share, monkeypatch):
    monkeypatch.setattr(set_blocks, "CHUNK", 64)
    for size in (0, 1, 63, 64, 65, 1000):
        mask = np.random.default_rng(size).random(size) < share
        found = indices_of(mask)
        assert found.dtype == np.intp
        np.testing.assert_array_equal(found, np.flatnonzero(mask))


@pytest.mark.parametrize("rows", [1, 2])
def test_a_held_block_is_contiguous_writable_and_mapped_from_its_threshold(rows):
    """Below MAPPED_FROM bytes a held block is a ladder's block; from it, one of its own mapping,
    exactly the block's bytes (the mapping rounds them up to pages, numpy's view does not)."""
    small = held_for_set(set_blocks.MAPPED_FROM // 16 // rows, np.float64, rows=rows)
    assert not isinstance(small.base, mmap.mmap) and small.base.size == rows * capacity(small.shape[-1])
    count = set_blocks.MAPPED_FROM // 8 // rows + 3
    block = held_for_set(count, np.float64, rows=rows)
    assert block.shape == ((count,) if rows == 1 else (rows, count))
    assert block.flags.c_contiguous and block.flags.writeable
    storage = block if rows == 1 else block.base
    assert isinstance(storage.base.obj, mmap.mmap) and storage.nbytes == rows * count * 8
    block[...] = np.arange(rows * count, dtype=float).reshape(block.shape)
    assert block.reshape(-1)[-1] == rows * count - 1


RESIDENT_PROBE = """
import json, sys
import numpy as np
from roughcontact.operators import heap, set_blocks

def resident():
    with open("/proc/self/status") as status:
        return next(int(line.split()[1]) for line in status if line.startswith("VmRSS")) * 1024

retained = heap.retain_large_blocks()
made = getattr(set_blocks, sys.argv[1])
before = resident()
block = made(8 << 20, np.float64)
block.fill(1.0)
touched = resident()
del block
print(json.dumps({"retained": retained, "rise": touched - before, "fall": touched - resident()}))
"""


@pytest.mark.skipif(platform.system() != "Linux" or platform.libc_ver()[0] != "glibc",
                    reason="the resident set is read from Linux's /proc, the heap's thresholds are glibc's")
@pytest.mark.parametrize("made", ["held_for_set", "set_sized"])
def test_a_held_blocks_memory_goes_back_to_the_system_when_it_goes(made):
    """The point of the mapping: when the set moves, its block's pages leave the process at once
    (munmap), where a heap block stays resident as free memory for the heap to place. With the
    heap's thresholds as a large grid's transforms set them (:func:`~roughcontact.operators.heap.
    retain_large_blocks`; in a process of its own, as they are process-wide), 64 MiB touched must
    raise the resident set by at least 60 MiB; deleting a held block must lower it as much, a
    set_sized block (the heap's) by less than 4 MiB (the process makes nothing else meanwhile;
    4 MiB allows for the interpreter's own pages)."""
    env = dict(os.environ)
    env.pop("ROUGHCONTACT_HEAP", None)
    out = subprocess.run([sys.executable, "-c", RESIDENT_PROBE, made], env=env, capture_output=True, text=True,
                         timeout=120, check=True)
    found = json.loads(out.stdout.strip().splitlines()[-1])
    assert found["retained"] and found["rise"] >= 60 << 20
    if made == "held_for_set":
        assert found["fall"] >= 60 << 20
    else:
        assert found["fall"] < 4 << 20
