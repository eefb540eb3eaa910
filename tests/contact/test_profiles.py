"""Wheel and rail profiles: the published S1002 and 60E1 definitions, CSV and SIMPACK
files (every header flag), bad files refused on one line, and `rail-mj profile`."""

from __future__ import annotations

import math
import re
from pathlib import Path

import numpy as np
import pytest
from conftest import DATA

from rail_mj.cli import main
from rail_mj.contact.profiles import (
    S1002_SECTIONS,
    Profile,
    ProfileError,
    rail_60e1,
    rail_60e1_head,
    read_profile,
    s1002,
    s1002_radius,
    s1002_radius_slope,
    write_csv,
)

ROUNDED = 1e-3  # mm: the published check values have three decimals


# --- S1002 ---------------------------------------------------------------------------


@pytest.mark.parametrize("s, f", [(0.0, 0.0), (60.0, -2.636), (-55.0, 28.0), (-70.0, 9.519), (-35.0, 6.867)])
def test_s1002_published_values(s, f):
    assert s1002_radius(s) == pytest.approx(f, abs=ROUNDED)


def test_s1002_outer_cone_is_1_in_15_and_the_flange_tip_is_its_highest_point():
    assert s1002_radius_slope(45.0) == pytest.approx(-1 / 15, abs=1e-8)
    s = np.linspace(-70.0, 60.0, 130_001)
    assert s[np.argmax(s1002_radius(s))] == pytest.approx(-55.0, abs=1e-3)
    assert s1002_radius_slope(-55.0) == pytest.approx(0.0, abs=1e-12)


def test_s1002_slope_at_the_taping_line():
    assert s1002_radius_slope(0.0) == pytest.approx(-0.0336, abs=1e-4)
    h = 1e-5  # the derivative agrees with the function itself
    assert (s1002_radius(h) - s1002_radius(-h)) / (2 * h) == pytest.approx(s1002_radius_slope(0.0), abs=1e-8)


def test_s1002_sections_meet_continuously_and_tangentially():
    # Section C's published ten-digit coefficients meet B and D to 0.12 µm; every other
    # junction (lines and arcs) to well under a nanometre.
    for (name_a, _, end, f_a, df_a), (name_b, start, _, f_b, df_b) in zip(S1002_SECTIONS, S1002_SECTIONS[1:]):
        assert end == start
        at = np.array([end])
        tolerance = 2e-4 if "C" in (name_a, name_b) else 1e-6
        assert abs(f_a(at)[0] - f_b(at)[0]) < tolerance, (name_a, name_b)
        assert abs(df_a(at)[0] - df_b(at)[0]) < 1e-3, (name_a, name_b)
    assert abs(S1002_SECTIONS[2][3](np.array([-35.0]))[0] - 6.867) < ROUNDED  # F(-35) from C
    assert abs(S1002_SECTIONS[3][3](np.array([-35.0]))[0] - 6.867) < ROUNDED  # and from D


def test_s1002_profile_is_in_the_documented_convention():
    wheel = s1002()
    assert wheel.kind == "wheel" and wheel.y[0] == -0.070 and wheel.y[-1] == 0.060
    assert np.all(np.diff(wheel.y) > 0)
    # z = -F: the flange hangs down to -28 mm, the outer cone rises to +2.636 mm.
    assert wheel.height(-0.055) == pytest.approx(-0.028, abs=1e-6)
    assert wheel.height(0.060) == pytest.approx(0.002636, abs=1e-6)
    assert np.max(np.abs(wheel.height(wheel.y) - wheel.z)) < 1e-12
    assert wheel.slope(0.0) == pytest.approx(0.0336, abs=1e-4)
    assert np.isnan(wheel.height(0.061)) and np.isnan(wheel.height(-0.0701))
    # The points are spread along the profile: no gap wider than its share.
    steps = np.hypot(np.diff(wheel.y), np.diff(wheel.z))
    assert steps.max() < 1.01 * steps.mean()


def test_sampled_profile_interpolates_between_points():
    coarse = Profile("coarse", "wheel", s1002(points=401).y, s1002(points=401).z)
    y = np.linspace(-0.0699, 0.0599, 997)
    assert np.max(np.abs(coarse.height(y) - s1002().height(y))) < 0.01e-3  # 10 µm at 0.5 mm spacing


# --- 60E1 ----------------------------------------------------------------------------


def test_60e1_arcs_are_tangent_and_their_centres_aligned():
    h = rail_60e1_head()
    junctions = [(h.c1, h.r1, h.c2, h.r2, h.phi1), (h.c2, h.r2, h.c3, h.r3, h.phi2)]
    for c_a, r_a, c_b, r_b, phi in junctions:
        p_a = (c_a[0] + r_a * math.sin(phi), c_a[1] + r_a * math.cos(phi))
        p_b = (c_b[0] + r_b * math.sin(phi), c_b[1] + r_b * math.cos(phi))
        assert math.dist(p_a, p_b) < 1e-9  # the arcs meet ...
        # ... and the smaller arc's centre lies on the line from the larger's through the junction
        cross = (p_a[0] - c_a[0]) * (c_b[1] - c_a[1]) - (p_a[1] - c_a[1]) * (c_b[0] - c_a[0])
        assert abs(cross) < 1e-9 * r_a * r_a
    assert h.c1 == (0.0, -300.0)
    assert h.c1[0] + h.r1 * math.sin(h.phi1) == pytest.approx(10.228, abs=1e-12)
    assert h.c2[0] + h.r2 * math.sin(h.phi2) == pytest.approx(26.0265, abs=1e-12)


def test_60e1_surface_slope_is_continuous_to_the_1_in_20_flank():
    rail, h = rail_60e1(), rail_60e1_head()
    for y_mm in (10.228, 26.0265, h.y3):
        y = y_mm * 1e-3
        jump = abs(rail.height(y - 1e-9) - rail.height(y + 1e-9))
        assert jump < 2e-9 * abs(rail.slope(y)) * 1.01 + 1e-13  # no more than the slope gives over 2 nm
        assert rail.slope(y - 1e-12) == pytest.approx(rail.slope(y + 1e-12), abs=1e-5)  # tangent
    assert rail.slope(0.0370) == pytest.approx(-20.0)
    assert rail.slope(-0.0370) == pytest.approx(20.0)


def test_60e1_head_is_72_mm_wide_and_40_mm_deep():
    rail, h = rail_60e1(), rail_60e1_head()
    assert 2 * h.y3 == pytest.approx(72.0, abs=ROUNDED)
    assert rail.kind == "rail" and rail.height(0.0) == 0.0 and np.max(rail.z) == 0.0
    assert rail.z[0] == pytest.approx(-0.040) and rail.z[-1] == pytest.approx(-0.040)
    assert np.allclose(rail.y, -rail.y[::-1], atol=1e-12)  # symmetric
    assert np.all(np.diff(rail.y) > 0)
    assert np.max(np.abs(rail.height(rail.y) - rail.z)) < 1e-12


# --- CSV -----------------------------------------------------------------------------


def test_csv_round_trip(tmp_path):
    for profile in (s1002(), rail_60e1()):
        first = tmp_path / f"{profile.name}.csv"
        first.write_bytes(write_csv(profile))
        again = read_profile(first)
        assert again.kind == profile.kind  # inferred from the shape
        # ten significant digits of millimetres
        assert np.max(np.abs(again.y - profile.y)) < 1e-10 and np.max(np.abs(again.z - profile.z)) < 1e-10
        assert write_csv(again) == first.read_bytes()
    assert first.read_text().startswith("y_mm,z_mm\n-37.28")


# --- SIMPACK -------------------------------------------------------------------------


def simpack_text(kind: str, points_mm, flags: dict, header: bool = True) -> str:
    """A SIMPACK profile file whose preprocessing with `flags` gives `points_mm` (y, z in
    rail-mj's convention, mm): each step undone in reverse order."""
    f = flags.get("units.len.f", 1.0)
    y = np.array([p[0] for p in points_mm]) * 1e-3 * f
    z = -np.array([p[1] for p in points_mm]) * 1e-3 * f  # SIMPACK's z points down
    if flags.get("inversion"):
        y, z = y[::-1], z[::-1]
    if flags.get("mirror.y"):
        y = -y
    if flags.get("mirror.z"):
        z = -z
    angle = flags.get("rotate", 0.0) / flags.get("units.ang.f", 1.0)
    c, s = math.cos(-angle), math.sin(-angle)
    y, z = c * y - s * z, s * y + c * z
    y, z = y - flags.get("shift.y", 0.0), z - flags.get("shift.z", 0.0)
    lines = ["! a profile written by tests/contact/test_profiles.py"]
    if header:
        lines += [
            "header.begin",
            "  version = 1",
            f"  type = {1 if kind == 'wheel' else 0}  ! 0 rail, 1 wheel",
            "header.end",
        ]
    lines += ["spline.begin", "  approx.smooth = 0"]
    lines += [f"  {key} = {value!r}" for key, value in flags.items()]
    lines += ["  point.begin", "    ! y z"]
    lines += [f"    {a:.17g} {b:.17g}" for a, b in zip(y, z)]
    lines += ["  point.end", "spline.end"]
    return "\n".join(lines) + "\n"


def mm(profile):
    return list(zip(profile.y * 1e3, profile.z * 1e3))


FLAG_CASES = [
    {},
    {"units.len.f": 1000.0},
    {"mirror.y": 1},
    {"mirror.z": 1},
    {"inversion": 1},
    {"shift.y": 0.004, "shift.z": -0.0015},
    {"rotate": 0.05},
    {"rotate": 2.5, "units.ang.f": 180 / math.pi},  # degrees
    {
        "units.len.f": 1000.0,
        "mirror.y": 1,
        "mirror.z": 1,
        "inversion": 1,
        "shift.y": 3.0,
        "shift.z": 1.0,
        "rotate": -0.02,
    },
]


@pytest.mark.parametrize("flags", FLAG_CASES, ids=lambda f: ",".join(f) or "none")
@pytest.mark.parametrize("kind", ["wheel", "rail"])
def test_simpack_flags_are_honoured(kind, flags, tmp_path):
    exact = s1002() if kind == "wheel" else rail_60e1()
    points = mm(s1002(points=201) if kind == "wheel" else rail_60e1(points=161))
    path = tmp_path / ("p.prw" if kind == "wheel" else "p.prr")
    path.write_text(simpack_text(kind, points, flags))
    got = read_profile(path)
    assert got.kind == kind and len(got.y) == len(points)
    assert np.all(np.diff(got.y) > 0)
    inside = np.clip(got.y, exact.y[0], exact.y[-1])  # a rotation back moves the ends by 1e-17 m
    assert np.max(np.abs(got.z - exact.height(inside))) < 1e-12
    assert got.y[0] == pytest.approx(exact.y[0], abs=1e-12) and got.y[-1] == pytest.approx(exact.y[-1], abs=1e-12)
    # Inversion alone only reorders the points; the 60E1 head is symmetric, mirror.y leaves it so.
    if flags and set(flags) != {"inversion"} and not (kind == "rail" and set(flags) == {"mirror.y"}):
        path.write_text(
            simpack_text(kind, points, flags)
            .replace("  rotate", "  ! rotate")
            .replace("  shift", "  ! shift")
            .replace("  mirror", "  ! mirror")
            .replace("  units.len.f", "  ! units.len.f")
        )
        try:
            ignored = read_profile(path)
        except ProfileError:
            return  # without its flags the file is no profile at all (wrong units)
        assert (
            len(ignored.y) != len(got.y)
            or np.max(np.abs(ignored.y - got.y)) > 1e-6
            or np.max(np.abs(ignored.z - got.z)) > 1e-6
        )


def test_shipped_example_files_read_to_the_standard_profiles():
    wheel = read_profile(DATA / "s1002.prw")
    rail = read_profile(DATA / "60e1.prr")
    assert (wheel.kind, rail.kind) == ("wheel", "rail")
    assert np.max(np.abs(wheel.z - s1002().height(wheel.y))) < 1e-9
    assert np.max(np.abs(rail.z - rail_60e1().height(rail.y))) < 1e-9
    assert wheel.y[0] == pytest.approx(-0.070) and rail.y[-1] == pytest.approx(rail_60e1().y[-1])


def test_the_kind_must_agree_with_a_simpack_file(tmp_path):
    path = tmp_path / "w.prw"
    path.write_text(simpack_text("wheel", mm(s1002(points=51)), {}))
    with pytest.raises(ProfileError, match="not a rail"):
        read_profile(path, kind="rail")
    path = tmp_path / "r.prw"
    path.write_text(simpack_text("rail", mm(rail_60e1(points=51)), {}))
    with pytest.raises(ProfileError, match=r"r.prw, line 4: type = 0 declares a rail profile"):
        read_profile(path)


# --- bad files -----------------------------------------------------------------------


def wheel_file(tmp_path, edit, name="bad.prw"):
    text = simpack_text("wheel", mm(s1002(points=21)), {"units.len.f": 1000.0})
    path = tmp_path / name
    path.write_text(edit(text))
    return path


def line_of(path: Path, needle: str) -> int:
    return next(n for n, line in enumerate(path.read_text().splitlines(), 1) if needle in line)


def refused(path: Path, pattern: str, kind=None) -> str:
    with pytest.raises(ProfileError) as info:
        read_profile(path, kind)
    message = str(info.value)
    assert "\n" not in message and str(path) in message
    assert re.search(pattern, message), message
    return message


def test_bad_simpack_files_are_refused_on_one_line_naming_file_and_line(tmp_path):
    path = wheel_file(tmp_path, lambda t: t.replace("point.begin", "").replace("point.end", ""))
    refused(path, "no point.begin line")

    path = wheel_file(tmp_path, lambda t: t.replace("point.end", ""))
    refused(path, rf"line {line_of(path, 'point.begin')}: point.begin without point.end")

    def garble(text):
        lines = text.splitlines()
        k = next(i for i, line in enumerate(lines) if "point.begin" in line) + 5
        lines[k] = "    -12.5 abc"
        return "\n".join(lines)

    path = wheel_file(tmp_path, garble)
    refused(path, rf"line {line_of(path, 'abc')}: expected two numbers y z .* got '-12.5 abc'")

    def one_point(text):
        head, rest = text.split("! y z\n")
        points, tail = rest.split("  point.end")
        return head + "! y z\n" + points.splitlines()[0] + "\n  point.end" + tail

    path = wheel_file(tmp_path, one_point)
    refused(path, rf"line {line_of(path, 'point.begin')}: 1 point\(s\) between point.begin .* at least 2")

    def duplicate(text):
        lines = text.splitlines()
        k = next(i for i, line in enumerate(lines) if "point.begin" in line) + 4
        lines.insert(k + 1, lines[k])
        return "\n".join(lines)

    path = wheel_file(tmp_path, duplicate)
    first = line_of(path, "point.begin") + 4  # the line copied: the third point
    refused(path, rf"line {first + 1}: y = .* the same y as the point on line {first}")

    path = wheel_file(tmp_path, lambda t: t.replace("units.len.f = 1000.0", "units.len.f = 1.0"))
    refused(path, r"span .* units.len.f is the number of the file's length units in a metre")

    path = wheel_file(tmp_path, lambda t: t.replace("approx.smooth = 0", "mirror.y = 2"))
    refused(path, rf"line {line_of(path, 'mirror.y')}: mirror.y must be 0 or 1, got '2'")

    path = wheel_file(tmp_path, lambda t: t.replace("approx.smooth = 0", "rotate = fast"))
    refused(path, rf"line {line_of(path, 'rotate')}: rotate must be a number")


def test_bad_csv_files_are_refused_on_one_line_naming_file_and_line(tmp_path):
    path = tmp_path / "bad.csv"
    path.write_text("y,z\n0,0\n1,1\n")
    refused(path, r"line 1: expected the header 'y_mm,z_mm'")
    path.write_text("y_mm,z_mm\n0,0\n10,1\n5,2\n")
    refused(path, r"line 4: y = 5 mm is a y before that of the point on line 3 \(10 mm\): points must run increasing")
    path.write_text("y_mm,z_mm\n# measured\n0,0\n10,1\n10,2\n")
    refused(path, r"line 5: y = 10 mm is the same y as the point on line 4")
    path.write_text("y_mm,z_mm\n0,0\n10;1\n")
    refused(path, r"line 3: expected two numbers y_mm,z_mm, got '10;1'")
    path.write_text("y_mm,z_mm\n0,0\n")
    refused(path, r"1 point\(s\): a profile needs at least 2")
    path.write_text("y_mm,z_mm\n0,0\n0.05,0.001\n")  # metres, not millimetres
    refused(path, r"span 0.05 mm .* the CSV is in millimetres")
    path.write_bytes(b"y_mm,z_mm\n\xff\xfe\n")
    refused(path, r"not a text file")
    refused(tmp_path / "missing.csv", r"cannot read it")
    refused(tmp_path / "profile.txt", r"unknown profile format '.txt'")


# --- the command line ----------------------------------------------------------------


def run(argv, capsys):
    status = main([str(a) for a in argv])
    captured = capsys.readouterr()
    return status, captured.out, captured.err


@pytest.mark.parametrize("name, kind", [("s1002", "wheel"), ("60e1", "rail"), ("S1002", "wheel")])
def test_cli_writes_the_standard_profiles(name, kind, tmp_path, capsys):
    csv, png = tmp_path / "p.csv", tmp_path / "p.png"
    status, out, err = run(["profile", name, "-o", csv, "--png", png], capsys)
    assert status == 0, err
    assert f": {kind}, " in out and str(csv) in out and str(png) in out
    assert png.read_bytes().startswith(b"\x89PNG")
    got = read_profile(csv)
    exact = s1002() if kind == "wheel" else rail_60e1()
    assert got.kind == kind and np.max(np.abs(got.z - exact.height(got.y))) < 1e-9


def test_cli_converts_a_simpack_file(tmp_path, capsys):
    csv = tmp_path / "wheel.csv"
    status, _out, err = run(["profile", DATA / "s1002.prw", "-o", csv], capsys)
    assert status == 0, err
    assert read_profile(csv).kind == "wheel" and not (tmp_path / "wheel.png").exists()


@pytest.mark.parametrize(
    "argv, pattern",
    [
        (["profile", "s1003", "-o", "{tmp}/p.csv"], r"s1003: not s1002, 60e1 or a profile file"),
        (["profile", "{tmp}/missing.prr", "-o", "{tmp}/p.csv"], r"missing.prr: cannot read it"),
        (["profile", "{tmp}/bad.prw", "-o", "{tmp}/p.csv", "--png", "{tmp}/p.png"], r"bad.prw: no point.begin line"),
        (["profile", "{tmp}/bad.prw", "-o", "{tmp}/bad.prw"], r"-o .*bad.prw: would overwrite the profile file"),
        (["profile", "s1002", "-o", "{tmp}"], r"is a directory"),
        (["profile", "s1002", "-o", "-", "--png", "-"], r"standard output already takes -o"),
        (["profile", "s1002", "-o", "{tmp}/p.csv", "--kind", "rail"], r"--kind rail, but it is a wheel profile"),
    ],
)
def test_cli_refuses_bad_input_with_one_line_and_exit_2(argv, pattern, tmp_path, capsys):
    (tmp_path / "bad.prw").write_text("header.begin\nheader.end\n")
    status, _out, err = run([a.replace("{tmp}", str(tmp_path)) for a in argv], capsys)
    assert status == 2
    lines = err.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("rail-mj: error: ")
    assert re.search(pattern, lines[0]), lines[0]
    assert not (tmp_path / "p.csv").exists() and not (tmp_path / "p.png").exists()
    assert (tmp_path / "bad.prw").read_text() == "header.begin\nheader.end\n"
