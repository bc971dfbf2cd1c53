"""What ``operator="auto"`` and ``method="auto"`` pick: the cheapest setting, with the same answer.

Every operator applies the same Eq. 10 kernel and every method meets the
same contact conditions to the same tolerance, so the choice is one of cost
only, and it is recorded with each result (``NormalResult.operator``,
``.method`` and ``.choice``). Measured on one rank (scripts/bench_crossover.py,
scripts/bench_normal_large.py; see docs/solvers.md):

- **operator**: ``"fft-periodic"`` for a surface declared periodic whose
  footprint is the whole grid (one period of a periodic interface), else
  ``"fft"``. The explicit ``"dense"`` matrix was never more than ~10 %
  faster (17² to 65², where the FFT operator also builds explicit contact-set
  blocks) and 11 times slower at 129² (a 12-load sweep, the active set,
  76 s against 6.8 s); above that it does not fit in memory. It remains the
  reference operator, on request.
- **method**: the bound-constrained ``"cg"``. With the rotation fixed it was
  4 to 6 times faster than the active set (``"ksp"``) from 65² up; with the
  rotation free 1.3 to 2 times; at 17² and 33² with free rotation the active
  set was faster by 0.1 to 0.3 s per 12-load task, which does not justify a
  second default. ``"gauss-seidel"`` (the paper's) is a reference only.
  The stability map (scripts/bench_stability.py) found no region where the
  CG fails and another method converges.
"""
from __future__ import annotations

from ..errors import InputError

OPERATOR_KINDS = ("dense", "fft", "fft-periodic")


def choose_operator(topography, operator: str = "auto") -> tuple[str, str]:
    """(operator kind, why) for ``operator`` (``"auto"`` or a kind, kept as given)."""
    if operator != "auto":
        if operator not in OPERATOR_KINDS:
            raise InputError("operator", f"must be 'auto' or one of {', '.join(OPERATOR_KINDS)}, got {operator!r}")
        return operator, "given"
    periodic = bool(topography.metadata.get("periodic", False)) and bool(topography.footprint.all())
    if periodic:
        return "fft-periodic", "auto: the surface is declared periodic and fills its grid"
    return "fft", "auto: the matrix-free FFT operator (the cheapest at every grid measured)"


def choose_method(operator_kind: str, method: str = "auto") -> tuple[str, str]:
    """(method, why) for ``method`` (``"auto"`` or a method, kept as given) on ``operator_kind``."""
    from .solver import METHODS

    if method != "auto":
        if method not in METHODS:
            raise InputError("method", f"must be 'auto' or one of {', '.join(METHODS)}, got {method!r}")
        return method, "given"
    return "cg", "auto: bound-constrained CG (the fastest method measured, and the only one for 'fft-periodic')"
