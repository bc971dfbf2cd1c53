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
