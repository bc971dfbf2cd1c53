"""Measures of tangential loading: the slip area against Q and E_f against P (§4.2 (vi), §5, Figs. 10a, 12).

- **Slip area linear in Q**: the slip area is the difference of two contact
  areas, both nearly proportional to their normal loads, so it grows as
  Q / f (§4.2 (vi), Fig. 10a). :func:`slip_area_linearity` fits
  A_slip = a Q + b along the sweep's ``Q`` and reports slope, intercept, R²
  and the interval of the slope; a·fP ≈ A_r is the Cattaneo prediction.
- **E_f against P**: the energy dissipated up to incipient sliding (Eq. 27)
  grows non-linearly with P (Fig. 12); :func:`frictional_energy_scaling`
  fits E_f ∝ P^m in log–log axes.
"""
from __future__ import annotations

import xarray as xr

from .ensemble import map_samples
from .fitting import CONFIDENCE, finite_points, fit_variables, line_fit, power_law_fit
from .inputs import LOAD, series


def slip_line(tangential, slip_area, confidence: float = CONFIDENCE) -> xr.Dataset:
    """A_slip = a Q + b by least squares (at least 3 loads Q; NaN points left out)."""
    fit = line_fit(*finite_points(tangential, slip_area), confidence, "slip area against Q")
    lo, hi = fit.intercept_interval
    return xr.Dataset({
        **fit_variables("slip_area_rate", fit, "slope a of the slip area against Q (Fig. 10a)", units="m2 N-1"),
        "slip_area_intercept": ((), fit.intercept, {"units": "m2", "long_name": "intercept b of the slip area "
                                                                                "against Q"}),
        "slip_area_intercept_lower": ((), lo, {"units": "m2", "long_name": "confidence interval of b, lower bound"}),
        "slip_area_intercept_upper": ((), hi, {"units": "m2", "long_name": "confidence interval of b, upper bound"}),
    })


def slip_area_linearity(ds: xr.Dataset, dim: str = "Q", tangential: str = "Q", confidence: float = CONFIDENCE,
                        on_error: str = "raise") -> xr.Dataset:
    """:func:`slip_line` of ``slip_area`` along the sweep dimension ``dim``, per sample of the other dims.

    The abscissa is the variable ``tangential`` (Q, N), which may vary with
    the other dimensions (a sweep along ``Q_over_fP`` at several loads); the
    incipient-sliding limit state, when the sweep holds it, is one of the
    points.
    """
    area = series(ds, "slip_area", dim)
    return map_samples(slip_line, [series(ds, tangential, dim), area], [dim], on_error=on_error,
                       confidence=confidence)


def energy_power_law(load, energy, confidence: float = CONFIDENCE) -> xr.Dataset:
    """E_f = C P^m in log–log axes (at least 3 loads, E_f > 0; NaN points left out)."""
    fit = power_law_fit(*finite_points(load, energy), confidence, "frictional energy against load")
    return xr.Dataset(fit_variables("frictional_energy_exponent", fit, "exponent m of E_f ∝ P^m (Fig. 12)"))


def frictional_energy_scaling(ds: xr.Dataset, load_dim: str = LOAD, energy: str = "incipient_sliding_energy",
                              confidence: float = CONFIDENCE, on_error: str = "raise") -> xr.Dataset:
    """:func:`energy_power_law` of ``energy`` along ``load_dim``, per sample of the other dimensions.

    ``energy`` names E_f at incipient sliding (Eq. 27); if it also varies
    along a sweep's ``Q``, its last state (the limit Q → fP) is taken.
    """
    values = series(ds, energy, load_dim)
    if "Q" in values.dims:
        values = values.isel(Q=-1, drop=True)
    load = series(ds, LOAD if LOAD in ds.variables else load_dim, load_dim)
    return map_samples(energy_power_law, [load, values], [load_dim], on_error=on_error, confidence=confidence)
