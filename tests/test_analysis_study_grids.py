"""Measures of a study whose tasks lie on different grids run on each task's own grid.

A combined study dataset pads the fields of tasks on smaller or coarser
grids (mated shifts cropping each composite to its lens; resolution axes);
every grid measure, stacked along the study's axes, must equal the measure
of that task's own file alone, exactly: the padding only adds nodes outside
the task's grid, which the measures cut away (``task_region``) before they
see the sample, and a task's spacing is its own (``grid_spacing``).
"""
from __future__ import annotations

import numpy as np
import pytest
import xarray as xr
from mpi4py import MPI

from roughcontact.analysis import (
    cluster_statistics,
    contact_dimension,
    contact_force_statistics,
    contact_renormalisation,
    force_spectrum,
)
from roughcontact.farm import load_study, run_study
from roughcontact.farm.store import TaskStore

MEASURES = {"box counting": (contact_dimension, "contact_dimension"),
            "renormalisation": (contact_renormalisation, "renormalised_dimension"),
            "forces": (contact_force_statistics, "loaded_nodes"),
            "multifractal": (force_spectrum, "holder_exponent"),
            "clusters": (cluster_statistics, "cluster_count")}


def study(name: str, axes: dict) -> dict:
    return {"name": name,
            "surface": {"generator": "midpoint", "rms_height": 1e-5, "fractal_dimension": 2.3, "seed": 3,
                        "footprint_diameter": 2.5e-3},
            "axes": axes, "materials": {"body1": {"E": 20e9, "nu": 0.0}},
            "normal": {"pressures": [2e7, 6e7]}, "output": {"fields": "all"}}


@pytest.fixture(scope="module")
def padded(tmp_path_factory):
    """Two studies: one spacing with three mated shifts (lenses of different extents), and two
    resolutions of one surface (spacings 2s and s)."""
    comm = MPI.COMM_WORLD
    out = comm.bcast(tmp_path_factory.mktemp("grids") if comm.Get_rank() == 0 else None, root=0)
    runs = {}
    for name, axes in (("lenses", {"levels": 5, "spacing": 1e-4,
                                    "mate_shift": [[0.0, 3e-4], [-4e-4, 0.0], [5e-4, 2e-4]]}),
                       ("resolutions", {"levels": [5, 6], "spacing": [2e-4, 1e-4], "zip": ["levels", "spacing"],
                                        "mate_shift": [[-4e-4, 2e-4]], "footprint_diameter": 5e-3})):
        raw = study(name, {k: v for k, v in axes.items() if isinstance(v, list)})
        raw["surface"].update({k: v for k, v in axes.items() if not isinstance(v, list)})
        definition = load_study(raw)
        run_study(definition, comm, out, log=lambda *a: None, quiet=True)
        with xr.open_dataset(out / f"{name}.nc", engine="h5netcdf") as ds:
            runs[name] = (definition, ds.load(), TaskStore(out, name))
    return runs


@pytest.mark.parametrize("name", ["lenses", "resolutions"])
@pytest.mark.parametrize("measure", sorted(MEASURES))
def test_each_task_measured_on_its_own_grid(padded, name, measure):
    definition, ds, store = padded[name]
    function, variable = MEASURES[measure]
    assert "differ" in ds.attrs["fields_note"]
    stacked = function(ds, load_dim="mean_pressure", on_error="mark")
    for task in definition.tasks():
        where = dict(zip((d.name for d in definition.dimensions), task.position))
        with xr.open_dataset(store.path(task), engine="h5netcdf") as own:
            alone = function(own.load(), load_dim="mean_pressure", on_error="mark")
        mine = stacked[variable].isel(where)
        expected = alone[variable]
        common = {d: expected[d].values for d in expected.dims if d in mine.dims and d != "mean_pressure"}
        np.testing.assert_array_equal(mine.sel(common).values, expected.values)
