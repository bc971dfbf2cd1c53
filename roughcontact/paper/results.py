"""The combined datasets of the paper's studies, opened once, and the numbers read from them per seed.

:class:`PaperResults` maps a study key (:data:`~.registry.STUDIES`) to its
root dataset and its tangential group. The helpers turn per-sample numbers
into the ensemble mean and its Student-t interval over seeds
(:func:`interval`), and pair two values of an axis seed by seed
(:func:`paired`): the same seed draws the same random numbers at every Δ, so
differences across Δ are taken per seed before the interval.
"""
from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import xarray as xr
from scipy import stats

from ..analysis.fitting import CONFIDENCE
from ..errors import InputError
from ..farm import load_study
from .registry import STUDIES, PaperStudy


@dataclass
class PaperResults:
    """Study datasets by key: ``root[key]`` and ``tangential[key]`` (None without sweeps)."""

    folder: Path
    studies: dict[str, Path]
    root: dict[str, xr.Dataset] = field(default_factory=dict)
    tangential: dict[str, xr.Dataset | None] = field(default_factory=dict)

    @classmethod
    def open(cls, folder: Path, study_files: dict[str, Path]) -> PaperResults:
        """The combined files ``<folder>/<name>.nc`` of the studies in ``study_files`` that exist."""
        results = cls(Path(folder), dict(study_files))
        for key, path in study_files.items():
            name = load_study(path).name
            combined = Path(folder) / f"{name}.nc"
            if not combined.exists():
                continue
            results.root[key] = xr.open_dataset(combined).load()
            try:
                results.tangential[key] = xr.open_dataset(combined, group="tangential").load()
            except OSError:
                results.tangential[key] = None
        return results

    def has(self, *keys: str) -> bool:
        return all(k in self.root for k in keys)

    def tasks(self, key: str):
        """The tasks of study ``key`` (to rebuild a task's topography for a map)."""
        return load_study(self.studies[key]).tasks()


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
    """Mean, lower and upper bound of its Student-t interval, and n, of the finite ``values`` (one per seed)."""
    values = np.asarray(values, dtype=float).ravel()
    values = values[np.isfinite(values)]
    n = values.size
    if n == 0:
        return np.nan, np.nan, np.nan, 0
    mean = float(values.mean())
    if n < 2:
        return mean, np.nan, np.nan, n
    half = stats.t.ppf(0.5 + confidence / 2.0, n - 1) * values.std(ddof=1) / np.sqrt(n)
    return mean, mean - half, mean + half, n


def paired(values: xr.DataArray, dim: str, a, b, log: bool = False) -> xr.DataArray:
    """values(dim = b) − values(dim = a) per remaining sample (log ratio with ``log``)."""
    high = values.sel({dim: b}, method="nearest")
    low = values.sel({dim: a}, method="nearest")
    return np.log(high / low) if log else high - low


def nearest(ds: xr.Dataset | xr.DataArray, **indexers):
    """``ds.sel(..., method="nearest")`` for float coordinates."""
    return ds.sel(indexers, method="nearest")
