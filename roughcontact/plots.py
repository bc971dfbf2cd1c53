"""Figures of the paper, drawn with matplotlib's non-interactive backend."""
from __future__ import annotations

import itertools
from pathlib import Path

import xarray as xr

#: the coordinates a load sweep may run along
LOAD_COORDINATES = ("normal_load", "mean_pressure")


def contact_area_vs_load(ds: xr.Dataset, path: str | Path, title: str = "") -> Path:
    """Real contact area fraction A_r/A_0 against load P or σ0 (paper Fig. 5a).

    ``ds`` is a study dataset or its :func:`~roughcontact.farm.ensemble_statistics`
    (with ``contact_fraction_lower`` and ``_upper``): then each curve is the
    ensemble mean with its confidence band. One curve per fractal dimension Δ,
    or per combination of the other study dimensions.
    """
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    load = next(name for name in LOAD_COORDINATES if name in ds.coords)
    area = ds["contact_fraction"]
    bands = "contact_fraction_lower" in ds
    others = [d for d in area.dims if d != load]
    fig, ax = plt.subplots(figsize=(5.6, 4.0), constrained_layout=True)
    for labels in itertools.product(*(range(area.sizes[d]) for d in others)):
        where = dict(zip(others, labels))
        label = ", ".join(_label(ds, d, i) for d, i in where.items())
        line, = ax.plot(ds[load], area.isel(where), "o-", ms=3, label=label or ("mean" if bands else None))
        if bands:
            ax.fill_between(ds[load], ds["contact_fraction_lower"].isel(where),
                            ds["contact_fraction_upper"].isel(where), color=line.get_color(), alpha=0.25, lw=0)
    units = ds[load].attrs.get("units", "")
    ax.set_xlabel(f"{ds[load].attrs.get('long_name', load)} [{units}]")
    ax.set_ylabel("real contact area fraction A_r / A_0")
    ax.set_xlim(left=0)
    ax.set_ylim(bottom=0)
    ax.grid(alpha=0.3)
    if others or bands:
        band = (f"mean and {ds.attrs.get('ensemble_confidence', 0.95):.0%} CI over "
                f"{int(ds['contact_fraction_samples'].max())} {ds.attrs.get('ensemble_dimension', 'seed')}s"
                if bands else None)
        ax.legend(title=band, fontsize=8)
    if title:
        ax.set_title(title, fontsize=10)
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=120)
    plt.close(fig)
    return path


def _label(ds: xr.Dataset, dim: str, index: int) -> str:
    if dim == "fractal_dimension":
        return f"Δ = {float(ds[dim][index]):g}"
    if dim in ds.coords:
        value = ds[dim].values[index]
        return f"{dim} = {value:g}" if isinstance(value, float) else f"{dim} = {value}"
    return f"{dim} {index}"
