"""The worn S1002 wheel (tools/worn_profile.py, docs/profiles.md "A worn S1002") and the
shipped profiled coaches: the files are what the tool writes, CSV and SIMPACK read the same,
the wear is where the construction puts it, and the equivalent conicity rises."""

from __future__ import annotations

import math
import sys

import numpy as np
import pytest
from conftest import MODELS, ROOT

from rail_mj.contact import geometry
from rail_mj.contact.conicity import equivalent_conicity
from rail_mj.contact.profiles import Profile, rail_60e1, read_profile, s1002_radius
from rail_mj.layout import load_layout

sys.path.insert(0, str(ROOT / "tools"))
import worn_profile

NEW = MODELS / "manchester-coach-s1002" / "manchester-coach-s1002.toml"
WORN = MODELS / "manchester-coach-worn" / "manchester-coach-worn.toml"
CSV = worn_profile.OUT / f"{worn_profile.NAME}.csv"
PRW = worn_profile.OUT / f"{worn_profile.NAME}.prw"
FILE_PRECISION = 0.5e-6 + 1e-12  # mm: the files' 6 decimals, rounded


@pytest.fixture(scope="module")
def tables():
    """The default contact tables (-10 to +10 mm) of the two shipped coaches: the same
    tables their layouts took their conicity from (one per process, `default_table`)."""
    return {name: geometry.contact_table(load_layout(path)) for name, path in (("new", NEW), ("worn", WORN))}


def test_the_files_are_what_the_tool_writes():
    # Regenerate with: python tools/worn_profile.py
    for path, data in worn_profile.files().items():
        assert path.read_bytes() == data, path.name


def test_csv_and_simpack_files_read_the_same():
    csv, prw = read_profile(CSV, "wheel"), read_profile(PRW)
    assert (csv.kind, prw.kind) == ("wheel", "wheel")
    assert len(csv.y) == len(prw.y) == len(worn_profile.points_mm()[0])
    # The same millimetres: the CSV reader multiplies by 1e-3, the SIMPACK one divides by its
    # units.len.f = 1000 (and negates SIMPACK's downward z), so they agree to the last bit.
    np.testing.assert_allclose(prw.y, csv.y, rtol=0, atol=1e-16)
    np.testing.assert_allclose(prw.z, csv.z, rtol=0, atol=1e-16)
    tool = worn_profile.profile()
    np.testing.assert_array_equal(tool.y, csv.y)
    np.testing.assert_array_equal(tool.z, csv.z)


def test_the_worn_wheel_is_s1002_outside_the_band_and_less_the_wear_inside():
    wheel = read_profile(CSV, "wheel")
    s, z = wheel.y * 1e3, wheel.z * 1e3
    new = -s1002_radius(s)
    band = np.abs(s - worn_profile.CENTRE) < worn_profile.HALF_WIDTH
    # Outside the band (the flange, its root, the outer face): S1002 to the file's precision.
    assert np.count_nonzero(~band & (s < 0)) > 300 and np.count_nonzero(~band & (s > 0)) > 50
    assert np.max(np.abs(z[~band] - new[~band])) <= FILE_PRECISION
    assert s[0] == -70.0 and s[-1] == 60.0
    assert np.min(z) == pytest.approx(-28.0, abs=FILE_PRECISION)  # the flange tip, unchanged
    # Inside it: metal only removed (z = -(r - r0) up), the Hann band of the construction.
    wear = z - new
    assert np.all(wear >= -FILE_PRECISION)
    np.testing.assert_allclose(wear, worn_profile.wear_depth(s), rtol=0, atol=FILE_PRECISION)
    assert np.max(wear) == pytest.approx(worn_profile.DEPTH, abs=1e-3)
    assert s[np.argmax(wear)] == pytest.approx(worn_profile.CENTRE, abs=worn_profile.STEP)
    # The band starts where S1002's flange root begins, inside the throat (-26 mm).
    assert worn_profile.CENTRE - worn_profile.HALF_WIDTH > -26.0
    # Smooth: the slope of the wear is continuous (no step between neighbouring pieces).
    slopes = np.diff(z[band]) / np.diff(s[band])
    assert np.max(np.abs(np.diff(slopes))) < 0.01


def test_the_file_sampling_is_not_what_changes_the_conicity(tables):
    """The worn file's points with no wear (S1002 sampled as the file is) give the new
    wheel's conicity within 0.002: the rise below is the wear's."""
    y, _ = worn_profile.points_mm()
    sampled = Profile("S1002 sampled", "wheel", y * 1e-3, -s1002_radius(y) * 1e-3)
    ys = np.round(np.arange(-120, 121) * 0.05e-3, 12)  # +/-6 mm: enough for 3 mm
    lam = geometry.equivalent_conicity(geometry.contact_table(geometry.Track(sampled, rail_60e1()), ys=ys))
    assert lam == pytest.approx(geometry.equivalent_conicity(tables["new"]), abs=0.002)


def test_contact_geometry_over_the_default_range(tables):
    for name, table in tables.items():
        np.testing.assert_array_equal(table.y, geometry.DEFAULT_YS)
        for column in ("r_left", "r_right", "delta_r", "roll", "contact_angle_left", "wheel_s_left"):
            assert np.all(np.isfinite(table.columns[column])), (name, column)
        # The symmetric pair gives an odd Δr.
        np.testing.assert_allclose(table.delta_r, -table.delta_r[::-1], rtol=0, atol=1e-12)
        assert np.all(np.diff(table.delta_r) >= -1e-12), name  # Δr never falls as y grows


def test_worn_wheels_raise_the_equivalent_conicity(tables):
    new, worn = (geometry.equivalent_conicity(tables[k], 3.0) for k in ("new", "worn"))
    assert 0.15 < new < 0.2  # S1002 on 60E1 at 1:40: 0.177 (docs/geometry.md)
    assert worn > 1.5 * new  # clearly higher ...
    assert 0.25 <= worn <= 0.6  # ... and within what is reported for worn pairs (0.3-0.5)
    # The layouts take these as their dynamics' conicity (wheelset.conicity omitted).
    assert load_layout(NEW).wheelset.conicity == new
    assert load_layout(WORN).wheelset.conicity == worn
    # Higher at 5 mm too; the amplitudes beyond flange contact are the flange's.
    lam = {k: equivalent_conicity(geometry.delta_r(t), [5.0])[0] for k, t in tables.items()}
    assert lam["worn"] > 1.5 * lam["new"]


def test_the_flange_is_met_where_it_was(tables):
    """The flange is unchanged: contact runs onto it (above 1 rad) within 0.25 mm of where
    it does on the new wheel (6.30 mm in the 0.05 mm table), at the same angle."""
    first = {}
    for name, table in tables.items():
        on = np.flatnonzero((table.y > 0) & (table.contact_angle_left > 1.0))
        first[name] = (table.y[on[0]] * 1e3, table.contact_angle_left[on[0]], table.wheel_s_left[on[0]] * 1e3)
    assert first["new"][0] == pytest.approx(6.30, abs=1e-9)
    assert abs(first["worn"][0] - first["new"][0]) <= 0.25
    assert math.degrees(first["worn"][1]) == pytest.approx(math.degrees(first["new"][1]), abs=3.0)
    assert first["worn"][2] < worn_profile.CENTRE - worn_profile.HALF_WIDTH  # on unworn metal
