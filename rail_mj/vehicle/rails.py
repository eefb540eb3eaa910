"""The rails under each wheelset of an irregular track: the irregularity part of the native block
and its kernels (docs/irregularities.md, "In a run").

A track's irregularities (rail_mj.track.irregularities) move the rails under every wheelset at
its own station along the track, the trailing wheelsets meeting the same rails later. What each
wheelset sees, with a the alignment, g the gauge's departure, z the level and c the cross level at
its station s, and V its speed (each channel a cubic spline in s, so that its slope and curvature
are continuous where RK4 samples them):

- the contact geometry (cones and profiles) takes the wheelset relative to the rails: its lateral
  offset y - a + h*phi (phi = c/1.5 m the rails' roll, left side up, about their rail-level
  centreline, which carries a wheelset centre at height h sideways by -h*phi), its yaw psi - a',
  its lateral rate y' - V*a' + h*V*phi'; its yaw rate is left absolute (the track's own turning
  a'' is the curve's V*k term, of order 1e-6 1/m here); each rail stands g/2 further out;
- a spatial vehicle with gravity (its wheel loads come from its suspension) takes the vertical
  channels too: each axlebox tendon is deflected by the wheelset's rise z and its roll phi about
  its centre (their rates at V*z', V*phi'), the axle load gains the wheelset's vertical inertia
  m*V^2*z'' and the roll moment loses its roll inertia about the rail level, I*V^2*phi''; and the
  rails' tilted normal forces push the wheelset downhill, -P*phi sideways. A planar vehicle takes
  the lateral channels (alignment and gauge) only.

`irregular_part` writes the part (rail_mj.numerics); `rails_at` evaluates it (numba: the native
callback calls it per wheelset, the runs' outputs per sample through `rails_along`).
"""

from __future__ import annotations

import mujoco
import numba
import numpy as np

from rail_mj.layout import Layout
from rail_mj.numerics import IRREGULAR_AT, IRREGULAR_HEADER, SPLINE
from rail_mj.track import Track
from rail_mj.track.irregularities import RAIL_BASE
from rail_mj.vehicle.block import tendon_coefficients

# The channels' entries in `rails_at`'s result.
ALIGNMENT, ALIGNMENT_SLOPE, GAUGE, LEVEL, LEVEL_SLOPE, LEVEL_CURVATURE, ROLL, ROLL_SLOPE, ROLL_CURVATURE = range(9)
RAILS = 9


def irregular_part(model: mujoco.MjModel, layout: Layout, track: Track, prefix: str = "") -> np.ndarray:
    """The irregularity part of the block (rail_mj.numerics) for `layout`'s vehicle under `prefix`
    in `model` on `track` (which has irregularities)."""
    from rail_mj.vehicle.loads import AxleLoads

    assert track.irregularities is not None
    x0, step, coefficients = track.irregularities.spline(track.length)
    names = [f"wheelset{i + 1}" for i in range(layout.n_wheelsets)]
    loads = AxleLoads.of(model, names, prefix)
    vertical = loads is not None
    data = mujoco.MjData(model)
    mujoco.mj_kinematics(model, data)
    wheelsets: list[float] = []
    for i, name in enumerate(names):
        body = model.body(prefix + name).id
        mass, height = float(model.body_mass[body]), float(data.xipos[body, 2])
        # Principal axes along the track's (rail_mj.vehicle.joints): the roll inertia is the first.
        roll_inertia = float(model.body_inertia[body, 0]) + mass * height * height
        tendons = [] if loads is None else loads.rows(model, i, prefix).tolist()
        wheelsets += [mass, roll_inertia, height, float(len(tendons))]
        lateral = model.joint(prefix + f"{name}_lateral").dofadr[0]
        for tendon, on_load, on_moment in tendons:
            # The rise shortens a z tendon (on P: 1) as its force pushes the wheelset down; the roll
            # about the centre is the roll about the rail level (on M) less the centre's own sideways
            # move there, -h per radian, through the tendon's coefficient on the wheelset's lateral.
            on_lateral = dict(tendon_coefficients(model, int(tendon))).get(lateral, 0.0)
            wheelsets += [tendon, -on_load, on_moment + on_lateral * height]
    header = [float(len(coefficients)), x0, step, float(vertical), float(len(names))]
    return np.concatenate([header, coefficients.reshape(-1), wheelsets])


@numba.njit(cache=True, inline="always")
def irregular_at(block, k):
    """Where the irregularity part of the track part at `k` starts; 0: a perfect track."""
    offset = int(block[k + IRREGULAR_AT])
    return k + offset if offset else 0


@numba.njit(cache=True)
def _cubic(block, c, t):
    """The value, slope and curvature of the cubic whose coefficients start at `c`, at `t`."""
    c0, c1, c2, c3 = block[c], block[c + 1], block[c + 2], block[c + 3]
    return c0 + t * (c1 + t * (c2 + t * c3)), c1 + t * (2.0 * c2 + 3.0 * t * c3), 2.0 * c2 + 6.0 * t * c3


@numba.njit(cache=True)
def rails_at(block, p, s):
    """The rails at station `s` (m) of the irregularity part at `p`: (a, a', g, z, z', z'', phi,
    phi', phi'') (the entries ALIGNMENT ... ROLL_CURVATURE), phi = c/1.5 m. Before the first station
    and past the last the rails hold their end values, level and straight."""
    m, x0, step = int(block[p]), block[p + 1], block[p + 2]
    u = (s - x0) / step
    held = False
    if u < 0.0:
        i, t, held = 0, 0.0, True
    elif u >= m:
        i, t, held = m - 1, step, True
    else:
        i = min(int(u), m - 1)
        t = s - (x0 + i * step)
    c = p + IRREGULAR_HEADER + SPLINE * i
    a, a1, _ = _cubic(block, c, t)
    g, _, _ = _cubic(block, c + 12, t)
    z, z1, z2 = _cubic(block, c + 4, t)
    cross, cross1, cross2 = _cubic(block, c + 8, t)
    if held:
        a1 = z1 = z2 = cross1 = cross2 = 0.0
    return a, a1, g, z, z1, z2, cross / RAIL_BASE, cross1 / RAIL_BASE, cross2 / RAIL_BASE


@numba.njit(cache=True, inline="always")
def wheelsets_at(block, p):
    """Where the wheelsets' entries of the irregularity part at `p` start."""
    return p + IRREGULAR_HEADER + SPLINE * int(block[p])


@numba.njit(cache=True)
def shift_axleboxes(block, w, speed, z, z1, phi, phi1, lengths, rates):
    """Add to a wheelset's axlebox tendons (its entries at `w`) their deflections by the rails'
    rise `z` and roll `phi` under it, and their rates from z' and phi' at `speed`; where the next
    wheelset's entries start."""
    count = int(block[w + 3])
    e = w + 4
    for _ in range(count):
        t, on_rise, on_roll = int(block[e]), block[e + 1], block[e + 2]
        lengths[t] += on_rise * z + on_roll * phi
        rates[t] += speed * (on_rise * z1 + on_roll * phi1)
        e += 3
    return e


@numba.njit(cache=True)
def next_wheelset(block, w):
    """Where the wheelset's entries after those at `w` start."""
    return w + 4 + 3 * int(block[w + 3])


@numba.njit(cache=True)
def rails_along(block, p, stations):
    """`rails_at` at every station (any shape, flattened): (stations.size, RAILS)."""
    flat = stations.reshape(-1)
    out = np.empty((flat.size, RAILS))
    for n in range(flat.size):
        out[n] = rails_at(block, p, flat[n])
    return out


@numba.njit(cache=True)
def axlebox_shifts(block, p, speeds, stations, lengths, rates):
    """Add to recorded tendon `lengths` and `rates` (samples, ntendon) the rails' deflections of
    every wheelset's axlebox tendons (`shift_axleboxes`), the wheelsets at `stations` (samples,
    wheelsets) and the vehicle at `speeds` (samples,)."""
    for n in range(stations.shape[0]):
        w = wheelsets_at(block, p)
        for i in range(stations.shape[1]):
            r = rails_at(block, p, stations[n, i])
            w = shift_axleboxes(
                block, w, speeds[n], r[LEVEL], r[LEVEL_SLOPE], r[ROLL], r[ROLL_SLOPE], lengths[n], rates[n]
            )


def wheelset_entries(block: np.ndarray, p: int) -> list[tuple[float, float, float]]:
    """Each wheelset's (mass, roll inertia about the rail level, centre height) from the part at `p`."""
    out, w = [], int(wheelsets_at(block, p))
    for _ in range(int(block[p + 4])):
        out.append((float(block[w]), float(block[w + 1]), float(block[w + 2])))
        w = int(next_wheelset(block, w))
    return out


class Rails:
    """The rails under a compiled vehicle's wheelsets, read from its model's irregularity part, for
    a run's outputs: what the callback gave the contact law, per sample.

    Example:

        >>> from rail_mj.layout import load_layout
        >>> from rail_mj.track import track_from_dict
        >>> from rail_mj.vehicle.spec import Vehicle
        >>> track = track_from_dict({"section": [{"kind": "straight", "length": 500.0}],
        ...                          "irregularities": {"spectrum": "erri-low", "seed": 3}})
        >>> rails = Rails.of(Vehicle(load_layout("models/wheelset/wheelset.toml"), track).model)
        >>> rails.vertical, round(float(rails.at(np.array([0.0, 200.0]))[1, GAUGE]) * 1e3, 4)
        (False, 0.3623)
    """

    def __init__(self, block: np.ndarray, part: int):
        self.block, self.part = block, part
        self.vertical = bool(block[part + 3])
        self.wheelsets = wheelset_entries(block, part)

    @classmethod
    def of(cls, model: mujoco.MjModel, prefix: str = "") -> Rails | None:
        """The vehicle under `prefix`'s rails; None on a perfect track."""
        from rail_mj.vehicle.block import native_block, track_part_at

        where = track_part_at(model, prefix)
        if where is None:
            return None
        block = native_block(model)
        part = int(irregular_at(block, where[1]))
        return cls(block, part) if part else None

    def at(self, stations: np.ndarray) -> np.ndarray:
        """`rails_at` at `stations` (any shape): shape + (RAILS,)."""
        stations = np.ascontiguousarray(stations, dtype=np.float64)
        return rails_along(self.block, self.part, stations).reshape(stations.shape + (RAILS,))

    def relative(self, stations, y, psi, y_dot, speeds):
        """The wheelsets relative to their rails, as the callback gives the contact law: (y, psi,
        y_dot, gauge), each shaped like `y` (samples, wheelsets); `stations` the wheelsets', `speeds`
        (samples, 1) or a number."""
        r = self.at(stations)
        y = y - r[..., ALIGNMENT]
        psi = psi - r[..., ALIGNMENT_SLOPE]
        y_dot = y_dot - speeds * r[..., ALIGNMENT_SLOPE]
        if self.vertical:
            height = np.array([h for _, _, h in self.wheelsets])
            y = y + height * r[..., ROLL]
            y_dot = y_dot + height * speeds * r[..., ROLL_SLOPE]
        return y, psi, y_dot, r[..., GAUGE]

    def inertia(self, stations, speeds) -> tuple[np.ndarray, np.ndarray]:
        """What the wheelsets' inertia adds to their axle loads and takes from their roll moments as
        they rise and roll with the rails (N, N m; (samples, wheelsets)): m*V^2*z'', I*V^2*phi''."""
        r = self.at(stations)
        mass = np.array([m for m, _, _ in self.wheelsets])
        roll = np.array([i for _, i, _ in self.wheelsets])
        v2 = np.asarray(speeds) ** 2
        return mass * v2 * r[..., LEVEL_CURVATURE], roll * v2 * r[..., ROLL_CURVATURE]


@numba.njit(cache=True)
def part_end(block, p):
    """Where the irregularity part at `p` ends: the next vehicle's entries start there."""
    w = wheelsets_at(block, p)
    for _ in range(int(block[p + 4])):
        w = next_wheelset(block, w)
    return w
