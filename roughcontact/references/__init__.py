"""Closed-form references used to validate the solvers (Johnson, *Contact Mechanics*, 1985)."""
from . import cattaneo_mindlin, flat_punch, hertz

__all__ = ["hertz", "flat_punch", "cattaneo_mindlin"]
