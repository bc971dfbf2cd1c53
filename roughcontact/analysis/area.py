"""Real contact area against load: the exponent of A_r ∝ P^m (Fig. 5a), its constant, and Persson's κ.

The paper reads A_r ∝ P at every Δ (Fig. 5a, §3.3) with a constant that falls
as the grid is refined (Fig. 5b). The theories of rough contact developed
since (Persson 2001; Hyun, Pei, Molinari & Robbins 2004) state the same
proportionality with a dimensionless constant κ,

.. math::  A_r = κ \\, P / (E^* h'_\\mathrm{rms}),

κ ≈ √(8/π) ≈ 1.6 in Persson's limit of small loads and 1.8–2.2 in boundary-
element and finite-element studies, h'_rms the rms slope of the composite
topography. A constant κ while A_r/P falls with the resolution means the drop
is the growth of h'_rms as finer scales are resolved.

Every measure here admits only the loads of the *proportional regime*: a
contact fraction A_r/A_0 up to ``max_fraction`` (the linear law is an
asymptote of small fractions) and at least ``min_nodes`` contact nodes (fewer
make one or two asperities, Hertzian A ∝ P^{2/3}). Each runs per sample along
the load dimension (:func:`~.ensemble.map_samples`).
"""
from __future__ import annotations

import numpy as np
import xarray as xr

from ..checks import check_integer, require_finite_positive
from ..errors import InputError
from .ensemble import map_samples
from .fitting import CONFIDENCE, fit_variables, power_law_fit
from .inputs import LOAD, sample_spacing

#: largest contact fraction of the proportional regime, and fewest contact nodes, by default
MAX_FRACTION = 0.10
MIN_NODES = 20


def _admitted(load, area, fraction, node_area, max_fraction: float, min_nodes: int) -> np.ndarray:
    """Loads of the proportional regime: positive, finite, fraction ≤ max, at least ``min_nodes`` nodes."""
    load, area, fraction = (np.asarray(v, dtype=float) for v in (load, area, fraction))
    finite = np.isfinite(load) & np.isfinite(area) & np.isfinite(fraction) & (load > 0)
    return finite & (fraction <= max_fraction) & (area >= min_nodes * node_area - 0.5 * node_area)


def load_exponent(load, area, fraction, spacing: float, max_fraction: float = MAX_FRACTION,
                  min_nodes: int = MIN_NODES, confidence: float = CONFIDENCE) -> xr.Dataset:
    """m of A_r = C P^m over the admitted loads of one sweep, with its interval, R² and the load range.

    Raises :class:`InputError` when fewer than 3 loads are admitted.
    """
    admitted = _admitted(load, area, fraction, spacing**2, max_fraction, min_nodes)
    if admitted.sum() < 3:
        raise InputError("loads", f"{int(admitted.sum())} load(s) have a contact fraction <= {max_fraction:g} "
                                  f"and >= {min_nodes} contact nodes; the exponent needs 3")
    load = np.asarray(load, dtype=float)
    fit = power_law_fit(load[admitted], np.asarray(area, dtype=float)[admitted], confidence, "real contact area")
    data = fit_variables("area_load_exponent", fit, "exponent m of A_r ∝ P^m (Fig. 5a)")
    data["area_load_smallest"] = ((), float(load[admitted].min()), {"units": "N", "long_name": "smallest load fitted"})
    data["area_load_largest"] = ((), float(load[admitted].max()), {"units": "N", "long_name": "largest load fitted"})
    return xr.Dataset(data)


def area_load_exponent(ds: xr.Dataset, load_dim: str = LOAD, max_fraction: float = MAX_FRACTION,
                       min_nodes: int = MIN_NODES, confidence: float = CONFIDENCE,
                       on_error: str = "mark") -> xr.Dataset:
    """:func:`load_exponent` of every sample of a study dataset (``contact_area``, ``contact_fraction``)."""
    load = _load(ds, load_dim)
    max_fraction, min_nodes = _regime(max_fraction, min_nodes)
    return map_samples(load_exponent, [load, ds["contact_area"], ds["contact_fraction"]], (load_dim,),
                       on_error=on_error, spacing=sample_spacing(ds), max_fraction=max_fraction,
                       min_nodes=min_nodes, confidence=confidence)


def proportionality(load, area, fraction, slope: float, spacing: float, modulus: float,
                    max_fraction: float = MAX_FRACTION, min_nodes: int = MIN_NODES) -> xr.Dataset:
    """c = Σ A P / Σ P² (A_r = c P through the origin, Fig. 5b) and κ = c E* h'_rms over the admitted loads."""
    admitted = _admitted(load, area, fraction, spacing**2, max_fraction, min_nodes)
    if not admitted.any():
        raise InputError("loads", f"no load has a contact fraction <= {max_fraction:g} and >= {min_nodes} "
                                  "contact nodes")
    p = np.asarray(load, dtype=float)[admitted]
    a = np.asarray(area, dtype=float)[admitted]
    constant = float(np.sum(a * p) / np.sum(p * p))
    slope = float(slope)
    return xr.Dataset({
        "area_load_constant": ((), constant, {"units": "m2 N-1", "long_name": "A_r / P, least squares through "
                                                                             "the origin (Fig. 5b)"}),
        "persson_kappa": ((), constant * modulus * slope,
                          {"units": "1", "long_name": "κ = A_r E* h'_rms / P (Persson; Hyun et al. 2004)"}),
        "persson_kappa_spread": ((), float(np.std(a / p * modulus * slope)),
                                 {"units": "1", "long_name": "standard deviation of κ over the admitted loads"}),
        "area_load_points": ((), int(admitted.sum()), {"units": "1", "long_name": "loads admitted"}),
    })


def persson_kappa(ds: xr.Dataset, load_dim: str = LOAD, modulus: float | None = None,
                  max_fraction: float = MAX_FRACTION, min_nodes: int = MIN_NODES,
                  on_error: str = "mark") -> xr.Dataset:
    """:func:`proportionality` of every sample: A_r/P and κ with h'_rms = ``topography_rms_slope`` of each task.

    ``modulus`` E* (Pa) defaults to the dataset's ``contact_modulus_Estar``.
    """
    if modulus is None:
        if "contact_modulus_Estar" not in ds.attrs:
            raise InputError("modulus", "the dataset has no contact_modulus_Estar attribute (materials varied "
                                        "along an axis?); give E* in Pa")
        modulus = float(ds.attrs["contact_modulus_Estar"])
    modulus = require_finite_positive("modulus", modulus)
    if "topography_rms_slope" not in ds:
        raise InputError("dataset", "has no topography_rms_slope (h'_rms of each task); not a study dataset")
    max_fraction, min_nodes = _regime(max_fraction, min_nodes)
    return map_samples(proportionality, [_load(ds, load_dim), ds["contact_area"], ds["contact_fraction"]],
                       (load_dim,), on_error=on_error, slope=ds["topography_rms_slope"],
                       spacing=sample_spacing(ds), modulus=modulus, max_fraction=max_fraction, min_nodes=min_nodes)


def _load(ds: xr.Dataset, load_dim: str) -> xr.DataArray:
    """The load P along ``load_dim``: the coordinate under load control, the solved load under closure control."""
    if load_dim not in ds.dims:
        raise InputError("load_dim", f"{load_dim!r} is not a dimension of the dataset (dims {tuple(ds.dims)})")
    if "normal_load" not in ds:
        raise InputError("dataset", f"holds no normal_load along {load_dim!r}")
    return ds["normal_load"]


def _regime(max_fraction: float, min_nodes: int) -> tuple[float, int]:
    if isinstance(max_fraction, bool) or not 0.0 < float(max_fraction) <= 1.0:
        raise InputError("max_fraction", f"must be a contact fraction in (0, 1], got {max_fraction!r}")
    return float(max_fraction), check_integer("min_nodes", min_nodes, 1)
