"""Root loci, stability charts and profiles: what a person looks at.

Example:

    >>> import tempfile, os
    >>> from rail_mj import load_layout
    >>> from rail_mj.analysis.stability import Stability
    >>> s = Stability(load_layout("models/wheelset/wheelset.toml"))
    >>> rows = root_locus(s, [20.0, 40.0, 60.0])
    >>> rows[0]["mode"], len(rows)
    ('wheelset 1 (wheelset hunting)', 5)
    >>> path = os.path.join(tempfile.mkdtemp(), "locus.png")
    >>> plot_root_locus(rows, s.critical_speed(10.0, 100.0), path, "wheelset").stat().st_size > 0
    True
"""

from __future__ import annotations

import cmath
import io
import math
from collections.abc import Callable
from pathlib import Path
from typing import TYPE_CHECKING

import matplotlib

matplotlib.use("Agg")  # headless: files only, no screen needed

import matplotlib.pyplot as plt
import numpy as np

from rail_mj.files import atomic_write

if TYPE_CHECKING:  # annotations only: `rail-mj profile` draws without loading MuJoCo
    from rail_mj.analysis.stability import CriticalSpeed, Stability
    from rail_mj.contact.profiles import Profile

CSV_COLUMNS = ("speed_m_per_s", "mode", "frequency_hz", "damping_ratio", "real", "imag")


def root_locus(stability: Stability, speeds, progress: Callable[[str], None] | None = None) -> list[dict]:
    """Every oscillatory mode at every speed, as rows with CSV_COLUMNS. `progress` is told
    each speed as it is done."""
    rows = []
    for k, v in enumerate(speeds):
        if progress is not None:
            progress(f"{float(v):.2f} m/s ({k + 1}/{len(speeds)})")
        for m in stability.modes(float(v)):
            if m.oscillatory:
                rows.append(
                    {
                        "speed_m_per_s": float(v),
                        "mode": m.name,
                        "frequency_hz": m.frequency,
                        "damping_ratio": m.damping_ratio,
                        "real": m.eigenvalue.real,
                        "imag": m.eigenvalue.imag,
                    }
                )
    return rows


def locus_csv(rows: list[dict]) -> bytes:
    buf = io.StringIO()
    buf.write(",".join(CSV_COLUMNS) + "\n")
    for r in rows:
        buf.write(",".join(f'"{r[c]}"' if c == "mode" else f"{r[c]:.10g}" for c in CSV_COLUMNS) + "\n")
    return buf.getvalue().encode()


def plot_root_locus(rows: list[dict], critical: CriticalSpeed | None, path, title: str) -> Path:
    """Write `root_locus_png` to `path`."""
    path = Path(path)
    atomic_write(path, root_locus_png(rows, critical, title))
    return path


def root_locus_png(rows: list[dict], critical: CriticalSpeed | None, title: str) -> bytes:
    """Frequency and damping ratio against speed, and the complex plane, coloured by mode
    name (as named at each speed: a mode can change character, and name, with speed)."""
    names = sorted({r["mode"] for r in rows}, key=lambda n: min(r["frequency_hz"] for r in rows if r["mode"] == n))
    colours = plt.colormaps["tab10" if len(names) <= 10 else "tab20"]
    fig, (ax_f, ax_z, ax_c) = plt.subplots(1, 3, figsize=(17, 6.5), layout="constrained")
    v_all = np.array([r["speed_m_per_s"] for r in rows]) if rows else np.zeros(1)
    for k, name in enumerate(names):
        sel = [r for r in rows if r["mode"] == name]
        v = np.array([r["speed_m_per_s"] for r in sel])
        colour = colours(k % colours.N)
        ax_f.scatter(v, [r["frequency_hz"] for r in sel], color=colour, s=12, label=name)
        ax_z.scatter(v, [r["damping_ratio"] for r in sel], color=colour, s=12)
        # Marker size grows with speed, so the direction of travel along a branch shows.
        size = 4 + 40 * (v - v_all.min()) / max(np.ptp(v_all), 1e-9)
        ax_c.scatter([r["real"] for r in sel], [r["imag"] for r in sel], color=colour, s=size)
    ax_f.set(xlabel="speed V (m/s)", ylabel="frequency f (Hz)", title="Frequency of each mode")
    ax_z.set(xlabel="speed V (m/s)", ylabel="damping ratio ζ (-)", title="Damping ratio (ζ < 0: unstable)")
    ax_z.axhline(0.0, color="black", linewidth=0.8)
    ax_c.set(
        xlabel="real part σ (1/s)",
        ylabel="imaginary part ω (rad/s)",
        title="Complex plane (marker size grows with speed)",
    )
    ax_c.axvline(0.0, color="black", linewidth=0.8)
    if rows:
        # Roots damped faster than the fastest oscillation are off to the left: they are
        # the creep-damped aperiodic motions, of no interest for stability.
        imag_max = max(r["imag"] for r in rows)
        real_max = max(r["real"] for r in rows)
        ax_c.set_xlim(-imag_max, max(0.1 * imag_max, 1.1 * real_max))
    if critical is not None and critical.critical_speed is not None:
        for ax in (ax_f, ax_z):
            ax.axvline(critical.critical_speed, color="red", linestyle="--", linewidth=1.2)
        ax_z.annotate(
            f"critical speed {critical.critical_speed:.1f} m/s\n{critical.mode}",
            (critical.critical_speed, 0.0),
            xytext=(6, 12),
            textcoords="offset points",
            color="red",
            fontsize=9,
        )
    for ax in (ax_f, ax_z, ax_c):
        ax.grid(alpha=0.3)
    fig.legend(
        loc="outside lower center",
        ncol=min(4, max(len(names), 1)),
        fontsize=9,
        title="mode (named from its eigenvector at each speed)",
    )
    fig.suptitle(f"Root locus: {title}")
    png = io.BytesIO()
    fig.savefig(png, format="png", dpi=110)
    plt.close(fig)
    return png.getvalue()


def bifurcation_csv(branches) -> bytes:
    buf = io.StringIO()
    buf.write("branch,speed_m_per_s,amplitude_m,frequency_hz,settled\n")
    for b in branches:
        for v, a, f, ok in zip(b.speeds, b.amplitudes, b.frequencies, b.alive):
            buf.write(f"{b.direction},{v:.10g},{a:.10g},{f:.10g},{int(ok)}\n")
    return buf.getvalue().encode()


def bifurcation_png(critical: CriticalSpeed, down, up, clearance: float, title: str) -> bytes:
    """Limit-cycle amplitude against speed: the branch followed down from hunting and the
    one followed up from a small disturbance, with both critical speeds marked."""
    fig, ax = plt.subplots(figsize=(9, 5.5), layout="constrained")
    for branch, marker, label in (
        (down, "o-", "speed lowered from hunting (limit cycle)"),
        (up, "s--", "from a small disturbance at each speed"),
    ):
        ax.plot(branch.speeds, np.asarray(branch.amplitudes) * 1e3, marker, ms=5, label=label)
    ax.axhline(clearance * 1e3, color="grey", linestyle=":", label=f"flangeway clearance {clearance * 1e3:g} mm")
    if critical.linear_critical_speed is not None:
        ax.axvline(
            critical.linear_critical_speed,
            color="red",
            linestyle="--",
            label=f"linear critical speed {critical.linear_critical_speed:.1f} m/s",
        )
    if critical.critical_speed is not None:
        ax.axvline(
            critical.critical_speed,
            color="green",
            linestyle="--",
            label=f"nonlinear critical speed {critical.critical_speed:.1f} m/s "
            f"(speed lowered in {critical.step:.0%} steps)",
        )
    ax.set(xlabel="speed V (m/s)", ylabel="amplitude: largest wheelset |y| (mm)", title=f"Bifurcation diagram: {title}")
    ax.grid(alpha=0.3)
    ax.legend(loc="upper left", fontsize=9)
    png = io.BytesIO()
    fig.savefig(png, format="png", dpi=110)
    plt.close(fig)
    return png.getvalue()


def stability_map_png(table, x_key: str, y_key: str, x_log: bool, y_log: bool, method: str, title: str) -> bytes:
    """The critical speed over two parameters (a sweep's table, one row per cell): colour
    and contours, the mode that sets it marked in each cell; cells with no crossing in the
    range searched marked grey (stable throughout) or black (unstable from its lowest
    speed); cells that could not be computed crossed."""
    rows = table.to_pylist()
    xs = sorted({r[x_key] for r in rows})
    ys = sorted({r[y_key] for r in rows})
    speed = np.full((len(ys), len(xs)), np.nan)
    modes: dict[str, list[tuple[float, float]]] = {}
    failed: list[tuple[float, float]] = []
    stable: list[tuple[float, float]] = []
    unstable: list[tuple[float, float]] = []
    for r in rows:
        i, j = ys.index(r[y_key]), xs.index(r[x_key])
        if r["status"] != "ok":
            failed.append((r[x_key], r[y_key]))
        elif r["critical_speed_m_per_s"] is None:
            # No crossing in the range: stable throughout, or unstable from its lowest speed.
            (unstable if r["outcome"] == "unstable" else stable).append((r[x_key], r[y_key]))
        else:
            speed[i, j] = r["critical_speed_m_per_s"]
            modes.setdefault(r["mode"] or "?", []).append((r[x_key], r[y_key]))
    fig, ax = plt.subplots(figsize=(9.5, 7), layout="constrained")
    if np.any(np.isfinite(speed)):
        mesh = ax.pcolormesh(
            cell_edges(xs, x_log), cell_edges(ys, y_log), np.ma.masked_invalid(speed), shading="flat", cmap="viridis"
        )
        fig.colorbar(mesh, ax=ax, label=f"{'linear' if method == 'eigen' else 'nonlinear'} critical speed (m/s)")
        if len(xs) > 1 and len(ys) > 1:
            lines = ax.contour(xs, ys, np.ma.masked_invalid(speed), colors="white", linewidths=0.8)
            ax.clabel(lines, fmt="%.0f", fontsize=8)
    markers = "o^svD<>phX*"
    for k, (name, points) in enumerate(sorted(modes.items())):
        px, py = zip(*points)
        ax.scatter(
            px,
            py,
            s=10,
            marker=markers[k % len(markers)],
            facecolors="none",
            edgecolors="black",
            linewidths=0.5,
            label=name,
        )
    if stable:
        px, py = zip(*stable)
        ax.scatter(px, py, s=40, marker="s", color="lightgrey", edgecolors="grey", label="stable in the range searched")
    if unstable:
        px, py = zip(*unstable)
        ax.scatter(px, py, s=40, marker="s", color="black", label="unstable from the lowest speed searched")
    if failed:
        px, py = zip(*failed)
        ax.scatter(px, py, s=40, marker="x", color="red", label="not computed (see the table)")
    ax.set(xlabel=key_label(x_key), ylabel=key_label(y_key), title=f"Critical speed of {title}")
    if x_log:
        ax.set_xscale("log")
    if y_log:
        ax.set_yscale("log")
    ax.legend(loc="upper center", bbox_to_anchor=(0.5, -0.1), ncol=2, fontsize=8, title="mode at the threshold")
    png = io.BytesIO()
    fig.savefig(png, format="png", dpi=110)
    plt.close(fig)
    return png.getvalue()


def cell_edges(centres, log: bool) -> np.ndarray:
    """The edges of the cells around a grid's `centres` (increasing): midway between neighbours,
    in log space on a log axis (the geometric mean: 2e6 and 8e6 meet at 4e6, not 5e6), and the
    outer edges half a cell beyond the outer centres in the same space, so that a log axis's
    bottom cell around 2e6 starts at 1e6 from a next value of 4e6 (matplotlib's "nearest" shading
    takes arithmetic midpoints, which put it at 1e6 - 1e6 = 0 and below). A lone centre's cell
    spans a factor 10**0.25 (a log axis: half a decade in all) or +-5 % of it (+-0.5 at 0) either way."""
    values = np.asarray(centres, dtype=float)
    if log:
        return (
            np.exp(cell_edges(np.log(values), False))
            if len(values) > 1
            else values[[0, 0]] * 10.0 ** np.array([-0.25, 0.25])
        )
    if len(values) == 1:
        half = 0.05 * abs(values[0]) or 0.5
        return values[[0, 0]] + np.array([-half, half])
    middle = (values[1:] + values[:-1]) / 2
    return np.concatenate(
        [[values[0] - (values[1] - values[0]) / 2], middle, [values[-1] + (values[-1] - values[-2]) / 2]]
    )


# The unit of each layout key a sweep or map varies, by its last name (`primary.yaw_stiffness`:
# yaw_stiffness): rail-mj's layouts are SI throughout (rail_mj.layout), "-" where dimensionless.
KEY_UNITS = {
    **dict.fromkeys(
        (
            "rolling_radius",
            "contact_half_spacing",
            "flangeway_clearance",
            "wheelset_positions",
            "bogie_positions",
            "position",
            "length",
            "width",
            "height",
            "spacing",
            "carbody_height",
            "bogie_height",
            "free_play",
            "deflection",
            "rail_transverse_radius",
            "wheel_transverse_radius",
            "track_gauge",
            "flange_back_spacing",
        ),
        "m",
    ),
    **dict.fromkeys(("conicity", "friction", "poisson_ratio", "rail_inclination", "falling_friction_ratio"), "-"),
    **dict.fromkeys(("lateral_stiffness", "kx", "ky", "kz", "stiffness"), "N/m"),
    **dict.fromkeys(("lateral_damping", "cx", "cy", "cz", "c", "damping"), "N·s/m"),
    **dict.fromkeys(("yaw_stiffness", "anti_roll_bar"), "N·m/rad"),
    "yaw_damping": "N·m·s/rad",
    "mass": "kg",
    "inertia": "kg·m²",
    **dict.fromkeys(("wheel_load", "force", "f11", "f22"), "N"),
    "f23": "N·m",
    "f33": "N·m²",
    "young_modulus": "Pa",
    "angle": "rad",
    "falling_friction_rate": "s/m",
}


def key_label(key: str) -> str:
    """An axis label for a layout key: the key and its unit, "primary.yaw_stiffness (N·m/rad)";
    the key alone where its unit is not known. Indices (bogies.2.mass, ...inertia.1) are skipped."""
    names = [part for part in key.split(".") if not part.isdigit()]
    unit = KEY_UNITS.get(names[-1]) if names else None
    return f"{key} ({unit})" if unit else key


def profile_png(profile: Profile) -> bytes:
    """A wheel or rail profile, to scale, in its own frame (rail_mj.contact.profiles): the metal
    shaded on its side of the surface (above a wheel's, below a rail's)."""
    y, z = profile.y * 1e3, profile.z * 1e3
    fig, ax = plt.subplots(figsize=(9, 5.5), layout="constrained")
    margin = 5.0
    if profile.kind == "wheel":
        ax.fill_between(y, z, z.max() + margin, color="lightsteelblue", label="wheel")
        ax.axvline(0.0, color="grey", linestyle=":", label="taping line (y = 0)")
    else:
        ax.fill_between(y, z, z.min() - margin, color="lightgrey", label="rail")
        ax.axvline(0.0, color="grey", linestyle=":", label="head centreline (y = 0)")
    ax.plot(y, z, color="black", linewidth=1.2, label=f"surface ({len(y)} points)")
    ax.set_aspect("equal")
    ax.set(
        xlabel="y (mm), positive towards the field side",
        ylabel="z (mm), up",
        title=f"{profile.kind} profile {profile.name}" + (f" ({profile.source})" if profile.source else ""),
    )
    ax.grid(alpha=0.3)
    ax.legend(loc="best", fontsize=9)
    return _png(fig)


def _png(fig) -> bytes:
    """The figure as PNG bytes; the figure closed."""
    png = io.BytesIO()
    fig.savefig(png, format="png", dpi=110)
    plt.close(fig)
    return png.getvalue()


def conicity_png(amplitudes, conicity, title: str, harmonic=None, quoted: tuple[float, float] | None = None) -> bytes:
    """Equivalent conicity against amplitude (mm; rail_mj.contact.conicity): the integration method,
    the harmonic linearisation dashed when given, and the value at `quoted` = (ŷ, λe), the
    3 mm of acceptance work, marked."""
    fig, ax = plt.subplots(figsize=(8, 5), layout="constrained")
    ax.plot(amplitudes, conicity, "o-", ms=4, label="integration of the Klingel equation (EN 15302 reference)")
    if harmonic is not None:
        ax.plot(amplitudes, harmonic, "--", color="grey", label="harmonic linearisation (cross-check)")
    if quoted is not None:
        at, value = quoted
        ax.axvline(at, color="red", linestyle=":", linewidth=1.2)
        ax.plot([at], [value], "D", color="red", label=f"λe = {value:.4f} at ŷ = {at:g} mm")
    ax.set(
        xlabel="amplitude ŷ (mm, half the peak-to-peak lateral motion)",
        ylabel="equivalent conicity λe (-)",
        title=f"Equivalent conicity (EN 15302): {title}",
    )
    ax.set_xlim(left=0.0)
    ax.set_ylim(bottom=0.0)
    ax.grid(alpha=0.3)
    ax.legend(loc="best", fontsize=9)
    return _png(fig)


def contact_geometry_png(table, title: str, conicity: float | None = None) -> bytes:
    """The picture of a contact table (rail_mj.contact.geometry): Δr(y), with the cone 2λy of
    `conicity` for comparison; the contact angles; and the left wheel over the left rail in
    the track frame at a few shifts, their contact points marked (two-point contacts as
    open circles)."""
    from rail_mj.contact.geometry import rail_points, wheel_points

    y = table.y * 1e3
    fig = plt.figure(figsize=(13, 8.5), layout="constrained")
    grid = fig.add_gridspec(2, 2, height_ratios=(1, 1.25))
    ax_dr, ax_angle, ax_prof = fig.add_subplot(grid[0, 0]), fig.add_subplot(grid[0, 1]), fig.add_subplot(grid[1, :])
    ax_dr.plot(y, table.delta_r * 1e3, color="black", label="Δr = r_left − r_right")
    if conicity is not None:
        ax_dr.plot(y, 2 * conicity * y, "--", color="grey", label=f"cone 2λy, λ = {conicity:.4g}")
    ax_dr.set(xlabel="lateral shift y (mm, to the left)", ylabel="Δr (mm)", title="rolling-radius difference")
    ax_angle.plot(y, np.degrees(table.contact_angle_left), label="left wheel")
    ax_angle.plot(y, np.degrees(table.contact_angle_right), label="right wheel")
    ax_angle.set(
        xlabel="lateral shift y (mm, to the left)",
        ylabel="contact angle (degrees)",
        title="contact angles (track frame, roll included)",
    )
    for ax in (ax_dr, ax_angle):
        ax.grid(alpha=0.3)
        ax.legend(loc="best", fontsize=9)
    rq, rz = rail_points(table.track, "left")
    ax_prof.fill_between(rq * 1e3, rz * 1e3, rz.min() * 1e3 - 2, color="lightgrey")
    ax_prof.plot(rq * 1e3, rz * 1e3, color="black", linewidth=1.2, label="left rail (canted)")
    flange = np.flatnonzero(table.contact_angle_left > 1.0)
    wanted = [0.0, 0.25 * y[-1], 0.5 * y[-1]] + ([y[flange[0]]] if len(flange) else []) + [y[-1]]
    rows = sorted({int(np.argmin(np.abs(y - w))) for w in wanted})
    for i, colour in zip(rows, plt.rcParams["axes.prop_cycle"].by_key()["color"]):
        wq, wz = wheel_points(table, i, "left")
        ax_prof.plot(wq * 1e3, wz * 1e3, color=colour, linewidth=1.0, label=f"left wheel at y = {y[i]:.2f} mm")
        cq = table.contact_y_left[i] * 1e3
        cz = float(np.interp(cq, rq * 1e3, rz * 1e3))
        ax_prof.plot([cq], [cz], "o", color=colour, ms=6)
        if table.two_point_left[i] > 0:
            q2 = table.contact_y2_left[i] * 1e3
            ax_prof.plot([q2], [np.interp(q2, rq * 1e3, rz * 1e3)], "o", mfc="none", color=colour, ms=9)
    ax_prof.set_xlim(rq.min() * 1e3 - 5, rq.max() * 1e3 + 5)
    ax_prof.set_ylim(rz.min() * 1e3 - 2, 12)
    ax_prof.set_aspect("equal")
    ax_prof.set(
        xlabel="track y (mm, from the track centre, to the left)",
        ylabel="z (mm, up)",
        title="left wheel on left rail: contact points (open circle: a second contact point)",
    )
    ax_prof.grid(alpha=0.3)
    ax_prof.legend(loc="lower right", fontsize=8)
    fig.suptitle(f"Contact geometry (rigid wheelset, zero yaw): {title}")
    return _png(fig)


def irregularities_png(x, channels: dict, title: str, spec=None, band=None) -> bytes:
    """A track's four irregularity channels against distance (mm), and each one's power spectral
    density (Welch, one-sided, per cycle/m) beside its target, the spectrum's S_f(f) = 2π·S(2π·f),
    within the band kept (dashed: its ends)."""
    from scipy.signal import welch

    from rail_mj.track.irregularities import CHANNELS

    fig, axes = plt.subplots(len(CHANNELS), 2, figsize=(15, 11), layout="constrained", width_ratios=(2.2, 1))
    step = float(x[1] - x[0]) if len(x) > 1 else 1.0
    for (ax_x, ax_f), channel in zip(axes, CHANNELS):
        values = channels[channel]
        ax_x.plot(x, values * 1e3, lw=0.6)
        ax_x.set(ylabel=f"{channel.replace('_', ' ')} (mm)")
        ax_x.grid(alpha=0.3)
        if len(values) > 16 and np.any(values):
            f, p = welch(values, fs=1.0 / step, nperseg=min(len(values), 4096))
            keep = f > 0
            ax_f.loglog(f[keep], p[keep], lw=0.8, label="realised (Welch)")
        if spec is not None and channel in spec.channels and band is not None:
            f_target = np.geomspace(1.0 / band[1], 1.0 / band[0], 200)
            target = 2.0 * np.pi * spec.density(channel, 2.0 * np.pi * f_target)
            ax_f.loglog(f_target, target, "k", lw=1.2, label=f"{spec.name} target")
            for edge in (1.0 / band[1], 1.0 / band[0]):
                ax_f.axvline(edge, color="grey", ls="--", lw=0.8)
            # The band, not the leakage beyond it, decides the scale.
            ax_f.set_ylim(float(target.min()) / 100.0, float(target.max()) * 10.0)
        ax_f.set(ylabel="PSD (m²·m)")
        ax_f.grid(alpha=0.3, which="both")
        if ax_f.get_legend_handles_labels()[0]:
            ax_f.legend(loc="lower left", fontsize=8)
    axes[-1][0].set(xlabel="distance along the track (m)")
    axes[-1][1].set(xlabel="spatial frequency (1/m)")
    fig.suptitle(title)
    return _png(fig)


# The CSV's units as a reader writes them on an axis.
_SHOWN_UNITS = {"n": "N", "m_per_s2": "m/s²", "m": "m", "rad": "rad", "": "-"}


def _shown(unit: str) -> str:
    """A CSV unit (`n_per_m`, `m_per_s2`) as an axis shows it (N/m, m/s²)."""
    head, per, tail = unit.partition("_per_m")
    return _SHOWN_UNITS.get(head, head) + ("/m" if per else "") + tail


RESPONSE_COLUMNS = ("frequency_hz", "wavelength_m", "input", "output", "gain", "gain_unit", "phase_deg")


def response_csv(frequencies, speed: float, gains: dict, outputs) -> bytes:
    """Transfer functions as rows of RESPONSE_COLUMNS, one per frequency, input and output: `gains`
    {input: (frequencies, outputs) complex}, `outputs` their rail_mj.analysis.response.Output; the
    gain per metre of the input, its phase in degrees (the output's lead over the irregularity
    under the vehicle's origin)."""
    buf = io.StringIO()
    buf.write(",".join(RESPONSE_COLUMNS) + "\n")
    for channel, h in gains.items():
        for k, out in enumerate(outputs):
            for f, g in zip(frequencies, h[:, k]):
                phase = math.degrees(cmath.phase(g))
                buf.write(f"{f:.10g},{speed / f:.10g},{channel},{out.name},{abs(g):.10g},{out.gain_unit},{phase:.6g}\n")
    return buf.getvalue().encode()


def response_png(frequencies, speed: float, gains: dict, outputs, title: str, rms: dict | None = None) -> bytes:
    """|H| against frequency (wavelength on the top axis), a panel per gain unit, a line per output
    and input; an input with no linear response on an output (|H| nowhere above 1e-9 of the
    panel's largest) is left out. `rms` {(output name, input): rms}: shown in the legend."""
    units = list(dict.fromkeys(o.gain_unit for o in outputs))
    fig, axes = plt.subplots(len(units), 1, figsize=(12, 3.2 * len(units) + 0.8), layout="constrained", squeeze=False)
    f = np.asarray(frequencies, dtype=float)
    for ax, unit in zip(axes[:, 0], units):
        columns = [(k, o) for k, o in enumerate(outputs) if o.gain_unit == unit]
        top = max(float(np.abs(h[:, k]).max()) for h in gains.values() for k, _ in columns)
        for k, o in columns:
            for channel, h in gains.items():
                g = np.abs(h[:, k])
                if top > 0.0 and g.max() > 1e-9 * top:
                    label = f"{o.name} ← {channel}"
                    if rms is not None and (o.name, channel) in rms:
                        label += f" (rms {rms[o.name, channel]:.3g} {_shown(o.unit)})"
                    ax.loglog(f, g, lw=1.0, label=label)
        ax.set(ylabel=f"|H| ({_shown(unit)})")
        ax.grid(alpha=0.3, which="both")
        if ax.get_legend_handles_labels()[0]:
            ax.legend(fontsize=7, loc="center left", bbox_to_anchor=(1.01, 0.5))
        top_axis = ax.secondary_xaxis(
            "top", functions=(lambda v: speed / np.maximum(v, 1e-12), lambda w: speed / np.maximum(w, 1e-12))
        )
        top_axis.set_xlabel("wavelength (m)", fontsize=8)
    axes[-1, 0].set(xlabel="frequency (Hz)")
    fig.suptitle(title)
    return _png(fig)
