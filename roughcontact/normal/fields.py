"""A result's fields without N values on every rank: gathering them, or writing them per rank.

A solve with ``gather=False`` (:meth:`~.solver.NormalSolver.solve_load`)
leaves each rank its own grid rows of the force, contact set and gap — the
rows of the :class:`~roughcontact.operators.layout.NodeLayout`, the slab the
FFT operator transforms there — so that a grid too large to replicate on
every rank (docs/solvers.md sizes one) is solved and stored with memory that
divides over the ranks:

- :func:`write_result` writes one NetCDF file from rank 0, which receives
  one rank's rows at a time (its extra memory is the largest block, never
  N); the file is what :func:`~roughcontact.datasets.normal_sweep_dataset`
  of the gathered result holds, along ``step`` of length 1, so
  ``xarray.open_dataset`` and the analysis read it as any sweep;
- :func:`gather_result` makes the ordinary result (every field whole on
  every rank) where a small grid or a tangential solve needs it.

The file is written under a temporary name and renamed when complete; a
failure on rank 0 still drains every rank's rows (no rank waits for ever)
and raises the same ``OSError`` on every rank.
"""
from __future__ import annotations

import os
from dataclasses import replace
from pathlib import Path

import numpy as np

from ..errors import InputError
from ..surfaces.rows import gather_into
from .problem import NormalProblem
from .result import NormalResult


def _row_blocks(result: NormalResult, problem: NormalProblem) -> list[tuple[int, int]]:
    """Every rank's (start, stop) grid rows of ``result``, checked against ``problem``'s layout."""
    if not isinstance(result, NormalResult):
        raise InputError("result", f"must be a NormalResult, got {type(result).__name__}")
    nx, ny = problem.topography.shape
    rows = tuple(result.rows) if result.distributed else (0, nx)
    expected = tuple(problem.flexibility.layout.rows) if result.distributed else (0, nx)
    held = [f for f in (result.force, result.pressure, result.contact, result.gap) if f is not None]
    ok = rows == expected and all(f.shape == (rows[1] - rows[0], ny) for f in held)
    if not all(problem.comm.allgather(ok)):
        raise InputError("result", "its fields do not match the problem's grid and rows on every rank: "
                                   "it was solved on another problem or communicator")
    return problem.comm.allgather(rows)


def gather_result(result: NormalResult, problem: NormalProblem, root: int | None = None) -> NormalResult:
    """The result with every field whole on every rank (collective; ``result`` itself when it already
    is). With ``root``, whole on that rank only, and without fields (None) on the others. A field
    the result no longer holds (None, :func:`~roughcontact.datasets.keep_fields`) stays None."""
    blocks = _row_blocks(result, problem)
    if not result.distributed:
        return result
    shape = problem.topography.shape
    counts = [(stop - start) * shape[1] for start, stop in blocks]

    def whole(block):
        return None if block is None else gather_into(problem.comm, block, counts, shape, root)

    force = whole(result.force)
    spacing = problem.topography.spacing
    pressure = force / spacing**2 if force is not None and result.pressure is not None else None
    return replace(result, force=force, pressure=pressure, contact=whole(result.contact),
                   gap=whole(result.gap), rows=None)


def write_result(result: NormalResult, problem: NormalProblem, path: str | os.PathLike,
                 fields: str = "all", attrs: dict | None = None) -> Path:
    """Write ``result`` (whole or each rank's rows) to ``path`` as NetCDF from rank 0 (collective).

    ``fields`` as in :func:`~roughcontact.datasets.normal_sweep_dataset`
    (``"all"``: force, pressure, gap and contact set). Every rank returns the
    path or raises the same ``OSError``.
    """
    from ..datasets import FIELD_TABLE, stored_fields

    comm, rank = problem.comm, problem.comm.Get_rank()
    blocks = _row_blocks(result, problem)
    names = stored_fields(FIELD_TABLE, fields)
    path = Path(path)
    tmp = path.with_name(path.name + ".part")
    handle, error = None, None
    if rank == 0:
        try:
            handle = _open_file(result, problem, tmp, names, attrs)
        except Exception as exc:   # reported on every rank below; the rows are still drained
            error = f"{type(exc).__name__}: {exc}"
    ny = problem.topography.shape[1]
    for name in names:
        get, dtype = FIELD_TABLE[name][:2]
        if rank != 0:
            if blocks[rank][1] > blocks[rank][0] and result.distributed:
                comm.Send(np.ascontiguousarray(get(result), dtype=dtype), dest=0, tag=11)
            continue
        mine = np.ascontiguousarray(get(result), dtype=dtype)
        for source, (start, stop) in enumerate(blocks):
            if stop == start or (source > 0 and not result.distributed):
                continue
            block = mine if source == 0 else np.empty((stop - start, ny), dtype=dtype)
            if source > 0:
                comm.Recv(block, source=source, tag=11)
            if error is None:
                try:
                    handle.variables[name][0, start:stop, :] = block
                except Exception as exc:
                    error = f"{type(exc).__name__}: {exc}"
    if rank == 0:
        try:
            if handle is not None:
                handle.close()
            if error is None:
                os.replace(tmp, path)
            elif tmp.exists():
                tmp.unlink()
        except Exception as exc:
            error = error or f"{type(exc).__name__}: {exc}"
    error = comm.bcast(error, root=0)
    if error:
        raise OSError(f"could not write {path}: {error}")
    return path


def _open_file(result: NormalResult, problem: NormalProblem, tmp: Path, names: list[str], attrs):
    """Rank 0: the result's scalars and grid coordinates written through xarray, then the file open
    (h5netcdf) with its field variables laid out, empty, for the rows to fill."""
    import h5netcdf

    from ..datasets import FIELD_TABLE, grid_coords, normal_sweep_dataset
    from ..netcdf import netcdf_attrs

    spacing = problem.topography.spacing
    tmp.parent.mkdir(parents=True, exist_ok=True)
    ds = normal_sweep_dataset([result], spacing, dim="step", fields="none", attrs=attrs)
    ds = ds.assign_coords(grid_coords(problem.topography.shape, spacing))
    ds.attrs = netcdf_attrs(ds.attrs)
    ds.to_netcdf(tmp, engine="h5netcdf", invalid_netcdf=False)
    handle = h5netcdf.File(tmp, "a")
    try:
        for name in names:
            _, dtype, units, long_name, _ = FIELD_TABLE[name]
            fill = np.nan if np.issubdtype(dtype, np.floating) else None
            variable = handle.create_variable(name, ("step", "x", "y"), dtype=dtype, fillvalue=fill)
            variable.attrs["units"] = units
            variable.attrs["long_name"] = long_name
    except Exception:
        handle.close()
        raise
    return handle

