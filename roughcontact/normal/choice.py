"""What ``operator="auto"`` and ``method="auto"`` pick: the cheapest setting, with the same answer.

Every operator applies the same Eq. 10 kernel and every method meets the
same contact conditions to the same tolerance, so the choice is one of cost
only, and it is recorded with each result (``NormalResult.operator``,
``.method`` and ``.choice``). Measured on one rank (benchmarks/bench_crossover.py,
benchmarks/bench_normal_large.py; see docs/solvers.md, last measured with
the free rotation found with the forces on every level):

- **operator**: ``"fft-periodic"`` for a surface declared periodic whose
  footprint is the whole grid (one period of a periodic interface); the
  explicit ``"dense"`` matrix up to :data:`DENSE_NODES` footprint nodes
  (44², where the active set is taken and its explicit blocks make it
  faster than on the FFT operator: a 12-load task on 33², 0.13–0.14 s
  against 0.27–0.28 s with the rotation free, 0.09 against 0.17–0.19 s
  fixed); ``"fft"`` above: with the CG the FFT operator is as fast as the
  dense matrix at 46²–48² and faster from 56² (0.17–0.22 against
  0.19–0.25 s free at 56², 0.21–0.24 against 0.25–0.31 s at 65²), and the
  dense matrix does not fit in memory beyond ~192².
- **method**: the active set (``"ksp"``) up to :data:`ACTIVE_SET_NODES`
  footprint nodes (44²), the bound-constrained ``"cg"`` above, and always
  on ``"fft-periodic"``. A 12-load task's time on the active set (dense)
  over the CG's (FFT), medians over surfaces and rotations: 0.68 at 33²,
  0.75 / 0.84 / 0.86 at 36² / 40² / 42², 0.97 at 44² (0.67–1.22), 1.18 at
  46² and 48², 4.1 at 56², 4.9 at 65² (``python -m
  benchmarks.bench_crossover --levels 5 6 --sizes 40 44 48 56 --seeds 1 2``
  and ``--levels --sizes 36 42 44 46 --seeds 1 2 3``, medians of 5; the
  CG with the smooth extension from 16², docs/solvers.md). ``"gauss-seidel"``
  (the paper's) is a reference only. The stability map
  (benchmarks/bench_stability.py) found no case, 64² to 1024², where the CG
  or the active set fails.
"""
from __future__ import annotations

from ..errors import InputError
from ..operators.memory import KINDS

#: The normal methods: the active set with Krylov or Gauss–Seidel inner solves, the bound-constrained CG.
METHODS = ("ksp", "gauss-seidel", "cg")
#: The methods of the active-set solver (they read PETSc options under a prefix).
ACTIVE_SET_METHODS = ("ksp", "gauss-seidel")

#: Footprint nodes up to which ``operator="auto"`` takes the explicit matrix.
DENSE_NODES = 44 * 44
#: Footprint nodes up to which ``method="auto"`` takes the active set.
ACTIVE_SET_NODES = 44 * 44


def auto_operator(nodes: int, periodic: bool) -> tuple[str, str]:
    """(operator kind, why) that ``"auto"`` picks for ``nodes`` footprint nodes."""
    if periodic:
        return "fft-periodic", "auto: the surface is declared periodic and fills its grid"
    if nodes <= DENSE_NODES:
        return "dense", f"auto: the explicit matrix (the cheapest measured up to {DENSE_NODES} nodes)"
    return "fft", f"auto: the matrix-free FFT operator (the cheapest measured above {DENSE_NODES} nodes)"


def choose_operator(topography, operator: str = "auto") -> tuple[str, str]:
    """(operator kind, why) for ``operator`` (``"auto"`` or a kind, kept as given)."""
    if operator != "auto":
        if operator not in KINDS:
            raise InputError("operator", f"must be 'auto' or one of {', '.join(KINDS)}, got {operator!r}")
        return operator, "given"
    nodes = topography.footprint_nodes
    periodic = bool(topography.metadata.get("periodic", False)) and nodes == topography.shape[0] * topography.shape[1]
    return auto_operator(nodes, periodic)


def choose_method(operator_kind: str, nodes: int, method: str = "auto") -> tuple[str, str]:
    """(method, why) for ``method`` (``"auto"`` or a method, kept as given) on ``operator_kind``
    over ``nodes`` footprint nodes."""
    if method != "auto":
        if method not in METHODS:
            raise InputError("method", f"must be 'auto' or one of {', '.join(METHODS)}, got {method!r}")
        return method, "given"
    if operator_kind.startswith("user"):
        return "ksp", "auto: the active set (the CG's Fourier preconditioner needs a kernel, not a user's Mat)"
    if operator_kind == "fft-periodic":
        return "cg", "auto: bound-constrained CG (the only method for 'fft-periodic')"
    if nodes <= ACTIVE_SET_NODES:
        return "ksp", f"auto: the active set (the fastest measured up to {ACTIVE_SET_NODES} nodes)"
    return "cg", f"auto: bound-constrained CG (the fastest measured above {ACTIVE_SET_NODES} nodes)"
