"""Statistics of the nodal contact forces p̄ at one load (§6, Fig. 13).

On the contact set at a given load:

- the histogram of p̄ on ``bins`` equal bins from 0 to max p̄ (Figs. 13a–c)
  and the cumulative distribution F(p̄), the fraction of contact nodes
  carrying at most p̄, at the bin edges (Fig. 13d);
- the **semi-log law** of p̄: log N(p̄) = a + b p̄, N the number of nodes per
  bin, i.e. an exponential population N ∝ exp(−p̄ / p_c) with b = −1/p_c;
- the **power law of p̄²**: the density of W = p̄² (the energy released by a
  slipping asperity if W ∝ p̄², §6) on ``bins`` logarithmic bins,
  n(W) ∝ W^β, the Gutenberg–Richter form the paper points to.

Both laws are least-squares lines through the logarithm of the counts
(:mod:`.fitting`) over the bins holding at least ``min_count`` nodes (fewer
make log N too noisy: the relative error of a Poisson count n is 1/√n); the
fitted range and R² are reported with each. Bin edges differ from one
result to the next, so they are data on the dimensions ``force_bin``,
``force_edge`` and ``square_bin``, not coordinates.
"""
from __future__ import annotations

import numpy as np
import xarray as xr
from scipy import stats

from ..checks import check_integer
from ..errors import InputError
from .ensemble import map_samples
from .fitting import CONFIDENCE, fit_variables, power_law_fit, semilog_fit
from .inputs import GRID, LOAD, as_dataset, contact_set, field, task_region


def _fitted_range(name: str, centres: np.ndarray, used: np.ndarray, units: str, what: str) -> dict:
    return {f"{name}_low": ((), centres[used].min(), {"units": units, "long_name": f"smallest {what} fitted"}),
            f"{name}_high": ((), centres[used].max(), {"units": units, "long_name": f"largest {what} fitted"})}


def force_statistics(force: np.ndarray, contact: np.ndarray, bins: int = 24, min_count: int = 5,
                     confidence: float = CONFIDENCE) -> xr.Dataset:
    """Histogram, cumulative distribution, semi-log law of p̄ and power law of p̄² at one load.

    Parameters
    ----------
    force
        Nodal forces p̄ (N).
    contact
        The contact set; only its nodes with p̄ > 0 count.
    bins
        Number of bins of each histogram (>= 3).
    min_count
        Bins holding fewer nodes are left out of the fits (>= 1).
    """
    bins = check_integer("bins", bins, 3)
    min_count = check_integer("min_count", min_count, 1)
    values = np.asarray(force, dtype=float)[np.asarray(contact, dtype=bool)]
    if not np.all(np.isfinite(values)) or np.any(values < 0):
        raise InputError("force", "must be finite and >= 0 on the contact set")
    values = values[values > 0]
    if values.size < 3 or values.max() == values.min():
        raise InputError("contact", f"holds {values.size} loaded node(s) with "
                                    f"{'equal forces' if values.size >= 3 else 'too few values'}: "
                                    "no distribution to fit")
    counts, edges = np.histogram(values, bins=bins, range=(0.0, values.max()))
    centres = 0.5 * (edges[1:] + edges[:-1])
    used = counts >= min_count
    semilog = semilog_fit(centres[used], counts[used], confidence, "force histogram")
    square = values**2
    square_edges = np.geomspace(square.min(), square.max(), bins + 1)
    square_counts, _ = np.histogram(square, bins=square_edges)
    square_centres = np.sqrt(square_edges[1:] * square_edges[:-1])
    square_density = square_counts / (values.size * np.diff(square_edges))
    square_used = square_counts >= min_count
    power = power_law_fit(square_centres[square_used], square_density[square_used], confidence,
                          "histogram of the squared forces")
    data = {
        "force_bin_centre": ("force_bin", centres, {"units": "N", "long_name": "centre of a bin of p̄"}),
        "force_count": ("force_bin", counts, {"units": "1", "long_name": "contact nodes per bin N(p̄) (Fig. 13)"}),
        "force_edge_value": ("force_edge", edges, {"units": "N", "long_name": "edge of a bin of p̄"}),
        "force_cumulative": ("force_edge", np.searchsorted(np.sort(values), edges, side="right") / values.size,
                             {"units": "1", "long_name": "fraction of contact nodes with a force ≤ p̄ "
                                                         "(Fig. 13d)"}),
        **fit_variables("force_semilog_slope", semilog, "slope b of log N = a + b p̄ (semi-log law, §6)",
                        units="N-1"),
        **_fitted_range("force_semilog", centres, used, "N", "bin centre p̄"),
        "square_bin_centre": ("square_bin", square_centres, {"units": "N2", "long_name": "geometric centre of a "
                                                                                         "bin of p̄²"}),
        "square_density": ("square_bin", square_density, {"units": "N-2", "long_name": "density n(p̄²) of the "
                                                                                       "squared forces"}),
        **fit_variables("square_force_exponent", power, "exponent β of n(p̄²) ∝ (p̄²)^β (power law, §6)"),
        **_fitted_range("square_force", square_centres, square_used, "N2", "bin centre p̄²"),
        "loaded_nodes": ((), values.size, {"units": "1", "long_name": "contact nodes with p̄ > 0"}),
        "mean_force": ((), values.mean(), {"units": "N", "long_name": "mean nodal force on the contact set"}),
    }
    return xr.Dataset(data)


def contact_force_statistics(source, load_dim: str = LOAD, bins: int = 24, min_count: int = 5,
                             confidence: float = CONFIDENCE, on_error: str = "raise") -> xr.Dataset:
    """:func:`force_statistics` of every result of ``source`` (results or a dataset)."""
    ds = as_dataset(source, load_dim)
    return map_samples(force_statistics, [field(ds, "force"), contact_set(ds)], GRID,
                       on_error=on_error, region=task_region(ds), bins=bins, min_count=min_count, confidence=confidence)


def force_law_comparison(force: np.ndarray, contact: np.ndarray, tail: float = 0.5) -> xr.Dataset:
    """Exponential (semi-log) against power law for the upper tail of the nodal forces, by likelihood (Fig. 13).

    The paper reads the histogram of p̄ as semi-log, N ∝ exp(−λ p̄), and that of
    p̄² as a power law, N ∝ (p̄²)^β. Both cannot hold on one tail (a power law
    in p̄² is one in p̄), and R² of binned fits cannot decide between them.
    On the forces above their ``tail`` quantile p_min, the maximum-likelihood
    shifted exponential (λ = 1/(mean − p_min)) and Pareto law (exponent
    a = 1 + n / Σ ln(p̄/p_min)) are compared by their log-likelihood ratio R
    (> 0 favours the exponential) and Vuong's normalised statistic, whose
    two-sided p-value says whether the sign of R is significant. ``beta``
    is the exponent β = −(a + 1)/2 the power law implies for the density of
    p̄² (N(p̄²) ∝ (p̄²)^β, the paper's reading, with q = p̄²: n_q(q) =
    n_p(√q) / (2√q)).
    """
    force = np.asarray(force, dtype=float)
    contact = np.asarray(contact, dtype=bool)
    if force.shape != contact.shape:
        raise InputError("contact", f"shape {contact.shape} differs from the forces' {force.shape}")
    if not 0.0 <= tail < 1.0:
        raise InputError("tail", f"must be a quantile in [0, 1), got {tail!r}")
    loads = force[contact & np.isfinite(force) & (force > 0)]
    smallest = float(np.quantile(loads, tail)) if loads.size else np.nan
    x = loads[loads >= smallest] if loads.size else loads
    if x.size < 10 or not np.ptp(x) > 0:
        raise InputError("force", f"{x.size} positive forces in the tail; the comparison needs 10 distinct ones")
    rate = 1.0 / (x.mean() - smallest)
    exponent = 1.0 + x.size / np.sum(np.log(x / smallest))
    log_exponential = np.log(rate) - rate * (x - smallest)
    log_power = np.log((exponent - 1.0) / smallest) - exponent * np.log(x / smallest)
    difference = log_exponential - log_power
    ratio = float(difference.sum())
    spread = float(difference.std(ddof=1))
    z = ratio / (np.sqrt(x.size) * spread) if spread > 0 else np.inf * np.sign(ratio)
    p_value = float(2.0 * stats.norm.sf(abs(z)))
    preferred = (1 if ratio > 0 else -1) if p_value < 0.05 else 0      # NaN p: undecided
    return xr.Dataset({
        "log_likelihood_ratio": ((), ratio, {"units": "1", "long_name": "log L(exponential) − log L(power law) on "
                                                                        "the tail"}),
        "vuong_statistic": ((), float(z), {"units": "1", "long_name": "Vuong's normalised log-likelihood ratio"}),
        "vuong_p_value": ((), p_value, {"units": "1", "long_name": "two-sided p-value of the ratio's sign"}),
        "preferred_law": ((), np.int8(preferred), {"units": "1", "long_name": "law the tail prefers at p < 0.05",
                                                   "flag_values": np.array([-1, 0, 1], dtype=np.int8),
                                                   "flag_meanings": "power_law undecided exponential"}),
        "tail_rate": ((), float(rate), {"units": "N-1", "long_name": "λ of the exponential tail"}),
        "tail_exponent": ((), float(exponent), {"units": "1", "long_name": "exponent a of the Pareto tail of p̄"}),
        "beta": ((), float(-(exponent + 1.0) / 2.0), {"units": "1", "long_name": "β of N(p̄²) ∝ (p̄²)^β implied "
                                                                                  "by the Pareto tail"}),
        "tail_nodes": ((), int(x.size), {"units": "1", "long_name": "contact nodes in the tail"}),
    })


def contact_force_law_comparison(source, load_dim: str = LOAD, tail: float = 0.5,
                                 on_error: str = "mark") -> xr.Dataset:
    """:func:`force_law_comparison` of every result of ``source`` (results or a dataset)."""
    ds = as_dataset(source, load_dim)
    return map_samples(force_law_comparison, [field(ds, "force"), contact_set(ds)], GRID, on_error=on_error,
                       region=task_region(ds), tail=tail)


def force_uniformity(force: np.ndarray, contact: np.ndarray) -> xr.Dataset:
    """How evenly the load spreads over the contact nodes (Fig. 13: "more uniform as Δ increases").

    ``force_cv``: standard deviation over mean of p̄ on the contact set (0 for
    equal forces); ``force_top_share``: the share of the load carried by the
    1 % most loaded nodes (at least one node); ``contact_nodes``.
    """
    force = np.asarray(force, dtype=float)
    values = force[np.asarray(contact, dtype=bool) & np.isfinite(force)]
    if values.size < 2 or not values.sum() > 0:
        raise InputError("contact", f"holds {values.size} node(s) with force; uniformity needs 2")
    top = max(1, round(0.01 * values.size))
    return xr.Dataset({
        "force_cv": ((), float(values.std() / values.mean()), {"units": "1", "long_name": "std / mean of p̄ on S"}),
        "force_top_share": ((), float(np.sort(values)[-top:].sum() / values.sum()),
                            {"units": "1", "long_name": "share of P on the 1 % most loaded contact nodes"}),
        "contact_nodes": ((), int(values.size), {"units": "1", "long_name": "contact nodes"}),
    })


def contact_force_uniformity(source, load_dim: str = LOAD, on_error: str = "mark") -> xr.Dataset:
    """:func:`force_uniformity` of every result of ``source``."""
    ds = as_dataset(source, load_dim)
    return map_samples(force_uniformity, [field(ds, "force"), contact_set(ds)], GRID, on_error=on_error,
                       region=task_region(ds))
