"""Box counting (§3.2) and the renormalisation of Eqs. 12–13 on sets of known dimension.

Exact cases (tolerance 1e-12, round-off of a least-squares fit of
logarithms): a filled square (2), straight and diagonal lines (1), isolated
nodes and a single node (0), the Sierpinski carpet counted in boxes of 3^k
(log 8 / log 3) and a Sierpinski gasket of 3 out of 4 quadrants counted in
boxes of 2^k (log 3 / log 2): for them N(ε) is an exact power law on every
box size. Approximate cases, with the reason for each tolerance next to it:
the carpet counted in the default powers of 2, and a random Cantor dust.
"""
from __future__ import annotations

import numpy as np
import pytest
import xarray as xr

from roughcontact.analysis import (
    box_counting,
    contact_dimension,
    contact_renormalisation,
    ensemble_statistics,
    renormalisation,
    size_effect,
)
from roughcontact.errors import InputError

CARPET = np.log(8.0) / np.log(3.0)
GASKET = np.log(3.0) / np.log(2.0)


def carpet(levels: int) -> np.ndarray:
    """Sierpinski carpet on 3^levels nodes a side: the middle ninth removed at every level."""
    mask = np.ones((1, 1), dtype=bool)
    for _ in range(levels):
        hole = np.zeros_like(mask)
        mask = np.block([[mask, mask, mask], [mask, hole, mask], [mask, mask, mask]])
    return mask


def gasket(levels: int) -> np.ndarray:
    """3 of the 4 quadrants kept at every level (2^levels nodes a side): N(2^j) = 3^(levels − j)."""
    mask = np.ones((1, 1), dtype=bool)
    for _ in range(levels):
        mask = np.block([[mask, mask], [mask, np.zeros_like(mask)]])
    return mask


def cantor_dust(levels: int, keep: float, rng: np.random.Generator) -> np.ndarray:
    """Mandelbrot's fractal percolation: each square splits in 2 × 2, each child kept with probability ``keep``.

    Conditioned on survival its dimension is log(4 keep) / log 2 almost surely
    (Falconer, Fractal Geometry, 3rd ed., §15.2; Mandelbrot 1982).
    """
    mask = np.ones((1, 1), dtype=bool)
    for _ in range(levels):
        mask = np.kron(mask, np.ones((2, 2), dtype=bool)) & (rng.random((2 * mask.shape[0],) * 2) < keep)
    return mask


def test_filled_square_line_and_diagonal():
    """A 33 × 33 grid (the window keeps 32²): N(ε) = (32/k)², 32/k and 32/k exactly."""
    square = box_counting(np.ones((33, 33), dtype=bool))
    assert float(square["contact_dimension"]) == pytest.approx(2.0, abs=1e-12)
    assert float(square["grid_scale_dimension"]) == pytest.approx(2.0, abs=1e-12)
    assert int(square["window_nodes"]) == 32
    np.testing.assert_array_equal(square["box_count"], (32 // square["box_nodes"].values) ** 2)
    line = np.zeros((33, 33), dtype=bool)
    line[5, :] = True
    diagonal = np.eye(33, dtype=bool)
    for mask in (line, diagonal):
        ds = box_counting(mask)
        assert float(ds["contact_dimension"]) == pytest.approx(1.0, abs=1e-12)
        assert float(ds["grid_scale_dimension"]) == pytest.approx(1.0, abs=1e-12)
        assert float(ds["contact_dimension_stderr"]) == pytest.approx(0.0, abs=1e-12)


def test_isolated_nodes_and_single_node_have_dimension_zero():
    """16 nodes, one per 8 × 8 block: N = 16 at k = 1 … 8 (the default fit) so Δσ = 0; one node: N = 1 always."""
    points = np.zeros((32, 32), dtype=bool)
    points[3::8, 5::8] = True
    ds = box_counting(points)
    np.testing.assert_array_equal(ds["box_count"].values[:4], 16)
    assert float(ds["contact_dimension"]) == pytest.approx(0.0, abs=1e-12)
    assert float(ds["grid_scale_dimension"]) == 0.0
    single = np.zeros((32, 32), dtype=bool)
    single[7, 9] = True
    ds = box_counting(single)
    assert float(ds["contact_dimension"]) == pytest.approx(0.0, abs=1e-12)
    assert (float(ds["contact_dimension_lower"]), float(ds["contact_dimension_upper"])) == pytest.approx((0.0, 0.0))


def test_sierpinski_carpet():
    """Boxes of 3^k on the 243² carpet: exact. Boxes of 2^k on the 729² carpet (window 512²): the
    boxes straddle the carpet's holes, which lowers N at small ε; measured 1.861, so the tolerance is
    0.05 (2.6 % of log 8 / log 3) and the estimate lies below the true value."""
    exact = box_counting(carpet(5), base=3)
    assert float(exact["contact_dimension"]) == pytest.approx(CARPET, abs=1e-12)
    assert float(exact["grid_scale_dimension"]) == pytest.approx(CARPET, abs=1e-12)
    powers_of_two = float(box_counting(carpet(6))["contact_dimension"])
    assert CARPET - 0.05 < powers_of_two < CARPET


def test_random_cantor_dust_ensemble():
    """20 surviving realisations of fractal percolation (keep 3/4, 256²): expected Δσ = log 3 / log 2.

    The spread of one estimate over realisations is 0.024 (measured), so the mean of 20 lies within
    0.02 (≈ 4 standard errors) of its expectation; the ensemble's 95 % interval, computed by
    contact_dimension + ensemble_statistics on a (seed, x, y) dataset, contains it.
    """
    rng = np.random.default_rng(1)
    masks = []
    while len(masks) < 20:
        mask = cantor_dust(8, 0.75, rng)
        if mask.any():
            masks.append(mask)
    ds = xr.Dataset({"contact": (("seed", "x", "y"), np.stack(masks).astype(np.int8))},
                    coords={"seed": np.arange(20)}, attrs={"spacing": 1e-6})
    per_seed = contact_dimension(ds)
    assert per_seed["contact_dimension"].dims == ("seed",)
    assert float(per_seed["contact_dimension"].mean()) == pytest.approx(GASKET, abs=0.02)
    summary = ensemble_statistics(per_seed, "seed")
    assert float(summary["contact_dimension_lower"]) < GASKET < float(summary["contact_dimension_upper"])
    assert int(summary["contact_dimension_samples"]) == 20
    assert "contact_dimension_stderr" not in summary   # the ensemble interval replaces per-seed errors


def test_renormalisation_of_a_gasket():
    """Uniform force f per node on a 3-of-4 gasket (256², s = 1 µm): a window of side b = 2^j s holding
    contact holds 3^j nodes, so σ0(b) = f 3^j / b² exactly, Δσ = log 3 / log 2 and, by Eq. 12 with
    N(b) = 3^(8 − j) windows, σ* = P / (N(b) b^Δσ) = f / s^Δσ."""
    s, f = 1e-6, 0.01
    mask = gasket(8)
    ds = renormalisation(np.where(mask, f, 0.0), mask, spacing=s)
    b = ds["box_size"].values
    j = np.log2(ds["box_nodes"].values)
    np.testing.assert_allclose(ds["window_pressure"], f * 3.0**j / b**2, rtol=1e-12)
    assert float(ds["renormalised_dimension"]) == pytest.approx(GASKET, abs=1e-12)
    assert float(ds["fractal_pressure"]) == pytest.approx(f / s**GASKET, rel=1e-9)


def test_size_effect_recovers_eq_13():
    """σ0 = σ* b^−(2 − Δσ) on five sizes, 1 % log-normal scatter: Δσ and σ* back within their intervals."""
    rng = np.random.default_rng(4)
    sizes = np.geomspace(1e-3, 1e-1, 5)
    pressure = 2.0e3 * sizes ** -(2.0 - 1.4) * np.exp(0.01 * rng.standard_normal(5))
    ds = size_effect(sizes, pressure)
    assert float(ds["renormalised_dimension_lower"]) < 1.4 < float(ds["renormalised_dimension_upper"])
    assert float(ds["fractal_pressure_lower"]) < 2.0e3 < float(ds["fractal_pressure_upper"])


def test_bad_input_is_named():
    with pytest.raises(InputError, match="contact: is empty"):
        box_counting(np.zeros((32, 32), dtype=bool))
    with pytest.raises(InputError, match="box_range: a box of 64 nodes is larger"):
        box_counting(np.ones((32, 32), dtype=bool), box_range=(1, 64))
    with pytest.raises(InputError, match="box_range: boxes of 1 to 2 nodes give 2"):
        box_counting(np.ones((32, 32), dtype=bool), box_range=(1, 2))
    with pytest.raises(InputError, match="box_range: boxes of 1 to 2 nodes give 2"):
        box_counting(np.ones((9, 9), dtype=bool))         # an 8-node window holds k = 1, 2 in the default range
    with pytest.raises(InputError, match="shape"):
        box_counting(np.ones((1, 40), dtype=bool))
    with pytest.raises(InputError, match="contact: is empty"):
        renormalisation(np.zeros((32, 32)), np.zeros((32, 32), dtype=bool))


def test_empty_contact_set_in_a_sweep_is_marked_not_silent():
    """With on_error="mark" an empty set is NaN and ``undefined`` = 1 with the reason; by default it raises."""
    contact = np.zeros((2, 32, 32), dtype=np.int8)
    contact[1, 8:24, 8:24] = 1       # aligned with the boxes: N = (16/k)²
    ds = xr.Dataset({"contact": (("normal_load", "x", "y"), contact),
                     "force": (("normal_load", "x", "y"), contact * 1.0)},
                    coords={"normal_load": ("normal_load", [0.0, 10.0], {"units": "N"})}, attrs={"spacing": 1e-4})
    with pytest.raises(InputError):
        contact_dimension(ds)
    marked = contact_dimension(ds, on_error="mark")
    assert np.isnan(float(marked["contact_dimension"][0]))
    assert float(marked["contact_dimension"][1]) == pytest.approx(2.0, abs=1e-12)
    np.testing.assert_array_equal(marked["undefined"], [1, 0])
    assert "is empty" in marked["undefined"].attrs["reasons"]
    assert float(contact_renormalisation(ds, on_error="mark")["renormalised_dimension"][1]) == pytest.approx(2.0)
