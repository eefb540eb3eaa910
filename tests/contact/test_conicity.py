"""Equivalent conicity (EN 15302, docs/conicity.md) against cases whose answer is known in
closed form. The standard's annex reference profile combinations are not available to the
project, so none of its numbers are tested here (docs/conicity.md says so)."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest
from conftest import MODELS
from scipy.special import ellipk

from rail_mj.cli import main
from rail_mj.contact.conicity import (
    DEFAULT_AMPLITUDES,
    ConicityError,
    DeltaR,
    equivalent_conicity,
    harmonic_conicity,
    klingel_ode,
    wavelength,
)

AMPLITUDES = [0.5, 1.0, 3.0, 6.0, 9.5]


def cubic(lam=0.1, kappa=0.002, reach=12.0):
    """Δr = 2λy + 2κy³, a hardening (Duffing) oscillator."""
    return DeltaR.from_function(
        lambda y: 2 * lam * y + 2 * kappa * y**3, -reach, reach, integral=lambda y: lam * y**2 + kappa * y**4 / 2
    )


def duffing_conicity(amplitude, lam=0.1, kappa=0.002):
    """The exact period of y'' + (2λy + 2κy³)/(e r0) = 0 (e r0 = 1) from its turning point A:
    T = 4K(m)/sqrt(w² + βA²), m = βA²/(2(w² + βA²)), w² = 2λ, β = 2κ; λe = (2π/T)²/2."""
    w2, beta = 2 * lam, 2 * kappa
    m = beta * amplitude**2 / (2 * (w2 + beta * amplitude**2))
    period = 4 * ellipk(m) / math.sqrt(w2 + beta * amplitude**2)
    return (2 * math.pi / period) ** 2 / 2


def dead_band(lam=0.1, band=1.0):
    """Δr = 0 for |y| < band, a cone beyond: 2λ·sign(y)·(|y| − band)."""
    return DeltaR.from_function(
        lambda y: 2 * lam * np.sign(y) * max(abs(y) - band, 0.0),
        -12.0,
        12.0,
        integral=lambda y: lam * max(abs(y) - band, 0.0) ** 2,
        knots=[-band, band],
    )


def write_csv(path, y, dr, header="y_mm,delta_r_mm"):
    path.write_text(header + "\n" + "".join(f"{float(a)!r},{float(b)!r}\n" for a, b in zip(y, dr)))
    return path


def run(argv, capsys):
    status = main([str(a) for a in argv])
    captured = capsys.readouterr()
    return status, captured.out, captured.err


# --- the integration method ---------------------------------------------------------------


@pytest.mark.parametrize("lam", [0.02, 0.15, 0.4])
def test_a_cone_has_its_conicity_at_every_amplitude(lam):
    # to 1e-6 relative, from 0.5 to 10 mm
    got = equivalent_conicity(DeltaR.cone(lam, half_range=10.0), DEFAULT_AMPLITUDES)
    np.testing.assert_allclose(got, lam, rtol=1e-6)


def test_a_cone_given_as_points_is_still_exact():
    # PCHIP through points on a line is the line: to 1e-6 relative
    y = np.linspace(-10.0, 10.0, 7)
    got = equivalent_conicity(DeltaR.from_points(y, 2 * 0.2 * y), [0.5, 2.0, 7.0])
    np.testing.assert_allclose(got, 0.2, rtol=1e-6)


def test_the_result_does_not_depend_on_e_and_r0():
    # λe to 1e-9 relative for three (e, r0); the wavelength itself scales as sqrt(e r0)
    delta_r = cubic()
    base = equivalent_conicity(delta_r, AMPLITUDES, e=1500.0, r0=460.0)
    for e, r0 in ((1000.0, 300.0), (2000.0, 625.0)):
        np.testing.assert_allclose(equivalent_conicity(delta_r, AMPLITUDES, e=e, r0=r0), base, rtol=1e-9)
    ratio = wavelength(delta_r, 3.0, e=2000.0, r0=625.0) / wavelength(delta_r, 3.0, e=1500.0, r0=460.0)
    assert ratio == pytest.approx(math.sqrt(2000.0 * 625.0 / (1500.0 * 460.0)), rel=1e-9)


def test_a_cone_wavelength_is_klingels():
    # L = 2π sqrt(e r0 / (2λ)) for Δr = 2λy, to 1e-9 relative
    assert wavelength(DeltaR.cone(0.1), 4.0, e=1500.0, r0=460.0) == pytest.approx(
        2 * math.pi * math.sqrt(1500.0 * 460.0 / 0.2), rel=1e-9
    )


def test_a_cubic_delta_r_has_the_duffing_period():
    # against the elliptic-integral period, to 1e-6 relative; λe grows with amplitude
    got = equivalent_conicity(cubic(), AMPLITUDES)
    np.testing.assert_allclose(got, [duffing_conicity(a) for a in AMPLITUDES], rtol=1e-6)
    assert got[-1] > 1.5 * got[0]


def test_the_cubic_from_csv_points_is_close_to_the_function():
    # PCHIP through points 0.1 mm apart: λe within 1e-5 of the function's
    y = np.arange(-12.0, 12.0001, 0.1)
    delta_r = DeltaR.from_points(y, 0.2 * y + 0.004 * y**3)
    np.testing.assert_allclose(
        equivalent_conicity(delta_r, AMPLITUDES), [duffing_conicity(a) for a in AMPLITUDES], rtol=1e-5
    )


@pytest.mark.parametrize("release", [3.0, -4.0, 8.0])
def test_the_quadrature_agrees_with_a_time_integration(release):
    # an asymmetric Δr = 2λy + μy²: amplitude (half the peak-to-peak) and wavelength from
    # DOP853 at rtol 1e-12 against the quadrature, to 1e-8 relative
    delta_r = DeltaR.from_function(
        lambda y: 0.2 * y + 0.01 * y**2, -12.0, 12.0, integral=lambda y: 0.1 * y**2 + 0.01 * y**3 / 3
    )
    amplitude, length = klingel_ode(delta_r, release)
    low, high, _ = delta_r.turning_points(amplitude)
    assert (high if release > 0 else low) == pytest.approx(release, rel=1e-8)
    assert high + low != pytest.approx(0.0, abs=0.1)  # the turning points are not symmetric
    assert length == pytest.approx(wavelength(delta_r, amplitude), rel=1e-8)


@pytest.mark.parametrize("offset", [-2.0, 0.7, 3.0])
def test_unequal_diameters_centre_the_motion_where_delta_r_vanishes(offset):
    # Δr = 2λ(y − y0), Δr(0) ≠ 0: λ at every amplitude to 1e-6, the centre at y0 to 1e-9 mm
    y = np.linspace(-10.0, 10.0, 41)
    delta_r = DeltaR.from_points(y, 2 * 0.15 * (y - offset))
    assert delta_r.centre == pytest.approx((offset, offset), abs=1e-9)
    amplitudes = [a for a in AMPLITUDES if a <= 10.0 - abs(offset)]
    np.testing.assert_allclose(equivalent_conicity(delta_r, amplitudes), 0.15, rtol=1e-6)
    low, high, _ = delta_r.turning_points(3.0)
    assert (low, high) == pytest.approx((offset - 3.0, offset + 3.0), abs=1e-9)


def test_a_dead_band_gives_no_conicity_inside_and_rising_beyond():
    # zero up to the band's half-width; beyond it the exact λe = π²/(2 I²), with the half period
    # I = 2d/sqrt(2Φ) + π/sqrt(2λ) (the band crossed at constant speed, Φ = λ(ŷ − d)²), to 1e-9
    lam, band = 0.1, 1.0
    delta_r = dead_band(lam, band)
    amplitudes = [0.3, 1.0, 1.01, 1.5, 3.0, 6.0, 10.0]
    got = equivalent_conicity(delta_r, amplitudes)
    assert got[0] == 0.0 and got[1] == 0.0
    for a, value in zip(amplitudes[2:], got[2:]):
        half = 2 * band / math.sqrt(2 * lam * (a - band) ** 2) + math.pi / math.sqrt(2 * lam)
        assert value == pytest.approx(math.pi**2 / (2 * half**2), rel=1e-9)
    assert got[2] < 1e-3 * lam and np.all(np.diff(got[1:]) > 0) and got[-1] < lam


def test_delta_r_that_vanishes_again_beyond_the_centre_has_gaps():
    # Δr back to zero on [3, 4] mm: the motion that reaches the plateau creeps onto it for ever,
    # and amplitudes from about 2.9 to 3.3 mm belong to no periodic motion (NaN); λe falls
    # towards the gap from both sides
    y = np.array([-10.0, -5.0, 0.0, 2.0, 3.0, 4.0, 10.0])
    delta_r = DeltaR.from_points(y, np.array([-2.0, -1.0, 0.0, 0.4, 0.0, 0.0, 1.0]))
    assert delta_r.centre == pytest.approx((0.0, 0.0), abs=1e-12)
    got = equivalent_conicity(delta_r, [1.0, 2.75, 3.0, 3.25, 3.5, 5.0])
    assert np.all(np.isnan(got[2:4])) and np.all(got[[0, 1, 4, 5]] > 0)
    assert got[1] < 0.3 * got[0] and got[4] < 0.1 * got[5]


# --- harmonic linearisation -------------------------------------------------------------


def test_harmonic_linearisation_is_exact_for_a_cone_and_shifted_cone():
    # to 1e-12 relative
    for centre in (0.0, 1.5):
        for a in (0.5, 3.0, 8.0):
            assert harmonic_conicity(DeltaR.cone(0.15, 10.0, centre), a) == pytest.approx(0.15, rel=1e-12)


def test_harmonic_linearisation_is_the_describing_function():
    # cubic: λ + (3/4)κŷ²; dead band: λ(1 − (2/π)(asin(d/ŷ) + (d/ŷ)sqrt(1 − (d/ŷ)²))); to 1e-10
    for a in AMPLITUDES:
        assert harmonic_conicity(cubic(), a) == pytest.approx(0.1 + 0.75 * 0.002 * a**2, rel=1e-10)
    for a in (1.5, 3.0, 6.0):
        r = 1.0 / a
        expected = 0.1 * (1 - 2 / math.pi * (math.asin(r) + r * math.sqrt(1 - r * r)))
        assert harmonic_conicity(dead_band(), a) == pytest.approx(expected, rel=1e-10)


def test_harmonic_linearisation_is_within_a_few_percent_of_the_integration():
    # mildly nonlinear (λe grows by a quarter to 10 mm): within 2 %, and not identical past 3 mm
    delta_r = cubic(kappa=0.001)
    exact = equivalent_conicity(delta_r, AMPLITUDES)
    harmonic = equivalent_conicity(delta_r, AMPLITUDES, method="harmonic")
    np.testing.assert_allclose(harmonic, exact, rtol=0.02)
    assert abs(harmonic[-1] / exact[-1] - 1) > 1e-3


# --- refusals -------------------------------------------------------------------------------


@pytest.mark.parametrize(
    "lines, where",
    [
        ("y_mm,delta_r_mm\n-1,-1\n0,0\n", "needs at least 3 points"),
        ("y_mm,delta_r_mm\n-1,-1\n0,0\n0,1\n", ":4: y = 0 mm does not increase"),
        ("y_mm,delta_r_mm\n-1,-1\n0,nan\n1,1\n", ":3: not a finite number"),
        ("y_mm,delta_r_mm\n-1,-1\n0,zero\n1,1\n", ":3: not a number"),
        ("y_mm,delta_r_mm\n-1,-1\n0,0,0\n1,1\n", ":3: expected 2 fields"),
        ("y,dr\n-1,-1\n0,0\n1,1\n", ":1: expected the header"),
        ("", "empty"),
        ("y_mm,delta_r_mm\n-1,1\n0,0\n1,-1\n", "must go from negative to positive once"),
        ("y_mm,delta_r_mm\n-1,1\n0,2\n1,3\n", "never negative"),
    ],
)
def test_bad_csv_is_refused_naming_file_and_line(tmp_path, lines, where):
    path = tmp_path / "dr.csv"
    path.write_text(lines)
    with pytest.raises(ConicityError, match=r"dr\.csv") as caught:
        DeltaR.read_csv(path)
    assert where in str(caught.value) and "\n" not in str(caught.value)


def test_an_amplitude_beyond_the_data_is_refused():
    delta_r = DeltaR.from_points([-4.0, 0.0, 4.0], [-0.8, 0.0, 0.8])
    assert delta_r.largest_amplitude() == pytest.approx(4.0, rel=1e-12)
    with pytest.raises(ConicityError, match="beyond the data"):
        equivalent_conicity(delta_r, [4.5])
    with pytest.raises(ConicityError, match="beyond the data"):
        harmonic_conicity(delta_r, 4.5)


# --- the command ----------------------------------------------------------------------------


@pytest.fixture
def cone_csv(tmp_path):
    y = np.linspace(-10.0, 10.0, 21)
    return write_csv(tmp_path / "cone.csv", y, list(2 * 0.12 * (y - 0.5)))


def test_cli_json_has_exactly_the_two_keys(cone_csv, capsys):
    status, out, err = run(["conicity", "--delta-r", cone_csv, "--json", "--amplitudes", "1:5:5"], capsys)
    assert status == 0, err
    result = json.loads(out)
    assert list(result) == ["amplitude_mm", "equivalent_conicity"]
    assert result["amplitude_mm"] == [1.0, 2.0, 3.0, 4.0, 5.0]
    np.testing.assert_allclose(result["equivalent_conicity"], 0.12, rtol=1e-6)


def test_cli_default_amplitudes_stop_where_the_data_do(cone_csv, capsys):
    # centre 0.5 mm in data from −10 to 10: amplitudes up to 9.5 mm
    status, out, err = run(["conicity", "--delta-r", cone_csv, "--json"], capsys)
    assert status == 0, err
    assert json.loads(out)["amplitude_mm"] == [0.5 * k for k in range(1, 20)]


def test_cli_text_and_png(cone_csv, tmp_path, capsys):
    png = tmp_path / "out" / "conicity.png"
    status, out, err = run(["conicity", "--delta-r", cone_csv, "--png", png], capsys)
    assert status == 0, err
    assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    assert "at 3 mm: 0.1200" in out and "centre y = 0.5 mm" in out
    assert not list(tmp_path.rglob(".*.tmp"))


def test_cli_cone_layout_gives_its_conicity(capsys):
    status, out, err = run(["conicity", MODELS / "wheelset" / "wheelset.toml", "--json"], capsys)
    assert status == 0, err
    np.testing.assert_allclose(json.loads(out)["equivalent_conicity"], 0.1, rtol=1e-6)


def test_cli_layout_with_profiles_gives_theirs(tmp_path, capsys):
    """A layout with [profiles]: the Δr of their contact geometry (tests/contact/test_geometry.py),
    not the cone of its wheelset.conicity."""
    layout = tmp_path / "profiled.toml"
    layout.write_text(
        (MODELS / "wheelset" / "wheelset.toml").read_text() + '\n[profiles]\nwheel = "S1002"\nrail = "UIC60"\n'
    )
    status, out, err = run(["conicity", layout, "--amplitudes", "3:3:1", "--json"], capsys)
    assert status == 0, err
    value = json.loads(out)["equivalent_conicity"][0]
    assert value != pytest.approx(0.1, abs=1e-3) and 0.05 < value < 0.5


@pytest.mark.parametrize(
    "extra, message",
    [
        (["--amplitudes", "1:x:3"], "must be A:B:N"),
        (["--amplitudes", "5:1:3"], "needs 0 < A <= B"),
        (["--amplitudes", "0:1:3"], "needs 0 < A <= B"),
        (["--amplitudes", "1:2:1"], "needs 0 < A <= B"),
        (["--amplitudes", "1:12:3"], "12 mm is beyond"),
        (["--amplitudes", "nan:1:3"], "needs 0 < A <= B"),
    ],
)
def test_cli_bad_amplitudes_exit_2_in_one_line(cone_csv, capsys, extra, message):
    status, out, err = run(["conicity", "--delta-r", cone_csv, *extra], capsys)
    assert status == 2 and out == ""
    assert len(err.strip().splitlines()) == 1 and message in err, err


@pytest.mark.parametrize(
    "text, message",
    [
        ("y_mm,delta_r_mm\n-1,-1\n1,1\n", "needs at least 3 points"),
        ("y_mm,delta_r_mm\n-1,-1\n1,1\n0,2\n", "bad.csv:4: y = 0 mm does not increase"),
        ("y_mm,delta_r_mm\n-1,-1\n0,inf\n1,1\n", "bad.csv:3: not a finite number"),
        ("nonsense", "bad.csv:1: expected the header"),
        ("y_mm,delta_r_mm\n-0.1,-0.01\n0,0\n0.1,0.01\n", "give --amplitudes"),
    ],
)
def test_cli_bad_csv_exits_2_in_one_line(tmp_path, capsys, text, message):
    bad = tmp_path / "bad.csv"
    bad.write_text(text)
    status, out, err = run(["conicity", "--delta-r", bad], capsys)
    assert status == 2 and out == ""
    assert len(err.strip().splitlines()) == 1 and message in err and "Traceback" not in err, err


@pytest.mark.parametrize(
    "argv, message",
    [
        ([], "give LAYOUT or --delta-r"),
        ([MODELS / "wheelset" / "wheelset.toml", "--delta-r", "x.csv"], "not both"),
        (["--delta-r", "missing.csv"], "cannot read"),
    ],
)
def test_cli_wrong_inputs_exit_2_in_one_line(capsys, argv, message):
    status, _out, err = run(["conicity", *argv], capsys)
    assert status == 2 and len(err.strip().splitlines()) == 1 and message in err, err


def test_cli_png_never_overwrites_the_input(cone_csv, capsys):
    before = cone_csv.read_bytes()
    status, _out, err = run(["conicity", "--delta-r", cone_csv, "--png", cone_csv], capsys)
    assert status == 2 and "would overwrite" in err and cone_csv.read_bytes() == before
