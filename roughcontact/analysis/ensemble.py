"""Run a measure on every sample of an ensemble, then average over seeds with spread and confidence interval.

A sample is one field (or one curve) of a dataset: everything but its core
dimensions ((x, y) for a field, the load for a closure curve) indexes the
samples, e.g. (``seed``, ``fractal_dimension``, ``normal_load``).
:func:`map_samples` applies a measure to each sample and puts the results
back on those dimensions; :func:`ensemble_statistics` then reduces one of
them (``seed``) to the mean, the standard deviation and the Student-t
confidence interval of the mean: one implementation for a study's scalars
and for the measures of its analysis.
"""
from __future__ import annotations

from collections.abc import Callable, Sequence

import numpy as np
import xarray as xr
from scipy import stats

from ..errors import InputError
from .fitting import CONFIDENCE, check_confidence, line_fit

#: suffixes of the per-sample uncertainty variables the ensemble interval replaces
_PER_SAMPLE_UNCERTAINTY = ("_stderr", "_lower", "_upper")
_ON_ERROR = ("raise", "mark")


def map_samples(function: Callable[..., xr.Dataset], arrays: Sequence[xr.DataArray], core_dims: Sequence[str],
                on_error: str = "raise", region: xr.DataArray | None = None, **kwargs) -> xr.Dataset:
    """``function(*values, **kwargs)`` on every sample; results stacked on the sample dimensions.

    Parameters
    ----------
    function
        Takes one numpy array per entry of ``arrays`` (their core dimensions,
        in order) and returns a dataset without the sample dimensions.
    arrays
        Broadcast against each other first.
    core_dims
        The dimensions ``function`` consumes.
    on_error
        ``"raise"``: an :class:`InputError` of one sample propagates.
        ``"mark"``: that sample's variables are NaN and the variable
        ``undefined`` (1 there) says so, with the reasons in its attributes.
    region
        Booleans on (some sample dims, *core_dims): the nodes that belong to a
        sample (a task's own grid within a study's larger one,
        :func:`~.inputs.task_region`). Each sample's arrays are cut to the
        bounding box of its region before ``function`` sees them, so a
        measure of a task stacked with others on a padded grid is the measure
        of that task alone. A sample without any region node is passed whole.
    **kwargs
        Passed to ``function``; a :class:`xarray.DataArray` among them holds
        one value per sample (e.g. each task's grid spacing) and ``function``
        gets that sample's value.
    """
    if on_error not in _ON_ERROR:
        raise InputError("on_error", f"must be one of {_ON_ERROR}, got {on_error!r}")
    per_sample = {k: v for k, v in kwargs.items() if isinstance(v, xr.DataArray)}
    fixed = {k: v for k, v in kwargs.items() if k not in per_sample}
    extra_arrays = [region] if region is not None else []
    broadcast = xr.broadcast(*arrays, *extra_arrays, *per_sample.values())
    arrays = [a.transpose(..., *core_dims) for a in broadcast[:len(arrays)]]
    region = broadcast[len(arrays)].transpose(..., *core_dims) if region is not None else None
    values = {k: v.isel({d: 0 for d in core_dims if d in v.dims})
              for k, v in zip(per_sample, broadcast[len(arrays) + len(extra_arrays):])}
    extra = [d for d in arrays[0].dims if d not in core_dims]
    if not extra:
        return _call(function, [a.values for a in arrays], None if region is None else region.values,
                     {**fixed, **{k: v.values.item() for k, v in values.items()}})
    stacked = [a.stack(sample=extra).transpose("sample", *core_dims) for a in arrays]
    regions = None if region is None else region.stack(sample=extra).transpose("sample", *core_dims).values
    samples = {k: v.stack(sample=extra).values for k, v in values.items()}
    parts: list[xr.Dataset | None] = []
    reasons: dict[str, str] = {}
    for i in range(stacked[0].sizes["sample"]):
        try:
            parts.append(_call(function, [s.values[i] for s in stacked], None if regions is None else regions[i],
                               {**fixed, **{k: v[i].item() for k, v in samples.items()}}))
        except InputError as exc:
            if on_error == "raise":
                raise
            parts.append(None)
            reasons[str(stacked[0]["sample"].values[i])] = str(exc)
    template = next((p for p in parts if p is not None), None)
    if template is None:
        raise InputError("samples", f"the measure is undefined on every sample: {next(iter(reasons.values()))}")
    blank = template.map(lambda v: xr.full_like(v, np.nan, dtype=float))
    out = xr.concat([blank if p is None else p for p in parts], dim="sample", coords="minimal",
                    compat="override", combine_attrs="override", join="outer")
    if on_error == "mark":
        out["undefined"] = ("sample", np.array([p is None for p in parts], dtype=np.int8),
                            {"units": "1", "long_name": "1 where the measure is undefined on this sample "
                                                        "(its variables are NaN)",
                             "reasons": "; ".join(f"{k}: {v}" for k, v in reasons.items()) or "none"})
    index = xr.Coordinates.from_pandas_multiindex(stacked[0].indexes["sample"], "sample")
    out = out.assign_coords(index).unstack("sample")
    carried = {k: c for k, c in arrays[0].coords.items() if k not in out.coords and set(c.dims) <= set(extra)}
    return out.assign_coords(carried).transpose(*extra, ...)


def _call(function, values: list[np.ndarray], region: np.ndarray | None, kwargs: dict) -> xr.Dataset:
    """``function`` on one sample's core values, cut to the bounding box of its ``region``."""
    if region is not None and region.any():
        box = []
        for axis in range(region.ndim):
            along = np.flatnonzero(region.any(axis=tuple(a for a in range(region.ndim) if a != axis)))
            box.append(slice(int(along[0]), int(along[-1]) + 1))
        values = [v[tuple(box)] for v in values]
    return function(*values, **kwargs)


def ensemble_statistics(ds: xr.Dataset, dim: str = "seed", confidence: float = CONFIDENCE) -> xr.Dataset:
    """Mean over ``dim``, its spread and its confidence interval, for every measure that varies along it.

    For each numeric variable v along ``dim`` (a measure, or a study's scalar
    such as ``contact_fraction``): ``v`` (the mean over the n defined
    samples; a failed task's NaN is left out), ``v_std`` (the sample
    standard deviation s, n − 1 in the denominator), ``v_lower`` and
    ``v_upper`` (mean ∓ t(n − 1) s / √n, Student t at ``confidence``) and
    ``v_samples`` (n). Not averaged: fields on the grid (dimensions x, y: each
    seed is another surface), CF flags (``flag_values``: task status, zone
    codes) and per-sample fit uncertainties (``_stderr``, ``_lower``,
    ``_upper``), which the spread over the ensemble replaces. Variables not
    along ``dim`` are kept as they are. Where fewer than two samples are
    defined the interval is NaN, as its ``comment`` says.
    """
    confidence = check_confidence(confidence)
    if dim not in ds.dims:
        raise InputError("dim", f"{dim!r} is not a dimension of the dataset (dims {tuple(ds.dims)})")
    if ds.sizes[dim] < 2:
        raise InputError(dim, f"has {ds.sizes[dim]} sample(s); a confidence interval needs at least 2")
    out = {}
    percent = f"{100 * confidence:g} %"
    for name, var in ds.data_vars.items():
        if dim not in var.dims:
            out[name] = var
            continue
        if (name.endswith(_PER_SAMPLE_UNCERTAINTY) or not np.issubdtype(var.dtype, np.number)
                or "flag_values" in var.attrs or {"x", "y"} & set(var.dims)):
            continue
        values = var.astype(float)
        count = values.count(dim)
        mean = values.mean(dim, skipna=True)
        spread = values.std(dim, ddof=1, skipna=True) if (count >= 2).any() else xr.full_like(mean, np.nan)
        t = xr.apply_ufunc(lambda n: stats.t.ppf(0.5 + confidence / 2.0, np.where(n >= 2, n - 1, np.nan)), count)
        half = t * spread / np.sqrt(count.where(count >= 2))
        label = var.attrs.get("long_name", name)
        units = var.attrs.get("units", "1")
        out[name] = mean.assign_attrs(var.attrs, cell_methods=f"{dim}: mean")
        comment = "NaN where fewer than 2 samples are defined"
        out[f"{name}_std"] = spread.assign_attrs(units=units, long_name=f"standard deviation of {label} over "
                                                                      f"{dim} (n − 1)", comment=comment)
        out[f"{name}_lower"] = (mean - half).assign_attrs(
            units=units, long_name=f"{percent} confidence interval of the mean of {label} over {dim}, lower bound",
            comment=comment)
        out[f"{name}_upper"] = (mean + half).assign_attrs(
            units=units, long_name=f"{percent} confidence interval of the mean of {label} over {dim}, upper bound",
            comment=comment)
        out[f"{name}_samples"] = count.assign_attrs(units="1", long_name=f"samples of {label} defined over {dim}")
    result = xr.Dataset(out).drop_vars(dim, errors="ignore")
    result.attrs.update(ds.attrs)
    result.attrs["ensemble_dimension"] = dim
    result.attrs["ensemble_confidence"] = confidence
    return result


def trend(values: xr.DataArray, dim: str, log: bool = False, name: str | None = None) -> xr.DataArray:
    """Least-squares slope of ``values`` against the coordinate ``dim`` (its log with ``log``), per sample.

    The per-sample number behind claims such as "Δσ rises with load" (Fig. 6d):
    reduce its sample dimension (``seed``) with :func:`ensemble_statistics`.
    The slope is :func:`~.fitting.line_fit`'s over the finite points; a sample
    with fewer than 3 of them gives NaN.
    """
    if dim not in values.dims:
        raise InputError("dim", f"{dim!r} is not a dimension of {values.name!r} (dims {values.dims})")
    x = values[dim].astype(float)
    if log:
        if not bool((x > 0).all()):
            raise InputError(dim, "a trend against log needs positive coordinates")
        x = np.log(x)

    def slope(y: np.ndarray, abscissa: np.ndarray) -> float:
        keep = np.isfinite(y)
        try:
            return line_fit(abscissa[keep], y[keep], name=str(values.name)).slope
        except InputError:
            return np.nan

    out = xr.apply_ufunc(slope, values.astype(float), kwargs={"abscissa": x.values}, input_core_dims=[[dim]],
                         vectorize=True)
    label = values.attrs.get("long_name", values.name)
    return out.rename(name or f"{values.name}_trend").assign_attrs(
        units="1" if log else f"{values.attrs.get('units', '1')} / {x.attrs.get('units', '1')}",
        long_name=f"slope of {label} against {'log ' if log else ''}{dim}")
