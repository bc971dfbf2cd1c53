"""Objects holding PETSc resources, freed collectively by ``destroy()`` or a ``with`` block."""
from __future__ import annotations


class Collective:
    """Base of solvers that own PETSc objects: ``with Solver(...) as s:`` destroys on exit.

    ``destroy`` is collective over the solver's communicator, so every rank
    must leave the block (exceptions raised by this package are raised on
    every rank, after the reductions that detect them).
    """

    def destroy(self) -> None:  # pragma: no cover - overridden
        raise NotImplementedError

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.destroy()
