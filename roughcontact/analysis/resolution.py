"""Real contact area against resolution at a fixed load (§3.2, Fig. 1d).

Solving the same surface at spacings s, 2s, 4s, … under the same load P
(:func:`~.petsc.solve_resolutions`), the real contact area A_r shrinks as
the grid is refined, as a power law A_r ∝ s^m. If the contact domain is a
fractal of dimension Δσ, the number of contact nodes grows as s^(−Δσ), each
of area s², so m = 2 − Δσ: ``implied_dimension`` reports 2 − m beside the
exponent (a smooth, Euclidean contact has m = 0 and Δσ = 2).
"""
from __future__ import annotations

import xarray as xr

from .ensemble import map_samples
from .fitting import CONFIDENCE, finite_points, fit_variables, power_law_fit
from .inputs import series


def area_resolution_fit(spacing, contact_area, confidence: float = CONFIDENCE) -> xr.Dataset:
    """Exponent m of A_r ∝ s^m with its interval, and Δσ = 2 − m (at least 3 resolutions; NaN points left out)."""
    fit = power_law_fit(*finite_points(spacing, contact_area), confidence, "contact area against spacing")
    return xr.Dataset({
        **fit_variables("area_resolution_exponent", fit, "exponent m of A_r ∝ s^m (Fig. 1d)"),
        **fit_variables("implied_dimension", fit, "Δσ = 2 − m implied by the exponent", scale=-1.0, offset=2.0,
                        quality=False),
    })


def contact_area_resolution(ds: xr.Dataset, dim: str = "spacing", confidence: float = CONFIDENCE,
                            on_error: str = "raise") -> xr.Dataset:
    """:func:`area_resolution_fit` along ``dim`` (the spacing coordinate, m) for every other sample."""
    area = series(ds, "contact_area", dim)
    return map_samples(area_resolution_fit, [area[dim], area], [dim], on_error=on_error, confidence=confidence)
