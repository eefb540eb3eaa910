"""Contact geometry of a rigid wheelset (rail_mj/contact/geometry.py, docs/geometry.md), the
[profiles] layout table and `rail-mj contact-geometry`."""

from __future__ import annotations

import math

import numpy as np
import pytest
from conftest import MODELS, PROFILES_TOML
from scipy.optimize import brentq

from rail_mj.contact import geometry
from rail_mj.contact.geometry import Track, contact_table, gaps
from rail_mj.contact.profiles import Profile, rail_60e1, s1002
from rail_mj.layout import LayoutError, load_layout

LAMBDA, R0 = 0.05, 0.46


def cone_wheel(lam=LAMBDA):
    """A straight tread of conicity lam across 120 mm: z = -(r - r0) = lam * s."""
    s = np.array([-0.06, 0.06])
    return Profile("cone", "wheel", s, lam * s)


def knife_rail():
    """A knife edge: the apex at (0, 0), 45-degree sides down to 20 mm below it."""
    return Profile("knife", "rail", np.array([-0.02, 0.0, 0.02]), np.array([-0.02, 0.0, -0.02]))


def exact_cone_on_knives(y, track, apex):
    """Roll and both rolling radii of the cone wheelset on knife edges at +/-apex, from the
    straight lines themselves: an independent closed form (brentq on the roll)."""
    d, r0, lam = track.taping_half_spacing, track.r0, LAMBDA

    def wheel_on(k, phi):
        """(Y, r): where side k's section passes over its knife. In the axle frame a point
        (Y, -r) with r = r0 + lam d - lam k Y lands at y + Y cos(phi) + r sin(phi): linear in Y."""
        big_y = (k * apex - y - (r0 + lam * d) * math.sin(phi)) / (math.cos(phi) - lam * k * math.sin(phi))
        return big_y, r0 + lam * d - lam * k * big_y

    def height(k, phi):  # the wheel's z over the knife, axle centre at 0
        big_y, r = wheel_on(k, phi)
        return big_y * math.sin(phi) - r * math.cos(phi)

    phi = brentq(lambda p: height(1, p) - height(-1, p), -0.1, 0.1, xtol=1e-16)
    return phi, wheel_on(1, phi)[1], wheel_on(-1, phi)[1]


def test_cone_on_knife_edges_gives_the_closed_form():
    track = Track(cone_wheel(), knife_rail(), rail_inclination=0.0, r0=R0)
    ys = np.linspace(-0.008, 0.008, 17)
    t = contact_table(track, ys=ys)
    for i, y in enumerate(ys):
        # the apex 14 mm outside the gauge point: the side is at 45 degrees
        phi, r_left, r_right = exact_cone_on_knives(y, track, track.track_gauge / 2 + 0.014)
        # The apex is sharp and exact (a polyline), so only rounding separates them: 1e-10.
        assert t.roll[i] == pytest.approx(phi, abs=1e-10)
        assert t.r_left[i] == pytest.approx(r_left, abs=1e-10)
        assert t.r_right[i] == pytest.approx(r_right, abs=1e-10)
        # The contact angle is atan(lam) on the wheelset, +/- its roll in the track frame: 1e-12.
        assert t.contact_angle_left[i] - t.roll[i] == pytest.approx(math.atan(LAMBDA), abs=1e-12)
        assert t.contact_angle_right[i] + t.roll[i] == pytest.approx(math.atan(LAMBDA), abs=1e-12)
    # Delta r = 2 lam y, the textbook cone, up to the roll: rolling about the axle moves both
    # wheels' lowest points r0*phi sideways, so Delta r = 2 lam (y + r0 phi) to first order in
    # the roll (1e-4 relative: the exact lines add lam*d*phi and cosines), which is
    # 2 lam y * b / (b - lam r0), 3.2 % more here (lam r0 / b = 0.031): within 3.5 %.
    np.testing.assert_allclose(t.delta_r, 2 * LAMBDA * (ys + R0 * t.roll), rtol=1e-4, atol=1e-12)
    nonzero = ys != 0
    ratio = t.delta_r[nonzero] / (2 * LAMBDA * ys[nonzero])
    assert np.all((ratio > 1.0) & (ratio < 1.035))


def test_cone_on_canted_knife_edges():
    """Canted 1:40, the knife's inner side leans 45 + 1.4 degrees: the gauge point 14 mm
    below the apex moves, and with it the apex; the closed form at the apex's new place."""
    track = Track(cone_wheel(), knife_rail(), rail_inclination=1 / 40, r0=R0)
    t = contact_table(track, ys=[-0.004, 0.003])
    delta = math.atan(1 / 40)
    # The inner side, u = -w .. 0 at z = u, canted: the point 14 mm below the (unmoved) apex.
    # q(u) = cos(delta) u - sin(delta) u, z(u) = sin(delta) u + cos(delta) u = -0.014
    u = -0.014 / (math.sin(delta) + math.cos(delta))
    apex = track.track_gauge / 2 - (math.cos(delta) - math.sin(delta)) * u
    for i, y in enumerate([-0.004, 0.003]):
        phi, r_left, r_right = exact_cone_on_knives(y, track, apex)
        assert t.roll[i] == pytest.approx(phi, abs=1e-10)
        assert t.r_left[i] == pytest.approx(r_left, abs=1e-10)
        assert t.r_right[i] == pytest.approx(r_right, abs=1e-10)
    np.testing.assert_allclose(t.contact_angle_left - t.roll, math.atan(LAMBDA), atol=1e-12)


def test_symmetric_pair_is_odd(standard):
    t = standard
    assert t.y[200] == 0.0
    np.testing.assert_allclose(t.delta_r, -t.delta_r[::-1], atol=1e-9)
    np.testing.assert_allclose(t.contact_angle_left, t.contact_angle_right[::-1], atol=1e-9)
    np.testing.assert_allclose(t.roll, -t.roll[::-1], atol=1e-9)
    np.testing.assert_allclose(t.contact_y_left, -t.contact_y_right[::-1], atol=1e-9)


def test_centred_wheelset(standard):
    t, i = standard, 200
    wheel = s1002()
    assert t.roll[i] == pytest.approx(0.0, abs=1e-12)
    for side in ("left", "right"):
        s = getattr(t, f"wheel_s_{side}")[i]
        # r = r0 + F at the contact, F = -z of the wheel profile: 1e-12 m
        assert getattr(t, f"r_{side}")[i] == pytest.approx(R0 - float(wheel.height(s)), abs=1e-12)
    assert t.r_left[i] == pytest.approx(t.r_right[i], abs=1e-12)


def test_no_penetration_anywhere(standard):
    t = standard
    s = np.linspace(-0.055, 0.06, 100_001)  # 1.15 um apart, 90 times the solver's coarse search
    for i in range(0, len(t.y), 8):
        for side in ("left", "right"):
            g = gaps(t, i, side, s)
            assert np.nanmin(g) > -1e-9, (t.y[i], side)  # nowhere into the rail
            assert np.nanmin(g) < 1e-9, (t.y[i], side)  # and touching it


def test_flange_contact_and_the_jump(standard):
    t = standard
    flange = np.flatnonzero(t.contact_angle_left > 1.0)
    assert len(flange) and t.y[flange[0]] < 0.010
    k = flange[0]
    # on the flange: about 70 degrees (S1002's flank is 70.0 degrees)
    assert 1.1 < t.contact_angle_left[k] < 1.3
    # Delta r jumps there: more than 5 mm of rolling radius within one 0.05 mm step
    assert t.delta_r[k] - t.delta_r[k - 1] > 0.005
    # At the step itself tread and flange touch together: bisect y to 1 nm between the
    # rows and the last tread row there shows a second contact (gap2 within 1e-5 m).
    track = t.track
    lo, hi = t.y[k - 1], t.y[k]
    while hi - lo > 1e-9:
        mid = 0.5 * (lo + hi)
        on_flange = contact_table(track, ys=[mid]).contact_angle_left[0] > 1.0
        lo, hi = (lo, mid) if on_flange else (mid, hi)
    row = contact_table(track, ys=[lo])
    assert row.two_point_left[0] == 1.0
    # S1002's 13 mm throat arc meets 60E1's 13 mm gauge corner: the points are a few mm
    # apart across the wheel, their contact angles more than 0.1 rad apart.
    assert abs(row.contact_angle2_left[0] - row.contact_angle_left[0]) > 0.1
    assert abs(row.contact_y2_left[0] - row.contact_y_left[0]) > 1e-3
    assert 0 <= row.gap2_left[0] <= geometry.TWO_POINT_GAP
    assert row.two_point_right[0] == 0.0


def test_csv_has_the_contract_columns_first(standard):
    text = standard.to_csv().decode()
    header = text.splitlines()[0].split(",")
    assert header[:7] == [
        "y_m",
        "r_left_m",
        "r_right_m",
        "delta_r_m",
        "contact_angle_left_rad",
        "contact_angle_right_rad",
        "roll_rad",
    ]
    assert "z_m" in header and "two_point_left" in header
    rows = np.loadtxt(text.splitlines()[1:], delimiter=",")
    assert rows.shape == (401, len(header))
    np.testing.assert_allclose(rows[:, 3], rows[:, 1] - rows[:, 2], atol=1e-11)


def test_delta_r_feeds_the_conicity(standard):
    d = geometry.delta_r(standard)
    assert d.centre[0] == pytest.approx(0.0, abs=1e-12) and d.centre[0] == d.centre[1]
    value = geometry.equivalent_conicity(standard, 3.0)
    assert 0.05 < value < 0.5  # a plausible new-profile value; the number is printed in the docs


# --- [profiles] in a layout ------------------------------------------------------------

PROFILED = (MODELS / "wheelset" / "wheelset.toml").read_text().replace("conicity = 0.1\n", "") + PROFILES_TOML


def write(tmp_path, text, name="profiled.toml"):
    path = tmp_path / name
    path.write_text(text)
    return path


def test_profiled_layout_loads_with_the_profiles_conicity(tmp_path, standard):
    from rail_mj.layout import Profiles, load_layout

    layout = load_layout(write(tmp_path, PROFILED))
    assert layout.profiles == Profiles("s1002", "60e1", 0.025, 1.435, 1.36)
    # wheelset.conicity omitted: the equivalent conicity at 3 mm of the same table (1e-12)
    assert layout.wheelset.conicity == pytest.approx(geometry.equivalent_conicity(standard, 3.0), abs=1e-12)
    # given: kept
    given = load_layout(
        write(
            tmp_path,
            PROFILED.replace("contact_half_spacing = 0.75\n", "contact_half_spacing = 0.75\nconicity = 0.2\n"),
            "g.toml",
        )
    )
    assert given.wheelset.conicity == 0.2 and given.profiles == layout.profiles


def test_profile_files_are_relative_to_the_layout(tmp_path):
    from rail_mj.contact.profiles import write_csv
    from rail_mj.layout import load_layout

    (tmp_path / "p").mkdir()
    (tmp_path / "p" / "wheel.csv").write_bytes(write_csv(s1002()))
    (tmp_path / "p" / "rail.csv").write_bytes(write_csv(rail_60e1()))
    text = PROFILED.replace('wheel = "s1002"', 'wheel = "p/wheel.csv"').replace('rail = "60e1"', 'rail = "p/rail.csv"')
    layout = load_layout(
        write(tmp_path, text.replace("contact_half_spacing = 0.75\n", "contact_half_spacing = 0.75\nconicity = 0.2\n"))
    )
    assert layout.profiles.wheel == str(tmp_path / "p" / "wheel.csv")
    t = contact_table(layout, ys=[-0.002, 0.0, 0.002])
    # The sampled profiles (1001 and 801 points, straight between them) against the exact
    # ones: within 10 um of radius (4 um found: the contact at +2 mm sits where S1002's
    # concave tread nearly fits the rail, and moves with the small chords).
    exact = contact_table(Track(s1002(), rail_60e1()), ys=[-0.002, 0.0, 0.002])
    np.testing.assert_allclose(t.r_left, exact.r_left, atol=1e-5)


@pytest.mark.parametrize(
    "change, key",
    [
        (("rail_inclination = 0.025", "rail_inclination = 0.2"), "profiles.rail_inclination"),
        (("rail_inclination = 0.025", "rail_inclination = -0.01"), "profiles.rail_inclination"),
        (("track_gauge = 1.435", "track_gauge = 1435"), "profiles.track_gauge"),
        (("flange_back_spacing = 1.360", "flange_back_spacing = 1.5"), "profiles.flange_back_spacing"),
        (("flange_back_spacing = 1.360", 'flange_back_spacing = "1.36"'), "profiles.flange_back_spacing"),
        (('wheel = "s1002"', 'wheel = "60e1"'), "profiles.wheel"),
        (('wheel = "s1002"', 'wheel = "s1003"'), "profiles.wheel"),
        (('wheel = "s1002"', 'wheel = "missing.csv"'), "profiles.wheel"),
        (('rail = "60e1"', 'rail = "bad.csv"'), "profiles.rail"),
        (('rail = "60e1"', "rail = 60"), "profiles.rail"),
        (('rail = "60e1"', 'rail = "60e1"\nrail_cant = 0.025'), "profiles.rail_cant"),
        (('wheel = "s1002"\n', ""), "profiles.wheel"),
    ],
)
def test_bad_profiles_keys_are_refused_in_one_line(tmp_path, capsys, change, key):
    from rail_mj.cli import main

    (tmp_path / "bad.csv").write_text("y_mm,z_mm\n0,0\n1\n")
    path = write(tmp_path, PROFILED.replace(*change))
    assert change[0] in PROFILED
    status = main(["conicity", str(path)])
    err = capsys.readouterr().err
    assert status == 2, err
    assert len(err.strip().splitlines()) == 1 and key in err and str(path) in err


def test_layout_without_profiles_still_needs_its_conicity(tmp_path):
    from rail_mj.layout import LayoutError, load_layout

    text = (MODELS / "wheelset" / "wheelset.toml").read_text().replace("conicity = 0.1\n", "")
    with pytest.raises(LayoutError, match=r"wheelset\.conicity: missing"):
        load_layout(write(tmp_path, text))


# --- the command ------------------------------------------------------------------------


def test_cli_contact_geometry_writes_the_table_and_the_picture(tmp_path, capsys, standard):
    from rail_mj.cli import main

    layout = write(tmp_path, PROFILED)
    csv, png = tmp_path / "out" / "cg.csv", tmp_path / "out" / "cg.png"
    status = main(["contact-geometry", str(layout), "-o", str(csv), "--png", str(png)])
    out, err = capsys.readouterr()
    assert status == 0, err
    assert "flange contact from |y| = 6.30 mm" in out
    lines = csv.read_text().splitlines()
    assert lines[0].startswith(
        "y_m,r_left_m,r_right_m,delta_r_m,contact_angle_left_rad,contact_angle_right_rad,roll_rad,"
    )
    rows = np.loadtxt(lines[1:], delimiter=",")
    np.testing.assert_allclose(rows[:, 3], standard.delta_r, atol=1e-11)  # the same table
    assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


def test_cli_contact_geometry_needs_profiles(tmp_path, capsys):
    from rail_mj.cli import main

    csv = tmp_path / "cg.csv"
    status = main(["contact-geometry", str(MODELS / "wheelset" / "wheelset.toml"), "-o", str(csv)])
    err = capsys.readouterr().err
    assert status == 2 and len(err.strip().splitlines()) == 1 and "[profiles]" in err
    assert not csv.exists()


def test_cli_conicity_of_profiles_and_of_a_cone(tmp_path, capsys, standard):
    import json

    from rail_mj.cli import main

    assert main(["conicity", str(write(tmp_path, PROFILED)), "--amplitudes", "3:3:1", "--json"]) == 0
    value = json.loads(capsys.readouterr().out)["equivalent_conicity"][0]
    assert value == pytest.approx(geometry.equivalent_conicity(standard, 3.0), abs=1e-9)
    # a coned layout without [profiles] still gives its cone's conicity (1e-9)
    assert main(["conicity", str(MODELS / "wheelset" / "wheelset.toml"), "--amplitudes", "3:3:1", "--json"]) == 0
    assert json.loads(capsys.readouterr().out)["equivalent_conicity"][0] == pytest.approx(0.1, abs=1e-9)


def test_cli_contact_geometry_refuses_to_overwrite_its_layout(tmp_path, capsys):
    from rail_mj.cli import main

    layout = write(tmp_path, PROFILED)
    before = layout.read_bytes()
    status = main(["contact-geometry", str(layout), "-o", str(tmp_path / "t.csv"), "--png", str(layout)])
    err = capsys.readouterr().err
    assert status == 2 and len(err.strip().splitlines()) == 1 and "overwrite" in err
    assert layout.read_bytes() == before and not (tmp_path / "t.csv").exists()


@pytest.mark.parametrize("spacing, where", [(1.434, "-53"), (1.24, "52")])
def test_a_wheelset_not_standing_on_its_treads_is_refused(spacing, where, tmp_path):
    """Flange backs almost at the gauge put the flange tips on the rails; far apart, the
    wheels' outer edges: neither is a wheel standing on a rail, and neither may feed the
    dynamics an equivalent conicity."""
    text = (MODELS / "manchester-coach" / "manchester-coach.toml").read_text()
    text = text.replace("conicity = 0.15", "").rstrip() + (
        f'\n\n[profiles]\nwheel = "s1002"\nrail = "60e1"\nflange_back_spacing = {spacing}\n'
    )
    path = tmp_path / "placed.toml"
    path.write_text(text)
    with pytest.raises(LayoutError, match=f"{where}.* mm from its taping line, off its tread"):
        load_layout(path)
