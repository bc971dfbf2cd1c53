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
import math
from typing import NamedTuple

import h5py
import numpy as np
import xarray as xr

from .. import __version__
from ..netcdf import netcdf_attrs

#: the name netCDF-C gives the scale of a dimension without a coordinate variable
_PLACEHOLDER = "This is a netCDF dimension but not a netCDF variable.%10d"


def write_groups(groups: dict[str, xr.Dataset], target=None, encoding=None, deferred=None, fill=None):
    """Write ``groups`` ("/" first) as one NetCDF-4 file at ``target`` (a path), or return its bytes.

    ``encoding(ds)`` gives per-variable HDF5 options (``compression``,
    ``compression_opts``, ``shuffle``, ``chunks``) of a group's dataset.
    ``deferred`` lays out variables without holding their values,
    ``{group: {name: Deferred}}``: each is created empty (its fill value
    where nothing is written) and ``fill(file)`` writes into them, the file
    still open, before it is closed.
    """
    buffer = io.BytesIO() if target is None else None
    deferred = deferred or {}
    with h5py.File(buffer if target is None else target, "w", track_order=True) as f:
        f.attrs["_NCProperties"] = np.bytes_(f"version=2,roughcontact={__version__},hdf5={h5py.version.hdf5_version}")
        ids = iter(range(1 << 30))
        for name, ds in groups.items():
            group = f if name == "/" else f.create_group(name, track_order=True)
            _write_group(group, ds, ids, encoding(ds) if encoding else {}, deferred.get(name, {}))
        if fill is not None:
            fill(f)
    return buffer.getvalue() if target is None else target


class Deferred(NamedTuple):
    """A variable laid out in a file before its values are written (:func:`write_groups`)."""

    dims: tuple[str, ...]
    shape: tuple[int, ...]
    dtype: np.dtype
    attrs: dict
    fillvalue: float
    options: dict                  # HDF5 options: chunks, compression


def _write_group(group: h5py.Group, ds: xr.Dataset, ids, encoding: dict, deferred: dict) -> None:
    for key, value in netcdf_attrs(ds.attrs).items():
        group.attrs[key] = value
    sizes = dict(ds.sizes)
    for var in deferred.values():
        sizes.update((d, n) for d, n in zip(var.dims, var.shape) if d not in sizes)
    dim_ids, scales = {}, {}
    for dim, size in sizes.items():
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
    auxiliary = _auxiliary(ds)

    def attach(dataset, name, dims, is_coord):
        for axis, dim in enumerate(dims):
            dataset.dims[axis].attach_scale(scales[dim])
        if dims:
            dataset.attrs["_Netcdf4Coordinates"] = np.array([dim_ids[d] for d in dims], dtype=np.int32)
        listed = _listed(auxiliary, name, dims)
        if listed and not is_coord:
            dataset.attrs["coordinates"] = " ".join(listed)

    for name, var in ds.variables.items():
        if name not in ds.dims:
            attach(_dataset(group, name, var, encoding.get(name, {})), name, var.dims, name in ds.coords)
    for name, var in deferred.items():
        dataset = group.create_dataset(name, shape=var.shape, dtype=var.dtype, fillvalue=var.fillvalue,
                                       **(var.options if math.prod(var.shape) else {}))
        for key, value in netcdf_attrs(var.attrs).items():
            dataset.attrs[key] = value
        attach(dataset, name, var.dims, False)


def _auxiliary(ds: xr.Dataset) -> dict[str, set]:
    """The auxiliary coordinates of ``ds`` (not dimensions) and the dimensions each spans."""
    return {n: set(ds[n].dims) for n in ds.coords if n not in ds.dims}


def _listed(auxiliary: dict[str, set], name: str, dims) -> list[str]:
    """The auxiliary coordinates a variable ``name`` on ``dims`` lists in its CF ``coordinates``."""
    return [c for c, used in auxiliary.items() if c != name and used <= set(dims)]


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
    values: np.ndarray          # or Unread: a field left on disk
    attrs: dict
    is_coord: bool


class Unread(NamedTuple):
    """The shape and type of a field :func:`read_groups` left on disk (``fields=False``)."""

    shape: tuple[int, ...]
    dtype: np.dtype


def is_field(dims: tuple[str, ...]) -> bool:
    """Whether a variable on ``dims`` is a field on the grid (… , x, y)."""
    return tuple(dims[-2:]) == ("x", "y")


def read_groups(source, fields: bool = True) -> dict[str, tuple[dict[str, Stored], dict]]:
    """The groups of a file from :func:`write_groups` (a path, or the file's bytes):
    ``{group: ({name: Stored}, attrs)}``, strings as ``str``, netCDF's and HDF5's own attributes
    left out (four times faster than through xarray: rank 0 reads every task file at the end
    of a study). Without ``fields``, a field's values are an :class:`Unread` (read them with
    :func:`read_fields`): what a task's file holds besides its fields is small."""
    out = {}
    with h5py.File(io.BytesIO(source) if isinstance(source, bytes) else source, "r") as f:
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
                if not fields and is_field(dims):
                    values = Unread(dataset.shape, np.dtype(np.int8 if dataset.dtype == bool else dataset.dtype))
                else:
                    values = _values(dataset)
                keep = {k: _text(dataset.attrs[k]) for k in keys
                        if not k.startswith("_") and k not in _HDF5_ATTRS}
                variables[key] = Stored(dims, values, keep, dims == (key,))
            variables = {k: v._replace(is_coord=v.is_coord or k in listed) for k, v in variables.items()}
            out[name] = (variables, {k: _text(v) for k, v in group.attrs.items() if not k.startswith("_")})
    return out


def held_groups(groups: dict[str, xr.Dataset]) -> dict[str, tuple[dict[str, Stored], dict]]:
    """What :func:`read_groups` reads without fields from the file :func:`write_groups` writes of
    ``groups``, taken from ``groups`` in memory: a leader hands rank 0 its task's small variables
    this way (reading its own file back cost ~30 ms a task, more than writing it). The same
    conversions as the file's round trip: attributes as NetCDF stores them, booleans as int8,
    strings as ``str``, a field as :class:`Unread`; a dimension without a coordinate is left out
    and auxiliary coordinates are those some other variable lists (CF ``coordinates``)."""
    out = {}
    for name, ds in groups.items():
        auxiliary = _auxiliary(ds)
        listed = {c for key, var in ds.variables.items() if key not in ds.coords
                  for c in _listed(auxiliary, key, var.dims)}
        variables = {}
        order = [d for d in ds.sizes if d in ds.variables and ds[d].dims == (d,)]
        order += [k for k in ds.variables if k not in ds.dims]
        for key in order:
            var = ds.variables[key]
            if is_field(var.dims):
                values = Unread(var.shape, np.dtype(np.int8 if var.dtype == bool else var.dtype))
            elif var.dtype.kind in "USO":
                values = np.asarray(var.values, dtype=object)
                values = np.vectorize(str, otypes=[object])(values) if values.size else values
            else:
                values = var.values.astype(np.int8) if var.dtype == bool else np.asarray(var.values)
            attrs = {k: v for k, v in netcdf_attrs(var.attrs).items() if not k.startswith("_") and k not in _HDF5_ATTRS}
            variables[key] = Stored(var.dims, values, attrs, var.dims == (key,) or key in listed)
        out[name] = (variables, {k: v for k, v in netcdf_attrs(ds.attrs).items() if not k.startswith("_")})
    return out


def read_fields(path, names: dict | None = None) -> dict[str, dict[str, np.ndarray]]:
    """The fields (variables on …, x, y) of a file from :func:`write_groups`, by group; with
    ``names`` (``{group: [field, …]}``) only those, found by name (a fifth of the time of looking
    at every variable of a task file)."""
    out = {}
    with h5py.File(path, "r") as f:
        if names is not None:
            for name, keys in names.items():
                group = f if name == "/" else f.get(name)
                for key in keys if group is not None else ():
                    if key in group:
                        out.setdefault(name, {})[key] = _values(group[key])
            return out
        for name, group in [("/", f), *((k, v) for k, v in f.items() if isinstance(v, h5py.Group))]:
            for key, dataset in group.items():
                if isinstance(dataset, h5py.Dataset) and dataset.ndim >= 2 and \
                        is_field(tuple(d[0].name.rsplit("/", 1)[-1] for d in dataset.dims if len(d))):
                    out.setdefault(name, {})[key] = _values(dataset)
    return out


def _values(dataset: h5py.Dataset) -> np.ndarray:
    values = dataset[()]
    if dataset.dtype.kind == "O":
        values = np.vectorize(_text, otypes=[object])(np.asarray(values, dtype=object))
    return np.asarray(values)


_HDF5_ATTRS = {"CLASS", "NAME", "REFERENCE_LIST", "DIMENSION_LIST", "coordinates"}


def _text(value):
    return value.decode() if isinstance(value, bytes) else value
