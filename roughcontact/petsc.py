"""PETSc glue every package shares: options under a prefix, checked Krylov solves.

Solvers set their defaults in code, then read the options database under
their prefix (``normal_``, ``cattaneo_``, ``coupled_``); :class:`OptionsScope`
inserts a solver's own options for its lifetime and removes them after.
:func:`solve_checked` is the one warm-started Krylov solve of the package:
it checks the converged reason after every solve, and a negative reason
raises :class:`~roughcontact.errors.ConvergenceError` naming it (silent
non-convergence is the commonest defect of contact codes).
"""
from __future__ import annotations

from petsc4py import PETSc

from .errors import ConvergenceError

_REASONS = {getattr(PETSc.KSP.ConvergedReason, k): k
            for k in dir(PETSc.KSP.ConvergedReason) if k.isupper()}


def ksp_reason_name(reason: int) -> str:
    """The name of a KSPConvergedReason value, e.g. ``DIVERGED_ITS``."""
    return _REASONS.get(int(reason), str(int(reason)))


def solve_checked(ksp, mat, b, x, r, what: str) -> int:
    """Solve ``mat`` x = b from the guess in ``x``; a negative converged reason raises.

    A warm start worse than zero (a much smaller load, a receding set) is
    dropped: CG would otherwise start from a residual far above |b| and may
    stop on PETSc's divergence test before its first iteration. A zero
    guess (given, or dropped) takes no product: the check is skipped and the
    KSP is told its guess is zero for this solve, so its first residual is b
    itself (the same residual, bit for bit, as b − A 0; the free rotation's
    Hessians start 8 of their 10 solves from zero near full contact at
    1024², each a product of H_SS twice before). ``r`` is a work vector;
    ``what`` names the solve in the error.

    Returns
    -------
    int
        The Krylov iterations.

    Raises
    ------
    ConvergenceError
        Named ``KSP_<reason>`` when the KSP diverged.
    """
    zero = x.norm() == 0.0
    if not zero:
        mat.mult(x, r)
        r.aypx(-1.0, b)
        if r.norm() > b.norm():
            x.set(0.0)
            zero = True
    if zero and ksp.getInitialGuessNonzero():
        ksp.setInitialGuessNonzero(False)
        try:
            ksp.solve(b, x)
        finally:
            ksp.setInitialGuessNonzero(True)
    else:
        ksp.solve(b, x)
    reason = ksp.getConvergedReason()
    its = ksp.getIterationNumber()
    if reason < 0:
        prefix = ksp.getOptionsPrefix() or ""
        raise ConvergenceError(
            "KSP_" + ksp_reason_name(reason),
            f"{what} stopped after {its} iterations with residual norm {ksp.getResidualNorm():.3e}; "
            f"raise -{prefix}ksp_max_it or loosen -{prefix}ksp_rtol")
    return its


class OptionsScope:
    """Insert options under a prefix for the life of an object, then remove them."""

    def __init__(self, prefix: str, options: dict | None):
        self.prefix = prefix
        self.keys = []
        db = PETSc.Options()
        for key, value in (options or {}).items():
            name = prefix + key.lstrip("-")
            db.setValue(name, "" if value is None else str(value))
            self.keys.append(name)

    def close(self) -> None:
        db = PETSc.Options()
        for name in self.keys:
            db.delValue(name)
        self.keys = []
