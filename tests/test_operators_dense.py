"""Elastic model: composite constants (Eqs. 4a, 4b, 5) and the Eq. 10 influence coefficients."""
from __future__ import annotations

import math

import numpy as np
import pytest

from roughcontact.materials import Interface, Material
from roughcontact.operators.kernel import influence_rows, punch_kernel
from roughcontact.surfaces import disc


def test_composite_constants():
    steel, glass = Material(210e9, 0.3), Material(70e9, 0.22)
    pair = Interface(steel, glass)
    # A = 2/E* with Johnson's 1/E* = (1 − ν1²)/E1 + (1 − ν2²)/E2 (paper footnote 2), to round-off
    e_star = 1.0 / ((1 - 0.3**2) / 210e9 + (1 - 0.22**2) / 70e9)
    assert pair.compliance == pytest.approx(2.0 / e_star, rel=1e-14)
    # identical bodies: β = 0 (Eq. 5); γ = ν / (1 − ν) (Eq. 4b)
    same = Interface(steel, steel)
    assert same.dundurs_beta == 0.0 and same.normal_uncoupled_exact
    assert same.composite_poisson == pytest.approx(0.3 / 0.7, rel=1e-14)
    assert not same.cattaneo_exact
    # ν = 0 on both sides: the Cattaneo analogy is exact (§4.1)
    assert Interface(Material(1e9, 0.0), Material(3e9, 0.0)).cattaneo_exact is False  # β ≠ 0: μ differ
    assert Interface(Material(1e9, 0.0), Material(1e9, 0.0)).cattaneo_exact
    # rigid counter-face: β = (κ − 1)/(κ + 1) = (1 − 2ν) / (2 (1 − ν))
    on_rigid = Interface(Material(1e9, 0.25))
    assert on_rigid.dundurs_beta == pytest.approx(0.5 / 1.5, rel=1e-14)
    with pytest.raises(Exception):
        Interface(Material.rigid(), Material.rigid())


def test_punch_kernel_self_term_and_far_field():
    """H_ii is the rigid-punch settlement A/(4a); far away H → A/(2π r), the point force (Eq. 6)."""
    s, compliance = 2e-6, 1e-10
    kernel = punch_kernel((64, 64), s, compliance)
    a = s / 2
    assert kernel[0, 0] == pytest.approx(compliance / (4 * a), rel=1e-15)
    r = math.hypot(40, 30) * s
    # arcsin(a/r) = a/r (1 + (a/r)²/6 + O((a/r)⁴)): the excess over the point force is
    # (a/r)²/6 = 1.7e-5 at r = 50 s, matched to the next term's relative size (a/r)² 3/20
    excess = kernel[40, 30] / (compliance / (2 * math.pi * r)) - 1.0
    assert excess == pytest.approx((a / r) ** 2 / 6, rel=1e-3)
    assert kernel[1, 0] == pytest.approx(compliance / (2 * math.pi * a) * math.asin(0.5), rel=1e-15)


@pytest.mark.parametrize("workers", [1, 2, 3])
def test_punch_kernel_by_threads_is_the_formula_entry_by_entry(monkeypatch, workers):
    """The table's rows, by chunks shared between threads (a slab's rows, as a distributed
    operator asks for them), are Eq. 10 evaluated at each offset alone, bit for bit, and rows
    3 … 7 agree with the closed form A/(2π a) · arcsin(min(1, a/r)) to round-off."""
    from roughcontact.operators import kernel, passes
    from roughcontact.operators.kernel import punch_entries

    monkeypatch.setattr(passes, "SHARED_VALUES", 1)          # split however small the table
    monkeypatch.setattr(kernel, "TABLE_CHUNK", 23 * 3)       # chunks of 3 rows, the last one short
    s, compliance = 3e-6, 2e-10
    rows = np.arange(3, 20)
    table = punch_kernel((40, 23), s, compliance, rows=rows, workers=workers)
    assert table.shape == (rows.size, 23)
    for k, i in enumerate(rows):
        for j in (0, 1, 7, 22):
            assert table[k, j] == punch_entries(np.array(i), np.array(j), s, compliance)
    a = s / 2
    r = np.hypot(rows[:5, None], np.arange(23)[None, :]) * s
    np.testing.assert_allclose(table[:5], compliance / (2 * np.pi * a) * np.arcsin(np.minimum(1.0, a / r)),
                               rtol=1e-14, atol=0)


@pytest.mark.parametrize("footprint", ["rectangle", "disc"])
def test_influence_rows_match_eq10(footprint):
    """Every row equals Eq. 10 evaluated node by node (exact to round-off) and H is symmetric."""
    shape, s, compliance = (13, 9), 1e-6, 3e-10
    mask = np.ones(shape, bool) if footprint == "rectangle" else disc(shape, s, 8.5 * s)
    nodes = np.argwhere(mask)
    kernel = punch_kernel(shape, s, compliance)
    h = influence_rows(kernel, mask, slice(0, len(nodes)))
    a = s / 2
    r = np.hypot(*(nodes[:, None, :] - nodes[None, :, :]).transpose(2, 0, 1)) * s
    expected = compliance / (2 * np.pi * a) * np.arcsin(np.minimum(1.0, a / np.where(r > 0, r, a)))
    np.testing.assert_allclose(h, expected, rtol=1e-14, atol=0)
    np.testing.assert_array_equal(h, h.T)
    part = influence_rows(kernel, mask, slice(5, 11))
    np.testing.assert_array_equal(part, h[5:11])
