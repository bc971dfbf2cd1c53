"""``roughcontact analyse RESULT.nc [--output DIR]``: add the measures to a study's results, draw them.

Reads a study's NetCDF results (a single sweep, or a combined study file
whose root group holds the normal sweeps and whose ``tangential`` group, if
any, the Q sweeps), runs every measure they allow (:func:`~.report.analyse`),
writes ``<name>.analysis.nc`` beside RESULT (from rank 0, to a temporary
name first, then renamed) and one figure per measure into ``--output``
(default: beside RESULT). Under MPI the bulk compliance of the closure
curve is computed on the ranks of the communicator the command line gives.
"""
from __future__ import annotations

import argparse
import sys
from pathlib import Path


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """The arguments of ``analyse``."""
    parser.add_argument("result", help="a study's results file (NetCDF), e.g. results/fractal-load-sweep.nc")
    parser.add_argument("--output", default=None, help="directory of the figures (default: beside RESULT)")
    parser.add_argument("--footprint-diameter", type=float, default=None,
                        help="diameter (m) of the disc footprint of a core section, for the bulk displacement "
                             "(default: the footprint the results record, else the whole grid)")
    parser.add_argument("--load-dim", default=None,
                        help="the load dimension (default: normal_load, or mean_pressure when the loads are "
                             "pressures)")
    parser.add_argument("--no-figures", action="store_true", help="write the measures only")


def read_results(path: Path):
    """(normal results, tangential sweeps or None) of a results file, loaded into memory."""
    import xarray as xr

    from ..errors import InputError

    if not path.is_file():
        raise InputError("result", f"no results file at {path}")
    try:
        groups = xr.open_groups(path, engine="h5netcdf")
        loaded = {name.strip("/"): group.load() for name, group in groups.items()}
        for group in groups.values():
            group.close()
    except (OSError, ValueError) as exc:
        raise InputError("result", f"{path} is not a readable NetCDF file: {exc}") from None
    return loaded[""], loaded.get("tangential")


def analyse_file(result: str | Path, comm, output: str | Path | None = None,
                 footprint_diameter: float | None = None, load_dim: str | None = None,
                 draw_figures: bool = True, log=print) -> dict[str, object]:
    """Analyse one results file on ``comm``; returns the paths written (identical on every rank)."""
    from ..netcdf import write_netcdf
    from ..surfaces.footprint import disc
    from .inputs import LOAD, grid_spacing
    from .report import analyse, draw

    result = Path(result)
    ds, tangential = read_results(result)
    if load_dim is None:
        load_dim = "mean_pressure" if "mean_pressure" in ds.dims and LOAD not in ds.dims else LOAD
    footprint = None if footprint_diameter is None else disc((ds.sizes["x"], ds.sizes["y"]), grid_spacing(ds),
                                                             footprint_diameter)
    merged, measures = analyse(ds, comm, footprint=footprint, load_dim=load_dim, tangential=tangential)
    name = result.name[: -len(".nc")] if result.name.endswith(".nc") else result.stem
    paths: dict[str, object] = {"netcdf": write_netcdf(merged, result.with_name(f"{name}.analysis.nc"), comm)}
    rank = comm.Get_rank()
    figures = draw(measures, ds, Path(output) if output else result.parent, name, load_dim, tangential) \
        if draw_figures and rank == 0 else []
    paths["figures"] = comm.bcast(figures, root=0)
    if rank == 0:
        log(f"{name}: measures {merged.attrs['measures']}; wrote {paths['netcdf']} and "
            f"{len(paths['figures'])} figure(s)")
        for key, reason in merged.attrs.items():
            if key.startswith("skipped_"):
                log(f"  skipped {key[len('skipped_'):]}: {reason}")
    return paths


def run(args: argparse.Namespace, comm) -> int:
    """Run ``analyse`` on ``comm`` (the command line's); 0 on success, 2 on bad input (message on rank 0)."""
    from ..errors import RoughContactError

    try:
        analyse_file(args.result, comm, output=args.output, footprint_diameter=args.footprint_diameter,
                     load_dim=args.load_dim, draw_figures=not args.no_figures)
    except RoughContactError as exc:
        if comm.Get_rank() == 0:
            print(f"roughcontact analyse: error: {exc}", file=sys.stderr)
        return 2
    return 0
