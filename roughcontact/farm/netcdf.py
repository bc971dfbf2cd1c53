"""A lean NetCDF-4 writer for task and study files: h5py with netCDF-4's HDF5 conventions.

Why not the package's one xarray path (:mod:`roughcontact.netcdf`): measured
by ``python -m benchmarks.bench_task_file`` (medians of 20 writes, one
rank), a default-study task file (65², 12 loads, 32 variables, 0.53 MB)
takes 26 ms here and 110 ms through ``to_netcdf(engine="h5netcdf")``, a
task with tangential and fretting groups (75 variables) 58 ms against
295 ms: 4.3–5.1 times, nearly all of it xarray's Python per variable, which
is more than solving a small grid; both files read back equal through
xarray. This writer does the same HDF5 calls directly — each dimension a
dimension scale (the coordinate of that name, or a placeholder named as
netCDF-C names its own), every variable attached to its scales with
``_Netcdf4Coordinates``, dimension ids ``_Netcdf4Dimid`` unique in the
file, groups as HDF5 groups, links in creation order — so xarray, h5netcdf
and netCDF-C read the result as NetCDF-4. It writes what the farm stores
(numbers, int8 fields, strings, CF attributes) and nothing more; non-index
coordinates are listed in each variable's ``coordinates`` attribute (CF).
"""
from __future__ import annotations

import io
from typing import NamedTuple

import h5py
import numpy as np
import xarray as xr

from .. import __version__
from ..netcdf import netcdf_attrs

#: the name netCDF-C gives the scale of a dimension without a coordinate variable
_PLACEHOLDER = "This is a netCDF dimension but not a netCDF variable.%10d"


def write_groups(groups: dict[str, xr.Dataset], target=None, encoding=None):
    """Write ``groups`` ("/" first) as one NetCDF-4 file at ``target`` (a path), or return its bytes.

    ``encoding(ds)`` gives per-variable HDF5 options (``compression``,
    ``compression_opts``, ``shuffle``, ``chunks``) of a group's dataset.
    """
    buffer = io.BytesIO() if target is None else None
    with h5py.File(buffer if target is None else target, "w", track_order=True) as f:
        f.attrs["_NCProperties"] = np.bytes_(f"version=2,roughcontact={__version__},hdf5={h5py.version.hdf5_version}")
        ids = iter(range(1 << 30))
        for name, ds in groups.items():
            group = f if name == "/" else f.create_group(name, track_order=True)
            _write_group(group, ds, ids, encoding(ds) if encoding else {})
    return buffer.getvalue() if target is None else target


def _write_group(group: h5py.Group, ds: xr.Dataset, ids, encoding: dict) -> None:
    for key, value in netcdf_attrs(ds.attrs).items():
        group.attrs[key] = value
    dim_ids, scales = {}, {}
    for dim, size in ds.sizes.items():
        dim_ids[dim] = next(ids)
        if dim in ds.variables and ds[dim].dims == (dim,):
            scale = _dataset(group, dim, ds[dim].variable, {})
            scale.make_scale(dim)
            scale.attrs["_Netcdf4Coordinates"] = np.array([dim_ids[dim]], dtype=np.int32)
        else:
            scale = group.create_dataset(dim, shape=(size,), dtype=np.float32)
            scale.make_scale(_PLACEHOLDER % size)
        scale.attrs["_Netcdf4Dimid"] = np.int32(dim_ids[dim])
        scales[dim] = scale
    auxiliary = [n for n in ds.coords if n not in ds.dims]
    for name, var in ds.variables.items():
        if name in ds.dims:
            continue
        dataset = _dataset(group, name, var, encoding.get(name, {}))
        for axis, dim in enumerate(var.dims):
            dataset.dims[axis].attach_scale(scales[dim])
        if var.dims:
            dataset.attrs["_Netcdf4Coordinates"] = np.array([dim_ids[d] for d in var.dims], dtype=np.int32)
        listed = [c for c in auxiliary if c != name and set(ds[c].dims) <= set(var.dims)]
        if listed and name not in ds.coords:
            dataset.attrs["coordinates"] = " ".join(listed)


def _dataset(group: h5py.Group, name: str, var: xr.Variable, options: dict) -> h5py.Dataset:
    values = var.values
    if values.dtype.kind in "USO":
        values = np.asarray(values, dtype=object)
        dataset = group.create_dataset(name, data=values, dtype=h5py.string_dtype("utf-8"))
    else:
        if values.dtype == bool:
            values = values.astype(np.int8)
        dataset = group.create_dataset(name, data=values, **(options if values.size else {}))
    for key, value in netcdf_attrs(var.attrs).items():
        dataset.attrs[key] = value
    return dataset


class Stored(NamedTuple):
    """A variable as :func:`read_groups` reads it."""

    dims: tuple[str, ...]
    values: np.ndarray
    attrs: dict
    is_coord: bool


def read_groups(path) -> dict[str, tuple[dict[str, Stored], dict]]:
    """The groups of a file from :func:`write_groups`: ``{group: ({name: Stored}, attrs)}``,
    strings as ``str``, netCDF's and HDF5's own attributes left out (four times faster than
    through xarray: rank 0 reads every task file at the end of a study)."""
    out = {}
    with h5py.File(path, "r") as f:
        for name, group in [("/", f), *((k, v) for k, v in f.items() if isinstance(v, h5py.Group))]:
            variables, listed = {}, set()
            for key, dataset in group.items():
                if isinstance(dataset, h5py.Group):
                    continue
                keys = set(dataset.attrs.keys())
                scale = "CLASS" in keys and dataset.is_scale
                if scale and _text(dataset.attrs["NAME"]).startswith(_PLACEHOLDER[:20]):
                    continue                       # a dimension without a coordinate variable
                if "coordinates" in keys:
                    listed.update(_text(dataset.attrs["coordinates"]).split())
                if scale:
                    dims = (key,)                  # a coordinate variable is its dimension's scale
                else:
                    dims = tuple(d[0].name.rsplit("/", 1)[-1] for d in dataset.dims)
                values = dataset[()]
                if dataset.dtype.kind == "O":
                    values = np.vectorize(_text, otypes=[object])(np.asarray(values, dtype=object))
                keep = {k: _text(dataset.attrs[k]) for k in keys
                        if not k.startswith("_") and k not in _HDF5_ATTRS}
                variables[key] = Stored(dims, np.asarray(values), keep, dims == (key,))
            variables = {k: v._replace(is_coord=v.is_coord or k in listed) for k, v in variables.items()}
            out[name] = (variables, {k: _text(v) for k, v in group.attrs.items() if not k.startswith("_")})
    return out


_HDF5_ATTRS = {"CLASS", "NAME", "REFERENCE_LIST", "DIMENSION_LIST", "coordinates"}


def _text(value):
    return value.decode() if isinstance(value, bytes) else value
