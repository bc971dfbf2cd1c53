"""Checks before the first solve: operator memory, oversubscription, the size of the results.

The dense operator of a task holds N² float64 entries over its group's
ranks (Eq. 10); an ensemble that cannot hold it is refused with the ways
out instead of a numpy ``MemoryError`` or an out-of-memory kill halfway
through. Every check here is collective over the run's communicator and
decides the same on every rank.
"""
from __future__ import annotations

import math
import os
from pathlib import Path

from ..errors import InputError

#: share of a rank's memory the operator may take; the rest holds the interpreter, PETSc's
#: vectors, the result fields and the task file being encoded
MEMORY_SHARE = 0.8

#: bytes per grid node and solve of the fields stored at each level, the same for a normal
#: solve (force, pressure, gap: float64; contact: int8) and a tangential state (traction,
#: slip, energy density: float64; zone: int8)
_FIELD_BYTES = {"none": 0, "contact": 1, "force": 8 + 1, "all": 3 * 8 + 1}


def available_memory(proc_cgroup: str = "/proc/self/cgroup", mount: str = "/sys/fs/cgroup") -> int:
    """Bytes this process can still get: MemAvailable, or its cgroup's remaining limit if lower.

    The cgroup is the process's own (``/proc/self/cgroup``: a Slurm job step's
    under ``--mem``), and every ancestor's limit counts: the least remaining
    (limit − usage) of them is the bound. cgroup v2 and v1's memory controller.
    """
    limits = []
    try:
        for line in Path("/proc/meminfo").read_text().splitlines():
            if line.startswith("MemAvailable:"):
                limits.append(int(line.split()[1]) * 1024)
    except OSError:
        pass
    for directory, (limit_name, usage_name) in _cgroup_dirs("memory", proc_cgroup, mount):
        try:
            limit = (directory / limit_name).read_text().strip()
            if limit != "max" and int(limit) < 2**60:
                limits.append(int(limit) - int((directory / usage_name).read_text()))
        except (OSError, ValueError):
            continue
    return min(limits) if limits else 2**62


#: the files of a controller's limit (and usage) in cgroup v2 and v1
_CGROUP_FILES = {"memory": (("memory.max", "memory.current"), ("memory.limit_in_bytes", "memory.usage_in_bytes")),
                 "cpu": (("cpu.max", None), ("cpu.cfs_quota_us", "cpu.cfs_period_us"))}


def _cgroup_dirs(controller: str, proc_cgroup: str = "/proc/self/cgroup", mount: str = "/sys/fs/cgroup"):
    """(directory, file names) of the process's own cgroup for ``controller`` and of each ancestor.

    From ``proc_cgroup``: ``0::/path`` (v2, under ``mount``) or
    ``N:memory:/path`` (v1, under ``mount/memory``). A path that is not
    there (a cgroup namespace shows "/") falls back to the mount's root.
    """
    v2, v1 = _CGROUP_FILES[controller]
    try:
        lines = Path(proc_cgroup).read_text().splitlines()
    except OSError:
        lines = []
    seen = set()
    for line in lines:
        hierarchy, controllers, path = (line.split(":", 2) + ["", ""])[:3]
        if hierarchy == "0" and controllers == "":
            root, files = Path(mount), v2
        elif controller in controllers.split(","):
            root, files = Path(mount) / controllers, v1
        else:
            continue
        here = root / path.strip().lstrip("/")
        if not here.is_dir():
            here = root
        while True:
            if here not in seen:
                seen.add(here)
                yield here, files
            if here == root or here.parent == here:
                break
            here = here.parent
    for root, files in ((Path(mount), v2), (Path(mount) / controller, v1)):   # no /proc/self/cgroup entry
        if root not in seen and root.is_dir():
            yield root, files


def task_size(task) -> tuple[int, int]:
    """(grid nodes, footprint nodes) of a task, at most, without building generated surfaces.

    Fields are stored on the whole grid; the footprint nodes are the unknowns
    of the normal problem. Exact for generated surfaces on a rectangle or a
    disc footprint (a mated shift only removes nodes); measured surfaces are read.
    """
    import numpy as np

    from ..checks import check_shape
    from ..surfaces import disc

    spec = task.surface
    if spec["generator"] == "file":
        topography = task.topography()
        return int(topography.heights.size), int(topography.footprint.sum())
    shape = (2 ** spec["levels"] + 1,) * 2 if spec["generator"] == "midpoint" else check_shape(spec["shape"])
    factor = spec.get("coarsening") or 1
    shape = tuple(-(-n // factor) for n in shape)
    grid = int(np.prod(shape))
    if spec.get("footprint_diameter") is None:
        return grid, grid
    try:
        return grid, int(disc(shape, float(spec.get("spacing", 1.0)) * factor, spec["footprint_diameter"]).sum())
    except InputError as exc:
        raise InputError("surface.footprint_diameter", str(exc).split(": ", 1)[1]) from None


def check_operator_memory(study, nodes: int, comm, k: int) -> None:
    """Refuse a study whose largest operator does not fit in the memory of a rank.

    Each rank of a node may hold its share of one operator
    (:func:`roughcontact.operators.operator_memory` over the ``k`` ranks of a
    task, the run's ranks per task); the node's available memory is divided
    among its ranks.
    """
    from mpi4py import MPI

    from ..normal.choice import auto_operator
    from ..operators import operator_memory
    from ..operators.memory import KINDS

    node = comm.Split_type(MPI.COMM_TYPE_SHARED)
    local = node.Get_size()
    node.Free()
    per_rank = comm.allreduce(available_memory() / local, op=MPI.MIN)
    kind = study.normal.operator
    if kind == "auto":                  # what auto picks (the periodic FFT needs what the FFT needs)
        kind = auto_operator(nodes, periodic=False)[0]
    need = operator_memory(kind, nodes, k)
    if need > MEMORY_SHARE * per_rank:
        others = [o for o in KINDS if o != kind]
        raise InputError("surface", (
            f"the {kind} operator of the largest task ({nodes} footprint nodes) needs {need / 2**30:.2f} GiB "
            f"per rank with ranks_per_task = {k}, more than {MEMORY_SHARE:.0%} of the "
            f"{per_rank / 2**30:.2f} GiB each of the {local} rank(s) on a node can have. Use more ranks per "
            f"task ([farm] ranks_per_task = {2 * k}, needing {operator_memory(kind, nodes, 2 * k) / 2**30:.2f} "
            f"GiB per rank), fewer ranks per node, a coarser grid (levels, spacing, coarsening)"
            + (f", or another operator (normal.operator = {' or '.join(repr(o) for o in others)})"
               if others else ", or a matrix-free operator when one is available")))


def oversubscription(comm) -> str | None:
    """A warning when a node runs more ranks than it has cores (collective)."""
    from mpi4py import MPI

    node = comm.Split_type(MPI.COMM_TYPE_SHARED)
    try:
        cpus = set().union(*node.allgather(sorted(os.sched_getaffinity(0))))
        local = node.Get_size()
    finally:
        node.Free()
    cores = min(len(cpus), _cgroup_cpus())
    if local > cores:
        return (f"{local} ranks share {cores} core(s) on a node: the run is oversubscribed and will be "
                f"much slower than with {cores} rank(s)")
    return None


def straddling_groups(nodes: list, size: int) -> list[int]:
    """The groups of ``size`` consecutive ranks (as :class:`~.executor.Groups` splits them) whose
    ranks lie on more than one node, ``nodes[r]`` naming rank r's node."""
    return [g for g in range(len(nodes) // size) if len(set(nodes[g * size:(g + 1) * size])) > 1]


def straddling(comm, size: int) -> str | None:
    """A warning when a group of ``size`` ranks spans nodes (collective): each product of its
    distributed operator then crosses the network. A rank's node is where MPI places it (the ranks
    that share memory with it, named by the lowest rank of ``comm`` among them)."""
    from mpi4py import MPI

    if size == 1:
        return None
    node = comm.Split_type(MPI.COMM_TYPE_SHARED)
    try:
        name = node.allreduce(comm.Get_rank(), op=MPI.MIN)
    finally:
        node.Free()
    spread = straddling_groups(comm.allgather(name), size)
    if not spread:
        return None
    shown = ", ".join(str(g) for g in spread[:8]) + (" …" if len(spread) > 8 else "")
    return (f"{len(spread)} group(s) of {size} ranks span nodes (group {shown}): their operator products cross "
            f"the network; place a multiple of {size} consecutive ranks on each node (e.g. srun --ntasks-per-node)")


def storage_estimate(study, grid_nodes: int) -> str:
    """What the results will weigh, said before the run (an upper bound before compression)."""
    tasks = math.prod(study.shape)
    loads = len(study.loads)
    per_task = loads * (20 * 8 + _FIELD_BYTES[study.fields] * grid_nodes)
    if study.tangential is not None:
        states = study.tangential.steps + 1
        per_task += loads * states * (25 * 8 + _FIELD_BYTES[study.fields] * grid_nodes)
    total = tasks * per_task
    return (f"fields {study.fields!r}: up to {_size(total)} for {tasks} task(s) × {loads} load(s) "
            f"on up to {grid_nodes} nodes, once in the task files and once in {study.name}.nc "
            f"(fields compressed)")


#: bytes rank 0 holds per task and load of a study's small variables (about 40 float64 curves
#: along the loads), per task (status, message, warnings, scalars), and per tangential state
_SMALL_PER_LOAD, _SMALL_PER_TASK, _SMALL_PER_STATE = 60 * 8, 4096, 30 * 8


def combine_memory(study, grid_nodes: int) -> int:
    """Bytes rank 0 holds to combine ``study``: the small variables of every task (placed as tasks
    finish), and one task's fields at a time (read from its file, then written: twice)."""
    tasks = math.prod(study.shape)
    loads = len(study.loads)
    states = study.tangential.steps + 1 if study.tangential is not None else 0
    small = tasks * (_SMALL_PER_TASK + loads * (_SMALL_PER_LOAD + states * _SMALL_PER_STATE))
    fields = 2 * loads * (1 + states) * grid_nodes * _FIELD_BYTES[study.fields]
    return small + fields


def check_combine_memory(study, grid_nodes: int) -> None:
    """Refuse, before the first solve, a study whose combined dataset rank 0 cannot hold."""
    need, have = combine_memory(study, grid_nodes), available_memory()
    if need > MEMORY_SHARE * have:
        raise InputError("axes", (
            f"combining the {math.prod(study.shape)} tasks of {study.name} needs about {_size(need)} on rank 0 "
            f"(each task's curves along {len(study.loads)} load(s); fields are streamed from the task files), "
            f"more than {MEMORY_SHARE:.0%} of the {_size(have)} it can have. Give rank 0 more memory (a node of "
            f"its own, a larger --mem), or split the study (fewer seeds or axis values per study, fewer loads)"))


def _size(nbytes: float) -> str:
    for unit in ("B", "kB", "MB", "GB", "TB"):
        if nbytes < 1000 or unit == "TB":
            return f"{nbytes:.0f} {unit}" if unit == "B" else f"{nbytes:.1f} {unit}"
        nbytes /= 1000


def _cgroup_cpus(proc_cgroup: str = "/proc/self/cgroup", mount: str = "/sys/fs/cgroup") -> float:
    """The fewest CPUs a quota of the process's own cgroup or an ancestor allows (inf: none)."""
    cpus = [math.inf]
    for directory, (quota_name, period_name) in _cgroup_dirs("cpu", proc_cgroup, mount):
        try:
            if period_name is None:                # v2: "quota period" or "max period"
                quota, period = (directory / quota_name).read_text().split()
            else:                                  # v1
                quota, period = ((directory / n).read_text().strip() for n in (quota_name, period_name))
            if quota != "max" and int(quota) > 0:
                cpus.append(max(1, math.floor(int(quota) / int(period))))
        except (OSError, ValueError):
            continue
    return min(cpus)
