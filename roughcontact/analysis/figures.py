"""Figures of the measures in the paper's style, drawn with matplotlib's non-interactive backend.

Each function takes the dataset a measure returned, with at most one sample
dimension (a load sweep; reduce an ensemble first with
:func:`~.ensemble.ensemble_statistics`), writes one PNG and returns its
path. Log–log axes where the paper has them, the fitted line drawn, its
exponent and interval in the legend.
"""
from __future__ import annotations

import itertools
from pathlib import Path

import numpy as np
import xarray as xr

from ..errors import InputError

#: curves drawn at most per panel (evenly picked along the sample dimension)
MAX_CURVES = 6
#: the coordinates a load sweep may run along
LOAD_COORDINATES = ("normal_load", "mean_pressure")


def pyplot():
    """matplotlib.pyplot on the non-interactive Agg backend (figures are written to files, never shown)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt


def _samples(ds: xr.Dataset, core: tuple[str, ...]) -> list[tuple[str, xr.Dataset]]:
    """(label, sample) pairs along the one sample dimension, thinned to MAX_CURVES, undefined samples left out."""
    extra = [d for d in ds.dims if d not in core]
    if len(extra) > 1:
        raise InputError("dataset", f"has sample dimensions {extra}; select or reduce all but one before drawing")
    if not extra:
        return [("", ds)]
    dim = extra[0]
    defined = np.flatnonzero(ds["undefined"].values == 0) if "undefined" in ds else np.arange(ds.sizes[dim])
    picks = defined[np.unique(np.linspace(0, defined.size - 1, min(MAX_CURVES, defined.size)).round().astype(int))]
    units = ds[dim].attrs.get("units", "") if dim in ds.coords else ""
    return [(f"{dim} = {ds[dim].values[i]:.4g} {units}".rstrip() + ": " if dim in ds.coords else f"{i}: ",
             ds.isel({dim: i})) for i in picks]


def _interval(ds: xr.Dataset, name: str) -> str:
    value = float(ds[name])
    if f"{name}_lower" in ds and f"{name}_upper" in ds:
        half = 0.5 * (float(ds[f"{name}_upper"]) - float(ds[f"{name}_lower"]))
        return f"{value:.3g} ± {half:.2g}"
    return f"{value:.3g}"


def _finish(fig, path, title: str, legends=()) -> Path:
    """Legends on ``legends``, the title over the figure, then the PNG at ``path``."""
    for ax in legends:
        ax.legend(fontsize=7)
    if title:
        fig.suptitle(title)
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=120)
    pyplot().close(fig)
    return path


def _loglog_fit(ax, x, y, fitted, label: str, marker: str = "o") -> None:
    """Points of log y against log x and the least-squares line through the fitted ones (positive, finite)."""
    line = ax.loglog(x, y, marker, label=label)[0]
    fitted = fitted & (x > 0) & (y > 0) & np.isfinite(x) & np.isfinite(y)
    if fitted.sum() >= 2:
        slope, intercept = np.polyfit(np.log(x[fitted]), np.log(y[fitted]), 1)
        ax.loglog(x[fitted], np.exp(intercept) * x[fitted] ** slope, "-", color=line.get_color(), lw=1)


def _label(ds: xr.Dataset, name: str) -> str:
    attrs = ds[name].attrs
    return f"{attrs.get('long_name', name)} [{attrs.get('units', '')}]"


def box_counting_figure(ds: xr.Dataset, path, title: str = "") -> Path:
    """N(ε) against ε with the fitted lines (Fig. 2), and Δσ against the sample dimension (Fig. 6d)."""
    plt = pyplot()
    samples = _samples(ds, ("box_size",))
    fig, axes = plt.subplots(1, 2 if len(samples) > 1 else 1, figsize=(10 if len(samples) > 1 else 5, 4),
                             constrained_layout=True, squeeze=False)
    ax = axes[0, 0]
    for label, sample in samples:
        _loglog_fit(ax, sample["box_size"].values, sample["box_count"].values.astype(float),
                    sample["contact_dimension_fitted"].values.astype(bool),
                    f"{label}Δσ = {_interval(sample, 'contact_dimension')}")
    ax.set(xlabel="box side ε [m]", ylabel="boxes holding contact N(ε)")
    if len(samples) > 1:
        dim = next(d for d in ds.dims if d != "box_size")
        x = ds[dim].values
        value = ds["contact_dimension"].values
        err = np.abs(np.stack([value - ds["contact_dimension_lower"].values,
                               ds["contact_dimension_upper"].values - value]))
        axes[0, 1].errorbar(x, value, yerr=err, fmt="o-", capsize=3, label="Δσ (fitted range)")
        axes[0, 1].plot(x, ds["grid_scale_dimension"].values, "s--", label="Δσ at the grid scale")
        axes[0, 1].set_xlabel(_label(ds, dim) if dim in ds.coords else dim)
        axes[0, 1].set_ylabel("Δσ")
        axes[0, 1].set_ylim(-0.1, 2.1)
    return _finish(fig, path, title, legends=axes.ravel())


def renormalisation_figure(ds: xr.Dataset, path, title: str = "") -> Path:
    """log σ0 against log b with the Eq. 13 line, slope −(2 − Δσ) (Fig. 3a)."""
    plt = pyplot()
    fig, ax = plt.subplots(figsize=(5, 4), constrained_layout=True)
    for label, sample in _samples(ds, ("box_size",)):
        _loglog_fit(ax, sample["box_size"].values, sample["window_pressure"].values,
                    sample["renormalised_dimension_fitted"].values.astype(bool),
                    f"{label}Δσ = {_interval(sample, 'renormalised_dimension')}")
    ax.set(xlabel="window side b [m]", ylabel="nominal pressure σ0 [Pa]", title="σ0 = σ* b^−(2 − Δσ) (Eq. 13)")
    return _finish(fig, path, title, legends=(ax,))


def closure_figure(ds: xr.Dataset, path, load_dim: str = "normal_load", title: str = "") -> Path:
    """Load against effective closure with the fitted hyperbola and its asymptote (Figs. 5c, 8a)."""
    from .closure import hyperbola

    plt = pyplot()
    fig, ax = plt.subplots(figsize=(5, 4), constrained_layout=True)
    load = ds[load_dim].values
    closure = ds["effective_closure"].values
    line = ax.plot(closure, load, "o", label="δz − c P")[0]
    fine = np.linspace(0.0, load.max(), 200)
    params = [float(ds[k]) for k in ("maximum_closure", "initial_stiffness", "first_touch_closure")]
    ax.plot(hyperbola(fine, *params), fine, "-", color=line.get_color(),
            label=f"hyperbola: δ_max = {_interval(ds, 'maximum_closure')} m,\n"
                  f"K0 = {_interval(ds, 'initial_stiffness')} N/m")
    ax.axvline(params[0] + params[2], ls="--", color="grey", lw=1, label="asymptote δ0 + δ_max")
    ax.set(xlabel="effective closure [m]", ylabel="normal load P [N]")
    return _finish(fig, path, title, legends=(ax,))


def force_statistics_figure(ds: xr.Dataset, path, title: str = "") -> Path:
    """Histograms with the semi-log law, cumulative distributions, and n(p̄²) with its power law (Fig. 13)."""
    plt = pyplot()
    fig, axes = plt.subplots(1, 3, figsize=(13, 4), constrained_layout=True)
    for label, sample in _samples(ds, ("force_bin", "force_edge", "square_bin")):
        centre, count = sample["force_bin_centre"].values, sample["force_count"].values
        line = axes[0].semilogy(centre, np.where(count > 0, count, np.nan), "o",
                                label=f"{label}b = {_interval(sample, 'force_semilog_slope')} /N")[0]
        inside = (centre >= float(sample["force_semilog_low"])) & (centre <= float(sample["force_semilog_high"]))
        inside &= count > 0
        if inside.sum() >= 2:
            slope, intercept = np.polyfit(centre[inside], np.log(count[inside]), 1)
            axes[0].semilogy(centre[inside], np.exp(intercept + slope * centre[inside]), "-",
                             color=line.get_color())
        axes[1].plot(sample["force_edge_value"], sample["force_cumulative"], "-", color=line.get_color())
        square, density = sample["square_bin_centre"].values, sample["square_density"].values
        positive = density > 0
        inside = (square >= float(sample["square_force_low"])) & (square <= float(sample["square_force_high"]))
        _loglog_fit(axes[2], square[positive], density[positive], inside[positive],
                    f"{label}β = {_interval(sample, 'square_force_exponent')}")
    axes[0].set(xlabel="nodal force p̄ [N]", ylabel="contact nodes per bin N")
    axes[1].set(xlabel="nodal force p̄ [N]", ylabel="cumulative fraction F(p̄)")
    axes[2].set(xlabel="p̄² [N²]", ylabel="density n(p̄²) [N⁻²]")
    return _finish(fig, path, title, legends=(axes[0], axes[2]))


def spectrum_figure(ds: xr.Dataset, path, title: str = "") -> Path:
    """f(α) for each sample, with the width and the maximum against Δσ of the support (Fig. 14)."""
    plt = pyplot()
    fig, ax = plt.subplots(figsize=(5, 4), constrained_layout=True)
    for label, sample in _samples(ds, ("q", "box_size")):
        ax.plot(sample["holder_exponent"], sample["singularity_spectrum"], "o-", ms=3,
                label=f"{label}width {float(sample['spectrum_width']):.3g}, max f "
                      f"{float(sample['spectrum_maximum']):.3g} (Δσ {float(sample['support_dimension']):.3g})")
    ax.set(xlabel="Hölder exponent α", ylabel="f(α)")
    return _finish(fig, path, title, legends=(ax,))


def clusters_figure(ds: xr.Dataset, path, title: str = "") -> Path:
    """Cluster size distribution (log–log) and the load fraction of the largest clusters."""
    plt = pyplot()
    fig, axes = plt.subplots(1, 2, figsize=(10, 4), constrained_layout=True)
    for label, sample in _samples(ds, ("cluster_size", "largest")):
        count = sample["cluster_size_count"].values.astype(float)
        axes[0].loglog(sample["cluster_size"].values, np.where(count > 0, count, np.nan), "o-",
                       label=f"{label}{int(sample['cluster_count'])} clusters")
        if "largest_load_fraction" in sample:
            axes[1].plot(sample["largest"], sample["largest_load_fraction"], "o-")
    axes[0].set(xlabel="cluster size [nodes, bins 2^j … 2^(j+1) − 1]", ylabel="clusters")
    axes[1].set(xlabel="k largest clusters", ylabel="fraction of the load carried", ylim=(0, 1.05))
    return _finish(fig, path, title, legends=(axes[0],))


def power_law_figure(x: xr.DataArray, y: xr.DataArray, fit: xr.Dataset, name: str, path, title: str = "") -> Path:
    """One log–log power law y ∝ x^m with its fitted line: A_r against s (Fig. 1d) or E_f against P (Fig. 12)."""
    plt = pyplot()
    fig, ax = plt.subplots(figsize=(5, 4), constrained_layout=True)
    _loglog_fit(ax, np.asarray(x, float), np.asarray(y, float), np.ones(np.size(x), bool),
                f"exponent {_interval(fit, name)}")
    ax.set(xlabel=f"{x.attrs.get('long_name', x.name)} [{x.attrs.get('units', '')}]",
           ylabel=f"{y.attrs.get('long_name', y.name)} [{y.attrs.get('units', '')}]")
    return _finish(fig, path, title, legends=(ax,))


def slip_area_figure(ds: xr.Dataset, fit: xr.Dataset, path, title: str = "") -> Path:
    """Stick and slip areas against Q with the fitted slip line (Fig. 10a)."""
    plt = pyplot()
    fig, ax = plt.subplots(figsize=(5, 4), constrained_layout=True)
    q = ds["Q"].values
    ax.plot(q, ds["slip_area"], "o", label=f"slip area, R² = {float(fit['slip_area_rate_r2']):.4f}")
    ax.plot(q, float(fit["slip_area_rate"]) * q + float(fit["slip_area_intercept"]), "-",
            label=f"slope {_interval(fit, 'slip_area_rate')} m²/N")
    if "stick_area" in ds:
        ax.plot(q, ds["stick_area"], "s", label="stick area")
    ax.set(xlabel="tangential load Q [N]", ylabel="area [m²]")
    return _finish(fig, path, title, legends=(ax,))


def contact_area_vs_load(ds: xr.Dataset, path, title: str = "") -> Path:
    """Real contact area fraction A_r/A_0 against load P or σ0 (paper Fig. 5a).

    ``ds`` is a study dataset or its :func:`~.ensemble.ensemble_statistics`
    (with ``contact_fraction_lower`` and ``_upper``): then each curve is the
    ensemble mean with its confidence band. One curve per fractal dimension Δ,
    or per combination of the other study dimensions.
    """
    plt = pyplot()
    dim = next(name for name in (*LOAD_COORDINATES, "closure") if name in ds.dims)
    # under closure control the load is an output, one curve of it per sample
    load = ds["normal_load"] if dim == "closure" else ds[dim]
    area = ds["contact_fraction"]
    bands = "contact_fraction_lower" in ds
    others = [d for d in area.dims if d != dim]
    fig, ax = plt.subplots(figsize=(5.6, 4.0), constrained_layout=True)
    for labels in itertools.product(*(range(area.sizes[d]) for d in others)):
        where = dict(zip(others, labels))
        label = ", ".join(_dimension_label(ds, d, i) for d, i in where.items())
        x = load.isel({d: i for d, i in where.items() if d in load.dims})
        line, = ax.plot(x, area.isel(where), "o-", ms=3, label=label or ("mean" if bands else None))
        if bands:
            ax.fill_between(x, ds["contact_fraction_lower"].isel(where),
                            ds["contact_fraction_upper"].isel(where), color=line.get_color(), alpha=0.25, lw=0)
    units = load.attrs.get("units", "")
    ax.set_xlabel(f"{load.attrs.get('long_name', load.name)} [{units}]")
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
    return _finish(fig, path, "")


def _dimension_label(ds: xr.Dataset, dim: str, index: int) -> str:
    """``Δ = 2.3`` or ``dim = value`` for the ``index``-th point of a study dimension."""
    if dim == "fractal_dimension":
        return f"Δ = {float(ds[dim][index]):g}"
    if dim in ds.coords:
        value = ds[dim].values[index]
        return f"{dim} = {value:g}" if isinstance(value, float) else f"{dim} = {value}"
    return f"{dim} {index}"
