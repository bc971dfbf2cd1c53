"""Length units of measured files, converted to SI metres."""
from __future__ import annotations

from ..errors import InputError

#: Metres per unit, for the unit names instrument files use.
LENGTH_UNITS = {
    "km": 1e3, "m": 1.0, "cm": 1e-2, "mm": 1e-3,
    "µm": 1e-6, "μm": 1e-6, "um": 1e-6, "micron": 1e-6, "microns": 1e-6,
    "nm": 1e-9, "Å": 1e-10, "A": 1e-10, "angstrom": 1e-10, "pm": 1e-12,
}


def metres_per(unit: str, parameter: str = "unit") -> float:
    """Metres in one ``unit`` (e.g. ``"mm"`` gives 1e-3)."""
    key = unit.strip() if isinstance(unit, str) else unit
    if key not in LENGTH_UNITS:
        raise InputError(parameter, f"unknown length unit {unit!r}; known: {', '.join(sorted(set(LENGTH_UNITS)))}")
    return LENGTH_UNITS[key]
