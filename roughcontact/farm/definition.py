"""Study definitions: what to solve, read from TOML files (see ``studies/`` and docs/studies.md).

A study names a surface, the two materials and the loading, and the
**axes** it varies; their product (or zip) is the list of tasks. A study
without axes is one task. Everything is validated before any solve:
unknown keys, wrong kinds of values and empty axes are :class:`InputError` s
naming the key, so a typo never silently falls back to a default.

Example (the built-in default, also ``studies/fractal_ensemble.toml``)::

    name = "fractal-ensemble"
    [surface]
    generator = "midpoint"          # random midpoint displacement (§3.3)
    levels = 6                      # 65 x 65 nodes
    spacing = 1e-4                  # m
    rms_height = 1e-5               # m
    [axes]
    fractal_dimension = [2.1, 2.3, 2.5]
    seeds = 8                       # seed = 1 … 8
    [materials]
    body1 = { E = 20e9, nu = 0.2 }
    body2 = { E = 20e9, nu = 0.2 }  # omit for a rigid flat
    [normal]
    loads = [25.0, 68.2, ...]       # N, increasing; or pressures = [...] (Pa, σ0 = P/A0),
                                    # or closures = [...] (m, δz from first touch)
    rotation = "free"               # θ from zero moments; or [θx, θy] (rad) fixed
    [output]
    fields = "all"                  # "none" | "contact" | "force" | "all"

A ``[tangential]`` table adds Q sweeps (and one fretting cycle) at some
loads, a ``[fretting]`` table the fretting map: one cycle at each of
several amplitudes, energy per cycle against amplitude
(``studies/fretting_map.toml``).
"""
from __future__ import annotations

import hashlib
import inspect
import json
import re
from dataclasses import asdict, dataclass, field, replace
from pathlib import Path
from typing import Any

import numpy as np
import tomllib

from ..checks import check_choice
from ..datasets import check_fields
from ..errors import InputError
from ..materials import Interface, Material
from ..tangential.checks import check_amplitudes
from . import schema
from .axes import Dimension, check_value, parse_axes, positions
from .task import FrettingOptions, Loading, NormalOptions, TangentialOptions, Task, generators

DEFAULT_STUDY: dict[str, Any] = {
    "name": "fractal-ensemble",
    "description": "normal-contact load sweeps of random-midpoint-displacement surfaces, "
                   "Delta = 2.1, 2.3, 2.5 x 8 seeds, between two sandstone-like half-spaces (Fig. 5a)",
    "surface": {"generator": "midpoint", "levels": 6, "spacing": 1e-4, "rms_height": 1e-5},
    "axes": {"fractal_dimension": [2.1, 2.3, 2.5], "seeds": 8},
    "materials": {"body1": {"E": 20e9, "nu": 0.2}, "body2": {"E": 20e9, "nu": 0.2}},
    "normal": {"loads": [round(float(p), 1) for p in np.linspace(25.0, 500.0, 12)], "method": "auto"},
    "output": {"fields": "all"},
}

#: keys every surface table accepts besides its generator's own arguments
COMMON_SURFACE_KEYS = {"generator", "detrend", "mate_shift", "footprint_diameter", "coarsening"}
_TABLES = {"name", "description", "surface", "axes", "materials", "normal", "tangential", "fretting", "output",
           "farm"}
_SAFE_NAME = re.compile(r"^[A-Za-z0-9][A-Za-z0-9._-]*$")


@dataclass(frozen=True)
class Study(Loading):
    """A validated study definition: the tasks, how they are solved (:class:`~.task.Loading`,
    the same for every task) and what is stored."""

    name: str
    surface: dict[str, Any]
    dimensions: tuple[Dimension, ...]
    interface: Interface | None
    ranks_per_task: int = 1
    root_works: bool = True             # rank 0 solves tasks too while it hands them out
    task_timeout: float | None = None   # s: a task still running then stops at its next load (failed)
    description: str = ""
    text: str = ""
    definition: str = ""
    base_dir: Path | None = None
    file_hashes: dict[str, str] = field(default_factory=dict, compare=False)

    @property
    def identity(self) -> str:
        """SHA-256 of :attr:`definition`: equal identities give equal results."""
        return hashlib.sha256(self.definition.encode()).hexdigest()

    @property
    def shape(self) -> tuple[int, ...]:
        """Sizes of the study dimensions (empty for a one-task study)."""
        return tuple(d.size for d in self.dimensions)

    @property
    def shared(self) -> dict[str, Any]:
        """What every task of the study shares, keyed as the study file's tables: the surface
        arguments that are not axes (the generator's defaults filled in), the materials unless
        varied, the controls and how they are solved (``[normal]``, ``[tangential]``,
        ``[fretting]``) and the fields stored (``[output]``).

        A resumed run whose shared part differs from the stored one's is refused
        naming the key (:meth:`~.store.TaskStore.check_owner`); the axes may grow,
        shrink or be reordered.
        """
        varied = {a.key for d in self.dimensions for a in d.axes}
        record = _loading_record(self.loading())
        control = next(key for key, (dim, _) in CONTROLS.items() if dim == self.load_dim)
        out = {"surface": {k: v for k, v in _with_defaults(self.surface).items() if k not in varied},
               "normal": {control: record["loads"], **record["normal"]},
               "tangential": record["tangential"], "fretting": record["fretting"],
               "output": {"fields": record["fields"]}}
        if "materials" not in varied:
            out["materials"] = _bodies(self.interface)
        return json.loads(json.dumps(out, sort_keys=True, default=_plain))

    def tasks(self) -> list[Task]:
        """Every task, in row-major order of the dimensions (``index`` is that order, ``key``
        what the task computes: :func:`task_key`)."""
        out = []
        loading = self.loading()
        for index, (position, values) in enumerate(positions(self.dimensions)):
            surface = {**self.surface, **{k: v for k, v in values.items() if k != "materials"}}
            if surface["generator"] == "file" and self.base_dir is not None:
                surface["path"] = str(self.base_dir / surface["path"])
            interface = values.get("materials", self.interface)
            out.append(Task(index=index, position=position, labels=values, surface=surface, interface=interface,
                            key=task_key(surface, interface, loading, self.file_hashes), **loading))
        return out


def task_key(surface: dict, interface, loading: dict, file_hashes: dict | None = None) -> str:
    """SHA-256 (hex) of everything that determines a task's results, and nothing else.

    The surface's arguments with the generator's defaults filled in (a measured
    surface by the SHA-256 of its file, not its path), the two materials, the
    loads and how they are solved, the fields stored. Not the task's position in
    its study nor the study's name: a task keeps its key, and its file, when an
    axis grows or is reordered.
    """
    spec = _with_defaults(surface)
    if spec["generator"] == "file":
        path = spec.pop("path")
        spec["file_sha256"] = (file_hashes or {}).get(path) or _sha256(path)
    record = {"surface": spec, "materials": _bodies(interface), **_loading_record(loading)}
    text = json.dumps(record, sort_keys=True, default=_plain)
    return hashlib.sha256(text.encode()).hexdigest()


def _with_defaults(surface: dict) -> dict:
    """``surface`` with every argument its generator defaults filled in."""
    function = generators()[surface["generator"]]
    defaults = {name: p.default for name, p in inspect.signature(function).parameters.items()
                if p.default is not inspect.Parameter.empty}
    return {**defaults, **surface}


def _bodies(interface) -> dict | None:
    """The two bodies' constants as the study file gives them (E = inf: rigid)."""
    if interface is None:
        return None
    return {name: {"E": getattr(interface, name).E, "nu": getattr(interface, name).nu} for name in ("body1", "body2")}


def _loading_record(loading: dict) -> dict:
    """The loading of a study or task as plain values (dataclasses as dicts)."""
    return {k: asdict(v) if hasattr(v, "__dataclass_fields__") else v for k, v in loading.items()}


def _plain(value):
    """JSON for what the standard encoder does not know (numpy scalars, paths)."""
    return value.item() if hasattr(value, "item") else str(value)


def _sha256(path) -> str:
    try:
        return hashlib.sha256(Path(path).read_bytes()).hexdigest()
    except OSError:
        return "unreadable"


def load_study(source: str | Path | dict | None = None, comm=None) -> Study:
    """A :class:`Study` from a TOML path, a dict, or the built-in default (None).

    With ``comm`` (collective), rank 0 alone reads and hashes the measured
    surfaces and sends the hashes to the others: one read per job, not one
    per rank."""
    base_dir, text = None, ""
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
            text = path.read_text()
            raw = tomllib.loads(text)
        except (tomllib.TOMLDecodeError, UnicodeDecodeError) as exc:
            raise InputError("study", f"{path} is not valid TOML: {exc}") from None
    schema.only(raw, _TABLES, "study")
    name = schema.string("name", raw.get("name", "study"))
    if not _SAFE_NAME.match(name):
        raise InputError("name", f"must be a plain file name (letters, digits, '.', '_', '-'; no path "
                                 f"and not starting with '.'), so results stay inside --output; got {name!r}")
    surface, function = _surface(schema.section(raw, "surface"))
    axis_keys = (_parameters(function) | COMMON_SURFACE_KEYS) - {"generator"}
    axes_table = schema.section(raw, "axes")
    dimensions = parse_axes(axes_table, axis_keys,
                            lambda where, key, value: schema.surface_value(where, key, value, function),
                            parse_interface)
    varied = {a.key for d in dimensions for a in d.axes}
    clash = sorted(varied & set(surface))
    if clash:
        raise InputError(f"axes.{clash[0]}", "is also given in [surface]; give it in one place")
    missing = [name for name, p in inspect.signature(function).parameters.items()
               if p.default is inspect.Parameter.empty and name not in set(surface) | varied]
    if missing:
        raise InputError(f"surface.{missing[0]}", f"is required by the {surface['generator']!r} generator "
                                                  "(give it in [surface] or as an axis)")
    interface = _materials(raw, "materials" in varied)
    loads, load_dim, normal = _normal(schema.section(raw, "normal"))
    tangential = _tangential(schema.section(raw, "tangential"), loads, load_dim)
    fretting = _fretting(schema.section(raw, "fretting"), loads, load_dim, tangential)
    output = schema.section(raw, "output")
    schema.only(output, {"fields"}, "output")
    fields = check_fields(schema.string("output.fields", output.get("fields", "contact")), "output.fields")
    farm = schema.section(raw, "farm")
    schema.only(farm, {"ranks_per_task", "root_works", "task_timeout"}, "farm")
    ranks = schema.integer("farm.ranks_per_task", farm.get("ranks_per_task", 1), minimum=1)
    root_works = farm.get("root_works", True)
    if not isinstance(root_works, bool):
        raise InputError("farm.root_works", f"must be true or false, got {root_works!r}")
    timeout = farm.get("task_timeout")
    timeout = None if timeout is None else schema.number("farm.task_timeout", timeout, positive=True)
    study = Study(name=name, surface=surface, dimensions=dimensions, interface=interface, loads=loads,
                  load_dim=load_dim, normal=normal, tangential=tangential, fretting=fretting, fields=fields,
                  ranks_per_task=ranks, root_works=root_works, task_timeout=timeout,
                  description=schema.string("description", raw.get("description", "")),
                  text=text or json.dumps(raw, indent=1, default=str), base_dir=base_dir)
    if surface["generator"] == "file":       # each measured surface read and hashed once
        paths = {values.get("path", surface.get("path")) for _, values in positions(dimensions)}
        paths = {str(base_dir / p) if base_dir is not None else p for p in paths}
        hashes = {p: _sha256(p) for p in sorted(paths)} if comm is None or comm.Get_rank() == 0 else None
        study = replace(study, file_hashes=hashes if comm is None else comm.bcast(hashes, root=0))
    return replace(study, definition=_definition(raw, study))


def parse_interface(where: str, spec) -> Interface:
    """The two bodies of a ``{body1 = {E, nu}, body2 = …}`` table (body2 absent: a rigid flat)."""
    if not isinstance(spec, dict):
        raise InputError(where, f"must be a table of body1 (and body2), got {spec!r}")
    schema.only(spec, {"body1", "body2"}, where)
    bodies = []
    for name in ("body1", "body2"):
        body = spec.get(name)
        if body is None:
            if name == "body1":
                raise InputError(f"{where}.body1", "is required")
            bodies.append(Material.rigid())
            continue
        if not isinstance(body, dict):
            raise InputError(f"{where}.{name}", f"must be a table {{ E = …, nu = … }}, got {body!r}")
        schema.only(body, {"E", "nu"}, f"{where}.{name}")
        for key in ("E", "nu"):
            if key not in body:
                raise InputError(f"{where}.{name}.{key}", "is required")
            schema.number(f"{where}.{name}.{key}", body[key])
        try:
            bodies.append(Material(body["E"], body["nu"]))
        except InputError as exc:
            raise InputError(f"{where}.{name}.{exc.parameter}", str(exc).split(": ", 1)[1]) from None
    return Interface(bodies[0], bodies[1])


def _surface(table: dict):
    surface = dict(table)
    generator = schema.string("surface.generator", surface.get("generator", "midpoint"))
    functions = generators()
    surface["generator"] = check_choice("surface.generator", generator, sorted(functions))
    function = functions[generator]
    schema.only(surface, _parameters(function) | COMMON_SURFACE_KEYS, "surface")
    for key, value in surface.items():
        if key != "generator":
            schema.surface_value(f"surface.{key}", key, value, function)
            check_value(f"surface.{key}", key, value)
    return surface, function


def _materials(raw: dict, varied: bool) -> Interface | None:
    if varied:
        if "materials" in raw:
            raise InputError("axes.materials", "is also given as [materials]; give it in one place")
        return None
    return parse_interface("materials", schema.section(raw, "materials"))


#: the [normal] keys that give the controls, the dimension each labels and its unit
CONTROLS = {"loads": ("normal_load", "N"), "pressures": ("mean_pressure", "Pa"), "closures": ("closure", "m")}


def _normal(table: dict):
    schema.only(table, {*CONTROLS, "method", "operator", "rotation"}, "normal")
    given = [key for key in CONTROLS if key in table]
    if len(given) != 1:
        both = f", not both {' and '.join(given)}" if given else ""
        raise InputError("normal.loads", "give exactly one of loads (P in N), pressures (σ0 = P/A0 in Pa) or "
                                         f"closures (δz from first touch in m){both}")
    key = given[0]
    dim, unit = CONTROLS[key]
    values = schema.increasing_numbers(f"normal.{key}", table[key], unit)
    rotation = _rotation(table.get("rotation"), key)
    options = NormalOptions(operator=schema.string("normal.operator", table.get("operator", "auto")),
                            method=schema.string("normal.method", table.get("method", "auto")), rotation=rotation)
    return values, dim, options


def _rotation(value, control: str) -> tuple[float, float] | None:
    """None for ``"free"`` (θ found from zero moments), else the fixed (θx, θy) in rad (Eq. 7).

    Not given: free under load control, (0, 0) under closure control, which
    imposes the whole rigid motion.
    """
    if value is None:
        value = [0.0, 0.0] if control == "closures" else "free"
    if value == "free":
        if control == "closures":
            raise InputError("normal.rotation", "closure control imposes the whole rigid motion (Eq. 7): give "
                                                "rotation = [θx, θy] in rad (e.g. [0.0, 0.0]), not \"free\"")
        return None
    if isinstance(value, str):
        raise InputError("normal.rotation", f"must be \"free\" or [θx, θy] in rad, got {value!r}")
    pair = schema.array("normal.rotation", value)
    if len(pair) != 2:
        raise InputError("normal.rotation", f"must be \"free\" or [θx, θy] in rad, got {value!r}")
    return tuple(schema.number("normal.rotation", v) for v in pair)


def _tangential(table: dict, loads: tuple[float, ...], load_dim: str) -> TangentialOptions | None:
    if not table:
        return None
    schema.only(table, {"friction", "steps", "at", "fretting_amplitude", "fretting_steps"}, "tangential")
    if "friction" not in table:
        raise InputError("tangential.friction", "is required (the Coulomb coefficient f)")
    friction = schema.number("tangential.friction", table["friction"], positive=True)
    steps = schema.integer("tangential.steps", table.get("steps", 10), minimum=1)
    indices = _at(table, "tangential", loads, load_dim)
    amplitude = table.get("fretting_amplitude")
    if amplitude is not None:
        amplitude = float(check_amplitudes([schema.number("tangential.fretting_amplitude", amplitude, positive=True)],
                                           name="tangential.fretting_amplitude")[0])
    fretting_steps = schema.integer("tangential.fretting_steps", table.get("fretting_steps", steps), minimum=1)
    return TangentialOptions(friction, steps, indices, amplitude, fretting_steps)


def _at(table: dict, where: str, loads: tuple[float, ...], load_dim: str) -> tuple[int, ...]:
    """Indices of the loads ``table["at"]`` names (default: every load > 0)."""
    at = table.get("at", [p for p in loads if p > 0])
    indices = []
    for value in schema.array(f"{where}.at", at):
        schema.number(f"{where}.at", value)
        if value not in loads:
            raise InputError(f"{where}.at", f"{value!r} is not one of the study's {load_dim} values")
        if value == 0:
            raise InputError(f"{where}.at", "a tangential load needs P > 0 (fP is the limit of Q)")
        indices.append(loads.index(value))
    return tuple(sorted(set(indices)))


def _fretting(table: dict, loads: tuple[float, ...], load_dim: str,
              tangential: TangentialOptions | None) -> FrettingOptions | None:
    """The fretting map: one cycle ±Q* at each amplitude Q*/(fP), at some loads."""
    if not table:
        return None
    schema.only(table, {"friction", "amplitudes", "steps", "at"}, "fretting")
    if "friction" in table:
        friction = schema.number("fretting.friction", table["friction"], positive=True)
        if tangential is not None and friction != tangential.friction:
            raise InputError("fretting.friction", f"is {friction!r} but tangential.friction is "
                                                  f"{tangential.friction!r}; give f in one place")
    elif tangential is not None:
        friction = tangential.friction
    else:
        raise InputError("fretting.friction", "is required (the Coulomb coefficient f) unless [tangential] gives it")
    if "amplitudes" not in table:
        raise InputError("fretting.amplitudes", "is required (Q*/(fP) of each cycle, increasing, in (0, 1))")
    amplitudes = check_amplitudes([schema.number("fretting.amplitudes", a, positive=True)
                                   for a in schema.array("fretting.amplitudes", table["amplitudes"])],
                                  name="fretting.amplitudes").tolist()
    steps = schema.integer("fretting.steps", table.get("steps", 8), minimum=1)
    return FrettingOptions(friction, tuple(amplitudes), steps, _at(table, "fretting", loads, load_dim))


def _parameters(function) -> set[str]:
    return set(inspect.signature(function).parameters)


def _definition(raw: dict, study: Study) -> str:
    """What determines the results, as canonical JSON: the study without its description
    and [farm] table, and the SHA-256 of the measured surfaces it reads."""
    relevant = {k: v for k, v in raw.items() if k not in ("description", "farm")}
    contents = sorted(h for h in study.file_hashes.values() if h != "unreadable")
    return json.dumps({"study": relevant, "files": contents}, sort_keys=True, default=str)
