"""A solved task as the datasets of its NetCDF file, and the file's bytes.

A task file has three groups, each a self-contained dataset with its own
coordinates (``xr.open_dataset(path, group="tangential")`` reads one):

- ``/``: the normal load sweep along ``normal_load`` (or ``mean_pressure``, ``closure``),
  the fields the study stores, and the task's own scalars (``status``,
  ``message``, the composite topography's statistics);
- ``tangential``: Q sweeps along ``Q_over_fP`` at some loads (Figs. 9–12);
- ``fretting``: fretting cycles along ``step``;
- ``fretting_map``: energy per cycle along ``amplitude`` (Q*/fP) at some loads.

Tangential groups keep the full load dimension of ``/`` (NaN, or −1 for
the int8 zones, at loads without a sweep), so the groups align as a tree.
Solving and describing stay apart: :mod:`.task` knows nothing of xarray. Files are
written and read by :mod:`.netcdf`.
"""
from __future__ import annotations

import numpy as np
import xarray as xr

from .. import __version__
from ..datasets import normal_sweep_dataset, stored_fields
from ..tangential.dataset import fretting_dataset, fretting_map_dataset, tangential_dataset
from .task import TaskOutcome

#: the load coordinate of each way of giving loads (CF attributes)
LOAD_COORDINATE = {
    "normal_load": {"units": "N", "long_name": "normal load P (Eq. 8), imposed"},
    "mean_pressure": {"units": "Pa", "long_name": "nominal pressure σ0 = P / A_0, imposed"},
    "closure": {"units": "m", "long_name": "normal approach δz from first touch (Eq. 7), imposed"},
}

#: per-task status values (the ``status`` variable's flags)
COMPLETED, FAILED = 0, 1
STATUS_ATTRS = {"long_name": "task status", "flag_values": np.array([COMPLETED, FAILED], dtype=np.int8),
                "flag_meanings": "completed failed"}

#: tangential fields and the ``fields`` level that stores them (see roughcontact.datasets.FIELDS)
_TANGENTIAL_FIELDS = {"zone": ("contact",), "traction": ("all",), "slip_distance": ("all",),
                      "frictional_energy_density": ("all",)}

#: int8 fields, whose "not computed" value is −1 (floats use NaN)
INT8_FILL = -1


def task_groups(outcome: TaskOutcome) -> dict[str, xr.Dataset]:
    """The datasets of a task file, by group ("/", and "tangential", "fretting", "fretting_map" when run)."""
    task = outcome.task
    dim = task.load_dim
    values = np.asarray(task.loads[:len(outcome.normal)], dtype=float)
    coordinate = (values, LOAD_COORDINATE[dim])
    spacing = outcome.topography.spacing if outcome.topography is not None else np.nan
    root = normal_sweep_dataset(outcome.normal, spacing, dim=dim, coordinate=coordinate, fields=task.fields)
    if task.tangential is not None:
        root["incipient_sliding_energy"] = (
            (dim,), np.asarray(outcome.incipient_energy, dtype=float),
            {"units": "J", "long_name": "energy dissipated up to incipient sliding E_tot (Eq. 27)"})
    root = root.assign(_task_scalars(outcome))
    first = outcome.normal[0] if outcome.normal else None
    root.attrs = {"roughcontact_version": __version__, "task": task.index, "task_key": task.key,
                  "task_name": task.name,
                  "ranks_per_task": outcome.ranks, "fields": task.fields,
                  "operator": first.operator if first else task.normal.operator,
                  "method": first.method if first else task.normal.method,
                  "solver": first.solver if first else "", "solver_choice": first.choice if first else "",
                  "warnings": "\n".join(outcome.warnings), **_axis_attrs(task.labels)}
    groups = {"/": root}
    if outcome.sweeps:
        groups["tangential"] = _stack(outcome, outcome.sweeps, _sweep_dataset, values)
    if outcome.cycles:
        groups["fretting"] = _stack(outcome, outcome.cycles, _cycle_dataset, values)
    if outcome.fretting_maps:
        groups["fretting_map"] = _stack(outcome, outcome.fretting_maps, _map_dataset, values)
    return groups


def encode(groups: dict[str, xr.Dataset], target=None, deferred=None, fill=None):
    """Write ``groups`` as one NetCDF-4 file (fields compressed, one chunk per grid).

    ``target`` is a path, or None for the file's bytes; ``deferred`` and ``fill``
    as :func:`~.netcdf.write_groups` takes them (fields written after the layout).
    """
    from .netcdf import write_groups

    return write_groups(groups, target, field_encoding, deferred, fill)


def field_encoding(ds: xr.Dataset) -> dict:
    """gzip (level 1, shuffled) for the variables on (…, x, y), chunked one grid at a time.

    Contact sets and zones compress to a few per cent, and the NaN rows of
    loads without a sweep to almost nothing.
    """
    out = {}
    for name, var in ds.data_vars.items():
        if var.dims[-2:] == ("x", "y") and var.size:
            chunks = tuple(1 for _ in var.dims[:-2]) + var.shape[-2:]
            out[name] = {"compression": "gzip", "compression_opts": 1, "shuffle": True, "chunks": chunks}
    return out


def _task_scalars(outcome: TaskOutcome) -> dict:
    from ..surfaces import rms_height, rms_slope

    topography = outcome.topography
    stats = {"nominal_area": np.nan, "footprint_nodes": np.nan, "grid_spacing": np.nan,
             "origin_x": np.nan, "origin_y": np.nan,
             "topography_rms_height": np.nan, "topography_rms_slope": np.nan}
    if topography is not None:
        origin = topography.metadata.get("origin", (0.0, 0.0))
        stats.update(nominal_area=topography.nominal_area, footprint_nodes=float(topography.footprint.sum()),
                     grid_spacing=topography.spacing, origin_x=origin[0], origin_y=origin[1],
                     topography_rms_height=rms_height(topography),
                     topography_rms_slope=rms_slope(topography) if topography.footprint.sum() > 1 else np.nan)
    attrs = {"nominal_area": ("m2", "apparent area A_0 of the footprint"),
             "footprint_nodes": ("1", "nodes of the footprint (unknowns of the normal problem)"),
             "grid_spacing": ("m", "grid spacing s of the composite topography"),
             "origin_x": ("m", "x of the grid's first node in the frame of the surface before a mated "
                               "shift cropped it"),
             "origin_y": ("m", "y of the grid's first node in the frame of the surface before a mated "
                               "shift cropped it"),
             "topography_rms_height": ("m", "rms height Sq of the composite topography Δh"),
             "topography_rms_slope": ("1", "rms slope Sdq of the composite topography Δh")}
    out = {name: ((), float(value), {"units": attrs[name][0], "long_name": attrs[name][1]})
           for name, value in stats.items()}
    out["status"] = ((), np.int8(FAILED if outcome.error else COMPLETED), STATUS_ATTRS)
    out["message"] = ((), outcome.error or "", {"long_name": "why the task failed (empty if it completed)"})
    out["warnings"] = ((), "\n".join(outcome.warnings),
                       {"long_name": "warnings raised while solving the task, one a line (empty if none)"})
    out["task_elapsed"] = ((), outcome.elapsed, {"units": "s", "long_name": "wall time of the task"})
    return out


def _sweep_dataset(outcome: TaskOutcome, index: int) -> xr.Dataset:
    task, sweep = outcome.task, outcome.sweeps[index]
    steps = task.tangential.steps
    ratio = np.arange(steps + 1) / steps
    keep = stored_fields(_TANGENTIAL_FIELDS, task.fields)
    ds = tangential_dataset(sweep, fields=bool(keep))
    ds = ds.drop_vars([n for n in _TANGENTIAL_FIELDS if n in ds and n not in keep])
    ds = ds.swap_dims(Q="Q_over_fP").assign_coords(
        Q_over_fP=("Q_over_fP", ratio, ds["Q_over_fP"].attrs),
        Q=("Q_over_fP", ratio * task.tangential.friction * outcome.loads[index], ds["Q"].attrs))
    ds["resticking_nodes"] = ((), ds.attrs["resticking_nodes"],
                              {"units": "1", "long_name": "largest number of nodes rejoining the stick set"})
    ds["sweep_elapsed"] = ((), ds.attrs["sweep_elapsed"], {"units": "s", "long_name": "wall time of the sweep"})
    ds.attrs = _model_attrs(ds.attrs)
    return ds


def _cycle_dataset(outcome: TaskOutcome, index: int) -> xr.Dataset:
    ds = fretting_dataset(outcome.cycles[index])
    for name, units, long_name in (("amplitude", "N", "amplitude Q* of the cycle"),
                                   ("loop_area", "J", "area of the Q–δx loop"),
                                   ("dissipated_per_cycle", "J", "energy dissipated per cycle")):
        ds[name] = ((), ds.attrs[name], {"units": units, "long_name": long_name})
    ds.attrs = _model_attrs(ds.attrs)
    return ds


def _map_dataset(outcome: TaskOutcome, index: int) -> xr.Dataset:
    ds = fretting_map_dataset(outcome.fretting_maps[index])
    ds.attrs = _model_attrs(ds.attrs)
    return ds


def _model_attrs(attrs: dict) -> dict:
    """What a tangential group keeps of its dataset's attributes: the Cattaneo model, the
    measured error of the uncoupled model (``uncoupled_error_*``) and f."""
    return {k: v for k, v in attrs.items()
            if k in ("cattaneo_model", "friction") or k.startswith("uncoupled_error_")}


def _stack(outcome: TaskOutcome, runs: dict, build, values: np.ndarray) -> xr.Dataset:
    """The datasets of ``runs`` (keyed by load index) along the load dimension of the
    task, with NaN (−1 for int8 fields) at the loads without a run."""
    dim = outcome.task.load_dim
    parts = []
    for i in sorted(runs):
        part = build(outcome, i).expand_dims({dim: [values[i]]})
        parts.append(part.assign_coords(Q=part["Q"].expand_dims({dim: [values[i]]})))   # Q = (Q/fP) f P
    stacked = xr.concat(parts, dim=dim, coords="different", compat="equals", combine_attrs="override",
                        join="outer")
    fill = {name: INT8_FILL for name, var in stacked.data_vars.items() if var.dtype == np.int8}
    out = stacked.reindex({dim: values}, fill_value=fill or xr.core.dtypes.NA)
    out[dim].attrs = LOAD_COORDINATE[dim]
    return out


def _axis_attrs(labels: dict) -> dict:
    out = {}
    for key, value in labels.items():
        if hasattr(value, "attrs"):         # an Interface
            out.update({f"axis_{key}_{k}": v for k, v in value.attrs().items()})
        else:
            out[f"axis_{key}"] = list(value) if isinstance(value, tuple) else value
    return out
