"""Shared by the benchmarks: run a worker under mpiexec for each rank count, the large-grid
scene's surface, and writing the JSON of results.

Benchmarks run as modules from the repository root (``python -m benchmarks.bench_farm``),
so this helper imports as ``benchmarks.common`` and workers start the same way.
"""
from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
from pathlib import Path


def mpiexec() -> str:
    """The launcher: $MPIEXEC, else the environment's own mpiexec, else the one on PATH."""
    bindir = Path(sys.executable).parent
    own = bindir / "mpiexec"
    return os.environ.get("MPIEXEC") or (str(own) if own.exists() else "mpiexec")


#: the repository root: workers and peers start here, where ``benchmarks`` is importable
ROOT = Path(__file__).resolve().parent.parent


def proc_status(key: str) -> int:
    """A /proc/self/status entry in bytes (VmRSS, VmHWM: the resident set and its high-water mark)."""
    with open("/proc/self/status") as handle:
        for line in handle:
            if line.startswith(key):
                return int(line.split()[1]) * 1024
    return 0


def worker_mpi():
    """A worker's start under mpiexec: PETSc initialised without reading the command line (the
    worker's own options are not PETSc's), then mpi4py's MPI module."""
    import petsc4py

    petsc4py.init([])
    from mpi4py import MPI

    return MPI


def run_module(module: str, args: list[str], python: str | None = None) -> list[str]:
    """The command line that runs benchmark ``module`` (e.g. ``benchmarks.bench_farm``) with ``args``."""
    return [python or sys.executable, "-m", module, *args]


def run_on_ranks(module: str, ranks: list[int], worker_args: list[str], bind_to: str = "launcher") -> list[dict]:
    """Rows written by ``module --worker --json FILE <worker_args>`` on each rank count.

    ``bind_to="core"`` pins each rank to one core (``--bind-to core``, which MPICH's Hydra and
    Open MPI both take): the FFT then runs one thread per rank, so a rank count measures ranks
    alone; ``"launcher"`` passes no binding and leaves the placement to the launcher's default
    (Hydra: none, so the ranks share the node's cores through the FFT threads; Open MPI binds).
    """
    rows = []
    binding = ["--bind-to", bind_to] if bind_to != "launcher" else []
    for n in ranks:
        with tempfile.TemporaryDirectory() as tmp:
            out = Path(tmp) / "rows.json"
            cmd = [mpiexec(), *binding, "-n", str(n),
                   *run_module(module, ["--worker", "--json", str(out), *worker_args])]
            # one BLAS thread per rank: OpenBLAS's spinning threads oversubscribe the cores otherwise
            env = dict(os.environ, OPENBLAS_NUM_THREADS=os.environ.get("OPENBLAS_NUM_THREADS", "1"),
                       OMP_NUM_THREADS=os.environ.get("OMP_NUM_THREADS", "1"))
            subprocess.run(cmd, check=True, env=env, cwd=ROOT)
            rows.extend(json.loads(out.read_text()))
    return rows


def emit(comm, rows: list[dict], row: dict) -> None:
    """Keep a worker's row and print it from rank 0 as it is measured."""
    rows.append(row)
    if comm.Get_rank() == 0:
        print(json.dumps(row), flush=True)


def write_rows(comm, rows: list[dict], path: str) -> None:
    """Rank 0 writes the worker's rows for :func:`run_on_ranks` to collect."""
    if comm.Get_rank() == 0:
        Path(path).write_text(json.dumps(rows, indent=1))


def add_launch_arguments(parser: argparse.ArgumentParser, repeats: int, output: str, binding: bool = False) -> None:
    """The options every benchmark takes: rank counts, repeats, output, and the hidden
    worker switches used by :func:`run_on_ranks`; ``binding``: also ``--bind-to``, for the
    benchmarks that pass it on to :func:`run_on_ranks`."""
    parser.add_argument("--ranks", type=int, nargs="+", default=[1, 2])
    if binding:
        parser.add_argument("--bind-to", choices=["launcher", "core"], default="launcher",
                            help="core: one core per rank (one FFT thread each); launcher (default): no "
                                 "binding asked, the launcher's own placement")
    parser.add_argument("--repeats", type=int, default=repeats)
    parser.add_argument("--output", default=output)
    parser.add_argument("--worker", action="store_true", help=argparse.SUPPRESS)
    parser.add_argument("--json", help=argparse.SUPPRESS)


def save_json(data, path, extra: str = "") -> Path:
    """Write a benchmark's rows (or report) to ``path``, creating its directory; say so."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(json.dumps(data, indent=1))
    print(f"wrote {path}{extra}")
    return path


def scene_surface(n: int, seed: int = 1, cutoff: float | None = None, **shape):
    """The large-grid scene on an n × n grid of the unit square: Fourier filtered, Hurst 0.8
    (or ``fractal_dimension=`` in ``shape``), unit rms slope, roll-off at the box size, short
    cut-off ``cutoff`` (default 8 s), non-periodic."""
    from roughcontact.surfaces import fourier_surface

    s = 1.0 / n
    if "fractal_dimension" not in shape:
        shape["hurst"] = 0.8
    return fourier_surface(n, s, rms_slope=1.0, rolloff_wavelength=1.0,
                           short_cutoff_wavelength=8 * s if cutoff is None else cutoff,
                           periodic=False, seed=seed, **shape)


#: the large-grid scene's mean pressure over E* (against a rigid flat of E* = 1)
SCENE_PRESSURE = 0.01


def scene_topography(n: int, seed: int = 1, **shape):
    """:func:`scene_surface` as a Topography of unit side (spacing 1/n)."""
    import numpy as np

    from roughcontact.surfaces import Topography

    return Topography(np.asarray(scene_surface(n, seed, **shape).heights), 1.0 / n)


def scene_problem(topography, comm):
    """The scene's normal problem: ``topography`` against a rigid flat, E* = 1, FFT operator."""
    from roughcontact.materials import Interface, Material
    from roughcontact.normal import NormalProblem

    return NormalProblem(topography, Interface(Material(1.0, 0.0)), comm, operator="fft")


def solve_scene(problem, pressure: float = SCENE_PRESSURE, settings=None, gather: bool = True,
                free_rotation: bool = False):
    """One load-controlled CG solve of ``problem`` at ``pressure`` × its nominal area, rotation
    fixed (``free_rotation``: found from zero moments, as a study's default; ``settings``: a
    CGSettings, default the solver's; ``gather=False``: each rank keeps its own rows of the
    result's fields)."""
    from roughcontact.normal import make_solver

    options = {} if settings is None else {"settings": settings}
    with make_solver(problem, "cg", **options) as solver:
        return solver.solve_load(pressure * problem.topography.nominal_area,
                                 rotation=None if free_rotation else (0.0, 0.0), gather=gather)


def ensemble_task(levels: int, seed: int = 1):
    """An ensemble's task, as ``auto``'s crossovers measure it: (topography, interface, loads). A
    midpoint surface of 2^levels + 1 nodes a side (Δ = 2.3, rms height 10 µm, spacing 100 µm)
    between two rock half-spaces (E = 20 GPa, ν = 0.2), and 12 loads from 0.005 % to 0.5 % of
    E* A0 (the default study's range of contact), solved one after the other, warm-started."""
    from roughcontact.surfaces import midpoint_surface

    return _task(midpoint_surface(levels, 2.3, spacing=1e-4, rms_height=1e-5, seed=seed))


def fourier_task(n: int, seed: int = 1):
    """:func:`ensemble_task` on a grid of any ``n`` nodes a side: a non-periodic Fourier surface
    (Δ = 2.3, rms height 10 µm, spacing 100 µm), the same half-spaces and loads."""
    from roughcontact.surfaces import fourier_surface

    return _task(fourier_surface(n, 1e-4, fractal_dimension=2.3, rms_height=1e-5, periodic=False, seed=seed))


def _task(topo):
    """(topo, the rock interface, the 12 loads from 0.005 % to 0.5 % of E* A0)."""
    import numpy as np

    from roughcontact.materials import Interface, Material

    rock = Interface(Material(20e9, 0.2), Material(20e9, 0.2))
    loads = np.geomspace(5e-4, 5e-2, 12) * 0.1 * rock.contact_modulus * topo.nominal_area
    return topo, rock, loads


def alternated(ways, repeat: int) -> list:
    """The ways a benchmark compares in one process, in their order on even repeats and reversed on
    odd ones, so that each goes first by turns."""
    ways = list(ways)
    return ways if repeat % 2 == 0 else ways[::-1]


def ensemble_problem(levels: int, seed: int, comm):
    """(problem, loads): :func:`ensemble_task`'s surface as an FFT NormalProblem on ``comm``, its
    one-time set-up (the operator's symbol and its preconditioner) done by an untimed solve of the
    first load, so that the ways a benchmark compares start even; each solver still makes its own
    coarse levels, inside its first load's time."""
    from roughcontact.normal import NormalProblem, make_solver

    topo, rock, loads = ensemble_task(levels, seed)
    problem = NormalProblem(topo, rock, comm, operator="fft")
    with make_solver(problem, "cg") as solver:
        solver.solve_load(loads[0], gather=False)
    return problem, loads


def sweep_scene(n: int):
    """The tangential benchmarks' scene: (topography, interface, closure). A midpoint surface
    (Δ = 2.3, seed 7) cropped to n × n, between two identical ν = 0 half-spaces, and the
    closure that brings the highest 15 % of the heights into contact (about 1.4 % of the nodes
    touch at 513² after the deformation)."""
    import numpy as np

    from roughcontact.materials import Interface, Material
    from roughcontact.surfaces import Topography, midpoint_surface

    levels = int(np.ceil(np.log2(n - 1))) if n > 2 else 1
    full = midpoint_surface(levels, 2.3, spacing=1e-4, rms_height=1e-5, seed=7)
    topo = Topography(full.heights[:n, :n], full.spacing)
    heights = topo.heights.ravel()
    return topo, Interface(Material(20e9, 0.0), Material(20e9, 0.0)), float(heights.max() - np.quantile(heights, 0.85))
