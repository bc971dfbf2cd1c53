"""Ensemble statistics of a study's scalars over random surfaces: mean, spread, confidence interval.

For every float scalar of a study dataset that varies along ``over`` (the
seeds by default), at each remaining coordinate (load, Δ, …), over the n
tasks that computed it (failed tasks and the loads they did not reach are
NaN and left out):

    mean  x̄ = Σ x_i / n,   std  s = sqrt(Σ (x_i − x̄)² / (n − 1)),
    CI    x̄ ± t_{(1+c)/2, n−1} s / √n   (Student's t, confidence c).

The mean and interval are those of
:func:`roughcontact.analysis.ensemble.ensemble_statistics` (one
implementation for the study and its analyses); this adds the spread.
"""
from __future__ import annotations

import xarray as xr

from ..errors import InputError


def ensemble_statistics(ds: xr.Dataset, over: str = "seed", confidence: float = 0.95) -> xr.Dataset:
    """Mean, standard deviation and ``confidence`` interval of the mean over ``over``.

    For each float scalar ``v`` of ``ds`` along ``over`` (fields on x, y are
    left out): ``v`` (the mean), ``v_std``, ``v_lower``, ``v_upper`` and
    ``v_samples`` (n), on the remaining dimensions, e.g.
    ``stats.contact_fraction_upper.sel(fractal_dimension=2.3)``.
    """
    from ..analysis.ensemble import ensemble_statistics as mean_and_interval

    if over not in ds.dims:
        raise InputError("over", f"the dataset has no dimension {over!r}; its dimensions are {sorted(ds.dims)}")
    names = [name for name, var in ds.data_vars.items()
             if over in var.dims and "x" not in var.dims and var.dtype.kind == "f"]
    out = mean_and_interval(ds[names], over, confidence)
    for name in names:
        std = ds[name].std(over, ddof=1, skipna=True)
        out[f"{name}_std"] = std.assign_attrs(units=ds[name].attrs.get("units", "1"),
                                              long_name=f"standard deviation of {name} over {over} (n − 1)")
    return out
