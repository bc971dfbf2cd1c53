"""Tangential sweeps and fretting cycles as xarray datasets (Figs. 9–12), CF-style attributes.

Variables carry ``units`` and ``long_name`` as in :mod:`roughcontact.datasets`;
write them with :func:`roughcontact.netcdf.write_netcdf`. A sweep's
dimension is ``Q`` (the tangential load, N) with the coordinate
``Q_over_fP`` on it, so ``ds.swap_dims(Q="Q_over_fP")`` plots against Q/fP.
Global attributes say whether the model is exact (``cattaneo_model``) and,
when it is not, the measured error of the uncoupled model for the
dataset's γ and Q/fP (``uncoupled_error_<metric>``,
:mod:`.uncoupled_error`), record the normal state, E_tot (Eq. 27) and the wall times of the normal solve and
of the sweep.
"""
from __future__ import annotations

import numpy as np
import xarray as xr

from .. import __version__
from ..datasets import grid_coords, scalar_variables
from ..errors import InputError
from .fretting import FrettingCycle
from .fretting_map import FrettingMap
from .sweep import TangentialSweep
from .uncoupled_error import uncoupled_error_attrs

_SCALARS = {
    # name: (getter, units, long_name)
    "tangential_approach": (lambda s: s.tangential_approach, "m", "tangential approach δx (Eq. 24)"),
    "corrective_load": (lambda s: s.corrective_load, "N", "corrective normal load P* = P − Q/f (Eq. 23)"),
    "corrective_closure": (lambda s: s.corrective_closure, "m", "corrective approach δz* (Eq. 23)"),
    "stick_area": (lambda s: s.stick_area, "m2", "stick area"),
    "slip_area": (lambda s: s.slip_area, "m2", "slip area"),
    "stick_force": (lambda s: s.stick_force, "N", "shear carried by the stick zone Q_stick"),
    "slip_force": (lambda s: s.slip_force, "N", "shear carried by the slip zone Q_slip"),
    "centroid_x": (lambda s: s.centroid[0], "m", "x of the centroid of shear G_Q (Eq. 25a)"),
    "centroid_y": (lambda s: s.centroid[1], "m", "y of the centroid of shear G_Q (Eq. 25b)"),
    "stick_centroid_x": (lambda s: s.stick_centroid[0], "m", "x of G_Q(stick)"),
    "stick_centroid_y": (lambda s: s.stick_centroid[1], "m", "y of G_Q(stick)"),
    "slip_centroid_x": (lambda s: s.slip_centroid[0], "m", "x of G_Q(slip) = G_P(slip)"),
    "slip_centroid_y": (lambda s: s.slip_centroid[1], "m", "y of G_Q(slip) = G_P(slip)"),
    "frictional_energy": (lambda s: s.frictional_energy, "J", "energy dissipated by friction E_f (Eq. 26)"),
    "stored_energy": (lambda s: s.stored_energy, "J",
                      "tangential elastic energy U = ½ qᵀ u_x (u_x = H q to the solves' tolerance)"),
    "coulomb_violation": (lambda s: s.coulomb_violation, "1",
                          "largest breach of 0 ≤ q ≤ f p over f max p (Eq. 14a)"),
    "outer_iterations": (lambda s: s.corrective.outer_iterations if s.corrective else 0, "1",
                         "active-set iterations of the corrective solve"),
    "linear_iterations": (lambda s: s.corrective.linear_iterations if s.corrective else 0, "1",
                          "inner linear-solver iterations of the corrective solve"),
    "elapsed": (lambda s: s.elapsed, "s", "wall time of the step"),
    "limit": (lambda s: int(s.limit), "1", "1 for the limit Q → fP of incipient sliding"),
}

ZONES = {"flag_values": np.array([0, 1, 2], dtype=np.int8), "flag_meanings": "no_contact stick slip"}


def tangential_dataset(sweep: TangentialSweep, fields: bool = True,
                       attrs: dict | None = None) -> xr.Dataset:
    """One dataset of a tangential sweep along ``Q``.

    With ``fields`` the shear force q̄, the stick/slip zones, the slip g and
    the frictional energy density (Eq. 26) are stored on (Q, x, y). A coupled
    sweep (:mod:`.coupled`) has no such layout: its states carry two shear
    components and an approach vector.
    """
    if sweep.model == "coupled":
        raise InputError("sweep", "coupled sweeps have no dataset layout; compare them with the uncoupled "
                                  "sweep's states (tools/chart_uncoupled_error.py)")
    states = sweep.states
    normal = sweep.normal
    dim = "Q"
    data = scalar_variables(states, _SCALARS, dim)
    data["work"] = ((dim,), sweep.work, {"units": "J", "long_name": "work of Q along δx, W = ∫ Q dδx "
                                                                  "(trapezoidal rule)"})
    coords = {
        dim: (dim, sweep.tangential, {"units": "N", "long_name": "tangential load Q"}),
        "Q_over_fP": (dim, np.array([s.load_ratio for s in states]),
                      {"units": "1", "long_name": "Q / (f P)"}),
    }
    if fields and states:
        coords.update(grid_coords(normal.force.shape, states[0].spacing))
        data["traction"] = ((dim, "x", "y"), np.stack([st.traction for st in states]),
                            {"units": "N", "long_name": "nodal shear force q̄ along Q (Eq. 21)"})
        zone = np.stack([np.where(st.slip, 2, np.where(st.stick, 1, 0)) for st in states]).astype(np.int8)
        data["zone"] = ((dim, "x", "y"), zone, {"units": "1", "long_name": "stick and slip zones", **ZONES})
        data["slip_distance"] = ((dim, "x", "y"), np.stack([st.slip_distance for st in states]),
                                 {"units": "m", "long_name": "slip g (0 in stick, NaN off contact)"})
        data["frictional_energy_density"] = (
            (dim, "x", "y"), np.stack([st.frictional_energy_density for st in states]),
            {"units": "J", "long_name": "energy dissipated per node f p̄ g (Eq. 26)"})
    ds = xr.Dataset(data, coords=coords)
    last = states[-1]
    ds.attrs.update({
        "roughcontact_version": __version__,
        "cattaneo_model": sweep.model,
        "composite_poisson_gamma": last.gamma, "dundurs_beta": last.beta,
        **uncoupled_error_attrs(last.gamma, last.beta, [s.load_ratio for s in states if not s.limit]),
        "friction": sweep.friction,
        "direction_x": last.direction[0], "direction_y": last.direction[1],
        "normal_load": normal.load, "closure": normal.closure,
        "rotation_x": normal.rotation[0], "rotation_y": normal.rotation[1],
        "pressure_centroid_x": normal.centroid[0], "pressure_centroid_y": normal.centroid[1],
        "contact_area": normal.contact_area, "nominal_area": normal.nominal_area,
        "spacing": last.spacing,
        "incipient_sliding_energy": last.frictional_energy if last.limit else np.nan,
        "resticking_nodes": sweep.resticking_nodes,
        "solver": last.corrective.solver if last.corrective else normal.solver,
        "normal_elapsed": normal.elapsed, "sweep_elapsed": sweep.elapsed,
    })
    ds.attrs.update(attrs or {})
    return ds


def fretting_dataset(cycle: FrettingCycle, attrs: dict | None = None) -> xr.Dataset:
    """The Q–δx path of a fretting cycle (loading, unloading, reloading) along ``step``."""
    dim = "step"
    first = cycle.loading.states[0]
    data = {
        "tangential_approach": ((dim,), cycle.approach, {"units": "m", "long_name": "tangential approach δx"}),
        "reverse_slip_area": ((dim,), cycle.reverse_slip_area,
                              {"units": "m2", "long_name": "area slipping since the last load reversal"}),
        "dissipated_energy": ((dim,), cycle.dissipated,
                              {"units": "J", "long_name": "energy dissipated by friction since Q = 0"}),
    }
    coords = {
        dim: (dim, np.arange(cycle.tangential.size), {"long_name": "index along the load path"}),
        "Q": (dim, cycle.tangential, {"units": "N", "long_name": "tangential load Q"}),
        "branch": (dim, cycle.branch, {"units": "1", "long_name": "branch of the load path",
                                        "flag_values": np.array([0, 1, 2], dtype=np.int8),
                                        "flag_meanings": "loading unloading reloading"}),
    }
    ds = xr.Dataset(data, coords=coords)
    ds.attrs.update({
        "roughcontact_version": __version__, "cattaneo_model": cycle.model,
        # a cycle reverses the load: the chart covers monotonic loading only
        **uncoupled_error_attrs(first.gamma, first.beta, None),
        "friction": cycle.friction, "normal_load": cycle.normal_load, "amplitude": cycle.amplitude,
        "loop_area": cycle.loop_area, "dissipated_per_cycle": cycle.dissipated_per_cycle,
    })
    ds.attrs.update(attrs or {})
    return ds


def fretting_map_dataset(fretting: FrettingMap, attrs: dict | None = None) -> xr.Dataset:
    """Energy per cycle against amplitude (:class:`~.fretting_map.FrettingMap`) along ``amplitude``."""
    dim = "amplitude"
    data = {
        "dissipated_per_cycle": ((dim,), fretting.dissipated_per_cycle,
                                 {"units": "J", "long_name": "energy dissipated per cycle +Q* → −Q* → +Q* "
                                                             "(4 E_f(Q*), Eq. 26)"}),
        "loop_area": ((dim,), fretting.loop_area,
                      {"units": "J", "long_name": "area of the Q–δx loop ∮ Q dδx (trapezoidal rule)"}),
        "approach_amplitude": ((dim,), fretting.approach,
                               {"units": "m", "long_name": "tangential approach δx at +Q* (Eq. 24)"}),
    }
    coords = {
        dim: (dim, fretting.amplitudes, {"units": "1", "long_name": "amplitude Q* / (f P)"}),
        "Q": (dim, fretting.tangential, {"units": "N", "long_name": "amplitude Q* of the cycle"}),
    }
    ds = xr.Dataset(data, coords=coords)
    ds.attrs.update({
        "roughcontact_version": __version__, "cattaneo_model": fretting.model,
        # cycles reverse the load: the chart of the uncoupled error covers monotonic loading only
        **uncoupled_error_attrs(fretting.gamma, fretting.beta, None),
        "friction": fretting.friction, "normal_load": fretting.normal.load,
        "history_points": fretting.history.tangential.size,
    })
    ds.attrs.update(attrs or {})
    return ds
