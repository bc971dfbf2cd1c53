"""Box-counting dimension Δσ of the contact domain S (§3.2, Figs. 2 and 6d).

N(ε), the number of boxes of side ε = k s that hold at least one contact
node, scales as N ∝ ε^(−Δσ) over the range where S looks self-similar; Δσ is
minus the slope of log N against log ε (Mandelbrot 1982; the paper's [14],
[18]). Box sizes are powers of a base (2 by default) on the analysis window
of :mod:`.boxes`. Two readings are reported:

- ``contact_dimension``: the fitted slope over ``box_range`` with its
  Student-t interval (:mod:`.fitting`), the paper's Δσ;
- ``grid_scale_dimension``: log(N(s) / N(b s)) / log b, S seen at the grid's
  own scale only. Isolated nodes give 0 (every node is its own box at both
  sizes), lines 1, filled patches 2: the paper's "Δσ close to 0.0" at small
  loads (Fig. 6d) is this pointwise regime.

Limits: on a finite window N(ε) saturates at the number of boxes for large
ε (slope → 2) and counts single nodes at ε = s (slope → 0 for sparse sets),
so Δσ depends on the fitted range; compare values only over the same range
and grid (docs/analysis.md).
"""
from __future__ import annotations

import numpy as np
import xarray as xr

from ..errors import InputError
from .boxes import box_coords, box_nodes, box_sums, crop, fitted_boxes
from .ensemble import map_samples
from .fitting import CONFIDENCE, fit_variables, power_law_fit
from .inputs import GRID, LOAD, as_dataset, contact_set, sample_spacing, task_region


def box_counts(mask: np.ndarray, base: int = 2, window: str = "origin") -> tuple[np.ndarray, np.ndarray]:
    """Box sides k (nodes) and the number N(k) of boxes holding a node of ``mask``, on the analysis ``window``."""
    window = crop(np.asarray(mask, dtype=bool), base, window)
    nodes = box_nodes(window.shape[0], base)
    counts = np.array([np.count_nonzero(box_sums(window, int(k))) for k in nodes])
    return nodes, counts


def box_counting(contact: np.ndarray, spacing: float = 1.0, base: int = 2,
                 box_range: tuple[int, int] | None = None, confidence: float = CONFIDENCE,
                 window: str = "origin") -> xr.Dataset:
    """Δσ of one contact set (a boolean array of any dimension, usually (nx, ny)).

    Parameters
    ----------
    contact
        The contact set S (True where in contact).
    spacing
        Grid spacing s (m); sets the ``box_size`` coordinate only.
    base
        Box sides are powers of ``base`` nodes.
    box_range
        (smallest, largest) box side of the fit, in nodes; default 1 … side / base².
    confidence
        Level of the interval.
    window
        ``"origin"`` or ``"cover"`` (:mod:`.boxes`): ``"cover"`` for a
        footprint that is not the square grid (a lens, §3.4).

    Raises
    ------
    InputError
        For an empty set (no box holds contact, Δσ undefined), a window too
        small for 3 box sizes, or a ``box_range`` beyond the window. A single
        contact node is defined: N = 1 at every size, Δσ = 0 exactly.
    """
    nodes, counts = box_counts(contact, base, window)
    if counts[0] == 0:
        raise InputError("contact", "is empty in the analysis window: no box holds contact, Δσ is undefined")
    fitted = fitted_boxes(nodes, box_range, base)
    fit = power_law_fit(nodes[fitted] * spacing, counts[fitted], confidence, "box counts")
    parts = box_coords(nodes, spacing, fitted, "contact_dimension")
    data = {
        "box_count": ("box_size", counts, {"units": "1", "long_name": "boxes holding contact N(ε)"}),
        **parts["fitted"],
        **fit_variables("contact_dimension", fit, "box-counting dimension Δσ of the contact set (§3.2)",
                        scale=-1.0),
        "grid_scale_dimension": ((), np.log(counts[0] / counts[1]) / np.log(base),
                                 {"units": "1", "long_name": "Δσ at the grid's own scale, "
                                                             "log(N(s) / N(b s)) / log b"}),
        "window_nodes": ((), nodes[-1], {"units": "1", "long_name": "side of the analysis window in nodes"}),
    }
    return xr.Dataset(data, coords=parts["coords"])


def contact_dimension(source, load_dim: str = LOAD, base: int = 2, box_range: tuple[int, int] | None = None,
                      confidence: float = CONFIDENCE, on_error: str = "raise", window: str = "origin") -> xr.Dataset:
    """Δσ of every contact set of ``source`` (results or a dataset), e.g. Δσ against load (Fig. 6d).

    ``on_error="mark"`` turns an empty contact set into NaN with the
    variable ``undefined`` saying why (:func:`~.ensemble.map_samples`).
    """
    ds = as_dataset(source, load_dim)
    return map_samples(box_counting, [contact_set(ds)], GRID, on_error=on_error, region=task_region(ds),
                       spacing=sample_spacing(ds),
                       base=base, box_range=box_range, confidence=confidence, window=window)
