"""The study dataset: every task file placed on the study's dimensions.

Each variable of a task file gains the study dimensions in front of its own
(``seed``, ``fractal_dimension``, … then ``normal_load``, ``Q_over_fP``,
``x``, ``y``). What a task did not compute is NaN (−1 for the int8 contact
sets and zones): the loads after a failure, a tangential sweep not asked for
at a load. Integer scalars become float64 for that reason, except ``status``.
Fields are combined when all tasks share one grid; otherwise they stay in
the task files and the dataset says so (``fields_note``). A coordinate that
differs between tasks (Q when loads are pressures and the footprints
differ) gains the study dimensions too.
"""
from __future__ import annotations

import os
from pathlib import Path

import numpy as np
import xarray as xr

from ..errors import InputError
from .netcdf import read_groups
from .records import INT8_FILL, LOAD_COORDINATE, encode

# integer variables that keep their type (every task has them, or −1 marks a missing one)
_KEEP_DTYPE = {"status", "branch"}


class _Misfit(ValueError):
    """A variable of a task file that is larger than the study's dimensions allow."""


class _Group:
    """The arrays of one group of the study dataset, filled task by task."""

    def __init__(self, study_shape: tuple[int, ...], sizes: dict[str, int]):
        self.study_shape = study_shape
        self.sizes = sizes
        self.arrays: dict[str, tuple[tuple, np.ndarray, dict, bool]] = {}
        self.index_coords: dict[str, tuple] = {}
        self.grid: tuple | None = None
        self.grids_differ = False
        self.attrs: dict = {}

    def add(self, position: tuple[int, ...], variables: dict, attrs: dict) -> None:
        """Place one task's variables and attributes (:func:`~.netcdf.read_groups`) at ``position``."""
        self.attrs = self.attrs or attrs
        if "x" in variables:
            x = variables["x"].values
            grid = (x.size, variables["y"].values.size, float(x[1] - x[0]) if x.size > 1 else 0.0)
            self.grid = self.grid or grid
            self.grids_differ |= grid != self.grid
        for name, var in variables.items():
            if var.dims == (name,):
                if name in ("x", "y") or var.values.size == self.sizes.get(name, -1):
                    self.index_coords.setdefault(name, (var.dims, var.values, var.attrs))
                continue
            self._place(name, var, position)

    def _place(self, name, var, position):
        values = var.values
        if name not in self.arrays:
            shape = self.study_shape + tuple(self.sizes.get(d, n) for d, n in zip(var.dims, values.shape))
            if values.dtype.kind in "iub" and ("x" in var.dims or name in _KEEP_DTYPE):
                array = np.full(shape, INT8_FILL, dtype=values.dtype)
            elif values.dtype.kind in "USO":
                array = np.full(shape, "", dtype=object)
            else:
                array = np.full(shape, np.nan)
            self.arrays[name] = (var.dims, array, dict(var.attrs), var.is_coord)
        dims, array, _, _ = self.arrays[name]
        room = array.shape[len(position):]
        if values.ndim and any(n > m for n, m in zip(values.shape, room)):
            if "x" not in var.dims:
                raise _Misfit(f"{name} has {dict(zip(var.dims, values.shape))}, more than the study's "
                              f"{dict(zip(dims, room))}")
            self.grids_differ = True   # a field on a larger grid than the first: kept in the task files
            return
        array[position + tuple(slice(0, n) for n in values.shape)] = values

    def dataset(self, study_dims: tuple[str, ...], study_coords: dict) -> xr.Dataset:
        data, coords = {}, dict(study_coords)
        for name, var in self.index_coords.items():
            if not (self.grids_differ and name in ("x", "y")):
                coords[name] = var
        for name, (dims, array, attrs, is_coord) in self.arrays.items():
            if self.grids_differ and "x" in dims:
                continue
            common = _common_to_every_task(array, len(study_dims)) if is_coord and array.size else None
            if common is not None:
                coords[name] = (dims, common, attrs)
                continue
            if array.dtype == object:      # strings: the width of the longest
                array = array.astype(str)
            (coords if is_coord else data)[name] = (study_dims + dims, array, attrs)
        ds = xr.Dataset(data, coords=coords, attrs=self.attrs)
        if self.grids_differ:
            ds.attrs["fields_note"] = ("the tasks' grids differ: the fields are in the task files only "
                                       "(<name>.tasks/task-*.nc)")
        return ds


def combine(study, paths) -> dict[str, xr.Dataset]:
    """The study dataset by group, from the task files ``paths[task.index]`` of ``study``."""
    sizes = {study.load_dim: len(study.loads)}
    if study.tangential is not None:
        sizes.update(Q_over_fP=study.tangential.steps + 1, step=3 * (study.tangential.fretting_steps + 1))
    if study.fretting is not None:
        sizes.update(amplitude=len(study.fretting.amplitudes))
    groups: dict[str, _Group] = {}
    for task in study.tasks():
        for name, (variables, attrs) in read_groups(paths[task.index]).items():
            try:
                groups.setdefault(name, _Group(study.shape, sizes)).add(task.position, variables, attrs)
            except _Misfit as exc:
                raise InputError(str(paths[task.index]), f"group {name}: {exc}: not a file of this study's "
                                                         f"{task.name}; remove it to solve the task again") from None
    study_dims = tuple(d.name for d in study.dimensions)
    study_coords = {}
    for dim in study.dimensions:
        study_coords.update(dim.coords())
    loads = (study.load_dim, np.asarray(study.loads, dtype=float), LOAD_COORDINATE[study.load_dim])
    return {name: group.dataset(study_dims, study_coords).assign_coords({loads[0]: loads})
            for name, group in groups.items()}


def write_combined(groups: dict[str, xr.Dataset], path: str | os.PathLike) -> Path:
    """Write the study dataset to ``path`` through ``path.part`` and a rename."""
    path = Path(path)
    part = path.with_name(path.name + ".part")
    part.unlink(missing_ok=True)
    encode(groups, part)
    os.replace(part, path)
    return path


def _common_to_every_task(array: np.ndarray, study_ndim: int) -> np.ndarray | None:
    """The values every task agrees on (NaN where a task did not compute them), or None."""
    flat = array.reshape((-1,) + array.shape[study_ndim:])
    common = np.fmax.reduce(flat, axis=0)
    missing = np.isnan(flat) if flat.dtype.kind == "f" else flat == INT8_FILL
    agree = missing | (flat == common)
    return common if agree.all() else None
