"""`rail-mj response`: transfer functions and rms responses to track irregularities from the command line."""

from __future__ import annotations

import csv
import json

import numpy as np
import pytest
from conftest import DATA, MODELS

from rail_mj.cli import main

SPATIAL = DATA / "manchester-coach-spatial.toml"
COACH = MODELS / "manchester-coach" / "manchester-coach.toml"


def run(argv, capsys):
    status = main([str(a) for a in argv])
    captured = capsys.readouterr()
    return status, captured.out, captured.err


def test_the_response_of_the_spatial_coach_with_its_rms_under_a_spectrum(tmp_path, capsys):
    png, data = tmp_path / "response.png", tmp_path / "response.csv"
    argv = ["response", SPATIAL, "--speed", "55", "--spectrum", "erri-high", "--frequencies", "0.1:20:60:log"]
    status, text, err = run([*argv, "-o", png, "--json"], capsys)
    assert status == 0, err
    doc = json.loads(text)
    assert doc["inputs"] == ["alignment", "level", "cross_level", "gauge"]
    assert doc["spectrum"] == {"name": "erri-high", "wavelengths_m": [3.0, 150.0], "scale": 1.0, "from": "erri-high"}
    outputs = doc["outputs"]
    assert list(outputs) == [
        "y1",
        "sum_y1",
        "q_left1",
        *(f"floor_{d}_{p}" for d in ("lateral", "vertical") for p in ("bogie1", "bogie2", "centre")),
    ]
    for entry in outputs.values():  # channels independent: the total is the root of the sum of squares
        shares = [v for k, v in entry["rms"].items() if k != "total"]
        assert entry["rms"]["total"] == pytest.approx(float(np.sqrt(np.sum(np.square(shares)))), rel=1e-12)
        assert entry["peak"]["gauge"] is None and entry["rms"]["gauge"] == 0.0
    assert outputs["y1"]["peak"]["level"] is None  # a symmetric vehicle: level moves nothing sideways
    assert outputs["floor_vertical_centre"]["peak"]["alignment"] is None
    assert png.stat().st_size > 10_000
    with data.open() as f:
        rows = list(csv.DictReader(f))
    assert len(rows) == 60 * 4 * 9
    first = {(r["input"], r["output"]): r for r in rows if float(r["frequency_hz"]) == 0.1}
    # 0.1 Hz at 55 m/s is a 550 m wave: the vehicle rides it as the rails carry it; the wheelset
    # moves with the alignment, the floor with the level, w^2 times it (the car body's bounce is
    # at ~1 Hz: 1 % off in amplification at 0.1).
    assert float(first["alignment", "y1"]["wavelength_m"]) == pytest.approx(550.0)
    assert float(first["alignment", "y1"]["gain"]) == pytest.approx(1.0, abs=0.01)
    assert float(first["level", "floor_vertical_centre"]["gain"]) == pytest.approx((2 * np.pi * 0.1) ** 2, rel=0.02)
    assert first["level", "floor_vertical_centre"]["gain_unit"] == "m_per_s2_per_m"


def test_the_text_names_the_spectrum_and_a_track_file_gives_it(tmp_path, capsys):
    track = tmp_path / "track.toml"
    track.write_text(
        '[[section]]\nkind = "straight"\nlength = 1000.0\n\n'
        '[irregularities]\nspectrum = "erri-low"\nwavelengths = [3.0, 70.0]\nscale = 0.5\n'
    )
    status, text, err = run(
        ["response", COACH, "--speed", "40", "--track", track, "-o", tmp_path / "r.png", "--outputs", "y*,floor_*"],
        capsys,
    )
    assert status == 0, err
    assert f"rms under erri-low (3-70 m, x0.5, from {track})" in text
    assert "y_carbody" in text and "psi1" not in text and "q_left1" not in text
    assert (tmp_path / "r.csv").exists()


@pytest.mark.parametrize(
    "extra, says",
    [
        (["--inputs", "level"], "takes alignment, gauge, not level"),
        (["--inputs", "twist"], "'twist' is no channel"),
        (["--outputs", "q_left1"], "--outputs: no output 'q_left1'"),
        (["--frequencies", "0:10:5"], "--frequencies A:B:N needs 0.001 <= A < B <= 1000 Hz"),
        (["--frequencies", "1:1e300:5:log"], "--frequencies A:B:N needs 0.001 <= A < B <= 1000 Hz"),
        (["--speed", "1e-300"], "--speed must be at least 1 m/s"),
        (["--speed", "150"], "unstable at 150 m/s (a mode grows at"),
        (["--csv", "-", "--json"], "--json prints to standard output"),
        (["--wavelengths", "3,70"], "--wavelengths and --scale go with --spectrum"),
        (["--spectrum", "erri-medium"], "--spectrum: must be one of"),
        (["--spectrum", "erri-low", "--wavelengths", "70,3"], "--wavelengths 70,3: need"),
        (["--spectrum", "erri-low", "--scale", "-1"], "--scale must be a number >= 0"),
        (["--amplitude", "3"], "--amplitude"),
    ],
)
def test_bad_requests_are_one_line_and_write_nothing(tmp_path, capsys, extra, says):
    png = tmp_path / "r.png"
    status, _, err = run(["response", COACH, "--speed", "40", "-o", png, *extra], capsys)
    assert status == 2
    assert len(err.strip().splitlines()) == 1 and says in err, err
    assert not png.exists() and not (tmp_path / "r.csv").exists()


def test_a_measured_track_has_no_spectrum_to_give(tmp_path, capsys):
    (tmp_path / "m.csv").write_text("x_m,alignment_mm,level_mm,cross_level_mm,gauge_mm\n0,0,0,0,0\n100,1,0,0,0\n")
    track = tmp_path / "track.toml"
    track.write_text('[[section]]\nkind = "straight"\nlength = 100.0\n\n[irregularities]\nfile = "m.csv"\n')
    status, _, err = run(["response", COACH, "--speed", "40", "--track", track, "-o", tmp_path / "r.png"], capsys)
    assert status == 2 and "measured, not a spectrum" in err
