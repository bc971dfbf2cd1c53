"""Contact clusters (islands): number, sizes, perimeters and the load they carry (beyond the paper).

Clusters are the connected components of the contact set, labelled by
:func:`scipy.ndimage.label` with edge-sharing neighbours (``connectivity``
4, the default: two nodes touching at a corner are two islands) or also
corner-sharing ones (8). Per cluster: its nodes, area (nodes × s²), the
load Σ p̄ it carries and its perimeter, the number of node edges between the
cluster and a node out of contact or the grid's border, times s.

Perimeter-corrected area: Yastrebov, Anciaux & Molinari (Tribol. Int. 114,
161, 2017) correct node counting for the contact boundary running between
nodes, A' = s² (N_c − κ N_e), with N_e the contact/non-contact edges and
κ = (π − 1 + ln 2)/24 ≈ 0.118 for their traction-per-pixel discretisation.
It is reported as ``corrected_contact_area``. With this package's Eq. 10
punches node counting is already nearly unbiased for a Hertz contact
(within 3 %, tests/test_analysis_clusters.py), and A' lies a few per cent
below it: see docs/analysis.md before using A'.

Size distribution: the number of clusters per logarithmic size bin (1, 2–3,
4–7, … nodes), and the load fraction carried by the ``largest`` clusters
(by area).
"""
from __future__ import annotations

import numpy as np
import xarray as xr
from scipy import ndimage

from ..checks import check_choice
from ..errors import InputError
from .ensemble import map_samples
from .inputs import GRID, LOAD, as_dataset, contact_set, field, sample_spacing, task_region

#: κ of the perimeter correction (Yastrebov, Anciaux & Molinari 2017)
PERIMETER_CORRECTION = (np.pi - 1.0 + np.log(2.0)) / 24.0
_STRUCTURES = {4: ndimage.generate_binary_structure(2, 1), 8: ndimage.generate_binary_structure(2, 2)}


def cluster_perimeters(labels: np.ndarray, count: int) -> np.ndarray:
    """Exposed node edges of each cluster 1 … count: edges to a non-contact node or to the border."""
    padded = np.pad(labels, 1)
    core = padded[1:-1, 1:-1]
    exposed = np.zeros(count + 1, dtype=np.int64)
    for axis in (0, 1):
        for shift in (1, -1):
            neighbour = np.roll(padded, shift, axis=axis)[1:-1, 1:-1]
            exposed += np.bincount(core[(core > 0) & (neighbour == 0)], minlength=count + 1)
    return exposed[1:]


def contact_clusters(contact: np.ndarray, force: np.ndarray | None = None, spacing: float = 1.0,
                     connectivity: int = 4, largest: tuple[int, ...] = (1, 5, 10)) -> xr.Dataset:
    """Islands of one contact set.

    Parameters
    ----------
    contact
        The contact set S, (nx, ny).
    force
        Nodal forces p̄ (N), for the load per cluster; optional.
    spacing
        Grid spacing s (m).
    connectivity
        4 (edge neighbours) or 8 (also corner neighbours).
    largest
        Counts k of the largest clusters whose load fraction is reported.

    Raises
    ------
    InputError
        For an empty contact set (no cluster).
    """
    connectivity = check_choice("connectivity", connectivity, tuple(_STRUCTURES))
    mask = np.asarray(contact, dtype=bool)
    if mask.ndim != 2:
        raise InputError("contact", f"must be a 2-D contact set, got {mask.ndim} dimension(s)")
    labels, count = ndimage.label(mask, structure=_STRUCTURES[connectivity])
    if count == 0:
        raise InputError("contact", "is empty: there is no cluster")
    nodes = np.bincount(labels.ravel(), minlength=count + 1)[1:]
    edges = cluster_perimeters(labels, count)
    order = np.argsort(nodes, kind="stable")[::-1]
    size_edges = 2 ** np.arange(int(np.log2(mask.size)) + 2)
    histogram, _ = np.histogram(nodes, bins=size_edges)
    data = {
        "cluster_count": ((), count, {"units": "1", "long_name": "number of contact clusters (islands)"}),
        "largest_cluster_area": ((), nodes.max() * spacing**2, {"units": "m2", "long_name": "area of the "
                                                                                             "largest cluster"}),
        "mean_cluster_area": ((), nodes.mean() * spacing**2, {"units": "m2", "long_name": "mean cluster area"}),
        "contact_perimeter": ((), edges.sum() * spacing, {"units": "m", "long_name": "total perimeter of the "
                                                                                      "clusters"}),
        "corrected_contact_area": ((), (nodes.sum() - PERIMETER_CORRECTION * edges.sum()) * spacing**2,
                                   {"units": "m2", "long_name": "perimeter-corrected contact area "
                                                                "s² (N_c − κ N_e), κ = (π − 1 + ln 2)/24"}),
        "cluster_size_count": ("cluster_size", histogram, {"units": "1", "long_name": "clusters per size bin"}),
    }
    coords = {"cluster_size": ("cluster_size", size_edges[:-1], {"units": "1", "long_name": "smallest cluster "
                                                                 "of the bin, in nodes (bins [2^j, 2^(j+1)))"})}
    if force is not None:
        force = np.asarray(force, dtype=float)
        if force.shape != mask.shape or not np.all(np.isfinite(force[mask])):
            raise InputError("force", "must be finite on the contact set and shaped like it")
        loads = ndimage.sum_labels(force, labels, index=np.arange(1, count + 1))
        total = loads.sum()
        if not total > 0:
            raise InputError("force", "the contact set carries no load")
        ranked = np.cumsum(loads[order]) / total
        kept = np.asarray(largest)
        if kept.ndim != 1 or kept.size == 0 or not np.issubdtype(kept.dtype, np.integer) or np.any(kept < 1):
            raise InputError("largest", f"must be a list of cluster counts >= 1, got {largest!r}")
        data["largest_load_fraction"] = ("largest", ranked[np.minimum(kept, count) - 1],
                                         {"units": "1", "long_name": "fraction of the load carried by the "
                                                                     "k largest clusters"})
        coords["largest"] = ("largest", kept, {"units": "1", "long_name": "k largest clusters (by area)"})
    return xr.Dataset(data, coords=coords)


def cluster_statistics(source, load_dim: str = LOAD, connectivity: int = 4, largest: tuple[int, ...] = (1, 5, 10),
                       on_error: str = "raise") -> xr.Dataset:
    """:func:`contact_clusters` of every contact set of ``source``; the loads only if it stores ``force``."""
    ds = as_dataset(source, load_dim)
    arrays = [contact_set(ds)] + ([field(ds, "force")] if "force" in ds else [])
    return map_samples(contact_clusters, arrays, GRID, on_error=on_error, region=task_region(ds),
                       spacing=sample_spacing(ds),
                       connectivity=connectivity, largest=largest)
