"""The fretting map as a farm study: energy per cycle against amplitude (studies/fretting_map.toml).

Runs the study file itself through the farm on the given communicator
(serially, and under ``mpiexec -n 2`` as a farm of two groups), then checks
the combined dataset against physics and against an independent route:

- the energy a cycle ±Q* dissipates is 4 E_f(Q*) (Mindlin–Deresiewicz, with
  the discrete theorem's 2f superposition, Eqs. 21–26); the existing
  :func:`~roughcontact.tangential.fretting_cycle` computes it node by node
  from the slip back, Σ f p̄ |Δg|, on a separately solved normal problem;
- it does not decrease with the amplitude (the slip zones of a larger
  amplitude contain those of a smaller one, the stick sets recede);
- the Q–δx loop's area (trapezoidal rule) is the dissipated energy up to
  the rule's error, and is at most the rectangle 2Q* × 2δx(Q*) around it.
"""
from __future__ import annotations

import warnings
from pathlib import Path

import numpy as np
import pytest
import xarray as xr
from mpi4py import MPI
from test_farm import open_group, quiet

from roughcontact.errors import InputError
from roughcontact.farm import load_study, run_study
from roughcontact.farm.task import open_normal_solver
from roughcontact.tangential import UncoupledApproximationWarning, fretting_cycle

STUDY = Path(__file__).resolve().parent.parent / "studies" / "fretting_map.toml"


def test_fretting_map_study_through_the_farm(comm, shared_dir):
    study = load_study(STUDY)
    fretting = study.fretting
    summary = run_study(study, comm, shared_dir, log=quiet, quiet=True)
    assert summary.exit_code == 0 and summary.solved == len(study.tasks()) and not summary.failed
    path = summary.paths["netcdf"]
    maps = open_group(path, "fretting_map")
    energy = maps["dissipated_per_cycle"]
    assert energy.dims == ("fractal_dimension", "seed", "normal_load", "amplitude")
    np.testing.assert_array_equal(maps["amplitude"].values, fretting.amplitudes)
    assert energy.attrs["units"] == "J" and maps.attrs["cattaneo_model"] == "uncoupled approximation"
    # cycles reverse the load: the chart of the uncoupled error does not cover them
    assert maps.attrs["uncoupled_error_frictional_energy"] == "outside the charted range"
    at = [study.loads[i] for i in fretting.at]
    others = [p for p in study.loads if p not in at]
    assert np.isnan(energy.sel(normal_load=others).values).all()      # no map asked for there
    energy = energy.sel(normal_load=at)
    assert np.isfinite(energy.values).all()
    # Q* = (Q*/fP) f P with the P the normal solve reached: the imposed P to 1e-8, the
    # equilibrium tolerance of load control (ActiveSetSettings.load_tol)
    q = maps["Q"].sel(normal_load=at)
    expected = maps["amplitude"] * fretting.friction * xr.DataArray(at, dims="normal_load")
    assert float(abs(q / expected - 1.0).max()) <= 1e-8

    # energy per cycle does not decrease with the amplitude; relative slack 1e-9 of the largest
    # (the corrective solves' tolerance on nodal forces) for amplitudes where no node slips yet
    steps = energy.diff("amplitude").values
    scale = energy.max("amplitude").values[..., None]
    assert (steps >= -1e-9 * scale).all(), steps
    assert (energy.isel(amplitude=-1) > 0).all() and (energy.isel(amplitude=-1) > energy.isel(amplitude=0)).all()

    # the loop: its area is at most the rectangle 2 Q* × 2 δx(Q*) and equals the dissipation up to the
    # trapezoidal rule's error: with 8 intervals to each +Q* it measured below 1 % here (the loop
    # slightly under the dissipation); 5 % leaves room for other surfaces (cycles where hardly a
    # node slips, E < 1e-3 of the largest, are left out: there the relative error means nothing)
    loop = maps["loop_area"].sel(normal_load=at)
    half_width = maps["approach_amplitude"].sel(normal_load=at)
    assert (loop <= 4 * q * half_width * (1 + 1e-12)).all()
    slipping = energy > 1e-3 * energy.max()
    assert (abs(loop - energy) <= 0.05 * energy).where(slipping, True).all(), (loop - energy).values

    # 4 E_f(Q*) by the independent single-cycle route, on each rank alone (COMM_SELF: a serial
    # solve, the arithmetic of a one-rank task): equal to 1e-9 relative, the corrective solves'
    # tolerance; every rank checks its own share of the tasks
    rank, size = comm.Get_rank(), comm.Get_size()
    for task in study.tasks()[rank::size]:
        where = dict(zip((d.name for d in study.dimensions), task.position))
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", UncoupledApproximationWarning)
            with open_normal_solver(task.topography(), task.interface, MPI.COMM_SELF, task.normal) as solver:
                for index, load in enumerate(study.loads):      # in order: the farm's warm starts
                    normal = solver.solve_load(load)
                    if index not in fretting.at:
                        continue
                    for amplitude in fretting.amplitudes:
                        cycle = fretting_cycle(solver.problem, normal, fretting.friction,
                                               amplitude * fretting.friction * normal.load, 4,
                                               method=task.normal.method)
                        got = float(maps["dissipated_per_cycle"].isel(where).sel(normal_load=load,
                                                                                 amplitude=amplitude))
                        reference = cycle.dissipated_per_cycle
                        assert got == pytest.approx(reference, rel=1e-9, abs=1e-9 * abs(reference) + 1e-30), (
                            task.name, amplitude, got, reference)


def bad(**tables) -> dict:
    raw = {"name": "bad", "surface": {"generator": "midpoint", "levels": 4, "spacing": 1e-4, "rms_height": 1e-5,
                                      "seed": 1, "fractal_dimension": 2.3},
           "materials": {"body1": {"E": 20e9, "nu": 0.0}}, "normal": {"loads": [5.0, 10.0]},
           "fretting": {"friction": 0.5, "amplitudes": [0.2, 0.5]}}
    raw.update(tables)
    return raw


@pytest.mark.parametrize("fretting, key, message", [
    ({"friction": 0.5, "amplitudes": [0.2], "cycles": 3}, "fretting.cycles", "unknown key"),
    ({"amplitudes": [0.2]}, "fretting.friction", "is required"),
    ({"friction": "0.5", "amplitudes": [0.2]}, "fretting.friction", "must be a number"),
    ({"friction": 0.5}, "fretting.amplitudes", "is required"),
    ({"friction": 0.5, "amplitudes": 0.2}, "fretting.amplitudes", "must be a list"),
    ({"friction": 0.5, "amplitudes": []}, "fretting.amplitudes", "is empty"),
    ({"friction": 0.5, "amplitudes": ["0.2"]}, "fretting.amplitudes", "must be a number"),
    ({"friction": 0.5, "amplitudes": [0.2, 1.0]}, "fretting.amplitudes", "in \\(0, 1\\)"),
    ({"friction": 0.5, "amplitudes": [0.0, 0.5]}, "fretting.amplitudes", "must be > 0"),
    ({"friction": 0.5, "amplitudes": [0.5, 0.2]}, "fretting.amplitudes", "strictly increasing"),
    ({"friction": 0.5, "amplitudes": [0.2], "steps": 2.0}, "fretting.steps", "must be an integer"),
    ({"friction": 0.5, "amplitudes": [0.2], "steps": 0}, "fretting.steps", "must be >= 1"),
    ({"friction": 0.5, "amplitudes": [0.2], "at": [7.0]}, "fretting.at", "is not one of"),
    ("fast", "fretting", "must be a table"),
])
def test_bad_fretting_tables_are_one_line_errors(fretting, key, message):
    with pytest.raises(InputError, match=message) as info:
        load_study(bad(fretting=fretting))
    assert info.value.parameter == key and "\n" not in str(info.value)


def test_friction_from_the_tangential_table_and_a_clash():
    """[fretting] takes f from [tangential] when it has none; two different values are refused."""
    study = load_study(bad(tangential={"friction": 0.4}, fretting={"amplitudes": [0.2]}))
    assert study.fretting.friction == 0.4 and study.fretting.at == (0, 1) and study.fretting.steps == 8
    with pytest.raises(InputError, match="give f in one place") as info:
        load_study(bad(tangential={"friction": 0.4}, fretting={"friction": 0.5, "amplitudes": [0.2]}))
    assert info.value.parameter == "fretting.friction"
