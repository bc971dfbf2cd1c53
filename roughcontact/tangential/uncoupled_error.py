"""The measured error of the uncoupled Cattaneo model, as the attributes a dataset carries (§4.1).

The discrete Cattaneo theorem (Eqs. 21–24) is exact for β = 0 and γ = 0
(Eqs. 4b, 5); for γ ≠ 0 it drops the γ terms of Eqs. 15–16. How much that
costs was measured against the coupled solve
(:mod:`roughcontact.tangential.coupled`) by ``tools/chart_uncoupled_error.py``,
which also writes the table read here (:mod:`.uncoupled_error_table`): the
largest |error| over a Hertz contact and rough surfaces Δ = 2.1–2.5, at
each charted ν (γ) and Q/fP.

:func:`uncoupled_error_attrs` turns it into dataset attributes: for each
metric the largest measured |error| at the charted points that bracket the
dataset's γ and its range of Q/fP (the limit state Q → fP⁻ is not charted
and does not count), 0 when the model is exact, and the text
:data:`OUTSIDE` where the case lies outside the charted range (β ≠ 0,
γ beyond the charted values, Q/fP below or above the charted loads, load
histories with reversals).
"""
from __future__ import annotations

import math
from collections.abc import Iterable

from . import uncoupled_error_table as measured

OUTSIDE = "outside the charted range"
#: attribute name prefix: ``uncoupled_error_<metric>``
PREFIX = "uncoupled_error_"
#: charted values are matched to this (Q/fP = k/10 computed in floating point)
_SLACK = 1e-6


def _bracket(values: tuple[float, ...], low: float, high: float) -> range | None:
    """Indices of the charted ``values`` from the last ≤ low to the first ≥ high; None outside."""
    if low < values[0] - _SLACK or high > values[-1] + _SLACK:
        return None
    first = max(i for i, v in enumerate(values) if v <= low + _SLACK)
    last = min(i for i, v in enumerate(values) if v >= high - _SLACK)
    return range(first, last + 1)


def uncoupled_error_bound(metric: str, gamma: float, beta: float, load_ratios: Iterable[float]) -> float | str:
    """The measured |error| of the uncoupled model for one metric, or :data:`OUTSIDE`.

    Parameters
    ----------
    metric
        A key of ``METRICS`` in :mod:`.uncoupled_error_table` (``"approach"``: δx
        relative, ``"frictional_energy"``: E_f relative, ``"stick_area"``,
        ``"stick_force"`` (/ fP), ``"centroid"`` (G_Q, spacings),
        ``"cross_traction"`` (|q_⊥| / f max p)).
    gamma, beta
        Composite Poisson ratio γ (Eq. 4b) and Dundurs' β (Eq. 5) of the interface.
    load_ratios
        Q/fP of the dataset's states without the limit state; Q = 0 (no load,
        both models give q = 0) does not count.

    Returns
    -------
    float or str
        0.0 when β = γ = 0 (the theorem is exact); the largest tabulated value
        over the charted γ and Q/fP that bracket the case; :data:`OUTSIDE` otherwise.
    """
    if metric not in measured.ERRORS:
        from ..errors import InputError

        raise InputError("metric", f"must be one of {sorted(measured.ERRORS)}, got {metric!r}")
    if abs(beta) > 1e-12:
        return OUTSIDE
    if abs(gamma) <= 1e-12:
        return 0.0
    loaded = [float(r) for r in load_ratios if r > 0.0]
    if not loaded:
        return 0.0
    rows = _bracket(measured.GAMMA, gamma, gamma)
    columns = _bracket(measured.Q_OVER_FP, min(loaded), max(loaded))
    if rows is None or columns is None:
        return OUTSIDE
    values = [measured.ERRORS[metric][i][k] for i in rows for k in columns]
    finite = [v for v in values if math.isfinite(v)]
    return max(finite) if finite else OUTSIDE


def uncoupled_error_attrs(gamma: float, beta: float, load_ratios: Iterable[float] | None) -> dict:
    """Attributes ``uncoupled_error_<metric>`` and ``uncoupled_error_basis`` for a dataset.

    ``load_ratios`` None means a load history with reversals, which the chart
    does not cover (every metric is :data:`OUTSIDE` unless the model is exact).
    """
    ratios = list(load_ratios) if load_ratios is not None else None
    exact = abs(beta) <= 1e-12 and abs(gamma) <= 1e-12
    out = {}
    for metric in measured.ERRORS:
        if ratios is None:
            out[PREFIX + metric] = 0.0 if exact else OUTSIDE
        else:
            out[PREFIX + metric] = uncoupled_error_bound(metric, gamma, beta, ratios)
    grid = 2**measured.LEVEL + 1
    out[PREFIX + "basis"] = (
        "largest |error| of the uncoupled Cattaneo model against the coupled solve measured at the charted "
        f"gamma {min(measured.GAMMA):g}-{max(measured.GAMMA):g} and Q/fP {min(measured.Q_OVER_FP):g}-"
        f"{max(measured.Q_OVER_FP):g} bracketing this dataset (beta = 0, {grid}x{grid} grids, surfaces: "
        f"{', '.join(measured.SURFACES)}; tools/chart_uncoupled_error.py); 0 when exact; relative for "
        "approach, frictional_energy and stick_area, over fP for stick_force, in grid spacings for centroid, "
        "over f max p for cross_traction; the limit Q -> fP is not charted")
    return out
