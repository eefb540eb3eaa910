"""rail-mj's Butterworth band-pass, zero-phase filter and periodogram are scipy.signal's
(written out to spare every run scipy.signal's import), to round-off."""

from __future__ import annotations

import numpy as np
import pytest
from scipy import signal

from rail_mj.analysis.filters import butterworth_sos, periodogram, sosfiltfilt

# (order, band, fs): EN 14363's band around a bogie's and a car body's hunting at a run's
# rates (1 kHz and 1/0.579 ms), its low-pass for f0 <= 2 Hz, and coarse samples.
CASES = [
    (4, (1.5, 5.5), 1000.0),
    (4, (6.0, 10.0), 1727.1),
    (4, 3.2, 1000.0),
    (4, (3.0, 7.0), 50.0),
    (2, (0.5, 4.0), 200.0),
    (6, 12.0, 100.0),
]


def _response(sos: np.ndarray, f: np.ndarray, fs: float) -> np.ndarray:
    return signal.sosfreqz(sos, worN=f, fs=fs)[1]


@pytest.mark.parametrize("order,band,fs", CASES)
def test_butterworth_is_scipys_filter(order, band, fs):
    """The same transfer function at every frequency (the sections may pair differently):
    |H - H_scipy| at most 1e-9 of the passband's unit gain, at 2,000 frequencies to Nyquist."""
    ours = butterworth_sos(order, band, fs)
    kind = "lowpass" if np.isscalar(band) else "bandpass"
    theirs = signal.butter(order, band, btype=kind, fs=fs, output="sos")
    assert ours.shape == theirs.shape
    f = np.linspace(0.0, fs / 2, 2000)
    assert np.max(np.abs(_response(ours, f, fs) - _response(theirs, f, fs))) < 1e-9


@pytest.mark.parametrize("order,band,fs", CASES)
def test_zero_phase_filtering_is_scipys(order, band, fs):
    """A noisy growing oscillation in three columns: the filtered signal matches scipy's
    sosfiltfilt to 1e-9 of its largest value (the recursion's round-off through poles within
    1e-2 of the unit circle)."""
    rng = np.random.default_rng(7)
    t = np.arange(20000) / fs
    x = np.column_stack(
        [np.exp(0.05 * t) * np.sin(2 * np.pi * k * t) + rng.normal(size=len(t)) for k in (3.5, 8.0, 1.0)]
    )
    x += 0.7  # a mean: the odd extension and the steady start carry it
    kind = "lowpass" if np.isscalar(band) else "bandpass"
    ours = sosfiltfilt(butterworth_sos(order, band, fs), x)
    theirs = signal.sosfiltfilt(signal.butter(order, band, btype=kind, fs=fs, output="sos"), x, axis=0)
    assert np.max(np.abs(ours - theirs)) < 1e-9 * np.max(np.abs(theirs))
    one = sosfiltfilt(butterworth_sos(order, band, fs), x[:, 0])
    assert one.shape == (len(t),) and np.array_equal(one, ours[:, 0])


def test_odd_orders_are_refused():
    with pytest.raises(ValueError, match="even order"):
        butterworth_sos(3, 12.0, 100.0)


def test_too_short_a_signal_is_refused():
    with pytest.raises(ValueError, match="needs more than 27"):
        sosfiltfilt(butterworth_sos(4, (1.0, 5.0), 100.0), np.ones(27))


@pytest.mark.parametrize("n", [1, 2, 7, 1000, 1001])
def test_periodogram_is_scipys(n):
    rng = np.random.default_rng(n)
    x = rng.normal(size=(n, 2)) + 3.0
    f, p = periodogram(x, fs=250.0)
    f_s, p_s = signal.periodogram(x, fs=250.0, axis=0)
    assert np.allclose(f, f_s, rtol=1e-15, atol=0)
    assert np.allclose(p, p_s, rtol=1e-12, atol=1e-14 * np.max(np.abs(p_s)))


def test_the_c_recursion_is_numbas_to_the_bit():
    """The filters' recursion in C (the installation's library) rounds as numba's: no fused
    multiply-adds, the same operations in the same order."""
    from rail_mj.analysis import filters

    rng = np.random.default_rng(3)
    x = rng.standard_normal((4000, 3))
    sos = filters.butterworth_sos(4, (1.5, 5.5), fs=200.0)
    zi = filters._steady_state(sos)
    assert filters._library() is not None
    native, compiled = filters._sosfilt(sos, x, zi), filters._sosfilt(sos, x, zi, native=False)
    assert np.any(native != x)
    np.testing.assert_array_equal(native, compiled)


@pytest.mark.parametrize("n", [16667, 20011, 4096])  # a large prime factor (Bluestein), a prime, a power of 2
def test_the_wheelsets_spectra_taken_together_are_each_ones_own(monkeypatch, n):
    """EN 14363's f0 takes a short run's wheelsets' spectra in one FFT call: each column's power
    is the one it has alone, bit for bit, and so is the f0 of their sum."""
    from rail_mj.analysis import en14363

    rng = np.random.default_rng(n)
    t = np.arange(n) * 1e-3
    columns = [np.sin(2 * np.pi * (3.0 + k) * t) + rng.normal(scale=0.5, size=n) for k in range(4)]
    rows = np.stack([c - c.mean() for c in columns])
    _, together = periodogram(rows.T, fs=1000.0, centred=True)
    for k, column in enumerate(columns):
        assert np.array_equal(together[:, k], periodogram(column, fs=1000.0)[1])
    short = en14363._dominant(t, iter(columns))
    monkeypatch.setattr(en14363, "_TOGETHER", 0)  # every run long: a column at a time
    assert en14363._dominant(t, iter(columns)) == short
