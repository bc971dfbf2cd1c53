"""Composite topographies: two surfaces, and a fracture face with its mate shifted by v (Fig. 7).

Known truths: a whole-pixel shift is array slicing, so the composite equals the array
difference exactly; bilinear interpolation reproduces a plane exactly, so a sub-pixel shift of
a plane h = a x + b y gives Δh = a vx + b vy everywhere; an unshifted mated pair closes
perfectly (Δh ≡ 0); the overlap of a disc and the same disc shifted by d is the lens of area
2R² acos(d/2R) − (d/2) sqrt(4R² − d²).
"""
from __future__ import annotations

import numpy as np
import pytest

from roughcontact.errors import InputError
from roughcontact.surfaces import (
    Topography,
    composite_topography,
    disc,
    fourier_surface,
    mated_composite,
    midpoint_surface,
)
from roughcontact.surfaces.interpolation import interpolate_at_indices, resample_square

S = 1e-4


def face(shape=(40, 30), seed=1):
    return fourier_surface(shape, S, hurst=0.8, rms_height=1e-5, seed=seed, periodic=False)


def test_unshifted_mated_faces_close_perfectly():
    t = mated_composite(face(), (0.0, 0.0))
    assert t.shape == (40, 30)
    assert np.all(t.heights == 0.0)


@pytest.mark.parametrize("pixels", [(3, 0), (0, -4), (5, 2), (-2, -7), (-6, 3)])
def test_whole_pixel_shift_is_the_array_difference(pixels):
    """Δh(x) = h(x) − h(x − v) on the overlap, bit for bit."""
    f = face()
    p, q = pixels
    t = mated_composite(f, (p * S, q * S))
    h = f.heights
    nx, ny = h.shape
    i0, j0 = max(p, 0), max(q, 0)
    i1, j1 = nx + min(p, 0), ny + min(q, 0)
    expected = h[i0:i1, j0:j1] - h[i0 - p:i1 - p, j0 - q:j1 - q]
    assert t.shape == expected.shape
    assert np.array_equal(t.heights, expected)
    assert t.metadata["origin"] == pytest.approx((i0 * S, j0 * S))
    assert t.metadata["shift"] == pytest.approx((p * S, q * S))


def test_two_surfaces_give_lower_minus_upper():
    lower = face(seed=1)
    upper = midpoint_surface(6, 2.3, S, rms_height=1e-5, seed=2)  # 65 x 65: a larger upper body
    t = composite_topography(lower, upper)
    assert np.array_equal(t.heights, lower.heights - upper.heights[:40, :30])
    t = composite_topography(lower, upper, shift=(-3 * S, 2 * S))
    assert np.array_equal(t.heights, lower.heights[:, 2:] - upper.heights[3:43, :28])


@pytest.mark.parametrize("shift", [(0.3 * S, 0.0), (0.0, -2.6 * S), (1.25 * S, -0.4 * S), (-7.5 * S, 3.1 * S)])
def test_sub_pixel_shift_of_a_plane_is_exact(shift):
    """Bilinear interpolation is exact on a plane: Δh = a vx + b vy to rounding. Heights of 1e-3 m
    carry rounding of 1e-19 m; Δh is about 1e-6 m, so 1e-9 relative is generous yet far below
    any interpolation error (which would be of order a s = 2e-6 m)."""
    a, b = 0.02, -0.035
    x = np.arange(50)[:, None] * S
    y = np.arange(44)[None, :] * S
    t = mated_composite(Topography(a * x + b * y + 1e-3, S), shift)
    expected = a * shift[0] + b * shift[1]
    np.testing.assert_allclose(t.heights, expected, rtol=1e-9, atol=0)
    # overlap: nodes i with i − vx/s within [0, n − 1]
    assert t.shape == (50 - int(np.ceil(abs(shift[0]) / S - 1e-9)), 44 - int(np.ceil(abs(shift[1]) / S - 1e-9)))


def test_sub_pixel_shift_interpolates_between_whole_pixel_ones():
    """A half-pixel shift is the mean of the neighbouring whole-pixel shifts of the upper face."""
    f = face()
    half = composite_topography(f, f, (0.5 * S, 0.0))
    h = f.heights
    expected = h[1:, :] - 0.5 * (h[:-1, :] + h[1:, :])
    np.testing.assert_allclose(half.heights, expected, rtol=0, atol=1e-15 * np.abs(h).max() * 10)


def test_core_section_overlap_is_the_lens_of_two_discs():
    """A 50 mm core sampled at 0.5 mm, shifted by 10 mm (Fig. 7(c)): the composite's footprint is
    the lens of two discs; its node count times s² matches the lens area within the perimeter
    band (lens perimeter × s)."""
    s, diameter, v = 0.5e-3, 50e-3, 10e-3
    n = 111
    f = fourier_surface(n, s, hurst=0.79, rms_height=0.3e-3, seed=3, periodic=False)
    core = f.with_footprint(disc(f.shape, s, diameter))
    t = mated_composite(core, (-v, 0.0))  # west
    radius = diameter / 2
    lens = 2 * radius**2 * np.arccos(v / (2 * radius)) - v / 2 * np.sqrt(4 * radius**2 - v**2)
    perimeter = 4 * radius * np.arccos(v / (2 * radius))
    assert t.nominal_area == pytest.approx(lens, abs=perimeter * s)
    # every composite node is inside both discs: at x and at x − v
    centre = (n - 1) * s / 2
    ox, oy = t.metadata["origin"]
    i, j = np.nonzero(t.footprint)
    x, y = ox + i * s, oy + j * s
    assert np.all(np.hypot(x - centre, y - centre) <= radius * (1 + 1e-9))
    assert np.all(np.hypot(x + v - centre, y - centre) <= radius * (1 + 1e-9))
    # heights off the lens are not used; on it they are finite
    assert np.isfinite(t.heights[t.footprint]).all()


@pytest.mark.parametrize("shift", [(40 * S, 0.0), (0.0, -30 * S), (-45.2 * S, 3 * S), (1e3, 1e3)])
def test_shift_larger_than_the_surface_is_rejected(shift):
    with pytest.raises(InputError) as err:
        mated_composite(face(), shift)
    assert err.value.parameter == "shift"


def test_shift_past_the_footprints_is_rejected():
    f = face((60, 60))
    core = f.with_footprint(disc(f.shape, S, 20 * S))
    with pytest.raises(InputError) as err:
        mated_composite(core, (25 * S, 0.0))
    assert err.value.parameter == "shift"


@pytest.mark.parametrize("shift", [(np.nan, 0.0), (1.0,), "west", (np.inf, 0.0)])
def test_malformed_shift_is_rejected(shift):
    with pytest.raises(InputError) as err:
        mated_composite(face(), shift)
    assert err.value.parameter == "shift"


def test_different_spacings_are_rejected():
    with pytest.raises(InputError) as err:
        composite_topography(face(), Topography(np.zeros((10, 10)), 2 * S))
    assert err.value.parameter == "upper"


def test_interpolation_marks_missing_neighbours_and_keeps_nodes_exact():
    values = np.arange(12.0).reshape(4, 3)
    values[2, 1] = np.nan
    out = interpolate_at_indices(values, [0.0, 1.0, 1.5, 3.0, 3.5], [0.0, 1.0, 2.0])
    assert out[0, 0] == 0.0 and out[1, 2] == values[1, 2] and out[3, 1] == values[3, 1]
    assert np.isnan(out[2, 1])  # needs (2, 1)
    assert out[2, 0] == pytest.approx(0.5 * (values[1, 0] + values[2, 0]))
    assert np.isnan(out[4]).all()  # beyond the grid


def test_resampling_non_square_pixels_reproduces_a_plane():
    """Pixels 1 x 2.5: the plane a x + b y is reproduced exactly on the square grid of spacing 1."""
    a, b = 0.3, -0.7
    nx, ny, sx, sy = 11, 7, 1.0, 2.5
    h = a * np.arange(nx)[:, None] * sx + b * np.arange(ny)[None, :] * sy
    out, s = resample_square(h, (sx, sy))
    assert s == 1.0 and out.shape == (11, 16)
    expected = a * np.arange(11)[:, None] * s + b * np.arange(16)[None, :] * s
    np.testing.assert_allclose(out, expected, rtol=0, atol=1e-12)
