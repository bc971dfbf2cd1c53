"""The paper's claims, each a number with its 95 % interval over seeds and a verdict fixed before the run.

Every claim is a function of :class:`~.results.PaperResults` that returns
rows: one per condition (a Δ, a shift, a load), each a per-seed number
reduced to its mean and Student-t interval (:func:`~.results.interval`) and
judged by its rule:

- ``above(x)``: reproduced if the interval lies above x, not reproduced if
  it lies below, undecided if it straddles x;
- ``below(x)``: the mirror image;
- ``within(a, b)``: reproduced if the interval lies inside [a, b], not
  reproduced if it misses [a, b] entirely, undecided otherwise;
- ``report``: a number the paper gives no firm reading of (no verdict).

The rules and their thresholds are written here, with the claim, and are
never tuned to the data; docs/paper.md explains each verdict. A claim whose
study was not run is "not run".
"""
from __future__ import annotations

from collections.abc import Callable
from dataclasses import asdict, dataclass

import numpy as np
import xarray as xr

from .. import analysis
from ..analysis.area import area_load_exponent, persson_kappa
from ..analysis.centroids import centroid_paths
from ..analysis.ensemble import trend
from ..analysis.multifractal import force_spectrum_nulls
from ..analysis.pressure_statistics import contact_force_law_comparison, contact_force_uniformity
from ..analysis.slip_zones import slip_zone_statistics
from ..errors import InputError
from .reference import bulk_compliances, contact_dimensions, footprint_centres, hertz_spectrum
from .results import PaperResults, interval, nearest, paired

#: the loads, closures and states at which the claims are read (quick and full scales share them)
LOAD_P = 992.0            # N, fig05_load: Δ = 2.3 at about 4 % contact
CLOSURE = 4e-6            # m from first touch, fig04_closure (Fig. 4d-f)
RESOLUTION_LOAD = 200.0   # N, fig01_resolution (Fig. 1)
ROCK_LOAD = 10000.0       # N, fig08_rock and fig10_shear (§3.4)
SLIP_STATE = 0.2          # Q/fP of Fig. 9's first panel
PAPER_DIMENSION_CURVE = 0.61   # the paper's m = 2 − Δσ of Fig. 1d (Δ = 2.1, Δσ = 1.39)
MAX_FRACTION_DIMENSION = 0.5   # Δσ < 2 read below this contact fraction (beyond, contact is near full)


@dataclass
class Row:
    """One tested number."""

    claim: str
    figure: str
    statement: str
    quantity: str
    condition: str
    mean: float
    lower: float
    upper: float
    n: int
    rule: str
    verdict: str

    def as_dict(self) -> dict:
        return asdict(self)


@dataclass(frozen=True)
class Rule:
    """A verdict from an interval (module notes)."""

    kind: str
    low: float = np.nan
    high: float = np.nan

    def __str__(self) -> str:
        return {"above": f"CI > {self.low:g}", "below": f"CI < {self.high:g}",
                "within": f"CI ⊂ [{self.low:g}, {self.high:g}]", "report": "reported"}[self.kind]

    def verdict(self, lower: float, upper: float) -> str:
        if self.kind == "report":
            return "reported"
        if not (np.isfinite(lower) and np.isfinite(upper)):
            return "undecided"
        if self.kind == "above":
            return "reproduced" if lower > self.low else "not reproduced" if upper < self.low else "undecided"
        if self.kind == "below":
            return "reproduced" if upper < self.high else "not reproduced" if lower > self.high else "undecided"
        if self.low <= lower and upper <= self.high:
            return "reproduced"
        return "not reproduced" if upper < self.low or lower > self.high else "undecided"


def above(x):
    return Rule("above", low=x)


def below(x):
    return Rule("below", high=x)


def within(a, b):
    return Rule("within", a, b)


REPORT = Rule("report")


@dataclass(frozen=True)
class Claim:
    """A claim of the paper: its id, figure, statement and the function that tests it."""

    key: str
    figure: str
    statement: str
    studies: tuple[str, ...]
    test: Callable[[PaperResults], list[tuple[str, str, xr.DataArray, Rule]]]


CLAIMS: list[Claim] = []


def claim(key: str, figure: str, statement: str, *studies: str):
    """Register ``function`` (results → [(quantity, condition, per-seed values, rule)]) as a claim."""
    def register(function):
        CLAIMS.append(Claim(key, figure, statement, studies, function))
        return function
    return register


def _per(values: xr.DataArray, dim: str, label: Callable[[float], str]):
    """(condition, values) for each point of ``dim``."""
    return [(label(float(v)), values.sel({dim: v})) for v in values[dim].values]


def _delta(value: float) -> str:
    return f"Δ = {value:g}"


def _spacing_axis(ds: xr.Dataset, values: xr.DataArray) -> xr.DataArray:
    """``values`` along ``coarsening`` relabelled by the grid spacing s (m) of each coarsening."""
    spacing = ds["grid_spacing"].isel({d: 0 for d in ds["grid_spacing"].dims if d != "coarsening"})
    return values.assign_coords(coarsening=spacing.values)


# --- Figs. 5a, 5b, 1d: real contact area against load and resolution --------------------------------------

@claim("C1", "5a", "A_r ∝ P at every Δ (nearly linear)", "load")
def _area_linear(r: PaperResults):
    fit = area_load_exponent(r.root["load"])
    return [("exponent m of A_r ∝ P^m (A_r/A_0 ≤ 10 %, ≥ 20 nodes)", c, v, within(0.85, 1.15))
            for c, v in _per(fit["area_load_exponent"], "fractal_dimension", _delta)]


@claim("C2", "5b", "the slope of A_r(P) falls as the grid is refined", "resolution")
def _slope_resolution(r: PaperResults):
    ds = r.root["resolution"]
    constant = _spacing_axis(ds, np.log(persson_kappa(ds)["area_load_constant"]))
    slope = trend(constant, "coarsening", log=True)
    return [("d ln(A_r/P) / d ln s (> 0: A_r/P falls as s is refined)", c, v, above(0.0))
            for c, v in _per(slope, "fractal_dimension", _delta)]


@claim("C3", "1d", "A_r decreases as a power of the resolution, A_r ∝ s^m; the paper reads m = 2 − Δσ ≈ 0.61 "
       "at Δ = 2.1", "resolution")
def _area_resolution(r: PaperResults):
    ds = r.root["resolution"]
    area = _spacing_axis(ds, np.log(nearest(ds["contact_area"], normal_load=RESOLUTION_LOAD)))
    m = trend(area, "coarsening", log=True)
    rows = [("exponent m of A_r ∝ s^m at 200 N (> 0: A_r falls as s is refined)", c, v, above(0.0))
            for c, v in _per(m, "fractal_dimension", _delta)]
    rows.append(("m at Δ = 2.1 against the paper's 0.61", "Δ = 2.1", nearest(m, fractal_dimension=2.1),
                 within(PAPER_DIMENSION_CURVE - 0.1, PAPER_DIMENSION_CURVE + 0.1)))
    return rows


@claim("C4", "5a, 5b", "since the paper: A_r = κ P / (E* h'_rms) with κ ≈ 1.6–2.2 (Persson; Hyun et al. 2004), "
       "so the drop of A_r with resolution is the growth of h'_rms", "load", "resolution")
def _kappa(r: PaperResults):
    rows = []
    if r.has("load"):
        kappa = persson_kappa(r.root["load"])["persson_kappa"]
        rows += [("κ = A_r E* h'_rms / P at the finest grid", c, v, within(1.4, 3.0))
                 for c, v in _per(kappa, "fractal_dimension", _delta)]
    if r.has("resolution"):
        ds = r.root["resolution"]
        kappa = _spacing_axis(ds, np.log(persson_kappa(ds)["persson_kappa"]))
        slope = trend(kappa, "coarsening", log=True)
        rows += [("d ln κ / d ln s (0: the drop of A_r/P is the growth of h'_rms)", c, v, within(-0.1, 0.1))
                 for c, v in _per(slope, "fractal_dimension", _delta)]
    return rows


# --- Figs. 2, 4, 6d: box-counting dimension of the contact domain -----------------------------------------

@claim("C5", "6d", "Δσ rises with load", "load")
def _dimension_rises(r: PaperResults):
    ds = r.root["load"]
    dims = contact_dimensions(r, "load").where(ds["contact_fraction"] <= MAX_FRACTION_DIMENSION)
    slope = trend(dims, "normal_load", log=True)
    return [("d Δσ / d ln P (A_r/A_0 ≤ 50 %)", c, v, above(0.0)) for c, v in _per(slope, "fractal_dimension", _delta)]


@claim("C6", "6d", "Δσ < 2 (the contact domain is a fractal set, not an area)", "load")
def _dimension_below_two(r: PaperResults):
    ds = r.root["load"]
    dims = contact_dimensions(r, "load").where(ds["contact_fraction"] <= MAX_FRACTION_DIMENSION)
    return [("largest Δσ over loads with A_r/A_0 ≤ 50 %", c, v, below(2.0))
            for c, v in _per(dims.max("normal_load"), "fractal_dimension", _delta)]


@claim("C7", "4", "a larger Δ gives a smaller Δσ at the same closure", "closure", "load")
def _dimension_order(r: PaperResults):
    rows = []
    if r.has("closure"):
        dims = nearest(contact_dimensions(r, "closure"), closure=CLOSURE)
        rows.append(("Δσ(Δ = 2.5) − Δσ(Δ = 2.1) at δz = 4 µm", "same closure", paired(dims, "fractal_dimension",
                                                                                       2.1, 2.5), below(0.0)))
    if r.has("load"):
        dims = nearest(contact_dimensions(r, "load"), normal_load=LOAD_P)
        rows.append(("Δσ(Δ = 2.5) − Δσ(Δ = 2.1) at P = 992 N", "same load", paired(dims, "fractal_dimension",
                                                                                    2.1, 2.5), below(0.0)))
    return rows


# --- Figs. 5c, 8a: closure curves ---------------------------------------------------------------------------

def by_shift(ds):
    """``ds`` with the ``shift`` dimension labelled by the westward shift v in mm (Figs. 8, 14)."""
    return ds.assign_coords(shift=("shift", -ds["shift_x"].values * 1e3, {"units": "mm", "long_name": "shift v"}))


def _closure_fits(ds: xr.Dataset, load_dim: str, compliance: dict) -> xr.Dataset:
    """Hyperbolic closure fits per sample, the bulk compliance of each footprint removed (offset 0: θ fixed)."""
    if "shift" in ds.dims:
        names = ["maximum_closure", "initial_stiffness", "effective_closure"]
        parts = [analysis.closure_curve(ds.isel(shift=[i]), compliance[i], load_dim=load_dim, offset=False,
                                        on_error="mark")[names] for i in range(ds.sizes["shift"])]
        return xr.concat(parts, dim="shift")
    return analysis.closure_curve(ds, compliance[0], load_dim=load_dim, offset=False, on_error="mark")


@claim("C8", "5c", "the closure asymptote δ_max and the compliance 1/K0 grow with Δ", "closure")
def _closure_delta(r: PaperResults):
    ds = r.root["closure"]
    fit = _closure_fits(ds, "closure", bulk_compliances(r, "closure"))
    return [("δ_max(2.5) − δ_max(2.1) [µm]", "hyperbola, bulk removed",
             1e6 * paired(fit["maximum_closure"], "fractal_dimension", 2.1, 2.5), above(0.0)),
            ("ln K0(2.1) − ln K0(2.5) (compliance 1/K0 grows with Δ)", "hyperbola, bulk removed",
             paired(fit["initial_stiffness"], "fractal_dimension", 2.5, 2.1, log=True), above(0.0))]


@claim("C9", "8a", "rock joint: the closure at a given load grows with the shift v; the curves overlap at large "
       "v and grow again at v ≈ 10 mm", "rock")
def _closure_shift(r: PaperResults):
    ds = by_shift(r.root["rock"])
    fit = _closure_fits(ds, "normal_load", bulk_compliances(r, "rock"))
    closure = nearest(fit["effective_closure"], normal_load=ROCK_LOAD) * 1e6
    return [("δ_eff(v = 2 mm) − δ_eff(v = 0.4 mm) at 10 kN [µm]", "rise", paired(closure, "shift", 0.4, 2.0),
             above(0.0)),
            ("δ_eff(v = 10 mm) / δ_eff(v = 5 mm) − 1 at 10 kN", "overlap",
             nearest(closure, shift=10.0) / nearest(closure, shift=5.0) - 1.0,
             within(-0.1, 0.1)),
            ("δ_eff(v = 10 mm) − δ_eff(v = 5 mm) at 10 kN [µm]", "growth again", paired(closure, "shift", 5.0, 10.0),
             above(0.0))]


# --- Figs. 9, 10, 11: partial slip ------------------------------------------------------------------------

@claim("C10", "10a", "the slip area grows linearly with Q, slope A_r / (fP) (§4.2 vi)", "load", "shear")
def _slip_linear(r: PaperResults):
    rows = []
    for key, load, label in (("load", LOAD_P, "midpoint Δ = {:g}, 992 N"), ("shear", ROCK_LOAD, "face Δ = {:g}, 10 kN")):
        if not r.has(key):
            continue
        tangential = nearest(r.tangential[key], normal_load=load)
        tangential = tangential.sel(Q_over_fP=tangential["Q_over_fP"] < 1.0)
        fit = analysis.slip_area_linearity(tangential, dim="Q_over_fP", tangential="Q")
        friction = float(r.tangential[key].attrs["friction"])
        area = nearest(r.root[key]["contact_area"], normal_load=load)
        ratio = fit["slip_area_rate"] * friction * load / area
        for c, v in _per(ratio, "fractal_dimension", label.format):
            rows.append(("slip-area slope × fP / A_r", c, v, within(0.85, 1.15)))
        for c, v in _per(fit["slip_area_rate_r2"], "fractal_dimension", label.format):
            rows.append(("R² of A_slip against Q", c, v, above(0.98)))
    return rows


@claim("C11", "10b", "Q_stick first rises, then falls as Q → fP", "shear")
def _stick_force(r: PaperResults):
    t = nearest(r.tangential["shear"], normal_load=ROCK_LOAD)
    stick = t["stick_force"] / (float(t.attrs["friction"]) * ROCK_LOAD)
    defined = stick.notnull().any("Q_over_fP")
    peak = stick["Q_over_fP"][stick.fillna(-np.inf).argmax("Q_over_fP")].where(defined)
    interior = ((peak > 0.0) & (peak < 1.0)).astype(float).where(defined)
    rows = []
    for c, v in _per(interior, "fractal_dimension", lambda d: f"face Δ = {d:g}"):
        rows.append(("share of seeds whose Q_stick peaks inside 0 < Q < fP", c, v, above(0.5)))
    for c, v in _per(peak.drop_vars("Q_over_fP"), "fractal_dimension", lambda d: f"face Δ = {d:g}"):
        rows.append(("Q/fP at the peak of Q_stick (Hertz, Cattaneo–Mindlin: 0.63)", c, v, REPORT))
    return rows


@claim("C12", "9", "slip starts at the boundary of the contact clusters, where the pressure is lowest", "load")
def _slip_zones(r: PaperResults):
    t = nearest(nearest(r.tangential["load"], normal_load=LOAD_P), Q_over_fP=SLIP_STATE)
    force = nearest(r.root["load"]["force"], normal_load=LOAD_P)
    stats = slip_zone_statistics(t["zone"], force)
    rows = [("slip boundary share / contact boundary share", c, v, above(1.0))
            for c, v in _per(stats["boundary_enrichment"], "fractal_dimension", _delta)]
    rows += [("mean p̄ on slip nodes / on stick nodes", c, v, below(1.0))
             for c, v in _per(stats["slip_force_ratio"], "fractal_dimension", _delta)]
    rows += [("share of slip nodes among the least loaded", c, v, REPORT)
             for c, v in _per(stats["low_force_overlap"], "fractal_dimension", _delta)]
    return rows


@claim("C13", "11", "G_Q moves away from the footprint's centre as Q → fP, along the reverse of the path of G_P "
       "under rising P", "shear")
def _centroids(r: PaperResults):
    root, t = r.root["shear"], r.tangential["shear"]
    cx, cy = footprint_centres(r, "shear")
    paths = centroid_paths(root, t, cx, cy, ROCK_LOAD)
    inner = paths["shear_centroid_distance"].sel(Q_over_fP=(t["Q_over_fP"] > 0) & (t["Q_over_fP"] < 1))
    away = trend(inner, "Q_over_fP")
    ratio = paths["reverse_path_gap"] / paths["pressure_path_length"]
    label = lambda d: f"face Δ = {d:g}"
    rows = [("d(|G_Q − C|/R) / d(Q/fP)", c, v, above(0.0)) for c, v in _per(away, "fractal_dimension", label)]
    rows += [("max |G_Q(Q) − G_P(P − Q/f)| / path length of G_P", c, v, below(0.1))
             for c, v in _per(ratio, "fractal_dimension", label)]
    rows += [("max |G_Q − (P G_P − P* G_P*)/(P − P*)| / R (the theorem's identity)", c, v, below(1e-6))
             for c, v in _per(paths["increment_identity_error"], "fractal_dimension", label)]
    return rows


# --- Fig. 12: energy ------------------------------------------------------------------------------------

@claim("C14", "12", "E_f depends non-linearly on P and, at a given P, increases with Δ", "load")
def _energy(r: PaperResults):
    ds = r.root["load"]
    fit = analysis.frictional_energy_scaling(ds, on_error="mark")
    rows = [("exponent m of E_tot ∝ P^m (Eq. 27; 1 = linear)", c, v, above(1.0))
            for c, v in _per(fit["frictional_energy_exponent"], "fractal_dimension", _delta)]
    energy = nearest(ds["incipient_sliding_energy"], normal_load=LOAD_P)
    rows.append(("ln E_tot(Δ = 2.5) − ln E_tot(Δ = 2.1) at 992 N", "same load",
                 paired(energy, "fractal_dimension", 2.1, 2.5, log=True), above(0.0)))
    return rows


# --- Fig. 13: force histograms -------------------------------------------------------------------------------

@claim("C15", "13", "at the same P a larger Δ has fewer contact nodes and more uniform forces", "load")
def _force_uniformity(r: PaperResults):
    ds = nearest(r.root["load"], normal_load=LOAD_P)
    u = contact_force_uniformity(ds)
    return [("contact nodes, ln N(2.5) − ln N(2.1)", "992 N", paired(u["contact_nodes"], "fractal_dimension",
                                                                      2.1, 2.5, log=True), below(0.0)),
            ("CV of p̄, CV(2.5) − CV(2.1) (< 0: more uniform)", "992 N",
             paired(u["force_cv"], "fractal_dimension", 2.1, 2.5), below(0.0)),
            ("share of P on the 1 % most loaded nodes, (2.5) − (2.1)", "992 N",
             paired(u["force_top_share"], "fractal_dimension", 2.1, 2.5), below(0.0))]


@claim("C16", "13", "p̄ follows a semi-log law and p̄² a power law (both cannot hold: which does?)", "load")
def _force_law(r: PaperResults):
    ds = nearest(r.root["load"], normal_load=LOAD_P)
    law = contact_force_law_comparison(ds)
    prefers = (law["preferred_law"] == 1).astype(float).where(law["undefined"] == 0)
    rows = [("share of seeds whose tail prefers the exponential (p < 0.05)", c, v, REPORT)
            for c, v in _per(prefers, "fractal_dimension", _delta)]
    rows += [("Vuong statistic (> 0 exponential, < 0 power law)", c, v, REPORT)
             for c, v in _per(law["vuong_statistic"], "fractal_dimension", _delta)]
    return rows


# --- Fig. 14: multifractal spectra ---------------------------------------------------------------------------

def _spectra(ds: xr.Dataset, window: str) -> xr.Dataset:
    return analysis.force_spectrum(ds, q=np.linspace(-5.0, 5.0, 21), window=window, on_error="mark")


@claim("C17", "14b", "as P rises the maximum and the width of f(α) grow", "rock", "load")
def _spectrum_load(r: PaperResults):
    rows = []
    if r.has("rock"):
        ds = nearest(by_shift(r.root["rock"]), shift=2.0)
        spectra = _spectra(ds, "cover")
        for name in ("spectrum_maximum", "spectrum_width"):
            rows.append((f"d {name} / d ln P", "rock, v = 2 mm", trend(spectra[name], "normal_load", log=True),
                         above(0.0)))
    if r.has("load"):
        ds = nearest(r.root["load"], fractal_dimension=2.3)
        spectra = _spectra(ds.where(ds["contact_fraction"] <= MAX_FRACTION_DIMENSION), "origin")
        for name in ("spectrum_maximum", "spectrum_width"):
            rows.append((f"d {name} / d ln P", "midpoint Δ = 2.3", trend(spectra[name], "normal_load", log=True),
                         above(0.0)))
    return rows


@claim("C18", "14a", "as the shift v grows the width and the maximum of f(α) fall", "rock")
def _spectrum_shift(r: PaperResults):
    ds = nearest(by_shift(r.root["rock"]), normal_load=ROCK_LOAD)
    spectra = _spectra(ds, "cover")
    rows = []
    for name in ("spectrum_width", "spectrum_maximum"):
        values = spectra[name]
        rows.append((f"d {name} / d ln v at 10 kN", "rock", trend(values, "shift", log=True), below(0.0)))
    return rows


@claim("C19", "14", "null tests: forces shuffled over the same contact set, equal forces on it, and a Hertz "
       "contact do not look multifractal in the same way", "load")
def _spectrum_nulls(r: PaperResults):
    ds = nearest(r.root["load"], normal_load=LOAD_P, fractal_dimension=2.3)
    nulls = force_spectrum_nulls(ds, q=np.linspace(-5.0, 5.0, 21), permutations=5)
    hertz = hertz_spectrum()
    return [("width − mean width of the shuffled forces", "midpoint Δ = 2.3, 992 N", nulls["width_excess"],
             above(0.0)),
            ("width of f(α)", "midpoint Δ = 2.3, 992 N", nulls["spectrum_width"], REPORT),
            ("width of equal forces on the same set", "midpoint Δ = 2.3, 992 N", nulls["uniform_width"], REPORT),
            ("width of f(α) of a Hertz contact (q ∈ [−5, 5])", "257², a = 64 s", xr.DataArray([hertz["width"]]),
             REPORT),
            ("maximum of f of a Hertz contact (a disc: 2)", "257², a = 64 s", xr.DataArray([hertz["maximum"]]),
             within(1.95, 2.05))]


@claim("C20", "1, 6d", "is Δσ converged in the grid? Δσ over the same physical boxes at every resolution",
       "resolution")
def _dimension_convergence(r: PaperResults):
    ds = nearest(r.root["resolution"], normal_load=RESOLUTION_LOAD)
    coarsest = int(ds["coarsening"].max())
    parts = []
    for c in ds["coarsening"].values:
        sample = ds.sel(coarsening=c)
        # the same physical boxes on every grid: one to four nodes of the coarsest grid
        box = (coarsest // int(c), 4 * coarsest // int(c))
        parts.append(analysis.contact_dimension(sample, box_range=box, on_error="mark")["contact_dimension"])
    dims = _spacing_axis(ds, xr.concat(parts, dim="coarsening"))
    slope = trend(dims, "coarsening", log=True)
    return [("d Δσ / d ln s over the same physical boxes (0: converged)", c, v, within(-0.05, 0.05))
            for c, v in _per(slope, "fractal_dimension", _delta)]


def evaluate(results: PaperResults) -> list[Row]:
    """Every claim's rows; a claim whose studies are missing or whose measure fails gets one row saying why."""
    rows = []
    for item in CLAIMS:
        if not any(results.has(k) for k in item.studies):
            rows.append(Row(item.key, item.figure, item.statement, "", "", np.nan, np.nan, np.nan, 0, "",
                            f"not run ({', '.join(item.studies)} not in this output)"))
            continue
        try:
            tests = item.test(results)
        except InputError as exc:
            rows.append(Row(item.key, item.figure, item.statement, "", "", np.nan, np.nan, np.nan, 0, "",
                            f"not measured: {exc}"))
            continue
        for quantity, condition, values, rule in tests:
            mean, lower, upper, n = interval(values.values)
            if n == 1:          # one deterministic number (a closed-form null), no ensemble: judged as it is
                lower = upper = mean
            rows.append(Row(item.key, item.figure, item.statement, quantity, condition, mean, lower, upper, n,
                            str(rule), rule.verdict(lower, upper)))
    return rows
