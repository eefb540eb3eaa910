"""The frequency response to track irregularities (rail_mj.analysis.response, docs/response.md),
against closed forms and against time-domain runs on the same rails."""

from __future__ import annotations

import numpy as np
import pytest
from conftest import DATA, MODELS, harmonic, measured_track_file

from rail_mj import load_layout, simulate
from rail_mj.analysis.response import Response
from rail_mj.track import load_track
from rail_mj.track.irregularities import CHANNELS, SPECTRA, line_grid, realise

WHEELSET = MODELS / "wheelset" / "wheelset.toml"
COACH = MODELS / "manchester-coach" / "manchester-coach.toml"
SPATIAL = DATA / "manchester-coach-spatial.toml"  # cones and linear creep: a linear vehicle


@pytest.fixture(scope="module")
def spatial() -> Response:
    return Response(load_layout(SPATIAL), 30.0)


def test_the_restrained_wheelset_answers_as_its_two_equations():
    """The restrained wheelset of docs/creep.md on an alignment a(s): relative to its rails the
    lateral creepage is unchanged and a enters only through the rolling-radius difference, so

        (-m w^2 + i w 2 f22/V) y - 2 f22 psi = 0
        c y + (-I w^2 + i w 2 f11 b^2/V + k_psi) psi = c a,    c = 2 f11 b lam / r0

    at w = 2 pi V / L. The linearisation differences a linear law in the callback's own splines:
    it is that solve to round-off (1e-15 measured)."""
    layout = load_layout(WHEELSET)
    w, c = layout.wheelset, layout.creep
    speed = 30.0
    response = Response(layout, speed)
    assert response.inputs == ("alignment", "gauge")
    m, inertia, r0, b, lam = w.mass, w.inertia[2], w.rolling_radius, w.contact_half_spacing, w.conicity
    coupling = 2 * c.f11 * b * lam / r0
    wavelengths = np.array([6.0, 15.0, 40.0, 300.0])
    h = response.transfer("alignment", speed / wavelengths)
    for k, wavelength in enumerate(wavelengths):
        omega = 2 * np.pi * speed / wavelength
        system = np.array(
            [
                [-m * omega**2 + 1j * omega * 2 * c.f22 / speed, -2 * c.f22],
                [coupling, -inertia * omega**2 + 1j * omega * 2 * c.f11 * b**2 / speed + layout.primary.yaw_stiffness],
            ]
        )
        expected = np.linalg.solve(system, np.array([0.0, coupling]))
        got = h[k, [response.outputs.index("y1"), response.outputs.index("psi1")]]
        np.testing.assert_allclose(got, expected, rtol=1e-9)
    # A symmetric vehicle about its centred state answers a gauge change only in second order.
    assert np.abs(response.transfer("gauge", [0.5, 2.0, 8.0])).max() == 0.0


@pytest.mark.parametrize(
    "channel, wavelength, outputs",
    [
        ("alignment", 20.0, ["y1", "psi1", "sum_y1", "y_carbody", "floor_lateral_centre", "floor_lateral_bogie1"]),
        ("level", 15.0, ["q_left1", "bounce_carbody", "floor_vertical_centre", "floor_vertical_bogie2"]),
        ("cross_level", 25.0, ["y1", "sum_y1", "q_left1", "y_over_q_left1", "roll_carbody", "floor_lateral_centre"]),
    ],
)
def test_a_sinusoidal_channel_gives_the_steady_amplitude_of_the_linearisation(
    tmp_path, spatial, channel, wavelength, outputs
):
    """One channel a sine of 1 mm and one wavelength, grown over 60 m, under the spatial coach at
    30 m/s: after the transients (decayed by e^-10 and more past 400 m) every output's harmonic at
    w = 2 pi V/L, amplitude and phase, is H(f)*A of the linearisation. What separates them: RK4 at
    the run's timestep, the spline of the 0.25 m samples, the floor accelerations' second differences
    at 1 kHz and second-order terms at 1 mm; 4.6e-5 of |H|*A at most measured."""
    speed, amplitude = 30.0, 1e-3
    x = np.arange(0.0, 1500.0, 0.25)
    ramp = np.where(x < 60.0, 0.5 - 0.5 * np.cos(np.pi * np.minimum(x, 60.0) / 60.0), 1.0)
    channels = {c: amplitude * np.cos(2 * np.pi * x / wavelength) * ramp * (c == channel) for c in CHANNELS}
    run = simulate(
        load_layout(SPATIAL),
        speed,
        1000.0,
        initial_lateral=0.0,
        track=load_track(measured_track_file(tmp_path, x, channels)),
    )
    names, columns = run.columns()
    column = dict(zip([n for n, _ in names], columns))
    h = spatial.transfer(channel, [speed / wavelength])[0] * amplitude
    late = run.x > 400.0
    for name in outputs:
        expected = h[spatial.outputs.index(name)]
        got = harmonic(column[name][late], run.t[late], 2 * np.pi * speed / wavelength)
        assert abs(got - expected) <= 2e-4 * abs(expected), (name, got, expected)


@pytest.mark.parametrize("path, scale", [(SPATIAL, 0.1), (COACH, 0.3)])
def test_a_run_on_generated_track_is_the_sum_of_its_lines_responses(tmp_path, path, scale):
    """An ERRI-low realisation 600 m long (all four channels, scaled to stay far inside the flange
    clearance), laid three times over, faded in over 50 m: over the second period, where every
    transient has gone (20 s), a linear vehicle's every output is, sample by sample, the sum over
    the realisation's lines of Re(H(f_j)*C_j*exp(i*Omega_j*s)), C_j the line's complex amplitude
    (the realisation's FFT), s the vehicle's station; so its variance is their sum, which for one
    channel is `realised_variance` whatever the seed. What separates them: second-order terms
    (2e-4 to 5e-3 of the rms measured, proportional to the amplitude) and the spline's curvature
    at the shortest waves, which the wheel loads take as m*V^2*z'' (4e-3 of q's rms measured)."""
    layout = load_layout(path)
    speed, length = 30.0, 600.0
    spec = SPECTRA["erri-low"]
    x, lines = realise(spec, length, seed=3, scale=scale, fade_in=0.0)
    n = round(length / (x[1] - x[0]))
    laid = np.arange(3 * n + 1) * (x[1] - x[0])
    fade = 0.5 - 0.5 * np.cos(np.pi * np.clip(laid / 50.0, 0.0, 1.0))
    channels = {c: fade * np.tile(lines[c][:n], 4)[: len(laid)] for c in CHANNELS}
    run = simulate(
        layout,
        speed,
        2 * length + 1.0,
        initial_lateral=0.0,
        track=load_track(measured_track_file(tmp_path, laid, channels)),
    )
    response = Response(layout, speed)
    period, f, _ = line_grid(length, (3.0, 150.0))
    assert period == length
    j = np.rint(f * period).astype(int)
    window = (run.station >= length - 1e-9) & (run.station < 2 * length - 1e-9)
    s = run.station[window]
    predicted = np.zeros((len(s), len(response.outputs)))
    for c in response.inputs:
        amplitudes = 2.0 * np.fft.fft(lines[c][:n])[j] / n  # the line's c_j: its value is Re(c_j e^(i Omega s))
        h = response.transfer(c, speed * f)
        predicted += np.real(np.exp(1j * 2 * np.pi * np.outer(s, f)) @ (amplitudes[:, None] * h))
    names, columns = run.columns()
    column = dict(zip([n for n, _ in names], columns))
    checked = 0
    for k, name in enumerate(response.outputs):
        expected = predicted[:, k]
        rms = np.sqrt(np.mean(expected**2))
        if rms == 0.0:  # a vertical output of a planar vehicle, or a gauge-only one
            continue
        got = column[name][window] - column[name][window].mean()
        assert np.sqrt(np.mean((got - expected) ** 2)) <= 1e-2 * rms, name
        checked += 1
    assert checked >= 7
    # Each channel's lines, summed as `realised_variance` sums them, give the prediction's variance
    # when it is the only channel (Parseval over the period): for alignment, alone in a planar
    # vehicle's lateral motion when the gauge answers nothing.
    alone = response.realised_variance(spec, length, scale=scale, channels=["alignment"])["alignment"]
    h = response.transfer("alignment", speed * f)
    amplitudes = 2.0 * np.fft.fft(lines["alignment"][:n])[j] / n
    lines_variance = ((np.abs(amplitudes[:, None] * h) ** 2) / 2).sum(axis=0)
    np.testing.assert_allclose(alone, lines_variance, rtol=1e-9)


def test_the_stochastic_integral_is_the_limit_of_the_realisations_lines(spatial):
    """`variance` integrates |H|^2 S over the band on RMS_POINTS of log(Omega); a realisation 20 km
    long has lines 5e-5 1/m apart, and their sum (`realised_variance`) is the trapezoid rule of the
    same integral: the two agree to the quadratures' error (1e-5 measured, every spectrum's channel)."""
    for name in ("erri-high", "fra-4"):
        integral = spatial.variance(SPECTRA[name])
        lines = spatial.realised_variance(SPECTRA[name], 20_000.0)
        assert set(integral) == set(SPECTRA[name].channels) & set(spatial.inputs)
        for c, v in integral.items():
            if c == "gauge":  # no linear response to it (test_the_restrained_wheelset_...)
                assert v.max() == lines[c].max() == 0.0
                continue
            some = v > 1e-12 * v.max()
            assert some.sum() >= 5
            np.testing.assert_allclose(v[some], lines[c][some], rtol=5e-5)


def test_inputs_and_outputs_a_vehicle_does_not_have_are_refused():
    response = Response(load_layout(COACH), 40.0)
    assert response.inputs == ("alignment", "gauge")
    with pytest.raises(ValueError, match="takes alignment, gauge"):
        response.transfer("level", [1.0])
    with pytest.raises(ValueError, match="no output 'q_left1'"):
        response.select(["q_left1"])
    assert response.select(["y[0-9]*", "floor_*"]) == [
        "y1",
        "y2",
        "y3",
        "y4",
        "floor_lateral_bogie1",
        "floor_lateral_bogie2",
        "floor_lateral_centre",
    ]
    with pytest.raises(ValueError, match="frequencies must be positive"):
        response.transfer("alignment", [0.0])


def test_above_the_critical_speed_there_is_no_steady_response():
    """The planar coach's eigen critical speed is 79.3 m/s (README): at 40 m/s every mode decays, at
    150 m/s one grows, and a transfer function there, the response of a system that does not settle,
    is refused."""
    from rail_mj.analysis.stability import Stability

    layout = load_layout(COACH)
    assert Response(layout, 40.0).growth < 0.0
    fast = Response(layout, 150.0)
    assert fast.growth == pytest.approx(Stability(layout).max_real_part(150.0), rel=1e-6)
    assert fast.growth > 0.0
    with pytest.raises(ValueError, match="unstable at 150 m/s"):
        fast.transfer("alignment", [1.0])
    with pytest.raises(ValueError, match="unstable at 150 m/s"):
        fast.variance(SPECTRA["erri-low"])
