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

