"""Renormalisation group of the contact pressure and its size effect (Eqs. 12–13, Fig. 3a).

Eq. 12: P = σ0 A0 = σ* H_S, with H_S the Hausdorff measure of the contact
domain S, of dimension [L]^Δσ, and σ* the fractal mean pressure
([F][L]^−Δσ). For an interface of linear size b, A0 = b² and H_S ∝ b^Δσ, so
(Eq. 13)

    log σ0 = log σ* − (2 − Δσ) log b.

From one contact domain (:func:`renormalisation`): cut the analysis window
(:mod:`.boxes`) into windows of side b = k s, k = 1, 2, 4, …; each window that
holds contact is an interface of size b carrying the load P_w of its nodes,
with nominal pressure P_w / b². Their mean over the windows holding contact,
σ0(b) = P / (N(b) b²) with N(b) the box count, follows Eq. 13 where S is
self-similar; the fitted slope gives Δσ = 2 + slope and the intercept σ*,
in N m^−Δσ. The spread of P_w / b² over the windows is reported beside it.
From domains of different sizes (:func:`size_effect`): the same fit of σ0
against b.
"""
from __future__ import annotations

import numpy as np
import xarray as xr

from ..errors import InputError
from .boxes import box_coords, box_nodes, box_sums, crop, fitted_boxes
from .ensemble import map_samples
from .fitting import CONFIDENCE, LineFit, fit_variables, power_law_fit
from .inputs import GRID, LOAD, as_dataset, contact_set, field, sample_spacing, task_region


def size_effect(sizes, nominal_pressure, confidence: float = CONFIDENCE) -> xr.Dataset:
    """Fit Eq. 13 to σ0 against b: Δσ = 2 + slope and σ* = exp(intercept).

    Parameters
    ----------
    sizes
        Linear sizes b of the interfaces (m).
    nominal_pressure
        Their nominal pressures σ0 = P / b² (Pa), positive.
    """
    fit = power_law_fit(sizes, nominal_pressure, confidence, "nominal pressure against size")
    return xr.Dataset(_size_effect_variables(fit))


def _size_effect_variables(fit: LineFit) -> dict:
    log_lo, log_hi = fit.intercept_interval
    comment = "[F][L]^-Δσ (Eq. 12): newtons per metre to the power Δσ of the same fit"
    return {
        **fit_variables("renormalised_dimension", fit, "Δσ = 2 + slope of log σ0 against log b (Eq. 13)",
                        offset=2.0),
        "fractal_pressure": ((), np.exp(fit.intercept), {"units": "N m-Δσ", "comment": comment,
                                                         "long_name": "fractal mean pressure σ* (Eqs. 12–13)"}),
        "fractal_pressure_lower": ((), np.exp(log_lo), {"units": "N m-Δσ", "comment": comment,
                                                        "long_name": "confidence interval of σ*, lower bound"}),
        "fractal_pressure_upper": ((), np.exp(log_hi), {"units": "N m-Δσ", "comment": comment,
                                                        "long_name": "confidence interval of σ*, upper bound"}),
    }


def renormalisation(force: np.ndarray, contact: np.ndarray, spacing: float = 1.0, base: int = 2,
                    box_range: tuple[int, int] | None = None, confidence: float = CONFIDENCE) -> xr.Dataset:
    """σ0(b) from windows of one contact domain, and the Eq. 13 fit (Δσ, σ*).

    Parameters
    ----------
    force
        Nodal forces p̄ (N) on the grid.
    contact
        The contact set S.
    spacing
        Grid spacing s (m).
    base, box_range, confidence
        As in :func:`~.box_counting.box_counting`.
    """
    force = crop(np.asarray(force, dtype=float), base)
    mask = crop(np.asarray(contact, dtype=bool), base)
    if force.shape != mask.shape:
        raise InputError("force", f"shape {force.shape} differs from the contact set's {mask.shape}")
    if not mask.any():
        raise InputError("contact", "is empty in the analysis window: no window carries load, σ0(b) is undefined")
    if not np.all(np.isfinite(force[mask])) or np.any(force[mask] < 0.0):
        raise InputError("force", "must be finite and >= 0 on the contact set")
    nodes = box_nodes(mask.shape[0], base)
    mean, spread = np.empty(nodes.size), np.empty(nodes.size)
    for i, k in enumerate(nodes):
        occupied = box_sums(mask, int(k)) > 0
        pressure = box_sums(np.where(mask, force, 0.0), int(k))[occupied] / (k * spacing) ** 2
        mean[i] = pressure.mean()
        spread[i] = pressure.std(ddof=1) if pressure.size > 1 else 0.0
    if not np.all(mean > 0):
        raise InputError("force", "the windows holding contact carry no load")
    fitted = fitted_boxes(nodes, box_range, base)
    fit = power_law_fit(nodes[fitted] * spacing, mean[fitted], confidence, "window pressures")
    parts = box_coords(nodes, spacing, fitted, "renormalised_dimension")
    data = {
        "window_pressure": ("box_size", mean, {"units": "Pa", "long_name": "mean nominal pressure σ0 = P_w / b² "
                                                                           "of the windows holding contact"}),
        "window_pressure_spread": ("box_size", spread, {"units": "Pa", "long_name": "standard deviation of "
                                                        "P_w / b² over the windows holding contact"}),
        **parts["fitted"],
        **_size_effect_variables(fit),
    }
    return xr.Dataset(data, coords=parts["coords"])


def contact_renormalisation(source, load_dim: str = LOAD, base: int = 2, box_range: tuple[int, int] | None = None,
                            confidence: float = CONFIDENCE, on_error: str = "raise") -> xr.Dataset:
    """:func:`renormalisation` of every contact domain of ``source`` (results or a dataset)."""
    ds = as_dataset(source, load_dim)
    return map_samples(renormalisation, [field(ds, "force"), contact_set(ds)], GRID,
                       on_error=on_error, region=task_region(ds), spacing=sample_spacing(ds), base=base,
                       box_range=box_range,
                       confidence=confidence)
