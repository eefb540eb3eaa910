"""`rail-mj generate` and `rail-mj run`: a layout's MuJoCo model, and one run of it with its
summary, samples and recording."""

from __future__ import annotations

import json
import math
import os
import sys
from pathlib import Path

import click

from rail_mj.cli.options import (
    EXIT_BAD_INPUT,
    EXIT_RUN_FAILED,
    Failure,
    check_outputs,
    check_profile_outputs,
    check_speed,
    layout_of,
    output_failure,
    positive_rate,
    sample_interval_of,
    track_of,
    uses_stdout,
    warn,
    warn_deficiency,
    written,
)
from rail_mj.layout import Layout
from rail_mj.practice import EXAGGERATION_LIMITS, INITIAL_LATERAL, max_initial_yaw


@click.command("generate")
@click.argument("layout", type=click.Path(dir_okay=False))
@click.option(
    "-o",
    "--out",
    "out_dir",
    required=True,
    type=click.Path(file_okay=False),
    help="Folder for <name>.xml, scene.xml and assets/.",
)
def generate_cmd(layout, out_dir):
    """Generate the MJCF model of LAYOUT."""
    from rail_mj.vehicle.mjcf import generate

    lay = layout_of(layout)
    check_outputs(layout, [("-o", out_dir)], folders=True)
    check_profile_outputs(lay, [("-o", out_dir)], folders=True)
    _check_generated(layout, lay, out_dir)
    try:
        written = generate(lay, out_dir)
    except ValueError as e:
        raise Failure(str(e), EXIT_BAD_INPUT) from None
    except OSError as e:
        raise output_failure(e, str(e)) from None
    for path in written:
        click.echo(str(path))


def _check_generated(path: str, layout: Layout, out_dir: str) -> None:
    """Refuse a folder in which `generate` would write over its own layout: DIR/<name>.xml,
    DIR/scene.xml and anything under DIR/assets/."""
    from pathlib import Path

    folder = Path(out_dir).resolve()
    source = Path(path).resolve()
    written = {folder / f"{layout.name}.xml", folder / "scene.xml"}
    if source in written or folder / "assets" in source.parents:
        raise Failure(f"-o {out_dir}: would overwrite the layout file {path}", EXIT_BAD_INPUT)


@click.command("run")
@click.argument("layout", type=click.Path(dir_okay=False))
@click.option("--speed", type=float, help="Forward speed, m/s (or --speed-profile).")
@click.option(
    "--speed-profile",
    help="The speed along the track instead: S:V,S:V,... (stations in m from the start, speeds in m/s), "
    "linear between the points and held beyond them, e.g. 0:90,3000:60 to brake slowly.",
)
@click.option("--distance", type=float, required=True, help="Distance to run, m.")
@click.option(
    "--initial-lateral",
    type=float,
    default=INITIAL_LATERAL,
    show_default=True,
    help="Start with the whole vehicle shifted left by this much, m.",
)
@click.option(
    "--initial-yaw",
    type=float,
    default=0.0,
    show_default=True,
    help="Start with every wheelset yawed nose-left by this much, rad.",
)
@click.option(
    "--track",
    type=click.Path(dir_okay=False),
    help="A track file (TOML sections or CSV design geometry; docs/track.md) to run along from its start.",
)
@click.option("--rrd", type=click.Path(dir_okay=False), help="Write a Rerun recording here.")
@click.option(
    "--rrd-rate",
    default="auto",
    show_default=True,
    help="Samples per second in the recording: auto (chosen from the motion), a number, or full (every sample).",
)
@click.option(
    "--exaggerate",
    default="auto",
    show_default=True,
    metavar="auto|FACTOR",
    help="The recording's 3D view draws every body's lateral motion and yaw this many times their size: "
    "auto (the largest motion as up to a quarter of the gauge, a factor of 1, 2 or 5 times a power of ten "
    "up to 100), or a factor from 1 (true size) to 1000. The plots show true values.",
)
@click.option(
    "--sample-rate",
    default="full",
    show_default=True,
    help="Samples per second the run keeps for its summary, CSV and recording: full (one a millisecond, "
    "0.6 kB each for a coach) or fewer, for a run too long for memory. The steps are the same; the "
    "summary reads the samples kept as they are, without a low-pass first. At least ten intervals a "
    "run: it ends at the first kept sample at or past --distance.",
)
@click.option("--out", type=click.Path(dir_okay=False), help="Write the samples as CSV here.")
@click.option("--json", "as_json", is_flag=True, help="Print the summary as JSON.")
def run_cmd(
    layout,
    speed,
    speed_profile,
    distance,
    initial_lateral,
    initial_yaw,
    track,
    rrd,
    rrd_rate,
    exaggerate,
    sample_rate,
    out,
    as_json,
):
    """Run LAYOUT at constant speed (or along --speed-profile) on straight track (or along
    --track) and summarise each wheelset's motion (and its steady curving in each curve).

    Outputs may be `-` (standard output; the summary then goes to stderr), a FIFO or a
    device: they are written through, never replaced."""
    lay = layout_of(layout)
    if (speed is None) == (speed_profile is None):
        raise Failure("give either --speed or --speed-profile", EXIT_BAD_INPUT)
    if speed is not None:
        check_speed("--speed", speed)
    else:
        speed = _profile_of(speed_profile)
    if not (math.isfinite(distance) and distance > 0):
        raise Failure(f"--distance must be a positive number, got {distance}", EXIT_BAD_INPUT)
    _check_disturbance(lay, initial_lateral, initial_yaw)
    rate = _recording_rate(rrd_rate)
    interval = sample_interval_of(sample_rate)
    factor = _exaggeration(exaggerate)
    check_outputs(layout, [("--out", out), ("--rrd", rrd)])
    check_profile_outputs(lay, [("--out", out), ("--rrd", rrd)])
    if track is not None:
        check_outputs(track, [("--out", out), ("--rrd", rrd)], source="the track file")
    the_track = track_of(track)
    from rail_mj.analysis import summary
    from rail_mj.output.samples import csv_bytes
    from rail_mj.simulation.runner import SimulationError

    try:
        run = _simulate_with_progress(lay, speed, distance, initial_lateral, initial_yaw, the_track, interval)
    except SimulationError as e:
        raise Failure(str(e), EXIT_RUN_FAILED) from None
    except ValueError as e:
        raise Failure(str(e), EXIT_BAD_INPUT) from None
    result = summary(run)
    _warn_deficiency(result)
    if interval is not None and result["sample_interval_s"] is not None and result["sample_interval_s"] > 1.5e-3:
        warn(
            f"the summary reads one sample every {result['sample_interval_s'] * 1e3:.3g} ms (--sample-rate), "
            "not low-passed before: forces and EN 14363's quantities alias what is faster than half that rate"
        )
    outputs = [p for p in (out, rrd) if p]
    with written(outputs) as temps:  # both or neither
        for tmp, path in zip(temps, outputs):
            if path == out:
                tmp.write_bytes(csv_bytes(run))
            else:
                from rail_mj.output.recording import exaggeration, recorded_samples, sample_rate, save_recording

                save_recording(run, tmp, rate, factor)
                keep = recorded_samples(run, rate)
                result["rrd_rate_per_s"] = sample_rate(run) / (keep[1] - keep[0]) if len(keep) > 1 else None
                result["rrd_exaggeration"] = exaggeration(run) if factor is None else factor
    if out:
        result["csv"] = out
    if rrd:
        result["rrd"] = rrd
    to_stderr = uses_stdout(out, rrd)
    if as_json:
        click.echo(json.dumps(result, indent=2), err=to_stderr)
    else:
        _print_summary(result, to_stderr)


def _warn_deficiency(result: dict) -> None:
    """A warning for each curve run through with a cant deficiency or excess beyond practice."""
    for curve in result.get("curves", []):
        warn_deficiency(f"curve {curve['section']} ({curve['radius_m']:g} m)", curve["cant_deficiency_mm"])


def _profile_of(text: str):
    """--speed-profile as a SpeedProfile (rail_mj.track.speed), or a one-line refusal."""
    from rail_mj.track import SpeedProfile, TrackError

    try:
        return SpeedProfile.parse(text)
    except TrackError as e:
        raise Failure(str(e), EXIT_BAD_INPUT) from None


def _recording_rate(text: str) -> float | None:
    """--rrd-rate: None (auto), math.inf (full) or a positive number of samples/s."""
    if text == "auto":
        return None
    if text == "full":
        return math.inf
    return positive_rate(text, "--rrd-rate", "auto, full")


def _exaggeration(text: str) -> float | None:
    """--exaggerate: None (auto) or a factor from 1 to 1000 (rail_mj.practice.EXAGGERATION_LIMITS)."""
    if text == "auto":
        return None
    try:
        factor = float(text)
    except ValueError:
        factor = math.nan
    low, high = EXAGGERATION_LIMITS
    if not low <= factor <= high:  # also NaN
        raise Failure(
            f"--exaggerate must be auto or a factor from {low:g} (true size) to {high:g}, got {text!r}", EXIT_BAD_INPUT
        )
    return factor


def _check_disturbance(layout: Layout, lateral: float, yaw: float) -> None:
    """Refuse a start the wheelsets cannot have on the rails: shifted past the flangeway
    clearance (the flange would start inside the rail), or yawed so far that the flange
    fronts cross the rails."""
    w = layout.wheelset
    for option, value in (("--initial-lateral", lateral), ("--initial-yaw", yaw)):
        if not math.isfinite(value):
            raise Failure(f"{option} must be a finite number, got {value}", EXIT_BAD_INPUT)
    if abs(lateral) > w.flangeway_clearance:
        raise Failure(
            f"--initial-lateral {lateral:g} m: a wheelset shifted past its flangeway "
            f"clearance ({w.flangeway_clearance:g} m) would start with its flange inside the "
            f"rail; give at most {w.flangeway_clearance:g} m",
            EXIT_BAD_INPUT,
        )
    limit = max_initial_yaw(w.rolling_radius, w.flangeway_clearance)
    if abs(yaw) > limit:
        raise Failure(
            f"--initial-yaw {yaw:g} rad: yawed more than {limit:.3g} rad, a wheelset's "
            f"flange fronts would cross the rails (clearance {w.flangeway_clearance:g} m); "
            f"angles of attack on track are a few mrad",
            EXIT_BAD_INPUT,
        )


def _simulate_with_progress(lay, speed, distance, initial_lateral, initial_yaw, track=None, interval=None):
    from rail_mj.simulation.runner import simulate

    if not sys.stderr.isatty():
        return simulate(lay, speed, distance, initial_lateral, initial_yaw, track=track, sample_interval=interval)
    at = f"{speed:g} m/s" if isinstance(speed, float | int) else "its speed profile"
    with click.progressbar(length=1000, label=f"{lay.name} at {at}", file=sys.stderr) as bar:
        done = [0]

        def progress(fraction: float) -> None:
            step = int(fraction * 1000)
            if step > done[0]:
                bar.update(step - done[0])
                done[0] = step

        return simulate(
            lay, speed, distance, initial_lateral, initial_yaw, progress=progress, track=track, sample_interval=interval
        )


def _rerun() -> str:
    """How to start Rerun's viewer from here: `rerun` where the shell finds this one (an active
    environment), else its path beside this Python (a venv not activated: `.venv/bin/rerun`)."""
    import shutil

    beside = Path(sys.executable).parent / "rerun"
    found = shutil.which("rerun")
    if beside.exists() and (found is None or Path(found).resolve() != beside.resolve()):
        relative = os.path.relpath(beside)
        return str(beside) if relative.startswith("..") else relative
    return "rerun"


def _fmt(value, spec: str) -> str:
    """`value` formatted by `spec`, or a dash as wide for a value there is not."""
    if value is None:
        return format("-", spec.rstrip("efgEFG").split(".")[0])
    return format(value, spec)


def _print_summary(result: dict, err: bool = False) -> None:
    def say(text: str) -> None:
        click.echo(text, err=err)

    profile = result.get("speed_profile")
    at = (
        f"{result['speed_m_per_s']:g} m/s"
        if profile is None
        else f"{profile['start_m_per_s']:.4g} to {profile['end_m_per_s']:.4g} m/s (--speed-profile)"
    )
    interval = result["sample_interval_s"]
    # Said when fewer samples than the steps (or one a millisecond) were kept: a long run's.
    kept = (
        f", a sample every {interval * 1e3:.3g} ms"
        if interval is not None and interval > max(result["timestep_s"], 1e-3) * 1.5
        else ""
    )
    say(
        f"{result['layout']}: {result['distance_m']:g} m at {at} "
        f"({result['duration_s']:.3g} s, timestep {result['timestep_s']:.3g} s{kept})"
    )
    say("wheelset  max|y| (mm)  end|y| (mm)  growth (1/s)  frequency (Hz)  wavelength (m)")
    for w in result["wheelsets"]:
        line = (
            f"{w['wheelset']:>8}  {w['max_abs_lateral_m'] * 1e3:>11.3f}  "
            f"{w['final_abs_lateral_m'] * 1e3:>11.3f}  {_fmt(w['growth_rate_per_s'], '>12.4f')}  "
            f"{_fmt(w['frequency_hz'], '>14.4f')}  {_fmt(w['wavelength_m'], '>14.3f')}"
        )
        if w["decayed"]:
            at = w.get("decayed_at_speed_m_per_s")
            speed = "" if at is None else f", {at:.4g} m/s"
            line += f"  decayed by {w['decayed_by_s']:.3g} s ({w['decayed_by_m']:.4g} m{speed})"
        say(line)
    if result["frames"]:
        say("body      max|y| (mm)  end|y| (mm)  max|yaw| (mrad)  growth (1/s)  frequency (Hz)  motion")
    for f in result["frames"]:
        line = (
            f"{f['body']:<8}  {f['max_abs_lateral_m'] * 1e3:>11.3f}  {f['final_abs_lateral_m'] * 1e3:>11.3f}  "
            f"{f['max_abs_yaw_rad'] * 1e3:>15.4f}  {_fmt(f['growth_rate_per_s'], '>12.4f')}  "
            f"{_fmt(f['frequency_hz'], '>14.4f')}  {f['motion']}"
        )
        if f["decayed"] and f["motion"] != "at rest":
            line += f" by {f['decayed_by_s']:.3g} s ({f['decayed_by_m']:.4g} m)"
        elif f["coordinate"] == "yaw":
            line += " (in yaw)"
        say(line)
    if any(b["decayed"] for b in result["wheelsets"] + result["frames"]):
        say(
            "decayed: |y| (a body's, or its yaw) below 5 % of its largest value from then to the end; growth, "
            "frequency and wavelength are those of the motion before"
        )
    if "sections" in result:  # on irregular track
        say(
            "on irregular track the motion is the rails' forced response: its growth, decay and frequency "
            "do not say whether the vehicle is stable (EN 14363's criterion below does)"
        )
    else:
        for verdict in ("growing", "sustained"):
            if result[verdict]:
                say(f"{verdict}: {', '.join(result[verdict])}")
    flange = result["flange_contact"]
    if flange is not None:
        first, largest = flange["first_strike"], flange["largest_flange_force_at"]
        if first is None:
            say("flange contact: none")
        else:
            say(
                f"flange contact: {flange['strikes']} strikes; first wheelset {first['wheelset']} on the "
                f"{first['rail']} rail at x = {first['x_m']:.4g} m ({first['t_s']:.3g} s); largest flange force "
                f"{flange['largest_flange_force_n'] / 1e3:.1f} kN, wheelset {largest['wheelset']} {largest['rail']} "
                f"at x = {largest['x_m']:.4g} m"
            )
    h = result.get("hunting")
    if h is not None:
        worst = max(h["max_rms_n"])
        say(
            f"hunting (EN 14363, rms Sigma Y over 100 m, band-passed at {h['frequency_hz']:.2f} +/- 2 Hz): "
            f"{'YES' if h['hunting'] else 'no'}, largest {worst / 1e3:.1f} kN against a limit of "
            f"{h['limit_n'] / 1e3:.1f} kN"
        )
    elif result.get("hunting_note"):
        say(f"hunting (EN 14363): not assessed, {result['hunting_note']}")
    if result.get("largest_y_over_q") is not None:
        at, low = result["largest_y_over_q_at"], result["smallest_wheel_load_at"]
        exceeded = "EXCEEDS the limit " if result["y_over_q_exceeded"] else "limit "
        line = (
            f"wheel loads ({result['wheel_loads_from']}): largest Y/Q {result['largest_y_over_q']:.3f} over "
            f"{result['y_over_q_window_m']:g} m ({exceeded}{result['y_over_q_limit']:g}; peak "
            f"{result['largest_y_over_q_peak']:.3f}), wheelset {at['wheelset']} {at['wheel']} at "
            f"x = {at['x_m']:.4g} m"
        )
        if result["wheel_loads_from"] != "static share":
            line += (
                f"; smallest Q {result['smallest_wheel_load_n'] / 1e3:.1f} kN (wheelset {low['wheelset']} "
                f"{low['wheel']} at x = {low['x_m']:.4g} m)"
            )
        say(line)
    if result.get("ride"):
        _say_ride(say, result["ride"])
    for section in result.get("sections", []):
        _say_section(say, section)
    if "track" in result and (result.get("curves") or "sections" not in result):
        # rail_mj.analysis.en14363.curving_part: the fit to the curvature and uncompensated
        # acceleration under each wheelset that the motion figures are taken about.
        largest = max(w["max_abs_lateral_about_curving_m"] for w in result["wheelsets"])
        say(
            "on a curved track growth, frequency, wavelength, decay and EN 14363 are of the motion about the "
            f"curving offsets (at most {largest * 1e3:.3f} mm); max|y| and end|y| include the offsets; "
            "each curve's steady values follow"
        )
    for curve in result.get("curves", []):
        deficiency, a_nc = curve["cant_deficiency_mm"], curve["uncompensated_acceleration_m_per_s2"]
        say(
            f"curve (section {curve['section']}, R {curve['radius_m']:g} m, cant {curve['cant_m'] * 1e3:g} mm, "
            f"deficiency {deficiency:.0f} mm, {a_nc:.2f} m/s^2), x = {curve['from_m']:.0f} to {curve['to_m']:.0f} m:"
        )
        say("  wheelset  mean y (mm)  angle of attack (mrad)  Sigma Y (kN)  max Y/Q  Tgamma left/right (N)")
        for w in curve["wheelsets"]:
            attack = w["mean_angle_of_attack_rad"] * 1e3
            wear = "/".join(f"{v:.1f}" for v in w["mean_wear_number_n"])
            say(
                f"  {w['wheelset']:>8}  {w['mean_lateral_m'] * 1e3:>11.2f}  {attack:>22.2f}"
                f"  {w['mean_guiding_force_n'] / 1e3:>12.2f}  {_fmt(w['max_y_over_q'], '>7.3f')}  {wear:>21}"
            )
    if "csv" in result:
        say(f"samples: {result['csv']}")
    if "rrd" in result:
        rate = result.get("rrd_rate_per_s")
        at = f", {rate:.4g} samples/s" if rate else ""
        factor = result.get("rrd_exaggeration", 1.0)
        scale = f", 3D view lateral motion and yaw x{factor:g}" if factor != 1.0 else ""
        say(f"recording: {result['rrd']}{at}{scale}  (open it with: {_rerun()} {result['rrd']})")


def _say_ride(say, ride: dict) -> None:
    """EN 12299's and Sperling's indices at each floor point (rail_mj.analysis.ride)."""
    points = ride["points"]
    names = "/".join(p["point"] for p in points)
    where = "" if ride["floor_height_m"] is None else f", floor at {ride['floor_height_m']:g} m"

    def each(key: str, spec: str) -> str:
        return "/".join(_fmt(p[key], spec) for p in points)

    vertical = points[0]["wz_vertical"] is not None
    say(f"ride comfort (EN 12299, Sperling; at {names}{where}):")
    say(f"  N_MV {each('n_mv', '.2f')}")
    say(f"  Wz lateral {each('wz_lateral', '.2f')}" + (f", vertical {each('wz_vertical', '.2f')}" if vertical else ""))
    say(
        f"  floor acceleration rms lateral {each('rms_lateral_m_per_s2', '.3f')} m/s^2"
        + (f", vertical {each('rms_vertical_m_per_s2', '.3f')} m/s^2" if vertical else "")
    )


def _say_section(say, section: dict) -> None:
    """A section's on-track statistics (rail_mj.analysis.en14363.on_track): extremes as 99.85 %
    percentiles, the plain extremes beside them."""
    limit = section["sum_y_limit_n"]
    at = f", Sigma Y limit {limit / 1e3:.1f} kN" if limit is not None else ""
    say(
        f"section {section['section']} ({section['kind']}, {section['from_m']:.0f} to {section['to_m']:.0f} m{at}): "
        "p99.85 (max)"
    )
    say("  wheelset  |Sigma Y| 2 m (kN)  Y/Q 2 m        Q min (kN)     dQ/Q0 min")
    for w in section["wheelsets"]:
        wheels = [w["left"], w["right"]]
        quotients, loads, unloadings = ([v[key] for v in wheels] for key in ("y_over_q", "q_n", "unloading"))
        quotient = (_largest(quotients), _largest(quotients, "max"))
        q = (_smallest(loads), _smallest(loads, "min"))
        unloading = (_smallest(unloadings), _smallest(unloadings, "min"))
        sum_y = (_extent(w["sum_y_n"], "p0_15", "p99_85"), _extent(w["sum_y_n"], "min", "max"))
        say(
            f"  {w['wheelset']:>8}  {_kilo(sum_y[0], '8.1f')} ({_kilo(sum_y[1], '.1f')})"
            f"  {_fmt(quotient[0], '.3f')} ({_fmt(quotient[1], '.3f')})"
            f"  {_kilo(q[0], '.1f')} ({_kilo(q[1], '.1f')})  {_fmt(unloading[0], '.3f')} ({_fmt(unloading[1], '.3f')})"
        )
    for frame in section.get("frames", []):
        a = frame["lateral_acceleration_m_per_s2"]
        high, largest = _extent(a, "p0_15", "p99_85"), _extent(a, "min", "max")
        say(f"  {frame['body']} lateral acceleration p99.85 {_fmt(high, '.2f')} m/s^2 (max {_fmt(largest, '.2f')})")


def _extent(stats: dict, low: str, high: str) -> float | None:
    """The larger size of two of a statistics entry's values (None where there are none)."""
    return None if stats[low] is None else max(abs(stats[low]), abs(stats[high]))


def _largest(entries, key: str = "p99_85") -> float | None:
    return max((e[key] for e in entries if e and e[key] is not None), default=None)


def _smallest(entries, key: str = "p0_15") -> float | None:
    return min((e[key] for e in entries if e and e[key] is not None), default=None)


def _kilo(value: float | None, spec: str) -> str:
    return _fmt(None if value is None else value / 1e3, spec)
