"""Normal results as xarray datasets with CF-style attributes.

Variables carry ``units`` and ``long_name`` so ``ds.plot`` labels axes by
itself; global attributes record the package version, the solver, and the
interface constants (A, γ, β of Eqs. 4a, 4b, 5). Write them with
:func:`roughcontact.netcdf.write_netcdf`.
"""
from __future__ import annotations

from dataclasses import replace
from typing import Sequence

import numpy as np
import xarray as xr

from . import __version__
from .checks import check_choice
from .normal.result import NormalResult

_SCALARS = {
    # name: (getter, units, long_name)
    "normal_load": (lambda r: r.load, "N", "normal load P (Eq. 8)"),
    "closure": (lambda r: r.closure, "m", "normal approach δz (Eq. 7)"),
    "rotation_x": (lambda r: r.rotation[0], "rad", "rotation θx (Eq. 7)"),
    "rotation_y": (lambda r: r.rotation[1], "rad", "rotation θy (Eq. 7)"),
    "moment_x": (lambda r: r.moments[0], "N m", "moment Mx = Σ p y about the footprint centroid (Eq. 8)"),
    "moment_y": (lambda r: r.moments[1], "N m", "moment My = Σ p x about the footprint centroid (Eq. 8)"),
    "centroid_x": (lambda r: r.centroid[0], "m", "x of the pressure centroid G_P"),
    "centroid_y": (lambda r: r.centroid[1], "m", "y of the pressure centroid G_P"),
    "contact_area": (lambda r: r.contact_area, "m2", "real contact area A_r"),
    "contact_fraction": (lambda r: r.contact_fraction, "1", "A_r / A_0"),
    "mean_pressure": (lambda r: r.load / r.nominal_area, "Pa", "nominal pressure σ0 = P / A_0"),
    "outer_iterations": (lambda r: r.outer_iterations, "1", "active-set iterations"),
    "linear_iterations": (lambda r: r.linear_iterations, "1", "inner linear-solver iterations"),
    "residual": (lambda r: r.residual, "1", "final relative complementarity residual"),
    "elapsed": (lambda r: r.elapsed, "s", "wall time of the solve"),
    "no_contact": (lambda r: int(r.no_contact), "1", "1 when nothing touches"),
    "full_contact": (lambda r: int(r.full_contact), "1", "1 when the whole footprint touches"),
}


def scalar_variables(items: Sequence, table: dict, dim: str) -> dict:
    """CF variables along ``dim`` from a ``{name: (getter, units, long_name)}`` table."""
    return {name: ((dim,), np.array([get(item) for item in items]), {"units": units, "long_name": long_name})
            for name, (get, units, long_name) in table.items()}


def grid_coords(shape: tuple[int, int], spacing: float) -> dict:
    """The x, y node coordinates (m) of a field on the grid (axis 0 is x)."""
    return {"x": ("x", np.arange(shape[0]) * spacing, {"units": "m", "long_name": "x"}),
            "y": ("y", np.arange(shape[1]) * spacing, {"units": "m", "long_name": "y"})}


#: what a sweep stores on the grid besides its scalars, each level holding the one before: nothing,
#: the contact sets, also the nodal forces (what box counting, histograms and f(α) read), or every field
FIELDS = ("none", "contact", "force", "all")
_LEVELS = {level: FIELDS[1:i + 1] for i, level in enumerate(FIELDS)}

FIELD_TABLE = {
    # name: (getter, dtype, units, long_name, stored with)
    "force": (lambda r: r.force, np.float64, "N", "nodal contact force p̄ (Eq. 9)", "force"),
    "pressure": (lambda r: r.pressure, np.float64, "Pa", "contact pressure p̄ / s²", "all"),
    "gap": (lambda r: r.gap, np.float64, "m", "deformed gap g = H p − w (Eq. 7; NaN off the footprint)", "all"),
    "contact": (lambda r: r.contact, np.int8, "1", "contact set S", "contact"),
}


def check_fields(fields: str, parameter: str = "fields") -> str:
    """``fields`` if it is one of :data:`FIELDS`, else :class:`InputError` naming ``parameter``."""
    return check_choice(parameter, fields, FIELDS)


def stored_fields(table: dict, fields: str) -> list[str]:
    """The names of a field table (values ending in the level they belong to) kept at ``fields``."""
    check_fields(fields)
    keep = _LEVELS[fields]
    return [name for name, spec in table.items() if spec[-1] in keep]


def keep_fields(result: NormalResult, fields: str) -> NormalResult:
    """``result`` with only the fields stored at level ``fields`` (:data:`FIELDS`), the others None:
    what a sweep keeps of each solve once the whole result has served (its scalars all kept)."""
    names = stored_fields(FIELD_TABLE, fields)
    return replace(result, **{name: None for name in FIELD_TABLE if name not in names})


def normal_sweep_dataset(results: Sequence[NormalResult], spacing: float, dim: str = "step",
                         coordinate: tuple | None = None, fields: str = "all",
                         attrs: dict | None = None) -> xr.Dataset:
    """One dataset of a sweep of normal solves along ``dim``.

    ``coordinate`` is the ``(values, attrs)`` of ``dim`` (default: the index of
    the solve); a scalar of the same name is then left out, so a sweep along
    ``dim="normal_load"`` is labelled by the imposed loads, not by the solved
    ones (equal to ``load_tol``). ``fields`` (:data:`FIELDS`) chooses what is
    stored on (dim, x, y): nothing, the contact set S, also the nodal force, or
    also the pressure and the deformed gap.
    """
    n = len(results)
    names = stored_fields(FIELD_TABLE, fields)
    for result in results if names else ():
        result.require_whole("results")
    data = scalar_variables(results, _SCALARS, dim)
    if coordinate is None:
        coords = {dim: (dim, np.arange(n), {"long_name": "index of the solve in the sweep"})}
    else:
        data.pop(dim, None)
        coords = {dim: (dim, np.asarray(coordinate[0])[:n], dict(coordinate[1]))}
    if names and n:
        coords.update(grid_coords(FIELD_TABLE[names[0]][0](results[0]).shape, spacing))
    for name in names if n else ():
        get, dtype, units, long_name, _ = FIELD_TABLE[name]
        data[name] = ((dim, "x", "y"), np.stack([get(r) for r in results]).astype(dtype),
                      {"units": units, "long_name": long_name})
    ds = xr.Dataset(data, coords=coords)
    ds.attrs.update({"roughcontact_version": __version__, "spacing": spacing,
                     "solver": results[0].solver if n else "", "control": results[0].control if n else "",
                     "operator": results[0].operator if n else "", "method": results[0].method if n else "",
                     "solver_choice": results[0].choice if n else ""})
    ds.attrs.update(attrs or {})
    return ds
