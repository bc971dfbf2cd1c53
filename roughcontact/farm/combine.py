"""The study dataset: every task file placed on the study's dimensions.

Each variable of a task file gains the study dimensions in front of its own
(``seed``, ``fractal_dimension``, … then ``normal_load``, ``Q_over_fP``,
``x``, ``y``). What a task did not compute is NaN (−1 for the int8 contact
sets and zones): the loads after a failure, a tangential sweep not asked for
at a load. Integer scalars become float64 for that reason, except ``status``.
A coordinate that differs between tasks (Q when loads are pressures and the
footprints differ) gains the study dimensions too.

Fields on different grids (:class:`Frame`): tasks whose grids share one
spacing but not their extent (mated shifts crop each composite to its own
lens, Figs. 7–8) are placed in one frame, the surface's before cropping
(each task records the position of its first node, ``origin_x`` and
``origin_y``), on the union of their grids, with x and y in metres; tasks
on different spacings (resolution studies, Figs. 1, 5b) are placed at node
(0, 0) of a grid as large as the largest, x and y then being node indices
without coordinates (each task's spacing is its ``grid_spacing``). Either
way a node outside a task's grid is NaN (−1 for int8 fields) and
``fields_note`` says how the grids were put together.
"""
from __future__ import annotations

import os
from pathlib import Path
from typing import Callable, NamedTuple

import h5py
import numpy as np
import xarray as xr

from ..datasets import grid_coords
from ..errors import InputError
from .netcdf import read_groups
from .records import INT8_FILL, LOAD_COORDINATE, encode

# integer variables that keep their type (every task has them, or −1 marks a missing one)
_KEEP_DTYPE = {"status", "branch"}


class _Misfit(ValueError):
    """A variable of a task file that is larger than the study's dimensions allow."""


class Frame(NamedTuple):
    """Where each task's fields sit on the study's grid (see the module's docstring)."""

    shape: tuple[int, int]                   # nodes (nx, ny) of the study's grid
    offsets: dict                            # task position -> (i0, j0) of its first node
    coords: dict                             # x, y coordinates (m); empty when the spacings differ
    note: str                                # how the grids were put together, "" when they are one

    @classmethod
    def of(cls, grids: dict) -> "Frame":
        """The frame of ``grids``: task position -> (nx, ny, spacing, origin_x, origin_y)."""
        if not grids:
            return cls((0, 0), {}, {}, "")
        spacings = {g[2] for g in grids.values()}
        if len({g[:2] + g[3:] for g in grids.values()}) == 1:
            nx, ny, s = next(iter(grids.values()))[:3]
            return cls((nx, ny), {p: (0, 0) for p in grids}, grid_coords((nx, ny), s), "")
        if max(spacings) - min(spacings) <= 1e-9 * max(spacings):
            s = max(spacings)
            x0 = min(g[3] for g in grids.values())
            y0 = min(g[4] for g in grids.values())
            offsets = {p: (int(round((g[3] - x0) / s)), int(round((g[4] - y0) / s))) for p, g in grids.items()}
            shape = (max(o[0] + grids[p][0] for p, o in offsets.items()),
                     max(o[1] + grids[p][1] for p, o in offsets.items()))
            coords = {"x": ("x", x0 + np.arange(shape[0]) * s, {"units": "m", "long_name": "x (frame of the "
                                                                "surface before cropping)"}),
                      "y": ("y", y0 + np.arange(shape[1]) * s, {"units": "m", "long_name": "y (frame of the "
                                                                "surface before cropping)"})}
            note = ("the tasks' grids differ in extent: each task's fields sit at its origin in the frame of "
                    "the surface before cropping, NaN (-1 for int8 fields) outside its grid")
            return cls(shape, offsets, coords, note)
        shape = (max(g[0] for g in grids.values()), max(g[1] for g in grids.values()))
        note = ("the tasks' grids differ in spacing: each task's fields start at node (0, 0), x and y are node "
                "indices (x = i grid_spacing of the task), NaN (-1 for int8 fields) outside its grid")
        return cls(shape, {p: (0, 0) for p in grids}, {}, note)


def task_grid(path) -> tuple | None:
    """(nx, ny, spacing, origin_x, origin_y) of a task file's fields, or None if it stores none."""
    with h5py.File(path, "r") as f:
        if "x" not in f or "y" not in f:
            return None
        nx, ny = f["x"].shape[0], f["y"].shape[0]
        spacing = float(f["grid_spacing"][()])
        origin = tuple(float(f[name][()]) if name in f else 0.0 for name in ("origin_x", "origin_y"))
    return nx, ny, spacing, *origin


class _Group:
    """The arrays of one group of the study dataset, filled task by task."""

    def __init__(self, study_shape: tuple[int, ...], sizes: dict[str, int], frame: Frame):
        self.study_shape = study_shape
        self.sizes = {**sizes, "x": frame.shape[0], "y": frame.shape[1]}
        self.frame = frame
        self.arrays: dict[str, tuple[tuple, np.ndarray, dict, bool]] = {}
        self.index_coords: dict[str, tuple] = {}
        self.attrs: dict = {}

    def add(self, position: tuple[int, ...], variables: dict, attrs: dict) -> None:
        """Place one task's variables and attributes (:func:`~.netcdf.read_groups`) at ``position``."""
        self.attrs = self.attrs or attrs
        for name, var in variables.items():
            if var.dims == (name,):
                if name not in ("x", "y") and var.values.size == self.sizes.get(name, -1):
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
            raise _Misfit(f"{name} has {dict(zip(var.dims, values.shape))}, more than the study's "
                          f"{dict(zip(dims, room))}")
        offset = dict(zip(("x", "y"), self.frame.offsets.get(position, (0, 0))))
        array[position + tuple(slice(offset.get(d, 0), offset.get(d, 0) + n)
                               for d, n in zip(var.dims, values.shape))] = values

    def dataset(self, study_dims: tuple[str, ...], study_coords: dict) -> xr.Dataset:
        data, coords = {}, dict(study_coords)
        coords.update(self.index_coords)
        if any("x" in dims for dims, *_ in self.arrays.values()):
            coords.update(self.frame.coords)
        for name, (dims, array, attrs, is_coord) in self.arrays.items():
            common = _common_to_every_task(array, len(study_dims)) if is_coord and array.size else None
            if common is not None:
                coords[name] = (dims, common, attrs)
                continue
            if array.dtype == object:      # strings: the width of the longest
                array = array.astype(str)
            (coords if is_coord else data)[name] = (study_dims + dims, array, attrs)
        ds = xr.Dataset(data, coords=coords, attrs=self.attrs)
        if self.frame.note and any("x" in dims for dims, *_ in self.arrays.values()):
            ds.attrs["fields_note"] = self.frame.note
        return ds


def combine(study, paths, damaged: Callable | None = None) -> dict[str, xr.Dataset]:
    """The study dataset by group, from the task files ``paths[task.index]`` of ``study``.

    A file HDF5 cannot read is handed to ``damaged(task, path, why)`` and its
    task left out (NaN, status −1: no result); without ``damaged`` it is an
    :class:`InputError` naming the file.
    """
    sizes = {study.load_dim: len(study.loads)}
    if study.tangential is not None:
        sizes.update(Q_over_fP=study.tangential.steps + 1, step=3 * (study.tangential.fretting_steps + 1))
    if study.fretting is not None:
        sizes.update(amplitude=len(study.fretting.amplitudes))
    grids, lost = {}, set()

    def read(task, function):
        path = paths[task.index]
        try:
            return function(path)
        except (OSError, KeyError, ValueError, TypeError) as exc:
            if damaged is None:
                raise InputError(str(path), f"HDF5 cannot read this task file ({exc}); remove it to solve "
                                            f"{task.name} again") from None
            damaged(task, path, f"HDF5 cannot read it: {exc}")
            lost.add(task.index)
            return None

    for task in study.tasks():
        grids[task.position] = read(task, task_grid)
    frame = Frame.of({position: grid for position, grid in grids.items() if grid is not None})
    groups: dict[str, _Group] = {}
    for task in study.tasks():
        content = read(task, read_groups) if task.index not in lost else None
        for name, (variables, attrs) in (content or {}).items():
            try:
                groups.setdefault(name, _Group(study.shape, sizes, frame)).add(task.position, variables, attrs)
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
    """Write the study dataset to ``path`` through ``path.part`` and a rename (an OSError
    removes the ``.part`` file and is raised)."""
    path = Path(path)
    part = path.with_name(f"{path.name}.{os.getpid()}.part")       # two shards may finish at once
    try:
        encode(groups, part)
        os.replace(part, path)
    except OSError:
        part.unlink(missing_ok=True)          # no half-written combined file is left
        raise
    return path


def _common_to_every_task(array: np.ndarray, study_ndim: int) -> np.ndarray | None:
    """The values every task agrees on (NaN where a task did not compute them), or None."""
    flat = array.reshape((-1,) + array.shape[study_ndim:])
    common = np.fmax.reduce(flat, axis=0)
    missing = np.isnan(flat) if flat.dtype.kind == "f" else flat == INT8_FILL
    agree = missing | (flat == common)
    return common if agree.all() else None
