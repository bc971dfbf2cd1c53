"""The measures the paper's claims read, against closed forms; the paper's study files and figure registry.

Each measure is checked on data whose answer is known by construction (a
hand-drawn slip pattern, exact power laws, samples drawn from a known law),
not against its own output.
"""
from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
import tomllib
import xarray as xr

from roughcontact.analysis.area import load_exponent, proportionality
from roughcontact.analysis.box_counting import box_counts
from roughcontact.analysis.ensemble import trend
from roughcontact.analysis.pressure_statistics import force_law_comparison, force_uniformity
from roughcontact.analysis.slip_zones import cluster_boundary, slip_zones
from roughcontact.errors import InputError
from roughcontact.farm import load_study
from roughcontact.paper.figures import DRAWERS, _stick_force_hertz
from roughcontact.paper.registry import FIGURES, STUDIES, needed, studies_folder

PAPER = Path(__file__).resolve().parents[1] / "studies" / "paper"


def test_slip_zones_on_a_hand_drawn_pattern():
    """A 3×3 cluster: its 8 edge nodes are its boundary, the centre is not. Slip on 4 edge nodes (forces 1),
    stick on the other 5 (forces 2, centre 3): enrichment = (4/4)/(8/9), force ratio = 1 / (11/5), and the
    4 least loaded nodes are exactly the slip nodes."""
    zone = np.zeros((5, 5), dtype=np.int8)
    zone[1:4, 1:4] = 1
    force = np.where(zone == 1, 2.0, 0.0)
    force[2, 2] = 3.0
    for i, j in ((1, 1), (1, 3), (3, 1), (3, 3)):
        zone[i, j], force[i, j] = 2, 1.0
    assert cluster_boundary(zone > 0).sum() == 8
    stats = slip_zones(zone, force)
    assert float(stats["boundary_enrichment"]) == pytest.approx(1.0 / (8.0 / 9.0), rel=1e-12)
    assert float(stats["slip_force_ratio"]) == pytest.approx(1.0 / (11.0 / 5.0), rel=1e-12)
    assert float(stats["low_force_overlap"]) == 1.0
    with pytest.raises(InputError, match="codes"):
        slip_zones(np.full((3, 3), -1), np.zeros((3, 3)))


def test_load_exponent_and_kappa_of_exact_power_laws():
    """A_r = C P^0.8 gives m = 0.8 to rounding; A_r = κ P / (E* h') with κ = 2 gives κ = 2. Loads beyond 10 %
    contact or under 20 nodes are left out (here the last and the first)."""
    spacing = 1e-4
    load = np.array([1.0, 10.0, 20.0, 40.0, 80.0, 1e4])
    area = 3e-6 * load**0.8
    area[0] = 5 * spacing**2                    # 5 nodes: below the 20-node floor
    fraction = np.array([0.001, 0.01, 0.02, 0.04, 0.08, 0.5])
    fit = load_exponent(load, area, fraction, spacing)
    assert float(fit["area_load_exponent"]) == pytest.approx(0.8, abs=1e-12)
    assert int(fit["area_load_exponent_points"]) == 4
    modulus, slope = 1e10, 0.05
    area = 2.0 * load / (modulus * slope)
    out = proportionality(load, area, fraction, slope, spacing, modulus)
    assert float(out["persson_kappa"]) == pytest.approx(2.0, rel=1e-12)


def test_trend_is_the_least_squares_slope():
    """Per sample, the slope of y = a x + b (or of y against ln x) is a, NaN points left out."""
    x = np.array([1.0, 2.0, 4.0, 8.0])
    y = xr.DataArray(np.stack([3.0 * x + 1.0, -2.0 * np.log(x)]), dims=("seed", "p"), coords={"p": x}, name="y")
    assert trend(y, "p").values[0] == pytest.approx(3.0, rel=1e-12)
    assert trend(y, "p", log=True).values[1] == pytest.approx(-2.0, rel=1e-12)
    y[0, 1] = np.nan
    assert trend(y, "p").values[0] == pytest.approx(3.0, rel=1e-12)


def test_cover_window_counts_every_node_of_a_lens():
    """On a 100×100 grid the origin window (64²) misses nodes beyond it; the cover window (128², zeros
    beyond the grid) counts every one: N(1) equals the number of set nodes, and on a set inside the
    origin window both windows give the same counts."""
    rng = np.random.default_rng(3)
    mask = rng.random((100, 100)) < 0.05
    _, counts = box_counts(mask, window="cover")
    assert counts[0] == mask.sum()
    _, origin = box_counts(mask)
    assert origin[0] == mask[:64, :64].sum() < mask.sum()
    inside = np.zeros_like(mask)
    inside[:64, :64] = mask[:64, :64]
    _, counts_o = box_counts(inside)
    _, counts_c = box_counts(inside, window="cover")
    assert np.array_equal(counts_o, counts_c[:counts_o.size])


def test_force_law_comparison_recovers_the_law_it_was_drawn_from():
    """20 000 exponential forces prefer the exponential, 20 000 Pareto forces (a = 3) the power law,
    each at p < 0.01 (Vuong); the Pareto exponent is recovered within 5 % (its MLE's standard error
    is a/√n ≈ 0.03 on the 10 000-point tail), and with it the exponent of the density of p̄²."""
    rng = np.random.default_rng(7)
    contact = np.ones(20000, dtype=bool)
    exponential = force_law_comparison(rng.exponential(2.0, 20000), contact)
    assert int(exponential["preferred_law"]) == 1 and float(exponential["vuong_p_value"]) < 0.01
    pareto = force_law_comparison(rng.pareto(2.0, 20000) + 1.0, contact)
    assert int(pareto["preferred_law"]) == -1 and float(pareto["vuong_p_value"]) < 0.01
    assert float(pareto["tail_exponent"]) == pytest.approx(3.0, rel=0.05)
    # p̄ with density ∝ p̄^−3 gives p̄² a density ∝ (p̄²)^−2: β = −(a + 1)/2
    assert float(pareto["beta"]) == pytest.approx(-2.0, rel=0.05)


def test_force_uniformity_of_equal_and_of_two_level_forces():
    """Equal forces: CV 0, the top 1 % carries 1 %. Half at 1, half at 3: CV = 1/2 (std 1, mean 2)."""
    equal = force_uniformity(np.ones(200), np.ones(200, dtype=bool))
    assert float(equal["force_cv"]) == 0.0 and float(equal["force_top_share"]) == pytest.approx(0.01)
    two = force_uniformity(np.r_[np.ones(100), 3 * np.ones(100)], np.ones(200, dtype=bool))
    assert float(two["force_cv"]) == pytest.approx(0.5, rel=1e-12)


def test_hertz_stick_force_fraction():
    """Cattaneo–Mindlin: Q_stick/fP = 1 − (1 − x²)^{3/2} − x³ with x = (1 − Q/fP)^{1/3}: 0 at both ends,
    and Q_stick + Q_slip = Q with Q_slip/fP = 1 − x³ + ... checked at Q/fP = 7/8 (x = 1/2):
    1 − (3/4)^{3/2} − 1/8."""
    ratio = np.array([0.0, 7.0 / 8.0, 1.0])
    assert _stick_force_hertz(ratio) == pytest.approx([0.0, 1.0 - 0.75**1.5 - 0.125, 0.0], abs=1e-12)


def test_every_figure_has_a_drawer_and_its_studies():
    """Figs. 1, 2, 3(a), 4–14 are drawn, each from registered studies that exist at both scales."""
    assert FIGURES == tuple(range(1, 15)) and set(DRAWERS) == set(FIGURES)
    for full in (False, True):
        folder = studies_folder(full)
        for study in STUDIES:
            load_study(folder / f"{study.stem}.toml")
    assert [s.key for s in needed([11])] == ["shear"]
    with pytest.raises(InputError, match="not reproduced"):
        needed([15])


#: keys the full scale may change: resolution and ensemble size (and the names that say so)
SCALE_KEYS = {"levels", "spacing", "shape", "seeds", "coarsening", "name", "description"}


@pytest.mark.parametrize("study", STUDIES, ids=lambda s: s.stem)
def test_quick_and_full_studies_differ_only_in_resolution_and_seeds(study):
    """The quick scale is the full one made smaller, never a different experiment."""
    def flat(path):
        out = {}
        for table, values in tomllib.loads(path.read_text()).items():
            for key, value in (values.items() if isinstance(values, dict) else [("", values)]):
                out[(table, key)] = value
        return out
    quick, full = flat(PAPER / f"{study.stem}.toml"), flat(PAPER / "full" / f"{study.stem}.toml")
    assert quick.keys() == full.keys()
    changed = {key for key in quick if quick[key] != full[key]}
    assert {k for _, k in changed} <= SCALE_KEYS | {""}, changed


def test_field_levels_hold_the_ones_before():
    """fields = "force" keeps the contact sets and the nodal forces (what box counting, histograms and f(α)
    read) but not the pressure (= force / s²) and the gap; "all" keeps every field."""
    from roughcontact.datasets import FIELD_TABLE, stored_fields

    assert stored_fields(FIELD_TABLE, "contact") == ["contact"]
    assert sorted(stored_fields(FIELD_TABLE, "force")) == ["contact", "force"]
    assert sorted(stored_fields(FIELD_TABLE, "all")) == ["contact", "force", "gap", "pressure"]
    assert stored_fields(FIELD_TABLE, "none") == []
