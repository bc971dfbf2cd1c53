"""Writing one task file: the farm's lean h5py writer against xarray's h5netcdf path.

Usage::

    python -m benchmarks.bench_task_file [--repeats 20] [--output results/bench_task_file.json]

Solves one task of the default study (65², 12 loads; and the same task with
a tangential sweep and a fretting cycle, four groups) once, then writes its
groups ``repeats`` times each way to a temporary directory: with
:func:`roughcontact.farm.netcdf.write_groups` (what the farm does) and with
``xarray.Dataset.to_netcdf(engine="h5netcdf")`` group by group (the
package's general path, :mod:`roughcontact.netcdf`), both with the same
compression of the fields. Reports the median time of each, their ratio and
that both files read back equal through xarray. Serial, one process.
"""
from __future__ import annotations

import argparse
import statistics
import tempfile
import time
from pathlib import Path

import xarray as xr
from mpi4py import MPI

from benchmarks.common import save_json
from roughcontact.farm import load_study, solve_task
from roughcontact.farm.netcdf import write_groups
from roughcontact.farm.records import field_encoding, task_groups
from roughcontact.netcdf import netcdf_attrs


def through_xarray(groups: dict[str, xr.Dataset], path: Path) -> None:
    for i, (name, ds) in enumerate(groups.items()):
        clean = ds.copy()
        clean.attrs = netcdf_attrs(ds.attrs)
        for var in clean.variables.values():
            var.attrs = netcdf_attrs(var.attrs)
        encoding = {k: {"chunksizes" if o == "chunks" else o: v for o, v in spec.items()}
                    for k, spec in field_encoding(ds).items()}
        clean.to_netcdf(path, mode="w" if i == 0 else "a", group=None if name == "/" else name,
                        engine="h5netcdf", encoding=encoding)


def timed(write, groups, directory: Path, repeats: int) -> list[float]:
    times = []
    for k in range(repeats):
        path = directory / f"{write.__name__}-{k}.nc"
        start = time.perf_counter()
        write(groups, path)
        times.append(time.perf_counter() - start)
    return times


def lean(groups, path):
    write_groups(groups, path, field_encoding)


def same_content(groups: dict[str, xr.Dataset], a: Path, b: Path) -> bool:
    for name in groups:
        group = None if name == "/" else name
        with xr.open_dataset(a, group=group, engine="h5netcdf") as x, \
                xr.open_dataset(b, group=group, engine="h5netcdf") as y:
            if not x.load().equals(y.load()):
                return False
    return True


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--repeats", type=int, default=20)
    parser.add_argument("--output", default="results/bench_task_file.json")
    args = parser.parse_args()
    study = load_study(None)
    cases = {"normal sweep (1 group)": study.tasks()[0]}
    tangential = load_study({**_default(), "tangential": {"friction": 0.5, "steps": 5, "at": [111.4],
                                                         "fretting_amplitude": 0.5}})
    cases["with tangential and fretting (3 groups)"] = tangential.tasks()[0]
    rows = []
    for label, task in cases.items():
        groups = task_groups(solve_task(task, MPI.COMM_SELF))
        with tempfile.TemporaryDirectory() as tmp:
            directory = Path(tmp)
            ours = timed(lean, groups, directory, args.repeats)
            xarray = timed(through_xarray, groups, directory, args.repeats)
            equal = same_content(groups, directory / "lean-0.nc", directory / "through_xarray-0.nc")
            size = (directory / "lean-0.nc").stat().st_size
        row = {"case": label, "groups": len(groups), "variables": sum(len(g.variables) for g in groups.values()),
               "file_bytes": size, "lean_s_median": statistics.median(ours),
               "xarray_s_median": statistics.median(xarray),
               "xarray_over_lean": statistics.median(xarray) / statistics.median(ours), "same_content": equal}
        print(row, flush=True)
        rows.append(row)
    save_json({"repeats": args.repeats, "rows": rows}, args.output)


def _default() -> dict:
    from roughcontact.farm import DEFAULT_STUDY

    return {**DEFAULT_STUDY, "axes": {"fractal_dimension": [2.3], "seeds": 1}}


if __name__ == "__main__":
    main()
