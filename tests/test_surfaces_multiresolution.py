"""The same surface at spacings s, 2s, 4s, … (paper Fig. 1), by decimation and by local averaging.

Known truths: decimation keeps node values exactly; block averaging over whole blocks keeps the
mean exactly (a sum regrouped) and maps a plane onto the plane at the block centres; a
self-affine surface's rms slope at spacing σ scales as σ^(H−1).
"""
from __future__ import annotations

import numpy as np
import pytest

from roughcontact.errors import InputError
from roughcontact.surfaces import Topography, coarsen, fourier_surface, midpoint_surface, multiresolution, rms_slope


def test_decimation_keeps_node_values_and_spacing():
    t = midpoint_surface(7, 2.3, 1e-4, rms_height=1e-5, seed=1)
    levels = multiresolution(t, 4, "decimate")
    assert [c.spacing for c in levels] == pytest.approx([1e-4, 2e-4, 4e-4, 8e-4])
    assert [c.shape for c in levels] == [(129, 129), (65, 65), (33, 33), (17, 17)]
    for k, c in enumerate(levels):
        assert np.array_equal(c.heights, t.heights[:: 2**k, :: 2**k])


def test_decimation_keeps_the_mean_of_a_plane_on_a_2n_plus_1_grid():
    """Grids of 2^n + 1 nodes decimate onto nodes symmetric about the centre, so a plane's mean
    (its centre value) is kept to rounding."""
    x = np.arange(65)[:, None] * 1.0
    y = np.arange(65)[None, :] * 1.0
    t = Topography(0.3 * x - 0.2 * y + 4.0, 1.0)
    for c in multiresolution(t, 6, "decimate"):
        assert c.heights.mean() == pytest.approx(t.heights.mean(), rel=1e-14)


def test_averaging_keeps_the_mean_exactly_and_a_plane_at_block_centres():
    t = fourier_surface((96, 64), 1e-5, hurst=0.6, rms_height=1e-6, seed=3, periodic=False)
    for c in multiresolution(t, 4, "average"):
        assert c.heights.mean() == pytest.approx(t.heights.mean(), abs=1e-15 * 1e-6 * 100)
    f = 4
    x = np.arange(96)[:, None] * 1e-5
    y = np.arange(64)[None, :] * 1e-5
    c = coarsen(Topography(2.0 * x + 3.0 * y, 1e-5), f, "average")
    origin = c.metadata["coarsening"]["origin"][0]
    assert origin == pytest.approx((f - 1) * 1e-5 / 2)
    xc = origin + np.arange(24)[:, None] * f * 1e-5
    yc = origin + np.arange(16)[None, :] * f * 1e-5
    np.testing.assert_allclose(c.heights, 2.0 * xc + 3.0 * yc, rtol=1e-12)


def test_averaging_drops_incomplete_blocks_and_keeps_footprint_blocks_whole():
    h = np.arange(7 * 5, dtype=float).reshape(7, 5)
    footprint = np.ones((7, 5), dtype=bool)
    footprint[0, 0] = False
    h[0, 0] = np.nan  # off the footprint: must not leak into any kept block
    c = coarsen(Topography(h, 1.0, footprint), 2, "average")
    assert c.shape == (3, 2)
    assert c.metadata["coarsening"]["dropped_nodes"] == (1, 1)
    assert not c.footprint[0, 0] and c.footprint.sum() == 5
    assert c.heights[1, 1] == pytest.approx(h[2:4, 2:4].mean())
    d = coarsen(Topography(h, 1.0, footprint), 2, "decimate")
    assert d.shape == (4, 3) and not d.footprint[0, 0]


def test_rms_slope_scales_with_spacing_as_sigma_to_H_minus_1():
    """Fig. 1's premise: a finer grid sees steeper slopes. The log–log slope of Sdq against the spacing
    over 1..16 s is H − 1 within 0.1 (4 seeds of 512², H = 0.7)."""
    hurst = 0.7
    slopes = []
    for seed in range(4):
        t = fourier_surface(512, 1e-5, hurst=hurst, rms_height=1e-6, seed=seed)
        levels = multiresolution(t, 5, "decimate")
        spacing = np.array([c.spacing for c in levels])
        sdq = np.array([rms_slope(c) for c in levels])
        slopes.append(np.polyfit(np.log(spacing), np.log(sdq), 1)[0])
    assert np.mean(slopes) == pytest.approx(hurst - 1.0, abs=0.1)


@pytest.mark.parametrize("call, parameter", [
    (lambda t: coarsen(t, 0), "factor"),
    (lambda t: coarsen(t, -2), "factor"),
    (lambda t: coarsen(t, 1.5), "factor"),
    (lambda t: coarsen(t, 40, "average"), "factor"),
    (lambda t: coarsen(t, 2, "median"), "method"),
    (lambda t: multiresolution(t, 0), "levels"),
    (lambda t: multiresolution(t, 9), "levels"),
])
def test_bad_arguments_name_the_parameter(call, parameter):
    t = Topography(np.zeros((33, 33)), 1.0)
    with pytest.raises(InputError) as err:
        call(t)
    assert err.value.parameter == parameter
