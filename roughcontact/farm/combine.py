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
import threading
from pathlib import Path
from typing import Callable, NamedTuple

import numpy as np
import xarray as xr

from ..datasets import grid_coords
from ..errors import InputError
from .netcdf import Deferred, Unread, read_fields, read_groups
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


class _Group:
    """One group of the study dataset: its small variables placed task by task in arrays of the
    study's shape, its fields only described (:class:`~.netcdf.Unread`: their values stay in the
    task files until written or loaded, placed in the :class:`Frame` known once every task is)."""

    def __init__(self, study_shape: tuple[int, ...], sizes: dict[str, int]):
        self.study_shape = study_shape
        self.sizes = sizes
        self.arrays: dict[str, tuple[tuple, np.ndarray, dict, bool]] = {}
        self.fields: dict[str, tuple[tuple, np.dtype, dict]] = {}
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
            if isinstance(var.values, Unread):
                self._check(name, var.dims, var.values.shape[:-2])
                if name not in self.fields:
                    whole = var.values.dtype.kind in "iub"
                    self.fields[name] = (var.dims, var.values.dtype if whole else np.dtype(np.float64),
                                         dict(var.attrs))
            else:
                self._place(name, var, position)

    def _check(self, name, dims, shape) -> tuple:
        """The room of a variable on ``dims`` (x and y excepted) in the study; :class:`_Misfit` if
        ``shape`` exceeds it."""
        room = tuple(self.sizes.get(d, n) for d, n in zip(dims, shape))
        if any(n > m for n, m in zip(shape, room)):
            raise _Misfit(f"{name} has {dict(zip(dims, shape))}, more than the study's {dict(zip(dims, room))}")
        return room

    def _place(self, name, var, position):
        values = var.values
        room = self._check(name, var.dims, values.shape)
        if name not in self.arrays:
            shape = self.study_shape + room
            if values.dtype.kind in "iub" and name in _KEEP_DTYPE:
                array = np.full(shape, INT8_FILL, dtype=values.dtype)
            elif values.dtype.kind in "USO":
                array = np.full(shape, "", dtype=object)
            else:
                array = np.full(shape, np.nan)
            self.arrays[name] = (var.dims, array, dict(var.attrs), var.is_coord)
        dims, array, _, _ = self.arrays[name]
        held = array.shape[len(position):]
        if values.ndim and any(n > m for n, m in zip(values.shape, held)):
            raise _Misfit(f"{name} has {dict(zip(var.dims, values.shape))}, more than the study's "
                          f"{dict(zip(dims, held))}")
        array[position + tuple(slice(0, n) for n in values.shape)] = values

    def deferred(self, study_dims: tuple, frame: Frame) -> dict[str, Deferred]:
        """The fields laid out on the study's dimensions and the frame's grid."""
        out = {}
        for name, (dims, dtype, attrs) in self.fields.items():
            room = tuple(self.sizes.get(d, 1) for d in dims[:-2]) + frame.shape
            out[name] = Deferred(study_dims + dims, self.study_shape + room, dtype, attrs,
                                 INT8_FILL if dtype.kind in "iub" else np.nan,
                                 {"chunks": (1,) * (len(self.study_shape) + len(dims) - 2) + frame.shape,
                                  "compression": "gzip", "compression_opts": 1, "shuffle": True})
        return out

    def dataset(self, study_dims: tuple[str, ...], study_coords: dict, frame: Frame) -> xr.Dataset:
        """The group's dataset without its fields."""
        data, coords = {}, dict(study_coords)
        coords.update(self.index_coords)
        if self.fields:
            coords.update(frame.coords)
        for name, (dims, array, attrs, is_coord) in self.arrays.items():
            common = _common_to_every_task(array, len(study_dims)) if is_coord and array.size else None
            if common is not None:
                coords[name] = (dims, common, attrs)
                continue
            if array.dtype == object:      # strings: the width of the longest
                array = array.astype(str)
            (coords if is_coord else data)[name] = (study_dims + dims, array, attrs)
        ds = xr.Dataset(data, coords=coords, attrs=self.attrs)
        if frame.note and self.fields:
            ds.attrs["fields_note"] = frame.note
        return ds


class Combiner:
    """The study dataset, built task by task as tasks finish (rank 0 of a run) or from their files.

    What it holds is the study's small variables (scalars and curves along
    the loads, a few hundred bytes per task and load), never a task file's
    fields: :meth:`result` lays them out and :class:`Combined` streams them
    from the task files.
    """

    def __init__(self, study):
        self.study = study
        sizes = {study.load_dim: len(study.loads)}
        if study.tangential is not None:
            sizes.update(Q_over_fP=study.tangential.steps + 1, step=3 * (study.tangential.fretting_steps + 1))
        if study.fretting is not None:
            sizes.update(amplitude=len(study.fretting.amplitudes))
        self.sizes = sizes
        self.parts: dict[str, _Group] = {}
        self.grids: dict[tuple, tuple] = {}
        self.fields_of: dict[tuple, Path] = {}
        self.added: set[int] = set()
        self._lock = threading.Lock()

    def add(self, task, content: dict, path) -> None:
        """Place a task's content (:func:`~.netcdf.read_groups` of its file without fields).
        Thread-safe: rank 0's executor thread adds the tasks of other leaders."""
        with self._lock:
            for name, (variables, attrs) in content.items():
                try:
                    self.parts.setdefault(name, _Group(self.study.shape, self.sizes)).add(task.position,
                                                                                         variables, attrs)
                except _Misfit as exc:
                    raise InputError(str(path), f"group {name}: {exc}: not a file of this study's {task.name}; "
                                                "remove it to solve the task again") from None
            grid = _grid(content)
            if grid is not None:
                self.grids[task.position] = grid
                self.fields_of[task.position] = Path(path)
            self.added.add(task.index)

    def read(self, task, path, damaged: Callable | None = None) -> None:
        """Add a task from its file. A file HDF5 cannot read is handed to ``damaged(task, path,
        why)`` and its task left out (NaN, status −1: no result); without ``damaged`` it is an
        :class:`InputError` naming the file."""
        try:
            content = read_groups(path, fields=False)
        except (OSError, KeyError, ValueError, TypeError) as exc:
            if damaged is None:
                raise InputError(str(path), f"HDF5 cannot read this task file ({exc}); remove it to solve "
                                            f"{task.name} again") from None
            damaged(task, path, f"HDF5 cannot read it: {exc}")
            return
        self.add(task, content, path)

    def result(self) -> "Combined":
        study = self.study
        frame = Frame.of(self.grids)
        study_dims = tuple(d.name for d in study.dimensions)
        study_coords = {}
        for dim in study.dimensions:
            study_coords.update(dim.coords())
        loads = (study.load_dim, np.asarray(study.loads, dtype=float), LOAD_COORDINATE[study.load_dim])
        groups = {name: part.dataset(study_dims, study_coords, frame).assign_coords({loads[0]: loads})
                  for name, part in self.parts.items()}
        deferred = {name: part.deferred(study_dims, frame) for name, part in self.parts.items() if part.fields}
        return Combined(groups, deferred, frame, self.fields_of)


class Combined:
    """The study dataset, its fields still in the task files.

    :attr:`groups` holds every group's dataset without its fields (what a
    study's statistics and figures need); :meth:`write` streams the fields
    task by task into the NetCDF export, so memory holds one task's fields
    at a time whatever the study's size; :meth:`load` reads them into memory
    (small studies, tests).
    """

    def __init__(self, groups: dict, deferred: dict, frame: Frame, fields_of: dict):
        self.groups = groups               # name -> xr.Dataset (no fields)
        self.deferred = deferred           # name -> {field: Deferred}
        self._frame = frame
        self._fields_of = fields_of        # task position -> its file (tasks whose fields are stored)

    def fill(self, sink: Callable) -> None:
        """``sink(group, name, index, values)`` for every field of every task, one task at a time."""
        names = {group: list(specs) for group, specs in self.deferred.items()}
        for position, path in self._fields_of.items():
            try:
                content = read_fields(path, names)
            except (OSError, KeyError, ValueError, TypeError) as exc:
                raise InputError(str(path), f"HDF5 cannot read the fields of this task file ({exc}); remove "
                                            "it to solve its task again") from None
            offset = dict(zip(("x", "y"), self._frame.offsets.get(position, (0, 0))))
            for name, fields in content.items():
                for key, values in fields.items():
                    spec = self.deferred.get(name, {}).get(key)
                    if spec is not None:
                        dims = spec.dims[len(position):]
                        sink(name, key, position + tuple(slice(offset.get(d, 0), offset.get(d, 0) + n)
                                                         for d, n in zip(dims, values.shape)), values)

    def load(self) -> dict[str, xr.Dataset]:
        """Every group with its fields, in memory."""
        arrays = {name: {k: np.full(v.shape, v.fillvalue, dtype=v.dtype) for k, v in specs.items()}
                  for name, specs in self.deferred.items()}

        def sink(group, name, index, values):
            arrays[group][name][index] = values

        self.fill(sink)
        return {name: ds.assign({k: (v.dims, arrays[name][k], v.attrs) for k, v in self.deferred.get(name, {}).items()})
                for name, ds in self.groups.items()}

    def write(self, path: str | os.PathLike) -> Path:
        """Write the study dataset to ``path`` through ``path.<pid>.part`` and a rename, the fields
        streamed from the task files (an OSError removes the ``.part`` file and is raised)."""
        path = Path(path)
        part = path.with_name(f"{path.name}.{os.getpid()}.part")       # two shards may finish at once

        def fill(f):
            def sink(group, name, index, values):
                (f if group == "/" else f[group])[name][index] = values
            self.fill(sink)

        try:
            encode(self.groups, part, deferred=self.deferred, fill=fill)
            os.replace(part, path)
        except OSError:
            part.unlink(missing_ok=True)          # no half-written combined file is left
            raise
        return path


def combine(study, paths, damaged: Callable | None = None, combiner: Combiner | None = None) -> Combined:
    """The study dataset (:class:`Combined`) from the task files ``paths[task.index]`` of ``study``.

    ``combiner`` holds the tasks already added as they finished (their files
    are not read again here, only their fields when written). A file HDF5
    cannot read is handed to ``damaged`` (:meth:`Combiner.read`).
    """
    combiner = combiner or Combiner(study)
    for task in study.tasks():
        if task.index not in combiner.added:
            combiner.read(task, paths[task.index], damaged)
    return combiner.result()


def read_shared(combiner: Combiner | None, tasks: list, path_of: Callable, comm, batch: int = 64) -> int:
    """Add to ``combiner`` (rank 0's) the tasks it lacks, their files read by all the ranks of
    ``comm`` (collective): each rank reads every ``size``-th file without its fields and sends
    what it read to rank 0, ``batch`` files per rank at a time. What a run resumed (tasks
    solved earlier) is read this way at the end, while the other ranks would only wait. A file
    that cannot be read is left out here; :func:`combine` reads it again on rank 0 and hands it to
    its ``damaged``. Returns the number of tasks added."""
    from .executor import abort

    rank, size = comm.Get_rank(), comm.Get_size()
    todo = comm.bcast([t.index for t in tasks if t.index not in combiner.added] if rank == 0 else None, root=0)
    by_index = {t.index: t for t in tasks}
    added = 0
    for start in range(0, len(todo), size * batch):
        mine = []
        try:
            for index in todo[start + rank:start + size * batch:size]:
                try:
                    mine.append((index, read_groups(path_of(by_index[index]), fields=False)))
                except (OSError, KeyError, ValueError, TypeError):
                    pass                                   # rank 0 meets it again, and says why
        except BaseException:                              # a defect: the others would wait forever
            import traceback

            if size == 1:
                raise
            abort(comm, f"roughcontact: rank {rank}: {traceback.format_exc()}")
        for part in comm.gather(mine, root=0) or ():
            for index, content in part:
                task = by_index[index]
                try:
                    combiner.add(task, content, path_of(task))
                    added += 1
                except InputError:
                    pass                                   # not this study's file: combine() says so
    return added


def _grid(content: dict) -> tuple | None:
    """(nx, ny, spacing, origin_x, origin_y) of a task's fields from its file's content, or None."""
    fields = [v.values.shape[-2:] for variables, _ in content.values() for v in variables.values()
              if isinstance(v.values, Unread)]
    if not fields:
        return None
    variables = content["/"][0]
    origin = tuple(float(variables[n].values) if n in variables else 0.0 for n in ("origin_x", "origin_y"))
    return (*fields[0], float(variables["grid_spacing"].values), *origin)


def _common_to_every_task(array: np.ndarray, study_ndim: int) -> np.ndarray | None:
    """The values every task agrees on (NaN where a task did not compute them), or None."""
    flat = array.reshape((-1,) + array.shape[study_ndim:])
    common = np.fmax.reduce(flat, axis=0)
    missing = np.isnan(flat) if flat.dtype.kind == "f" else flat == INT8_FILL
    agree = missing | (flat == common)
    return common if agree.all() else None
