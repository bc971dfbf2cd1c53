"""Readers: native .npy / text / NetCDF, and the real instrument files through SurfaceTopography.

Known truths: a file written here with known values, spacing and units must come back in SI
exactly (one multiplication by the unit factor); the measured files' grids, physical sizes,
units and rms slopes are listed in the data README (read independently when the files were
added); a truncated copy of a file must be refused, not half-read.

The measured files are looked up in ``$ROUGHCONTACT_DATA`` (the folder holding them, or a folder
with a ``topographies`` subfolder), else ``<repository>/../shared/data/topographies``.
"""
from __future__ import annotations

import os
import sys
from pathlib import Path

import numpy as np
import pytest

from roughcontact.errors import InputError
from roughcontact.surfaces import Topography, disc, read_topography, rms_slope, write_topography


def data_dir() -> Path:
    env = os.environ.get("ROUGHCONTACT_DATA")
    if env:
        base = Path(env)
        return base / "topographies" if (base / "topographies").is_dir() else base
    return Path(__file__).resolve().parents[1].parent / "shared" / "data" / "topographies"


def measured(name: str) -> Path:
    pytest.importorskip("SurfaceTopography", reason="measured files are read through the 'topography' extra")
    path = data_dir() / name
    if not path.is_file():
        pytest.skip(f"measured file {name} not found in {data_dir()} (set ROUGHCONTACT_DATA)")
    return path


# --------------------------------------------------------------------------- native formats


def test_npy_round_trip_in_si(tmp_path):
    heights_um = np.random.default_rng(0).normal(size=(12, 9))
    np.save(tmp_path / "h.npy", heights_um)
    t = read_topography(tmp_path / "h.npy", spacing=0.5, unit="um")
    assert np.array_equal(t.heights, heights_um * 1e-6)
    assert t.spacing == pytest.approx(0.5e-6, rel=1e-15)
    assert t.metadata["units"] == {"length": "um", "height": "um"}
    assert t.metadata["source"] == "h.npy" and len(t.metadata["sha256"]) == 64
    t = read_topography(tmp_path / "h.npy", spacing=2.0, unit="mm", height_unit="nm")
    assert np.array_equal(t.heights, heights_um * 1e-9) and t.spacing == pytest.approx(2e-3)


def test_text_matrix_and_csv_round_trip(tmp_path):
    h = np.random.default_rng(1).normal(size=(6, 5))
    np.savetxt(tmp_path / "h.txt", h, header="heights in mm, rows are x")
    t = read_topography(tmp_path / "h.txt", spacing=0.01, unit="mm")
    assert np.array_equal(t.heights, h * 1e-3) and t.spacing == pytest.approx(1e-5)
    np.savetxt(tmp_path / "h.csv", h, delimiter=",")
    assert np.array_equal(read_topography(tmp_path / "h.csv", spacing=0.01, unit="mm").heights, h * 1e-3)


def test_xyz_columns_with_a_missing_node(tmp_path):
    """x-y-z rows in any order; an absent node is missing data, rejected or masked on request."""
    nx, ny, s = 5, 4, 2.0
    x, y = np.meshgrid(np.arange(nx) * s + 100.0, np.arange(ny) * s - 3.0, indexing="ij")
    z = 0.1 * x + 0.2 * y
    rows = np.column_stack([x.ravel(), y.ravel(), z.ravel()])
    rows = np.delete(rows, 7, axis=0)[::-1]  # node (1, 3) absent; reversed order
    np.savetxt(tmp_path / "h.xyz", rows)
    with pytest.raises(InputError) as err:
        read_topography(tmp_path / "h.xyz", unit="um")
    assert err.value.parameter == "missing" and "missing='mask'" in str(err.value)
    t = read_topography(tmp_path / "h.xyz", unit="um", missing="mask")
    assert t.shape == (5, 4) and t.spacing == pytest.approx(2e-6)
    assert not t.footprint[1, 3] and t.footprint.sum() == 19
    expected = (0.1 * x + 0.2 * y) * 1e-6
    np.testing.assert_allclose(t.heights[t.footprint], expected[t.footprint], rtol=1e-15)
    assert t.metadata["missing_points"] == 1


def test_xyz_off_grid_or_duplicated_is_rejected(tmp_path):
    np.savetxt(tmp_path / "a.xyz", [[0, 0, 1], [1, 0, 1], [2.5, 0, 1], [0, 1, 1]])
    with pytest.raises(InputError, match="uniform grid") as err:
        read_topography(tmp_path / "a.xyz", unit="m")
    assert err.value.parameter == "path"
    np.savetxt(tmp_path / "b.xyz", [[0, 0, 1], [1, 0, 1], [0, 0, 2], [1, 1, 1]])
    with pytest.raises(InputError, match="twice"):
        read_topography(tmp_path / "b.xyz", unit="m")


def test_netcdf_round_trip_keeps_heights_spacing_footprint(tmp_path):
    h = np.random.default_rng(2).normal(size=(20, 20)) * 1e-6
    footprint = disc((20, 20), 1e-4, 1.5e-3)
    h[~footprint] = np.nan
    original = Topography(h, 1e-4, footprint, {"specimen": "sandstone", "shift": (1e-3, 0.0)})
    write_topography(original, tmp_path / "t.nc")
    t = read_topography(tmp_path / "t.nc")
    assert t.spacing == original.spacing
    assert np.array_equal(t.footprint, footprint)
    assert np.array_equal(t.heights[footprint], h[footprint])
    assert t.metadata["stored_metadata"]["specimen"] == "sandstone"
    assert t.metadata["missing_points"] == 0


def test_netcdf_written_by_surfacetopography(tmp_path):
    st = pytest.importorskip("SurfaceTopography")
    h = np.random.default_rng(3).normal(size=(8, 6))
    st.Topography(h, (8 * 0.25, 6 * 0.25), unit="um").to_netcdf(str(tmp_path / "st.nc"))
    t = read_topography(tmp_path / "st.nc")
    np.testing.assert_allclose(t.heights, h * 1e-6, rtol=1e-15)
    assert t.spacing == pytest.approx(0.25e-6, rel=1e-12)


def test_netcdf_with_non_uniform_coordinates_is_refused(tmp_path):
    import xarray as xr

    ds = xr.Dataset({"heights": (("x", "y"), np.zeros((4, 3)), {"units": "m"})},
                    coords={"x": ("x", [0.0, 1.0, 2.0, 4.0], {"units": "m"}),
                            "y": ("y", [0.0, 1.0, 2.0], {"units": "m"})})
    ds.to_netcdf(tmp_path / "uneven.nc", engine="h5netcdf")
    with pytest.raises(InputError, match="not uniform") as err:
        read_topography(tmp_path / "uneven.nc")
    assert err.value.parameter == "path"


def test_resampling_carries_a_stored_footprint(tmp_path):
    """A disc footprint on 1 x 0.7 pixels, resampled onto 0.7: the nominal area is kept within the
    perimeter band (one coarse pixel, 1.0, times the ellipse's perimeter), and no point counts as missing."""
    import xarray as xr

    sx, sy, n = 1.0, 0.7, 30
    x, y = np.arange(n) * sx, np.arange(n) * sy
    footprint = ((x[:, None] - 14.5) / 10) ** 2 + ((y[None, :] - 10.15) / 7) ** 2 <= 1  # 20 x 14 m ellipse
    ds = xr.Dataset({"heights": (("x", "y"), np.random.default_rng(5).random((n, n)), {"units": "m"}),
                     "footprint": (("x", "y"), footprint.astype(np.int8))},
                    coords={"x": ("x", x, {"units": "m"}), "y": ("y", y, {"units": "m"})})
    ds.to_netcdf(tmp_path / "ellipse.nc", engine="h5netcdf")
    t = read_topography(tmp_path / "ellipse.nc", resample=True)
    assert t.spacing == pytest.approx(0.7) and t.metadata["missing_points"] == 0
    ellipse_area, perimeter = np.pi * 10 * 7, 2 * np.pi * np.sqrt((10**2 + 7**2) / 2)
    assert t.nominal_area == pytest.approx(ellipse_area, abs=perimeter * sx)


def test_three_column_matrix_can_be_forced(tmp_path):
    """A 5 x 3 height matrix would look like x-y-z rows; layout='matrix' reads it as heights."""
    h = np.arange(15.0).reshape(5, 3)
    np.savetxt(tmp_path / "thin.txt", h)
    t = read_topography(tmp_path / "thin.txt", spacing=1.0, unit="m", layout="matrix")
    assert np.array_equal(t.heights, h)
    with pytest.raises(InputError) as err:  # read as x-y-z: 5 points on a 5 x 5 grid, 20 missing
        read_topography(tmp_path / "thin.txt", unit="m")
    assert err.value.parameter == "missing"


def test_nan_heights_rejected_or_masked(tmp_path):
    h = np.ones((6, 6))
    h[2, 3] = np.nan
    np.save(tmp_path / "h.npy", h)
    with pytest.raises(InputError) as err:
        read_topography(tmp_path / "h.npy", spacing=1.0, unit="m")
    assert err.value.parameter == "missing"
    t = read_topography(tmp_path / "h.npy", spacing=1.0, unit="m", missing="mask")
    assert t.footprint.sum() == 35 and not t.footprint[2, 3]
    np.save(tmp_path / "all_nan.npy", np.full((3, 3), np.nan))
    with pytest.raises(InputError) as err:
        read_topography(tmp_path / "all_nan.npy", spacing=1.0, unit="m", missing="mask")
    assert err.value.parameter == "path"


def test_non_square_pixels_need_resample(tmp_path):
    a, b = 0.02, 0.05
    sx, sy = 1.0, 2.0
    h = a * np.arange(9)[:, None] * sx + b * np.arange(5)[None, :] * sy
    np.save(tmp_path / "h.npy", h)
    with pytest.raises(InputError) as err:
        read_topography(tmp_path / "h.npy", spacing=(sx, sy), unit="mm")
    assert err.value.parameter == "resample" and "resample=True" in str(err.value)
    t = read_topography(tmp_path / "h.npy", spacing=(sx, sy), unit="mm", resample=True)
    assert t.spacing == pytest.approx(1e-3) and t.shape == (9, 9)
    expected = (a * np.arange(9)[:, None] + b * np.arange(9)[None, :]) * 1e-3
    np.testing.assert_allclose(t.heights, expected, rtol=0, atol=1e-15)
    t = read_topography(tmp_path / "h.npy", spacing=(sx, sy), unit="mm", resample=0.5e-3)
    assert t.spacing == 0.5e-3 and t.shape == (17, 17)


def test_detrend_on_read(tmp_path):
    h = 5.0 + 0.01 * np.arange(10)[:, None] + np.random.default_rng(4).normal(size=(10, 10)) * 1e-3
    np.save(tmp_path / "h.npy", h)
    t = read_topography(tmp_path / "h.npy", spacing=1.0, unit="m", detrend="mean")
    assert abs(t.heights.mean()) < 1e-14
    t = read_topography(tmp_path / "h.npy", spacing=1.0, unit="m", detrend="plane")
    assert t.metadata["detrend"]["slope_x"] == pytest.approx(0.01, abs=1e-3)


def test_unreadable_and_truncated_native_files(tmp_path):
    np.save(tmp_path / "ok.npy", np.zeros((50, 50)))
    data = (tmp_path / "ok.npy").read_bytes()
    (tmp_path / "cut.npy").write_bytes(data[: len(data) // 2])
    (tmp_path / "junk.txt").write_text("height map\n1 2 three\n")
    (tmp_path / "empty.txt").write_text("# nothing\n")
    write_topography(Topography(np.zeros((30, 30)), 1.0), tmp_path / "ok.nc")
    nc = (tmp_path / "ok.nc").read_bytes()
    (tmp_path / "cut.nc").write_bytes(nc[: len(nc) // 3])
    np.save(tmp_path / "line.npy", np.zeros(10))
    for name in ("cut.npy", "junk.txt", "empty.txt", "cut.nc", "line.npy", "absent.npy"):
        with pytest.raises(InputError) as err:
            read_topography(tmp_path / name, spacing=1.0, unit="m")
        assert err.value.parameter == "path", name


@pytest.mark.parametrize("kwargs, parameter", [
    (dict(), "spacing"),
    (dict(spacing=1.0), "unit"),
    (dict(spacing=1.0, unit="furlong"), "unit"),
    (dict(spacing=0.0, unit="m"), "spacing"),
    (dict(spacing=-2.0, unit="m"), "spacing"),
    (dict(spacing=(1.0, 0.0), unit="m"), "spacing"),
    (dict(spacing=1.0, unit="m", missing="fill"), "missing"),
    (dict(spacing=1.0, unit="m", detrend="quadratic"), "detrend"),
    (dict(spacing=1.0, unit="m", format="tiff"), "format"),
    (dict(spacing=1.0, unit="m", channel=2), "channel"),
    (dict(spacing=1.0, unit="m", resample=-1.0), "resample"),
])
def test_bad_reader_arguments_name_the_parameter(tmp_path, kwargs, parameter):
    np.save(tmp_path / "h.npy", np.zeros((4, 4)))
    with pytest.raises(InputError) as err:
        read_topography(tmp_path / "h.npy", **kwargs)
    assert err.value.parameter == parameter


def test_missing_optional_dependency_says_how_to_install(tmp_path, monkeypatch):
    (tmp_path / "scan.opd").write_bytes(b"\0" * 64)
    monkeypatch.setitem(sys.modules, "SurfaceTopography", None)  # import now raises ImportError
    with pytest.raises(ImportError, match=r"roughcontact\[topography\]"):
        read_topography(tmp_path / "scan.opd")


# --------------------------------------------------------------------------- measured files

# From the data README: grid, physical size (m) to the digits listed, file unit, rms slope (~).
MEASURED = {
    "opd-1.opd": dict(grid=(640, 480), size=(0.1259e-3, 0.0944e-3), unit="mm", slope=0.018),
    "sur-2.sur": dict(grid=(563, 484), size=(1.961e-3, 1.686e-3), unit="mm", slope=0.003),
}


@pytest.mark.parametrize("name", list(MEASURED))
def test_measured_square_pixel_files_match_their_readme(name):
    expected = MEASURED[name]
    path = measured(name)
    with pytest.raises(InputError) as err:  # both scans have dropped-out pixels
        read_topography(path)
    assert err.value.parameter == "missing"
    t = read_topography(path, missing="mask", detrend="plane")
    assert t.shape == expected["grid"]
    # README sizes carry 4 significant digits: 1e-3 relative
    np.testing.assert_allclose(np.array(t.shape) * t.spacing, expected["size"], rtol=1e-3)
    assert t.metadata["units"]["length"] == expected["unit"]
    assert 0 < t.metadata["missing_points"] < 0.01 * t.heights.size
    assert not t.footprint.all() and np.isfinite(t.heights[t.footprint]).all()
    # README gives the slope to one significant digit ("~"): 15 % band
    assert rms_slope(t) == pytest.approx(expected["slope"], rel=0.15)
    assert t.metadata["reader"].startswith("SurfaceTopography")


def test_sur_heights_are_converted_from_mm_to_metres():
    """README: the SUR heights carry an offset of about 9 um; read raw, the mean is 8-11 um in metres."""
    t = read_topography(measured("sur-2.sur"), missing="mask")
    assert 8e-6 < t.heights[t.footprint].mean() < 11e-6


def test_measured_x3p_has_non_square_pixels_and_resamples():
    path = measured("x3p-2.x3p")
    with pytest.raises(InputError) as err:
        read_topography(path)
    assert err.value.parameter == "resample" and "resample=True" in str(err.value)
    t = read_topography(path, resample=True)
    sx, sy = t.metadata["pixel_size"]
    # README: 650 x 650 pixels of 0.128 x 0.315 um, 83.0 x 204.5 um
    assert (sx, sy) == pytest.approx((0.128e-6, 0.315e-6), rel=3e-3)
    assert t.spacing == sx
    assert t.shape[0] == 650
    # the 650 nodes along y span 649 pixels; the resampled nodes stay inside and miss less than a spacing
    span = 204.5e-6 * 649 / 650
    assert (t.shape[1] - 1) * t.spacing <= span * (1 + 3e-3) and t.shape[1] * t.spacing > span * (1 - 3e-3)
    assert t.metadata["units"]["length"] == "m" and "instrument" in t.metadata


@pytest.mark.parametrize("name", ["opd-1.opd", "sur-2.sur", "x3p-2.x3p"])
@pytest.mark.parametrize("fraction", [0.5, 0.999])
def test_truncated_measured_files_are_refused(tmp_path, name, fraction):
    data = measured(name).read_bytes()
    cut = tmp_path / name
    cut.write_bytes(data[: int(len(data) * fraction)])
    with pytest.raises(InputError) as err:
        read_topography(cut, missing="mask", resample=True)
    assert err.value.parameter == "path"
    assert len(str(err.value)) < 500  # a sentence, not a binary dump
