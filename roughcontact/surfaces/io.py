"""Reading measured topographies into SI :class:`Topography` objects.

The paper's rock joint was "digitised by means of a laser profilometer"
(§3.4); today's instruments write vendor formats (Wyko OPD, Digital Surf SUR,
ISO 25178 X3P, ...). :func:`read_topography` reads

- natively: NumPy ``.npy`` arrays, plain text (a matrix of heights, or x-y-z
  columns: ``.txt``, ``.csv``, ``.xyz``) and NetCDF (``.nc``: the CF files
  written by :func:`write_topography`, or SurfaceTopography's NetCDF files);
- every other format through SurfaceTopography (Jacobs, Junge, Pastewka et
  al., ContactEngineering; MIT licence), an optional dependency installed with
  ``pip install "roughcontact[topography]"``.

Whatever the source, the result has heights and spacing in metres, the
original units and instrument metadata in ``metadata``, a square grid (non-
square pixels are an error unless ``resample`` is given), missing points either
rejected or masked out of the footprint (``missing``), and optionally the mean
or mean plane removed (``detrend``).
"""
from __future__ import annotations

import contextlib
import hashlib
import io as _stdio
import json
import warnings
from pathlib import Path
from typing import Any

import numpy as np

from ..checks import check_choice, require_finite_positive
from ..errors import InputError
from .detrend import MODES as DETREND_MODES
from .detrend import _detrended
from .interpolation import resample_square
from .topography import Topography, _uniform_step
from .units import metres_per

#: File suffixes read without SurfaceTopography.
NATIVE_SUFFIXES = {".npy": "npy", ".txt": "text", ".csv": "text", ".xyz": "text",
                   ".nc": "netcdf", ".nc4": "netcdf", ".netcdf": "netcdf"}
FORMATS = ("npy", "text", "netcdf", "surfacetopography")
#: Relative difference of sx and sy below which pixels count as square.
SQUARE_RTOL = 1e-6


def read_topography(path, *, format: str | None = None, spacing=None, unit: str | None = None,
                    height_unit: str | None = None, channel: int | str | None = None,
                    layout: str = "auto", resample: bool | float = False,
                    missing: str = "reject", detrend: str | None = None) -> Topography:
    """Read a measured topography as SI heights on a square grid.

    Parameters
    ----------
    path
        File to read.
    format
        ``"npy"``, ``"text"``, ``"netcdf"`` or ``"surfacetopography"``; by
        default from the suffix (see :data:`NATIVE_SUFFIXES`; any other suffix
        goes to SurfaceTopography, which detects the format itself).
    spacing
        Pixel size (a number, or (sx, sy)) in ``unit``, for files that do not
        store one (``.npy``, a text matrix, some instrument files). An error
        if the file stores its own.
    unit
        Length unit of the lateral coordinates (and of the heights unless
        ``height_unit`` is given) for files that do not store one, e.g.
        ``"m"``, ``"mm"``, ``"um"``. An error if the file stores its own.
    height_unit
        Unit of the heights when it differs from ``unit`` (native formats).
    channel
        Channel index or name of a multi-channel instrument file; default the
        file's default channel.
    layout
        Plain text only: ``"matrix"`` (rows are x, columns are y),
        ``"xyz"`` (three columns x, y, z) or ``"auto"`` (x-y-z when the file
        has exactly three columns and more than three rows).
    resample
        Non-square pixels (sx ≠ sy) raise :class:`InputError` unless this is
        True (bilinear resampling onto the spacing min(sx, sy)) or a spacing
        in metres to resample onto.
    missing
        Undefined points (NaN, or masked by the instrument): ``"reject"``
        (default) raises :class:`InputError`; ``"mask"`` leaves them out of
        the footprint.
    detrend
        ``None`` (keep the heights as measured), ``"mean"`` or ``"plane"``
        (least-squares plane over the footprint).

    Returns
    -------
    Topography
        ``metadata`` holds ``source`` (file name), ``sha256`` of the file,
        ``format``, ``reader``, ``units`` (as stored in the file),
        ``pixel_size`` (m, before any resampling), ``missing_points`` and,
        where the file has them, ``instrument``, ``acquisition_time`` and
        ``raw_metadata``.
    """
    path = Path(path)
    if not path.is_file():
        raise InputError("path", f"no such file: {path.name!r}")
    if format is None:
        format = NATIVE_SUFFIXES.get(path.suffix.lower(), "surfacetopography")
    format = check_choice("format", format, FORMATS)
    missing = check_choice("missing", missing, ("reject", "mask"))
    detrend = check_choice("detrend", detrend, (None,) + DETREND_MODES)
    layout = check_choice("layout", layout, ("auto", "matrix", "xyz"))
    footprint = None
    if format == "surfacetopography":
        heights, pixel_size, meta = _read_surfacetopography(path, channel, spacing, unit)
    elif format == "netcdf":
        heights, pixel_size, meta, footprint = _read_netcdf(path, spacing, unit, height_unit)
    else:
        if channel is not None:
            raise InputError("channel", f"{format} files have a single channel")
        reader = {"npy": _read_npy, "text": _read_text}[format]
        heights, pixel_size, meta = reader(path, spacing=spacing, unit=unit, height_unit=height_unit,
                                           layout=layout)
    meta = dict(source=path.name, sha256=_sha256(path), **meta)
    return _finish(heights, pixel_size, meta, footprint, resample=resample, missing=missing, detrend=detrend)


def write_topography(topography: Topography, path) -> None:
    """Write a topography as a CF NetCDF-4 file that :func:`read_topography` reads back.

    Variables: ``heights(x, y)`` in m, coordinates ``x`` and ``y`` in m,
    ``footprint(x, y)`` (1 inside the nominal contact region); the metadata
    is kept as JSON in the global attribute ``roughcontact_metadata``.
    Heights and spacing round-trip exactly.
    """
    import xarray as xr

    from .. import __version__
    from ..netcdf import write_netcdf

    t = topography
    ds = xr.Dataset(
        {"heights": (("x", "y"), np.asarray(t.heights),
                     {"units": "m", "long_name": "composite height (positive towards the counter-face)"}),
         "footprint": (("x", "y"), np.asarray(t.footprint, dtype=np.int8),
                       {"long_name": "node belongs to the nominal contact region", "units": "1"})},
        coords={"x": ("x", t.x, {"units": "m", "long_name": "x"}),
                "y": ("y", t.y, {"units": "m", "long_name": "y"})},
        attrs={"spacing": t.spacing, "roughcontact_version": __version__,
               "roughcontact_metadata": json.dumps(t.metadata, default=str)})
    write_netcdf(ds, path)


def _finish(heights: np.ndarray, pixel_size: tuple[float, float], meta: dict[str, Any],
            footprint: np.ndarray | None, *, resample, missing: str, detrend: str | None) -> Topography:
    """SI heights with pixel size (sx, sy) -> Topography on a square grid.

    ``footprint`` (stored by :func:`write_topography`) marks the nominal contact
    region; undefined points outside it are not missing data.
    """
    heights = np.asarray(heights, dtype=float)
    if heights.ndim != 2 or min(heights.shape) < 1:
        raise InputError("path", f"holds no 2-D height map (shape {heights.shape})")
    if footprint is None:
        footprint = np.ones(heights.shape, dtype=bool)
    if not np.isfinite(heights[footprint]).any():
        raise InputError("path", "holds no defined height")
    sx, sy = (float(v) for v in pixel_size)
    meta["pixel_size"] = (sx, sy)
    square = abs(sx - sy) <= SQUARE_RTOL * max(sx, sy)
    if isinstance(resample, (bool, np.bool_)):
        target = None if (square or not resample) else min(sx, sy)
        if not square and not resample:
            raise InputError(
                "resample", f"the pixels are not square ({sx:.6g} m x {sy:.6g} m); pass resample=True to "
                f"interpolate onto a square grid of spacing {min(sx, sy):.6g} m, or resample=<spacing in m>")
    else:
        target = require_finite_positive("resample", resample)
    if target is None:
        spacing = sx if square else None
    else:
        heights, spacing = resample_square(heights, (sx, sy), target)
        # a new node is in the footprint when every node it interpolates from is ((1 - t) + t may round)
        footprint = resample_square(footprint.astype(float), (sx, sy), target)[0] >= 1.0 - 1e-9
        meta["resampled"] = dict(method="bilinear", from_pixel_size=(sx, sy), spacing=spacing)
    undefined = ~np.isfinite(heights) & footprint
    meta["missing_points"] = int(undefined.sum())
    if undefined.any() and missing == "reject":
        raise InputError(
            "missing", f"{int(undefined.sum())} of {int(footprint.sum())} points are undefined (NaN or masked "
            "by the instrument); pass missing='mask' to leave them out of the footprint")
    footprint = footprint & ~undefined
    if detrend is not None:
        heights, coefficients = _detrended(heights, spacing, footprint, detrend)
        meta["detrend"] = dict(mode=detrend, **coefficients)
    return Topography(heights, spacing, footprint, meta)


def _read_npy(path: Path, *, spacing, unit, height_unit, layout):
    try:
        heights = np.load(path, allow_pickle=False)
    except Exception as exc:  # numpy raises ValueError, OSError, EOFError, ...
        raise _unreadable(path, "a .npy array", exc) from None
    if heights.ndim != 2:
        raise InputError("path", f"{path.name}: a .npy topography must be a 2-D array, got shape {heights.shape}")
    if not np.issubdtype(heights.dtype, np.number):
        raise InputError("path", f"{path.name}: heights must be numbers, got dtype {heights.dtype}")
    return _native(heights.astype(float), path, "npy", spacing, unit, height_unit)


def _read_text(path: Path, *, spacing, unit, height_unit, layout):
    try:
        with open(path, encoding="utf-8") as f:
            text = f.read()
        delimiter = "," if path.suffix.lower() == ".csv" else None
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", UserWarning)  # "input contained no data": reported below
            data = np.loadtxt(_stdio.StringIO(text), comments="#", delimiter=delimiter, ndmin=2)
    except Exception as exc:
        raise _unreadable(path, "plain text numbers (use format='surfacetopography' for text files "
                          "with a header)", exc) from None
    if data.size == 0:
        raise InputError("path", f"{path.name}: holds no numbers")
    if layout == "xyz" or (layout == "auto" and data.shape[1] == 3 and data.shape[0] > 3):
        if data.shape[1] != 3:
            raise InputError("layout", f"'xyz' needs three columns, {path.name} has {data.shape[1]}")
        factor = metres_per(_need_unit(unit, path), "unit")
        heights, (sx, sy) = _grid_from_xyz(data[:, 0] * factor, data[:, 1] * factor, data[:, 2])
        if spacing is not None:
            raise InputError("spacing", "x-y-z files define their own spacing; do not pass spacing")
        z_factor = metres_per(height_unit, "height_unit") if height_unit is not None else factor
        meta = dict(format="text (x-y-z)", reader="roughcontact", units=dict(length=unit, height=height_unit or unit))
        return heights * z_factor, (sx, sy), meta
    heights, pixel, meta = _native(data, path, "text (matrix)", spacing, unit, height_unit)
    return heights, pixel, meta


def _read_netcdf(path: Path, spacing, unit, height_unit):
    import xarray as xr

    try:
        ds = xr.open_dataset(path)
    except Exception as exc:
        raise _unreadable(path, "NetCDF", exc) from None
    with ds:
        if "heights" not in ds.variables:
            raise InputError("path", f"{path.name}: NetCDF file has no variable 'heights' "
                             f"(variables: {', '.join(map(str, ds.variables))})")
        try:
            var = ds["heights"].transpose("x", "y")
            heights = np.asarray(var.values, dtype=float)
        except Exception as exc:
            raise _unreadable(path, "NetCDF heights(x, y)", exc) from None
        length_unit = _file_unit(ds.coords["x"].attrs if "x" in ds.coords else {}) or _file_unit(var.attrs)
        z_unit = _file_unit(var.attrs) or length_unit
        if (length_unit or z_unit) and (unit is not None or height_unit is not None):
            raise InputError("unit", f"{path.name} stores its units ({length_unit}, {z_unit}); do not pass unit")
        length_unit = length_unit or _need_unit(unit, path)
        z_unit = z_unit or height_unit or length_unit
        steps = []
        for axis in ("x", "y"):
            if axis in ds.coords and ds.coords[axis].size > 1:
                try:
                    steps.append(_uniform_step(axis, np.asarray(ds.coords[axis].values, dtype=float), 1e-6))
                except InputError as exc:
                    raise InputError("path", f"{path.name}: {exc}") from None
            else:
                steps.append(None)
        if "mask" in ds.variables:  # SurfaceTopography: True where undefined
            heights[np.asarray(ds["mask"].transpose("x", "y").values, dtype=bool)] = np.nan
        footprint = None
        if "footprint" in ds.variables:
            footprint = np.asarray(ds["footprint"].transpose("x", "y").values, dtype=bool)
        stored = ds.attrs.get("roughcontact_metadata")
        written_spacing = ds.attrs.get("spacing")
    if written_spacing is not None and all(
            s is None or abs(s - float(written_spacing)) <= 1e-9 * s for s in steps):
        # files of write_topography: the exact spacing, not the mean of coordinate differences
        steps = [float(written_spacing)] * 2
    if all(s is None for s in steps):
        if spacing is None:
            raise InputError("spacing", f"{path.name} has no x/y coordinates; pass spacing")
        pixel = _pixel_pair(spacing)
    else:
        if spacing is not None:
            raise InputError("spacing", f"{path.name} defines its coordinates; do not pass spacing")
        steps = [s if s is not None else next(v for v in steps if v is not None) for s in steps]
        pixel = tuple(steps)
    factor = metres_per(length_unit, "unit")
    meta = dict(format="netcdf", reader="roughcontact", units=dict(length=length_unit, height=z_unit))
    if stored:
        try:
            meta["stored_metadata"] = json.loads(stored)
        except ValueError:
            meta["stored_metadata"] = stored
    heights = heights * metres_per(z_unit, "height_unit")
    return heights, (pixel[0] * factor, pixel[1] * factor), meta, footprint


def _read_surfacetopography(path: Path, channel, spacing, unit):
    try:
        import SurfaceTopography
        from SurfaceTopography import open_topography
    except ImportError:
        raise ImportError(
            f"reading {path.suffix or 'this'} files needs the optional dependency SurfaceTopography: "
            "pip install 'roughcontact[topography]' (or use .npy, text or NetCDF)") from None
    name = f"SurfaceTopography {SurfaceTopography.__version__}"
    # some of its format probes print binary dumps; keep them off the user's terminal
    with contextlib.redirect_stdout(_stdio.StringIO()):
        try:
            reader = open_topography(str(path))
        except Exception as exc:
            raise _unreadable(path, "any format SurfaceTopography knows", exc) from None
    channels = [c for c in reader.channels if c.dim == 2]
    if not channels:
        raise InputError("path", f"{path.name}: holds no 2-D topography channel (line scans are not surfaces)")
    if channel is None:
        info = reader.default_channel if reader.default_channel.dim == 2 else channels[0]
    else:
        matches = [c for c in channels if channel in (c.index, c.name)]
        if not matches:
            raise InputError("channel", f"{channel!r} is not among {[(c.index, c.name) for c in channels]}")
        info = matches[0]
    kwargs = {}
    if info.physical_sizes is None:
        if spacing is None:
            raise InputError("spacing", f"{path.name} stores no pixel size; pass spacing (in unit)")
        sx, sy = _pixel_pair(spacing)
        kwargs["physical_sizes"] = (sx * info.nb_grid_pts[0], sy * info.nb_grid_pts[1])
    elif spacing is not None:
        raise InputError("spacing", f"{path.name} stores its pixel size; do not pass spacing")
    if info.unit is None:
        kwargs["unit"] = _need_unit(unit, path)
    elif unit is not None:
        raise InputError("unit", f"{path.name} stores its unit ({info.unit}); do not pass unit")
    with contextlib.redirect_stdout(_stdio.StringIO()):
        try:
            topography = reader.topography(channel_index=info.index, **kwargs)
            heights = topography.heights()
        except Exception as exc:
            raise _unreadable(path, f"channel {info.name!r}", exc) from None
    heights = np.ma.filled(np.ma.asarray(heights, dtype=float), np.nan)
    factor = metres_per(topography.unit, "unit")
    sx, sy = (float(v) * factor for v in topography.pixel_size)
    file_info = dict(topography.info)
    meta = dict(format=type(reader).__name__.removesuffix("Reader"), reader=name, channel=info.name,
                units=dict(length=topography.unit, height=topography.unit))
    for key in ("instrument", "raw_metadata"):
        if key in file_info:
            meta[key] = file_info[key]
    if "acquisition_time" in file_info:
        meta["acquisition_time"] = str(file_info["acquisition_time"])
    return heights * factor, (sx, sy), meta


def _native(heights: np.ndarray, path: Path, fmt: str, spacing, unit, height_unit):
    """Matrix of heights from a file without calibration: spacing and unit from the caller."""
    if spacing is None:
        raise InputError("spacing", f"{path.name}: a {fmt} file stores no pixel size; pass spacing (in unit)")
    sx, sy = _pixel_pair(spacing)
    length = _need_unit(unit, path)
    factor = metres_per(length, "unit")
    z_factor = metres_per(height_unit, "height_unit") if height_unit is not None else factor
    meta = dict(format=fmt, reader="roughcontact", units=dict(length=length, height=height_unit or length))
    return heights * z_factor, (sx * factor, sy * factor), meta


def _grid_from_xyz(x: np.ndarray, y: np.ndarray, z: np.ndarray):
    """Heights on the uniform grid spanned by scattered x-y-z rows; absent nodes are NaN."""
    index, steps = [], []
    for name, c in (("x", x), ("y", y)):
        if not np.isfinite(c).all():
            raise InputError("path", f"x-y-z file has non-finite {name} coordinates")
        values = np.unique(c)
        span = values[-1] - values[0]
        if values.size == 1:
            index.append(np.zeros(c.size, dtype=np.intp))
            steps.append(None)
            continue
        gaps = np.diff(values)
        step = gaps[gaps > 1e-9 * span].min()
        i = np.round((c - values[0]) / step)
        if np.max(np.abs(c - values[0] - i * step)) > 1e-6 * step:
            raise InputError("path", f"x-y-z file: {name} values are not on a uniform grid")
        index.append(i.astype(np.intp))
        steps.append(float(step))
    if steps[0] is None and steps[1] is None:
        raise InputError("path", "x-y-z file holds a single point")
    steps = [s if s is not None else next(v for v in steps if v is not None) for s in steps]
    shape = (index[0].max() + 1, index[1].max() + 1)
    flat = np.ravel_multi_index((index[0], index[1]), shape)
    if np.unique(flat).size != flat.size:
        raise InputError("path", "x-y-z file lists the same (x, y) node twice")
    heights = np.full(shape, np.nan)
    heights.flat[flat] = z
    return heights, tuple(steps)


def _pixel_pair(spacing) -> tuple[float, float]:
    if np.ndim(spacing) == 0:
        s = require_finite_positive("spacing", spacing)
        return s, s
    try:
        sx, sy = spacing
    except (TypeError, ValueError):
        raise InputError("spacing", f"must be a number or a pair (sx, sy), got {spacing!r}") from None
    return require_finite_positive("spacing", sx), require_finite_positive("spacing", sy)


def _need_unit(unit, path: Path) -> str:
    if unit is None:
        raise InputError("unit", f"{path.name} stores no length unit; pass unit (e.g. 'm', 'mm', 'um')")
    metres_per(unit, "unit")
    return unit


def _file_unit(attrs) -> str | None:
    for key in ("units", "unit", "length_unit"):
        if key in attrs and str(attrs[key]).strip():
            return str(attrs[key]).strip()
    return None


def _unreadable(path: Path, what: str, exc: Exception) -> InputError:
    detail = " ".join(str(exc).split())
    if len(detail) > 240:
        detail = detail[:240] + " ..."
    return InputError("path", f"{path.name} could not be read as {what} (truncated or corrupt?): "
                      f"{type(exc).__name__}: {detail}")


def _sha256(path: Path) -> str:
    digest = hashlib.sha256()
    with open(path, "rb") as f:
        for block in iter(lambda: f.read(1 << 20), b""):
            digest.update(block)
    return digest.hexdigest()
