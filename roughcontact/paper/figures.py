"""The paper's figures, panels as its own, drawn from the study datasets (``fig01.png`` … ``fig14.png``).

Where the paper shows one surface we show seed 1 for the maps and the
ensemble mean with its 95 % band over seeds for every curve. Maps are drawn
with :mod:`roughcontact.analysis.maps`; each title says the seed, the load and
the grid. :data:`DRAWERS` maps a figure number to its function
``draw(results, path)``.
"""
from __future__ import annotations

import dataclasses
from pathlib import Path

import numpy as np
import xarray as xr

from .. import analysis
from ..analysis.ensemble import ensemble_statistics
from ..analysis.figures import pyplot
from ..analysis.maps import draw_contact_map, draw_force_map, draw_height_map, draw_zone_map, height_field
from ..analysis.multifractal import multifractal_spectrum
from .claims import CLOSURE, LOAD_P, RESOLUTION_LOAD, ROCK_LOAD, by_shift
from .reference import bulk_compliances, contact_dimensions, footprint_centres, hertz_forces
from .results import PaperResults, nearest

Q_MOMENTS = np.linspace(-5.0, 5.0, 21)


def _figure(panels: int, width: float = 3.6, height: float = 3.3, columns: int | None = None):
    plt = pyplot()
    columns = columns or panels
    rows = -(-panels // columns)
    fig, axes = plt.subplots(rows, columns, figsize=(width * columns, height * rows), constrained_layout=True,
                             squeeze=False)
    axes = axes.ravel()
    for ax in axes[panels:]:
        ax.set_visible(False)
    return fig, axes[:panels]


def _save(fig, path: Path, title: str) -> Path:
    fig.suptitle(title, fontsize=10)
    fig.savefig(path, dpi=110)
    pyplot().close(fig)
    return path


def _tag(ax, letter: str, title: str) -> None:
    ax.set_title(f"({letter}) {title}", fontsize=8, loc="left")


def _band(ax, x, mean, lower, upper, label: str, log: bool = False, marker: str = "o"):
    line, = (ax.loglog if log else ax.plot)(x, mean, marker + "-", ms=3, label=label)
    ax.fill_between(x, lower, upper, color=line.get_color(), alpha=0.25, lw=0)
    return line


def _bands(ax, stats: xr.Dataset, name: str, x: str, along: str, label, log: bool = False, scale: float = 1.0,
           x_scale: float = 1.0):
    """One curve with its band per value of ``along`` from an ``ensemble_statistics`` result."""
    for value in stats[along].values:
        s = stats.sel({along: value})
        xs = (s[x].values if x in s else stats[x].values) * x_scale
        _band(ax, xs, s[name].values * scale, s[f"{name}_lower"].values * scale, s[f"{name}_upper"].values * scale,
              label(value), log=log)
    ax.legend(fontsize=7)
    ax.grid(alpha=0.3)


def _delta(value) -> str:
    return f"Δ = {float(value):g}"


def _task(results: PaperResults, key: str, **labels):
    """The task of study ``key`` whose axis labels equal ``labels`` (first seed unless given)."""
    for task in results.tasks(key):
        if all(np.allclose(np.ravel(task.labels.get(k)), np.ravel(v)) for k, v in labels.items()):
            return task
    raise KeyError(f"no task of {key} with {labels}")


# --- Fig. 1: contact domain against resolution ----------------------------------------------------------

def fig01(r: PaperResults, path: Path) -> Path:
    ds = r.root["resolution"]
    fig, axes = _figure(4)
    sample = nearest(ds, fractal_dimension=2.1, normal_load=RESOLUTION_LOAD).sel(seed=1)
    for ax, letter, c in zip(axes, "abc", (1, 2, 4)):
        one = sample.sel(coarsening=c)
        draw_contact_map(ax, one["contact"], float(one["grid_spacing"]))
        sigma = RESOLUTION_LOAD / float(one["contact_area"]) / 1e6
        _tag(ax, letter, f"s = {float(one['grid_spacing']) * 1e3:.2g} mm: A_r = {float(one['contact_area']) * 1e6:.3g}"
                         f" mm², σ_n = {sigma:.3g} MPa")
    area = nearest(ds["contact_area"], normal_load=RESOLUTION_LOAD) * 1e6
    spacing = ds["grid_spacing"].isel(fractal_dimension=0, seed=0).values * 1e3
    stats = ensemble_statistics(xr.Dataset({"area": area.assign_coords(coarsening=spacing)}))
    _bands(axes[3], stats, "area", "coarsening", "fractal_dimension", _delta, log=True)
    axes[3].set(xlabel="grid spacing s [mm]", ylabel="A_r [mm²]")
    axes[3].set_xticks(spacing, [f"{v:.3g}" for v in spacing])      # the grids themselves, no minor labels
    axes[3].xaxis.set_minor_formatter(pyplot().NullFormatter())
    _tag(axes[3], "d", "A_r ∝ s^m at 200 N (mean, 95 % CI)")
    return _save(fig, path, "Fig. 1: the same surface (Δ = 2.1, seed 1) at three resolutions, P = 200 N")


# --- Fig. 2: box counting ------------------------------------------------------------------------------

def fig02(r: PaperResults, path: Path) -> Path:
    ds = r.root["load"]
    sample = nearest(ds, fractal_dimension=2.5, normal_load=3645.0).sel(seed=1)
    fig, axes = _figure(2)
    draw_contact_map(axes[0], sample["contact"])
    _tag(axes[0], "a", "contact set, Δ = 2.5, P = 3645 N, seed 1")
    counted = analysis.box_counting(sample["contact"].values == 1, float(sample["grid_spacing"]))
    fitted = counted["contact_dimension_fitted"].values.astype(bool)
    eps = counted["box_size"].values * 1e3
    axes[1].loglog(eps, counted["box_count"].values, "o", label="N(ε)")
    slope, intercept = np.polyfit(np.log(eps[fitted]), np.log(counted["box_count"].values[fitted]), 1)
    axes[1].loglog(eps[fitted], np.exp(intercept) * eps[fitted] ** slope, "-",
                   label=f"Δσ = {float(counted['contact_dimension']):.3f}")
    axes[1].loglog(eps, counted["box_count"].values[0] * (eps / eps[0]) ** -2.0, ":", color="0.5",
                   label="slope −2 (a full area)")
    axes[1].set(xlabel="box side ε [mm]", ylabel="boxes holding contact N(ε)")
    axes[1].legend(fontsize=7)
    _tag(axes[1], "b", "box counting (Eq. 11)")
    return _save(fig, path, "Fig. 2: box-counting dimension of the contact domain")


# --- Fig. 3a: renormalisation -----------------------------------------------------------------------------

def fig03(r: PaperResults, path: Path) -> Path:
    ds = nearest(r.root["load"], normal_load=LOAD_P).sel(seed=1)
    renorm = analysis.contact_renormalisation(ds, on_error="mark")
    fig, axes = _figure(1, width=4.6, height=3.8)
    ax = axes[0]
    for d in renorm["fractal_dimension"].values:
        s = renorm.sel(fractal_dimension=d)
        b = s["box_size"].values * 1e3
        line, = ax.loglog(b, s["window_pressure"].values / 1e6, "o", ms=3)
        fitted = s["renormalised_dimension_fitted"].values.astype(bool)
        slope, intercept = np.polyfit(np.log(b[fitted]), np.log(s["window_pressure"].values[fitted] / 1e6), 1)
        ax.loglog(b[fitted], np.exp(intercept) * b[fitted] ** slope, "-", color=line.get_color(),
                  label=f"Δ = {d:g}: Δσ = {2 + slope:.2f}")
    ax.set(xlabel="window side b [mm]", ylabel="σ0 [MPa]")
    ax.legend(fontsize=7)
    _tag(ax, "a", "σ0 = σ* b^−(2 − Δσ) (Eq. 13), P = 992 N, seed 1")
    return _save(fig, path, "Fig. 3a: size effect of the nominal pressure (3b–d are schemes)")


# --- Fig. 4: three surfaces at the same closure ----------------------------------------------------------

def fig04(r: PaperResults, path: Path) -> Path:
    ds = nearest(r.root["closure"], closure=CLOSURE).sel(seed=1)
    fig, axes = _figure(6, columns=3)
    stats = ensemble_statistics(nearest(contact_dimensions(r, "closure"), closure=CLOSURE).to_dataset())
    heights = [height_field(_task(r, "closure", fractal_dimension=d, seed=1).topography())
               for d in ds["fractal_dimension"].values]
    limit = max(float(np.nanmax(np.abs(h.values))) for h in heights) * 1e6
    for i, d in enumerate(ds["fractal_dimension"].values):
        draw_height_map(axes[i], heights[i], -limit, limit)
        _tag(axes[i], "abc"[i], f"Δh, Δ = {d:g} (seed 1), same rms height")
        draw_contact_map(axes[3 + i], ds.sel(fractal_dimension=d)["contact"])
        s = stats.sel(fractal_dimension=d)
        _tag(axes[3 + i], "def"[i], f"δz = 4 µm: Δσ = {float(s['contact_dimension']):.2f} "
                                    f"[{float(s['contact_dimension_lower']):.2f}, {float(s['contact_dimension_upper']):.2f}]")
    return _save(fig, path, "Fig. 4: three surfaces and their contact domains at the same closure δz = 4 µm")


# --- Fig. 5: area against load, against resolution, closure curves -----------------------------------------

def fig05(r: PaperResults, path: Path) -> Path:
    fig, axes = _figure(3, width=4.0)
    load = r.root["load"]
    stats = ensemble_statistics(load[["contact_fraction"]])
    _bands(axes[0], stats, "contact_fraction", "normal_load", "fractal_dimension", _delta, x_scale=1e-3)
    axes[0].set(xlabel="P [kN]", ylabel="A_r / A_0")
    _tag(axes[0], "a", "A_r against P, s = L/256")
    res = nearest(r.root["resolution"], fractal_dimension=2.1)
    stats = ensemble_statistics(res[["contact_area"]])
    spacing = res["grid_spacing"].isel(seed=0).values * 1e3
    _bands(axes[1], stats.assign_coords(coarsening=spacing), "contact_area", "normal_load", "coarsening",
           lambda s: f"s = {s:.2g} mm", scale=1e6)
    axes[1].set(xlabel="P [N]", ylabel="A_r [mm²]")
    _tag(axes[1], "b", "A_r against P, Δ = 2.1, four resolutions")
    closure = r.root["closure"]
    c = bulk_compliances(r, "closure")[0]
    effective = (closure["closure"] - c * closure["normal_load"]) * 1e6
    stats = ensemble_statistics(xr.Dataset({"effective": effective, "load": closure["normal_load"]}))
    for d in stats["fractal_dimension"].values:
        s = stats.sel(fractal_dimension=d)
        line, = axes[2].plot(s["effective"], s["load"] / 1e3, "o-", ms=3, label=_delta(d))
        axes[2].fill_betweenx(s["load"] / 1e3, s["effective_lower"], s["effective_upper"], color=line.get_color(),
                              alpha=0.25, lw=0)
    axes[2].set(xlabel="effective closure δz − c P [µm]", ylabel="P [kN]")
    axes[2].legend(fontsize=7)
    axes[2].grid(alpha=0.3)
    _tag(axes[2], "c", "closure curves, bulk removed")
    return _save(fig, path, "Fig. 5: real contact area and closure (mean and 95 % CI over seeds)")


# --- Fig. 6: domains at three loads, Δσ against load -----------------------------------------------------

def fig06(r: PaperResults, path: Path) -> Path:
    ds = r.root["load"]
    fig, axes = _figure(4)
    sample = nearest(ds, fractal_dimension=2.3).sel(seed=1)
    for ax, letter, p in zip(axes, "abc", (113.0, LOAD_P, 8678.0)):
        one = nearest(sample, normal_load=p)
        draw_contact_map(ax, one["contact"])
        _tag(ax, letter, f"Δ = 2.3, P = {p:g} N, A_r/A_0 = {float(one['contact_fraction']):.3f}")
    stats = ensemble_statistics(contact_dimensions(r, "load").to_dataset())
    for d in stats["fractal_dimension"].values:
        s = stats.sel(fractal_dimension=d)
        line, = axes[3].semilogx(ds["normal_load"], s["contact_dimension"], "o-", ms=3, label=_delta(d))
        axes[3].fill_between(ds["normal_load"], s["contact_dimension_lower"], s["contact_dimension_upper"],
                             color=line.get_color(), alpha=0.25, lw=0)
    axes[3].axhline(2.0, color="0.5", ls=":")
    axes[3].set(xlabel="P [N]", ylabel="Δσ")
    axes[3].legend(fontsize=7)
    _tag(axes[3], "d", "Δσ against load (mean, 95 % CI)")
    return _save(fig, path, "Fig. 6: contact domains at increasing load, s = L/256")


# --- Fig. 7: the rock joint's faces ------------------------------------------------------------------------

def _face(task):
    surface = {k: v for k, v in task.surface.items() if k != "mate_shift"}
    return dataclasses.replace(task, surface=surface).topography()


def fig07(r: PaperResults, path: Path) -> Path:
    ds = by_shift(r.root["rock"])
    fig, axes = _figure(3)
    shifts = ds["shift"].values
    first = _task(r, "rock", seed=1)
    draw_height_map(axes[0], height_field(_face(first)))
    axes[0].annotate("", xy=(0.15, 0.92), xytext=(0.35, 0.92), xycoords="axes fraction",
                     arrowprops={"arrowstyle": "->"})
    _tag(axes[0], "a", "fracture face h (seed 1); the mate moves west by v")
    for v in shifts:
        task = _task(r, "rock", mate_shift=(-v * 1e-3, 0.0), seed=1)
        lens = task.topography()
        field = height_field(lens)
        axes[1].contour(field["x"] * 1e3, field["y"] * 1e3, np.isfinite(field.values).T.astype(float), levels=[0.5],
                        linewidths=0.8)
    axes[1].set(xlabel="x [mm]", ylabel="y [mm]", aspect="equal")
    _tag(axes[1], "b", "lens footprints, v = " + ", ".join(f"{v:g}" for v in shifts) + " mm")
    lens = _task(r, "rock", mate_shift=(-shifts[-1] * 1e-3, 0.0), seed=1).topography()
    draw_height_map(axes[2], height_field(lens))
    _tag(axes[2], "c", f"composite Δh, v = {shifts[-1]:g} mm")
    return _save(fig, path, "Fig. 7: the rock joint (synthetic face Δ = 2.21, roll-off 8 mm, 50 mm disc)")


# --- Fig. 8: closure against shift, domains ----------------------------------------------------------------

def fig08(r: PaperResults, path: Path) -> Path:
    ds = by_shift(r.root["rock"])
    compliance = bulk_compliances(r, "rock")
    fig, axes = _figure(4)
    for i, v in enumerate(ds["shift"].values):
        one = ds.isel(shift=i)
        effective = (one["closure"] - compliance[i] * one["normal_load"]) * 1e6
        stats = ensemble_statistics(xr.Dataset({"effective": effective}))
        line, = axes[0].plot(stats["effective"], ds["normal_load"] / 1e3, "o-", ms=3, label=f"v = {v:g} mm")
        axes[0].fill_betweenx(ds["normal_load"] / 1e3, stats["effective_lower"], stats["effective_upper"],
                              color=line.get_color(), alpha=0.25, lw=0)
    axes[0].set(xlabel="effective closure δz − c P [µm]", ylabel="P [kN]")
    axes[0].legend(fontsize=7)
    axes[0].grid(alpha=0.3)
    _tag(axes[0], "a", "closure curves, five westward shifts")
    for ax, letter, v in zip(axes[1:], "bcd", (0.4, 2.0, 10.0)):
        one = nearest(ds, shift=v, normal_load=ROCK_LOAD).sel(seed=1)
        draw_contact_map(ax, one["contact"])
        _tag(ax, letter, f"v = {v:g} mm, P = 10 kN, A_r/A_0 = {float(one['contact_fraction']):.4f}")
    return _save(fig, path, "Fig. 8: rock joint, closure and contact domains (σ0 = 5.1 MPa at 10 kN)")


# --- Fig. 9: stick and slip zones ------------------------------------------------------------------------

def _busiest_window(zone: np.ndarray, side: int) -> tuple[slice, slice]:
    """The side × side window holding most slip and stick nodes together."""
    mixed = ((zone == 1) | (zone == 2)).astype(float)
    best, where = -1.0, (0, 0)
    for i in range(0, max(zone.shape[0] - side, 0) + 1, side // 4):
        for j in range(0, max(zone.shape[1] - side, 0) + 1, side // 4):
            window = zone[i:i + side, j:j + side]
            score = mixed[i:i + side, j:j + side].sum() * ((window == 2).any() and (window == 1).any())
            if score > best:
                best, where = score, (i, j)
    return slice(where[0], where[0] + side), slice(where[1], where[1] + side)


def fig09(r: PaperResults, path: Path) -> Path:
    t = nearest(r.tangential["load"], normal_load=LOAD_P, fractal_dimension=2.3).sel(seed=1)
    root = nearest(r.root["load"], normal_load=LOAD_P, fractal_dimension=2.3).sel(seed=1)
    fig, axes = _figure(4)
    for ax, letter, q in zip(axes, "ab", (0.3, 0.7)):
        draw_zone_map(ax, nearest(t, Q_over_fP=q)["zone"])
        _tag(ax, letter, f"Q/fP = {q:g}: stick black, slip grey")
    zone = nearest(t, Q_over_fP=0.3)["zone"]
    rows, cols = _busiest_window(zone.values, 40)
    draw_zone_map(axes[2], zone.isel(x=rows, y=cols))
    _tag(axes[2], "c", "enlarged, Q/fP = 0.3")
    image = draw_force_map(axes[3], root["force"].isel(x=rows, y=cols), root["contact"].isel(x=rows, y=cols))
    fig.colorbar(image, ax=axes[3], shrink=0.8, label="p̄ [N]")
    _tag(axes[3], "d", "the same window: nodal forces p̄")
    return _save(fig, path, "Fig. 9: stick and slip zones, Δ = 2.3, P = 992 N, seed 1")


# --- Fig. 10: stick and slip areas and forces -----------------------------------------------------------

def _stick_force_hertz(ratio: np.ndarray) -> np.ndarray:
    """Q_stick / fP of a Hertz contact (Cattaneo–Mindlin): 1 − (1 − x²)^{3/2} − x³, x = (1 − Q/fP)^{1/3}."""
    x = np.cbrt(1.0 - np.asarray(ratio))
    return 1.0 - (1.0 - x**2) ** 1.5 - x**3


def fig10(r: PaperResults, path: Path) -> Path:
    t = nearest(r.tangential["shear"], normal_load=ROCK_LOAD).isel(fractal_dimension=0)
    f = float(r.tangential["shear"].attrs["friction"])
    stats = ensemble_statistics(t[["stick_area", "slip_area", "stick_force", "slip_force"]])
    q = t["Q_over_fP"].values
    fig, axes = _figure(2, width=4.2)
    for name in ("stick_area", "slip_area"):
        _band(axes[0], q, stats[name] * 1e6, stats[f"{name}_lower"] * 1e6, stats[f"{name}_upper"] * 1e6,
              name.replace("_", " "))
    area = float(nearest(r.root["shear"]["contact_area"], normal_load=ROCK_LOAD).isel(fractal_dimension=0).mean())
    axes[0].plot(q, area * q * 1e6, ":", color="0.4", label="A_r Q/(fP)")
    axes[0].set(xlabel="Q / fP", ylabel="area [mm²]")
    axes[0].legend(fontsize=7)
    _tag(axes[0], "a", "stick and slip areas (rock face)")
    for name in ("stick_force", "slip_force"):
        scale = 1.0 / (f * ROCK_LOAD)
        _band(axes[1], q, stats[name] * scale, stats[f"{name}_lower"] * scale, stats[f"{name}_upper"] * scale,
              name.replace("_", " ") + " / fP")
    fine = np.linspace(0.0, 1.0, 101)
    axes[1].plot(fine, _stick_force_hertz(fine), ":", color="0.4", label="Q_stick/fP, Hertz")
    axes[1].set(xlabel="Q / fP", ylabel="force / fP")
    axes[1].legend(fontsize=7)
    _tag(axes[1], "b", "Q_stick and Q_slip")
    return _save(fig, path, "Fig. 10: partial slip of the rock joint, v = 2 mm, P = 10 kN (mean, 95 % CI)")


# --- Fig. 11: centroid paths --------------------------------------------------------------------------

def fig11(r: PaperResults, path: Path) -> Path:
    root, t = r.root["shear"], r.tangential["shear"]
    cx, cy = footprint_centres(r, "shear")
    fig, axes = _figure(2, width=4.0)
    for ax, letter, i, name in zip(axes, "ab", (0, 1), ("rock", "concrete")):
        one = root.isel(fractal_dimension=i).sel(seed=1)
        tt = nearest(t.isel(fractal_dimension=i).sel(seed=1), normal_load=ROCK_LOAD)
        c = (float(cx.isel(fractal_dimension=i).sel(seed=1)), float(cy.isel(fractal_dimension=i).sel(seed=1)))
        inner = tt.sel(Q_over_fP=(tt["Q_over_fP"] > 0) & (tt["Q_over_fP"] < 1))
        ax.plot((inner["centroid_x"] - c[0]) * 1e3, (inner["centroid_y"] - c[1]) * 1e3, "o-", ms=3,
                label="G_Q, Q/fP 0.1 → 0.9")
        ax.plot((one["centroid_x"] - c[0]) * 1e3, (one["centroid_y"] - c[1]) * 1e3, "s--", ms=3,
                label="G_P, P 1 → 10 kN")
        ax.plot(0, 0, "k+", ms=10, label="footprint centroid C")
        ax.set(xlabel="x − C_x [mm]", ylabel="y − C_y [mm]", aspect="equal")
        ax.legend(fontsize=7)
        _tag(ax, letter, f"{name} face (seed 1)")
    return _save(fig, path, "Fig. 11: paths of the shear centroid G_Q and of the pressure centroid G_P")


# --- Fig. 12: dissipated energy -------------------------------------------------------------------------

def fig12(r: PaperResults, path: Path) -> Path:
    ds = r.root["load"]
    stats = ensemble_statistics(ds[["incipient_sliding_energy"]])
    fig, axes = _figure(1, width=4.6, height=3.8)
    _bands(axes[0], stats, "incipient_sliding_energy", "normal_load", "fractal_dimension", _delta, log=True)
    axes[0].set(xlabel="P [N]", ylabel="E_tot [J] (Eq. 27)")
    _tag(axes[0], "a", "energy dissipated up to incipient sliding")
    return _save(fig, path, "Fig. 12: dissipated energy against load (mean, 95 % CI)")


# --- Fig. 13: force histograms -----------------------------------------------------------------------------

def fig13(r: PaperResults, path: Path) -> Path:
    ds = nearest(r.root["load"], normal_load=LOAD_P)
    fig, axes = _figure(4)
    for i, d in enumerate(ds["fractal_dimension"].values):
        one = ds.sel(fractal_dimension=d)
        forces = one["force"].values[one["contact"].values == 1]
        seeds = one.sizes["seed"]
        counts, edges = np.histogram(forces, bins=24)
        axes[i].semilogy(0.5 * (edges[1:] + edges[:-1]), counts / seeds, "o-", ms=3)
        axes[i].set(xlabel="p̄ [N]", ylabel="contact nodes per seed")
        _tag(axes[i], "abc"[i], f"Δ = {d:g}: {forces.size / seeds:.0f} contact nodes per seed")
        ordered = np.sort(forces / forces.mean())
        axes[3].plot(ordered, np.arange(1, ordered.size + 1) / ordered.size, label=_delta(d))
    axes[3].set(xlabel="p̄ / mean p̄", ylabel="cumulative distribution", xscale="log")
    axes[3].legend(fontsize=7)
    _tag(axes[3], "d", "cumulative distributions")
    return _save(fig, path, f"Fig. 13: nodal forces at the same load P = {LOAD_P:g} N (seeds pooled)")


# --- Fig. 14: multifractal spectra --------------------------------------------------------------------------

def _mean_spectrum(ax, spectra: xr.Dataset, label: str):
    alpha = spectra["holder_exponent"].mean("seed")
    f = spectra["singularity_spectrum"].mean("seed")
    ax.plot(alpha, f, "o-", ms=2, label=label)


def fig14(r: PaperResults, path: Path) -> Path:
    rock = by_shift(r.root["rock"])
    fig, axes = _figure(3)
    at_load = nearest(rock, normal_load=ROCK_LOAD)
    spectra = analysis.force_spectrum(at_load, q=Q_MOMENTS, window="cover", on_error="mark")
    for v in spectra["shift"].values:
        _mean_spectrum(axes[0], spectra.sel(shift=v), f"v = {v:g} mm")
    _tag(axes[0], "a", "P = 10 kN, varying v (seed means)")
    at_shift = nearest(rock, shift=2.0)
    for p in (1000.0, 2000.0, 4500.0, ROCK_LOAD):
        spectra = analysis.force_spectrum(nearest(at_shift, normal_load=p), q=Q_MOMENTS, window="cover",
                                          on_error="mark")
        _mean_spectrum(axes[1], spectra, f"P = {p / 1e3:g} kN")
    _tag(axes[1], "b", "v = 2 mm, increasing P")
    one = nearest(r.root["load"], normal_load=LOAD_P, fractal_dimension=2.3).sel(seed=1)
    force = np.where(one["contact"].values == 1, one["force"].values, 0.0)
    shuffled = force.copy()
    support = force > 0
    shuffled[support] = np.random.default_rng(0).permutation(force[support])
    for measure, label in ((force, "midpoint Δ = 2.3, 992 N"), (shuffled, "same forces shuffled"),
                           (support.astype(float), "equal forces on the set"), (hertz_forces(), "Hertz contact")):
        s = multifractal_spectrum(measure, q=Q_MOMENTS)
        axes[2].plot(s["holder_exponent"], s["singularity_spectrum"], "o-", ms=2, label=label)
    _tag(axes[2], "c", "null tests (seed 1)")
    for ax in axes:
        ax.set(xlabel="α", ylabel="f(α)")
        ax.legend(fontsize=7)
        ax.grid(alpha=0.3)
    return _save(fig, path, "Fig. 14: multifractal spectra of the contact forces (q ∈ [−5, 5])")


DRAWERS = {1: fig01, 2: fig02, 3: fig03, 4: fig04, 5: fig05, 6: fig06, 7: fig07, 8: fig08, 9: fig09, 10: fig10,
           11: fig11, 12: fig12, 13: fig13, 14: fig14}


def draw(figure: int, results: PaperResults, folder: Path) -> Path:
    """``fig<NN>.png`` under ``folder``."""
    return DRAWERS[figure](results, Path(folder) / f"fig{figure:02d}.png")
