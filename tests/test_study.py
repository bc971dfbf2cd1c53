"""Study definitions and the main job: input validation, surfaces, NetCDF round trip."""
from __future__ import annotations

import numpy as np
import pytest
import xarray as xr

from roughcontact.driver import run_normal_study
from roughcontact.errors import InputError
from roughcontact.study import DEFAULT_STUDY, load_study

TINY = {
    "name": "tiny",
    "surface": {"generator": "midpoint", "levels": 4, "fractal_dimension": 2.3, "spacing": 1e-4,
                "rms_height": 1e-5, "seed": 2},
    "materials": {"body1": {"E": 20e9, "nu": 0.2}},
    "normal": {"loads": [5.0, 10.0, 20.0]},
}


@pytest.fixture
def shared_dir(tmp_path, comm):
    """One directory for all ranks (rank 0's), since rank 0 writes the files."""
    from pathlib import Path

    return Path(comm.bcast(str(tmp_path), root=0))


def test_main_job_writes_netcdf_and_plot(comm, shared_dir):
    study = load_study(TINY)
    paths = run_normal_study(study, comm, shared_dir, log=lambda *a: None)
    comm.Barrier()
    with xr.open_dataset(paths["netcdf"], engine="h5netcdf") as ds:
        # equilibrium: the solved load is the imposed one (relative 1e-9, solver tolerance)
        np.testing.assert_allclose(ds["load"].values, TINY["normal"]["loads"], rtol=1e-9)
        np.testing.assert_allclose(ds["force"].sum(("x", "y")).values, TINY["normal"]["loads"], rtol=1e-9)
        assert ds["load"].attrs["units"] == "N"
        assert ds.attrs["dundurs_beta"] == pytest.approx(0.5 * (1 - 2 * 0.2) / (1 - 0.2))
        assert np.all(np.diff(ds["contact_fraction"].values) > 0)
    assert paths["figure"].stat().st_size > 1000


def test_default_study_is_valid():
    study = load_study(None)
    assert study.name == DEFAULT_STUDY["name"]
    assert study.topography().shape == (65, 65)
    assert study.interface.normal_uncoupled_exact


def test_study_file_with_measured_surface_shift_and_disc(tmp_path):
    """A file surface (path relative to the study), mated shift and core footprint."""
    rng = np.random.default_rng(0)
    np.save(tmp_path / "face.npy", rng.standard_normal((40, 40)) * 1e-6)
    (tmp_path / "joint.toml").write_text('''
name = "joint"
[surface]
generator = "file"
path = "face.npy"
spacing = 1e-4
unit = "m"
footprint_diameter = 3e-3
mate_shift = [2e-4, 0.0]
[materials]
body1 = { E = 20e9, nu = 0.2 }
[normal]
loads = [1.0]
''')
    topo = load_study(tmp_path / "joint.toml").topography()
    face = np.load(tmp_path / "face.npy")
    assert topo.spacing == pytest.approx(1e-4)
    # footprint: the lens of two 30-node-diameter discs 2 nodes apart (~ π 15² − 2·30 nodes)
    assert 600 <= topo.footprint.sum() <= 710
    # whole-pixel shift by 2 nodes along x: every Δh is exactly some h(x) − h(x − v)
    expected = np.round((face[2:, :] - face[:-2, :]).ravel(), 18)
    assert np.all(np.isin(np.round(topo.heights[topo.footprint], 18), expected))


@pytest.mark.parametrize("change, parameter", [
    ({"surface": {"generator": "midpoint", "levls": 4}}, "surface.levls"),
    ({"surface": {"generator": "spline"}}, "surface.generator"),
    ({"materials": {"body1": {"E": -1.0, "nu": 0.2}}}, "materials.body1.E"),
    ({"materials": {"body1": {"E": 1e9}}}, "materials.body1.nu"),
    ({"normal": {"loads": [3.0, 1.0]}}, "normal.loads"),
    ({"normal": {"loads": []}}, "normal.loads"),
    ({"solver": {}}, "study.solver"),
])
def test_bad_study_names_the_key(change, parameter):
    raw = {**TINY, **change}
    with pytest.raises(InputError) as info:
        load_study(raw)
    assert info.value.parameter == parameter


def test_missing_or_broken_study_file(tmp_path):
    with pytest.raises(InputError) as info:
        load_study(tmp_path / "nope.toml")
    assert info.value.parameter == "study"
    (tmp_path / "bad.toml").write_text("name = [unclosed")
    with pytest.raises(InputError) as info:
        load_study(tmp_path / "bad.toml")
    assert info.value.parameter == "study"


def test_failed_sweep_keeps_the_solved_loads(comm, shared_dir, monkeypatch):
    """A solver failure mid-sweep keeps the loads already solved, with the reason, and
    re-raises; no complete-looking file is written."""
    from roughcontact.errors import ConvergenceError
    from roughcontact.normal import ActiveSetSolver

    solve_load = ActiveSetSolver.solve_load
    third = TINY["normal"]["loads"][2]

    def fail_at_third(self, load, *args, **kwargs):   # same decision on every rank
        if load == third:
            raise ConvergenceError("ACTIVE_SET_MAX_ITERATIONS", "forced for the test")
        return solve_load(self, load, *args, **kwargs)

    monkeypatch.setattr(ActiveSetSolver, "solve_load", fail_at_third)
    with pytest.raises(ConvergenceError):
        run_normal_study(load_study(TINY), comm, shared_dir, log=lambda *a: None)
    comm.Barrier()
    with xr.open_dataset(shared_dir / "tiny.partial.nc", engine="h5netcdf") as ds:
        assert ds.sizes["step"] == 2
        np.testing.assert_allclose(ds["load"].values, TINY["normal"]["loads"][:2], rtol=1e-9)
        assert "stopped at load 20 N" in ds.attrs["incomplete"]
    assert not (shared_dir / "tiny.nc").exists()


def test_command_line_reports_bad_study(tmp_path, comm):
    """`roughcontact run` on a bad study prints one line naming the key and exits 2."""
    import subprocess
    import sys

    if comm.Get_size() > 1:
        pytest.skip("spawns a serial interpreter; run by the serial pass")
    (tmp_path / "bad.toml").write_text('[surface]\ngenerator = "midpoint"\nlevels = 4\nfractal_dimension = 3.4\n'
                                       '[materials]\nbody1 = { E = 1e9, nu = 0.2 }\n[normal]\nloads = [1.0]\n')
    run = subprocess.run([sys.executable, "-m", "roughcontact", "run", str(tmp_path / "bad.toml"),
                          "--output", str(tmp_path)], capture_output=True, text=True, timeout=120)
    assert run.returncode == 2, run.stderr
    assert "fractal_dimension" in run.stderr and "Traceback" not in run.stderr


def test_petsc_options_are_split_from_program_arguments():
    from roughcontact.cli import split_petsc_args

    own, petsc = split_petsc_args(["run", "s.toml", "-normal_ksp_type", "gmres", "--output", "out",
                                   "-log_view", "--", "-normal_ksp_rtol", "1e-9"])
    assert own == ["run", "s.toml", "--output", "out"]
    assert petsc == ["-normal_ksp_type", "gmres", "-log_view", "-normal_ksp_rtol", "1e-9"]
