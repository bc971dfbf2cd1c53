"""Fields drawn on the grid: contact domains, stick and slip zones, composite topographies (Figs. 1, 4, 6–9).

Each function draws one field of one task on a matplotlib axis, in metres
(the extent is nodes × spacing from the field's own x and y coordinates, so
maps of different resolutions or of lenses cut from one face share physical
axes) with x to the right and y up, and returns what it drew. Nodes outside
the task's grid (NaN, or −1 for int8 fields, in a combined study dataset)
are left blank. Colours follow the paper: contact black, stick black and
slip grey (Fig. 9).
"""
from __future__ import annotations

import numpy as np
import xarray as xr

from ..errors import InputError

#: colours of the zone codes 0 (no contact), 1 (stick), 2 (slip), as Fig. 9
ZONE_COLOURS = ("white", "black", "0.6")


def _image(ax, field: xr.DataArray, values: np.ndarray, spacing: float | None = None, **options):
    if tuple(field.dims[-2:]) != ("x", "y") or field.ndim != 2:
        raise InputError("field", f"must be one field on (x, y), got dims {field.dims}; select one sample first")
    if spacing is None and "x" not in field.coords:
        raise InputError("spacing", "the field has no x, y coordinates (tasks of different spacings); give spacing")
    if spacing is not None:
        x, y = (np.arange(n) * spacing * 1e3 for n in field.shape)
    else:
        x, y = field["x"].values * 1e3, field["y"].values * 1e3
    step_x = x[1] - x[0] if x.size > 1 else 1.0
    step_y = y[1] - y[0] if y.size > 1 else 1.0
    extent = (x[0] - step_x / 2, x[-1] + step_x / 2, y[0] - step_y / 2, y[-1] + step_y / 2)
    image = ax.imshow(values.T, origin="lower", extent=extent, interpolation="nearest", **options)
    ax.set_xlabel("x [mm]")
    ax.set_ylabel("y [mm]")
    ax.set_aspect("equal")
    return image


def _trim(field: xr.DataArray, defined: np.ndarray) -> xr.DataArray:
    """``field`` cut to the bounding box of its defined nodes (a task's own grid)."""
    if not defined.any():
        return field
    rows = np.flatnonzero(defined.any(axis=1))
    cols = np.flatnonzero(defined.any(axis=0))
    return field.isel(x=slice(rows[0], rows[-1] + 1), y=slice(cols[0], cols[-1] + 1))


def draw_contact_map(ax, contact: xr.DataArray, spacing: float | None = None):
    """The contact set S in black on white; nodes outside the task's grid blank.

    ``spacing`` (m) places a field that has no x, y coordinates (a study
    combining different spacings stores node indices only), from (0, 0).
    """
    contact = _trim(contact, contact.values >= 0)
    values = np.where(contact.values >= 0, (contact.values == 1).astype(float), np.nan)
    return _image(ax, contact, values, spacing, cmap="Greys", vmin=0.0, vmax=1.0)


def draw_force_map(ax, force: xr.DataArray, contact: xr.DataArray):
    """Nodal forces p̄ on the contact set on a logarithmic colour scale; no contact white."""
    from matplotlib.colors import LogNorm

    defined = contact.values >= 0
    force, contact = _trim(force, defined), _trim(contact, defined)
    values = np.where(contact.values == 1, force.values, np.nan)
    positive = values[np.isfinite(values) & (values > 0)]
    if positive.size == 0:
        raise InputError("force", "holds no positive force on the contact set")
    return _image(ax, force, values, cmap="viridis", norm=LogNorm(positive.min(), positive.max()))


def draw_zone_map(ax, zone: xr.DataArray):
    """Stick (black) and slip (grey) nodes, no contact white (Fig. 9); outside the task's grid blank."""
    from matplotlib.colors import ListedColormap

    zone = _trim(zone, zone.values >= 0)
    values = np.where(zone.values >= 0, zone.values.astype(float), np.nan)
    return _image(ax, zone, values, cmap=ListedColormap(ZONE_COLOURS), vmin=-0.5, vmax=2.5)


def draw_height_map(ax, height: xr.DataArray, vmin: float | None = None, vmax: float | None = None):
    """A composite topography Δh (µm) off its footprint blank (NaN), on a diverging scale."""
    values = height.values * 1e6
    return _image(ax, height, values, cmap="RdBu_r", vmin=vmin, vmax=vmax)


def height_field(topography) -> xr.DataArray:
    """Δh of a :class:`~roughcontact.surfaces.Topography` as a field on (x, y) in its own frame, NaN off the footprint.

    The origin is the topography's ``metadata["origin"]`` when it has one (a
    lens cut from a shifted face, §3.4), else (0, 0).
    """
    ox, oy = topography.metadata.get("origin", (0.0, 0.0))
    nx, ny = topography.shape
    s = topography.spacing
    values = np.where(topography.footprint, topography.heights, np.nan)
    return xr.DataArray(values, dims=("x", "y"),
                        coords={"x": ox + np.arange(nx) * s, "y": oy + np.arange(ny) * s},
                        attrs={"units": "m", "long_name": "composite topography Δh"})
