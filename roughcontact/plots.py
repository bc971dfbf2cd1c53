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
    (a ``statistic`` dimension): then each curve is the ensemble mean with its
    confidence band. One curve per fractal dimension Δ, or per combination of
    the other study dimensions.
    """
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    load = next(name for name in LOAD_COORDINATES if name in ds.coords)
    area = ds["contact_fraction"]
    bands = "statistic" in area.dims
    others = [d for d in area.dims if d not in (load, "statistic")]
    fig, ax = plt.subplots(figsize=(5.6, 4.0), constrained_layout=True)
    for labels in itertools.product(*(range(area.sizes[d]) for d in others)):
        curve = area.isel(dict(zip(others, labels)))
        label = ", ".join(_label(ds, d, i) for d, i in zip(others, labels))
        if bands:
            mean = curve.sel(statistic="mean")
            line, = ax.plot(ds[load], mean, "o-", ms=3, label=label or "mean")
            ax.fill_between(ds[load], curve.sel(statistic="ci_low"), curve.sel(statistic="ci_high"),
                            color=line.get_color(), alpha=0.25, lw=0)
        else:
            ax.plot(ds[load], curve, "o-", ms=3, label=label or None)
    units = ds[load].attrs.get("units", "")
    ax.set_xlabel(f"{ds[load].attrs.get('long_name', load)} [{units}]")
    ax.set_ylabel("real contact area fraction A_r / A_0")
    ax.set_xlim(left=0)
    ax.set_ylim(bottom=0)
    ax.grid(alpha=0.3)
    if others or bands:
        band = f"mean and {ds.attrs.get('confidence', 0.95):.0%} CI over {ds.attrs.get('over', 'seeds')}"
        ax.legend(title=band if bands else None, fontsize=8)
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
