"""Study axes: the parameters an ensemble varies, and the tasks their product (or zip) defines.

An axis is a surface argument (``seed``, ``fractal_dimension``, ``levels``,
``spacing``, ``mate_shift``, ``coarsening``, ``path``, …) or ``materials``
with a list of values. Axes named together in ``zip`` vary together and share
one dimension, named after the first of them; all dimensions are then
combined as a product, in the order the axes are declared. Each position in
that product is one task.
"""
from __future__ import annotations

import itertools
from dataclasses import dataclass
from typing import Any

import numpy as np

from ..checks import check_fractal_dimension, check_integer, check_seed, check_vector, require_finite_positive
from ..errors import InputError
from . import schema

#: the dimension an axis names in the datasets, when it differs from its key
DIMENSION_OF = {"mate_shift": "shift"}

#: units and long names of axis coordinates (CF attributes)
COORDINATE_ATTRS = {
    "seed": ("1", "seed of the random surface"),
    "fractal_dimension": ("1", "fractal dimension Δ of the surface"),
    "hurst": ("1", "Hurst exponent H = 3 − Δ"),
    "levels": ("1", "refinement levels, (2^levels + 1)² nodes"),
    "spacing": ("m", "grid spacing s"),
    "coarsening": ("1", "decimation factor of the surface (spacing × factor)"),
    "rms_height": ("m", "rms height Sq of the surface"),
    "rms_slope": ("1", "rms slope Sdq of the surface"),
    "footprint_diameter": ("m", "diameter of the disc footprint"),
    "shift_x": ("m", "x of the mated shift v (Fig. 7)"),
    "shift_y": ("m", "y of the mated shift v (Fig. 7)"),
}

# value checks of axis values, before any surface is built (a generator checks the rest)
_VALUE_CHECKS = {
    "fractal_dimension": check_fractal_dimension,
    "seed": check_seed,
    "levels": lambda v: check_integer("levels", v, 1, 14),
    "coarsening": lambda v: check_integer("coarsening", v, 1),
    "spacing": lambda v: require_finite_positive("spacing", v),
    "rms_height": lambda v: require_finite_positive("rms_height", v),
    "rms_slope": lambda v: require_finite_positive("rms_slope", v),
    "footprint_diameter": lambda v: require_finite_positive("footprint_diameter", v),
    "mate_shift": lambda v: check_vector("mate_shift", v),
}


@dataclass(frozen=True)
class Axis:
    """One varied parameter: its key and its values (materials as ``Interface`` objects)."""

    key: str
    values: tuple

    def coords(self, dim: str) -> dict[str, tuple]:
        """xarray coordinates of this axis along ``dim`` (CF attributes)."""
        if self.key == "materials":
            bodies = [(i.body1, i.body2) for i in self.values]
            return {f"{q}{b + 1}": (dim, np.array([getattr(pair[b], q) for pair in bodies]),
                                    {"units": "Pa" if q == "E" else "1",
                                     "long_name": f"{'Young modulus' if q == 'E' else 'Poisson ratio'} "
                                                  f"of body {b + 1}"})
                    for b in (0, 1) for q in ("E", "nu")}
        name = DIMENSION_OF.get(self.key, self.key)
        if isinstance(self.values[0], (tuple, list)):
            return {f"{name}_{c}": (dim, np.array([float(v[i]) for v in self.values]), _attrs(f"{name}_{c}"))
                    for i, c in enumerate("xy")}
        return {name: (dim, np.array(self.values), _attrs(name))}


@dataclass(frozen=True)
class Dimension:
    """A study dimension: one axis, or several zipped together."""

    name: str
    axes: tuple[Axis, ...]

    @property
    def size(self) -> int:
        return len(self.axes[0].values)

    def coords(self) -> dict[str, tuple]:
        out = {}
        for axis in self.axes:
            out.update(axis.coords(self.name))
        return out


def parse_axes(table: dict, surface_keys: set[str], check_surface_value, parse_interface) -> tuple[Dimension, ...]:
    """The study's dimensions from its ``[axes]`` table.

    ``surface_keys`` are the keys an axis may vary, ``check_surface_value(where,
    key, value)`` checks the kind of one value; ``parse_interface(where, spec)``
    turns a ``{body1, body2}`` table into an :class:`~roughcontact.materials.Interface`.
    """
    if "seeds" in table and "seed" in table:
        raise InputError("axes.seeds", "give either seeds (a count: 1 … n) or seed (a list), not both")
    table = {("seed" if k == "seeds" else k):
             (list(range(1, schema.integer("axes.seeds", v, minimum=1) + 1)) if k == "seeds" else v)
             for k, v in table.items()}
    groups = _zip_groups(table.pop("zip", []))
    schema.only(table, surface_keys | {"materials"}, "axes")
    axes = {}
    for key, raw in table.items():
        where = f"axes.{key}"
        values = schema.array(where, raw)
        if key == "materials":
            values = [parse_interface(f"{where}[{i}]", v) for i, v in enumerate(values)]
        else:
            for i, value in enumerate(values):
                check_surface_value(f"{where}[{i}]", key, value)
                check_value(f"{where}[{i}]", key, value)
            values = [tuple(v) if isinstance(v, list) else v for v in values]
        axes[key] = Axis(key, tuple(values))
    for group in groups:
        for key in group:
            if key not in axes:
                raise InputError("axes.zip", f"{key!r} is not an axis of the study")
        sizes = {key: axes[key].values.__len__() for key in group}
        if len(set(sizes.values())) > 1:
            raise InputError("axes.zip", f"zipped axes must have equal lengths, got {sizes}")
    zipped = {key: group for group in groups for key in group}
    dimensions, seen = [], set()
    for key in axes:
        if key in seen:
            continue
        group = zipped.get(key, (key,))
        seen.update(group)
        dimensions.append(Dimension(DIMENSION_OF.get(group[0], group[0]), tuple(axes[k] for k in group)))
    return tuple(dimensions)


def positions(dimensions: tuple[Dimension, ...]):
    """Every position (one index per dimension) in row-major order, with its parameters."""
    for position in itertools.product(*(range(d.size) for d in dimensions)):
        values: dict[str, Any] = {}
        for index, dim in zip(position, dimensions):
            for axis in dim.axes:
                values[axis.key] = axis.values[index]
        yield position, values


def _zip_groups(raw) -> list[tuple[str, ...]]:
    groups = schema.array("axes.zip", raw, nonempty=False)
    if groups and all(isinstance(g, str) for g in groups):
        groups = [groups]
    out, seen = [], set()
    for group in groups:
        names = schema.array("axes.zip", group)
        for name in names:
            schema.string("axes.zip", name)
            if name in seen:
                raise InputError("axes.zip", f"{name!r} appears in more than one zip group")
            seen.add(name)
        out.append(tuple(names))
    return out


def check_value(where: str, key: str, value) -> None:
    """The range checks of a surface argument the farm knows (the generator checks the rest)."""
    check = _VALUE_CHECKS.get(key)
    if check is None:
        return
    try:
        check(value)
    except InputError as exc:
        raise InputError(where, str(exc).split(": ", 1)[1]) from None


def _attrs(name: str) -> dict:
    units, long_name = COORDINATE_ATTRS.get(name, ("", name.replace("_", " ")))
    return {"units": units, "long_name": long_name} if units else {"long_name": long_name}
