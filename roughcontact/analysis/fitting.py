"""Straight-line fits with Student-t confidence intervals, and their CF variables.

Every measure of this package that is a slope (a dimension, an exponent, a
linear rate) comes from :func:`line_fit`: ordinary least squares by
:func:`scipy.stats.linregress` (slope, intercept and their standard errors),
with the interval ``estimate ± t(1 − (1 − c)/2, n − 2) × stderr`` of
confidence ``c`` (Student t, n − 2 degrees of freedom). :func:`power_law_fit`
fits ``log y`` against ``log x``, :func:`semilog_fit` ``log y`` against ``x``.

The interval treats the points as independent with equal scatter. The points
of a box-counting plot are not independent (the boxes of one size nest in
those of the next), so for them the interval understates the uncertainty;
the spread over an ensemble of surfaces (:mod:`.ensemble`) is the honest one.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy import stats

from ..errors import InputError

#: default confidence of every interval
CONFIDENCE = 0.95


@dataclass(frozen=True)
class LineFit:
    """y = slope x + intercept by least squares.

    Attributes
    ----------
    slope, intercept
        The fitted line.
    slope_stderr, intercept_stderr
        Their standard errors (0 when the points lie exactly on the line).
    r_squared
        Coefficient of determination R² (1 for points exactly on a line;
        defined as 1 when y does not vary and the fit is exact).
    points
        Number of points n (>= 3).
    t_value
        Student t quantile of the interval, n − 2 degrees of freedom.
    confidence
        Confidence level of the interval.
    """

    slope: float
    intercept: float
    slope_stderr: float
    intercept_stderr: float
    r_squared: float
    points: int
    t_value: float
    confidence: float

    @property
    def slope_interval(self) -> tuple[float, float]:
        half = self.t_value * self.slope_stderr
        return self.slope - half, self.slope + half

    @property
    def intercept_interval(self) -> tuple[float, float]:
        half = self.t_value * self.intercept_stderr
        return self.intercept - half, self.intercept + half


def check_confidence(confidence: float) -> float:
    """A confidence level in (0, 1)."""
    try:
        c = float(confidence)
    except (TypeError, ValueError):
        raise InputError("confidence", f"must be a number in (0, 1), got {confidence!r}") from None
    if not 0.0 < c < 1.0:
        raise InputError("confidence", f"must lie in (0, 1), got {confidence!r}")
    return c


def t_quantile(confidence: float, dof: int) -> float:
    """Two-sided Student t quantile t(1 − (1 − c)/2, dof)."""
    return float(stats.t.ppf(0.5 + check_confidence(confidence) / 2.0, dof))


def line_fit(x, y, confidence: float = CONFIDENCE, name: str = "data") -> LineFit:
    """Least-squares line through (x, y) with standard errors and R².

    Raises :class:`InputError` naming ``name`` for fewer than 3 points (no
    degree of freedom is left for an interval), non-finite values, or x that
    does not vary.
    """
    x = np.asarray(x, dtype=float).ravel()
    y = np.asarray(y, dtype=float).ravel()
    if x.size != y.size:
        raise InputError(name, f"has {x.size} abscissae and {y.size} ordinates")
    if x.size < 3:
        raise InputError(name, f"has {x.size} point(s); a slope with an interval needs at least 3")
    if not (np.all(np.isfinite(x)) and np.all(np.isfinite(y))):
        raise InputError(name, "holds NaN or infinite values")
    if np.ptp(x) == 0.0:
        raise InputError(name, "all points share one abscissa: no slope")
    fit = stats.linregress(x, y)
    residual = y - (fit.slope * x + fit.intercept)
    spread = float(np.sum((y - y.mean()) ** 2))
    exact = float(np.sum(residual**2)) <= 1e-24 * max(spread, float(np.sum(y**2)), 1e-300)
    r_squared = 1.0 if exact else float(fit.rvalue**2)
    slope_se = 0.0 if exact else float(fit.stderr)
    intercept_se = 0.0 if exact else float(fit.intercept_stderr)
    return LineFit(float(fit.slope), float(fit.intercept), slope_se, intercept_se, r_squared,
                   int(x.size), t_quantile(confidence, x.size - 2), check_confidence(confidence))


def finite_points(x, y) -> tuple[np.ndarray, np.ndarray]:
    """The pairs (x, y) where both are finite: a curve less the points a task did not compute."""
    x = np.asarray(x, dtype=float).ravel()
    y = np.asarray(y, dtype=float).ravel()
    keep = np.isfinite(x) & np.isfinite(y)
    return x[keep], y[keep]


def power_law_fit(x, y, confidence: float = CONFIDENCE, name: str = "data") -> LineFit:
    """y = C x^m as the line log y = m log x + log C (natural logarithms)."""
    x = np.asarray(x, dtype=float)
    y = np.asarray(y, dtype=float)
    if np.any(~(x > 0)) or np.any(~(y > 0)):
        raise InputError(name, "a power law needs positive abscissae and ordinates")
    return line_fit(np.log(x), np.log(y), confidence, name)


def semilog_fit(x, y, confidence: float = CONFIDENCE, name: str = "data") -> LineFit:
    """y = C exp(m x) as the line log y = m x + log C."""
    y = np.asarray(y, dtype=float)
    if np.any(~(y > 0)):
        raise InputError(name, "a semi-log law needs positive ordinates")
    return line_fit(x, np.log(y), confidence, name)


def fit_variables(name: str, fit: LineFit, long_name: str, units: str = "1",
                  scale: float = 1.0, offset: float = 0.0, quality: bool = True) -> dict:
    """CF scalar variables of ``value = scale × slope + offset`` with its uncertainty.

    ``name`` (the value), ``name_stderr``, ``name_lower`` and ``name_upper``
    (the confidence interval) and, with ``quality``, ``name_r2`` and
    ``name_points``.
    """
    value = scale * fit.slope + offset
    bounds = sorted(scale * b + offset for b in fit.slope_interval)
    percent = f"{100 * fit.confidence:g} %"
    variables = {
        name: ((), value, {"units": units, "long_name": long_name}),
        f"{name}_stderr": ((), abs(scale) * fit.slope_stderr,
                           {"units": units, "long_name": f"standard error of {long_name}"}),
        f"{name}_lower": ((), bounds[0], {"units": units, "long_name": f"{percent} confidence interval of "
                                          f"{long_name}, lower bound (Student t, n − 2 dof)"}),
        f"{name}_upper": ((), bounds[1], {"units": units, "long_name": f"{percent} confidence interval of "
                                          f"{long_name}, upper bound (Student t, n − 2 dof)"}),
    }
    if quality:
        variables[f"{name}_r2"] = ((), fit.r_squared, {"units": "1", "long_name": f"R² of the fit of {long_name}"})
        variables[f"{name}_points"] = ((), fit.points, {"units": "1",
                                                        "long_name": f"points in the fit of {long_name}"})
    return variables
