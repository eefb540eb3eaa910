"""Frequency response to track irregularities: transfer functions from the linearisation, and the
stochastic rms response to a track spectrum (docs/response.md).

About the centred state at speed V the vehicle on irregular track is linear,

    x' = A x + B u,    y = C0 x + C2 q'' + D u,

x = [qpos, qvel] its state, u the rails under its wheelsets (per wheelset what the native callback
reads, rail_mj.vehicle.rails.rails_at: the alignment and its slope, the gauge, the level and its
slope and curvature, the rails' roll and its slope and curvature), y the outputs a run records
(its CSV's columns: wheelsets' and frames' motion, wheel forces, Y/Q) and the car body's floor
accelerations, which read its displacements twice differentiated (C2) and gravity tilted by its
roll (C0). All four matrices are central differences of MuJoCo's forward dynamics with the native
callback installed and of a `Run` made of the perturbed states, as rail_mj.simulation.linear makes
A: the inputs are perturbed through the callback's own splines (a probe irregularity, one spline
interval under each wheelset), so the response is the model's, not a re-derivation.

A channel c of one spatial frequency, c(s) = exp(i*Omega*s) along the track, reaches wheelset i at
its place x_i ahead of the vehicle's origin as exp(i*Omega*x_i)*exp(i*omega*t), omega = V*Omega,
with its slope i*Omega and curvature -Omega^2 times that, so

    H_c(omega) = (C0 - omega^2 C2) (i*omega - A)^-1 B U_c(Omega) + D U_c(Omega)

per metre of the channel. Under a spectrum S_c(Omega) (one-sided, m^2 per rad/m,
rail_mj.track.irregularities) of independent channels, the output's variance is
sum_c integral |H_c(V*Omega)|^2 S_c(Omega) dOmega over the band of wavelengths kept; over one
period of a realisation, whose lines are known, it is the sum over those lines.

Example:

    >>> from rail_mj import load_layout
    >>> r = Response(load_layout("models/wheelset/wheelset.toml"), 30.0)
    >>> r.inputs, r.outputs[:3]
    (('alignment', 'gauge'), ('y1', 'psi1', 'sum_y1'))
    >>> h = r.transfer("alignment", [0.1, 2.0])  # Hz: a 300 m wave carries the wheelset with the rails,
    >>> [round(float(g), 3) for g in abs(h[:, r.outputs.index("y1")])]  # a 15 m one near its hunting frequency
    [1.001, 2.264]
"""

from __future__ import annotations

import dataclasses
import fnmatch
import math

import mujoco
import numpy as np

from rail_mj.analysis.stability import NEUTRAL, linearised_contact
from rail_mj.layout import Layout
from rail_mj.numerics import IRREGULAR_HEADER, SPLINE
from rail_mj.simulation.linear import FD_STEP, modal_roots
from rail_mj.simulation.run import Run
from rail_mj.track import Track
from rail_mj.track.irregularities import (
    CHANNELS,
    DEFAULT_BAND,
    RAIL_BASE,
    Irregularities,
    Spectrum,
    check_band,
    line_grid,
)
from rail_mj.units import GRAVITY
from rail_mj.vehicle.block import set_speed
from rail_mj.vehicle.curve import ODOMETER
from rail_mj.vehicle.rails import (
    ALIGNMENT,
    ALIGNMENT_SLOPE,
    GAUGE,
    LEVEL,
    LEVEL_CURVATURE,
    LEVEL_SLOPE,
    RAILS,
    ROLL,
    ROLL_CURVATURE,
    ROLL_SLOPE,
    Rails,
)
from rail_mj.vehicle.sensors import Sensors
from rail_mj.vehicle.spec import Vehicle

# The channels a planar vehicle takes (rail_mj.vehicle.rails): it has no vertical motion.
LATERAL_CHANNELS = ("alignment", "gauge")
# m: the probe irregularity's spline interval. Less than any two wheelsets' spacing (1.8 m and more
# in practice), so that each wheelset reads an interval of its own.
PROBE_STEP = 0.25
# m: the probe track beyond the vehicle's ends.
PROBE_MARGIN = 5.0
# The entries of rails_at a channel feeds, with the power of i*Omega each carries (value, slope,
# curvature) and the factor from the channel's metres (cross level is a height over the rail base;
# the rails' roll its angle).
FEEDS = {
    "alignment": ((ALIGNMENT, 0, 1.0), (ALIGNMENT_SLOPE, 1, 1.0)),
    "gauge": ((GAUGE, 0, 1.0),),
    "level": ((LEVEL, 0, 1.0), (LEVEL_SLOPE, 1, 1.0), (LEVEL_CURVATURE, 2, 1.0)),
    "cross_level": ((ROLL, 0, 1 / RAIL_BASE), (ROLL_SLOPE, 1, 1 / RAIL_BASE), (ROLL_CURVATURE, 2, 1 / RAIL_BASE)),
}
# Each entry of rails_at: its channel's coefficients in the spline (c0..c3 at 4*index, CHANNELS
# order), its order of derivative, and the channel's metres per unit of the entry.
ENTRIES = {
    ALIGNMENT: (0, 0, 1.0),
    ALIGNMENT_SLOPE: (0, 1, 1.0),
    LEVEL: (1, 0, 1.0),
    LEVEL_SLOPE: (1, 1, 1.0),
    LEVEL_CURVATURE: (1, 2, 1.0),
    ROLL: (2, 0, RAIL_BASE),
    ROLL_SLOPE: (2, 1, RAIL_BASE),
    ROLL_CURVATURE: (2, 2, RAIL_BASE),
    GAUGE: (3, 0, 1.0),
}
# Columns of a run that are not responses: time and place, the track under it (the inputs
# themselves), the flanges (clear about the centred state: no linear response), the speed, and
# the floor's accelerations (differenced in time there, made from the floor's motion here).
NOT_OUTPUTS = (
    "t",
    "x",
    "curvature*",
    "cant*",
    "alignment*",
    "level*",
    "cross_level*",
    "gauge*",
    "flange*",
    "floor_*",
    "speed",
)
# Points of the stochastic integral over log(Omega): a lightly damped mode's peak (damping
# ratio 0.02, relative width 0.04) is then spanned by ~40 of them over a band of 50:1.
RMS_POINTS = 4001


@dataclasses.dataclass(frozen=True)
class Output:
    """One response: its name (a run's CSV column, or floor_lateral_<point>/floor_vertical_<point>)
    and its unit (as the CSV writes them: m, rad, n, m_per_s2, "" for a ratio)."""

    name: str
    unit: str

    @property
    def gain_unit(self) -> str:
        """The unit of its transfer function, per metre of irregularity."""
        return f"{self.unit}_per_m" if self.unit else "per_m"


class Response:
    """A vehicle's frequency response to each irregularity channel at `speed` (m/s), linearised
    about the centred state (on profiles at the lateral amplitude `amplitude`, mm, as `Stability`).

    `inputs`: the channels the vehicle takes (a planar one the lateral ones); `outputs`: the names of
    what responds, in order; `transfer(channel, frequencies)` the complex gains (frequencies, outputs)
    per metre of the channel; `variance(spectrum, band)` each channel's share of every output's
    variance under a spectrum, `realised_variance` the same over one realisation's lines. A vehicle
    linearised above its critical speed has no steady response: both refuse it (`growth`). See the
    module's docstring for the example.
    """

    def __init__(self, layout: Layout, speed: float, amplitude: float | None = None):
        if not (math.isfinite(speed) and speed > 0.0):
            raise ValueError(f"speed must be a positive number, got {speed}")
        self.layout, self.speed = layout, float(speed)
        layout, self.amplitude = linearised_contact(layout, amplitude)
        if layout.spatial is not None and not layout.spatial.gravity:
            raise ValueError(
                f"{layout.source}: a spatial vehicle without gravity takes no irregularities (its wheel loads, "
                f"which the rails' level and cross level change, come from its suspension's weight): set "
                f"[spatial] gravity = true"
            )
        self.inputs = CHANNELS if layout.spatial is not None else LATERAL_CHANNELS
        reach = np.asarray(layout.wheelset_x, dtype=float)
        # The vehicle's origin on the probe track, m: half an interval off the knots for a wheelset
        # at a whole number of intervals from it, so that no rounding picks its neighbour's.
        self._start = PROBE_MARGIN + PROBE_STEP / 2 - float(reach.min())
        length = self._start + float(reach.max()) + PROBE_MARGIN
        x = np.arange(0.0, length + PROBE_STEP / 2, PROBE_STEP)
        zero = tuple(0.0 for _ in x)
        probe = Irregularities(file="<probe>", measured=(tuple(x), zero, zero, zero, zero))
        self.vehicle = Vehicle(layout, dataclasses.replace(Track.straight(float(x[-1])), irregularities=probe))
        model = self.vehicle.model
        set_speed(model, self.speed)
        self.model, self.data = model, mujoco.MjData(model)
        self._growth: float | None = None
        self._linearise()

    # --- the linearisation --------------------------------------------------

    def _centre(self) -> tuple[np.ndarray, np.ndarray]:
        """The centred state on the probe track: the odometer at the vehicle's place, rolling at V."""
        model = self.model
        qpos, qvel = np.zeros(model.nq), np.zeros(model.nv)
        qpos[:] = model.qpos0
        joint = model.joint(ODOMETER)
        qpos[joint.qposadr[0]] = self._start
        qvel[joint.dofadr[0]] = self.speed
        return qpos, qvel

    def _read(self, states: list[tuple[np.ndarray, np.ndarray]]) -> tuple[np.ndarray, Run]:
        """qacc at each state, with the native callback, and a `Run` of them (a sample each), read
        by fresh sensors (the block's probe is read as it now is)."""
        from rail_mj.simulation import native

        model, data = self.model, self.data
        acc, readings = np.empty((len(states), model.nv)), np.empty((len(states), model.nsensordata))
        with native.installed():
            for n, (qpos, qvel) in enumerate(states):
                mujoco.mj_resetData(model, data)
                data.qpos[:], data.qvel[:] = qpos, qvel
                mujoco.mj_forward(model, data)
                acc[n], readings[n] = data.qacc, data.sensordata
        vehicle = self.vehicle
        n, count = len(states), vehicle.n_wheelsets
        pos, quat = np.zeros((n, model.nbody, 3)), np.tile((1.0, 0.0, 0.0, 0.0), (n, model.nbody, 1))
        rates, loads = np.empty((n, count, 2)), np.empty((n, count, 2))
        sensors = Sensors(model, vehicle.wheelset_names)
        sensors.poses(readings, pos, quat)
        sensors.rates(readings, rates)
        sensors.loads(readings, loads)
        t = np.arange(len(states), dtype=float)
        return acc, Run(vehicle, self.speed, 1.0, t, pos, quat, rates, None, loads)

    def _quantities(self, run: Run) -> tuple[list[Output], np.ndarray, np.ndarray]:
        """The run's responses (samples, outputs): as they are (C0's), and those whose second
        derivative is the output (C2's, the floor's displacements; zero for the others)."""
        names, columns = run.columns()
        outputs, plain, twice = [], [], []
        for (name, unit), column in zip(names, columns):
            if not any(fnmatch.fnmatchcase(name, p) for p in NOT_OUTPUTS):
                outputs.append(Output(name, unit))
                plain.append(column)
                twice.append(np.zeros_like(column))
        floor = run.floor_motion()
        if floor is not None:
            for k, point in enumerate(floor.names):
                outputs.append(Output(f"floor_lateral_{point}", "m_per_s2"))
                plain.append(GRAVITY * floor.roll)
                twice.append(floor.lateral[:, k])
            if floor.vertical is not None:
                for k, point in enumerate(floor.names):
                    outputs.append(Output(f"floor_vertical_{point}", "m_per_s2"))
                    plain.append(np.zeros_like(floor.roll))
                    twice.append(floor.vertical[:, k])
        return outputs, np.array(plain).T, np.array(twice).T

    def _linearise(self) -> None:
        model, h = self.model, FD_STEP
        nv = model.nv
        # Slides and hinges only (rail_mj.vehicle.joints): qpos and qvel share their indices, which
        # the floor's C2, acting on qpos's differences, takes for q''.
        assert model.nq == nv, "a vehicle with ball or free joints"
        qpos0, qvel0 = self._centre()
        states = []
        for j in range(2 * nv):
            for sign in (1.0, -1.0):
                qpos, qvel = qpos0.copy(), qvel0.copy()
                (qpos if j < nv else qvel)[j % nv] += sign * h
                states.append((qpos, qvel))
        acc, run = self._read(states)
        outputs, plain, twice = self._quantities(run)
        self._outputs = outputs
        A = np.zeros((2 * nv, 2 * nv))
        A[:nv, nv:] = np.eye(nv)
        A[nv:] = ((acc[0::2] - acc[1::2]) / (2 * h)).T
        self.A = A
        self.C0 = ((plain[0::2] - plain[1::2]) / (2 * h)).T
        self.C2 = ((twice[0::2] - twice[1::2]) / (2 * h)).T
        self.C2 = self.C2[:, :nv]
        # The inputs, each wheelset's rails entry by entry, through the probe's spline.
        rails = Rails.of(model)
        assert rails is not None
        start = int(model.numeric_adr[0]) + rails.part
        stations = self._start + np.asarray(self.vehicle.sensors.wheelset_x)
        self.wheelset_x = np.asarray(self.vehicle.sensors.wheelset_x, dtype=float)
        entries = [(i, e) for i in range(len(stations)) for e in range(RAILS)]
        self.B = np.zeros((2 * nv, len(entries)))
        self.D = np.zeros((len(outputs), len(entries)))
        intervals = [self._interval(rails, s)[0] for s in stations]
        if len(set(intervals)) < len(intervals):
            raise ValueError(f"{self.layout.source}: two wheelsets closer than {PROBE_STEP:g} m: no response for them")
        for column, (i, e) in enumerate(entries):
            interval, t = self._interval(rails, float(stations[i]))
            channel, order, metres = ENTRIES[e]
            at = start + IRREGULAR_HEADER + SPLINE * interval + 4 * channel
            # The cubic (s - s_i)^order/order! about the wheelset's station, in the interval's own t.
            poly = {0: (1.0, 0.0, 0.0, 0.0), 1: (-t, 1.0, 0.0, 0.0), 2: (t * t / 2, -t, 0.5, 0.0)}[order]
            samples = []
            for sign in (1.0, -1.0):
                model.numeric_data[at : at + 4] = sign * h * metres * np.array(poly)
                # The run's outputs now: it reads the block when asked (its rails are read once).
                acc, run = self._read([(qpos0, qvel0)])
                samples.append((acc[0], self._quantities(run)[1][0]))
            model.numeric_data[at : at + 4] = 0.0
            (acc_plus, plus), (acc_minus, minus) = samples
            self.B[nv:, column] = (acc_plus - acc_minus) / (2 * h)
            self.D[:, column] = (plus - minus) / (2 * h)

    @property
    def growth(self) -> float:
        """The largest real part of the linearisation's modal roots, 1/s (rigid-body and pure-integrator
        roots left out, rail_mj.simulation.linear.modal_roots): above zero the vehicle hunts at this
        speed, and a harmonic track has no steady response to give."""
        if self._growth is None:
            roots = modal_roots(self.A)
            # Within round-off of the imaginary axis a root is neutral (an undamped mode), not growing.
            self._growth = float(np.max(np.where(np.abs(roots.real) <= NEUTRAL * np.abs(roots), 0.0, roots.real)))
        return self._growth

    def check_stable(self) -> None:
        """ValueError, in one line, if the vehicle is unstable at its speed (`growth` above zero)."""
        if self.growth > 0.0:
            raise ValueError(
                f"{self.layout.source}: unstable at {self.speed:g} m/s (a mode grows at {self.growth:.3g} 1/s: "
                f"the critical speed is below it), so no steady response to the track exists: take a lower speed"
            )

    @staticmethod
    def _interval(rails: Rails, s: float) -> tuple[int, float]:
        """The probe's interval at station `s` and the distance into it, as rails_at finds them."""
        block, p = rails.block, rails.part
        m, x0, step = int(block[p]), block[p + 1], block[p + 2]
        i = min(int((s - x0) / step), m - 1)
        return i, s - (x0 + i * step)

    # --- what it gives ------------------------------------------------------

    @property
    def outputs(self) -> tuple[str, ...]:
        return tuple(o.name for o in self._outputs)

    def output(self, name: str) -> Output:
        return self._outputs[self.outputs.index(name)]

    def select(self, patterns, strict: bool = True) -> list[str]:
        """The outputs matching any of `patterns` (names or shell patterns: `y*`, `floor_*`), in the
        patterns' order; `strict`: ValueError naming a pattern that matches none."""
        chosen: list[str] = []
        for pattern in patterns:
            match = [n for n in self.outputs if fnmatch.fnmatchcase(n, pattern)]
            if not match and strict:
                raise ValueError(f"no output {pattern!r}: this vehicle's are {', '.join(self.outputs)}")
            chosen += [n for n in match if n not in chosen]
        return chosen

    def _drive(self, channel: str, omega: np.ndarray) -> np.ndarray:
        """U_c at spatial frequencies `omega` (rad/m): (frequencies, wheelsets*RAILS), per metre."""
        if channel not in self.inputs:
            takes = ", ".join(self.inputs)
            raise ValueError(f"input {channel!r}: this vehicle takes {takes} (a planar vehicle no vertical ones)")
        u = np.zeros((len(omega), len(self.wheelset_x), RAILS), dtype=complex)
        phase = np.exp(1j * omega[:, None] * self.wheelset_x[None, :])
        for entry, power, factor in FEEDS[channel]:
            u[:, :, entry] = factor * (1j * omega[:, None]) ** power * phase
        return u.reshape(len(omega), len(self.wheelset_x) * RAILS)

    def transfer(self, channel: str, frequencies) -> np.ndarray:
        """The complex gains of every output to `channel` (one of `inputs`) at `frequencies` (Hz, the
        vehicle's; the wavelength is V/f): (frequencies, outputs), output units per metre."""
        f = np.atleast_1d(np.asarray(frequencies, dtype=float))
        if not (np.all(np.isfinite(f)) and np.all(f > 0.0)):
            raise ValueError("frequencies must be positive numbers")
        self.check_stable()
        omega = 2.0 * np.pi * f
        u = self._drive(channel, omega / self.speed)
        n = self.A.shape[0]
        nv = n // 2
        out = np.empty((len(f), len(self._outputs)), dtype=complex)
        for k, w in enumerate(omega):
            x = np.linalg.solve(1j * w * np.eye(n) - self.A, self.B @ u[k])
            out[k] = self.C0 @ x - w * w * (self.C2 @ x[:nv]) + self.D @ u[k]
        return out

    def variance(
        self, spectrum: Spectrum, band=DEFAULT_BAND, scale: float = 1.0, channels=None
    ) -> dict[str, np.ndarray]:
        """Each channel's share of every output's variance (outputs,) under `spectrum` (`scale` times
        its amplitude) over `band` (wavelengths, m): the integral of |H_c|^2 S_c over Omega, by the
        trapezoid rule on RMS_POINTS of log(Omega). `channels`: those to take (default: `inputs`
        that the spectrum gives)."""
        short, long = check_band(band)
        log = np.linspace(math.log(2 * math.pi / long), math.log(2 * math.pi / short), RMS_POINTS)
        omega = np.exp(log)
        out = {}
        for c in self._channels(spectrum, channels):
            gain = np.abs(self.transfer(c, self.speed * omega / (2 * np.pi))) ** 2
            weight = (scale**2 * spectrum.density(c, omega) * omega)[:, None]
            out[c] = np.trapezoid(gain * weight, log, axis=0)
        return out

    def realised_variance(
        self, spectrum: Spectrum, length: float, band=DEFAULT_BAND, scale: float = 1.0, channels=None
    ):
        """`variance` over one period of a realisation of `length` m (rail_mj.track.irregularities.realise):
        the sum over its lines of |H_c|^2 times each line's variance, what a linear vehicle's steady
        response has over that period whatever the seed."""
        period, f, w = line_grid(length, band)
        out = {}
        for c in self._channels(spectrum, channels):
            lines = scale**2 * w * 2.0 * np.pi * spectrum.density(c, 2.0 * np.pi * f) / period
            gain = np.abs(self.transfer(c, self.speed * f)) ** 2
            out[c] = (gain * lines[:, None]).sum(axis=0)
        return out

    def _channels(self, spectrum: Spectrum, channels) -> list[str]:
        chosen = list(self.inputs if channels is None else channels)
        for c in chosen:
            self._drive(c, np.zeros(0))  # refused here if the vehicle does not take it
        return [c for c in chosen if c in spectrum.channels]
