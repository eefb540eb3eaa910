"""Butterworth filters in second-order sections, run forwards and backwards, and the
periodogram's peak: what EN 14363's running-instability criterion needs of a run.

These are scipy.signal's `butter(..., output="sos")`, `sosfiltfilt` (odd padding of
3 x (2 x sections + 1) samples, each pass started from its steady state) and `periodogram`
(constant detrend, boxcar window), written out because every `rail-mj run` summarises its
motion with them and importing scipy.signal costs half a second (scipy 1.17 parses the
docstring of each of its functions at import). `tests/analysis/test_filters.py` holds them to
scipy's to round-off. The recursion is compiled with numba, which a run has loaded already.

Example:

    >>> import numpy as np
    >>> sos = butterworth_sos(4, (1.5, 5.5), fs=1000.0)
    >>> sos.shape
    (4, 6)
"""

from __future__ import annotations

import math

import numba
import numpy as np


def butterworth_sos(order: int, band: float | tuple[float, float], fs: float) -> np.ndarray:
    """A digital Butterworth low-pass (`band` its corner, Hz) or band-pass (`band` its two
    edges, Hz) of `order` poles (twice that for a band-pass) at sampling rate fs, as
    second-order sections [b0, b1, b2, 1, a1, a2], the gain in the first.

    The analog prototype's poles on the unit circle, shifted to the corners pre-warped for the
    bilinear transform (Oppenheim and Schafer, Discrete-Time Signal Processing, 7.1), then
    mapped to z = (4 + s) / (4 - s) on the half-sample scale scipy uses (fs = 2). An even
    order only (EN 14363's is 4): its poles come in conjugate pairs, a section each.
    """
    if order < 2 or order % 2:
        raise ValueError(f"a Butterworth filter of even order is made here, not order {order}")
    edges = np.atleast_1d(np.asarray(band, dtype=float))
    warped = 4.0 * np.tan(math.pi * (2.0 * edges / fs) / 2.0)
    prototype = -np.exp(1j * math.pi * np.arange(-order + 1, order, 2) / (2 * order))
    if len(edges) == 1:
        poles = prototype * warped[0]
        zeros_at_origin = 0
        gain = warped[0] ** order
    else:
        width = warped[1] - warped[0]
        centre2 = warped[0] * warped[1]
        half = prototype * width / 2.0
        root = np.sqrt(half**2 - centre2)
        poles = np.concatenate([half + root, half - root])
        zeros_at_origin = order
        gain = width**order
    # The bilinear transform: an s-plane zero at 0 goes to z = 1, one at infinity to z = -1.
    z_poles = (4.0 + poles) / (4.0 - poles)
    gain *= np.real(4.0**zeros_at_origin / np.prod(4.0 - poles))
    upper = np.sort_complex(z_poles[z_poles.imag > 0])  # conjugate pairs: one section each
    sections = np.zeros((len(upper), 6))
    for i, p in enumerate(upper):
        if zeros_at_origin:
            sections[i, :3] = (1.0, 0.0, -1.0)  # (z - 1)(z + 1)
        else:
            sections[i, :3] = (1.0, 2.0, 1.0)  # (z + 1)^2
        sections[i, 3:] = (1.0, -2.0 * p.real, abs(p) ** 2)
    sections[0, :3] *= gain
    return sections


def _steady_state(sos: np.ndarray) -> np.ndarray:
    """Each section's transposed direct-form state for a unit step held forever: the state
    a pass starts from, scaled by the first sample (scipy's sosfilt_zi)."""
    zi = np.empty((len(sos), 2))
    scale = 1.0
    for i, (b0, b1, b2, _, a1, a2) in enumerate(sos):
        # (I - A) z = B - A_col b0 for the companion form of [1, a1, a2].
        rhs = np.array([b1 - a1 * b0, b2 - a2 * b0])
        zi[i] = scale * np.linalg.solve(np.array([[1.0 + a1, -1.0], [a2, 1.0]]), rhs)
        scale *= (b0 + b1 + b2) / (1.0 + a1 + a2)
    return zi


@numba.njit(cache=True)
def _sosfilt(sos: np.ndarray, x: np.ndarray, zi: np.ndarray) -> np.ndarray:
    """Second-order sections, transposed direct form II, down axis 0 of x; zi[s] times the
    first row starts section s."""
    y = x.copy()
    for c in range(x.shape[1]):
        for s in range(sos.shape[0]):
            b0, b1, b2, a1, a2 = sos[s, 0], sos[s, 1], sos[s, 2], sos[s, 4], sos[s, 5]
            z0 = zi[s, 0] * x[0, c]
            z1 = zi[s, 1] * x[0, c]
            for n in range(x.shape[0]):
                v = y[n, c]
                out = b0 * v + z0
                z0 = b1 * v - a1 * out + z1
                z1 = b2 * v - a2 * out
                y[n, c] = out
    return y


def sosfiltfilt(sos: np.ndarray, x: np.ndarray) -> np.ndarray:
    """`sos` run forwards and then backwards down axis 0 of x (no phase shift), x extended at
    each end by its point reflection over 3 x (2 x sections + 1) samples, as scipy.signal's
    sosfiltfilt with its defaults."""
    x = np.asarray(x, dtype=float)
    shape = x.shape
    flat = x.reshape(len(x), -1)
    # scipy counts a section's trailing zero coefficients out of the filter's length: none here.
    pad = 3 * (2 * len(sos) + 1 - min(int(np.sum(sos[:, 2] == 0)), int(np.sum(sos[:, 5] == 0))))
    if len(flat) <= pad:
        raise ValueError(f"the signal has {len(flat)} samples, the filter needs more than {pad}")
    extended = np.concatenate([2 * flat[0] - flat[pad:0:-1], flat, 2 * flat[-1] - flat[-2 : -(pad + 2) : -1]])
    zi = _steady_state(sos)
    forwards = _sosfilt(sos, extended, zi)
    backwards = _sosfilt(sos, np.ascontiguousarray(forwards[::-1]), zi)[::-1]
    return backwards[pad:-pad].reshape(shape)


def periodogram(signal: np.ndarray, fs: float) -> tuple[np.ndarray, np.ndarray]:
    """Frequencies (Hz) and one-sided power spectral density of each column of `signal`
    (samples along axis 0) about its mean, boxcar window: scipy.signal.periodogram's defaults."""
    x = np.asarray(signal, dtype=float)
    n = len(x)
    spectrum = np.fft.rfft(x - x.mean(axis=0), axis=0)
    power = np.abs(spectrum) ** 2 / (fs * n)
    # One-sided: every bin but the mean (and the Nyquist bin of an even length) counted twice.
    power[1 : n // 2 + 1 if n % 2 else n // 2] *= 2.0
    return np.fft.rfftfreq(n, 1.0 / fs), power
