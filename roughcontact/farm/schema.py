"""Type checks of study tables: one-line :class:`InputError` s naming the key, never a traceback.

TOML already distinguishes numbers, strings, booleans, arrays and tables;
these checks make sure each key gets the kind it needs (``spacing = "1e-4"``
is refused, not converted) before any value reaches a generator or solver.
"""
from __future__ import annotations

import inspect
import math
from typing import Any

from ..errors import InputError

#: the kinds a surface argument can take, read from the generators' annotations
#: (``"float | None"`` → ``{"float"}``); keys without an annotation are listed here
_KIND_OF_KEY = {
    "spacing": {"float"},
    "shape": {"int", "pair"},
    "path": {"str"},
    "mate_shift": {"vector"},
    "footprint_diameter": {"float"},
    "detrend": {"str"},
    "coarsening": {"int"},
}


def only(table: dict, allowed: set[str], where: str) -> None:
    """:class:`InputError` naming the first key of ``table`` not in ``allowed``."""
    unknown = sorted(set(table) - set(allowed))
    if unknown:
        raise InputError(f"{where}.{unknown[0]}", f"unknown key; allowed: {', '.join(sorted(allowed))}")


def section(raw: dict, name: str) -> dict:
    """The table ``raw[name]`` (empty if absent), or :class:`InputError` if it is not a table."""
    value = raw.get(name, {})
    if not isinstance(value, dict):
        raise InputError(name, f"must be a table, got {_kind(value)} {value!r}")
    return value


def number(where: str, value, minimum: float | None = None, positive: bool = False) -> float:
    """A finite int or float (not a string, not a boolean)."""
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        raise InputError(where, f"must be a number, got {_kind(value)} {value!r}")
    if not math.isfinite(value):
        raise InputError(where, f"must be finite, got {value!r}")
    if positive and not value > 0:
        raise InputError(where, f"must be > 0, got {value!r}")
    if minimum is not None and value < minimum:
        raise InputError(where, f"must be >= {minimum:g}, got {value!r}")
    return float(value)


def integer(where: str, value, minimum: int | None = None) -> int:
    """A TOML integer (``6``, not ``6.0`` nor ``"6"``)."""
    if isinstance(value, bool) or not isinstance(value, int):
        raise InputError(where, f"must be an integer, got {_kind(value)} {value!r}")
    if minimum is not None and value < minimum:
        raise InputError(where, f"must be >= {minimum}, got {value!r}")
    return value


def string(where: str, value) -> str:
    """A string."""
    if not isinstance(value, str):
        raise InputError(where, f"must be a string, got {_kind(value)} {value!r}")
    return value


def array(where: str, value, nonempty: bool = True) -> list:
    """A TOML array."""
    if not isinstance(value, list):
        raise InputError(where, f"must be a list, got {_kind(value)} {value!r}")
    if nonempty and not value:
        raise InputError(where, "is empty")
    return value


def increasing_numbers(where: str, value, unit: str) -> tuple[float, ...]:
    """A non-empty increasing list of numbers >= 0 (loads, pressures)."""
    values = [number(where, v, minimum=0.0) for v in array(where, value)]
    if any(b < a for a, b in zip(values, values[1:])):
        raise InputError(where, f"must be increasing (each is warm-started from the last), got {value!r} {unit}")
    return tuple(values)


def surface_value(where: str, key: str, value, function) -> None:
    """Check the kind of a surface argument against the generator's annotation."""
    kinds = _KIND_OF_KEY.get(key) or _annotated_kinds(function, key)
    if not kinds:
        return
    if "vector" in kinds:
        if not (isinstance(value, list) and len(value) == 2):
            raise InputError(where, f"must be a pair [x, y] in metres, got {_kind(value)} {value!r}")
        for v in value:
            number(where, v)
        return
    if "pair" in kinds and isinstance(value, list):
        if len(value) != 2:
            raise InputError(where, f"must be an integer or a pair of integers, got {value!r}")
        for v in value:
            integer(where, v, minimum=1)
        return
    checks = [("bool", lambda: isinstance(value, bool)),
              ("int", lambda: isinstance(value, int) and not isinstance(value, bool)),
              ("float", lambda: isinstance(value, (int, float)) and not isinstance(value, bool)),
              ("str", lambda: isinstance(value, str))]
    if not any(kind in kinds and ok() for kind, ok in checks):
        wanted = " or ".join(_NAMES[k] for k in ("float", "int", "bool", "str", "pair") if k in kinds)
        raise InputError(where, f"must be {wanted}, got {_kind(value)} {value!r}")


_NAMES = {"float": "a number", "int": "an integer", "bool": "true or false", "str": "a string",
          "pair": "a pair of integers"}


def _annotated_kinds(function, key: str) -> set[str]:
    parameter = inspect.signature(function).parameters.get(key)
    if parameter is None or parameter.annotation is inspect.Parameter.empty:
        return set()
    annotation = parameter.annotation if isinstance(parameter.annotation, str) else str(parameter.annotation)
    return {part.strip() for part in annotation.split("|")} & {"int", "float", "bool", "str"}


def _kind(value: Any) -> str:
    return {bool: "boolean", int: "integer", float: "number", str: "string", list: "list",
            dict: "table"}.get(type(value), type(value).__name__)
