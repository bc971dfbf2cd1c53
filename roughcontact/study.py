"""Study definitions: what to solve, read from TOML files (see ``studies/``).

A study names a surface, the two materials and the loading. Unknown keys are
errors naming the key, so a typo never silently falls back to a default.

Example (the built-in default, also in ``studies/fractal_load_sweep.toml``)::

    name = "fractal-load-sweep"
    [surface]
    generator = "midpoint"          # random midpoint displacement (§3.3)
    levels = 6                      # 65 x 65 nodes
    fractal_dimension = 2.3
    spacing = 1e-4                  # m
    rms_height = 1e-5               # m
    seed = 1
    [materials]
    body1 = { E = 20e9, nu = 0.2 }
    body2 = { E = 20e9, nu = 0.2 }  # omit for a rigid flat
    [normal]
    loads = [20.0, 40.0, ...]       # N, increasing
    method = "ksp"                  # or "gauss-seidel"

``surface.generator`` is ``"midpoint"``, ``"fourier"`` or ``"file"``; the
other keys of the table are that function's arguments
(:func:`~roughcontact.surfaces.midpoint_surface`,
:func:`~roughcontact.surfaces.fourier_surface`,
:func:`~roughcontact.surfaces.read_topography`, whose ``path`` is relative
to the study file), plus ``detrend`` ("mean" or "plane"),
``footprint_diameter`` (m, a cylindrical specimen) and ``mate_shift``
([vx, vy] in m: the composite of the face and its mate shifted by v, Fig. 7).
"""
from __future__ import annotations

import inspect
import tomllib
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from .errors import InputError
from .materials import Interface, Material
from .surfaces.topography import Topography

DEFAULT_STUDY: dict[str, Any] = {
    "name": "fractal-load-sweep",
    "description": "normal-contact load sweep of a random-midpoint-displacement surface "
                   "(Delta = 2.3) between two sandstone-like half-spaces",
    "surface": {"generator": "midpoint", "levels": 6, "fractal_dimension": 2.3,
                "spacing": 1e-4, "rms_height": 1e-5, "seed": 1},
    "materials": {"body1": {"E": 20e9, "nu": 0.2}, "body2": {"E": 20e9, "nu": 0.2}},
    "normal": {"loads": [float(p) for p in np.linspace(25.0, 500.0, 12)], "method": "ksp"},
}

# keys every surface table accepts besides its generator's own arguments
_COMMON_SURFACE_KEYS = {"generator", "detrend", "mate_shift", "footprint_diameter"}


def _generators() -> dict[str, Any]:
    from .surfaces import fourier_surface, midpoint_surface, read_topography

    return {"midpoint": midpoint_surface, "fourier": fourier_surface, "file": read_topography}


def _parameters(function) -> set[str]:
    return set(inspect.signature(function).parameters)


@dataclass(frozen=True)
class Study:
    """A validated study definition."""

    name: str
    surface: dict[str, Any]
    interface: Interface
    loads: tuple[float, ...]
    method: str = "ksp"
    description: str = ""
    base_dir: Path | None = None
    raw: dict[str, Any] = field(default_factory=dict)

    def topography(self) -> Topography:
        """Build the composite topography Δh (identical on every rank).

        Steps, each optional after the first: generate or read the surface;
        detrend it; form the composite with its mate shifted by v (Fig. 7);
        restrict it to a disc footprint (a cylindrical specimen, §3.4).
        """
        from .surfaces import detrend, disc, mated_composite

        spec = dict(self.surface)
        generator = spec.pop("generator")
        mode = spec.pop("detrend", None)
        shift = spec.pop("mate_shift", None)
        diameter = spec.pop("footprint_diameter", None)
        if generator == "file" and self.base_dir is not None and "path" in spec:
            spec["path"] = str(self.base_dir / spec["path"])
        function = _generators()[generator]
        try:
            inspect.signature(function).bind(**spec)
        except TypeError as exc:   # a missing required key
            raise InputError(f"surface ({generator})", str(exc)) from None
        topography = function(**spec)
        if mode is not None:
            topography = detrend(topography, mode)
        if diameter is not None:
            topography = topography.with_footprint(
                topography.footprint & disc(topography.shape, topography.spacing, diameter))
        if shift is not None:
            topography = mated_composite(topography, tuple(shift))
        return topography


def load_study(source: str | Path | dict | None = None) -> Study:
    """A :class:`Study` from a TOML path, a dict, or the built-in default (None)."""
    base_dir = None
    if source is None:
        raw = DEFAULT_STUDY
    elif isinstance(source, dict):
        raw = source
    else:
        path = Path(source)
        base_dir = path.resolve().parent
        if not path.is_file():
            raise InputError("study", f"no study file at {path}")
        try:
            raw = tomllib.loads(path.read_text())
        except (tomllib.TOMLDecodeError, UnicodeDecodeError) as exc:
            raise InputError("study", f"{path} is not valid TOML: {exc}") from None
    _only(raw, {"name", "description", "surface", "materials", "normal"}, "study")
    surface = dict(_section(raw, "surface"))
    generator = surface.get("generator", "midpoint")
    generators = _generators()
    if generator not in generators:
        raise InputError("surface.generator", f"must be one of {sorted(generators)}, got {generator!r}")
    surface["generator"] = generator
    _only(surface, _parameters(generators[generator]) | _COMMON_SURFACE_KEYS, "surface")
    materials = _section(raw, "materials")
    _only(materials, {"body1", "body2"}, "materials")
    bodies = []
    for name in ("body1", "body2"):
        spec = materials.get(name)
        if spec is None:
            if name == "body1":
                raise InputError("materials.body1", "is required")
            bodies.append(Material.rigid())
            continue
        _only(spec, {"E", "nu"}, f"materials.{name}")
        try:
            bodies.append(Material(spec["E"], spec["nu"]))
        except KeyError as exc:
            raise InputError(f"materials.{name}.{exc.args[0]}", "is required") from None
        except InputError as exc:
            raise InputError(f"materials.{name}.{exc.parameter}", str(exc).split(": ", 1)[1]) from None
    normal = _section(raw, "normal")
    _only(normal, {"loads", "method"}, "normal")
    loads = np.asarray(normal.get("loads", []), dtype=float).ravel()
    if loads.size == 0 or not np.all(np.isfinite(loads)) or np.any(loads < 0) or np.any(np.diff(loads) < 0):
        raise InputError("normal.loads", "must be a non-empty increasing list of loads >= 0 (N)")
    return Study(name=str(raw.get("name", "study")), surface=surface,
                 interface=Interface(bodies[0], bodies[1]), loads=tuple(loads.tolist()),
                 method=str(normal.get("method", "ksp")), description=str(raw.get("description", "")),
                 base_dir=base_dir, raw=raw)


def _section(raw: dict, name: str) -> dict:
    value = raw.get(name, {})
    if not isinstance(value, dict):
        raise InputError(name, f"must be a table, got {type(value).__name__}")
    return value


def _only(table: dict, allowed: set[str], where: str) -> None:
    unknown = sorted(set(table) - allowed)
    if unknown:
        raise InputError(f"{where}.{unknown[0]}", f"unknown key; allowed: {', '.join(sorted(allowed))}")
