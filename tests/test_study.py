"""Study definitions and the main job: input validation, surfaces, guards, the command line."""
from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
import xarray as xr

from roughcontact.errors import InputError
from roughcontact.farm import DEFAULT_STUDY, load_study, run_study

TINY = {
    "name": "tiny",
    "surface": {"generator": "midpoint", "levels": 4, "fractal_dimension": 2.3, "spacing": 1e-4,
                "rms_height": 1e-5, "seed": 2},
    "materials": {"body1": {"E": 20e9, "nu": 0.2}},
    "normal": {"loads": [5.0, 10.0, 20.0]},
    "output": {"fields": "all"},
}
ROOT = Path(__file__).resolve().parents[1]
TINY_NODES = 17   # 2**4 + 1 nodes a side


def test_single_surface_study_is_a_one_task_ensemble(comm, shared_dir):
    """A study without axes is one task: its dataset has no study dimension, loads are the
    ``normal_load`` coordinate, and the fields, attributes and figure are there."""
    study = load_study(TINY)
    assert study.shape == () and len(study.tasks()) == 1
    summary = run_study(study, comm, shared_dir, log=lambda *a: None, quiet=True)
    assert summary.exit_code == 0
    with xr.open_dataset(summary.paths["netcdf"], engine="h5netcdf") as ds:
        assert dict(ds.sizes) == {"normal_load": 3, "x": 17, "y": 17}
        np.testing.assert_array_equal(ds["normal_load"], TINY["normal"]["loads"])
        # equilibrium: Σ p̄ = P to the tolerance load control guarantees (ActiveSetSettings.load_tol)
        np.testing.assert_allclose(ds["force"].sum(("x", "y")), TINY["normal"]["loads"], rtol=1e-8)
        assert ds["contact"].dtype == np.int8
        assert ds["normal_load"].attrs["units"] == "N" and ds["mean_pressure"].attrs["units"] == "Pa"
        assert ds.attrs["dundurs_beta"] == pytest.approx(0.5 * (1 - 2 * 0.2) / (1 - 0.2))
        assert ds.attrs["study"] == "tiny" and ds.attrs["mpi_ranks"] == comm.Get_size()
        assert np.all(np.diff(ds["contact_fraction"].values) > 0)
        assert np.isnan(ds["gap"].values).sum() == 0   # the footprint is the whole grid
    assert summary.paths["figure"].stat().st_size > 1000


def test_closure_control_and_fixed_rotation_agree_with_load_control(comm, shared_dir):
    """Three controls of one surface, solved by the farm: closures δz (rotation fixed at 0), loads
    with the rotation fixed at 0, loads with it free. Closure control at δz gives the P that load
    control at that P maps back to the same δz (the two controls of one convex problem, Eqs. 7–8),
    to the load tolerance 1e-8 times the closure; with θ fixed the moments are outputs (not 0 on
    a rough surface), with θ free they vanish and G_P lies on the footprint's centroid to the
    moment tolerance (1e-8 P times the half-size, i.e. 1e-8 of the grid here)."""
    closures = [2e-6, 5e-6, 1e-5]
    by_closure = run_study(load_study({**TINY, "name": "by-closure", "normal": {"closures": closures}}),
                           comm, shared_dir, log=lambda *a: None, quiet=True)
    with xr.open_dataset(by_closure.paths["netcdf"], engine="h5netcdf") as ds:
        assert ds["closure"].attrs["units"] == "m" and list(ds.dims) == ["closure", "x", "y"]
        np.testing.assert_array_equal(ds["closure"], closures)
        loads = ds["normal_load"].values
        np.testing.assert_allclose(ds["force"].sum(("x", "y")), loads, rtol=1e-12)
        np.testing.assert_array_equal(ds["rotation_x"], 0.0)
    assert np.all(np.diff(loads) > 0)
    fixed = run_study(load_study({**TINY, "name": "fixed", "normal": {"loads": loads.tolist(),
                                                                       "rotation": [0.0, 0.0]}}),
                      comm, shared_dir, log=lambda *a: None, quiet=True)
    free = run_study(load_study({**TINY, "name": "free", "normal": {"loads": loads.tolist()}}),
                     comm, shared_dir, log=lambda *a: None, quiet=True)
    with xr.open_dataset(fixed.paths["netcdf"], engine="h5netcdf") as at_zero, \
            xr.open_dataset(free.paths["netcdf"], engine="h5netcdf") as free_ds:
        np.testing.assert_allclose(at_zero["closure"], closures, rtol=1e-7)
        np.testing.assert_array_equal(at_zero["rotation_y"], 0.0)
        assert np.abs(at_zero["moment_y"]).max() > 1e-3 * loads.max() * 1e-4   # an output, not imposed
        centre = 0.5 * (TINY_NODES - 1) * 1e-4
        np.testing.assert_allclose(free_ds["centroid_x"], centre, rtol=0, atol=1e-8 * TINY_NODES * 1e-4)
        np.testing.assert_allclose(free_ds["centroid_y"], centre, rtol=0, atol=1e-8 * TINY_NODES * 1e-4)
        assert np.abs(free_ds["rotation_y"]).max() > 0.0


def test_default_study_is_the_ensemble_of_its_file():
    """The built-in default is studies/fractal_ensemble.toml: the same definition, 3 Δ × 8 seeds."""
    study = load_study(None)
    assert study.name == DEFAULT_STUDY["name"]
    assert study.shape == (3, 8) and [d.name for d in study.dimensions] == ["fractal_dimension", "seed"]
    assert study.tasks()[0].topography().shape == (65, 65)
    assert study.interface.normal_uncoupled_exact
    assert load_study(ROOT / "studies" / "fractal_ensemble.toml").identity == study.identity
    assert len(load_study(ROOT / "studies" / "fractal_load_sweep.toml").tasks()) == 1
    joint = load_study(ROOT / "studies" / "rock_joint_shift.toml")
    assert joint.shape == (5,) and [d.name for d in joint.dimensions] == ["shift"]


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
    topo = load_study(tmp_path / "joint.toml").tasks()[0].topography()
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
    ({"surface": {**TINY["surface"], "spacing": "1e-4"}}, "surface.spacing"),
    ({"surface": {**TINY["surface"], "levels": 4.0}}, "surface.levels"),
    ({"surface": {**TINY["surface"], "fractal_dimension": 3.4}}, "surface.fractal_dimension"),
    ({"surface": {"generator": "midpoint", "levels": 4}}, "surface.fractal_dimension"),
    ({"materials": {"body1": {"E": -1.0, "nu": 0.2}}}, "materials.body1.E"),
    ({"materials": {"body1": {"E": "20e9", "nu": 0.2}}}, "materials.body1.E"),
    ({"materials": {"body1": {"E": 1e9}}}, "materials.body1.nu"),
    ({"materials": {"body1": 5}}, "materials.body1"),
    ({"normal": {"loads": [3.0, 1.0]}}, "normal.loads"),
    ({"normal": {"loads": []}}, "normal.loads"),
    ({"normal": {"loads": ["abc"]}}, "normal.loads"),
    ({"normal": {"loads": [1.0], "pressures": [1e5]}}, "normal.loads"),
    ({"normal": {"loads": [1.0], "closures": [1e-6]}}, "normal.loads"),
    ({"normal": {"closures": [2e-6, 1e-6]}}, "normal.closures"),
    ({"normal": {"closures": [1e-6], "rotation": "free"}}, "normal.rotation"),
    ({"normal": {"loads": [1.0], "rotation": [0.0]}}, "normal.rotation"),
    ({"normal": {"loads": [1.0], "rotation": "fixed"}}, "normal.rotation"),
    ({"normal": {"loads": [1.0], "rotation": [0.0, "a"]}}, "normal.rotation"),
    ({"normal": {"loads": [1.0], "method": "jacobi"}}, "normal.method"),
    ({"normal": {"loads": [1.0], "operator": "sparse"}}, "normal.operator"),
    ({"solver": {}}, "study.solver"),
    ({"name": "../elsewhere"}, "name"),
    ({"name": ".hidden"}, "name"),
    ({"axes": {"seed": []}}, "axes.seed"),
    ({"axes": {"seeds": 3, "seed": [1]}}, "axes.seeds"),
    ({"axes": {"fractal_dimension": [2.1, 3.2]}}, "axes.fractal_dimension[1]"),
    ({"axes": {"colour": [1, 2]}}, "axes.colour"),
    ({"axes": {"levels": [3, 4], "spacing": [1e-4], "zip": ["levels", "spacing"]}}, "axes.zip"),
    ({"axes": {"seed": [1, 2]}}, "axes.seed"),       # also fixed in [surface]
    ({"tangential": {"friction": 0.5, "at": [7.0]}}, "tangential.at"),
    ({"tangential": {"friction": 0.5, "fretting_amplitude": 1.0}}, "tangential.fretting_amplitude"),
    ({"tangential": {"steps": 3}}, "tangential.friction"),
    ({"output": {"fields": "some"}}, "output.fields"),
    ({"farm": {"ranks_per_task": 0}}, "farm.ranks_per_task"),
    ({"farm": {"root_works": "no"}}, "farm.root_works"),
    ({"farm": {"task_timeout": 0}}, "farm.task_timeout"),
    ({"farm": {"task_timeout": "1h"}}, "farm.task_timeout"),
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


def test_operator_too_large_for_memory_is_refused_before_any_solve(comm, shared_dir):
    """(2^13 + 1)² nodes: a dense H of 36 PB. Refused with the ways out, before any surface is
    built, and nothing written."""
    study = load_study({**TINY, "surface": {**TINY["surface"], "levels": 13}})
    with pytest.raises(InputError, match="ranks_per_task.*coarser grid") as info:
        run_study(study, comm, shared_dir, log=lambda *a: None)
    assert info.value.parameter == "surface"
    assert not (shared_dir / "tiny.tasks").exists()     # not claimed: a corrected study may use the name


def test_memory_check_uses_the_ranks_per_task_of_the_run(comm, shared_dir):
    """--ranks-per-task overrides [farm] ranks_per_task for the memory check too: the refusal
    names the k the run would use, not the study's; 0 is refused as the study's 0 would be."""
    size = comm.Get_size()
    study = load_study({**TINY, "surface": {**TINY["surface"], "levels": 13}, "farm": {"ranks_per_task": 8}})
    with pytest.raises(InputError, match="coarser grid") as info:
        run_study(study, comm, shared_dir, log=lambda *a: None, ranks_per_task=size)
    assert f"with ranks_per_task = {size}," in str(info.value)
    assert f"ranks_per_task = {2 * size}, needing" in str(info.value)
    with pytest.raises(InputError) as info:
        run_study(load_study(TINY), comm, shared_dir, log=lambda *a: None, ranks_per_task=0)
    assert info.value.parameter == "farm.ranks_per_task" and "\n" not in str(info.value)
    assert not (shared_dir / "tiny.tasks").exists()


def test_output_that_cannot_be_written_is_refused_first(comm, shared_dir):
    if comm.Get_rank() == 0:
        (shared_dir / "a-file").write_text("not a directory")
    comm.Barrier()
    with pytest.raises(InputError) as info:
        run_study(load_study(TINY), comm, shared_dir / "a-file" / "results", log=lambda *a: None)
    assert info.value.parameter == "--output"


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
    assert len(run.stderr.strip().splitlines()) == 1


def test_command_line_warns_about_options_meant_for_it(tmp_path, comm):
    """``-output x`` (one dash) goes to PETSc; the run says so, and names a misspelt PETSc option
    no solver read. The study still runs, into the default directory."""
    import subprocess
    import sys

    if comm.Get_size() > 1:
        pytest.skip("spawns a serial interpreter; run by the serial pass")
    (tmp_path / "tiny.toml").write_text('name = "tiny"\n[surface]\nlevels = 3\nfractal_dimension = 2.3\n'
                                        'spacing = 1e-4\nrms_height = 1e-5\n[materials]\n'
                                        'body1 = { E = 20e9, nu = 0.2 }\n[normal]\nloads = [1.0]\n')
    run = subprocess.run([sys.executable, "-m", "roughcontact", "run", str(tmp_path / "tiny.toml"), "-output",
                          "elsewhere", "-normal_ksp_typo", "cg"], capture_output=True, text=True, timeout=120,
                         cwd=tmp_path)
    assert run.returncode == 0, run.stderr
    assert "-output (one dash) was passed to PETSc" in run.stderr and "did you mean --output" in run.stderr
    assert "-normal_ksp_typo was not used" in run.stderr
    assert (tmp_path / "results" / "tiny.nc").exists()


def test_petsc_options_are_split_from_program_arguments():
    from roughcontact.cli import split_petsc_args

    own, petsc = split_petsc_args(["run", "s.toml", "-normal_ksp_type", "gmres", "--output", "out",
                                   "-log_view", "--", "-normal_ksp_rtol", "1e-9"])
    assert own == ["run", "s.toml", "--output", "out"]
    assert petsc == ["-normal_ksp_type", "gmres", "-log_view", "-normal_ksp_rtol", "1e-9"]
