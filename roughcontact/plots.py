"""Figures of the paper, drawn with matplotlib's non-interactive backend."""
from __future__ import annotations

from pathlib import Path

import xarray as xr


def contact_area_vs_load(ds: xr.Dataset, path: str | Path, title: str = "") -> Path:
    """Real contact area fraction A_r/A_0 against load P (paper Fig. 5a)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(5.0, 3.8), constrained_layout=True)
    ax.plot(ds["load"], ds["contact_fraction"], "o-")
    ax.set_xlabel(f"{ds['load'].attrs['long_name']} [{ds['load'].attrs['units']}]")
    ax.set_ylabel("real contact area fraction A_r / A_0")
    ax.set_xlim(left=0)
    ax.set_ylim(bottom=0)
    ax.grid(alpha=0.3)
    if title:
        ax.set_title(title)
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=120)
    plt.close(fig)
    return path
