"""Objects holding PETSc resources, freed collectively by ``destroy()`` or a ``with`` block."""
from __future__ import annotations

from .errors import RoughContactError


class DestroyedError(RoughContactError, RuntimeError):
    """An object was used after ``destroy()`` (or after its ``with`` block ended)."""


class Collective:
    """Base of objects that own PETSc objects: ``with Solver(...) as s:`` destroys on exit.

    ``destroy`` is collective over the object's communicator, so every rank
    must leave the block (exceptions raised by this package are raised on
    every rank, after the reductions that detect them). It may be called
    more than once; any later use raises :class:`DestroyedError` instead of
    failing deep inside PETSc.
    """

    _destroyed = False

    def destroy(self) -> None:
        """Free the PETSc objects (collective); later calls do nothing."""
        if not self._destroyed:
            self._destroyed = True
            self._release()

    def _release(self) -> None:  # pragma: no cover - overridden
        raise NotImplementedError

    def _check_alive(self) -> None:
        if self._destroyed:
            raise DestroyedError(f"this {type(self).__name__} was destroyed (its `with` block ended or "
                                 "destroy() was called); create a new one")

    def __enter__(self):
        self._check_alive()
        return self

    def __exit__(self, *exc):
        self.destroy()
