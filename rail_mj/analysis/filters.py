"""Butterworth filters in second-order sections, run forwards and backwards, and the
periodogram's peak: what EN 14363's running-instability criterion needs of a run.

These are scipy.signal's `butter(..., output="sos")`, `sosfiltfilt` (odd padding of
3 x (2 x sections + 1) samples, each pass started from its steady state) and `periodogram`
(constant detrend, boxcar window), written out because every `rail-mj run` summarises its
motion with them and importing scipy.signal costs half a second (scipy 1.17 parses the
docstring of each of its functions at import). `tests/analysis/test_filters.py` holds them to
scipy's to round-off. The recursion is C, built once per installation (rail_mj.compiled), so that
a run's summary needs no numba; numba compiles it where no C compiler is found.

Example:

    >>> import numpy as np
    >>> sos = butterworth_sos(4, (1.5, 5.5), fs=1000.0)
    >>> sos.shape
    (4, 6)
"""

from __future__ import annotations

import ctypes
import functools
import math

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


# `_sosfilt_numba`'s recursion in C, in place on a C-ordered (n, columns) array.
_C_SOURCE = """/* Written by rail_mj.analysis.filters. */
#include <stdint.h>

void rail_mj_sosfilt(const double *sos, int64_t sections, const double *zi, double *y, int64_t n,
                     int64_t columns) {
    for (int64_t c = 0; c < columns; c++) {
        double first = y[c];
        for (int64_t s = 0; s < sections; s++) {
            double b0 = sos[6 * s], b1 = sos[6 * s + 1], b2 = sos[6 * s + 2];
            double a1 = sos[6 * s + 4], a2 = sos[6 * s + 5];
            double z0 = zi[2 * s] * first, z1 = zi[2 * s + 1] * first;
            for (int64_t i = 0; i < n; i++) {
                double v = y[i * columns + c];
                double out = b0 * v + z0;
                z0 = b1 * v - a1 * out + z1;
                z1 = b2 * v - a2 * out;
                y[i * columns + c] = out;
            }
        }
    }
}
"""


@functools.cache
def _library() -> ctypes.CDLL | None:
    from rail_mj import compiled

    library = compiled.load("filters", "", _C_SOURCE)
    if library is not None:
        i64, v = ctypes.c_int64, ctypes.c_void_p
        library.rail_mj_sosfilt.argtypes = (v, i64, v, v, i64, i64)
        library.rail_mj_sosfilt.restype = None
    return library


@functools.cache
def _sosfilt_numba():
    import numba

    @numba.njit(cache=True)
    def sosfilt(sos, x, zi):
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

    return sosfilt


def _sosfilt(sos: np.ndarray, x: np.ndarray, zi: np.ndarray, native: bool = True) -> np.ndarray:
    """Second-order sections, transposed direct form II, down axis 0 of x (2-D); zi[s] times the
    first row starts section s. `native`: the C library's (else numba's, as where it cannot be built)."""
    library = _library() if native else None
    if library is None:
        return _sosfilt_numba()(sos, x, zi)
    sos, zi = np.ascontiguousarray(sos, dtype=float), np.ascontiguousarray(zi, dtype=float)
    y = np.array(x, dtype=float, order="C")
    library.rail_mj_sosfilt(sos.ctypes.data, len(sos), zi.ctypes.data, y.ctypes.data, y.shape[0], y.shape[1])
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


def periodogram(signal: np.ndarray, fs: float, centred: bool = False) -> tuple[np.ndarray, np.ndarray]:
    """Frequencies (Hz) and one-sided power spectral density of each column of `signal`
    (samples along axis 0) about its mean, boxcar window: scipy.signal.periodogram's defaults.
    `centred`: the columns are given less their means already."""
    x = np.asarray(signal, dtype=float)
    n = len(x)
    spectrum = np.fft.rfft(x if centred else x - x.mean(axis=0), axis=0)
    power = np.abs(spectrum) ** 2 / (fs * n)
    # One-sided: every bin but the mean (and the Nyquist bin of an even length) counted twice.
    power[1 : n // 2 + 1 if n % 2 else n // 2] *= 2.0
    return np.fft.rfftfreq(n, 1.0 / fs), power
