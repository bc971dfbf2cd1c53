"""The transforms' large temporaries reused from the heap (roughcontact.operators.heap).

Each case runs in a process of its own: the allocator's thresholds are process-wide and would
otherwise carry over into the rest of the suite. What is measured is the kernel's count of
minor page faults (getrusage) while a 256 MiB block is made, touched and freed: a freshly
mapped block faults on every page (or huge page) it touches, a block reused from the heap on
none. The counts are exact integers of the process, not timings.
"""
import json
import os
import platform
import subprocess
import sys

import numpy as np
import pytest

from roughcontact.operators.convolution import padded_lengths
from roughcontact.operators.heap import MAPPED_FROM

pytestmark = pytest.mark.skipif(platform.system() != "Linux" or platform.libc_ver()[0] != "glibc",
                                reason="the thresholds are glibc's")

PROBE = """
import json, resource, sys
import numpy as np
from roughcontact.operators import heap

def faults():
    before = resource.getrusage(resource.RUSAGE_SELF).ru_minflt
    block = np.ones(1 << 25)       # 256 MiB, above glibc's largest dynamic mmap threshold
    del block
    return resource.getrusage(resource.RUSAGE_SELF).ru_minflt - before

if sys.argv[1] == "retain":
    retained = heap.retain_large_blocks()
elif sys.argv[1] == "hold":
    retained = heap.hold_touched_pages(int(sys.argv[2]))
elif sys.argv[1] == "transform":
    from mpi4py import MPI
    from roughcontact.operators.convolution import SlabConvolution
    SlabConvolution(tuple(int(v) for v in sys.argv[2:4]), MPI.COMM_SELF)
    retained = heap._retained
else:
    retained = False
first = faults()
print(json.dumps({"retained": retained, "faults": [first, faults(), faults()]}))
"""


def _probe(*args, heap_variable=None):
    env = dict(os.environ)
    env.pop("ROUGHCONTACT_HEAP", None)
    if heap_variable is not None:
        env["ROUGHCONTACT_HEAP"] = heap_variable
    out = subprocess.run([sys.executable, "-c", PROBE, *args], env=env, capture_output=True, text=True,
                         timeout=120, check=True)
    return json.loads(out.stdout.strip().splitlines()[-1])


def test_a_plain_process_maps_every_large_block_afresh():
    # the control: without retention every 256 MiB block faults again, so the probe sees faults
    probe = _probe("plain")
    first, second, third = probe["faults"]
    assert first >= 100
    assert second >= first // 2 and third >= first // 2


def test_retained_blocks_are_reused_without_faults():
    probe = _probe("retain")
    first, second, third = probe["faults"]
    if not probe["retained"]:
        pytest.skip("this glibc refuses an mmap threshold above 32 MiB (older releases cap it there)")
    assert first >= 100                  # the first block is new memory either way
    assert second <= first // 10 and third <= first // 10


def test_the_environment_leaves_the_allocator_alone():
    probe = _probe("retain", heap_variable="system")
    first, second, _ = probe["faults"]
    assert probe["retained"] is False
    assert second >= first // 2


def test_held_pages_serve_the_next_blocks_without_faults(comm):
    if comm.Get_size() > 1:
        pytest.skip("a process of its own per rank would only repeat the serial pass")
    # 1 GiB touched and freed beforehand (two 512 MiB blocks, more than the trim threshold that
    # retain_large_blocks alone sets): even the first 256 MiB block after it reuses those pages
    held = _probe("hold", str(1 << 30))
    if not held["retained"]:
        pytest.skip("this glibc refuses an mmap threshold above 32 MiB (older releases cap it there)")
    plain = _probe("plain")
    assert plain["faults"][0] >= 100
    assert max(held["faults"]) <= plain["faults"][0] // 10


def test_holding_pages_respects_the_environment():
    assert _probe("hold", str(1 << 28), heap_variable="system")["retained"] is False


@pytest.mark.parametrize("shape, retained", [((64, 64), False), ((2048, 2048), True)])
def test_a_transform_retains_from_blocks_glibc_would_map(shape, retained, comm):
    if comm.Get_size() > 1:
        pytest.skip("starts MPI in a process of its own; run by the serial pass")
    # a 2048² rank's double-precision spectra of its rows, 2048 × 2049 complex128, pass 32 MiB;
    # a 64² grid's transforms stay far below and leave the allocator as it is
    assert (_spectra_bytes(shape) > MAPPED_FROM) is retained
    if retained and not _probe("retain")["retained"]:
        pytest.skip("this glibc refuses an mmap threshold above 32 MiB (older releases cap it there)")
    probe = _probe("transform", *map(str, shape))
    assert probe["retained"] is retained


def _spectra_bytes(shape):
    ly = padded_lengths(shape, False)[1]
    return shape[0] * (ly // 2 + 1) * np.dtype(np.complex128).itemsize
