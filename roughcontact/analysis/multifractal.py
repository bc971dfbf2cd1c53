"""Multifractal spectrum f(α) of the contact forces by the Chhabra–Jensen direct method (§6, Eqs. 28–31, Fig. 14).

The measure is the normalised nodal force P_i = p̄_i / Σ p̄ on the analysis
window (:mod:`.boxes`); P_i(ε) is its sum over the box i of side ε = k s.
With the ratio ε / L (L the window's side) and, for each moment q, the
escort measure μ_i(q, ε) = P_i^q / Σ_j P_j^q (over the boxes with P > 0),
Chhabra & Jensen (Phys. Rev. Lett. 62, 1327, 1989) read the spectrum
directly as slopes against log(ε / L):

    α(q) = Σ μ_i log P_i / log ε          (the Hölder exponent of Eqs. 28–29)
    f(q) = Σ μ_i log μ_i / log ε          (the dimension of the set S_α, Eq. 31)
    τ(q) = log Σ P_i^q / log ε,   D_q = τ(q) / (q − 1),   f = q α − τ

without the Legendre transform of a numerically differentiated τ(q). Sums
are formed in logarithms (:func:`scipy.special.logsumexp`), so q = ±10 does
not overflow. Defined values: q = 0 counts the boxes with P > 0, so f(0) =
D_0 = Δσ of the support over the same boxes (the spectrum's maximum, checked
against box counting in ``support_dimension``); at q = 1 the limit
D_1 = α(1) = f(1) (the information dimension) replaces τ / (q − 1) = 0/0.

Limits: for q < 0 the sums are dominated by the boxes of smallest measure,
a handful of boundary nodes on a small domain, so α and f for negative q
carry the largest finite-size error (docs/analysis.md).
"""
from __future__ import annotations

import numpy as np
import xarray as xr
from scipy.special import logsumexp

from ..checks import check_integer
from ..errors import InputError
from .boxes import box_coords, box_nodes, box_sums, crop, fitted_boxes
from .ensemble import map_samples
from .fitting import CONFIDENCE, check_confidence, line_fit, t_quantile
from .inputs import GRID, LOAD, as_dataset, contact_set, field, sample_spacing, task_region

#: default moments q
MOMENTS = np.linspace(-10.0, 10.0, 41)


def _check_moments(q) -> np.ndarray:
    q = np.asarray(q, dtype=float).ravel()
    if q.size == 0 or not np.all(np.isfinite(q)):
        raise InputError("q", "must be a non-empty list of finite moments")
    q = np.sort(q)
    if np.any(np.diff(q) == 0):
        raise InputError("q", "holds a moment twice")
    return q


def _slopes(x: np.ndarray, values: np.ndarray, confidence: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Slope, its standard error and R² of each row of ``values`` against ``x``."""
    fits = [line_fit(x, row, confidence, "multifractal sums") for row in values]
    return (np.array([f.slope for f in fits]), np.array([f.slope_stderr for f in fits]),
            np.array([f.r_squared for f in fits]))


def multifractal_spectrum(measure: np.ndarray, spacing: float = 1.0, q=MOMENTS, base: int = 2,
                          box_range: tuple[int, int] | None = None, confidence: float = CONFIDENCE,
                          window: str = "origin") -> xr.Dataset:
    """τ(q), D_q, α(q) and f(α) of a non-negative measure on a grid of any dimension.

    Parameters
    ----------
    measure
        Nodal masses, e.g. the forces p̄ (N) with 0 off the contact set.
    spacing
        Grid spacing s (m), for the ``box_size`` coordinate.
    q
        Moments (any finite values, sorted on return).
    base, box_range, window
        Box sizes and the analysis window, as in :func:`~.box_counting.box_counting`.
    confidence
        Level of the intervals of α and f.

    Returns
    -------
    xarray.Dataset
        On ``q``: ``mass_exponent`` τ, ``generalised_dimension`` D_q,
        ``holder_exponent`` α, ``singularity_spectrum`` f and the standard
        errors and R² of the α and f fits; scalars ``spectrum_width``
        (α_max − α_min), ``spectrum_maximum`` (max f over q) and
        ``support_dimension`` (Δσ of the support by box counting, which
        equals f(0) when q holds 0) and ``maximum_excess`` (max f − Δσ,
        the check of the maximum against box counting).
    """
    q = _check_moments(q)
    confidence = check_confidence(confidence)
    window = crop(np.asarray(measure, dtype=float), base, window)
    if not np.all(np.isfinite(window)) or np.any(window < 0.0):
        raise InputError("measure", "must be finite and >= 0 (forces on the contact set, 0 elsewhere)")
    total = window.sum()
    if not total > 0.0:
        raise InputError("measure", "is zero on the analysis window: no contact force, no spectrum")
    nodes = box_nodes(window.shape[0], base)
    fitted = fitted_boxes(nodes, box_range, base)
    scale = np.log(nodes[fitted] / nodes[-1])
    alpha_sums, f_sums, tau_sums, occupied = [], [], [], []
    for k in nodes[fitted]:
        mass = box_sums(window / total, int(k)).ravel()
        log_mass = np.log(mass[mass > 0.0])
        weighted = q[:, None] * log_mass[None, :]
        log_partition = logsumexp(weighted, axis=1)
        log_escort = weighted - log_partition[:, None]
        escort = np.exp(log_escort)
        alpha_sums.append((escort * log_mass).sum(axis=1))
        f_sums.append((escort * log_escort).sum(axis=1))
        tau_sums.append(log_partition)
        occupied.append(log_mass.size)
    alpha, alpha_se, alpha_r2 = _slopes(scale, np.array(alpha_sums).T, confidence)
    f, f_se, f_r2 = _slopes(scale, np.array(f_sums).T, confidence)
    tau = _slopes(scale, np.array(tau_sums).T, confidence)[0]
    with np.errstate(divide="ignore", invalid="ignore"):
        dimension = np.where(q == 1.0, alpha, tau / (q - 1.0))
    support = -line_fit(scale, np.log(occupied), confidence, "box counts").slope
    t = t_quantile(confidence, int(fitted.sum()) - 2)
    widest = (np.argmax(alpha), np.argmin(alpha))
    parts = box_coords(nodes, spacing, fitted, "multifractal")
    q_var = {"units": "1", "long_name": "moment order q"}
    data = {
        "mass_exponent": ("q", tau, {"units": "1", "long_name": "mass exponent τ(q), Σ P^q ∝ ε^τ"}),
        "generalised_dimension": ("q", dimension, {"units": "1", "long_name": "generalised dimension "
                                                   "D_q = τ / (q − 1); D_1 = α(1)"}),
        "holder_exponent": ("q", alpha, {"units": "1", "long_name": "Hölder exponent α(q) (Eqs. 28–29)"}),
        "holder_exponent_stderr": ("q", alpha_se, {"units": "1", "long_name": "standard error of α(q)"}),
        "holder_exponent_r2": ("q", alpha_r2, {"units": "1", "long_name": "R² of the fit of α(q)"}),
        "singularity_spectrum": ("q", f, {"units": "1", "long_name": "singularity spectrum f(α(q)) (Eq. 31)"}),
        "singularity_spectrum_stderr": ("q", f_se, {"units": "1", "long_name": "standard error of f(q)"}),
        "singularity_spectrum_r2": ("q", f_r2, {"units": "1", "long_name": "R² of the fit of f(q)"}),
        "spectrum_width": ((), alpha[widest[0]] - alpha[widest[1]],
                           {"units": "1", "long_name": "width of the spectrum α_max − α_min over q"}),
        "spectrum_width_stderr": ((), float(np.hypot(alpha_se[widest[0]], alpha_se[widest[1]])),
                                  {"units": "1", "long_name": "standard error of the width "
                                                              "(the two α fits taken as independent)"}),
        "spectrum_maximum": ((), float(np.max(f)), {"units": "1", "long_name": "maximum of f over q"}),
        "spectrum_maximum_stderr": ((), float(f_se[np.argmax(f)]),
                                    {"units": "1", "long_name": "standard error of the maximum of f"}),
        "support_dimension": ((), support, {"units": "1", "long_name": "box-counting dimension Δσ of the "
                                                                       "support over the same boxes"}),
        "maximum_excess": ((), float(np.max(f)) - support,
                           {"units": "1", "long_name": "max f − Δσ: 0 for a concave spectrum, > 0 where "
                                                       "finite-size effects make f peak away from q = 0"}),
        "interval_t_value": ((), t, {"units": "1", "long_name": f"Student t of the {100 * confidence:g} % "
                                                                "interval: stderr × t is its half-width"}),
        **parts["fitted"],
    }
    return xr.Dataset(data, coords={"q": ("q", q, q_var), **parts["coords"]})


def force_spectrum(source, load_dim: str = LOAD, q=MOMENTS, base: int = 2, box_range: tuple[int, int] | None = None,
                   confidence: float = CONFIDENCE, on_error: str = "raise", window: str = "origin") -> xr.Dataset:
    """f(α) of the nodal forces of every result of ``source`` (Fig. 14), forces off the contact set ignored."""
    ds = as_dataset(source, load_dim)
    measure = field(ds, "force").where(contact_set(ds), 0.0)
    return map_samples(multifractal_spectrum, [measure], GRID, on_error=on_error, region=task_region(ds),
                       spacing=sample_spacing(ds), q=q,
                       base=base, box_range=box_range, confidence=confidence, window=window)


def spectrum_nulls(measure: np.ndarray, spacing: float = 1.0, q=MOMENTS, base: int = 2,
                   box_range: tuple[int, int] | None = None, window: str = "origin", permutations: int = 10,
                   seed: int = 0) -> xr.Dataset:
    """Width and maximum of f(α) of ``measure`` beside two nulls on the same support (Fig. 14).

    - *shuffled*: the same nodal masses permuted at random over the same
      support (``permutations`` draws from ``seed``): keeps the support and
      the distribution of p̄, destroys their arrangement;
    - *uniform*: equal masses on the same support: what the support alone gives.

    ``width_excess`` = width − mean shuffled width is the part of the width
    that the arrangement of the forces makes; a spectrum of a measure that is
    multifractal only through its support and its histogram has none.
    """
    permutations = check_integer("permutations", permutations, 1)
    measure = np.asarray(measure, dtype=float)
    options = dict(spacing=spacing, q=q, base=base, box_range=box_range, window=window)
    real = multifractal_spectrum(measure, **options)
    support = measure > 0.0
    rng = np.random.default_rng(seed)
    shuffled = []
    for _ in range(permutations):
        values = measure.copy()
        values[support] = rng.permutation(measure[support])
        shuffled.append(multifractal_spectrum(values, **options))
    uniform = multifractal_spectrum(support.astype(float), **options)
    widths = np.array([float(s["spectrum_width"]) for s in shuffled])
    maxima = np.array([float(s["spectrum_maximum"]) for s in shuffled])
    width = float(real["spectrum_width"])
    return xr.Dataset({
        "spectrum_width": ((), width, real["spectrum_width"].attrs),
        "spectrum_maximum": ((), float(real["spectrum_maximum"]), real["spectrum_maximum"].attrs),
        "shuffled_width": ((), float(widths.mean()), {"units": "1", "long_name": "mean width of f(α) of the "
                                                                                "forces shuffled over the support"}),
        "shuffled_width_std": ((), float(widths.std(ddof=1)) if permutations > 1 else np.nan,
                               {"units": "1", "long_name": "standard deviation of the shuffled widths"}),
        "shuffled_maximum": ((), float(maxima.mean()), {"units": "1", "long_name": "mean maximum of f of the "
                                                                                  "shuffled forces"}),
        "uniform_width": ((), float(uniform["spectrum_width"]),
                          {"units": "1", "long_name": "width of f(α) of equal forces on the support"}),
        "uniform_maximum": ((), float(uniform["spectrum_maximum"]),
                            {"units": "1", "long_name": "maximum of f of equal forces on the support"}),
        "width_excess": ((), width - float(widths.mean()),
                         {"units": "1", "long_name": "width − mean shuffled width (the arrangement's share)"}),
    })


def force_spectrum_nulls(source, load_dim: str = LOAD, q=MOMENTS, base: int = 2,
                         box_range: tuple[int, int] | None = None, window: str = "origin", permutations: int = 10,
                         seed: int = 0, on_error: str = "mark") -> xr.Dataset:
    """:func:`spectrum_nulls` of the nodal forces of every result of ``source``."""
    ds = as_dataset(source, load_dim)
    measure = field(ds, "force").where(contact_set(ds), 0.0)
    return map_samples(spectrum_nulls, [measure], GRID, on_error=on_error, region=task_region(ds),
                       spacing=sample_spacing(ds), q=q, base=base, box_range=box_range, window=window,
                       permutations=permutations, seed=seed)
