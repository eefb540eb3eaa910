"""Track irregularities from standard spectra: the densities' normalisation against their band
integrals, realisations against the densities (the factor-of-2 and 2π errors the users of these
spectra most often make), reproducibility, and one-line refusals."""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.integrate import quad

from rail_mj.track import TrackError
from rail_mj.track.irregularities import (
    CHANNELS,
    FADE_IN,
    SPECTRA,
    band_variance,
    check_band,
    realise,
    realised_variance,
    spectrum,
)


@pytest.mark.parametrize("name", sorted(SPECTRA))
def test_the_band_variance_is_the_integral_of_the_density(name):
    """The closed form (ERRI's alignment and level) and the quadrature (the rest) against scipy's
    adaptive quad of the same density over Ω from 2π/150 to 2π/3 rad/m: to 1e-9."""
    spec = SPECTRA[name]
    for channel in CHANNELS:
        density = lambda w, channel=channel: float(spec.density(channel, w))  # noqa: E731
        expected = quad(density, 2 * math.pi / 150, 2 * math.pi / 3, limit=200, epsabs=0.0, epsrel=1e-12)[0]
        assert band_variance(spec, channel) == pytest.approx(expected, rel=1e-9, abs=1e-20)


def test_erri_levels_are_of_the_size_practice_knows():
    """ERRI B176 over EN 13848's D1-D3 (3-150 m): rms level 2.9 mm (low) and 4.7 mm (high), the worse
    track about 1.6 times the better (sqrt(1.080e-6/4.032e-7) = 1.64), alignment likewise."""
    low, high = SPECTRA["erri-low"], SPECTRA["erri-high"]
    assert band_variance(low, "level") ** 0.5 == pytest.approx(2.863e-3, rel=1e-3)
    assert (band_variance(high, "level") / band_variance(low, "level")) ** 0.5 == pytest.approx(
        math.sqrt(1.080e-6 / 4.032e-7), rel=1e-12
    )
    assert (band_variance(high, "alignment") / band_variance(low, "alignment")) ** 0.5 == pytest.approx(
        math.sqrt(6.125e-7 / 2.119e-7), rel=1e-12
    )


@pytest.mark.parametrize("name", ["erri-low", "erri-high", "fra-4"])
def test_a_realisation_has_the_variance_of_its_density(name):
    """Without the fade, over the grid's whole period (6000 m = 40 x 150 m), a realisation's mean
    square is Σ w·S_f·Δf to round-off (Parseval: the cosines are orthogonal there), and that sum is
    the band integral to 2e-4 (the trapezoid rule at Δf = 1/6000 per m). A one-sided density read
    as two-sided, or per rad/m as per cycle/m, is off by a factor 2 or 2π."""
    spec = SPECTRA[name]
    x, values = realise(spec, 6000.0, seed=7, fade_in=0.0)
    period = slice(0, len(x) - 1)  # the last sample is the first again
    for channel in spec.channels:
        mean_square = float(np.mean(values[channel][period] ** 2))
        assert mean_square == pytest.approx(realised_variance(spec, channel, 6000.0), rel=1e-10)
        assert mean_square == pytest.approx(band_variance(spec, channel), rel=2e-4)


def test_the_same_seed_gives_the_same_track_and_channels_are_independent():
    spec = SPECTRA["erri-high"]
    _, a = realise(spec, 2000.0, seed=1)
    _, b = realise(spec, 2000.0, seed=1)
    _, c = realise(spec, 2000.0, seed=2)
    for channel in CHANNELS:
        np.testing.assert_array_equal(a[channel], b[channel])
        assert not np.allclose(a[channel], c[channel])
    # Independent streams: the channels' correlation is that of unrelated random phases.
    assert abs(np.corrcoef(a["alignment"], a["level"])[0, 1]) < 0.3


def test_a_realisation_fades_in_and_scales():
    spec = SPECTRA["erri-low"]
    x, faded = realise(spec, 1500.0, seed=3)
    _, doubled = realise(spec, 1500.0, seed=3, scale=2.0)
    assert faded["level"][0] == 0.0
    start = x < FADE_IN
    assert np.max(np.abs(faded["level"][start])) < np.max(np.abs(faded["level"][~start]))
    np.testing.assert_allclose(doubled["level"], 2.0 * faded["level"], rtol=0, atol=1e-15)
    assert x[-1] == pytest.approx(1500.0) and np.all(np.diff(x) <= 0.3 + 1e-12)


def test_fra_classes_give_level_and_alignment_and_a_better_class_is_smoother():
    """Class 6 is the best track: its level varies less than class 1's; cross level and gauge are
    not in the FRA family and are zero."""
    assert band_variance(SPECTRA["fra-6"], "level") < band_variance(SPECTRA["fra-1"], "level")
    _, values = realise(SPECTRA["fra-5"], 600.0)
    assert not values["cross_level"].any() and not values["gauge"].any()
    assert values["level"].any()


@pytest.mark.parametrize(
    "call, says",
    [
        (lambda: spectrum("erri-medium"), "irregularities.spectrum: must be one of"),
        (lambda: check_band([150.0, 3.0]), "irregularities.wavelengths: need"),
        (lambda: check_band([0.1, 3.0]), "irregularities.wavelengths: need"),
        (lambda: check_band("3-150"), "irregularities.wavelengths: give [shortest, longest]"),
        (lambda: realise(SPECTRA["erri-low"], -5.0), "length must be positive"),
        (lambda: realise(SPECTRA["erri-low"], 100.0, scale=math.nan), "irregularities.scale"),
        (lambda: SPECTRA["erri-low"].density("twist", 1.0), "channel must be one of"),
    ],
)
def test_what_makes_no_irregularity_is_refused_in_one_line(call, says):
    with pytest.raises(TrackError, match=None) as caught:
        call()
    message = str(caught.value)
    assert says in message and "\n" not in message
