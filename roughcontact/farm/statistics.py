"""Ensemble statistics over random surfaces: mean, spread and confidence interval of the mean.

For every scalar of a study dataset that varies along ``over`` (the seeds
by default), at each remaining coordinate (load, Δ, …):

    mean  x̄ = Σ x_i / n,   std  s = sqrt(Σ (x_i − x̄)² / (n − 1)),
    CI    x̄ ± t_{(1+c)/2, n−1} s / √n   (Student's t, confidence c),

over the n tasks that computed it (failed tasks and loads they did not
reach are NaN and left out; n is kept as ``count``).
"""
from __future__ import annotations

import numpy as np
import xarray as xr

from ..errors import InputError

#: the entries of the ``statistic`` dimension
STATISTICS = ("mean", "std", "ci_low", "ci_high", "count")


def ensemble_statistics(ds: xr.Dataset, over: str = "seed", confidence: float = 0.95) -> xr.Dataset:
    """Mean, standard deviation and ``confidence`` interval of the mean over ``over``.

    Returns a dataset with the float scalars of ``ds`` (fields on x, y are
    left out) along a new leading dimension ``statistic`` =
    :data:`STATISTICS`, e.g. ``stats.contact_fraction.sel(statistic="mean")``.
    """
    from scipy import stats

    if over not in ds.dims:
        raise InputError("over", f"the dataset has no dimension {over!r}; its dimensions are {sorted(ds.dims)}")
    if not 0.0 < confidence < 1.0:
        raise InputError("confidence", f"must lie in (0, 1), got {confidence!r}")
    names = [name for name, var in ds.data_vars.items()
             if over in var.dims and "x" not in var.dims and var.dtype.kind == "f"]
    sample = ds[names]
    count = sample.count(over)
    mean = sample.mean(over, keep_attrs=True)
    std = sample.std(over, ddof=1, keep_attrs=True)
    quantile = xr.apply_ufunc(lambda n: np.where(n > 1, stats.t.ppf(0.5 + confidence / 2, np.maximum(n, 2) - 1),
                                                 np.nan), count)
    half = quantile * std / np.sqrt(count)
    parts = [mean, std, mean - half, mean + half, count.astype(float)]
    out = xr.concat(parts, dim=xr.DataArray(list(STATISTICS), dims="statistic", name="statistic"),
                    coords="minimal", compat="override")
    for name in names:
        out[name].attrs = dict(ds[name].attrs)
    out.attrs = {"over": over, "confidence": confidence,
                 "method": "mean, sample standard deviation (n - 1) and Student-t interval of the mean"}
    return out
