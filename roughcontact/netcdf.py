"""Writing xarray datasets as NetCDF-4: the package's one path through xarray and h5netcdf.

:func:`write_netcdf` writes from rank 0 of the given communicator, to a
temporary name first and renamed when complete, so a failure never leaves a
truncated file under the final name; every rank returns the path or raises
the same error. :func:`netcdf_attrs` turns attributes into what NetCDF can
store. The farm's task files use a leaner writer of the same format
(:mod:`roughcontact.farm.netcdf`, for a measured reason given there).
"""
from __future__ import annotations

import os
from pathlib import Path

import numpy as np
import xarray as xr


def netcdf_attrs(attrs: dict, prefix: str = "") -> dict:
    """Attributes NetCDF can store: nested dicts flattened with ``_``, booleans
    as 0/1, None as the string "none", anything else unsupported as its repr."""
    out = {}
    for key, value in attrs.items():
        name = f"{prefix}{key}"
        if isinstance(value, dict):
            out.update(netcdf_attrs(value, prefix=f"{name}_"))
        elif isinstance(value, (bool, np.bool_)):
            out[name] = int(value)
        elif value is None:
            out[name] = "none"
        elif isinstance(value, (str, int, float, np.number)):
            out[name] = value
        elif isinstance(value, (list, tuple, np.ndarray)) and all(
                isinstance(v, (int, float, np.number)) and not isinstance(v, bool) for v in np.ravel(value)):
            out[name] = np.asarray(value)
        else:
            out[name] = repr(value)
    return out


def write_netcdf(ds: xr.Dataset, path: str | os.PathLike, comm=None) -> Path:
    """Write ``ds`` to ``path`` from rank 0 (atomically); all ranks return the path."""
    path = Path(path)
    rank = 0 if comm is None else comm.Get_rank()
    error = None
    if rank == 0:
        try:
            path.parent.mkdir(parents=True, exist_ok=True)
            tmp = path.with_name(path.name + ".part")
            clean = ds.copy()
            clean.attrs = netcdf_attrs(ds.attrs)
            clean.to_netcdf(tmp, engine="h5netcdf", invalid_netcdf=False)
            os.replace(tmp, path)
        except Exception as exc:   # reported on every rank below, never swallowed
            error = f"{type(exc).__name__}: {exc}"
    if comm is not None:
        error = comm.bcast(error, root=0)
    if error:
        raise OSError(f"could not write {path}: {error}")
    return path
