"""Paths of the shear centroid G_Q and of the pressure centroid G_P (§4.2, Fig. 11).

Under a fixed rotation the discrete Cattaneo theorem (Eqs. 21–24) gives the
shear q = f (p − p*) with p* the normal solution at the corrective load
P* = P − Q/f, so the shear centroid is

.. math::  G_Q = (P\\,G_P(P) − P^*\\,G_P(P^*)) / (P − P^*),

an identity :func:`centroid_paths` checks (``increment_identity_error``).
The paper reads Fig. 11 as "G_Q moves away from the centroid as Q → fP,
along the reverse of the path of G_P under rising P". The identity shows
when that holds: G_Q(P*) equals G_P(P*) only where G_P does not move.
``reverse_path_gap`` measures the difference on the loads where both are
known, beside ``pressure_path_length``, the excursion of G_P itself.

Distances are divided by the radius R = √(A_0/π) of the nominal footprint
and measured from its centroid C (``centre_x``, ``centre_y``), in the frame of
the task's grid, where both centroids are recorded.
"""
from __future__ import annotations

import numpy as np
import xarray as xr

from ..checks import require_finite_positive
from ..errors import InputError


def centroid_paths(root: xr.Dataset, tangential: xr.Dataset, centre_x: xr.DataArray | float,
                   centre_y: xr.DataArray | float, load: float, load_dim: str = "normal_load") -> xr.Dataset:
    """Distances of G_Q (along ``Q_over_fP``) and G_P (along the load) from C, and the checks of the module notes.

    ``root`` is a study dataset (``centroid_x``/``_y`` = G_P, ``nominal_area``),
    ``tangential`` its tangential group (``centroid_x``/``_y`` = G_Q on
    (…, ``load_dim``, ``Q_over_fP``)), ``load`` the P of the sweep (N).
    """
    for name in ("centroid_x", "centroid_y", "nominal_area"):
        if name not in root:
            raise InputError("root", f"has no {name!r}: not a study dataset")
    if "Q_over_fP" not in tangential.dims:
        raise InputError("tangential", "has no Q_over_fP dimension: not a tangential group")
    load = require_finite_positive("load", load)
    friction = require_finite_positive("friction", tangential.attrs.get("friction", root.attrs.get("friction", 0)))
    radius = np.sqrt(root["nominal_area"] / np.pi)
    gp_x, gp_y = root["centroid_x"], root["centroid_y"]
    gq_x = tangential["centroid_x"].sel({load_dim: load})
    gq_y = tangential["centroid_y"].sel({load_dim: load})
    pressure_distance = np.hypot(gp_x - centre_x, gp_y - centre_y) / radius
    shear_distance = np.hypot(gq_x - centre_x, gq_y - centre_y) / radius
    # the corrective loads P* = P − Q/f of the sweep, matched to the loads of the root sweep
    corrective = load * (1.0 - tangential["Q_over_fP"].values)
    loads = root[load_dim].values
    match = np.array([np.flatnonzero(np.isclose(loads, p, rtol=1e-9, atol=0.0))[:1] for p in corrective],
                     dtype=object)
    pairs = [(k, int(m[0])) for k, m in enumerate(match) if len(m) and 0.0 < corrective[k] < load]
    at = int(np.flatnonzero(np.isclose(loads, load, rtol=1e-9, atol=0.0))[0])
    gap, identity = [], []
    for k, j in pairs:
        gq = np.stack([gq_x.isel(Q_over_fP=k), gq_y.isel(Q_over_fP=k)])
        gp_star = np.stack([gp_x.isel({load_dim: j}), gp_y.isel({load_dim: j})])
        gp_full = np.stack([gp_x.isel({load_dim: at}), gp_y.isel({load_dim: at})])
        p_star = corrective[k]
        predicted = (load * gp_full - p_star * gp_star) / (load - p_star)
        gap.append(np.hypot(*(gq - gp_star)) / radius.values)
        identity.append(np.hypot(*(gq - predicted)) / radius.values)
    dims = tuple(d for d in gp_x.dims if d != load_dim)
    below = root[load_dim] <= load
    start = pressure_distance.where(below).isel({load_dim: 0})
    excursion = np.hypot(gp_x - gp_x.isel({load_dim: 0}), gp_y - gp_y.isel({load_dim: 0})).where(below) / radius
    out = xr.Dataset({
        "shear_centroid_distance": shear_distance.assign_attrs(units="1", long_name="|G_Q − C| / R"),
        "pressure_centroid_distance": pressure_distance.assign_attrs(units="1", long_name="|G_P − C| / R"),
        "pressure_path_length": excursion.max(load_dim).assign_attrs(
            units="1", long_name="largest |G_P(P') − G_P(P_min)| / R over P' ≤ P"),
        "pressure_centroid_start": start.assign_attrs(units="1", long_name="|G_P − C| / R at the smallest load"),
    })
    if pairs:
        out["reverse_path_gap"] = (dims, np.nanmax(np.stack(gap), axis=0),
                                   {"units": "1", "long_name": "largest |G_Q(Q) − G_P(P − Q/f)| / R"})
        out["increment_identity_error"] = (dims, np.nanmax(np.stack(identity), axis=0),
                                           {"units": "1", "long_name": "largest |G_Q − (P G_P(P) − P* G_P(P*)) / "
                                                                       "(P − P*)| / R"})
    out.attrs["friction"] = friction
    return out
