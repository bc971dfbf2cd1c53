"""The combined datasets of the paper's studies, opened once, and the numbers read from them per seed.

:class:`PaperResults` maps a study key (:data:`~.registry.STUDIES`) to its
root dataset and its tangential group. The helpers turn per-sample numbers
into the ensemble mean and its Student-t interval over seeds
(:func:`interval`), and pair two values of an axis seed by seed
(:func:`paired`): the same seed draws the same random numbers at every Δ, so
differences across Δ are taken per seed before the interval.
"""
from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import h5py
import numpy as np
import xarray as xr

from ..analysis.ensemble import ensemble_statistics
from ..analysis.fitting import CONFIDENCE
from ..errors import InputError
from ..farm import load_study
from .registry import STUDIES, PaperStudy


@dataclass
class PaperResults:
    """Study datasets by key: ``root[key]`` and ``tangential[key]`` (None without sweeps).

    :meth:`cached` keeps what several claims and figures read (Δσ of every
    contact set of a study, bulk compliances, footprint centroids) so that
    each is computed once per report.
    """

    folder: Path
    studies: dict[str, Path]
    root: dict[str, xr.Dataset] = field(default_factory=dict)
    tangential: dict[str, xr.Dataset | None] = field(default_factory=dict)
    _cache: dict = field(default_factory=dict, repr=False)

    @classmethod
    def open(cls, folder: Path, study_files: dict[str, Path]) -> PaperResults:
        """The combined files ``<folder>/<name>.nc`` of the studies in ``study_files`` that exist."""
        results = cls(Path(folder), dict(study_files))
        for key, path in study_files.items():
            combined = Path(folder) / f"{load_study(path).name}.nc"
            if not combined.exists():
                continue
            with h5py.File(combined, "r") as f:
                has_sweeps = "tangential" in f
            results.root[key] = xr.open_dataset(combined).load()
            results.tangential[key] = (xr.open_dataset(combined, group="tangential").load() if has_sweeps
                                       else None)
        return results

    def has(self, *keys: str) -> bool:
        return all(k in self.root for k in keys)

    def tasks(self, key: str):
        """The tasks of study ``key`` (to rebuild a task's topography for a map)."""
        return load_study(self.studies[key]).tasks()

    def cached(self, name: tuple, compute: Callable[[], Any]) -> Any:
        """``compute()`` the first time ``name`` is asked for, the same object afterwards."""
        if name not in self._cache:
            self._cache[name] = compute()
        return self._cache[name]


def study_files(folder: Path, studies: tuple[PaperStudy, ...] = STUDIES) -> dict[str, Path]:
    """``{key: <folder>/<stem>.toml}`` of ``studies``, each checked to exist."""
    files = {}
    for study in studies:
        path = Path(folder) / f"{study.stem}.toml"
        if not path.exists():
            raise InputError("studies", f"{path} is missing")
        files[study.key] = path
    return files


def interval(values, confidence: float = CONFIDENCE) -> tuple[float, float, float, int]:
    """Mean, lower and upper bound of its Student-t interval, and n, of the finite ``values`` (one per seed).

    The interval is :func:`~roughcontact.analysis.ensemble_statistics`' (NaN for fewer than 2 values).
    """
    values = np.asarray(values, dtype=float).ravel()
    values = values[np.isfinite(values)]
    if values.size == 0:
        return np.nan, np.nan, np.nan, 0
    if values.size == 1:
        return float(values[0]), np.nan, np.nan, 1
    stats = ensemble_statistics(xr.Dataset({"v": ("seed", values)}), confidence=confidence)
    return float(stats["v"]), float(stats["v_lower"]), float(stats["v_upper"]), values.size


def nearest(ds: xr.Dataset | xr.DataArray, **indexers):
    """``ds.sel(indexers)`` for float coordinates: the nearest value, refused unless within 1e-6 of it (relative).

    A study that lacks the asked-for load, closure, shift or Δ gives a one-line
    :class:`InputError`, not silently the nearest other value.
    """
    out = ds.sel(indexers, method="nearest")
    for dim, wanted in indexers.items():
        got = np.asarray(out[dim].values, dtype=float)
        if not np.allclose(got, wanted, rtol=1e-6, atol=0.0):
            raise InputError(dim, f"the study has no {dim} = {wanted:g} (nearest: {float(np.ravel(got)[0]):g})")
    return out


def paired(values: xr.DataArray, dim: str, a, b, log: bool = False) -> xr.DataArray:
    """values(dim = b) − values(dim = a) per remaining sample (log ratio with ``log``)."""
    high, low = nearest(values, **{dim: b}), nearest(values, **{dim: a})
    return np.log(high / low) if log else high - low
