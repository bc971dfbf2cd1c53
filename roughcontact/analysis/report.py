"""All measures of a study's results in one dataset, and their figures.

:func:`analyse` runs every measure the results allow (the contact-domain
measures need the fields; the closure curve the interface constants; the
tangential ones a sweep's variables) and merges them into one dataset. A
measure whose input is missing or undefined is skipped, and the dataset's
attribute ``skipped_<measure>`` says why; a measure undefined on some
samples only (an empty contact set at one load) is NaN there with
``<measure>_undefined`` = 1. Results on which no measure runs (not a
roughcontact result, or one with nothing to measure) are an
:class:`~roughcontact.errors.InputError` saying what is missing.
"""
from __future__ import annotations

import itertools
from pathlib import Path

import numpy as np
import xarray as xr

from .. import __version__
from ..errors import InputError
from ..materials import Interface, Material
from . import figures
from .box_counting import contact_dimension
from .closure import closure_curve
from .clusters import cluster_statistics
from .ensemble import ensemble_statistics
from .inputs import LOAD, grid_spacing, standard_names
from .multifractal import force_spectrum
from .pressure_statistics import contact_force_statistics
from .renormalisation import contact_renormalisation
from .resolution import contact_area_resolution
from .tangential import frictional_energy_scaling, slip_area_linearity

#: measures on the contact fields, by name, with the fields each needs
FIELD_MEASURES = {
    "box_counting": (contact_dimension, ("contact",)),
    "renormalisation": (contact_renormalisation, ("contact", "force")),
    "force_statistics": (contact_force_statistics, ("contact", "force")),
    "multifractal": (force_spectrum, ("contact", "force")),
    "clusters": (cluster_statistics, ("contact",)),
}
#: the dimensions each measure's figure draws along, besides the load
_CORE = {"box_counting": ("box_size",), "renormalisation": ("box_size",),
         "force_statistics": ("force_bin", "force_edge", "square_bin"), "multifractal": ("q", "box_size"),
         "clusters": ("cluster_size", "largest"), "closure": (), "slip_area": (), "frictional_energy": (),
         "resolution": ()}


def interface_from_attrs(attrs: dict) -> Interface:
    """The two materials recorded in a results file's attributes (E1, nu1, E2, nu2)."""
    try:
        return Interface(Material(float(attrs["E1"]), float(attrs["nu1"])),
                         Material(float(attrs["E2"]), float(attrs["nu2"])))
    except KeyError as exc:
        raise InputError("attrs", f"the results record no {exc.args[0]}: the interface is unknown") from None


def stored_footprint(ds: xr.Dataset) -> tuple[np.ndarray, str]:
    """The footprint the results record: a ``footprint`` variable, else where the ``gap`` is finite, else all nodes."""
    if "footprint" in ds:
        return ds["footprint"].values.astype(bool), "footprint stored in the results"
    if "gap" in ds:
        gap = ds["gap"].transpose(..., "x", "y").values.reshape((-1, ds.sizes["x"], ds.sizes["y"]))
        return np.isfinite(gap).any(axis=0), "nodes where the stored gap is finite"
    return np.ones((ds.sizes["x"], ds.sizes["y"]), dtype=bool), "whole grid (the results record no footprint)"


def analyse(ds: xr.Dataset, comm=None, footprint: np.ndarray | None = None, load_dim: str = LOAD,
            tangential: xr.Dataset | None = None) -> tuple[xr.Dataset, dict[str, xr.Dataset]]:
    """Every measure the results allow; returns the merged dataset and each measure's own.

    Parameters
    ----------
    ds
        A study's normal results (fields on (…, x, y), scalars along ``load_dim``).
    comm
        Communicator of the bulk-compliance operator (closure curves); with
        None the closure curve is skipped.
    footprint
        Nominal contact region for the bulk displacement; default
        :func:`stored_footprint`.
    tangential
        Tangential sweeps (``slip_area`` along ``Q`` or ``Q_over_fP``), if any.
    """
    from .petsc import footprint_bulk_compliance

    ds = standard_names(ds, load_dim)
    if tangential is not None:   # a group that shares the study's dimensions shares their coordinates
        tangential = tangential.assign_coords({d: ds[d] for d in tangential.dims if d in ds.coords and
                                               d not in tangential.coords and tangential.sizes[d] == ds.sizes[d]})
    measures: dict[str, xr.Dataset] = {}
    skipped: dict[str, str] = {}

    def attempt(name, compute):
        try:
            measures[name] = compute()
        except InputError as exc:
            skipped[name] = str(exc)

    for name, (measure, needs) in FIELD_MEASURES.items():
        if all(f in ds for f in needs):
            attempt(name, lambda m=measure: m(ds, load_dim=load_dim, on_error="mark"))
    note = ""
    if "closure" in ds and load_dim in ds.dims:
        footprint, note = (footprint, "footprint given") if footprint is not None else stored_footprint(ds)

        def closure():
            if comm is None:
                raise InputError("comm", "no communicator for the bulk-compliance operator")
            bulk = footprint_bulk_compliance(footprint, grid_spacing(ds), interface_from_attrs(ds.attrs), comm)
            return closure_curve(ds, bulk.mean, load_dim=load_dim, on_error="mark")
        attempt("closure", closure)
    if "incipient_sliding_energy" in ds and load_dim in ds.dims:
        attempt("frictional_energy", lambda: frictional_energy_scaling(ds, load_dim=load_dim, on_error="mark"))
    if "contact_area" in ds and "spacing" in ds.dims:
        attempt("resolution", lambda: contact_area_resolution(ds, on_error="mark"))
    for sweep in (ds, tangential):
        dim = next((d for d in ("Q", "Q_over_fP") if sweep is not None and d in sweep.dims), None)
        if dim and "slip_area" in sweep:
            attempt("slip_area", lambda s=sweep, d=dim: slip_area_linearity(s, dim=d, on_error="mark"))
    if not measures:
        raise InputError("result", "no measure applies: " + ("; ".join(f"{k}: {v}" for k, v in skipped.items())
                                                             or _missing_inputs(ds)))
    for measure in measures.values():   # the axes keep the units and long_name the results gave them
        for coord in set(measure.coords) & set(ds.coords):
            measure[coord].attrs = {**ds[coord].attrs, **measure[coord].attrs}
    renamed = [m.rename({"undefined": f"{name}_undefined"}) if "undefined" in m else m
               for name, m in measures.items()]
    merged = xr.merge(renamed, compat="no_conflicts", combine_attrs="drop_conflicts", join="outer")
    merged.attrs = {"roughcontact_version": __version__, "measures": " ".join(measures) or "none",
                    **{f"skipped_{k}": v for k, v in skipped.items()},
                    **({"bulk_footprint": note} if "closure" in measures else {}),
                    **{k: v for k, v in ds.attrs.items() if k in ("study", "spacing", "description")}}
    return merged, measures


def _missing_inputs(ds: xr.Dataset) -> str:
    """What a results file lacks when no measure can run on it (one line)."""
    variables = ", ".join(sorted(ds.data_vars)[:8]) or "no variable"
    return ("it holds none of what the measures read — the contact set `contact` (and the nodal forces "
            "`force`) on (…, x, y), the `closure` along the load, `incipient_sliding_energy`, `contact_area` "
            f"along `spacing`, or `slip_area` along Q; it has {variables}. Is it a roughcontact result "
            "(`roughcontact run`, a study's <name>.nc)?")


def views(result: xr.Dataset, core: tuple[str, ...], load_dim: str = LOAD) -> tuple[str, list]:
    """What one figure can show: the mean over ``seed`` (when it has 2 or more; the note says so), then
    one view per value of every other dimension but the load, named by a suffix such as
    ``_fractal_dimension2.3`` and a caption such as ``fractal_dimension = 2.3``.
    Returns (note, [(suffix, caption, view), …])."""
    note = ""
    if "seed" in result.dims and result.sizes["seed"] > 1:
        note = f", mean over {result.sizes['seed']} seeds"
        result = ensemble_statistics(result.drop_vars("undefined", errors="ignore"), "seed")
    elif "seed" in result.dims:
        result = result.isel(seed=0)
    others = [d for d in result.dims if d not in core and d != load_dim]
    out = []
    for index in itertools.product(*(range(result.sizes[d]) for d in others)):
        view = result.isel(dict(zip(others, index)))
        values = [f"{view[d].values.item():g}" if d in view.coords and np.issubdtype(view[d].dtype, np.number)
                  else str(i) for d, i in zip(others, index)]
        out.append(("".join(f"_{d}{v}" for d, v in zip(others, values)),
                    ", ".join(f"{d} = {v}" for d, v in zip(others, values)), view))
    return note, out


def draw(measures: dict[str, xr.Dataset], ds: xr.Dataset, directory: str | Path, name: str,
         load_dim: str = LOAD, tangential: xr.Dataset | None = None) -> list[Path]:
    """Figures of the measures as ``<directory>/<name>_<measure>[_<dim><value>…].png``."""
    directory = Path(directory)
    ds = standard_names(ds, load_dim)
    drawers = {
        "box_counting": figures.box_counting_figure,
        "renormalisation": figures.renormalisation_figure,
        "force_statistics": figures.force_statistics_figure,
        "multifractal": figures.spectrum_figure,
        "clusters": figures.clusters_figure,
        "closure": lambda m, p, title: figures.closure_figure(m, p, load_dim=load_dim, title=title),
        "frictional_energy": lambda m, p, title: figures.power_law_figure(
            ds[LOAD if LOAD in ds else load_dim], ds["incipient_sliding_energy"], m, "frictional_energy_exponent",
            p, title),
        "resolution": lambda m, p, title: figures.power_law_figure(
            ds["spacing"], ds["contact_area"], m, "area_resolution_exponent", p, title),
        "slip_area": lambda m, p, title: figures.slip_area_figure(tangential if tangential is not None else ds,
                                                                  m, p, title),
    }
    out = []
    for measure, result in measures.items():
        if measure in ("frictional_energy", "resolution", "slip_area") and len(
                [d for d in result.dims if d != load_dim]) > 0:
            continue   # these figures draw the raw curve beside the fit: one sample only
        note, shown = views(result, _CORE[measure], load_dim)
        for suffix, caption, view in shown:
            out.append(drawers[measure](view, directory / f"{name}_{measure}{suffix}.png",
                                        title=", ".join(filter(None, (name, caption))) + note))
    return out
