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
    loads = root[load_dim].values
    index = {float(p): j for j, p in enumerate(loads)}
    if load not in index or load not in tangential[load_dim].values:
        raise InputError("load", f"P = {load:g} N is not a load of both the root sweep and the tangential group")
    radius = np.sqrt(root["nominal_area"] / np.pi)
    gp_x, gp_y = root["centroid_x"], root["centroid_y"]
    gq_x = tangential["centroid_x"].sel({load_dim: load})
    gq_y = tangential["centroid_y"].sel({load_dim: load})
    pressure_distance = np.hypot(gp_x - centre_x, gp_y - centre_y) / radius
    shear_distance = np.hypot(gq_x - centre_x, gq_y - centre_y) / radius
    # the corrective loads P* = P − Q/f of the sweep that are loads of the root sweep too (0 < P* < P)
    full = {load_dim: index[load]}
    gap, identity = [], []
    for k, ratio in enumerate(tangential["Q_over_fP"].values):
        p_star = load * (1.0 - ratio)
        j = next((index[p] for p in index if 0.0 < p_star < load and np.isclose(p, p_star, rtol=1e-9, atol=0.0)),
                 None)
        if j is None:
            continue
        star = {load_dim: j}
        predicted_x = (load * gp_x.isel(full) - p_star * gp_x.isel(star)) / (load - p_star)
        predicted_y = (load * gp_y.isel(full) - p_star * gp_y.isel(star)) / (load - p_star)
        gq = (gq_x.isel(Q_over_fP=k), gq_y.isel(Q_over_fP=k))
        gap.append(np.hypot(gq[0] - gp_x.isel(star), gq[1] - gp_y.isel(star)) / radius)
        identity.append(np.hypot(gq[0] - predicted_x, gq[1] - predicted_y) / radius)
    below = root[load_dim] <= load
    excursion = np.hypot(gp_x - gp_x.isel({load_dim: 0}), gp_y - gp_y.isel({load_dim: 0})).where(below) / radius
    nothing = xr.full_like(radius, np.nan)   # no corrective load is a load of the root sweep
    return xr.Dataset({
        "shear_centroid_distance": shear_distance.assign_attrs(units="1", long_name="|G_Q − C| / R"),
        "pressure_centroid_distance": pressure_distance.assign_attrs(units="1", long_name="|G_P − C| / R"),
        "pressure_path_length": excursion.max(load_dim).assign_attrs(
            units="1", long_name="largest |G_P(P') − G_P(P_min)| / R over P' ≤ P"),
        "reverse_path_gap": (xr.concat(gap, "pair").max("pair") if gap else nothing).assign_attrs(
            units="1", long_name="largest |G_Q(Q) − G_P(P − Q/f)| / R"),
        "increment_identity_error": (xr.concat(identity, "pair").max("pair") if identity else nothing).assign_attrs(
            units="1", long_name="largest |G_Q − (P G_P(P) − P* G_P(P*)) / (P − P*)| / R"),
    })
