"""The memory and CPU guards read the process's own cgroup, and every ancestor's limit counts.

A cgroup tree is written under a temporary directory as the kernel lays it
out (cgroup v2: one hierarchy; v1: one per controller), with the
``/proc/self/cgroup`` lines a Slurm job step shows; the expected bound is
the least remaining (limit − usage) along the path, computed by hand.
"""
from __future__ import annotations

import math

from roughcontact.farm.guards import _cgroup_cpus, available_memory

MiB = 2**20      # limits of a few MiB: below any machine's MemAvailable, so the cgroup decides


def write(root, path: str, **files) -> None:
    directory = root / path
    directory.mkdir(parents=True, exist_ok=True)
    for name, text in files.items():
        (directory / name.replace("_", ".", 1)).write_text(text)


def test_cgroup_v2_limit_of_the_job_step_not_of_the_mount_root(tmp_path):
    """Slurm's --mem sets memory.max on the job's cgroup, not at the mount root: the job's
    2 MiB (0.5 MiB used) bounds the step below it, whose own limit is 'max'."""
    mount = tmp_path / "cgroup"
    write(mount, "", memory_max="max", memory_current=str(50 * MiB))
    write(mount, "system.slice/slurmstepd.scope/job_7", memory_max=str(2 * MiB), memory_current=str(MiB // 2))
    write(mount, "system.slice/slurmstepd.scope/job_7/step_0", memory_max="max", memory_current=str(MiB // 4),
          cpu_max="200000 100000")
    proc = tmp_path / "cgroup.txt"
    proc.write_text("0::/system.slice/slurmstepd.scope/job_7/step_0\n")
    assert available_memory(str(proc), str(mount)) == 2 * MiB - MiB // 2
    assert _cgroup_cpus(str(proc), str(mount)) == 2


def test_cgroup_v1_memory_controller_and_a_namespace_that_shows_the_root(tmp_path):
    """v1: the memory controller's own hierarchy; the tightest of the step's and the job's
    remaining memory wins. A path absent from the mount (a cgroup namespace) falls back to its root."""
    mount = tmp_path / "cgroup"
    write(mount, "memory", memory_limit_in_bytes=str(2**63 - 4096), memory_usage_in_bytes=str(MiB))
    write(mount, "memory/slurm/uid_1/job_9", memory_limit_in_bytes=str(4 * MiB), memory_usage_in_bytes=str(MiB))
    write(mount, "memory/slurm/uid_1/job_9/step_0", memory_limit_in_bytes=str(3 * MiB + MiB // 2),
          memory_usage_in_bytes=str(MiB))
    proc = tmp_path / "cgroup.txt"
    proc.write_text("5:cpu,cpuacct:/slurm/uid_1/job_9/step_0\n4:memory:/slurm/uid_1/job_9/step_0\n0::/\n")
    assert available_memory(str(proc), str(mount)) == min(3 * MiB + MiB // 2 - MiB, 4 * MiB - MiB)
    proc.write_text("4:memory:/not/here\n")
    write(mount, "memory", memory_limit_in_bytes=str(3 * MiB), memory_usage_in_bytes=str(MiB))
    assert available_memory(str(proc), str(mount)) == 3 * MiB - MiB
    assert _cgroup_cpus(str(proc), str(mount)) == math.inf



def test_a_study_whose_combined_dataset_rank_0_cannot_hold_is_refused_before_any_solve():
    """Rank 0 keeps each task's curves along the loads (fields are streamed): 10⁵ tasks of
    10⁴ loads are at least 10⁵ × 10⁴ × 8 B = 8 GB for one float64 curve, and the study's ~40
    curves over 320 GB, beyond what any rank here can have; 10 tasks of 2 loads pass."""
    import pytest

    from roughcontact.errors import InputError
    from roughcontact.farm import load_study
    from roughcontact.farm.guards import check_combine_memory, combine_memory

    def study(seeds, loads):
        return load_study({"name": "big", "surface": {"generator": "midpoint", "levels": 3, "spacing": 1e-4,
                                                      "rms_height": 1e-5, "fractal_dimension": 2.3},
                           "axes": {"seeds": seeds}, "materials": {"body1": {"E": 20e9, "nu": 0.0}},
                           "normal": {"loads": [float(p) for p in range(1, loads + 1)]}})

    big = study(100_000, 10_000)
    assert combine_memory(big, 81) > 40 * 100_000 * 10_000 * 8
    with pytest.raises(InputError, match="combining the 100000 tasks of big needs about .* on rank 0") as info:
        check_combine_memory(big, 81)
    assert info.value.parameter == "axes"
    check_combine_memory(study(10, 2), 81)


def test_groups_that_span_nodes_are_found_from_the_placement_of_their_ranks(comm):
    """Groups are k consecutive ranks: with 4 ranks per node, k = 2 and k = 4 keep every group on
    a node, k = 8 spans two nodes by construction, and 3 ranks per node (6 ranks, k = 2) split the
    middle group; a cyclic placement splits every group. On this machine (one node) no group of
    the suite's communicator spans nodes, whatever k divides it."""
    from roughcontact.farm.guards import straddling, straddling_groups

    block = ["a"] * 4 + ["b"] * 4
    assert straddling_groups(block, 2) == [] and straddling_groups(block, 4) == []
    assert straddling_groups(block, 8) == [0]
    assert straddling_groups(["a"] * 3 + ["b"] * 3, 2) == [1]
    assert straddling_groups(["a", "b"] * 4, 2) == [0, 1, 2, 3]
    assert straddling(comm, comm.Get_size()) is None and straddling(comm, 1) is None
