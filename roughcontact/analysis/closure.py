"""Closure curves: the effective closure of the interface and its hyperbolic fit (§3.3–3.4, Figs. 5c, 8a).

The approach δz (Eq. 7) sums the closure of the rough interface and the
bulk deformation of the half-spaces. The bulk part depends only on P: it is
the displacement of the nominal contact region under a uniform pressure
P / A0 (§3.3), c P with the bulk compliance c computed by
:func:`~.petsc.bulk_compliance` from the same operator H as the solve (so
it is exact for the discretisation). The effective closure is

    δ_eff = δz − c P,

and the paper fits it with a hyperbola whose asymptote is the complete
closure of the joint. The hyperbola is that of Bandis, Lumsden & Barton
(Int. J. Rock Mech. Min. Sci. 20, 249, 1983; Goodman 1976), shifted by the
closure δ0 at first touch:

    δ_eff(P) = δ0 + δ_max P / (K0 δ_max + P),  i.e.  P / (δ_eff − δ0) = K0 + P / δ_max,

with δ_max the maximum closure of the joint from first touch (m; the
asymptote is δ0 + δ_max) and K0 = dP/dδ_eff at P = 0 the initial normal
stiffness (N/m). δ0 is 0 under displacement control without rotation (δz
counts from first touch); under load control with free rotation the first
touch is at the footprint's centroid and δz starts at the initial gap
there, hence the offset (``offset=False`` fixes δ0 = 0). The fit is
:func:`scipy.optimize.curve_fit` (least squares in δ_eff), started from the
straight line P / (δ_eff − δ0) against P at the best δ0 of a scan; standard
errors come from its covariance scaled by the residual variance, intervals
from Student t with n − p degrees of freedom (p = 3, or 2 without offset).
"""
from __future__ import annotations

import numpy as np
import xarray as xr
from scipy import stats
from scipy.optimize import curve_fit

from ..errors import InputError
from .ensemble import map_samples
from .fitting import CONFIDENCE, finite_points, t_quantile
from .inputs import LOAD, as_dataset, series


def hyperbola(load, maximum_closure: float, initial_stiffness: float, first_touch: float = 0.0):
    """δ_eff = δ0 + δ_max P / (K0 δ_max + P)."""
    return first_touch + maximum_closure * load / (initial_stiffness * maximum_closure + load)


_PARAMETERS = (("maximum_closure", "m", "maximum closure δ_max from first touch"),
               ("initial_stiffness", "N m-1", "initial normal stiffness K0 = dP/dδ at P = 0"),
               ("first_touch_closure", "m", "effective closure δ0 at first touch"))


def _start(load: np.ndarray, closure: np.ndarray, offset: bool) -> tuple[float, ...]:
    """Start values: the straight line P / (δ − δ0) against P at the δ0 of a scan that fits it best."""
    lowest = closure[load > 0].min()
    candidates = lowest - np.ptp(closure) * np.linspace(0.05, 1.0, 20) if offset else np.zeros(1)
    best = None
    for first_touch in candidates:
        usable = (load > 0) & (closure > first_touch)
        if usable.sum() < 3:
            continue
        ratio = load[usable] / (closure[usable] - first_touch)
        slope, intercept = np.polyfit(load[usable], ratio, 1)
        if slope <= 0 or intercept <= 0:
            continue
        params = (1.0 / slope, intercept) + ((first_touch,) if offset else ())
        misfit = np.sum((closure - hyperbola(load, *params)) ** 2)
        if best is None or misfit < best[0]:
            best = (misfit, params)
    if best is None:
        return (2.0 * np.ptp(closure), np.median(load[load > 0]) / np.ptp(closure)) + ((lowest,) if offset else ())
    return best[1]


def _check_curvature(load, closure, residual, offset: bool, confidence: float) -> None:
    """Raise unless the hyperbola fits significantly better than a straight line (F-test at ``confidence``).

    A straight closure curve has no asymptote: the least-squares hyperbola
    then runs off to δ_max → ∞, and whatever finite δ_max the optimiser
    stops at means nothing.
    """
    columns = [load, np.ones_like(load)] if offset else [load]
    straight = closure - np.stack(columns, axis=1) @ np.linalg.lstsq(np.stack(columns, axis=1), closure,
                                                                     rcond=None)[0]
    rss_line, rss_curve = float(straight @ straight), float(residual @ residual)
    dof = load.size - len(columns) - 1
    scale = max(float(closure @ closure), 1e-300)
    if rss_line <= 1e-24 * scale:
        raise InputError("closure", "the closure curve is a straight line: it has no asymptote")
    statistic = (rss_line - rss_curve) / max(rss_curve, 1e-30 * scale) * dof
    p_value = float(stats.f.sf(statistic, 1, dof)) if rss_curve < rss_line else 1.0
    if p_value > 1.0 - confidence:
        raise InputError("closure", f"the hyperbola fits no better than a straight line (F-test p = {p_value:.2g}):"
                                    " the curve shows no asymptote")


def hyperbola_fit(load, closure, offset: bool = True, confidence: float = CONFIDENCE) -> xr.Dataset:
    """Maximum closure δ_max, initial stiffness K0 (and δ0) of a closure curve, with their uncertainty.

    Parameters
    ----------
    load
        Loads P (N), >= 0.
    closure
        Effective closures δ_eff (m) at those loads; NaN points (loads not
        computed) are left out.
    offset
        Fit the closure δ0 at first touch (default) or fix it to 0.

    Raises
    ------
    InputError
        Fewer loads than parameters + 1 (no interval), or a curve the
        hyperbola cannot follow: one it fits no better than a straight line
        (F-test at ``confidence``), which has no asymptote.
    """
    if np.size(load) != np.size(closure):
        raise InputError("closure", f"{np.size(load)} loads but {np.size(closure)} closures")
    load, closure = finite_points(load, closure)
    count = 3 if offset else 2
    if np.count_nonzero(load > 0) < count + 1:
        raise InputError("closure", f"{np.count_nonzero(load > 0)} positive load(s); the hyperbola's {count} "
                                    f"parameters and an interval need at least {count + 1}")
    # fit in units of the largest load and closure, where the parameters are of order one
    load_unit, closure_unit = load.max(), max(np.abs(closure).max(), 1e-300)
    units = np.array([closure_unit, load_unit / closure_unit, closure_unit][:count])
    p0 = np.asarray(_start(load, closure, offset)) / units
    lower = [0.0, 0.0] + ([-np.inf] if offset else [])
    try:
        params, covariance = curve_fit(hyperbola, load / load_unit, closure / closure_unit, p0=p0,
                                       bounds=(lower, np.inf), ftol=1e-14, xtol=1e-14, gtol=1e-14)
    except (RuntimeError, ValueError) as exc:
        raise InputError("closure", f"the hyperbola does not fit this closure curve ({exc})") from None
    params, errors = params * units, np.sqrt(np.diag(covariance)) * units
    residual = closure - hyperbola(load, *params)
    _check_curvature(load, closure, residual, offset, confidence)
    if not np.all(np.isfinite(errors)):
        raise InputError("closure", "the closure curve does not determine the hyperbola's parameters")
    t = t_quantile(confidence, load.size - count)
    percent = f"{100 * confidence:g} %"
    data = {}
    for (name, unit, long_name), value, error in zip(_PARAMETERS, params, errors):
        data[name] = ((), value, {"units": unit, "long_name": long_name})
        data[f"{name}_stderr"] = ((), error, {"units": unit, "long_name": f"standard error of {long_name}"})
        for bound, sign in (("lower", -1.0), ("upper", 1.0)):
            data[f"{name}_{bound}"] = ((), value + sign * t * error, {
                "units": unit, "long_name": f"{percent} confidence interval of {long_name}, {bound} bound"})
    if not offset:
        data["first_touch_closure"] = ((), 0.0, {"units": "m", "long_name": "effective closure δ0 at first touch "
                                                                           "(fixed)"})
    data["closure_fit_rms"] = ((), float(np.sqrt(np.mean(residual**2))),
                               {"units": "m", "long_name": "rms residual of the hyperbolic fit"})
    return xr.Dataset(data)


def closure_curve(source, bulk_compliance: float, load_dim: str = LOAD, offset: bool = True,
                  confidence: float = CONFIDENCE, on_error: str = "raise") -> xr.Dataset:
    """Effective closure δz − c P along ``load_dim`` and its hyperbolic fit, per sample.

    Parameters
    ----------
    source
        Results or a dataset with ``closure`` and ``normal_load`` along ``load_dim``.
    bulk_compliance
        c (m/N), the footprint's mean displacement per unit load under
        uniform pressure (:func:`~.petsc.bulk_compliance`).
    """
    ds = as_dataset(source, load_dim)
    compliance = float(bulk_compliance)
    if not np.isfinite(compliance) or compliance < 0:
        raise InputError("bulk_compliance", f"must be finite and >= 0 (m/N), got {bulk_compliance!r}")
    load = series(ds, LOAD if LOAD in ds.variables else load_dim, load_dim)
    approach = series(ds, "closure", load_dim)
    effective = (approach - compliance * load).assign_attrs(
        units="m", long_name="effective closure δz − c P (bulk displacement removed)")
    fit = map_samples(hyperbola_fit, [load, effective], [load_dim], on_error=on_error, offset=offset,
                      confidence=confidence)
    fit["effective_closure"] = effective
    fit["bulk_compliance"] = ((), compliance, {"units": "m N-1", "long_name": "bulk compliance c: mean "
                                               "displacement of the footprint per unit uniform load"})
    return fit
