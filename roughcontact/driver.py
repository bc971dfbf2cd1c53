"""Run a study on a communicator: build the surface, solve, write NetCDF and a figure."""
from __future__ import annotations

from pathlib import Path

from .datasets import normal_sweep_dataset, write_netcdf
from .errors import RoughContactError
from .study import Study


def run_normal_study(study: Study, comm, output: str | Path, log=print) -> dict[str, Path]:
    """Load sweep of ``study`` on the ranks of ``comm`` (operator rows split over them).

    Writes ``<output>/<name>.nc`` (all results, fields included) and
    ``<output>/<name>_area_vs_load.png`` (A_r/A_0 against P, Fig. 5a).
    """
    from .normal import ActiveSetSolver, NormalProblem
    from .plots import contact_area_vs_load

    rank = comm.Get_rank()
    say = log if rank == 0 else (lambda *a, **k: None)
    topography = study.topography()
    say(f"{study.name}: {topography.shape[0]}x{topography.shape[1]} nodes, s = {topography.spacing:g} m, "
        f"{len(study.loads)} loads, {comm.Get_size()} rank(s), method {study.method}")
    problem = NormalProblem(topography, study.interface, comm)
    results = []
    attrs = {"study": study.name, "description": study.description, "ranks": comm.Get_size()}
    attrs.update(study.interface.attrs())
    attrs.update({f"surface_{k}": v for k, v in topography.metadata.items()})
    output = Path(output)
    try:
        with ActiveSetSolver(problem, study.method) as solver:
            for load in study.loads:
                res = solver.solve_load(load)
                results.append(res)
                say("  " + res.summary())
    except RoughContactError as exc:
        # keep what was solved: the loads before the failure, and why it stopped
        if results:
            partial = output / f"{study.name}.partial.nc"
            write_netcdf(normal_sweep_dataset(results, topography.spacing, dim="step", attrs={
                **attrs, "incomplete": f"stopped at load {study.loads[len(results)]:g} N: {exc}"}),
                partial, comm)
            say(f"kept the {len(results)} solved load(s) in {partial}")
        raise
    finally:
        problem.destroy()
    ds = normal_sweep_dataset(results, topography.spacing, dim="step", attrs=attrs)
    paths = {"netcdf": write_netcdf(ds, output / f"{study.name}.nc", comm)}
    if rank == 0:
        paths["figure"] = contact_area_vs_load(ds, output / f"{study.name}_area_vs_load.png",
                                               title=f"{study.name} ({topography.shape[0]}² nodes)")
    paths["figure"] = comm.bcast(paths.get("figure"), root=0)
    say(f"wrote {paths['netcdf']} and {paths['figure']}")
    return paths
