"""``roughcontact analyse RESULT.nc``: a study's results get their measures and figures.

A 33² midpoint surface (Δ = 2.3) between two sandstone-like half-spaces is
solved at six loads and written as a load sweep; ``run`` then reads the
NetCDF file. A second case is an ensemble laid out as a combined study file
(seeds × loads, −1 marking contact sets a task did not compute, a
``tangential`` group), built from closed forms so the measures can be checked.
"""
from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np
import pytest
import xarray as xr

from roughcontact.analysis import box_counting, command, hyperbola
from roughcontact.analysis.petsc import footprint_bulk_compliance
from roughcontact.datasets import normal_sweep_dataset
from roughcontact.materials import Interface, Material
from roughcontact.netcdf import write_netcdf
from roughcontact.normal import NormalProblem, solve_loads
from roughcontact.surfaces import disc, midpoint_surface

INTERFACE = Interface(Material(20e9, 0.2), Material(20e9, 0.2))
LOADS = (5.0, 10.0, 20.0, 40.0, 80.0, 160.0)
MEASURES = {"box_counting", "renormalisation", "force_statistics", "multifractal", "clusters", "closure"}


def arguments(*argv: str) -> argparse.Namespace:
    parser = argparse.ArgumentParser(prog="roughcontact analyse")
    command.add_arguments(parser)
    return parser.parse_args(list(argv))


def solve_sweep(comm, path: Path, levels: int, footprint=None) -> Path:
    """A load sweep of a midpoint surface written as NetCDF with the interface's constants."""
    topography = midpoint_surface(levels, 2.3, spacing=1e-4, rms_height=1e-5, seed=1)
    if footprint is not None:
        topography = topography.with_footprint(footprint)
    problem = NormalProblem(topography, INTERFACE, comm)
    try:
        results = solve_loads(problem, LOADS)
    finally:
        problem.destroy()
    ds = normal_sweep_dataset(results, topography.spacing, attrs={"study": path.stem, **INTERFACE.attrs()})
    return write_netcdf(ds, path, comm)


def test_analyse_writes_measures_and_figures(comm, shared_dir):
    result = solve_sweep(comm, shared_dir / "small.nc", levels=5)
    assert command.run(arguments(str(result), "--output", str(shared_dir / "figures")), comm) == 0
    comm.Barrier()
    path = shared_dir / "small.analysis.nc"
    assert not path.with_name(path.name + ".part").exists()
    with xr.open_dataset(path, engine="h5netcdf") as ds, xr.open_dataset(result, engine="h5netcdf") as solved:
        assert set(ds.attrs["measures"].split()) == MEASURES
        for name, var in ds.data_vars.items():          # every variable labelled (CF)
            assert "units" in var.attrs and "long_name" in var.attrs, name
        assert ds["contact_dimension"].dims == ("normal_load",)
        np.testing.assert_allclose(ds["normal_load"], LOADS, rtol=1e-9)
        # Δσ of the stored contact set at the largest load, box counted on its own
        largest = solved["contact"].isel({solved["contact"].dims[0]: -1}).values == 1
        assert float(ds["contact_dimension"][-1]) == pytest.approx(
            float(box_counting(largest)["contact_dimension"]), abs=1e-12)
        # the bulk part removed is c P, c of the whole 33² footprint under uniform pressure
        bulk = footprint_bulk_compliance(np.ones((33, 33), dtype=bool), 1e-4, INTERFACE, comm)
        assert float(ds["bulk_compliance"]) == pytest.approx(bulk.mean, rel=1e-12)
        np.testing.assert_allclose(ds["effective_closure"],
                                   solved["closure"].values - bulk.mean * ds["normal_load"].values, rtol=1e-12)
        assert float(ds["maximum_closure"]) > 0 and float(ds["initial_stiffness"]) > 0
        np.testing.assert_array_equal(ds["box_counting_undefined"], 0)
    for measure in MEASURES:
        assert (shared_dir / "figures" / f"small_{measure}.png").stat().st_size > 1000


def test_analyse_a_disc_footprint_and_bad_input(comm, shared_dir):
    footprint = disc((17, 17), 1e-4, 1.5e-3)
    result = solve_sweep(comm, shared_dir / "disc.nc", levels=4, footprint=footprint)
    assert command.run(arguments(str(result), "--footprint-diameter", "1.5e-3", "--no-figures"), comm) == 0
    comm.Barrier()
    with xr.open_dataset(shared_dir / "disc.analysis.nc", engine="h5netcdf") as ds:
        assert ds.attrs["bulk_footprint"] == "footprint given"
        bulk = footprint_bulk_compliance(footprint, 1e-4, INTERFACE, comm)
        assert float(ds["bulk_compliance"]) == pytest.approx(bulk.mean, rel=1e-12)
    assert not list(shared_dir.glob("disc_*.png"))
    assert command.run(arguments(str(shared_dir / "missing.nc")), comm) == 2


def test_analyse_refuses_a_file_that_is_not_a_result(comm, shared_dir, capfd):
    """A NetCDF file of something else (a temperature series) is no result: exit 2 and one line on
    stderr naming what the measures read, not "measures none" and exit 0."""
    foreign = shared_dir / "temperature.nc"
    if comm.Get_rank() == 0:
        xr.Dataset({"temperature": ("time", np.arange(5.0))}).to_netcdf(foreign, engine="h5netcdf")
    comm.Barrier()
    assert command.run(arguments(str(foreign), "--no-figures"), comm) == 2
    err = capfd.readouterr().err
    if comm.Get_rank() == 0:
        lines = [line for line in err.splitlines() if line.strip()]
        assert len(lines) == 1 and "no measure applies" in lines[0] and "`contact`" in lines[0]
        assert "temperature" in lines[0]
    assert not (shared_dir / "temperature.analysis.nc").exists()


def test_analyse_an_ensemble_study_file(comm, shared_dir):
    """Two seeds × five loads on a 32² grid: seed s has filled squares of side 8 (s + load index + 1)
    nodes, aligned with the boxes of 1 … 8 nodes (Δσ = 2 exactly), except seed 1's last load, which its
    task did not compute
    (contact −1, closure NaN). The closure is c P + a hyperbola of known parameters per seed; the
    tangential group holds slip areas exactly linear in Q on Q_over_fP."""
    spacing, loads = 1e-4, np.array([10.0, 20.0, 40.0, 80.0, 160.0])
    contact = np.zeros((2, 5, 32, 32), dtype=np.int8)
    for seed in range(2):
        for k in range(5):
            side = min(8 * (seed + k + 1), 32)
            contact[seed, k, :side, :side] = 1
    contact[1, 4] = -1
    bulk = footprint_bulk_compliance(np.ones((32, 32), dtype=bool), spacing, INTERFACE, comm).mean
    truth = [(20e-6, 5e6, 2e-6), (10e-6, 8e6, 1e-6)]
    closure = np.stack([hyperbola(loads, *t) + bulk * loads for t in truth])
    closure[1, 4] = np.nan
    root = xr.Dataset(
        {"contact": (("seed", "normal_load", "x", "y"), contact, {"units": "1", "long_name": "contact set S"}),
         "force": (("seed", "normal_load", "x", "y"), np.where(contact == 1, 0.5, np.nan), {"units": "N"}),
         "closure": (("seed", "normal_load"), closure, {"units": "m"})},
        coords={"seed": [0, 1], "normal_load": ("normal_load", loads, {"units": "N"}),
                "x": np.arange(32) * spacing, "y": np.arange(32) * spacing},
        attrs={"spacing": spacing, **INTERFACE.attrs()})
    ratio = np.linspace(0.0, 1.0, 6)
    q = 0.6 * loads[None, :, None] * ratio[None, None, :] * np.ones((2, 1, 1))
    tangential = xr.Dataset({"slip_area": (("seed", "normal_load", "Q_over_fP"), 3e-9 * q)},
                            coords={"Q": (("seed", "normal_load", "Q_over_fP"), q), "Q_over_fP": ratio})
    path = shared_dir / "ensemble.nc"
    if comm.Get_rank() == 0:
        root.to_netcdf(path, engine="h5netcdf")
        tangential.to_netcdf(path, mode="a", group="tangential", engine="h5netcdf")
    comm.Barrier()
    assert command.run(arguments(str(path), "--output", str(shared_dir / "ensemble")), comm) == 0
    comm.Barrier()
    with xr.open_dataset(shared_dir / "ensemble.analysis.nc", engine="h5netcdf") as ds:
        assert {"box_counting", "closure", "slip_area"} <= set(ds.attrs["measures"].split())
        assert ds["contact_dimension"].dims == ("seed", "normal_load")
        np.testing.assert_allclose(ds["contact_dimension"].values[0], 2.0, atol=1e-12)
        np.testing.assert_array_equal(ds["box_counting_undefined"], [[0, 0, 0, 0, 0], [0, 0, 0, 0, 1]])
        assert np.isnan(float(ds["contact_dimension"][1, 4]))
        np.testing.assert_array_equal(ds["closure_undefined"], [0, 0])     # seed 1 fitted on its 4 loads
        for seed, (maximum, stiffness, _) in enumerate(truth):
            assert float(ds["maximum_closure"][seed]) == pytest.approx(maximum, rel=1e-6)
            assert float(ds["initial_stiffness"][seed]) == pytest.approx(stiffness, rel=1e-6)
        np.testing.assert_allclose(ds["slip_area_rate"], 3e-9, rtol=1e-9)
    assert (shared_dir / "ensemble" / "ensemble_box_counting.png").stat().st_size > 1000
