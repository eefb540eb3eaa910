"""Ride comfort (rail_mj.analysis.ride): EN 12299's weightings against their transfer functions, N_MV,
the continuous comfort and Sperling's Wz of signals whose values are known."""

from __future__ import annotations

import math

import numpy as np
import pytest

from rail_mj.analysis.ride import WB, WC, WD, continuous_comfort, mean_comfort, sperling, sperling_gain

FS = 1000.0  # Hz, a run's sampling


def en12299(f, f1, f2, f3, f4, q4, f5=None, q5=None, f6=None, q6=None, k=1.0):
    """|H(i*2*pi*f)| written out factor by factor (EN 12299, Annex A), independently of the module."""
    s = 2j * np.pi * np.asarray(f, float)
    w = {n: 2 * np.pi * v for n, v in (("1", f1), ("2", f2), ("3", f3), ("4", f4))}
    q1 = 1 / math.sqrt(2)
    high = s**2 / (s**2 + w["1"] * s / q1 + w["1"] ** 2)
    low = w["2"] ** 2 / (s**2 + w["2"] * s / q1 + w["2"] ** 2)
    transition = (1 + s / w["3"]) / (1 + s / (q4 * w["4"]) + (s / w["4"]) ** 2)
    step = 1.0
    if f5 is not None:
        w5, w6 = 2 * np.pi * f5, 2 * np.pi * f6
        step = k * (1 + s / (q5 * w5) + (s / w5) ** 2) / (1 + s / (q6 * w6) + (s / w6) ** 2)
    return np.abs(high * low * transition * step)


REFERENCE = np.array([0.5, 1.0, 2.0, 4.0, 8.0, 16.0, 31.5])  # Hz


@pytest.mark.parametrize(
    ("weighting", "parameters"),
    [
        (WB, (0.4, 100.0, 16.0, 16.0, 0.63, 2.5, 0.8, 4.0, 0.8, 0.4)),
        (WD, (0.4, 100.0, 2.0, 2.0, 0.63)),
        (WC, (0.4, 100.0, 8.0, 8.0, 0.63)),
    ],
)
def test_each_weighting_has_its_transfer_functions_gain(weighting, parameters):
    """The analog gain to rounding; the discrete filter, run once over a sine, its steady amplitude to
    0.3 % up to 16 Hz (the bilinear transform's warping at 1 kHz: tan(pi*f/fs)/(pi*f/fs) - 1 is
    8e-4 at 16 Hz) and to 2 % at 31.5 Hz."""
    expected = en12299(REFERENCE, *parameters)
    np.testing.assert_allclose(weighting.gain(REFERENCE), expected, rtol=1e-12)
    t = np.arange(0, 40.0, 1 / FS)
    for f, gain in zip(REFERENCE, expected):
        out = weighting.apply(np.sin(2 * np.pi * f * t), FS)
        steady = out[t >= 30.0]  # ten seconds: the 0.4 Hz high pass has settled by e^-17
        amplitude = math.sqrt(2 * np.mean(steady**2))
        assert amplitude == pytest.approx(gain, rel=0.003 if f <= 16 else 0.02), f


def test_a_forward_only_filter_is_not_the_squared_gain():
    """Applied once, 4 Hz lateral comes out at |Wd(4)| = 0.51, not |Wd(4)|^2 = 0.26 (forward-backward)."""
    t = np.arange(0, 40.0, 1 / FS)
    out = WD.apply(np.sin(2 * np.pi * 4.0 * t), FS)[t >= 30.0]
    assert math.sqrt(2 * np.mean(out**2)) == pytest.approx(float(WD.gain(4.0)), rel=1e-3)


def test_the_mean_comfort_of_steady_sines():
    """N_MV = 6*sqrt(a_Y^2 + a_Z^2) with each a the weighted rms of the steady sine (every 5 s block
    holds whole periods: the 95th percentile is the steady value, the first blocks' transient lower):
    1 Hz lateral at 0.3 m/s^2 and 5 Hz vertical at 0.2 m/s^2 over 2 minutes."""
    t = np.arange(0, 120.0, 1 / FS)
    lateral, vertical = 0.3 * np.sin(2 * np.pi * t), 0.2 * np.sin(2 * np.pi * 5 * t)
    a_y = float(WD.gain(1.0)) * 0.3 / math.sqrt(2)
    a_z = float(WB.gain(5.0)) * 0.2 / math.sqrt(2)
    assert mean_comfort(lateral, vertical, FS) == pytest.approx(6 * math.hypot(a_y, a_z), rel=2e-3)
    assert mean_comfort(lateral, None, FS) == pytest.approx(6 * a_y, rel=2e-3)
    assert mean_comfort(lateral[:4000], None, FS) is None  # shorter than one 5 s window
    comfort = continuous_comfort(lateral, FS, WD)
    assert np.isnan(comfort[: int(4.9 * FS)]).all()
    np.testing.assert_allclose(comfort[t > 60.0], 6 * a_y, rtol=2e-3)


@pytest.mark.parametrize("lateral", [False, True])
def test_sperlings_index_of_a_sine(lateral):
    """Wz = 4.42*(B(f)*A/sqrt(2))^0.3 for a sine of whole periods (its spectrum one line), with B_y =
    1.25*B_z; B_z(1 Hz) from its formula written out here."""
    t = np.arange(0, 20.0, 1 / FS)
    for f, amplitude in ((1.0, 0.5), (6.0, 0.2)):
        b = float(sperling_gain(f, lateral))
        assert sperling(amplitude * np.sin(2 * np.pi * f * t) + 0.3, FS, lateral) == pytest.approx(
            4.42 * (b * amplitude / math.sqrt(2)) ** 0.3, rel=1e-9
        )
    f = 1.0
    b_z = 0.588 * math.sqrt(
        (1.911 * f**2 + (0.25 * f**2) ** 2) / ((1 - 0.2777 * f**2) ** 2 + (1.563 * f - 0.0368 * f**3) ** 2)
    )
    assert float(sperling_gain(1.0, lateral)) == pytest.approx(b_z * (1.25 if lateral else 1.0), rel=1e-12)
