"""Where slip starts: slip nodes on the edges of contact clusters and at low pressure (§4.2, Fig. 9).

The discrete Cattaneo theorem (Eqs. 21–24) makes the slip set at Q the part
of the contact set S(P) that the corrective solution P* = P − Q/f has left:
the nodes that unload first when the punch is lifted. The paper reads
Fig. 9 as "slip starts at the boundary of the clusters, where the pressure is
lowest". Three numbers test it on one state (zone codes of
:data:`roughcontact.tangential.dataset.ZONES`: 0 no contact, 1 stick, 2 slip):

- ``boundary_enrichment``: the share of slip nodes on a cluster boundary
  divided by the share of all contact nodes on one (> 1: slip prefers edges);
  a boundary node is a contact node with a 4-neighbour outside S or outside
  the grid;
- ``slip_force_ratio``: mean nodal force p̄ on slip nodes over that on stick
  nodes (< 1: slip at low pressure);
- ``low_force_overlap``: the share of slip nodes among the |slip| contact
  nodes of lowest p̄ (1: slip is exactly the least loaded nodes).
"""
from __future__ import annotations

import numpy as np
import xarray as xr

from ..errors import InputError
from .ensemble import map_samples
from .inputs import GRID

NO_CONTACT, STICK, SLIP = 0, 1, 2


def cluster_boundary(contact: np.ndarray) -> np.ndarray:
    """Contact nodes with at least one of their 4 neighbours outside the contact set or the grid."""
    contact = np.asarray(contact, dtype=bool)
    padded = np.pad(contact, 1, constant_values=False)
    inner = (padded[:-2, 1:-1] & padded[2:, 1:-1] & padded[1:-1, :-2] & padded[1:-1, 2:])
    return contact & ~inner


def slip_zones(zone: np.ndarray, force: np.ndarray) -> xr.Dataset:
    """Boundary enrichment, force ratio and low-force overlap of the slip set of one state (module notes).

    ``zone`` holds the codes 0/1/2 (−1, "not computed", is refused); ``force``
    the nodal forces p̄ of the normal solution at the same P.
    """
    zone = np.asarray(zone)
    force = np.asarray(force, dtype=float)
    if zone.shape != force.shape:
        raise InputError("force", f"shape {force.shape} differs from the zones' {zone.shape}")
    if np.any((zone != NO_CONTACT) & (zone != STICK) & (zone != SLIP)):
        raise InputError("zone", "holds codes other than 0 (no contact), 1 (stick), 2 (slip): not a computed state")
    contact = zone != NO_CONTACT
    slip, stick = zone == SLIP, zone == STICK
    if not slip.any() or not stick.any():
        raise InputError("zone", f"holds {int(slip.sum())} slip and {int(stick.sum())} stick node(s); "
                                 "the measures compare the two")
    boundary = cluster_boundary(contact)
    slip_share = boundary[slip].mean()
    contact_share = boundary[contact].mean()
    order = np.argsort(force[contact], kind="stable")
    lowest = np.zeros(int(contact.sum()), dtype=bool)
    lowest[order[:int(slip.sum())]] = True
    overlap = float(slip[contact][lowest].mean())
    return xr.Dataset({
        "slip_boundary_share": ((), float(slip_share), {"units": "1", "long_name": "share of slip nodes on a "
                                                                                   "cluster boundary"}),
        "contact_boundary_share": ((), float(contact_share), {"units": "1", "long_name": "share of contact nodes "
                                                                                         "on a cluster boundary"}),
        "boundary_enrichment": ((), float(slip_share / contact_share),
                                {"units": "1", "long_name": "slip boundary share / contact boundary share"}),
        "slip_force_ratio": ((), float(force[slip].mean() / force[stick].mean()),
                             {"units": "1", "long_name": "mean p̄ on slip nodes / mean p̄ on stick nodes"}),
        "low_force_overlap": ((), overlap, {"units": "1", "long_name": "share of slip nodes among the |slip| "
                                                                       "least loaded contact nodes"}),
        "slip_nodes": ((), int(slip.sum()), {"units": "1", "long_name": "slip nodes"}),
    })


def slip_zone_statistics(zone: xr.DataArray, force: xr.DataArray, on_error: str = "mark") -> xr.Dataset:
    """:func:`slip_zones` of every state: ``zone`` (…, x, y) of a tangential group, ``force`` of its root.

    Both are broadcast against each other (the root's force has no Q
    dimension); select the loads that have a sweep first (elsewhere the zones
    are −1 and the state is marked undefined). Each state is cut to its
    task's own grid (zones ≥ 0), as the other grid measures.
    """
    return map_samples(slip_zones, [zone, force], GRID, on_error=on_error, region=zone >= 0)
