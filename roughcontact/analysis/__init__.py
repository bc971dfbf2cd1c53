"""Measures of the contact domain and of the pressure field (§3.2–§3.4, §5–§6).

Each measure takes normal results (:class:`~roughcontact.normal.NormalResult`,
a sequence of them) or a dataset with fields on (…, x, y) and returns a
labelled :class:`xarray.Dataset` (CF ``units`` and ``long_name``), every
fitted quantity with its standard error and confidence interval. Leading
dimensions (``seed``, ``fractal_dimension``, ``normal_load``, …) are kept:
the measure runs per sample, and :func:`ensemble_statistics` reduces one of
them to the mean and its interval. The array-level functions
(:func:`box_counting`, :func:`multifractal_spectrum`, …) take numpy arrays.

- box-counting Δσ, Δσ against load (§3.2, Figs. 2, 6d): :func:`contact_dimension`;
  :func:`box_counting` on an array;
- renormalisation and size effect (Eqs. 12–13, Fig. 3a): :func:`contact_renormalisation`;
  :func:`renormalisation`, :func:`size_effect`;
- contact area against resolution (Fig. 1d): :func:`contact_area_resolution`; :func:`area_resolution_fit`;
- closure curves (Figs. 5c, 8a): :func:`closure_curve`; :func:`hyperbola_fit`;
- force statistics (Fig. 13): :func:`contact_force_statistics`; :func:`force_statistics`;
- multifractal f(α) (Eqs. 28–31, Fig. 14): :func:`force_spectrum`; :func:`multifractal_spectrum`;
- clusters (beyond the paper): :func:`cluster_statistics`; :func:`contact_clusters`;
- slip area against Q, E_f against P (Figs. 10a, 12): :func:`slip_area_linearity`,
  :func:`frictional_energy_scaling`; :func:`slip_line`, :func:`energy_power_law`;
- A_r against P and Persson's κ (Figs. 5a–b): :func:`area_load_exponent`, :func:`persson_kappa`;
- where slip starts (Fig. 9): :func:`slip_zone_statistics`; centroid paths (Fig. 11): :func:`centroid_paths`;
- force laws and uniformity (Fig. 13): :func:`contact_force_law_comparison`, :func:`contact_force_uniformity`;
- f(α) against its nulls (Fig. 14): :func:`force_spectrum_nulls`;
- a per-seed slope along any axis, for "rises/falls" claims: :func:`trend`;
- maps of fields on the grid: :mod:`.maps` (matplotlib).

The PETSc-based helpers (:func:`bulk_compliance`, :func:`solve_resolutions`)
live in :mod:`.petsc` and are imported from there, so this package imports
without PETSc.
"""
from .area import area_load_exponent, persson_kappa
from .box_counting import box_counting, box_counts, contact_dimension
from .centroids import centroid_paths
from .closure import closure_curve, hyperbola, hyperbola_fit
from .clusters import cluster_statistics, contact_clusters
from .ensemble import ensemble_statistics, map_samples, trend
from .fitting import LineFit, line_fit, power_law_fit, semilog_fit
from .inputs import as_dataset, standard_names
from .multifractal import force_spectrum, force_spectrum_nulls, multifractal_spectrum
from .pressure_statistics import (
                                  contact_force_law_comparison,
                                  contact_force_statistics,
                                  contact_force_uniformity,
                                  force_statistics,
)
from .renormalisation import contact_renormalisation, renormalisation, size_effect
from .resolution import area_resolution_fit, contact_area_resolution
from .slip_zones import slip_zone_statistics
from .tangential import energy_power_law, frictional_energy_scaling, slip_area_linearity, slip_line

__all__ = [
                                  "LineFit",
                                  "area_load_exponent",
                                  "area_resolution_fit",
                                  "as_dataset",
                                  "box_counting",
                                  "box_counts",
                                  "centroid_paths",
                                  "closure_curve",
                                  "cluster_statistics",
                                  "contact_area_resolution",
                                  "contact_clusters",
                                  "contact_dimension",
                                  "contact_force_law_comparison",
                                  "contact_force_statistics",
                                  "contact_force_uniformity",
                                  "contact_renormalisation",
                                  "energy_power_law",
                                  "ensemble_statistics",
                                  "force_spectrum",
                                  "force_spectrum_nulls",
                                  "force_statistics",
                                  "frictional_energy_scaling",
                                  "hyperbola",
                                  "hyperbola_fit",
                                  "line_fit",
                                  "map_samples",
                                  "multifractal_spectrum",
                                  "persson_kappa",
                                  "power_law_fit",
                                  "renormalisation",
                                  "semilog_fit",
                                  "size_effect",
                                  "slip_area_linearity",
                                  "slip_line",
                                  "slip_zone_statistics",
                                  "standard_names",
                                  "trend",
]
