"""What the analysis reads: normal results, or datasets of them, with fields on (…, x, y).

Every measure accepts a :class:`~roughcontact.normal.NormalResult`, a
sequence of them (a load sweep), or an :class:`xarray.Dataset` whose fields
``force`` and ``contact`` lie on (…, x, y) with any leading dimensions
(``seed``, ``fractal_dimension``, ``shift``, the load dimension). Scalars are
read by the names ``normal_load``, ``closure`` and ``contact_fraction``; the
load dimension is configurable (default ``normal_load``). Datasets that still
call the load ``load`` along a ``step`` dimension are renamed on the way in
(:func:`standard_names`).
"""
from __future__ import annotations

from collections.abc import Sequence

import numpy as np
import xarray as xr

from ..checks import require_finite_positive
from ..errors import InputError
from ..normal.result import NormalResult

#: dimensions of a field on the grid (axis 0 is x)
GRID = ("x", "y")
#: default name of the load dimension and variable
LOAD = "normal_load"


def result_spacing(result: NormalResult) -> float:
    """Grid spacing s of a result: A_0 = (footprint nodes) s², the footprint being where the gap is finite."""
    nodes = int(np.isfinite(result.gap).sum())
    if nodes == 0:
        raise InputError("result", "has no footprint node (the gap is NaN everywhere)")
    return float(np.sqrt(result.nominal_area / nodes))


def as_dataset(source, load_dim: str = LOAD) -> xr.Dataset:
    """A dataset with ``force``, ``contact`` on (…, x, y) and the load as ``load_dim``.

    Parameters
    ----------
    source
        A :class:`NormalResult`, a non-empty sequence of them (stacked along
        ``load_dim`` with their loads as its coordinate), or a dataset.
    load_dim
        Name of the load dimension and variable.
    """
    from ..datasets import normal_sweep_dataset

    if isinstance(source, xr.Dataset):
        return standard_names(source, load_dim)
    if isinstance(source, NormalResult):
        source.require_whole("source")
        ds = normal_sweep_dataset([source], result_spacing(source), dim="step")
        return standard_names(ds, load_dim).isel({load_dim: 0})
    if isinstance(source, Sequence) and source and all(isinstance(r, NormalResult) for r in source):
        for result in source:
            result.require_whole("source")
        return standard_names(normal_sweep_dataset(list(source), result_spacing(source[0]), dim="step"),
                              load_dim)
    raise InputError("source", "must be a NormalResult, a non-empty sequence of them or an xarray Dataset, "
                               f"got {type(source).__name__}")


def standard_names(ds: xr.Dataset, load_dim: str = LOAD) -> xr.Dataset:
    """Rename a sweep's ``load`` to ``normal_load`` and make the load its dimension.

    A variable ``load`` (the older name) becomes ``normal_load``; when
    ``load_dim`` is not a dimension but ``normal_load`` is a 1-D variable
    along some dimension (``step``), that dimension is swapped for it.
    """
    if LOAD not in ds.variables and "load" in ds.data_vars:
        ds = ds.rename({"load": LOAD})
    if load_dim not in ds.dims and load_dim in ds.variables and ds[load_dim].ndim == 1:
        ds = ds.swap_dims({ds[load_dim].dims[0]: load_dim})
    return ds


def grid_spacing(obj: xr.Dataset | xr.DataArray) -> float:
    """The spacing s (m): the ``spacing`` attribute, else the step of the ``x`` coordinate."""
    if "spacing" in obj.attrs:
        return require_finite_positive("spacing", obj.attrs["spacing"])
    if "x" in obj.coords and obj["x"].size >= 2:
        return require_finite_positive("spacing", float(obj["x"][1] - obj["x"][0]))
    raise InputError("spacing", "the dataset has neither a 'spacing' attribute nor an x coordinate to read it from")


def sample_spacing(ds: xr.Dataset) -> float | xr.DataArray:
    """The spacing s (m) of the fields: the ``spacing`` attribute, else the tasks' recorded
    ``grid_spacing`` (one number when every task has the same; each task's along the study's
    dimensions where a study combines grids of different spacings), else the step of ``x``."""
    if "spacing" not in ds.attrs and "grid_spacing" in ds.data_vars:
        spacing = ds["grid_spacing"]
        values = np.unique(spacing.values[np.isfinite(spacing.values)])
        if values.size == 1:
            return require_finite_positive("spacing", float(values[0]))
        if values.size > 1:
            return spacing
    return grid_spacing(ds)


def task_region(ds: xr.Dataset) -> xr.DataArray:
    """The nodes of each task's own grid on (…, x, y): where ``contact`` is 0 or 1 (a study marks nodes
    outside a task's grid, and loads it did not compute, with −1), else where ``force`` is finite."""
    if "contact" in ds.variables:
        return field(ds, "contact") >= 0
    return np.isfinite(field(ds, "force"))


def field(ds: xr.Dataset, name: str) -> xr.DataArray:
    """The variable ``name`` on (…, x, y), x and y last."""
    if name not in ds.variables:
        raise InputError(name, f"the dataset has no variable {name!r} (it has {', '.join(sorted(ds.data_vars))})")
    array = ds[name]
    if not set(GRID) <= set(array.dims):
        raise InputError(name, f"must lie on the grid dimensions (…, x, y), got {array.dims}")
    return array.transpose(..., *GRID)


def contact_set(ds: xr.Dataset) -> xr.DataArray:
    """The contact set S on (…, x, y) as booleans: nodes where ``contact`` is 1.

    Combined study files mark what a task did not compute with −1 (int8
    fields) or NaN; such nodes are not in contact.
    """
    return field(ds, "contact") == 1


def series(ds: xr.Dataset, name: str, dim: str) -> xr.DataArray:
    """The variable ``name`` with ``dim`` last (a curve along ``dim`` per sample of the other dims).

    Points that are NaN (loads a task did not compute) are left out by the
    fits that read a series (:func:`~.fitting.finite_points`).
    """
    if name not in ds.variables:
        raise InputError(name, f"the dataset has no variable {name!r}")
    array = ds[name]
    if dim not in array.dims:
        raise InputError(dim, f"{name!r} does not vary along {dim!r} (its dims are {array.dims})")
    return array.transpose(..., dim)
