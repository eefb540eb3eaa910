"""`rail-mj run --track`: a run along a curved track from the command line."""

from __future__ import annotations

import json

from conftest import MODELS

from rail_mj.cli import main

BOGIE = MODELS / "bogie" / "bogie.toml"
CURVE = MODELS / "tracks" / "curve-600.toml"


def run(argv, capsys):
    status = main([str(a) for a in argv])
    captured = capsys.readouterr()
    return status, captured.out, captured.err


def test_a_run_along_a_track_reports_each_curve_and_writes_the_track_columns(tmp_path, capsys):
    out = tmp_path / "run.csv"
    status, text, err = run(
        ["run", BOGIE, "--speed", "25", "--distance", "580", "--track", CURVE, "--json", "--out", out], capsys
    )
    assert status == 0, err
    result = json.loads(text)
    assert result["track"] == str(CURVE)
    (curve,) = result["curves"]
    assert curve["section"] == 3 and curve["radius_m"] == 600.0 and curve["cant_m"] == 0.15
    # 11.8*V^2/R - cant, V in km/h (EN 13803), to the small-angle difference of the exact form.
    assert abs(curve["cant_deficiency_mm"] - (11.8 * 90.0**2 / 600.0 - 150.0)) < 1.0
    leading = curve["wheelsets"][0]
    assert leading["mean_angle_of_attack_rad"] > 0  # the leading wheelset points at the outer rail
    assert leading["mean_lateral_m"] < 0  # and runs towards it (the right rail of a left curve)
    # Each wheel's wear number, left and right, mean and largest: the leading wheelset's, pressed
    # against its yaw spring by the curve, above the trailing one's.
    assert len(leading["mean_wear_number_n"]) == 2 and len(leading["max_wear_number_n"]) == 2
    trailing = curve["wheelsets"][1]
    assert min(leading["mean_wear_number_n"]) > max(trailing["mean_wear_number_n"]) >= 0.0
    header = out.read_text().splitlines()[0].split(",")
    assert header[-4:] == ["curvature1", "curvature2", "cant1", "cant2"]


def test_a_bad_track_is_refused_in_one_line(tmp_path, capsys):
    bad = tmp_path / "bad.toml"
    bad.write_text('[[section]]\nkind = "curve"\nlength = 100.0\n')
    status, _out, err = run(["run", BOGIE, "--speed", "25", "--distance", "20", "--track", bad], capsys)
    assert status == 2
    assert err.strip().splitlines() == [
        f"rail-mj: error: {bad}: section 1 (curve): radius missing: a curve "
        "needs its radius (m; positive turns left, negative right)"
    ]


def test_a_run_longer_than_the_track_is_refused_before_it_starts(capsys):
    status, _out, err = run(["run", BOGIE, "--speed", "25", "--distance", "2000", "--track", CURVE], capsys)
    assert status == 2
    assert "longer than the track" in err and len(err.strip().splitlines()) == 1


def test_curving_gives_each_radius_and_speed_its_steady_state(capsys):
    status, text, err = run(
        ["curving", BOGIE, "--radii", "600,-1200", "--speeds", "20:30:2", "--cant", "0.05", "--json"], capsys
    )
    assert status == 0, err
    results = json.loads(text)
    assert [(r["radius_m"], r["speed_m_per_s"]) for r in results] == [
        (600.0, 20.0),
        (600.0, 30.0),
        (-1200.0, 20.0),
        (-1200.0, 30.0),
    ]
    left, right = results[0], results[2]
    assert all(v >= 0.0 for r in results for w in r["wheelsets"] for v in w["wear_number_n"])
    assert right["cant_m"] == -0.05  # the outer rail of a right curve is the left one
    # Either hand, the leading wheelset points at its outer rail and runs towards it.
    for result, outward in ((left, -1.0), (right, 1.0)):
        leading = result["wheelsets"][0]
        assert leading["angle_of_attack_rad"] > 0
        assert outward * leading["lateral_m"] > 0


def test_curving_refuses_a_radius_no_track_has(capsys):
    status, _out, err = run(["curving", BOGIE, "--radius", "5", "--speed", "10"], capsys)
    assert status == 2
    assert err.strip().splitlines() == [
        "rail-mj: error: --radius must be at least 10 m (tighter than trams run; a 2.5 m wheelbase would "
        "turn through 0.25 rad), got 5; check the units (m)"
    ]


def test_a_sweep_along_a_track_keys_its_cases_by_the_track(tmp_path, capsys):
    out = tmp_path / "sweep.csv"
    argv = ["sweep", BOGIE, "--speeds", "20:30:2", "--distance", "400", "-o", out, "--json"]
    status, text, err = run([*argv, "--track", CURVE], capsys)
    assert status == 0, err
    assert json.loads(text)["by_status"] == {"ok": 2, "diverged": 0, "refused": 0, "failed": 0}
    curved = out.read_text()
    # The same sweep on straight track is another sweep: its cases' keys differ.
    status, _text, err = run(argv, capsys)
    assert status == 2 and "holds results of another sweep" in err
    assert out.read_text() == curved


def test_a_curving_sweep_takes_the_curve_as_keys_and_gives_curving_s_numbers(tmp_path, capsys):
    """`sweep --method curving`: track.radius and track.cant as --grid and --set keys, a case per
    grid point and speed, each row the steady state `rail-mj curving` gives."""
    out = tmp_path / "curving.csv"
    argv = ["sweep", BOGIE, "--method", "curving", "--grid", "track.radius=600:1200:2", "--set", "track.cant=0.1"]
    status, _text, err = run([*argv, "--speeds", "20:30:2", "-o", out], capsys)
    assert status == 0, err
    lines = out.read_text().splitlines()
    assert lines[0].split(",")[:9] == [
        '"case"',
        '"track.radius"',
        '"speed_m_per_s"',
        '"cant_deficiency_mm"',
        '"leading_lateral_m"',
        '"leading_angle_of_attack_rad"',
        '"max_y_over_q"',
        '"max_wear_number_n"',
        '"status"',
    ]
    assert len(lines) == 5
    status, text, err = run(["curving", BOGIE, "--radius", "1200", "--cant", "0.1", "--speed", "30", "--json"], capsys)
    assert status == 0, err
    leading = json.loads(text)[0]["wheelsets"][0]
    case = lines[4].split(",")  # the last case: 1200 m at 30 m/s
    assert float(case[1]) == 1200.0 and float(case[2]) == 30.0
    assert float(case[5]) == leading["angle_of_attack_rad"]


def test_curve_keys_belong_to_a_curving_sweep(capsys):
    status, _out, err = run(
        ["sweep", BOGIE, "--grid", "track.radius=300:600:2", "--speeds", "20:30:2", "-o", "x.csv"], capsys
    )
    assert status == 2
    assert err.strip() == "rail-mj: error: track.radius is a key of --method curving, not of run"
    status, _out, err = run(["sweep", BOGIE, "--method", "curving", "--speeds", "20:30:2", "-o", "x.csv"], capsys)
    assert status == 2 and "needs the curve's radius" in err


def test_a_cant_deficiency_beyond_practice_is_warned_about(capsys):
    """EN 13803's 150 mm for vehicles without tilt: 1.5*V^2/(g*R) - cant, on the 600 m curve with
    150 mm cant, passes it at 34.3 m/s. One warning line per curve (run) or case (curving), the
    result still given; none within practice."""
    deficiency = round(1.5e3 * 36.0**2 / (9.81 * 600.0) - 150.0)  # mm, 180: small-angle form, to 1 mm
    status, text, err = run(["run", BOGIE, "--speed", "36", "--distance", "580", "--track", CURVE], capsys)
    assert status == 0 and f"deficiency {deficiency} mm" in text
    (line,) = err.strip().splitlines()
    assert line.startswith(f"rail-mj: warning: curve 3 (600 m): cant deficiency {deficiency} mm is")
    assert "outside railway practice, -110 to 150 mm (EN 13803" in line
    status, _text, err = run(["curving", BOGIE, "--radius", "600", "--cant", "0.15", "--speeds", "25:36:2"], capsys)
    assert status == 0
    (line,) = err.strip().splitlines()
    assert line.startswith(f"rail-mj: warning: 600 m curve at 36 m/s: cant deficiency {deficiency} mm is")
