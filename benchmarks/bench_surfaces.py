"""Benchmark of the surface generators: wall time and peak memory at 1024² and 4096².

Usage::

    python -m benchmarks.bench_surfaces [--sizes 1024 4096] [--repeats 5 3] [--output results/bench_surfaces.json]

For each generator and size, the time is the median of ``repeats`` runs
(``time.perf_counter``) and the memory is the peak of Python-visible
allocations during one further run (``tracemalloc``, which sees NumPy's
buffers), i.e. the working memory of the generator including its result.
Midpoint displacement works on 2**k + 1 nodes a side, so "1024" means 1025²
for it. Serial, one process; the figures go to a JSON file.
"""
from __future__ import annotations

import argparse
import gc
import json
import os
import platform
import statistics
import time
import tracemalloc
from datetime import datetime, timezone
from pathlib import Path

import numpy as np

from roughcontact import __version__
from roughcontact.surfaces import fourier_surface, midpoint_surface


def generators(n: int):
    levels = int(round(np.log2(n)))
    return {
        "midpoint": lambda: midpoint_surface(levels, 2.3, 1e-4, rms_height=1e-5, seed=1),
        "midpoint+additions": lambda: midpoint_surface(levels, 2.3, 1e-4, rms_height=1e-5, seed=1,
                                                       random_additions=True),
        "fourier periodic": lambda: fourier_surface(n, 1e-4, fractal_dimension=2.3, rms_height=1e-5, seed=1),
        "fourier non-periodic": lambda: fourier_surface(n, 1e-4, fractal_dimension=2.3, rms_height=1e-5, seed=1,
                                                        periodic=False),
    }


def measure(make, repeats: int) -> dict:
    times = []
    for _ in range(repeats):
        gc.collect()
        start = time.perf_counter()
        surface = make()
        times.append(time.perf_counter() - start)
        shape = surface.shape
        del surface
    gc.collect()
    tracemalloc.start()
    surface = make()
    _, peak = tracemalloc.get_traced_memory()
    tracemalloc.stop()
    result_bytes = surface.heights.nbytes + surface.footprint.nbytes
    del surface
    return dict(shape=list(shape), repeats=repeats, time_median_s=statistics.median(times),
                time_min_s=min(times), time_max_s=max(times),
                peak_memory_MiB=peak / 2**20, result_MiB=result_bytes / 2**20)


def main(argv=None) -> dict:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--sizes", type=int, nargs="+", default=[1024, 4096])
    parser.add_argument("--repeats", type=int, nargs="+", default=[5, 3],
                        help="repeats per size (one value for all sizes, or one per size)")
    parser.add_argument("--output", type=Path, default=Path("results") / "bench_surfaces.json")
    args = parser.parse_args(argv)
    repeats = args.repeats * len(args.sizes) if len(args.repeats) == 1 else args.repeats
    if len(repeats) != len(args.sizes):
        parser.error("--repeats takes one value or one per size")
    cases = []
    for n, r in zip(args.sizes, repeats):
        for name, make in generators(n).items():
            figures = measure(make, r)
            cases.append(dict(generator=name, size=n, **figures))
            print(f"{name:22s} {figures['shape'][0]:5d}²  median {figures['time_median_s']:8.3f} s  "
                  f"peak {figures['peak_memory_MiB']:8.1f} MiB  (result {figures['result_MiB']:.1f} MiB)",
                  flush=True)
    report = dict(
        benchmark="surface generation", roughcontact=__version__, numpy=np.__version__,
        python=platform.python_version(), machine=platform.machine(), cpus=os.cpu_count(),
        date=datetime.now(timezone.utc).isoformat(timespec="seconds"),
        method="median wall time of repeats (perf_counter); peak of tracemalloc over one extra run",
        cases=cases)
    args.output.parent.mkdir(parents=True, exist_ok=True)
    args.output.write_text(json.dumps(report, indent=2) + "\n")
    print(f"written {args.output}")
    return report


if __name__ == "__main__":
    main()
